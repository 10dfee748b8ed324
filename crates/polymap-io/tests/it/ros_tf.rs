//! tf in ROS recordings: the laser's mounting from `/tf_static`, odometry from `/tf`, tf
//! recorded after the scans it places, frames tf does not have, and damaged tf messages.

use std::path::Path;

use polymap::geometry::Pose2;
use polymap::scan::RangeScan;
use polymap_io::log::{LogOptions, LogSource, LogStats};
use polymap_io::ros::mcap_file::McapCompression;
use polymap_io::ros::ros1::{BagCompression, BagWriter};
use polymap_io::ros::{
    Flavor, LaserScanMsg, RecordOptions, RosTime, TfMessage, TfOdometry, TransformStampedMsg,
    write_bag_with, write_mcap_with,
};

use crate::ros_written::scans;

fn read_log(path: &Path, options: &LogOptions) -> (Vec<RangeScan>, LogStats, Vec<String>) {
    let mut log = LogSource::open(path, options).unwrap();
    let mut out = Vec::new();
    while let Some(s) = log.next_scan().unwrap() {
        out.push(s);
    }
    (out, log.stats(), log.carmen_stats().other_warnings)
}

fn close(a: Pose2, b: Pose2) -> bool {
    (a.x_m - b.x_m).abs() < 1e-9
        && (a.y_m - b.y_m).abs() < 1e-9
        && Pose2::new(0.0, 0.0, a.theta_rad - b.theta_rad)
            .theta_rad
            .abs()
            < 1e-9
}

fn mounted(mount: Pose2, n: usize) -> Vec<RangeScan> {
    let mut written = scans(n);
    for s in &mut written {
        s.robot_from_laser = mount;
    }
    written
}

/// A laser mounted 0.25 m ahead, 0.1 m right and turned 0.2 rad, written as MCAP and bag with
/// tf: every scan reads back with that mounting, placed in `base_link`.
#[test]
fn the_mounting_reads_back_from_tf_static_in_both_formats() {
    let dir = tempfile::tempdir().unwrap();
    let mount = Pose2::new(0.25, -0.1, 0.2);
    let written = mounted(mount, 120);
    let options = RecordOptions {
        odometry_topic: true,
        tf: true,
    };
    let mcap = dir.path().join("m.mcap");
    write_mcap_with(&mcap, &written, McapCompression::Zstd, options).unwrap();
    let bag = dir.path().join("m.bag");
    write_bag_with(&bag, &written, BagCompression::Bz2, options).unwrap();
    for path in [mcap, bag] {
        let (read, stats, warnings) = read_log(&path, &LogOptions::default());
        assert_eq!(read.len(), written.len());
        for (r, w) in read.iter().zip(&written) {
            assert!(close(r.robot_from_laser, mount), "{:?}", r.robot_from_laser);
            assert_eq!(r.stamp, w.stamp);
            assert_eq!(r.ranges_m.len(), w.ranges_m.len());
        }
        let tf = stats.tf.expect("tf");
        assert_eq!(tf.base_frame.as_deref(), Some("base_link"));
        assert_eq!((tf.static_messages, tf.messages), (1, 120));
        assert_eq!(tf.scans_mounted, 120);
        // The odometry topic witnesses the steps; tf's odom → base_link is not needed.
        assert_eq!(tf.odometry, None);
        assert!(warnings.is_empty(), "{warnings:?}");
    }
}

/// Without an odometry topic, `odom → base_link` on /tf is the odometry: as the prior
/// (`odometry`, with no topic to find) and as the witness.
#[test]
fn odometry_comes_from_tf_without_an_odometry_topic() {
    let dir = tempfile::tempdir().unwrap();
    let written = mounted(Pose2::new(0.3, 0.0, 0.0), 90);
    let path = dir.path().join("tf-odom.bag");
    let options = RecordOptions {
        odometry_topic: false,
        tf: true,
    };
    write_bag_with(&path, &written, BagCompression::Lz4, options).unwrap();
    for (odometry, use_) in [(true, TfOdometry::Prior), (false, TfOdometry::Witness)] {
        let options = LogOptions {
            odometry,
            witness_odometry: !odometry,
            ..LogOptions::default()
        };
        let (read, stats, warnings) = read_log(&path, &options);
        for (r, w) in read.iter().zip(&written) {
            let (p, q) = (r.odom_from_robot.unwrap(), w.odom_from_robot.unwrap());
            assert!(close(p, q), "{p:?} {q:?}");
        }
        let tf = stats.tf.unwrap();
        assert_eq!(tf.odometry, Some(use_));
        assert_eq!((tf.scans_with_odometry, tf.scans_without_odometry), (90, 0));
        assert!(warnings.is_empty(), "{warnings:?}");
    }
}

