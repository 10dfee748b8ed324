//! The command-line contract of ARCHITECTURE.md: files written, exit status, errors.

use std::fs;

use crate::support::{map_quietly, polymap, text};

#[test]
fn map_without_a_log_maps_the_built_in_world_and_writes_the_contract() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let o = polymap(&["map", "-o", out.to_str().unwrap(), "--quiet"]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("hallway45"),
        "says which world: {}",
        text(&o)
    );
    for f in ["map.json", "trajectory.tum", "map.svg", "summary.json"] {
        assert!(out.join(f).is_file(), "{f} written");
    }
    let summary: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    for key in [
        "scans",
        "points",
        "segments",
        "polylines",
        "elapsed_s",
        "scans_per_s",
        "config",
    ] {
        assert!(summary.get(key).is_some(), "summary has {key}");
    }
    let map = polymap_io::map_json::read_map_json(out.join("map.json")).unwrap();
    assert_eq!(
        map.segments.len() as u64,
        summary["segments"].as_u64().unwrap()
    );
    let traj = polymap_io::tum::read_tum(out.join("trajectory.tum")).unwrap();
    assert_eq!(traj.len() as u64, summary["scans"].as_u64().unwrap());
    assert_eq!(
        traj[0].stamp.text, "1000000000.000000",
        "stamps are the log's own text"
    );
    assert!(roxmltree::Document::parse(&fs::read_to_string(out.join("map.svg")).unwrap()).is_ok());
}

#[test]
fn a_truncated_line_is_an_error_naming_file_and_line_unless_skipped() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("bad.clf");
    let good = format!(
        "FLASER 180 {} 0 0 0 0 0 0 1.5 host 1.5\n",
        vec!["2.0"; 180].join(" ")
    );
    fs::write(&log, format!("{good}{good}FLASER 180 2.0 2.0\n{good}")).unwrap();
    let out = dir.path().join("run");
    let o = map_quietly(&log, &out, &[]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("bad.clf:3"), "names file and line: {err}");
    assert_eq!(err.trim().lines().count(), 1, "one line: {err}");
    // Without -q: the summary line (-q prints nothing on success).
    let o = polymap(&[
        "map",
        log.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--skip-bad-lines",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("skipped 1 malformed line"),
        "{}",
        text(&o)
    );
    assert!(
        String::from_utf8_lossy(&o.stdout).starts_with("3 scans"),
        "{}",
        text(&o)
    );
}

#[test]
fn a_missing_log_and_an_unknown_preset_are_clear_errors() {
    let o = polymap(&[
        "map",
        "/nonexistent/log.clf",
        "-o",
        "/tmp/polymap-never",
        "-q",
    ]);
    assert!(
        !o.status.success() && String::from_utf8_lossy(&o.stderr).contains("/nonexistent/log.clf"),
        "{}",
        text(&o)
    );
    let o = polymap(&["map", "--preset", "fastest", "--print-config"]);
    assert!(
        !o.status.success() && String::from_utf8_lossy(&o.stderr).contains("unknown preset"),
        "{}",
        text(&o)
    );
}

#[test]
fn printed_config_reads_back_as_the_same_config() {
    let dir = tempfile::tempdir().unwrap();
    for preset in ["default", "paper"] {
        let o = polymap(&["map", "--preset", preset, "--print-config"]);
        assert!(o.status.success(), "{}", text(&o));
        let path = dir.path().join(format!("{preset}.toml"));
        fs::write(&path, &o.stdout).unwrap();
        let again = polymap(&["map", "--config", path.to_str().unwrap(), "--print-config"]);
        assert_eq!(
            String::from_utf8_lossy(&again.stdout),
            String::from_utf8_lossy(&o.stdout),
            "{preset} round trip"
        );
    }
}

