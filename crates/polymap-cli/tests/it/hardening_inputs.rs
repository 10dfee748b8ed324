//! Hostile but realistic inputs to the newer surfaces: saved maps, run folders, ROS recordings,
//! endless inputs. Each ends with a clear error or a counted, warned skip, within seconds.

use std::fs;
use std::path::{Path, PathBuf};

use crate::support::{map_quietly, polymap, text};

/// A simulated office log in `dir`.
fn office_log(dir: &Path) -> PathBuf {
    let o = polymap(&["simulate", "office", "-o", dir.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    dir.join("office.clf")
}

/// The office's first 100 scans mapped into `dir/name`.
fn office_run(dir: &Path, name: &str) -> (PathBuf, PathBuf) {
    let log = office_log(dir);
    let run = dir.join(name);
    let o = map_quietly(&log, &run, &["--max-scans", "100"]);
    assert!(o.status.success(), "{}", text(&o));
    (log, run)
}

/// Every file of a folder with its bytes, for a before-and-after comparison.
fn contents(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut all: Vec<(String, Vec<u8>)> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, fs::read(&p).unwrap())
        })
        .collect();
    all.sort();
    all
}

/// Names in a folder that are temporary files of an atomic write.
fn temporaries(dir: &Path) -> Vec<String> {
    fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp-"))
        .collect()
}

/// `mkdir D/map.json; polymap map LOG -o D` failed at the rename and left `.map.json.tmp-PID`.
#[test]
fn a_folder_in_the_way_of_an_output_fails_the_run_without_a_temporary() {
    let dir = tempfile::tempdir().unwrap();
    let log = office_log(dir.path());
    let run = dir.path().join("run");
    fs::create_dir_all(run.join("map.json")).unwrap();
    let o = map_quietly(&log, &run, &["--max-scans", "20"]);
    assert!(!o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("map.json"), "{}", text(&o));
    assert_eq!(temporaries(&run), Vec::<String>::new());
}

/// `localize LOG --map S -o S` rewrote the saved map's trajectory, scan count and loop nodes;
/// `map --resume S -o S` and a rosbag2 folder as its own output are refused the same way,
/// and nothing in the input folder changes.
#[test]
fn an_output_folder_that_is_an_input_is_refused_by_every_command() {
    let dir = tempfile::tempdir().unwrap();
    let (log, saved) = office_run(dir.path(), "saved");
    let before = contents(&saved);
    let (l, s) = (log.to_str().unwrap(), saved.to_str().unwrap());
    let through_link = dir.path().join("link");
    std::os::unix::fs::symlink(&saved, &through_link).unwrap();
    let link = through_link.to_str().unwrap();
    let runs: [&[&str]; 4] = [
        &["localize", l, "--map", s, "-o", s, "-q"],
        &["localize", l, "--map", s, "-o", link, "-q"],
        &["map", l, "--resume", s, "-o", &format!("{s}/."), "-q"],
        &["merge", s, link, "-o", s, "-q"],
    ];
    for args in runs {
        let o = polymap(args);
        assert!(!o.status.success(), "{args:?}: {}", text(&o));
        assert!(
            text(&o).contains("the output folder is an input"),
            "{args:?}: {}",
            text(&o)
        );
        assert_eq!(contents(&saved), before, "{args:?} changed the input");
    }
}

/// Runs polymap with standard input from `stdin`.
fn polymap_with_stdin(args: &[&str], stdin: &Path) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_polymap"))
        .args(args)
        .stdin(fs::File::open(stdin).unwrap())
        .output()
        .expect("the polymap binary runs")
}

