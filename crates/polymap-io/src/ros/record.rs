//! Scans written as ROS recordings (for the simulator and for tests): `LaserScan` on one
//! topic and, for scans with odometry, `Odometry` stamped like the scan on another; with tf,
//! the laser's mounting on `/tf_static` and the odometry on `/tf`.

use std::path::Path;

use polymap::geometry::Pose2;
use polymap::scan::RangeScan;

use super::error::RosError;
use super::mcap_file::{McapCompression, McapWriter};
use super::messages::{LaserScanMsg, OdometryMsg, RosTime, TfMessage, TransformStampedMsg};
use super::ros1::{BagCompression, BagWriter};
use super::scan_tf::{BASE_LINK, ODOM_FRAME, TF_STATIC_TOPIC, TF_TOPIC};
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

/// What a recording written by [`write_mcap_with`] or [`write_bag_with`] holds besides the scans
/// on `/scan` (frame `laser`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RecordOptions {
    /// `/odom` (`nav_msgs/Odometry`, frames `odom` → `base_link`) for the scans with odometry,
    /// stamped like the scan.
    pub odometry_topic: bool,
    /// tf (`tf2_msgs/TFMessage`): on `/tf_static`, `base_link → laser`, the scans'
    /// `robot_from_laser` (before the first scan, and again before a scan whose mounting
    /// differs); on `/tf`, `odom → base_link`, the odometry of the scans with odometry, stamped
    /// like the scan. Without it a scan whose laser is off the robot's origin cannot be
    /// written.
    pub tf: bool,
}

impl RecordOptions {
    /// What [`write_mcap`] and [`write_bag`] write: `/odom`, and tf where a scan's laser is
    /// off the robot's origin (only tf can say so).
    pub fn for_scans(scans: &[RangeScan]) -> Self {
        RecordOptions {
            odometry_topic: true,
            tf: scans.iter().any(|s| s.robot_from_laser != Pose2::IDENTITY),
        }
    }
}

/// The topics of a recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stream {
    Scan,
    Odom,
    Tf,
    TfStatic,
}

/// Every message of a recording of `scans`, in order, serialized in `flavor`, handed to `emit`
/// with its topic and receive time (the scan's stamp).
fn each_message(
    scans: &[RangeScan],
    path: &Path,
    options: RecordOptions,
    flavor: Flavor,
    mut emit: impl FnMut(Stream, RosTime, &[u8]) -> Result<(), RosError>,
) -> Result<(), RosError> {
    let mut mount: Option<Pose2> = None;
    for (seq, scan) in scans.iter().enumerate() {
        let seq = seq as u32;
        if scan.robot_from_laser != Pose2::IDENTITY && !options.tf {
            return Err(RosError::Unsupported {
                path: path.to_path_buf(),
                what: "a laser mounted off the robot's origin needs tf, which was not asked for"
                    .into(),
            });
        }
        let time = RosTime::from_stamp(&scan.stamp).ok_or_else(|| RosError::Unsupported {
            path: path.to_path_buf(),
            what: format!("stamp {} does not fit a ROS time", scan.stamp.text),
        })?;
        let tf = |parent: &str, child: &str, pose: &Pose2| {
            let t = TransformStampedMsg::from_pose(time, parent, child, pose);
            TfMessage {
                transforms: vec![t],
            }
            .encode(flavor, seq)
        };
        if options.tf && mount != Some(scan.robot_from_laser) {
            let msg = tf(BASE_LINK, LASER_FRAME, &scan.robot_from_laser);
            emit(Stream::TfStatic, time, &msg)?;
            mount = Some(scan.robot_from_laser);
        }
        if let Some(pose) = &scan.odom_from_robot {
            if options.odometry_topic {
                let msg = OdometryMsg::from_pose(time, pose).encode(flavor, seq);
                emit(Stream::Odom, time, &msg)?;
            }
            if options.tf {
                emit(Stream::Tf, time, &tf(ODOM_FRAME, BASE_LINK, pose))?;
            }
        }
        let laser = LaserScanMsg::from_range_scan(scan, time, LASER_FRAME);
        emit(Stream::Scan, time, &laser.encode(flavor, seq))?;
    }
    Ok(())
}