#[test]
fn simulate_writes_a_log_that_maps_and_evaluates() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    let o = polymap(&["simulate", "hex60", "-o", d]);
    assert!(o.status.success(), "{}", text(&o));
    let run = format!("{d}/run");
    let o = polymap(&["map", &format!("{d}/hex60.clf"), "-o", &run, "-q"]);
    assert!(o.status.success(), "{}", text(&o));
    let o = polymap(&[
        "eval",
        "trajectory",
        &format!("{run}/trajectory.tum"),
        &format!("{d}/hex60.truth.tum"),
        "--json",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(
        v["associated"].as_u64(),
        v["truth_poses"].as_u64(),
        "every pose matched by stamp"
    );
    let o = polymap(&[
        "eval",
        "map",
        &run,
        "--walls",
        &format!("{d}/hex60.walls.json"),
        "--log",
        &format!("{d}/hex60.clf"),
    ]);
    assert!(
        o.status.success() && String::from_utf8_lossy(&o.stdout).contains("precision"),
        "{}",
        text(&o)
    );
}

#[test]
fn exports_are_written_during_mapping_and_again_from_a_finished_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    assert!(polymap(&["simulate", "office", "-o", d]).status.success());
    let run = format!("{d}/run");
    let o = polymap(&[
        "map",
        &format!("{d}/office.clf"),
        "-o",
        &run,
        "-q",
        "--max-scans",
        "300",
        "--export",
        "png,html,pgm,dxf",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    for f in [
        "map.png",
        "report.html",
        "map.pgm",
        "map.yaml",
        "map.dxf",
        "history.json",
    ] {
        assert!(std::path::Path::new(&run).join(f).is_file(), "{f} written");
    }
    let yaml = fs::read_to_string(format!("{run}/map.yaml")).unwrap();
    assert!(
        yaml.contains("resolution: 0.05") && yaml.contains("image: map.pgm"),
        "{yaml}"
    );
    for f in ["map.png", "report.html", "map.pgm", "map.dxf"] {
        fs::remove_file(format!("{run}/{f}")).unwrap();
    }
    let o = polymap(&[
        "export",
        &run,
        "--format",
        "png,html,pgm,dxf",
        "--resolution",
        "0.1",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    for f in ["map.png", "report.html", "map.pgm", "map.dxf"] {
        assert!(
            std::path::Path::new(&run).join(f).is_file(),
            "{f} re-exported"
        );
    }
    assert!(
        fs::read_to_string(format!("{run}/map.yaml"))
            .unwrap()
            .contains("resolution: 0.1")
    );
}

/// A closed standard output (`polymap … | head`) ends the output quietly, without a panic
/// ("failed printing to stdout: Broken pipe").
#[test]
fn closed_stdout_does_not_panic() {
    let dir = tempfile::tempdir().unwrap();
    let script = format!(
        "set -o pipefail; {bin} simulate hex60 -o {d} | (exec 0<&-; sleep 0.2); {bin} map {d}/hex60.clf -o {d}/run -q --max-scans 50 | (exec 0<&-; sleep 0.2)",
        bin = env!("CARGO_BIN_EXE_polymap"),
        d = dir.path().display()
    );
    let o = std::process::Command::new("bash")
        .arg("-c")
        .arg(&script)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        !String::from_utf8_lossy(&o.stderr).contains("panicked"),
        "{}",
        text(&o)
    );
}

#[test]
fn a_log_without_scans_is_an_error_and_one_without_returns_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("odometry-only.clf");
    fs::write(
        &log,
        "# a log\nODOM 0 0 0 0 0 0 1.0 host 1.0\nSYNC x 1.0 host 1.0\n",
    )
    .unwrap();
    let out = dir.path().join("run");
    let o = map_quietly(&log, &out, &[]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("odometry-only.clf: no laser scans") && err.contains("1 SYNC"),
        "{err}"
    );
    assert!(
        !out.join("map.json").exists(),
        "no outputs for a failed run"
    );
    let nans = dir.path().join("nans.clf");
    fs::write(
        &nans,
        format!(
            "FLASER 180 {} 0 0 0 0 0 0 1.5 host 1.5\n",
            vec!["nan"; 180].join(" ")
        ),
    )
    .unwrap();
    let o = map_quietly(&nans, &out, &[]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("none of the 1 scans has a valid return"),
        "{}",
        text(&o)
    );
}

/// Export and eval check that a trajectory matches the log before pairing its poses with the
/// log's scans: a trajectory that does not match is an error, not paired by position in
/// silence.
#[test]
fn a_trajectory_that_does_not_match_the_log_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    assert!(polymap(&["simulate", "office", "-o", d]).status.success());
    let run = format!("{d}/run");
    assert!(
        polymap(&[
            "map",
            &format!("{d}/office.clf"),
            "-o",
            &run,
            "-q",
            "--max-scans",
            "200"
        ])
        .status
        .success()
    );
    // A prefix of the log is fine (a run cut short), and said so.
    let o = polymap(&["export", &run, "--format", "pgm"]);
    assert!(
        o.status.success() && String::from_utf8_lossy(&o.stderr).contains("first 200 scans"),
        "{}",
        text(&o)
    );
    // Another log's trajectory (stamps changed) is refused by both commands.
    let traj = format!("{run}/trajectory.tum");
    let shifted: String = fs::read_to_string(&traj)
        .unwrap()
        .lines()
        .map(|l| format!("9{l}\n"))
        .collect();
    fs::write(&traj, shifted).unwrap();
    // The run's manifest says the trajectory is not the run's...
    let o = polymap(&["export", &run, "--format", "pgm"]);
    assert!(
        !o.status.success()
            && String::from_utf8_lossy(&o.stderr).contains("trajectory.tum: not the file run"),
        "{}",
        text(&o)
    );
    // ...and without the manifest (a folder edited by hand) the stamps still tell.
    fs::remove_file(format!("{run}/manifest.json")).unwrap();
    let o = polymap(&["export", &run, "--format", "pgm"]);
    assert!(
        !o.status.success()
            && String::from_utf8_lossy(&o.stderr).contains("not this log's trajectory"),
        "{}",
        text(&o)
    );
    let o = polymap(&["eval", "map", &run, "--log", &format!("{d}/office.clf")]);
    assert!(
        !o.status.success() && String::from_utf8_lossy(&o.stderr).contains("has stamp"),
        "{}",
        text(&o)
    );
}

/// --config is laid over the preset (it does not replace it), and bad values are refused.
#[test]
fn a_config_file_is_laid_over_the_preset_and_bad_values_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let partial = dir.path().join("partial.toml");
    fs::write(&partial, "[merge]\nk = 2.0\n").unwrap();
    let o = polymap(&[
        "map",
        "--preset",
        "paper",
        "--config",
        partial.to_str().unwrap(),
        "--print-config",
    ]);
    let printed = String::from_utf8_lossy(&o.stdout);
    assert!(
        printed.contains("k = 2.0") && printed.contains("method = \"endpoints\""),
        "{printed}"
    );
    // Repeated files are laid over each other in order.
    let later = dir.path().join("later.toml");
    fs::write(&later, "[merge]\nk = 3.0\n[align]\nmax_iterations = 7\n").unwrap();
    let o = polymap(&[
        "map",
        "--config",
        partial.to_str().unwrap(),
        "--config",
        later.to_str().unwrap(),
        "--print-config",
    ]);
    let printed = String::from_utf8_lossy(&o.stdout);
    assert!(
        printed.contains("k = 3.0") && printed.contains("max_iterations = 7"),
        "{printed}"
    );
    fs::write(&partial, "[directions]\nbins = 0\n").unwrap();
    let o = polymap(&[
        "map",
        "--config",
        partial.to_str().unwrap(),
        "--print-config",
    ]);
    assert!(
        !o.status.success() && String::from_utf8_lossy(&o.stderr).contains("directions.bins"),
        "{}",
        text(&o)
    );
    assert!(
        !polymap(&["map", "--max-scans", "0", "--print-config"])
            .status
            .success()
    );
}

