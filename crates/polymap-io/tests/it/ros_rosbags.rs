//! Cross-checks with an independent implementation, the Python `rosbags` package
//! (`scripts/rosbags-crosscheck.py`): polymap reads what rosbags writes, and rosbags reads what
//! polymap writes, to the bit: laser scans and tf (`tf2_msgs/TFMessage`, ROS 1 and CDR).

use std::path::{Path, PathBuf};
use std::process::Command;

use polymap_io::log::{LogOptions, LogSource};
use polymap_io::ros::mcap_file::McapCompression;
use polymap_io::ros::ros1::BagCompression;
use polymap_io::ros::{
    ReadLimits, RosFormat, TfMessage, open_source, sniff, write_bag, write_mcap,
};

fn script() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scripts/rosbags-crosscheck.py")
}

/// True when `python3` can import rosbags; without it the test fails under CI and skips
/// (visibly) elsewhere.
fn rosbags_available() -> bool {
    let ok = Command::new("python3")
        .args(["-c", "import rosbags"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "python3 cannot import rosbags (.ci/run installs it)"
        );
        eprintln!("SKIPPED: python3 cannot import rosbags (pip install rosbags)");
    }
    ok
}

fn python(args: &[&str]) -> String {
    let out = Command::new("python3")
        .arg(script())
        .args(args)
        .output()
        .expect("python3 runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// polymap's own view of a file's LaserScans and tf, in the script's `read` format.
fn polymap_lines(path: &Path) -> String {
    let format = sniff(path).unwrap().unwrap();
    let mut source = open_source(path, format, ReadLimits::default(), false).unwrap();
    let mut out = String::new();
    let mut tf_lines = String::new();
    while source.advance().unwrap() {
        let m = source.current();
        let c = &source.connections()[m.connection];
        if c.is_tf() {
            let msg = TfMessage::decode(m.data, c.encoding.flavor().unwrap())
                .unwrap_or_else(|e| panic!("{}: {e}: {:?} {:?}", path.display(), c, m.data));
            for t in msg.transforms {
                let values: Vec<String> = t
                    .translation_m
                    .iter()
                    .chain(&t.rotation)
                    .map(|v| format!("{:016x}", v.to_bits()))
                    .collect();
                tf_lines.push_str(&format!(
                    "tf {} {} {} {} {} {}\n",
                    c.topic,
                    t.stamp.sec,
                    t.stamp.nanosec,
                    t.parent_frame,
                    t.child_frame,
                    values.join(" ")
                ));
            }
            continue;
        }
        if !c.is_laser_scan() {
            continue;
        }
        let msg =
            polymap_io::ros::LaserScanMsg::decode(m.data, c.encoding.flavor().unwrap()).unwrap();
        let ranges: Vec<String> = msg
            .ranges
            .iter()
            .map(|r| format!("{:08x}", r.to_bits()))
            .collect();
        out.push_str(&format!(
            "{} {} {} {:08x} {:08x} {:08x} {:08x} {}\n",
            c.topic,
            msg.stamp.sec,
            msg.stamp.nanosec,
            msg.angle_min.to_bits(),
            msg.angle_increment.to_bits(),
            msg.range_min.to_bits(),
            msg.range_max.to_bits(),
            ranges.join(",")
        ));
    }
    out + &tf_lines
}

#[test]
fn polymap_reads_what_rosbags_writes() {
    if !rosbags_available() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    python(&["write", dir.path().to_str().unwrap()]);
    for (name, format) in [
        ("rb_bz2.bag", RosFormat::Bag1),
        ("rb_lz4.bag", RosFormat::Bag1),
        ("rb_mcap", RosFormat::Folder),
        ("rb_sqlite", RosFormat::Folder),
    ] {
        let path = dir.path().join(name);
        assert_eq!(sniff(&path).unwrap(), Some(format), "{name}");
        // The same bits as rosbags reads (the MCAP's second scan is big endian).
        assert_eq!(
            polymap_lines(&path),
            python(&["read", path.to_str().unwrap()]),
            "{name}"
        );
        let options = LogOptions {
            odometry: true,
            ..LogOptions::default()
        };
        let mut log = LogSource::open(&path, &options).unwrap();
        let mut scans = Vec::new();
        while let Some(s) = log.next_scan().unwrap() {
            scans.push(s);
        }
        let stamps: Vec<&str> = scans.iter().map(|s| s.stamp.text.as_str()).collect();
        assert_eq!(
            stamps,
            [
                "1700000000.250000",
                "1700000001.123456789",
                "1700000002.000000"
            ],
            "{name}"
        );
        for (k, s) in scans.iter().enumerate() {
            assert_eq!(s.angle_min_rad, 1.5);
            assert_eq!(s.angle_increment_rad, -0.25);
            // nan, inf, below range_min, above range_max and -inf are no-returns; 8.0 = range_max
            // is a return.
            let valid: Vec<bool> = s.ranges_m.iter().map(|&r| s.is_valid_range(r)).collect();
            assert_eq!(
                valid,
                [true, false, false, false, false, true, false, true],
                "{name}"
            );
            assert_eq!(s.ranges_m[0], 1.0 + k as f64);
            // Odometry from (0, 0, 0) at T0 to (3, 6, 0.9) at T0 + 3 s.
            let f = (s.stamp.seconds - 1_700_000_000.0) / 3.0;
            let p = s.odom_from_robot.unwrap();
            assert!((p.x_m - 3.0 * f).abs() < 1e-6, "{name} {k}: {p:?}");
            assert!((p.y_m - 6.0 * f).abs() < 1e-6, "{name} {k}: {p:?}");
            assert!((p.theta_rad - 0.9 * f).abs() < 1e-6, "{name} {k}: {p:?}");
            // The laser's mounting from /tf_static (`/base_link` → `laser`), recorded after
            // the first scan.
            let m = s.robot_from_laser;
            assert!(
                (m.x_m - 0.2).abs() < 1e-12
                    && (m.y_m - 0.1).abs() < 1e-12
                    && (m.theta_rad - 0.3).abs() < 1e-12,
                "{name} {k}: {m:?}"
            );
        }
        let tf = log.stats().tf.expect("the recording has tf");
        assert_eq!(tf.base_frame.as_deref(), Some("base_link"), "{name}");
        assert_eq!(
            (tf.static_messages, tf.messages, tf.scans_mounted),
            (1, 2, 3),
            "{name}"
        );
    }
}

#[test]
fn rosbags_reads_what_polymap_writes() {
    if !rosbags_available() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scans = polymap_sim_like_scans();
    let bag = dir.path().join("p.bag");
    write_bag(&bag, &scans, BagCompression::Bz2).unwrap();
    let mcap_dir = dir.path().join("p_mcap");
    std::fs::create_dir(&mcap_dir).unwrap();
    let mcap = mcap_dir.join("p.mcap");
    write_mcap(&mcap, &scans, McapCompression::Lz4).unwrap();
    // rosbags reads MCAP through a rosbag2 folder.
    std::fs::write(
        mcap_dir.join("metadata.yaml"),
        rosbag2_metadata("p.mcap", scans.len()),
    )
    .unwrap();
    for path in [bag, mcap_dir] {
        let theirs = python(&["read", path.to_str().unwrap()]);
        // A scan and odom → base_link per scan, and the mounting once.
        assert_eq!(theirs.lines().count(), 2 * scans.len() + 1);
        assert!(
            theirs.contains(" base_link laser 3fc999999999999a 0000000000000000 "),
            "{theirs}"
        );
        assert_eq!(polymap_lines(&path), theirs, "{}", path.display());
    }
}

fn polymap_sim_like_scans() -> Vec<polymap::scan::RangeScan> {
    use polymap::geometry::Pose2;
    use polymap::scan::{RangeScan, Stamp};
    (0..40)
        .map(|k| {
            let s = RangeScan {
                stamp: Stamp {
                    seconds: 0.0,
                    text: format!("1000.{:06}", k * 25_000),
                },
                ranges_m: (0..270)
                    .map(|i| 0.5 + 0.013 * ((i * 7 + k) % 101) as f64)
                    .collect(),
                angle_min_rad: -135f64.to_radians(),
                angle_increment_rad: 1f64.to_radians(),
                max_range_m: 30.0,
                // Off the robot's origin: written as tf.
                robot_from_laser: Pose2::new(0.2, 0.0, 0.1),
                odom_from_robot: Some(Pose2::new(k as f64, 0.0, 0.0)),
            };
            polymap_io::ros::float32_scan(&s)
        })
        .collect()
}

/// A minimal rosbag2 `metadata.yaml` for one MCAP file with /scan, /odom, /tf and /tf_static.
fn rosbag2_metadata(file: &str, scans: usize) -> String {
    let topic = |name: &str, ty: &str, count: usize| {
        format!(
            "  - message_count: {count}\n    topic_metadata:\n      name: {name}\n      \
             offered_qos_profiles: ''\n      serialization_format: cdr\n      type: {ty}\n      \
             type_description_hash: ''\n"
        )
    };
    let tf = "tf2_msgs/msg/TFMessage";
    format!(
        "rosbag2_bagfile_information:\n  version: 9\n  storage_identifier: mcap\n  \
         duration:\n    nanoseconds: 1000000000\n  starting_time:\n    nanoseconds_since_epoch: 1000000000000\n  \
         message_count: {}\n  topics_with_message_count:\n{}  compression_format: ''\n  \
         compression_mode: ''\n  relative_file_paths:\n  - {file}\n  files:\n  - path: {file}\n    \
         starting_time:\n      nanoseconds_since_epoch: 1000000000000\n    duration:\n      \
         nanoseconds: 1000000000\n    message_count: {}\n  custom_data: {{}}\n  ros_distro: humble\n",
        3 * scans + 1,
        [
            topic("/scan", "sensor_msgs/msg/LaserScan", scans),
            topic("/odom", "nav_msgs/msg/Odometry", scans),
            topic("/tf", tf, scans),
            topic("/tf_static", tf, 1),
        ]
        .concat(),
        3 * scans + 1
    )
}
