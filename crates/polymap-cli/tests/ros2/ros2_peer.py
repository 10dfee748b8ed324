#!/usr/bin/env python3
"""A ROS 2 peer for testing `polymap ros2` without ROS: plays a recording's LaserScans (and
odometry) into the node over Eclipse Cyclone DDS and records everything the node publishes.

    ros2_peer.py --recording FILE --out RESULT.json [--rate R] [--pause-after N --pause-s S]
                 [--wrong-type N] [--scan-topic /scan] [--odom-topic /odom] [--max-scans N]
    ros2_peer.py --listen-s S --out RESULT.json     (listen only)

The domain comes from ROS_DOMAIN_ID, the network configuration from CYCLONEDDS_URI (the tests
give one that keeps every packet on the loopback interface). RESULT.json holds what was sent,
what arrived per topic (counts, frames, the last pose, the grid's size, the last status) and
the node's publications as discovery saw them (topic, type and QoS).
"""

import argparse
import json
import math
import os
import sys
import threading
import time
from pathlib import Path

sys.dont_write_bytecode = True
sys.path.insert(0, str(Path(__file__).resolve().parent))

from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsPublication  # noqa: E402
from cyclonedds.core import Policy, Qos  # noqa: E402
from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.pub import DataWriter  # noqa: E402
from cyclonedds.sub import DataReader  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402
from cyclonedds.util import duration  # noqa: E402

import ros2_msgs as m  # noqa: E402

SENSOR = Qos(Policy.Reliability.BestEffort, Policy.Durability.Volatile, Policy.History.KeepLast(10))
RELIABLE = Qos(
    Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
    Policy.Durability.Volatile,
    Policy.History.KeepAll,
)
LATCHED = Qos(
    Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
    Policy.Durability.TransientLocal,
    Policy.History.KeepLast(1),
)


def yaw(q):
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


class Listener:
    """Takes whatever arrives on the node's outputs, on a thread."""

    def __init__(self, dp):
        self.readers = {
            "pose": DataReader(dp, Topic(dp, "rt/pose", m.PoseWithCovarianceStamped), qos=RELIABLE),
            "tf": DataReader(dp, Topic(dp, "rt/tf", m.TFMessage), qos=RELIABLE),
            "map": DataReader(dp, Topic(dp, "rt/map", m.OccupancyGrid), qos=LATCHED),
            "segments": DataReader(dp, Topic(dp, "rt/polymap/segments", m.MarkerArray), qos=LATCHED),
            "status": DataReader(dp, Topic(dp, "rt/polymap/status", m.DiagnosticArray), qos=RELIABLE),
        }
        self.publications = BuiltinDataReader(dp, BuiltinTopicDcpsPublication)
        self.lock = threading.Lock()
        self.counts = {k: 0 for k in self.readers}
        self.poses = []
        self.tf_edges = {}
        self.grid = None
        self.markers = None
        self.status = None
        self.pubs = {}
        self.stop = False
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def run(self):
        while not self.stop:
            self.take()
            time.sleep(0.005)

    def take(self):
        with self.lock:
            for name, r in self.readers.items():
                for s in r.take(N=100):
                    self.counts[name] += 1
                    self.keep(name, s)
            for p in self.publications.take(N=100):
                name = p.topic_name or ""
                if name.startswith("rt/") and name not in ("rt/scan", "rt/odom"):
                    q = p.qos
                    self.pubs[name] = {
                        "type": p.type_name,
                        "reliability": type(q[Policy.Reliability]).__name__,
                        "durability": type(q[Policy.Durability]).__name__,
                    }

    def keep(self, name, s):
        if name == "pose":
            p = s.pose.pose
            st = s.header.stamp
            self.poses.append(
                {
                    "stamp": st.sec + st.nanosec * 1e-9,
                    "frame": s.header.frame_id,
                    "x": p.position.x,
                    "y": p.position.y,
                    "yaw": yaw(p.orientation),
                    "cov_xx": s.pose.covariance[0],
                    "cov_yaw": s.pose.covariance[35],
                }
            )
        elif name == "tf":
            for t in s.transforms:
                self.tf_edges[f"{t.header.frame_id}->{t.child_frame_id}"] = True
        elif name == "map":
            i = s.info
            known = sum(1 for v in s.data if v >= 0)
            self.grid = {
                "frame": s.header.frame_id,
                "width": i.width,
                "height": i.height,
                "resolution": i.resolution,
                "cells": len(s.data),
                "occupied": sum(1 for v in s.data if v == 100),
                "known": known,
            }
        elif name == "segments":
            strips = [k for k in s.markers if k.type == 4]
            self.markers = {
                "markers": len(s.markers),
                "line_strips": len(strips),
                "points": sum(len(k.points) for k in strips),
                "frame": s.markers[0].header.frame_id if s.markers else "",
                "first_action": s.markers[0].action if s.markers else None,
            }
        elif name == "status":
            st = s.status[0]
            self.status = {
                "level": st.level,
                "name": st.name,
                "message": st.message,
                "values": {kv.key: kv.value for kv in st.values},
            }

    def result(self):
        with self.lock:
            return {
                "counts": dict(self.counts),
                "poses": list(self.poses),
                "tf_edges": sorted(self.tf_edges),
                "grid": self.grid,
                "markers": self.markers,
                "status": self.status,
                "publications": dict(self.pubs),
            }


