//! ROS recordings end to end: the simulator's worlds as CARMEN, MCAP and bag map to the same
//! results, the laser's mounting read from tf, the real Hokuyo bag maps coherently, and
//! `polymap info` tells what a file holds.

use std::path::Path;

use crate::support::{datasets, map_quietly, polymap, text};

fn simulate_ros(dir: &Path, fov_deg: u16) {
    let out = polymap(&[
        "simulate",
        "hallway45",
        "-o",
        dir.to_str().unwrap(),
        "--ros",
        "--fov-deg",
        &fov_deg.to_string(),
    ]);
    assert!(out.status.success(), "{}", text(&out));
}

/// Maps `dir/hallway45.EXT` into `dir/out-EXT-TAG`; returns map.json and trajectory.tum.
fn map_outputs(dir: &Path, ext: &str, tag: &str, extra: &[&str]) -> (Vec<u8>, Vec<u8>) {
    let out_dir = dir.join(format!("out-{ext}-{tag}"));
    let out = map_quietly(&dir.join(format!("hallway45.{ext}")), &out_dir, extra);
    assert!(out.status.success(), "{}", text(&out));
    (
        std::fs::read(out_dir.join("map.json")).unwrap(),
        std::fs::read(out_dir.join("trajectory.tum")).unwrap(),
    )
}

/// Maps every scan of `log` (`extra` options) into `out` and scores its trajectory against
/// the truth: ATE position RMS, metres, and the run's summary.
fn ate_m(log: &Path, out: &Path, truth: &Path, extra: &[&str]) -> (f64, serde_json::Value) {
    let o = map_quietly(log, out, extra);
    assert!(o.status.success(), "{}", text(&o));
    let eval = polymap(&[
        "eval",
        "trajectory",
        out.join("trajectory.tum").to_str().unwrap(),
        truth.to_str().unwrap(),
        "--json",
    ]);
    assert!(eval.status.success(), "{}", text(&eval));
    let v: serde_json::Value = serde_json::from_slice(&eval.stdout).unwrap();
    let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
    (
        v["ate"]["position_m"]["rms"].as_f64().unwrap(),
        serde_json::from_str(&summary).unwrap(),
    )
}

/// The largest distance between the positions of two TUM trajectories of the same stamps.
fn largest_gap_m(a: &[u8], b: &[u8]) -> f64 {
    let xy = |t: &[u8]| -> Vec<(f64, f64)> {
        String::from_utf8_lossy(t)
            .lines()
            .map(|l| {
                let v: Vec<f64> = l.split(' ').skip(1).map(|x| x.parse().unwrap()).collect();
                (v[0], v[1])
            })
            .collect()
    };
    let (a, b) = (xy(a), xy(b));
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(&b)
        .map(|(p, q)| (p.0 - q.0).hypot(p.1 - q.1))
        .fold(0.0, f64::max)
}

/// One world, three formats, one result. The simulator mounts the laser 0.25 m ahead of the
/// robot: the recordings say so with tf, exactly, and the CARMEN log in each `ROBOTLASER1`
/// line's two poses, to their 6 decimals (so the CARMEN run may differ by a micrometre). The
/// MCAP file and the bag agree to the bit, for a 270° and a 360° laser (the 360° one exercises
/// the closed-scan extraction).
#[test]
fn one_world_as_carmen_mcap_and_bag_maps_to_identical_bytes() {
    for fov in [270, 360] {
        let dir = tempfile::tempdir().unwrap();
        simulate_ros(dir.path(), fov);
        let clf = map_outputs(dir.path(), "clf", "plain", &[]);
        let mcap = map_outputs(dir.path(), "mcap", "plain", &[]);
        let bag = map_outputs(dir.path(), "bag", "plain", &[]);
        assert!(mcap == bag, "{fov}°: MCAP and bag differ");
        let gap = largest_gap_m(&clf.1, &mcap.1);
        assert!(gap < 1e-4, "{fov}°: CARMEN and MCAP {gap} m apart");
        let lines = String::from_utf8(clf.1).unwrap();
        assert_eq!(lines.lines().count(), 1553, "{fov}°");
        assert!(lines.starts_with("1000000000.000000 "), "{fov}°");
        // With odometry (nav_msgs/Odometry, interpolated) the two ROS formats agree too.
        let odom = ["--odometry"];
        let mcap = map_outputs(dir.path(), "mcap", "odom", &odom);
        let bag = map_outputs(dir.path(), "bag", "odom", &odom);
        assert!(mcap == bag, "{fov}°: MCAP and bag differ with --odometry");
    }
}

