//! The ROS recordings in `../shared/datasets/ros`; each test skips with a message when absent.

use std::path::{Path, PathBuf};

use polymap_io::log::{LogKind, LogOptions, LogSource};
use polymap_io::ros::{LaserScanMsg, ReadLimits, RosFormat, RosTime, open_source, survey};

/// `$POLYMAP_DATASETS/ros/NAME` (default `../shared/datasets`), or `None` with a message.
pub fn ros_file(name: &str) -> Option<PathBuf> {
    let dir = match std::env::var_os("POLYMAP_DATASETS") {
        Some(d) => PathBuf::from(d),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/datasets"),
    };
    let path = dir.join("ros").join(name);
    if path.exists() {
        Some(path)
    } else {
        eprintln!("SKIPPED: {} is absent", path.display());
        None
    }
}

/// Every LaserScan message of a file, decoded, in file order.
fn laser_messages(path: &Path, format: RosFormat) -> Vec<LaserScanMsg> {
    let mut source = open_source(path, format, ReadLimits::default(), false).unwrap();
    let mut out = Vec::new();
    while source.advance().unwrap() {
        let m = source.current();
        let c = &source.connections()[m.connection];
        if c.is_laser_scan() {
            out.push(LaserScanMsg::decode(m.data, c.encoding.flavor().unwrap()).unwrap());
        }
    }
    out
}

#[test]
fn the_hokuyo_bag_gives_all_360_scans_despite_its_wrong_index() {
    let Some(path) = ros_file("laser-only-hokuyo.bag") else {
        return;
    };
    assert_eq!(LogKind::of(&path).unwrap(), LogKind::Ros(RosFormat::Bag1));
    let mut log = LogSource::open(&path, &LogOptions::default()).unwrap();
    let mut last = f64::NEG_INFINITY;
    let mut first = None;
    while let Some(scan) = log.next_scan().unwrap() {
        assert_eq!(scan.ranges_m.len(), 681);
        assert_eq!(scan.angle_min_rad, f64::from(-2.086_213_8_f32));
        assert_eq!(scan.angle_increment_rad, f64::from(0.006_135_923_3_f32));
        assert!(scan.stamp.seconds > last, "stamps increase");
        last = scan.stamp.seconds;
        first.get_or_insert(scan);
    }
    let stats = log.stats();
    assert_eq!(stats.scans, 360);
    assert_eq!(stats.records, 360);
    assert_eq!(stats.odometry_messages, 0);
    let first = first.unwrap();
    assert_eq!(first.stamp.text, "1282836370.970876375");
    assert_eq!(
        &first.ranges_m[..3],
        &[
            f64::from(3.002f32),
            f64::from(3.009f32),
            f64::from(3.009f32)
        ]
    );
    // Zero readings are below range_min (0.02 m): no-returns.
    assert!(first.ranges_m[16].is_infinite());
    assert_eq!(stats.valid_readings + stats.no_return_readings, 360 * 681);
}

/// The two synthetic scans of the conformance bag, as its README and rosbags describe them.
fn check_conformance(msgs: &[LaserScanMsg], stamps: [(i64, u32); 2]) {
    assert_eq!(msgs.len(), 2);
    for (m, (sec, nanosec)) in msgs.iter().zip(stamps) {
        assert_eq!(m.stamp, RosTime { sec, nanosec });
        assert_eq!(m.frame_id, "test_frame");
        assert_eq!(m.angle_min, -1.57);
        assert_eq!(m.angle_max, 1.57);
        assert_eq!(m.angle_increment, 0.01);
        assert_eq!(m.time_increment, 0.0);
        assert_eq!(m.scan_time, 0.1);
        assert_eq!(m.range_min, 0.1);
        assert_eq!(m.range_max, 10.0);
        assert_eq!(m.ranges, vec![1.0, 2.0, 3.0, 4.0, 5.0]);
        assert_eq!(m.intensity_count, 5);
        let scan = m.to_range_scan();
        assert_eq!(scan.ranges_m, vec![1.0, 2.0, 3.0, 4.0, 5.0]);
        assert_eq!(scan.valid_count(), 5);
    }
}

