//! Scans written as ROS recordings (for the simulator and for tests): `LaserScan` on one
//! topic and, for scans with odometry, `Odometry` stamped like the scan on another.

use std::path::Path;

use polymap::geometry::Pose2;
use polymap::scan::RangeScan;

use super::error::RosError;
use super::mcap_file::{McapCompression, McapWriter};
use super::messages::{LaserScanMsg, OdometryMsg, RosTime};
use super::ros1::{BagCompression, BagWriter};
use super::wire::Flavor;

/// Topic of the laser scans written.
pub const SCAN_TOPIC: &str = "/scan";
/// Topic of the odometry written.
pub const ODOM_TOPIC: &str = "/odom";
/// `header.frame_id` of the scans written.
pub const LASER_FRAME: &str = "laser";

/// The scan as a ROS `LaserScan` carries it: readings, first bearing, step and maximum range
/// rounded to `float32` (no-returns and readings at or beyond the maximum kept as they are).
/// Writing such a scan to any format and reading it back gives the same values, so the
/// simulator uses it to write one world identically as CARMEN, MCAP and bag.
///
/// ```
/// use polymap::scan::{RangeScan, Stamp};
/// use polymap::geometry::Pose2;
/// use polymap_io::ros::float32_scan;
/// let scan = RangeScan {
///     stamp: Stamp::from_seconds(1.0), ranges_m: vec![1.1, 30.0], angle_min_rad: -1.0,
///     angle_increment_rad: 0.1, max_range_m: 30.0, robot_from_laser: Pose2::IDENTITY,
///     odom_from_robot: None,
/// };
/// let s = float32_scan(&scan);
/// assert_eq!(s.ranges_m, vec![f64::from(1.1f32), 30.0]);
/// assert_eq!(s.angle_increment_rad, f64::from(0.1f32));
/// ```
pub fn float32_scan(scan: &RangeScan) -> RangeScan {
    let narrow = |v: f64| f64::from(v as f32);
    let max_range_m = narrow(scan.max_range_m);
    RangeScan {
        ranges_m: scan
            .ranges_m
            .iter()
            .map(|&r| {
                let n = narrow(r);
                if scan.is_valid_range(r) && n < max_range_m {
                    n
                } else {
                    max_range_m
                }
            })
            .collect(),
        angle_min_rad: narrow(scan.angle_min_rad),
        angle_increment_rad: narrow(scan.angle_increment_rad),
        max_range_m,
        ..scan.clone()
    }
}

/// One scan (and its odometry) as messages: time, `LaserScan`, optional `Odometry`.
fn messages(
    scan: &RangeScan,
    path: &Path,
) -> Result<(RosTime, LaserScanMsg, Option<OdometryMsg>), RosError> {
    if scan.robot_from_laser != Pose2::IDENTITY {
        return Err(RosError::Unsupported {
            path: path.to_path_buf(),
            what: "a laser mounted off the robot's origin needs tf, which polymap does not write"
                .into(),
        });
    }
    let time = RosTime::from_stamp(&scan.stamp).ok_or_else(|| RosError::Unsupported {
        path: path.to_path_buf(),
        what: format!("stamp {} does not fit a ROS time", scan.stamp.text),
    })?;
    let laser = LaserScanMsg::from_range_scan(scan, time, LASER_FRAME);
    let odom = scan
        .odom_from_robot
        .map(|p| OdometryMsg::from_pose(time, &p));
    Ok((time, laser, odom))
}

/// Writes scans as a ROS 2 MCAP file: `/scan` (`sensor_msgs/msg/LaserScan`) and, for scans with
/// odometry, `/odom` (`nav_msgs/msg/Odometry`); CDR little endian.
pub fn write_mcap(
    path: &Path,
    scans: &[RangeScan],
    compression: McapCompression,
) -> Result<(), RosError> {
    let mut w = McapWriter::create(path, compression)?;
    let scan_channel = w.add_channel(SCAN_TOPIC, "sensor_msgs/msg/LaserScan")?;
    let odom_channel = match scans.iter().any(|s| s.odom_from_robot.is_some()) {
        true => Some(w.add_channel(ODOM_TOPIC, "nav_msgs/msg/Odometry")?),
        false => None,
    };
    for scan in scans {
        let (time, laser, odom) = messages(scan, path)?;
        if let (Some(odom), Some(channel)) = (odom, odom_channel) {
            w.write(channel, time, &odom.encode(Flavor::CdrLittle, 0))?;
        }
        w.write(scan_channel, time, &laser.encode(Flavor::CdrLittle, 0))?;
    }
    w.finish()
}

/// Writes scans as a ROS 1 bag: `/scan` (`sensor_msgs/LaserScan`) and, for scans with
/// odometry, `/odom` (`nav_msgs/Odometry`).
pub fn write_bag(
    path: &Path,
    scans: &[RangeScan],
    compression: BagCompression,
) -> Result<(), RosError> {
    let mut w = BagWriter::create(path, compression)?;
    let scan_conn = w.add_connection(SCAN_TOPIC, "sensor_msgs/LaserScan");
    let odom_conn = scans
        .iter()
        .any(|s| s.odom_from_robot.is_some())
        .then(|| w.add_connection(ODOM_TOPIC, "nav_msgs/Odometry"));
    for (seq, scan) in scans.iter().enumerate() {
        let (time, laser, odom) = messages(scan, path)?;
        let seq = seq as u32;
        if let (Some(odom), Some(conn)) = (odom, odom_conn) {
            w.write(conn, time, &odom.encode(Flavor::Ros1, seq))?;
        }
        w.write(scan_conn, time, &laser.encode(Flavor::Ros1, seq))?;
    }
    w.finish()
}