fn transform(ns: i128, parent: &str, child: &str, pose: Pose2) -> TfMessage {
    TfMessage {
        transforms: vec![TransformStampedMsg::from_pose(
            time(ns),
            parent,
            child,
            &pose,
        )],
    }
}

fn time(ns: i128) -> RosTime {
    RosTime {
        sec: (ns / 1_000_000_000) as i64,
        nanosec: (ns % 1_000_000_000) as u32,
    }
}

/// A bag as recorders leave them: tf published (and recorded) after the scans it places. The
/// scans of frame `scan_frame` at 10 Hz from 100 s, the robot moving 1 m/s along x; odom →
/// base_link at 20 Hz, received 0.3 s after its stamp; the mounting on /tf_static received
/// 1.5 s after the first scan. Frames are written with a leading `/`, as ROS 1 did.
fn late_tf_bag(path: &Path, scan_frame: &str, extra_tf: &[(u64, Vec<u8>)]) {
    let mut w = BagWriter::create(path, BagCompression::None).unwrap();
    let scan = w.add_connection("/scan", "sensor_msgs/LaserScan");
    let tf = w.add_connection("/tf", "tf2_msgs/TFMessage");
    let tf_static = w.add_connection("/tf_static", "tf/tfMessage");
    let start: i128 = 100_000_000_000;
    let mut messages: Vec<(i128, u32, Vec<u8>)> = Vec::new();
    let template = &scans(1)[0];
    for k in 0..50i128 {
        let t = start + k * 100_000_000;
        let msg = LaserScanMsg::from_range_scan(template, time(t), scan_frame);
        messages.push((t, scan, msg.encode(Flavor::Ros1, k as u32)));
    }
    for k in 0..110i128 {
        let t = start + k * 50_000_000;
        let odom = Pose2::new(k as f64 * 0.05, 0.0, 0.0);
        let msg = transform(t, "/odom", "/base_link", odom);
        messages.push((t + 300_000_000, tf, msg.encode(Flavor::Ros1, 0)));
    }
    let mount = transform(start, "/base_link", "/laser", Pose2::new(0.25, 0.0, 0.1));
    messages.push((
        start + 1_500_000_000,
        tf_static,
        mount.encode(Flavor::Ros1, 0),
    ));
    for (k, data) in extra_tf {
        messages.push((start + *k as i128 * 100_000_000 + 1, tf, data.clone()));
    }
    messages.sort_by_key(|m| m.0);
    for (t, conn, data) in messages {
        w.write(conn, time(t), &data).unwrap();
    }
    w.finish().unwrap();
}

#[test]
fn tf_recorded_after_the_scans_places_them() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("late.bag");
    late_tf_bag(&path, "/laser", &[]);
    let options = LogOptions {
        odometry: true,
        ..LogOptions::default()
    };
    let (read, stats, warnings) = read_log(&path, &options);
    assert_eq!(read.len(), 50);
    for (k, s) in read.iter().enumerate() {
        assert!(close(s.robot_from_laser, Pose2::new(0.25, 0.0, 0.1)), "{k}");
        let odom = s.odom_from_robot.expect("odometry from tf");
        assert!((odom.x_m - 0.1 * k as f64).abs() < 1e-9, "{k}: {odom:?}");
    }
    let tf = stats.tf.unwrap();
    assert_eq!(tf.odometry, Some(TfOdometry::Prior));
    assert_eq!((tf.scans_mounted, tf.scans_with_odometry), (50, 50));
    assert!(warnings.is_empty(), "{warnings:?}");
}

/// Scans of a frame tf does not know are taken as at the robot's origin, with one warning
/// naming the frame and counting them; so are all scans when `base_frame` names a frame tf
/// does not have.
#[test]
fn a_frame_without_tf_is_warned_once_and_taken_as_the_robot() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sonar.bag");
    late_tf_bag(&path, "sonar", &[]);
    let (read, stats, warnings) = read_log(&path, &LogOptions::default());
    assert!(read.iter().all(|s| s.robot_from_laser == Pose2::IDENTITY));
    let miss = &stats.tf.unwrap().scans_without_mount["sonar"];
    assert_eq!(miss.scans, 50);
    assert!(
        miss.first_problem.contains("frame \"sonar\" is not in tf"),
        "{miss:?}"
    );
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(
        warnings[0].contains(
            "50 scan(s) in frame \"sonar\" have no tf to the robot's frame \"base_link\""
        ),
        "{warnings:?}"
    );
    let path = dir.path().join("laser.bag");
    late_tf_bag(&path, "laser", &[]);
    let options = LogOptions {
        base_frame: Some("chassis".into()),
        ..LogOptions::default()
    };
    let (read, stats, warnings) = read_log(&path, &options);
    assert!(read.iter().all(|s| s.robot_from_laser == Pose2::IDENTITY));
    assert_eq!(stats.tf.unwrap().scans_without_mount["laser"].scans, 50);
    assert!(warnings[0].contains("\"chassis\""), "{warnings:?}");
    // `base_frame` naming the laser's own parent chain still places it.
    let options = LogOptions {
        base_frame: Some("/odom".into()),
        ..LogOptions::default()
    };
    let (read, _, _) = read_log(&path, &options);
    let p = read[20].robot_from_laser;
    assert!(close(p, Pose2::new(2.0 + 0.25, 0.0, 0.1)), "{p:?}");
}