#[test]
fn the_conformance_mcap_holds_two_exact_laser_scans() {
    let Some(path) = ros_file("rosbag2-conformance.mcap") else {
        return;
    };
    assert_eq!(LogKind::of(&path).unwrap(), LogKind::Ros(RosFormat::Mcap));
    let msgs = laser_messages(&path, RosFormat::Mcap);
    check_conformance(
        &msgs,
        [(1_749_315_324, 962_061_056), (1_749_315_325, 13_669_120)],
    );
    // Through its chunk indexes (a topic given) too.
    let options = LogOptions {
        topic: Some("/test/sensor_msgs/laser_scan".into()),
        ..LogOptions::default()
    };
    let mut log = LogSource::open(&path, &options).unwrap();
    let first = log.next_scan().unwrap().unwrap();
    assert_eq!(first.stamp.text, "1749315324.962061056");
    assert!(log.next_scan().unwrap().is_some() && log.next_scan().unwrap().is_none());
    let mut source = open_source(&path, RosFormat::Mcap, ReadLimits::default(), false).unwrap();
    let topics = survey(source.as_mut()).unwrap();
    assert_eq!(topics.len(), 94);
    assert_eq!(topics.iter().map(|t| t.messages).sum::<u64>(), 188);
}

#[test]
fn the_conformance_db3_holds_the_same_two_scans() {
    let Some(path) = ros_file("rosbag2-conformance.db3") else {
        return;
    };
    assert_eq!(LogKind::of(&path).unwrap(), LogKind::Ros(RosFormat::Sqlite));
    let msgs = laser_messages(&path, RosFormat::Sqlite);
    check_conformance(
        &msgs,
        [(1_749_315_324, 736_855_808), (1_749_315_324, 789_328_896)],
    );
}

#[test]
fn a_rosbag2_folder_reads_through_its_metadata() {
    let (Some(db3), Some(yaml)) = (
        ros_file("rosbag2-conformance.db3"),
        ros_file("rosbag2-conformance.metadata.yaml"),
    ) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(&yaml, dir.path().join("metadata.yaml")).unwrap();
    std::fs::copy(&db3, dir.path().join("test_bag_sqlite3.db3")).unwrap();
    assert_eq!(
        LogKind::of(dir.path()).unwrap(),
        LogKind::Ros(RosFormat::Folder)
    );
    let options = LogOptions {
        odometry: true,
        ..LogOptions::default()
    };
    let mut log = LogSource::open(dir.path(), &options).unwrap();
    let mut scans = Vec::new();
    while let Some(s) = log.next_scan().unwrap() {
        scans.push(s);
    }
    assert_eq!(scans.len(), 2);
    assert_eq!(scans[0].stamp.text, "1749315324.736855808");
    assert!(scans.iter().all(|s| s.odom_from_robot.is_some()));
    assert_eq!(log.stats().odometry_messages, 2);
}

#[test]
fn the_kind_is_told_by_content_not_by_the_extension() {
    let Some(path) = ros_file("laser-only-hokuyo.bag") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let disguised = dir.path().join("hokuyo.clf");
    std::fs::copy(&path, &disguised).unwrap();
    assert_eq!(
        LogKind::of(&disguised).unwrap(),
        LogKind::Ros(RosFormat::Bag1)
    );
}

/// The `tf2_msgs/msg/TFMessage`s of the conformance recordings, written by ROS 2, decode from
/// both storages (the readers keep the bytes of tf messages): `test_frame` → `child_frame` at
/// (1, 2, 3), identity rotation. Their topic is not `/tf`, so mapping reads no tf from them.
#[test]
fn the_conformance_tf_messages_decode_in_both_storages() {
    use polymap_io::ros::TfMessage;
    for (name, format) in [
        ("rosbag2-conformance.mcap", RosFormat::Mcap),
        ("rosbag2-conformance.db3", RosFormat::Sqlite),
    ] {
        let Some(path) = ros_file(name) else {
            return;
        };
        let mut source = open_source(&path, format, ReadLimits::default(), false).unwrap();
        let mut transforms = Vec::new();
        while source.advance().unwrap() {
            let m = source.current();
            let c = &source.connections()[m.connection];
            if c.is_tf() {
                assert_eq!(c.topic, "/test/tf2_msgs/tf_message");
                let msg = TfMessage::decode(m.data, c.encoding.flavor().unwrap()).unwrap();
                transforms.extend(msg.transforms);
            }
        }
        assert_eq!(transforms.len(), 2, "{name}");
        for t in &transforms {
            assert_eq!(
                (t.parent_frame.as_str(), t.child_frame.as_str()),
                ("test_frame", "child_frame")
            );
            assert_eq!(t.translation_m, [1.0, 2.0, 3.0]);
            assert_eq!(t.rotation, [0.0, 0.0, 0.0, 1.0]);
        }
        let mut log = LogSource::open(&path, &LogOptions::default()).unwrap();
        while log.next_scan().unwrap().is_some() {}
        assert_eq!(log.stats().tf, None, "{name}");
    }
}