/// Writes scans as a ROS 2 MCAP file: `/scan` (`sensor_msgs/msg/LaserScan`) and, for scans with
/// odometry, `/odom` (`nav_msgs/msg/Odometry`); tf where a scan's laser is off the robot's
/// origin ([`RecordOptions::for_scans`]); CDR little endian.
pub fn write_mcap(
    path: &Path,
    scans: &[RangeScan],
    compression: McapCompression,
) -> Result<(), RosError> {
    write_mcap_with(path, scans, compression, RecordOptions::for_scans(scans))
}

/// [`write_mcap`] with the topics of `options`.
pub fn write_mcap_with(
    path: &Path,
    scans: &[RangeScan],
    compression: McapCompression,
    options: RecordOptions,
) -> Result<(), RosError> {
    let mut w = McapWriter::create(path, compression)?;
    let odometry = scans.iter().any(|s| s.odom_from_robot.is_some());
    let scan_channel = w.add_channel(SCAN_TOPIC, "sensor_msgs/msg/LaserScan")?;
    let mut channel = |on: bool, topic: &str, type_name: &str| match on {
        true => w.add_channel(topic, type_name).map(Some),
        false => Ok(None),
    };
    let odom_channel = channel(
        options.odometry_topic && odometry,
        ODOM_TOPIC,
        "nav_msgs/msg/Odometry",
    )?;
    let tf_type = "tf2_msgs/msg/TFMessage";
    let static_channel = channel(options.tf, TF_STATIC_TOPIC, tf_type)?;
    let tf_channel = channel(options.tf && odometry, TF_TOPIC, tf_type)?;
    each_message(
        scans,
        path,
        options,
        Flavor::CdrLittle,
        |stream, time, data| {
            let channel = match stream {
                Stream::Scan => Some(scan_channel),
                Stream::Odom => odom_channel,
                Stream::Tf => tf_channel,
                Stream::TfStatic => static_channel,
            };
            match channel {
                Some(c) => w.write(c, time, data),
                None => Ok(()),
            }
        },
    )?;
    w.finish()
}

/// Writes scans as a ROS 1 bag: `/scan` (`sensor_msgs/LaserScan`) and, for scans with
/// odometry, `/odom` (`nav_msgs/Odometry`); tf where a scan's laser is off the robot's origin
/// ([`RecordOptions::for_scans`]).
pub fn write_bag(
    path: &Path,
    scans: &[RangeScan],
    compression: BagCompression,
) -> Result<(), RosError> {
    write_bag_with(path, scans, compression, RecordOptions::for_scans(scans))
}

/// [`write_bag`] with the topics of `options`.
pub fn write_bag_with(
    path: &Path,
    scans: &[RangeScan],
    compression: BagCompression,
    options: RecordOptions,
) -> Result<(), RosError> {
    let mut w = BagWriter::create(path, compression)?;
    let odometry = scans.iter().any(|s| s.odom_from_robot.is_some());
    let scan_conn = w.add_connection(SCAN_TOPIC, "sensor_msgs/LaserScan");
    let odom_conn = (options.odometry_topic && odometry)
        .then(|| w.add_connection(ODOM_TOPIC, "nav_msgs/Odometry"));
    let tf_type = "tf2_msgs/TFMessage";
    let static_conn = options
        .tf
        .then(|| w.add_connection(TF_STATIC_TOPIC, tf_type));
    let tf_conn = (options.tf && odometry).then(|| w.add_connection(TF_TOPIC, tf_type));
    each_message(scans, path, options, Flavor::Ros1, |stream, time, data| {
        let conn = match stream {
            Stream::Scan => Some(scan_conn),
            Stream::Odom => odom_conn,
            Stream::Tf => tf_conn,
            Stream::TfStatic => static_conn,
        };
        match conn {
            Some(c) => w.write(c, time, data),
            None => Ok(()),
        }
    })?;
    w.finish()
}
