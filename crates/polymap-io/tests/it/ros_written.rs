//! ROS files written by polymap-io and read back: every format and compression, topic choice,
//! odometry interpolation, and damaged input.

use std::path::Path;

use polymap::geometry::Pose2;
use polymap::scan::{RangeScan, Stamp};
use polymap_io::log::{LogError, LogOptions, LogSource};
use polymap_io::ros::mcap_file::McapCompression;
use polymap_io::ros::ros1::{BagCompression, BagWriter};
use polymap_io::ros::{
    Flavor, LaserScanMsg, OdometryMsg, RosError, RosTime, float32_scan, write_bag, write_mcap,
};

/// `n` scans of 360 beams with odometry, as a ROS message holds them.
pub fn scans(n: usize) -> Vec<RangeScan> {
    (0..n)
        .map(|k| {
            let scan = RangeScan {
                stamp: Stamp {
                    seconds: 0.0,
                    text: format!("{}.{:06}", 1_000_000 + k / 10, (k % 10) * 100_000),
                },
                ranges_m: (0..360)
                    .map(|i| match (i + k) % 37 {
                        0 => 30.0,
                        j => 1.0 + 0.01 * j as f64 + 0.001 * k as f64,
                    })
                    .collect(),
                angle_min_rad: -std::f64::consts::PI,
                angle_increment_rad: 1f64.to_radians(),
                max_range_m: 30.0,
                robot_from_laser: Pose2::IDENTITY,
                odom_from_robot: Some(Pose2::new(0.1 * k as f64, 0.05 * k as f64, 0.01 * k as f64)),
            };
            let mut s = float32_scan(&scan);
            s.stamp.seconds = s.stamp.text.parse().unwrap();
            s
        })
        .collect()
}

fn read_all(path: &Path, options: &LogOptions) -> Result<Vec<RangeScan>, LogError> {
    let mut log = LogSource::open(path, options)?;
    let mut out = Vec::new();
    while let Some(s) = log.next_scan()? {
        out.push(s);
    }
    Ok(out)
}

fn with_odometry() -> LogOptions {
    LogOptions {
        odometry: true,
        ..LogOptions::default()
    }
}

fn assert_same(read: &[RangeScan], written: &[RangeScan]) {
    assert_eq!(read.len(), written.len());
    for (r, w) in read.iter().zip(written) {
        assert_eq!(r.stamp, w.stamp);
        assert_eq!(r.angle_min_rad, w.angle_min_rad);
        assert_eq!(r.angle_increment_rad, w.angle_increment_rad);
        for (a, b) in r.ranges_m.iter().zip(&w.ranges_m) {
            assert_eq!(r.is_valid_range(*a), w.is_valid_range(*b));
            if w.is_valid_range(*b) {
                assert_eq!(a, b);
            }
        }
        let (p, q) = (r.odom_from_robot.unwrap(), w.odom_from_robot.unwrap());
        assert_eq!((p.x_m, p.y_m), (q.x_m, q.y_m));
        assert!((p.theta_rad - q.theta_rad).abs() < 1e-12);
    }
}

#[test]
fn bags_in_every_compression_read_back_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let written = scans(1200); // more than one 768 KiB chunk
    for c in [
        BagCompression::None,
        BagCompression::Bz2,
        BagCompression::Lz4,
    ] {
        let path = dir.path().join(format!("{c:?}.bag"));
        write_bag(&path, &written, c).unwrap();
        assert_same(&read_all(&path, &with_odometry()).unwrap(), &written);
    }
}

#[test]
fn mcap_files_in_every_compression_read_back_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let written = scans(300);
    for c in [
        McapCompression::None,
        McapCompression::Zstd,
        McapCompression::Lz4,
    ] {
        let path = dir.path().join(format!("{c:?}.mcap"));
        write_mcap(&path, &written, c).unwrap();
        assert_same(&read_all(&path, &with_odometry()).unwrap(), &written);
    }
}

/// A bag with the given LaserScan topics (3 and 5 messages) and odometry messages at `odom`
/// (seconds, pose).
fn custom_bag(path: &Path, topics: &[&str], odom: &[(u32, Pose2)]) {
    let mut w = BagWriter::create(path, BagCompression::None).unwrap();
    let conns: Vec<u32> = topics
        .iter()
        .map(|t| w.add_connection(t, "sensor_msgs/LaserScan"))
        .collect();
    let odom_conn = w.add_connection("/odom", "nav_msgs/Odometry");
    for &(sec, pose) in odom {
        let t = RosTime {
            sec: i64::from(sec),
            nanosec: 0,
        };
        w.write(
            odom_conn,
            t,
            &OdometryMsg::from_pose(t, &pose).encode(Flavor::Ros1, 0),
        )
        .unwrap();
    }
    for (i, &c) in conns.iter().enumerate() {
        for k in 0..(3 + 2 * i) {
            let t = RosTime {
                sec: 10,
                nanosec: 200_000_000 * k as u32,
            };
            let scan = &scans(1)[0];
            let msg = LaserScanMsg::from_range_scan(scan, t, "laser");
            w.write(c, t, &msg.encode(Flavor::Ros1, k as u32)).unwrap();
        }
    }
    w.finish().unwrap();
}

