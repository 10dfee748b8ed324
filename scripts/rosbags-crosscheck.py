#!/usr/bin/env python3
"""Cross-checks polymap's ROS readers and writers with an independent implementation, the
Python `rosbags` package (installed by .ci/run; used by crates/polymap-io/tests/it/ros_rosbags.rs).

    rosbags-crosscheck.py write DIR   writes the same laser, odometry and tf messages as
                                      DIR/rb_bz2.bag, DIR/rb_lz4.bag (ROS 1), DIR/rb_mcap/ and
                                      DIR/rb_sqlite/ (rosbag2 folders); one MCAP scan is CDR big
                                      endian.
    rosbags-crosscheck.py read PATH   prints every sensor_msgs LaserScan of a bag or rosbag2
                                      folder, one line each: topic sec nanosec, then the float32
                                      bits (hex) of angle_min angle_increment range_min range_max,
                                      then the ranges' bits, comma-separated; then every
                                      transform of tf2_msgs TFMessages, one line each: `tf` topic
                                      sec nanosec parent child, then the float64 bits (hex) of
                                      the translation x y z and the rotation x y z w.

The messages written (the Rust test holds the same numbers):
  /scan, frame `laser`, 3 scans k = 0, 1, 2 at header stamps 1700000000 + k s plus
  250000000, 123456789 and 0 ns; angle_min 1.5, angle_increment -0.25 (clockwise), 8 beams,
  range_min 0.1, range_max 8.0, ranges [1 + k, nan, inf, 0.05, 9.0, 2.5, -inf, 8.0];
  scan 1 has 8 intensities. Receive time = header stamp.
  /odom, frames odom -> base_link, at 1700000000 s and 1700000003 s: x, y, yaw = (0, 0, 0) and
  (3, 6, 0.9).
  /tf_static (tf2_msgs/TFMessage), at 1700000000 s: /base_link -> laser at x, y, yaw =
  (0.2, 0.1, 0.3), with a leading slash on the parent; receive time 0.5 s after the first scan.
  /tf: the odometry again as odom -> base_link, each 0.2 s after its stamp.
"""

import math
import struct
import sys
from pathlib import Path

import numpy as np
from rosbags.highlevel import AnyReader
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

TF_MESSAGE = "tf2_msgs/msg/TFMessage"


def typestore(store):
    """A typestore that knows tf2_msgs/TFMessage (the ROS 1 store lacks it)."""
    ts = get_typestore(store)
    if TF_MESSAGE not in ts.types:
        ts.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", TF_MESSAGE))
    return ts

SCAN_NS = [250_000_000, 123_456_789, 0]
T0 = 1_700_000_000
ODOMETRY = [(T0, (0.0, 0.0, 0.0)), (T0 + 3, (3.0, 6.0, 0.9))]


def make_header(ts, seq, sec, nanosec, frame_id):
    """A std_msgs Header; ROS 1's has a sequence number."""
    Header = ts.types["std_msgs/msg/Header"]
    stamp = ts.types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec)
    if "seq" in Header.__dataclass_fields__:
        return Header(seq=seq, stamp=stamp, frame_id=frame_id)
    return Header(stamp=stamp, frame_id=frame_id)


def scans(ts):
    LaserScan = ts.types["sensor_msgs/msg/LaserScan"]
    out = []
    for k, ns in enumerate(SCAN_NS):
        ranges = np.array(
            [1.0 + k, math.nan, math.inf, 0.05, 9.0, 2.5, -math.inf, 8.0], dtype=np.float32
        )
        intensities = np.arange(8, dtype=np.float32) if k == 1 else np.array([], dtype=np.float32)
        header = make_header(ts, k, T0 + k, ns, "laser")
        msg = LaserScan(
            header=header,
            angle_min=1.5,
            angle_max=1.5 - 0.25 * 7,
            angle_increment=-0.25,
            time_increment=0.0,
            scan_time=0.1,
            range_min=0.1,
            range_max=8.0,
            ranges=ranges,
            intensities=intensities,
        )
        out.append(((T0 + k) * 10**9 + ns, msg))
    return out


