//! `polymap ros2` against an independent DDS stack: Eclipse Cyclone DDS's Python binding
//! (`tests/ros2/ros2_peer.py`) plays recordings into the node and records what it publishes.
//! Every participant, on both sides, keeps to the loopback interface: the node by
//! `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`, Cyclone by a configuration naming `lo`, with
//! multicast off and unicast discovery to 127.0.0.1. Each test has a domain of its own.
//!
//! Without Python's `cyclonedds` and `rosbags` the tests skip with a message, except in CI
//! (`CI=true`), where they fail.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use polymap_io::log::{LogOptions, LogSource};
use polymap_io::ros::mcap_file::McapCompression;
use polymap_io::ros::write_mcap;
use serde_json::Value;

use crate::support::{polymap, text};

const CYCLONE_LOOPBACK: &str = "<CycloneDDS><Domain id=\"any\"><General><Interfaces>\
    <NetworkInterface name=\"lo\"/></Interfaces><AllowMulticast>false</AllowMulticast></General>\
    <Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>40\
    </MaxAutoParticipantIndex><Peers><Peer address=\"127.0.0.1\"/></Peers></Discovery></Domain>\
    </CycloneDDS>";

/// The DDS domain of test `k` (0..7): apart for each test, and for each test process, within
/// 0 to 101, whose ports Linux keeps out of its ephemeral range.
fn domain(k: u16) -> u16 {
    let slot = (std::process::id() % 13) as u16;
    10 + slot * 7 + k
}

fn peer_script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/ros2/ros2_peer.py")
}

/// True when `python3` has cyclonedds and rosbags; without them the test fails under CI and
/// skips with a message elsewhere.
fn peer_available() -> bool {
    let ok = Command::new("python3")
        .args(["-c", "import cyclonedds.domain, rosbags.highlevel"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "python3 cannot import cyclonedds and rosbags: CI=true requires them"
        );
        eprintln!(
            "SKIPPED: python3 cannot import cyclonedds and rosbags (pip install cyclonedds rosbags)"
        );
    }
    ok
}