def wait_matched(writer, timeout_s):
    """Waits until the node's reader matched `writer` (discovery done)."""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if len(writer.get_matched_subscriptions()) > 0:
            return True
        time.sleep(0.01)
    return False


def tf_of(msg):
    """A rosbags TFMessage as ours."""
    out = []
    for t in msg.transforms:
        st = t.header.stamp
        tr, r = t.transform.translation, t.transform.rotation
        out.append(
            m.TransformStamped(
                m.Header(m.Time(st.sec, st.nanosec), t.header.frame_id),
                t.child_frame_id,
                m.Transform(m.Vector3(tr.x, tr.y, tr.z), m.Quaternion(r.x, r.y, r.z, r.w)),
            )
        )
    return m.TFMessage(out)


def scans_of(recording, scan_topic, odom_topic, max_scans):
    """(stamp_s, kind, message) in file order: kind is scan, odom, tf or tf_static."""
    from rosbags.highlevel import AnyReader

    out = []
    with AnyReader([Path(recording)]) as r:
        topics = (scan_topic, odom_topic, "/tf", "/tf_static")
        conns = [c for c in r.connections if c.topic in topics]
        scans = 0
        last = None
        for c, _, raw in r.messages(connections=conns):
            msg = r.deserialize(raw, c.msgtype)
            if c.topic in ("/tf", "/tf_static"):
                kind = c.topic[1:]
                out.append((last if last is not None else -math.inf, kind, tf_of(msg)))
                continue
            st = msg.header.stamp
            header = m.Header(m.Time(st.sec, st.nanosec), msg.header.frame_id)
            t = st.sec + st.nanosec * 1e-9
            last = t
            if c.topic == scan_topic:
                if max_scans is not None and scans >= max_scans:
                    break
                scans += 1
                out.append(
                    (
                        t,
                        "scan",
                        m.LaserScan(
                            header,
                            float(msg.angle_min),
                            float(msg.angle_max),
                            float(msg.angle_increment),
                            float(msg.time_increment),
                            float(msg.scan_time),
                            float(msg.range_min),
                            float(msg.range_max),
                            [float(v) for v in msg.ranges],
                            [float(v) for v in msg.intensities],
                        ),
                    )
                )
            else:
                p = msg.pose.pose
                out.append(
                    (
                        t,
                        "odom",
                        m.Odometry(
                            header,
                            msg.child_frame_id,
                            m.PoseWithCovariance(
                                m.Pose(
                                    m.Point(p.position.x, p.position.y, p.position.z),
                                    m.Quaternion(
                                        p.orientation.x,
                                        p.orientation.y,
                                        p.orientation.z,
                                        p.orientation.w,
                                    ),
                                ),
                                [float(v) for v in msg.pose.covariance],
                            ),
                        ),
                    )
                )
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--recording")
    ap.add_argument("--out", required=True)
    ap.add_argument("--rate", type=float, default=1.0, help="times real time")
    ap.add_argument("--scan-hz", type=float, help="instead of --rate: scans evenly at this rate")
    ap.add_argument("--scan-topic", default="/scan")
    ap.add_argument("--odom-topic", default="/odom")
    ap.add_argument("--no-odometry", action="store_true", help="do not play the odometry topic")
    ap.add_argument("--no-tf", action="store_true", help="do not play /tf and /tf_static")
    ap.add_argument("--max-scans", type=int)
    ap.add_argument("--pause-after", type=int, help="stop publishing after N scans...")
    ap.add_argument("--pause-s", type=float, default=0.0, help="...for S seconds, new writer")
    ap.add_argument("--wrong-type", type=int, default=0, help="also publish N std_msgs/String on the scan topic")
    ap.add_argument("--listen-s", type=float, help="only listen this long")
    ap.add_argument("--wait-node-s", type=float, default=30.0)
    ap.add_argument("--settle-s", type=float, default=10.0)
    a = ap.parse_args()

    dp = DomainParticipant(int(os.environ.get("ROS_DOMAIN_ID", "0")))
    listener = Listener(dp)
    result = {"sent_scans": 0, "matched": False}
    if a.listen_s is not None:
        time.sleep(a.listen_s)
    else:
        stream = scans_of(a.recording, a.scan_topic, a.odom_topic, a.max_scans)
        scan_topic = Topic(dp, "rt" + a.scan_topic, m.LaserScan)
        odom_topic = Topic(dp, "rt" + a.odom_topic, m.Odometry)
        scans = DataWriter(dp, scan_topic, qos=SENSOR)
        odom = DataWriter(dp, odom_topic, qos=SENSOR)
        tf = DataWriter(dp, Topic(dp, "rt/tf", m.TFMessage), qos=RELIABLE)
        tf_static = DataWriter(
            dp,
            Topic(dp, "rt/tf_static", m.TFMessage),
            qos=Qos(
                Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
                Policy.Durability.TransientLocal,
                Policy.History.KeepLast(100),
            ),
        )
        result["matched"] = wait_matched(scans, a.wait_node_s)
        # ...and the node's pose and tf writers joined to our readers, so none is missed.
        end = time.monotonic() + a.wait_node_s
        while time.monotonic() < end and not all(
            len(listener.readers[k].get_matched_publications()) > 0 for k in ("pose", "tf")
        ):
            time.sleep(0.01)
        # Matched on our side is not yet matched on the node's: give discovery a moment, so
        # the first best-effort scans are not sent before the node listens.
        time.sleep(0.5)
        wrong = None
        if a.wrong_type:
            # Another participant publishes std_msgs/String on the scan topic's very name.
            other = DomainParticipant(int(os.environ.get("ROS_DOMAIN_ID", "0")))
            wrong = DataWriter(other, Topic(other, "rt" + a.scan_topic, m.String), qos=SENSOR)
        start_wall = time.monotonic()
        stamps = [t for t, _, _ in stream if t != -math.inf]
        start_stamp = stamps[0] if stamps else 0.0
        sent = 0
        for t, kind, msg in stream:
            if a.scan_hz:
                due = start_wall + sent / a.scan_hz
            else:
                due = start_wall + (max(t, start_stamp) - start_stamp) / a.rate
            delay = due - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            if kind == "scan":
                if a.pause_after is not None and sent == a.pause_after:
                    # The publisher goes away and a new one comes back later.
                    del scans
                    time.sleep(a.pause_s)
                    scans = DataWriter(dp, scan_topic, qos=SENSOR)
                    wait_matched(scans, a.wait_node_s)
                    start_wall += a.pause_s
                scans.write(msg)
                sent += 1
                if wrong is not None and sent <= a.wrong_type:
                    wrong.write(m.String("not a scan"))
            elif kind == "odom":
                if not a.no_odometry:
                    odom.write(msg)
            elif not a.no_tf:
                (tf_static if kind == "tf_static" else tf).write(msg)
        result["sent_scans"] = sent
        end = time.monotonic() + a.settle_s
        while time.monotonic() < end:
            with listener.lock:
                if listener.counts["pose"] >= sent:
                    break
            time.sleep(0.05)
        time.sleep(0.5)
    listener.take()
    result.update(listener.result())
    listener.stop = True
    tmp = a.out + ".tmp"
    with open(tmp, "w") as f:
        json.dump(result, f)
    os.replace(tmp, a.out)


if __name__ == "__main__":
    main()