/// The simulated corridor's bare middle ends the run with the weak-stretch warning naming its
/// scans, listed in `summary.json` and shaded on `report.html` (from `history.json`); the
/// office, observable throughout, has none.
#[test]
fn a_bare_corridor_is_warned_of_as_weak_stretches() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    for (world, stretches) in [("corridor", true), ("office", false)] {
        assert!(polymap(&["simulate", world, "-o", d]).status.success());
        let run = format!("{d}/{world}-run");
        let log = format!("{d}/{world}.clf");
        let o = polymap(&["map", &log, "-o", &run, "-q", "--export", "html"]);
        assert!(o.status.success(), "{}", text(&o));
        let warned = String::from_utf8_lossy(&o.stderr).contains("weak for 2 stretch(es)");
        let summary: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(format!("{run}/summary.json")).unwrap())
                .unwrap();
        let listed = summary["tracking"]["weak_stretches"].as_array().unwrap();
        let history: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(format!("{run}/history.json")).unwrap())
                .unwrap();
        let shaded = history["weak_stretches"].as_array().unwrap();
        assert_eq!(warned, stretches, "{world}: {}", text(&o));
        assert_eq!(
            listed.len(),
            if stretches { 2 } else { 0 },
            "{world}: {listed:?}"
        );
        assert_eq!(shaded.len(), listed.len(), "{world}: {shaded:?}");
        for (w, s) in listed.iter().zip(shaded) {
            assert!(w["travel_m"].as_f64().unwrap() >= 10.0, "{w}");
            assert_eq!((&w["first"], &w["last"]), (&s[0], &s[1]));
        }
    }
}

/// With `--diagnostics`, each tracked scan's line holds every pose tracking tried for it
/// (`tries`: where ICP converged, its inliers and correspondences), the pose taken among them,
/// which `scripts/tries` compares with a reference.
#[test]
fn diagnostics_hold_the_poses_tracking_tried_for_each_scan() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let o = polymap(&[
        "map",
        "--max-scans",
        "80",
        "--diagnostics",
        "-o",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let text = fs::read_to_string(out.join("diagnostics.jsonl")).unwrap();
    let mut tracked = 0;
    for line in text.lines().skip(1) {
        let row: serde_json::Value = serde_json::from_str(line).unwrap();
        let d = &row["diagnostics"];
        let taken = &d["align"]["map_from_robot"];
        let tries = d["tries"].as_array().expect("tries on a tracked scan");
        assert!(
            tries.iter().any(|t| &t["map_from_robot"] == taken),
            "{line}"
        );
        for t in tries {
            let inliers = t["inliers"].as_u64().expect("inliers");
            let correspondences = t["correspondences"].as_u64().expect("correspondences");
            assert!(inliers <= correspondences, "{line}");
        }
        tracked += 1;
    }
    assert_eq!(tracked, 79);
}