#[test]
fn several_laser_topics_are_an_error_that_lists_them_with_counts() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("two.bag");
    custom_bag(&path, &["/front", "/rear"], &[]);
    let e = read_all(&path, &LogOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("2 sensor_msgs/LaserScan topics"), "{e}");
    assert!(
        e.contains("/front (3 messages)") && e.contains("/rear (5 messages)"),
        "{e}"
    );
    assert!(e.contains("--topic"), "{e}");
    let rear = LogOptions {
        topic: Some("/rear".into()),
        ..LogOptions::default()
    };
    assert_eq!(read_all(&path, &rear).unwrap().len(), 5);
    let missing = LogOptions {
        topic: Some("/side".into()),
        ..LogOptions::default()
    };
    let e = read_all(&path, &missing).unwrap_err().to_string();
    assert!(
        e.contains("no messages on topic /side") && e.contains("/front, /rear"),
        "{e}"
    );
}

#[test]
fn odometry_is_interpolated_to_each_scan_stamp() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("odom.bag");
    // Odometry at 9 s and 11 s; scans at 10.0, 10.2, 10.4 s.
    custom_bag(
        &path,
        &["/scan"],
        &[
            (9, Pose2::new(0.0, 0.0, 3.0)),
            (11, Pose2::new(2.0, -4.0, -3.0)),
        ],
    );
    let read = read_all(&path, &with_odometry()).unwrap();
    for (s, f) in read.iter().zip([0.5, 0.6, 0.7]) {
        let p = s.odom_from_robot.unwrap();
        assert!((p.x_m - 2.0 * f).abs() < 1e-9 && (p.y_m + 4.0 * f).abs() < 1e-9);
        // Yaw goes the short way round, through ±π.
        let expected = 3.0 + f * (std::f64::consts::TAU - 6.0);
        let d = (p.theta_rad - expected + 1.0).rem_euclid(std::f64::consts::TAU) - 1.0;
        assert!(d.abs() < 1e-9, "{} vs {expected}", p.theta_rad);
    }
    let none = dir.path().join("none.bag");
    custom_bag(&none, &["/scan"], &[]);
    let e = read_all(&none, &with_odometry()).unwrap_err().to_string();
    assert!(
        e.contains("no nav_msgs/Odometry topic with messages"),
        "{e}"
    );
}

/// A bag cut inside a record, as a crashed recorder leaves it, failed even with
/// --skip-bad-input; it yields the scans before the cut, with a warning saying where it ends.
#[test]
fn a_cut_bag_yields_the_scans_before_the_cut_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cut.bag");
    let written = scans(1200);
    write_bag(&path, &written, BagCompression::Lz4).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() * 2 / 3]).unwrap();
    let options = LogOptions {
        topic: Some("/scan".into()),
        ..LogOptions::default()
    };
    let mut log = LogSource::open(&path, &options).unwrap();
    let mut read = Vec::new();
    while let Some(s) = log.next_scan().unwrap() {
        read.push(s);
    }
    assert!(
        !read.is_empty() && read.len() < written.len(),
        "{}",
        read.len()
    );
    assert!(read.iter().zip(&written).all(|(r, w)| r.stamp == w.stamp));
    let said = log.stats().warnings.join(" ");
    let size = bytes.len() * 2 / 3;
    assert!(
        said.contains(&format!(
            "cut.bag: the file ends at byte {size}, inside the record"
        )),
        "{said}"
    );
}

#[test]
fn a_corrupt_chunk_fails_or_is_skipped_and_counted() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.bag");
    let written = scans(1200);
    write_bag(&path, &written, BagCompression::Lz4).unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    // Garble the middle of the first chunk's compressed data (it starts after the 4 KiB header).
    for b in &mut bytes[20_000..20_400] {
        *b ^= 0x5a;
    }
    std::fs::write(&path, &bytes).unwrap();
    let options = LogOptions {
        topic: Some("/scan".into()),
        ..LogOptions::default()
    };
    let e = read_all(&path, &options).unwrap_err().to_string();
    assert!(e.contains("bad.bag: byte 4109: corrupt lz4 chunk"), "{e}");
    let skipping = LogOptions {
        skip_bad_input: true,
        ..options
    };
    let mut log = LogSource::open(&path, &skipping).unwrap();
    let mut n = 0;
    while log.next_scan().unwrap().is_some() {
        n += 1;
    }
    assert!(n > 0 && n < 1200, "{n}");
    assert_eq!(log.stats().bad_records, 1);
}