/// `polymap map /dev/zero` (and standard input from it) spun forever; `--config /dev/zero`
/// was read until memory ran out. Each now ends at once with an error saying what the input
/// is; a log on standard input still maps.
#[cfg(unix)]
#[test]
fn endless_inputs_are_refused_and_stdin_still_maps() {
    let dir = tempfile::tempdir().unwrap();
    let log = office_log(dir.path());
    let out = dir.path().join("out");
    let o = o_str(&out);
    let null = Path::new("/dev/null");
    let cases: [(&[&str], &Path, &str); 3] = [
        (
            &["map", "/dev/zero", "-o", o, "-q"],
            null,
            "a character device, not a log file",
        ),
        (
            &["map", "-", "-o", o, "-q"],
            Path::new("/dev/zero"),
            "longer than",
        ),
        (
            &["map", "-", "-o", o, "-q", "--skip-bad-input"],
            Path::new("/dev/zero"),
            "without an end: not a text log",
        ),
    ];
    for (args, stdin, message) in cases {
        let o = polymap_with_stdin(args, stdin);
        assert!(!o.status.success(), "{args:?}: {}", text(&o));
        assert!(text(&o).contains(message), "{args:?}: {}", text(&o));
    }
    let config = polymap(&["map", o_str(&log), "-o", o, "-q", "--config", "/dev/zero"]);
    assert!(!config.status.success());
    assert!(
        text(&config).contains("/dev/zero: cannot read: a character device"),
        "{}",
        text(&config)
    );
    let args = ["map", "-", "-o", o, "-q", "--max-scans", "30"];
    let stdin = polymap_with_stdin(&args, &log);
    assert!(stdin.status.success(), "{}", text(&stdin));
    assert_eq!(
        fs::read_to_string(out.join("trajectory.tum"))
            .unwrap()
            .lines()
            .count(),
        30
    );
}

fn o_str(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// An MCAP file of `n` scans of a 10 m circle on `topic`, in frame `frame`; `step` radians
/// between beams.
fn mcap_of(path: &Path, topic: &str, frame: &str, n: usize, step: f32) {
    use polymap_io::ros::mcap_file::{McapCompression, McapWriter};
    use polymap_io::ros::{Flavor, LaserScanMsg, RosTime};
    let mut w = McapWriter::create(path, McapCompression::None).unwrap();
    let channel = w.add_channel(topic, "sensor_msgs/msg/LaserScan").unwrap();
    for i in 0..n {
        let stamp = RosTime {
            sec: 100 + i as i64,
            nanosec: 0,
        };
        let msg = LaserScanMsg {
            stamp,
            frame_id: frame.into(),
            angle_min: 0.0,
            angle_max: step * 359.0,
            angle_increment: step,
            time_increment: 0.0,
            scan_time: 0.0,
            range_min: 0.0,
            range_max: 20.0,
            ranges: vec![10.0; 360],
            intensity_count: 0,
        };
        w.write(channel, stamp, &msg.encode(Flavor::CdrLittle, 0))
            .unwrap();
    }
    w.finish().unwrap();
}

/// `polymap info` printed raw escape bytes from topic and frame names.
#[test]
fn info_escapes_topic_and_frame_names() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("odd.mcap");
    mcap_of(&path, "/scan\x1b[2J", "laser\x1b]0;x\x07", 3, 0.0175);
    let o = polymap(&["info", path.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(!out.contains('\x1b') && !out.contains('\x07'), "{out:?}");
    assert!(out.contains("/scan\\x1b[2J"), "{out}");
}

/// A LaserScan whose beams span 361 rad mapped to an empty map with exit 0; a ROS file cut
/// inside its header, or one whose every scan is bad under `--skip-bad-input`, was reported
/// as a CARMEN log without FLASER lines.
#[test]
fn impossible_scans_and_cut_recordings_are_named_for_what_they_are() {
    let dir = tempfile::tempdir().unwrap();
    let wide = dir.path().join("wide.mcap");
    mcap_of(&wide, "/scan", "laser", 5, 361.0 / 359.0);
    let out = dir.path().join("out");
    let o = map_quietly(&wide, &out, &[]);
    assert!(!o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("more than a full turn"), "{}", text(&o));
    let o = map_quietly(&wide, &out, &["--skip-bad-input"]);
    assert!(!o.status.success(), "{}", text(&o));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("no laser scans (LaserScan messages on /scan) in 5 messages")
            && err.contains("5 bad messages skipped")
            && !err.contains("FLASER"),
        "{err}"
    );
    let cut = dir.path().join("cut.mcap");
    fs::write(&cut, &fs::read(&wide).unwrap()[..6]).unwrap();
    let o = map_quietly(&cut, &out, &[]);
    assert!(!o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("an MCAP file cut off: the file is 6 bytes"),
        "{}",
        text(&o)
    );
}

/// The office's map tiled `k` × `k` (its copies 40 m apart), as a saved map in `dir`.
fn tiled_map(from: &Path, dir: &Path, k: usize) {
    let map: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(from.join("map.json")).unwrap()).unwrap();
    let mut segments = Vec::new();
    for i in 0..k * k {
        let (dx, dy) = (40.0 * (i % k) as f64, 40.0 * (i / k) as f64);
        for s in map["segments"].as_array().unwrap() {
            let mut s = s.clone();
            for end in ["start", "end"] {
                let p = s[end].as_array().unwrap();
                let (x, y) = (p[0].as_f64().unwrap(), p[1].as_f64().unwrap());
                s[end] = serde_json::json!([x + dx, y + dy]);
            }
            segments.push(s);
        }
    }
    let mut tiled = map.clone();
    tiled["segments"] = serde_json::Value::Array(segments);
    tiled["polylines"] = serde_json::json!([]);
    fs::create_dir_all(dir).unwrap();
    fs::write(dir.join("map.json"), tiled.to_string()).unwrap();
}