/// A robot whose tree has `base_footprint` and no `base_link` is placed from `base_footprint`.
#[test]
fn base_footprint_is_the_robot_where_tf_has_no_base_link() {
    let dir = tempfile::tempdir().unwrap();
    let mut w = BagWriter::create(&dir.path().join("f.bag"), BagCompression::None).unwrap();
    let scan = w.add_connection("/scan", "sensor_msgs/LaserScan");
    let tf_static = w.add_connection("/tf_static", "tf2_msgs/TFMessage");
    let mount = transform(0, "base_footprint", "laser", Pose2::new(-0.2, 0.0, 3.0));
    w.write(tf_static, time(1), &mount.encode(Flavor::Ros1, 0))
        .unwrap();
    let template = &scans(1)[0];
    for k in 0..5 {
        let msg = LaserScanMsg::from_range_scan(template, time(k * 1_000_000), "laser");
        w.write(scan, time(k * 1_000_000), &msg.encode(Flavor::Ros1, 0))
            .unwrap();
    }
    w.finish().unwrap();
    let (read, stats, _) = read_log(&dir.path().join("f.bag"), &LogOptions::default());
    assert!(
        read.iter()
            .all(|s| close(s.robot_from_laser, Pose2::new(-0.2, 0.0, 3.0)))
    );
    assert_eq!(
        stats.tf.unwrap().base_frame.as_deref(),
        Some("base_footprint")
    );
}

/// A damaged tf message (cut short; a count of transforms beyond its length) is skipped and
/// counted with a warning naming the file, the topic and the message, without
/// `skip_bad_input`; the other transforms still place the scans.
#[test]
fn a_malformed_tf_message_is_a_counted_skip_naming_file_and_message() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad-tf.bag");
    let good = transform(0, "odom", "base_link", Pose2::IDENTITY).encode(Flavor::Ros1, 0);
    let cut = good[..good.len() - 9].to_vec();
    let mut huge = good.clone();
    huge[..4].copy_from_slice(&[0xff, 0xff, 0xff, 0x0f]);
    late_tf_bag(&path, "laser", &[(10, cut), (20, huge)]);
    let (read, stats, warnings) = read_log(&path, &LogOptions::default());
    assert_eq!(read.len(), 50);
    assert!(
        read.iter()
            .all(|s| close(s.robot_from_laser, Pose2::new(0.25, 0.0, 0.1)))
    );
    let tf = stats.tf.unwrap();
    assert_eq!(tf.bad_messages, 2);
    assert_eq!(stats.bad_records, 0, "not a bad scan");
    let first = &tf.bad_message_errors[0];
    assert!(
        first.contains("bad-tf.bag: topic /tf, message ")
            && first.contains("the message ends inside"),
        "{first}"
    );
    assert!(
        tf.bad_message_errors[1].contains("`transforms` claims 268435455 elements"),
        "{:?}",
        tf.bad_message_errors
    );
    assert!(
        warnings
            .iter()
            .any(|w| w.starts_with("2 tf message(s) did not decode and were skipped; first: ")),
        "{warnings:?}"
    );
}

/// A recording without tf reads as before: no tf counts, no warning, the laser at the origin.
#[test]
fn a_recording_without_tf_has_no_tf_counts() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("plain.mcap");
    let written = scans(30);
    let options = RecordOptions {
        odometry_topic: true,
        tf: false,
    };
    write_mcap_with(&path, &written, McapCompression::None, options).unwrap();
    let (read, stats, warnings) = read_log(&path, &LogOptions::default());
    assert_eq!(read.len(), 30);
    assert!(read.iter().all(|s| s.robot_from_laser == Pose2::IDENTITY));
    assert_eq!(stats.tf, None);
    assert!(warnings.is_empty());
    // A mounting cannot be written without tf.
    let e = write_mcap_with(
        &path,
        &mounted(Pose2::new(0.1, 0.0, 0.0), 3),
        McapCompression::None,
        options,
    );
    assert!(e.unwrap_err().to_string().contains("needs tf"));
}