/// A simulated world written as ROS recordings into `dir`; the MCAP file.
fn recording(dir: &Path, world: &str) -> PathBuf {
    let o = polymap(&["simulate", world, "--ros", "-o", dir.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    dir.join(format!("{world}.mcap"))
}

fn start_node(domain: u16, out: &Path, extra: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_polymap"))
        .args(["ros2", "-o", out.to_str().unwrap()])
        .args(extra)
        .env("ROS_DOMAIN_ID", domain.to_string())
        .env("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        .env_remove("ROS_LOCALHOST_ONLY")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("polymap ros2 starts")
}

fn peer_command(domain: u16, out: &Path, args: &[&str]) -> Command {
    let mut c = Command::new("python3");
    c.arg(peer_script())
        .args(["--out", out.to_str().unwrap()])
        .args(args)
        .env("ROS_DOMAIN_ID", domain.to_string())
        .env("CYCLONEDDS_URI", CYCLONE_LOOPBACK);
    c
}

/// Runs the peer to its end; what it recorded.
fn run_peer(domain: u16, dir: &Path, args: &[&str]) -> Value {
    let out = dir.join("peer.json");
    let o = peer_command(domain, &out, args)
        .output()
        .expect("python3 runs");
    assert!(o.status.success(), "the peer failed: {}", text(&o));
    serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap()
}

/// Sends `signal` (`INT`, `TERM`) to the node and waits for it to end (killed, and the test
/// failed, after two minutes).
fn stop_node(mut child: Child, signal: &str) -> Output {
    let status = Command::new("kill")
        .args([&format!("-{signal}"), &child.id().to_string()])
        .status()
        .expect("kill runs");
    assert!(status.success());
    let deadline = Instant::now() + Duration::from_secs(120);
    while child
        .try_wait()
        .expect("the node can be waited for")
        .is_none()
    {
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("the node did not end within two minutes of SIG{signal}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    child.wait_with_output().expect("the node's output")
}

fn summary(out: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap()
}

/// The tf edges the node published (the peer hears its own `odom → base_link` too).
fn node_tf_edges(got: &Value) -> Vec<String> {
    got["tf_edges"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|e| e.as_str().filter(|e| e.starts_with("map->")))
        .map(str::to_owned)
        .collect()
}

#[test]
fn a_recording_played_live_maps_as_the_recording_does_and_every_output_arrives() {
    if !peer_available() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let mcap = recording(dir.path(), "hallway45");
    let live = dir.path().join("live");
    // A queue that never fills, so that no scan is dropped however loaded the machine is.
    let node = start_node(
        domain(0),
        &live,
        &[
            "--odom-topic",
            "odom",
            "--map-period",
            "0.5",
            "--queue",
            "10000",
        ],
    );
    let got = run_peer(
        domain(0),
        dir.path(),
        &[
            "--recording",
            mcap.to_str().unwrap(),
            "--rate",
            "20",
            "--max-scans",
            "600",
        ],
    );
    let o = stop_node(node, "INT");
    assert!(
        o.status.success(),
        "SIGINT ends the node with 0: {}",
        text(&o)
    );
    assert_eq!(got["matched"], true);
    assert_eq!(got["sent_scans"], 600);
    let counts = &got["counts"];
    assert_eq!(counts["pose"], 600, "a pose per scan: {counts}");
    assert!(counts["tf"].as_u64().unwrap() >= 600, "{counts}");
    for topic in ["map", "segments", "status"] {
        assert!(counts[topic].as_u64().unwrap() >= 1, "{topic}: {counts}");
    }
    // The type names and QoS that RViz, Foxglove and Nav2 subscribe with.
    let pubs = &got["publications"];
    for (topic, ty, durability) in [
        (
            "rt/map",
            "nav_msgs::msg::dds_::OccupancyGrid_",
            "TransientLocal",
        ),
        ("rt/tf", "tf2_msgs::msg::dds_::TFMessage_", "Volatile"),
        (
            "rt/pose",
            "geometry_msgs::msg::dds_::PoseWithCovarianceStamped_",
            "Volatile",
        ),
        (
            "rt/polymap/segments",
            "visualization_msgs::msg::dds_::MarkerArray_",
            "TransientLocal",
        ),
        (
            "rt/polymap/status",
            "diagnostic_msgs::msg::dds_::DiagnosticArray_",
            "Volatile",
        ),
    ] {
        let p = &pubs[topic];
        assert_eq!(p["type"], ty, "{topic}: {pubs}");
        assert_eq!(p["reliability"], "Reliability.Reliable", "{topic}: {pubs}");
        assert_eq!(
            p["durability"],
            format!("Durability.{durability}"),
            "{topic}"
        );
    }
    // With odometry, map → odom (the recording's odometry frame), so map → odom → base chain.
    assert_eq!(node_tf_edges(&got), ["map->odom"]);
    assert_eq!(got["grid"]["frame"], "map");
    assert!(
        got["grid"]["occupied"].as_u64().unwrap() > 100,
        "{}",
        got["grid"]
    );
    assert!(got["markers"]["line_strips"].as_u64().unwrap() >= 1);
    assert_eq!(got["markers"]["first_action"], 3, "DELETEALL first");
    assert_eq!(got["status"]["name"], "polymap: tracking");
    let poses = got["poses"].as_array().unwrap();
    assert_eq!(poses[0]["frame"], "map");
    // The first scan's pose sets the map frame (no uncertainty); every later one rests on a fit.
    let cov_xx: Vec<f64> = poses
        .iter()
        .map(|p| p["cov_xx"].as_f64().unwrap())
        .collect();
    assert!(cov_xx[1..].iter().all(|&c| c > 0.0), "{cov_xx:?}");
    assert!(cov_xx[0] >= 0.0);

    // The run folder on SIGINT is `polymap map`'s on the same scans, pose for pose.
    let offline = dir.path().join("offline");
    let o = polymap(&[
        "map",
        mcap.to_str().unwrap(),
        "-o",
        offline.to_str().unwrap(),
        "-q",
        "--max-scans",
        "600",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let s = summary(&live);
    assert_eq!(s["live"]["dropped_scans"], 0, "{}", s["live"]);
    assert_eq!(
        std::fs::read_to_string(live.join("trajectory.tum")).unwrap(),
        std::fs::read_to_string(offline.join("trajectory.tum")).unwrap()
    );
    assert!(live.join("map.json").is_file() && live.join("map.svg").is_file());
    assert!(s["live"]["latency_ms"]["p99"].as_f64().unwrap() > 0.0);
}

#[test]
fn the_node_outlives_a_publisher_that_goes_and_comes_back_and_a_wrong_type_on_its_topic() {
    if !peer_available() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let mcap = recording(dir.path(), "hallway45");
    let live = dir.path().join("live");
    let node = start_node(domain(1), &live, &[]);
    let got = run_peer(
        domain(1),
        dir.path(),
        &[
            "--recording",
            mcap.to_str().unwrap(),
            "--rate",
            "20",
            "--max-scans",
            "300",
            "--pause-after",
            "150",
            "--pause-s",
            "1.5",
            "--wrong-type",
            "20",
            "--no-odometry",
            "--no-tf",
        ],
    );
    let o = stop_node(node, "TERM");
    assert!(
        o.status.success(),
        "SIGTERM ends the node with 0: {}",
        text(&o)
    );
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("a publisher of std_msgs/msg/String on scan is ignored"),
        "{stderr}"
    );
    // Without odometry and without tf, the scans' frame is the robot's: map → laser.
    assert_eq!(node_tf_edges(&got), ["map->laser"]);
    assert!(
        stderr.contains("no tf places the scans' frame laser on the robot"),
        "{stderr}"
    );
    let s = summary(&live);
    let l = &s["live"];
    let mapped = l["scans_mapped"].as_u64().unwrap();
    let dropped = l["dropped_scans"].as_u64().unwrap();
    let received = l["scan_messages"].as_u64().unwrap();
    // A new publisher's first scan may go before discovery joined it to the node (best
    // effort); on a loaded machine the full queue drops scans, counted. None is lost without
    // a count.
    assert!(received >= 295, "{l}");
    assert_eq!(received, mapped + dropped, "{l}");
    assert_eq!(
        got["counts"]["pose"].as_u64().unwrap(),
        mapped,
        "{}",
        got["counts"]
    );
    let trajectory = std::fs::read_to_string(live.join("trajectory.tum")).unwrap();
    assert_eq!(trajectory.lines().count() as u64, mapped);
}

#[test]
fn a_node_stopped_while_scans_stream_saves_every_scan_it_took_and_no_cut_file() {
    if !peer_available() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let mcap = recording(dir.path(), "hallway45");
    let live = dir.path().join("live");
    let node = start_node(domain(2), &live, &[]);
    let mut peer = peer_command(
        domain(2),
        &dir.path().join("peer.json"),
        &[
            "--recording",
            mcap.to_str().unwrap(),
            "--rate",
            "5",
            "--no-odometry",
        ],
    )
    .stdout(Stdio::null())
    .stderr(Stdio::null())
    .spawn()
    .unwrap();
    // Stopped while the scans still come (the peer needs 30 s for the whole recording).
    std::thread::sleep(Duration::from_secs(6));
    let o = stop_node(node, "TERM");
    let _ = peer.kill();
    let _ = peer.wait();
    assert!(o.status.success(), "{}", text(&o));
    let s = summary(&live);
    let mapped = s["live"]["scans_mapped"].as_u64().unwrap();
    assert!(mapped > 10, "{}", s["live"]);
    let lines = std::fs::read_to_string(live.join("trajectory.tum"))
        .unwrap()
        .lines()
        .count() as u64;
    assert_eq!(
        lines, mapped,
        "every scan handed to the mapper is in the trajectory"
    );
    // The folder is one run's: its manifest lists every file, whole.
    let o = polymap(&["export", live.to_str().unwrap(), "--format", "png"]);
    assert!(o.status.success(), "{}", text(&o));
}

#[test]
fn the_node_localizes_in_and_continues_a_saved_map_as_the_offline_commands_do() {
    if !peer_available() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let mcap = recording(dir.path(), "hallway45");
    let saved = dir.path().join("saved");
    let o = polymap(&[
        "map",
        mcap.to_str().unwrap(),
        "-o",
        saved.to_str().unwrap(),
        "-q",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    for (domain, flag, offline_cmd) in [
        (domain(3), "--localize", "localize"),
        (domain(4), "--resume", "map"),
    ] {
        let live = dir.path().join(format!("live{domain}"));
        // A queue that never fills: the comparison needs every scan, however loaded the
        // machine is.
        let node = start_node(
            domain,
            &live,
            &[flag, saved.to_str().unwrap(), "--queue", "10000"],
        );
        let got = run_peer(
            domain,
            dir.path(),
            &[
                "--recording",
                mcap.to_str().unwrap(),
                "--rate",
                "20",
                "--max-scans",
                "200",
                "--no-odometry",
            ],
        );
        let o = stop_node(node, "INT");
        assert!(o.status.success(), "{flag}: {}", text(&o));
        // No pose is published before the run is placed in the saved map (a few scans).
        let poses = got["counts"]["pose"].as_u64().unwrap();
        assert!((190..=200).contains(&poses), "{flag}: {poses} poses");
        let offline = dir.path().join(format!("offline{domain}"));
        let mut args = vec![
            offline_cmd,
            mcap.to_str().unwrap(),
            "-o",
            offline.to_str().unwrap(),
        ];
        args.extend(["-q", "--max-scans", "200", "--topic", "/scan"]);
        let saved_s = saved.to_str().unwrap();
        if offline_cmd == "localize" {
            args.extend(["--map", saved_s]);
        } else {
            args.extend(["--resume", saved_s]);
        }
        let o = polymap(&args);
        assert!(o.status.success(), "{}", text(&o));
        assert_eq!(
            std::fs::read_to_string(live.join("trajectory.tum")).unwrap(),
            std::fs::read_to_string(offline.join("trajectory.tum")).unwrap(),
            "{flag}"
        );
    }
}

#[test]
fn a_node_killed_mid_run_leaves_its_last_periodic_save_whole() {
    if !peer_available() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let mcap = recording(dir.path(), "hallway45");
    let live = dir.path().join("live");
    let mut node = start_node(domain(5), &live, &["--save-period", "1"]);
    let mut peer = peer_command(
        domain(5),
        &dir.path().join("peer.json"),
        &[
            "--recording",
            mcap.to_str().unwrap(),
            "--rate",
            "5",
            "--no-odometry",
        ],
    )
    .stdout(Stdio::null())
    .stderr(Stdio::null())
    .spawn()
    .unwrap();
    let deadline = Instant::now() + Duration::from_secs(60);
    while !live.join("summary.json").is_file() {
        assert!(
            Instant::now() < deadline,
            "no periodic save within a minute"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    std::thread::sleep(Duration::from_millis(2500));
    // A crash: no chance to save at the end.
    node.kill().unwrap();
    let _ = node.wait();
    let _ = peer.kill();
    let _ = peer.wait();
    let s = summary(&live);
    assert_eq!(s["checkpoint"], true, "{s}");
    let scans = s["scans"].as_u64().unwrap();
    assert!(scans > 10, "{s}");
    let lines = std::fs::read_to_string(live.join("trajectory.tum"))
        .unwrap()
        .lines()
        .count() as u64;
    assert_eq!(lines, scans);
    // Whole and usable: exported, and continued by a new run.
    let o = polymap(&[
        "export",
        live.to_str().unwrap(),
        "--format",
        "png",
        "--log",
        mcap.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let more = dir.path().join("more");
    let o = polymap(&[
        "map",
        mcap.to_str().unwrap(),
        "-o",
        more.to_str().unwrap(),
        "-q",
        "--resume",
        live.to_str().unwrap(),
        "--max-scans",
        "50",
    ]);
    assert!(o.status.success(), "{}", text(&o));
}

#[test]
fn the_real_hokuyo_bag_played_at_five_times_real_time_maps_as_the_bag_does() {
    let Some(datasets) = crate::support::datasets() else {
        eprintln!("SKIPPED: ../shared/datasets is absent");
        return;
    };
    if !peer_available() {
        return;
    }
    let bag = datasets.join("ros/laser-only-hokuyo.bag");
    let dir = tempfile::tempdir().unwrap();
    // The bag's damaged index stops Python's rosbags; the peer plays its scans from an MCAP
    // file written by polymap's own reader (all 360 scans, as recorded).
    let mcap = dir.path().join("hokuyo.mcap");
    let mut source = LogSource::open(&bag, &LogOptions::default()).unwrap();
    let mut scans = Vec::new();
    while let Some(scan) = source.next_scan().unwrap() {
        scans.push(scan);
    }
    assert_eq!(scans.len(), 360);
    write_mcap(&mcap, &scans, McapCompression::None).unwrap();
    let live = dir.path().join("live");
    let node = start_node(domain(6), &live, &["--queue", "10000"]);
    let got = run_peer(
        domain(6),
        dir.path(),
        &["--recording", mcap.to_str().unwrap(), "--rate", "5"],
    );
    let o = stop_node(node, "INT");
    assert!(o.status.success(), "{}", text(&o));
    let sent = got["sent_scans"].as_u64().unwrap();
    assert_eq!(sent, 360);
    assert_eq!(got["counts"]["pose"].as_u64().unwrap(), sent);
    // The bag has no tf: the laser's frame is the robot's, said once.
    assert_eq!(node_tf_edges(&got), ["map->laser"]);
    let offline = dir.path().join("offline");
    let n = sent.to_string();
    let o = polymap(&[
        "map",
        bag.to_str().unwrap(),
        "-o",
        offline.to_str().unwrap(),
        "-q",
        "--max-scans",
        &n,
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(
        std::fs::read_to_string(live.join("trajectory.tum")).unwrap(),
        std::fs::read_to_string(offline.join("trajectory.tum")).unwrap()
    );
}