/// A saved map is input like any other: one wall from (1e6, 1e6) to (-1e6, -1e6) made
/// `--resume`, `localize`, `eval map` and `merge` run for minutes, coordinates times 1e298
/// ended `merge` in a 16 GB allocation. Each command now refuses the file at once, naming it
/// and the segment. A map whose search for the log's start without `--initial-pose` is slow
/// warns with the cost; one where it would take minutes a scan is refused with the limit; both
/// map with `--initial-pose`.
#[test]
fn saved_maps_beyond_the_bounds_are_refused_and_wide_ones_warn() {
    let dir = tempfile::tempdir().unwrap();
    let (log, saved) = office_run(dir.path(), "saved");
    let json = fs::read_to_string(saved.join("map.json")).unwrap();
    let first = json.find("\"start\":[").unwrap();
    let cut = json.find("\"born_scan\"").unwrap();
    let wall = "\"start\":[1000000.0,1000000.0],\"end\":[-1000000.0,-1000000.0],";
    let hostile = dir.path().join("hostile");
    fs::create_dir_all(&hostile).unwrap();
    fs::write(
        hostile.join("map.json"),
        format!("{}{wall}{}", &json[..first], &json[cut..]),
    )
    .unwrap();
    let (l, h, s) = (o_str(&log), o_str(&hostile), o_str(&saved));
    let out = dir.path().join("out");
    let o = o_str(&out);
    let runs: [&[&str]; 4] = [
        &["map", l, "--resume", h, "-o", o, "-q"],
        &["localize", l, "--map", h, "-o", o, "-q"],
        &["eval", "map", h],
        &["merge", s, h, "-o", o, "-q"],
    ];
    for args in runs {
        let run = polymap(args);
        assert!(!run.status.success(), "{args:?}: {}", text(&run));
        assert!(
            text(&run).contains("map.json: segment 0 is 2828427.1 m long"),
            "{args:?}: {}",
            text(&run)
        );
    }
    // A map of about 340 m × 340 m: a search for the start over it would take minutes a scan.
    let vast = dir.path().join("vast");
    tiled_map(&saved, &vast, 9);
    let run = polymap(&["localize", l, "--map", o_str(&vast), "-o", o, "-q"]);
    assert!(!run.status.success(), "{}", text(&run));
    assert!(
        text(&run).contains("100000 m² a search for the log's start may cover")
            && text(&run).contains("--initial-pose"),
        "{}",
        text(&run)
    );
    // A map of about 8,000 m², a large building: searched, with a warning of the cost.
    let wide = dir.path().join("wide");
    tiled_map(&saved, &wide, 3);
    let run = polymap(&[
        "localize",
        l,
        "--map",
        o_str(&wide),
        "-o",
        o,
        "-q",
        "--max-scans",
        "2",
    ]);
    assert!(
        text(&run).contains("per scan until it is found") && !text(&run).contains("may cover"),
        "{}",
        text(&run)
    );
    let args = ["--max-scans", "20", "--initial-pose", "0,0,0"];
    let run = polymap(
        &[
            &["localize", l, "--map", o_str(&wide), "-o", o, "-q"][..],
            &args,
        ]
        .concat(),
    );
    assert!(run.status.success(), "{}", text(&run));
}