#[test]
fn a_scan_whose_count_does_not_fit_names_topic_and_message() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("count.bag");
    let mut w = BagWriter::create(&path, BagCompression::Bz2).unwrap();
    let c = w.add_connection("/scan", "sensor_msgs/LaserScan");
    let scan = &scans(1)[0];
    for k in 0..3u32 {
        let t = RosTime { sec: 5, nanosec: k };
        let mut data = LaserScanMsg::from_range_scan(scan, t, "laser").encode(Flavor::Ros1, k);
        if k == 1 {
            // The ranges count sits after seq, stamp, frame_id ("laser") and seven floats.
            let at = 4 + 8 + 4 + 5 + 7 * 4;
            data[at..at + 4].copy_from_slice(&0x7fff_ffffu32.to_le_bytes());
        }
        w.write(c, t, &data).unwrap();
    }
    w.finish().unwrap();
    let e = read_all(&path, &LogOptions::default()).unwrap_err();
    assert!(
        matches!(&e, LogError::Ros(RosError::Message { index: 2, .. })),
        "{e}"
    );
    let text = e.to_string();
    assert!(
        text.contains("count.bag: topic /scan, message 2 (byte 4109)"),
        "{text}"
    );
    assert!(
        text.contains("`ranges` claims 2147483647 elements"),
        "{text}"
    );
    let skipping = LogOptions {
        skip_bad_input: true,
        ..LogOptions::default()
    };
    let mut log = LogSource::open(&path, &skipping).unwrap();
    let mut n = 0;
    while log.next_scan().unwrap().is_some() {
        n += 1;
    }
    assert_eq!((n, log.stats().bad_records), (2, 1));
}

#[test]
fn big_endian_cdr_decodes_like_little_endian() {
    let scan = &scans(1)[0];
    let t = RosTime { sec: 7, nanosec: 8 };
    let msg = LaserScanMsg::from_range_scan(scan, t, "laser");
    let le = LaserScanMsg::decode(&msg.encode(Flavor::CdrLittle, 0), Flavor::CdrLittle).unwrap();
    let be = LaserScanMsg::decode(&msg.encode(Flavor::CdrBig, 0), Flavor::CdrLittle).unwrap();
    assert_eq!(le, be);
    assert_eq!(le, msg);
}

/// A camera topic of 300 KB images with a sparse laser: the chunks holding only images are
/// neither read nor decompressed when the laser topic is asked for.
#[test]
fn mcap_chunks_without_the_laser_topic_are_skipped() {
    use polymap_io::ros::mcap_file::McapWriter;
    use polymap_io::ros::mcap_indexed::McapIndexedReader;
    use polymap_io::ros::{MessageSource, ReadLimits};
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("camera.mcap");
    let mut w = McapWriter::create(&path, McapCompression::Zstd).unwrap();
    let camera = w.add_channel("/camera", "sensor_msgs/msg/Image").unwrap();
    let laser = w.add_channel("/scan", "sensor_msgs/msg/LaserScan").unwrap();
    let scan = &scans(1)[0];
    let image: Vec<u8> = (0..300_000u32)
        .map(|i| (i.wrapping_mul(2_654_435_761) >> 24) as u8)
        .collect();
    for k in 0..100u32 {
        let t = RosTime {
            sec: 100,
            nanosec: k * 1_000_000,
        };
        w.write(camera, t, &image).unwrap();
        if k % 10 == 9 {
            let msg = LaserScanMsg::from_range_scan(scan, t, "laser");
            w.write(laser, t, &msg.encode(Flavor::CdrLittle, 0))
                .unwrap();
        }
    }
    w.finish().unwrap();
    let size = std::fs::metadata(&path).unwrap().len();
    let mut r =
        McapIndexedReader::open(&path, ReadLimits::default(), false, &["/scan".to_string()])
            .unwrap()
            .reader()
            .expect("an indexed file");
    let mut n = 0;
    while r.advance().unwrap() {
        assert_eq!(r.connections()[r.current().connection].topic, "/scan");
        n += 1;
    }
    assert_eq!(n, 10);
    assert!(
        r.position() * 5 < size,
        "read {} of {size} bytes",
        r.position()
    );
    let options = LogOptions {
        topic: Some("/scan".into()),
        ..LogOptions::default()
    };
    assert_eq!(read_all(&path, &options).unwrap().len(), 10);
}