/// The simulated office with the laser 0.25 m ahead of the robot, as MCAP with tf: the
/// trajectory is the robot's (`base_link`), as the truth is. Taking the laser as the robot
/// (`--base-frame laser`, what a reader ignoring tf does) puts it 0.25 m off every pose: the
/// error triples (measured 0.047 m and 0.169 m RMS). Without an odometry topic, tf's
/// odom → base_link is the odometry for `--odometry`.
#[test]
fn a_laser_mounted_off_centre_maps_to_the_robots_trajectory_through_tf() {
    use polymap_io::log::{LogOptions, LogSource};
    use polymap_io::ros::mcap_file::McapCompression;
    use polymap_io::ros::{RecordOptions, write_mcap_with};

    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let o = polymap(&["simulate", "office", "--ros", "-o", d.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    let (mcap, truth) = (d.join("office.mcap"), d.join("office.truth.tum"));
    let (with_tf, summary) = ate_m(&mcap, &d.join("tf"), &truth, &[]);
    let tf = &summary["reader"]["tf"];
    assert_eq!(tf["base_frame"], "base_link", "{summary}");
    assert_eq!(tf["scans_mounted"], 1696, "{summary}");
    assert_eq!(
        tf["scans_without_mount"],
        serde_json::json!({}),
        "{summary}"
    );
    let (laser_as_robot, _) = ate_m(&mcap, &d.join("no-tf"), &truth, &["--base-frame", "laser"]);
    assert!(with_tf < 0.08, "ATE {with_tf} m with tf");
    assert!(
        laser_as_robot > 0.12 && laser_as_robot > 2.0 * with_tf,
        "ATE {laser_as_robot} m with the laser taken as the robot, {with_tf} m with tf"
    );
    // The same recording without /odom: --odometry tracks from tf's odom → base_link.
    let options = LogOptions {
        odometry: true,
        ..LogOptions::default()
    };
    let mut log = LogSource::open(&mcap, &options).unwrap();
    let mut scans = Vec::new();
    while let Some(s) = log.next_scan().unwrap() {
        scans.push(s);
    }
    let tf_only = d.join("tf-only.mcap");
    let options = RecordOptions {
        odometry_topic: false,
        tf: true,
    };
    write_mcap_with(&tf_only, &scans, McapCompression::Zstd, options).unwrap();
    let (odometry, summary) = ate_m(&tf_only, &d.join("odo"), &truth, &["--odometry"]);
    let tf = &summary["reader"]["tf"];
    assert_eq!(tf["odometry"], "prior", "{summary}");
    assert_eq!(tf["scans_with_odometry"], 1696, "{summary}");
    eprintln!(
        "ATE RMS: {with_tf:.4} m through tf, {laser_as_robot:.4} m with the laser as the robot, \
         {odometry:.4} m with --odometry from tf"
    );
    assert!(odometry < 0.08, "ATE {odometry} m with --odometry from tf");
}

/// A malformed tf message in a bag is skipped, counted and warned about naming the file and
/// the message, without --skip-bad-input; the run maps.
#[test]
fn a_malformed_tf_message_is_warned_about_and_skipped() {
    use polymap_io::carmen::{CarmenReader, ReaderOptions};
    use polymap_io::ros::ros1::{BagCompression, BagWriter};
    use polymap_io::ros::{Flavor, LaserScanMsg, RosTime, TfMessage, TransformStampedMsg};

    let dir = tempfile::tempdir().unwrap();
    simulate_ros(dir.path(), 180);
    let mut reader =
        CarmenReader::open(dir.path().join("hallway45.clf"), ReaderOptions::default()).unwrap();
    let path = dir.path().join("bad-tf.bag");
    let mut w = BagWriter::create(&path, BagCompression::Lz4).unwrap();
    let scan = w.add_connection("/scan", "sensor_msgs/LaserScan");
    let tf_static = w.add_connection("/tf_static", "tf2_msgs/TFMessage");
    let mut k = 0u32;
    while let (Some(s), true) = (reader.next_scan().unwrap(), k < 300) {
        let time = RosTime::from_stamp(&s.stamp).unwrap();
        if k == 0 {
            let t = TransformStampedMsg::from_pose(time, "base_link", "laser", &s.robot_from_laser);
            let good = TfMessage {
                transforms: vec![t],
            }
            .encode(Flavor::Ros1, 0);
            w.write(tf_static, time, &good).unwrap();
            w.write(tf_static, time, &good[..good.len() - 3]).unwrap();
        }
        let msg = LaserScanMsg::from_range_scan(&s, time, "laser");
        w.write(scan, time, &msg.encode(Flavor::Ros1, k)).unwrap();
        k += 1;
    }
    w.finish().unwrap();
    let out = dir.path().join("out");
    let o = map_quietly(&path, &out, &[]);
    assert!(o.status.success(), "{}", text(&o));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("1 tf message(s) did not decode and were skipped; first: ")
            && stderr.contains("bad-tf.bag: topic /tf_static, message 2 (byte "),
        "{stderr}"
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["reader"]["tf"]["bad_messages"], 1, "{summary}");
    assert_eq!(summary["reader"]["tf"]["scans_mounted"], 300, "{summary}");
}

/// The real Hokuyo bag: all 360 scans, stamps with nanoseconds, and a map that explains the
/// scans (a coherent picture: 99.5 % of 231,818 points within 10 cm of 17 segments, as measured).
#[test]
fn the_hokuyo_bag_maps_to_a_coherent_picture() {
    let Some(dir) = datasets() else {
        eprintln!("SKIPPED: ../shared/datasets is absent");
        return;
    };
    let bag = dir.join("ros/laser-only-hokuyo.bag");
    let out_dir = tempfile::tempdir().unwrap();
    let out = map_quietly(&bag, out_dir.path(), &[]);
    assert!(out.status.success(), "{}", text(&out));
    let tum = std::fs::read_to_string(out_dir.path().join("trajectory.tum")).unwrap();
    assert_eq!(tum.lines().count(), 360);
    assert!(tum.starts_with("1282836370.970876375 "), "{}", &tum[..40]);
    let eval = polymap(&[
        "eval",
        "map",
        out_dir.path().to_str().unwrap(),
        "--log",
        bag.to_str().unwrap(),
        "--json",
    ]);
    assert!(eval.status.success(), "{}", text(&eval));
    let v: serde_json::Value = serde_json::from_slice(&eval.stdout).unwrap();
    let share = v["points"]["share_within_loose"].as_f64().unwrap();
    assert!(
        share > 0.97,
        "only {share} of the points within 10 cm of the map"
    );
    let segments = v["segments"].as_u64().unwrap();
    assert!((8..60).contains(&segments), "{segments} segments");
}

#[test]
fn info_tells_topics_counts_and_laser_geometry() {
    let Some(dir) = datasets() else {
        eprintln!("SKIPPED: ../shared/datasets is absent");
        return;
    };
    let out = polymap(&[
        "info",
        dir.join("ros/laser-only-hokuyo.bag").to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out));
    let s = String::from_utf8(out.stdout).unwrap();
    assert!(s.contains("ROS 1 bag"), "{s}");
    assert!(
        s.contains("/scan  sensor_msgs/LaserScan  ros1  360 messages"),
        "{s}"
    );
    assert!(s.contains("681 beams over 239.4°"), "{s}");
    assert!(s.contains("range 0.02–5.6 m, 10.02 Hz"), "{s}");
    assert!(s.contains("odometry: none"), "{s}");
    assert!(s.contains("tf: none"), "{s}");
    let out = polymap(&[
        "info",
        dir.join("ros/rosbag2-conformance.db3").to_str().unwrap(),
    ]);
    let s = String::from_utf8(out.stdout).unwrap();
    assert!(s.contains("94 topics, 188 messages"), "{s}");
    assert!(
        s.contains("odometry: /test/nav_msgs/odometry (2 messages)"),
        "{s}"
    );
}

#[test]
fn info_describes_a_carmen_log_in_its_terms() {
    let dir = tempfile::tempdir().unwrap();
    simulate_ros(dir.path(), 360);
    let out = polymap(&["info", dir.path().join("hallway45.clf").to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out));
    let s = String::from_utf8(out.stdout).unwrap();
    assert!(s.contains("CARMEN log"), "{s}");
    assert!(s.contains("1553 scans"), "{s}");
    assert!(s.contains("laser: 360 beams"), "{s}");
    assert!(s.contains("360.0° covered"), "{s}");
}

/// A ROS recording's odometry witnesses the steps without `--odometry`: the simulated hallway
/// as MCAP, its odometry 0.5 m ahead on every 100th scan from the 300th, warns and counts the
/// steps off (two per spike), with the trajectory and map of the clean recording.
#[test]
fn a_spiked_ros_odometry_is_warned_without_changing_the_map() {
    use polymap::geometry::Pose2;
    use polymap_io::log::{LogOptions, LogSource};
    use polymap_io::ros::mcap_file::McapCompression;
    use polymap_io::ros::write_mcap;

    let dir = tempfile::tempdir().unwrap();
    simulate_ros(dir.path(), 180);
    // The recording's own scans, odometry and mounting (the CARMEN log holds the mounting to
    // its 6 decimals only).
    let options = LogOptions {
        odometry: true,
        ..LogOptions::default()
    };
    let mut reader = LogSource::open(&dir.path().join("hallway45.mcap"), &options).unwrap();
    let mut scans = Vec::new();
    while let Some(scan) = reader.next_scan().unwrap() {
        scans.push(scan);
    }
    for (k, scan) in scans.iter_mut().enumerate() {
        if k >= 300 && k % 100 == 0 {
            let o = scan.odom_from_robot.expect("the simulator writes odometry");
            scan.odom_from_robot = Some(Pose2::new(o.x_m + 0.5, o.y_m, o.theta_rad));
        }
    }
    let spiked = dir.path().join("spiked.mcap");
    write_mcap(&spiked, &scans, McapCompression::None).unwrap();
    let out = dir.path().join("out-spiked");
    let o = map_quietly(&spiked, &out, &[]);
    assert!(o.status.success(), "{}", text(&o));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("off the log's odometry"), "{stderr}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let off = summary["tracking"]["off_odometry"].as_u64().unwrap();
    assert_eq!(summary["reader"]["other_warnings"], serde_json::json!([]));
    let spikes = (300..scans.len()).step_by(100).count() as u64;
    assert!(
        off >= spikes && off <= 2 * spikes,
        "{off} steps off for {spikes} spikes"
    );
    let (clean_map, clean_trajectory) = map_outputs(dir.path(), "mcap", "clean", &[]);
    assert_eq!(std::fs::read(out.join("map.json")).unwrap(), clean_map);
    assert_eq!(
        std::fs::read(out.join("trajectory.tum")).unwrap(),
        clean_trajectory
    );
}