/// Runs polymap with an environment variable set.
fn polymap_with_env(args: &[&str], key: &str, value: &str) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_polymap"))
        .args(args)
        .env(key, value)
        .output()
        .expect("the polymap binary runs")
}

/// A run folder could mix two runs: a kill in the write phase left the new map.json beside the
/// old summary.json and loop_nodes.json, and --resume took it; after a full disk, `export`
/// built a report from the earlier run's history.json; two runs writing one folder both
/// succeeded. The manifest, written last, and the folder's lock now tie the files together.
#[test]
fn a_run_folder_mixing_two_runs_is_refused_and_a_folder_is_written_by_one_run() {
    let dir = tempfile::tempdir().unwrap();
    let (log, run) = office_run(dir.path(), "run");
    let (l, r) = (o_str(&log), o_str(&run));
    let other = dir.path().join("other");
    let manifest: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(run.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(manifest["complete"], true, "{manifest}");
    assert!(manifest["files"]["loop_nodes.json"]["crc32"].is_string());
    let readers = |what: &str| {
        let out = o_str(&other);
        let runs: [&[&str]; 4] = [
            &[
                "map",
                l,
                "--resume",
                r,
                "-o",
                out,
                "-q",
                "--max-scans",
                "10",
            ],
            &[
                "localize",
                l,
                "--map",
                r,
                "-o",
                out,
                "-q",
                "--max-scans",
                "10",
            ],
            &["merge", r, r, "-o", out, "-q"],
            &["export", r, "--format", "html"],
        ];
        for args in runs {
            let o = polymap(args);
            assert!(!o.status.success(), "{args:?}: {}", text(&o));
            assert!(text(&o).contains(what), "{args:?}: {}", text(&o));
        }
    };
    // Killed while writing summary.json: map.json and trajectory.tum are the new run's.
    let args = ["map", l, "-o", r, "-q", "--max-scans", "150"];
    let o = polymap_with_env(&args, "POLYMAP_TEST_FAULT", "summary.json:abort");
    assert!(!o.status.success());
    readers("did not finish writing it");
    // A full disk at history.json: the earlier run's history stays, and is not reported on.
    let o = polymap_with_env(&args, "POLYMAP_TEST_FAULT", "history.json:enospc");
    assert!(!o.status.success());
    readers("did not finish writing it");
    // A whole run, then another run's loop nodes copied in.
    let o = map_quietly(&log, &run, &["--max-scans", "150"]);
    assert!(o.status.success(), "{}", text(&o));
    let (_, earlier) = office_run(dir.path(), "earlier");
    fs::copy(earlier.join("loop_nodes.json"), run.join("loop_nodes.json")).unwrap();
    let o = polymap(&["localize", l, "--map", r, "-o", o_str(&other), "-q"]);
    assert!(!o.status.success());
    assert!(
        text(&o).contains("loop_nodes.json: not the file run")
            && text(&o).contains("mixes files of two runs"),
        "{}",
        text(&o)
    );
    // While a run writes a folder, another is refused before it maps.
    let lock = polymap_pipeline::manifest::FolderLock::exclusive(&run).unwrap();
    let o = map_quietly(&log, &run, &["--max-scans", "10"]);
    assert!(!o.status.success());
    assert!(
        text(&o).contains("another polymap run is writing this folder"),
        "{}",
        text(&o)
    );
    drop(lock);
    let o = map_quietly(&log, &run, &["--max-scans", "10"]);
    assert!(o.status.success(), "{}", text(&o));
    let o = polymap(&["export", r, "--format", "png"]);
    assert!(o.status.success(), "{}", text(&o));
    let manifest = fs::read_to_string(run.join("manifest.json")).unwrap();
    assert!(manifest.contains("map.png"), "{manifest}");
}