/// Topic choice in an MCAP file comes from its summary's counts (no pass over the data).
#[test]
fn several_laser_topics_in_mcap_are_listed_from_the_summary() {
    use polymap_io::ros::ReadLimits;
    use polymap_io::ros::mcap_file::McapWriter;
    use polymap_io::ros::mcap_indexed::summary_topics;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("two.mcap");
    let mut w = McapWriter::create(&path, McapCompression::Lz4).unwrap();
    let front = w
        .add_channel("/front", "sensor_msgs/msg/LaserScan")
        .unwrap();
    let rear = w.add_channel("/rear", "sensor_msgs/msg/LaserScan").unwrap();
    let scan = &scans(1)[0];
    for k in 0..7u32 {
        let t = RosTime { sec: 3, nanosec: k };
        let data = LaserScanMsg::from_range_scan(scan, t, "laser").encode(Flavor::CdrLittle, 0);
        w.write(if k < 4 { front } else { rear }, t, &data).unwrap();
    }
    w.finish().unwrap();
    let topics = summary_topics(&path, ReadLimits::default())
        .unwrap()
        .unwrap();
    let counts: Vec<(&str, u64)> = topics
        .iter()
        .map(|t| (t.connection.topic.as_str(), t.messages))
        .collect();
    assert_eq!(counts, [("/front", 4), ("/rear", 3)]);
    let e = read_all(&path, &LogOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("/front (4 messages), /rear (3 messages)"), "{e}");
}

/// Without `odometry`, `witness_odometry` attaches the file's only odometry topic where the
/// file is surveyed anyway: none outside the odometry's time span, none when the laser topic is
/// named (no survey), and odometry that cannot be read is dropped, not an error.
#[test]
fn odometry_witnesses_best_effort_without_the_odometry_prior() {
    let dir = tempfile::tempdir().unwrap();
    let witness = LogOptions {
        witness_odometry: true,
        ..LogOptions::default()
    };
    // Odometry at 9 s and 10 s; scans at 10.0, 10.2, 10.4 s: the last two lie beyond the last
    // odometry message.
    let path = dir.path().join("odom.bag");
    let odom = [
        (9, Pose2::new(0.0, 0.0, 0.0)),
        (10, Pose2::new(1.0, 0.0, 0.0)),
    ];
    custom_bag(&path, &["/scan"], &odom);
    let unwitnessed = |path: &Path, options: &LogOptions| {
        read_all(path, options)
            .unwrap()
            .iter()
            .all(|s| s.odom_from_robot.is_none())
    };
    let read = read_all(&path, &witness).unwrap();
    assert_eq!(read[0].odom_from_robot, Some(Pose2::new(1.0, 0.0, 0.0)));
    assert!(read[1..].iter().all(|s| s.odom_from_robot.is_none()));
    // The odometry prior takes the nearest pose there instead.
    let prior = read_all(&path, &with_odometry()).unwrap();
    assert!(prior.iter().all(|s| s.odom_from_robot.is_some()));
    // ...and says so.
    let mut log = LogSource::open(&path, &with_odometry()).unwrap();
    while log.next_scan().unwrap().is_some() {}
    assert_eq!(log.stats().scans_outside_odometry, 2);
    let warnings = log.carmen_stats().warnings();
    assert!(
        warnings
            .iter()
            .any(|w| w.starts_with("2 scan(s) stamped outside the odometry's time span")),
        "{warnings:?}"
    );
    // Odometry 2 s apart (9 s and 11 s): a gap a witness does not interpolate across, though
    // the odometry prior does.
    let gapped = dir.path().join("gapped.bag");
    let wide = [
        (9, Pose2::new(0.0, 0.0, 0.0)),
        (11, Pose2::new(2.0, 0.0, 0.0)),
    ];
    custom_bag(&gapped, &["/scan"], &wide);
    assert!(unwitnessed(&gapped, &witness));
    assert!(
        read_all(&gapped, &with_odometry())
            .unwrap()
            .iter()
            .all(|s| s.odom_from_robot.is_some())
    );
    // No odometry topic: no witness, and no error.
    let none = dir.path().join("none.bag");
    custom_bag(&none, &["/scan"], &[]);
    assert!(unwitnessed(&none, &witness));
    // The laser topic named: the file is not surveyed for the odometry's.
    let named = LogOptions {
        topic: Some("/scan".into()),
        ..witness.clone()
    };
    assert!(unwitnessed(&path, &named));
    // An odometry topic that is not odometry: dropped, said why, and the scans read on.
    let wrong = LogOptions {
        odom_topic: Some("/scan".into()),
        ..witness
    };
    let mut log = LogSource::open(&path, &wrong).unwrap();
    let mut n = 0;
    while let Some(s) = log.next_scan().unwrap() {
        assert!(s.odom_from_robot.is_none());
        n += 1;
    }
    assert_eq!(n, 3);
    let dropped = log.stats().odometry_dropped.expect("dropped");
    assert!(dropped.contains("not nav_msgs/Odometry"), "{dropped}");
    assert!(
        log.carmen_stats()
            .warnings()
            .iter()
            .any(|w| w.contains("no odometry witnesses the steps"))
    );
}