def odometry(ts):
    t = ts.types
    out = []
    for sec, (x, y, yaw) in ODOMETRY:
        header = make_header(ts, 0, sec, 0, "odom")
        pose = t["geometry_msgs/msg/Pose"](
            position=t["geometry_msgs/msg/Point"](x=x, y=y, z=0.0),
            orientation=t["geometry_msgs/msg/Quaternion"](
                x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2)
            ),
        )
        zero3 = t["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
        msg = t["nav_msgs/msg/Odometry"](
            header=header,
            child_frame_id="base_link",
            pose=t["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
            twist=t["geometry_msgs/msg/TwistWithCovariance"](
                twist=t["geometry_msgs/msg/Twist"](linear=zero3, angular=zero3),
                covariance=np.zeros(36),
            ),
        )
        out.append((sec * 10**9, msg))
    return out


def transform(ts, sec, parent, child, x, y, yaw):
    t = ts.types
    return t["geometry_msgs/msg/TransformStamped"](
        header=make_header(ts, 0, sec, 0, parent),
        child_frame_id=child,
        transform=t["geometry_msgs/msg/Transform"](
            translation=t["geometry_msgs/msg/Vector3"](x=x, y=y, z=0.0),
            rotation=t["geometry_msgs/msg/Quaternion"](
                x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2)
            ),
        ),
    )


def tf(ts):
    """(receive time, topic, message): the static mounting, then odom -> base_link."""
    msg = ts.types[TF_MESSAGE]
    mount = msg(transforms=[transform(ts, T0, "/base_link", "laser", 0.2, 0.1, 0.3)])
    out = [(T0 * 10**9 + 750_000_000, "/tf_static", mount)]
    for sec, (x, y, yaw) in ODOMETRY:
        odom = msg(transforms=[transform(ts, sec, "odom", "base_link", x, y, yaw)])
        out.append((sec * 10**9 + 200_000_000, "/tf", odom))
    return out


def write(root):
    root = Path(root)
    ts1 = typestore(Stores.ROS1_NOETIC)
    for name, fmt in [("rb_bz2.bag", Writer1.CompressionFormat.BZ2), ("rb_lz4.bag", Writer1.CompressionFormat.LZ4)]:
        w = Writer1(root / name)
        w.set_compression(fmt)
        with w:
            scan = w.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=ts1)
            odom = w.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=ts1)
            tfs = {
                topic: w.add_connection(topic, TF_MESSAGE, typestore=ts1)
                for topic in ("/tf_static", "/tf")
            }
            messages = [(t, odom, m, "nav_msgs/msg/Odometry") for t, m in odometry(ts1)]
            messages += [(t, scan, m, "sensor_msgs/msg/LaserScan") for t, m in scans(ts1)]
            messages += [(t, tfs[topic], m, TF_MESSAGE) for t, topic, m in tf(ts1)]
            for t, conn, m, typ in sorted(messages, key=lambda e: e[0]):
                w.write(conn, t, ts1.serialize_ros1(m, typ))
    ts2 = typestore(Stores.ROS2_HUMBLE)
    for name, plugin in [("rb_mcap", StoragePlugin.MCAP), ("rb_sqlite", StoragePlugin.SQLITE3)]:
        with Writer2(root / name, version=9, storage_plugin=plugin) as w:
            scan = w.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=ts2)
            odom = w.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=ts2)
            tfs = {
                topic: w.add_connection(topic, TF_MESSAGE, typestore=ts2)
                for topic in ("/tf_static", "/tf")
            }
            messages = [(t, odom, m, "nav_msgs/msg/Odometry", True) for t, m in odometry(ts2)]
            messages += [(t, tfs[topic], m, TF_MESSAGE, True) for t, topic, m in tf(ts2)]
            messages += [
                (t, scan, m, "sensor_msgs/msg/LaserScan", not (plugin == StoragePlugin.MCAP and k == 1))
                for k, (t, m) in enumerate(scans(ts2))
            ]
            for t, conn, m, typ, little in sorted(messages, key=lambda e: e[0]):
                w.write(conn, t, ts2.serialize_cdr(m, typ, little_endian=little))


def bits(v):
    return struct.unpack("<I", struct.pack("<f", v))[0]


def bits64(v):
    return struct.unpack("<Q", struct.pack("<d", v))[0]


def read(path):
    tf_lines = []
    with AnyReader([Path(path)], default_typestore=typestore(Stores.ROS2_HUMBLE)) as reader:
        for conn, _, raw in reader.messages():
            if conn.msgtype.endswith("TFMessage"):
                for t in reader.deserialize(raw, conn.msgtype).transforms:
                    v, q = t.transform.translation, t.transform.rotation
                    values = " ".join(f"{bits64(x):016x}" for x in (v.x, v.y, v.z, q.x, q.y, q.z, q.w))
                    stamp = t.header.stamp
                    tf_lines.append(
                        f"tf {conn.topic} {stamp.sec} {stamp.nanosec} {t.header.frame_id} "
                        f"{t.child_frame_id} {values}"
                    )
                continue
            if not conn.msgtype.endswith("LaserScan") or "MultiEcho" in conn.msgtype:
                continue
            m = reader.deserialize(raw, conn.msgtype)
            head = [f"{bits(v):08x}" for v in (m.angle_min, m.angle_increment, m.range_min, m.range_max)]
            ranges = ",".join(f"{bits(r):08x}" for r in m.ranges)
            print(conn.topic, m.header.stamp.sec, m.header.stamp.nanosec, *head, ranges)
    for line in tf_lines:
        print(line)


if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] not in ("write", "read"):
        sys.exit(__doc__)
    {"write": write, "read": read}[sys.argv[1]](sys.argv[2])
