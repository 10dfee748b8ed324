//! Regression checks on the real logs, when `../shared/datasets` is present (skipped with a
//! visible message otherwise). Short prefixes, and a few whole logs that the release build
//! maps in seconds (the CI runs it); sweeps over many runs are benchmarks (`scripts/sweep`).

use std::path::Path;

use polymap::config::Config;
use polymap::mapper::Mapper;
use polymap_io::carmen::{CarmenReader, ReaderOptions};

use crate::support::{datasets, map_quietly, polymap, text};

/// Maps `log` into `out` (quietly, with `extra` arguments), which must succeed: its standard
/// error and its summary.json.
fn map_with_summary(log: &Path, out: &Path, extra: &[&str]) -> (String, serde_json::Value) {
    let o = map_quietly(log, out, extra);
    assert!(o.status.success(), "{}", text(&o));
    let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
    (
        String::from_utf8_lossy(&o.stderr).into_owned(),
        serde_json::from_str(&summary).unwrap(),
    )
}

/// Intel's first 150 scans are taken standing still in a corridor. A constant-velocity guess
/// can turn ICP's drift along the corridor into a 47 m slide. A person walking by moves the
/// estimate a few centimetres (6.7 cm at scan 22); 15 cm catches any slide.
#[test]
fn intel_stationary_start_does_not_slide() {
    let Some(dir) = datasets() else {
        eprintln!("SKIPPED: ../shared/datasets is absent");
        return;
    };
    let mut reader =
        CarmenReader::open(dir.join("intel/intel.clf"), ReaderOptions::default()).unwrap();
    let mut mapper = Mapper::new(Config::default());
    for _ in 0..140 {
        let scan = reader.next_scan().unwrap().unwrap();
        let u = mapper.push(&scan);
        let moved = u.map_from_robot.translation().length();
        assert!(
            moved < 0.15,
            "scan {}: {moved} m from the start while standing still",
            u.scan_index
        );
    }
}

/// ACES every 10th scan (phase 1) comes out 27 m off the dense run, its corridors tracked
/// short after stops: the run must say so through the log's odometry witness, while the dense
/// run, which tracks, must not. Whole logs, release builds: about 3 s.
#[test]
fn a_sparse_aces_run_that_breaks_is_told_by_the_odometry_and_the_dense_one_is_not() {
    let Some(dir) = datasets() else {
        eprintln!("SKIPPED: ../shared/datasets is absent");
        return;
    };
    let log = dir.join("aces/aces.clf");
    let out = tempfile::tempdir().unwrap();
    let run = |name: &str, extra: &[&str]| map_with_summary(&log, &out.path().join(name), extra);
    let (stderr, summary) = run("sparse", &["--every", "10", "--every-offset", "1"]);
    assert!(stderr.contains("off the log's odometry"), "{stderr}");
    let scans = summary["scans"].as_u64().unwrap();
    let off = summary["tracking"]["off_odometry"].as_u64().unwrap();
    assert!(
        off * 100 > 3 * scans,
        "{off} of {scans} steps off the odometry"
    );
    let (stderr, summary) = run("dense", &[]);
    assert!(!stderr.contains("off the log's odometry"), "{stderr}");
    assert_eq!(summary["tracking"]["off_odometry"], 0);
}

/// Intel with the laser cut to 5.6 m drifts through many slightly short steps observed by few
/// points along the corridors (0.28 m mean relation error against 0.026 m with the whole
/// range), no run of weak scans reaching 10 m: the run must say so by its weakly observed
/// travel, while the run with the whole range must not. Whole log twice, release build: about
/// 10 s.
#[test]
fn intel_with_a_short_laser_warns_of_its_weakly_observed_travel_and_the_full_laser_does_not() {
    let Some(dir) = datasets() else {
        eprintln!("SKIPPED: ../shared/datasets is absent");
        return;
    };
    let log = dir.join("intel/intel.clf");
    let out = tempfile::tempdir().unwrap();
    let short = out.path().join("short.toml");
    std::fs::write(&short, "[extract]\nmax_range_m = 5.6\n").unwrap();
    let run = |name: &str, extra: &[&str]| {
        let (stderr, summary) = map_with_summary(&log, &out.path().join(name), extra);
        let t = summary["tracking"].clone();
        let share = t["weak_travel_m"].as_f64().unwrap() / t["travel_m"].as_f64().unwrap();
        (stderr, share, t)
    };
    let warning = "of the travel";
    let (stderr, share, t) = run("short", &["--config", short.to_str().unwrap()]);
    assert!(stderr.contains(warning), "{stderr}");
    assert!(share > 0.1, "{share}");
    assert!(
        !t["weak_travel_parts"].as_array().unwrap().is_empty(),
        "{t}"
    );
    let (stderr, share, _) = run("full", &[]);
    assert!(!stderr.contains(warning), "{stderr}");
    assert!(share < 0.05, "{share}");
}

/// FR079 with the laser cut to 5.6 m stalls at scans 4797-4815: 19 steps tracked at -0.10 to
/// +0.07 m where the robot drove 0.11 m a scan, each `ok` (7-15 points' worth along the
/// corridor, door frames matched a frame off) and each under the 0.3 m the odometry witness
/// needs; the run comes out 0.127 m off (0.038 m with the whole range). The run must name the
/// stall by the tracked steps against the log's odometry over metres, and the run with the
/// whole range must name none. Whole log twice, release build: about 8 s.
#[test]
fn fr079_with_a_short_laser_names_where_it_stalled_against_the_odometry() {
    let Some(dir) = datasets() else {
        eprintln!("SKIPPED: ../shared/datasets is absent");
        return;
    };
    let log = dir.join("fr079/fr079.clf");
    let out = tempfile::tempdir().unwrap();
    let short = out.path().join("short.toml");
    std::fs::write(&short, "[extract]\nmax_range_m = 5.6\n").unwrap();
    let warning = "fell short of the log's odometry";
    let run = |name: &str, extra: &[&str]| map_with_summary(&log, &out.path().join(name), extra);
    let (stderr, summary) = run("short", &["--config", short.to_str().unwrap()]);
    assert!(stderr.contains(warning), "{stderr}");
    let stretches = summary["tracking"]["short_of_odometry"].as_array().unwrap();
    let stall = stretches.iter().find(|s| {
        let first = s["first"].as_u64().unwrap();
        let last = s["last"].as_u64().unwrap();
        first <= 4805 && last >= 4805
    });
    assert!(stall.is_some(), "{stretches:?}");
    let (stderr, summary) = run("full", &[]);
    assert!(!stderr.contains(warning), "{stderr}");
    assert_eq!(
        summary["tracking"]["short_of_odometry"],
        serde_json::json!([])
    );
}

/// Intel every 5th scan, phase 1, under a nuisance variant of the thinning (0.051 m between
/// points, 43 rotation search points) ends 0.38 m off, most of it in the relations that reach
/// its last stretch (kept scans from 2400 on: 6 relations, 1.75 m and more, 0.02-0.05 m over
/// the others). Walls placed there stand where the scans before saw free space, and no later
/// scan is there to see through them (the running seen-through share 5.6 %); the only other
/// warning that names scans names three lost before it (2032, 2300-2301). Cast again at their
/// final poses, the run's scans see through the finished map's walls 6.6 % as often as they
/// see them: the run must warn and name scans of that stretch (a range ending in kept scans
/// 2540-2725, the last). The same phase under the default thinning (0.043 m off) must not
/// (1.3 %). Two runs, release build: about 4 s.
#[test]
fn intel_every_fifth_scan_names_walls_placed_late_across_rooms_passed_before() {
    let Some(dir) = datasets() else {
        eprintln!("SKIPPED: ../shared/datasets is absent");
        return;
    };
    let log = dir.join("intel/intel.clf");
    let out = tempfile::tempdir().unwrap();
    let variant = out.path().join("variant.toml");
    std::fs::write(
        &variant,
        "[align]\npoint_spacing_m = 0.051\nrotation_search_points = 43\n",
    )
    .unwrap();
    let warning = "cast again at their final poses";
    let every = ["--every", "5", "--every-offset", "1"];
    let run = |name: &str, extra: &[&str]| {
        let args: Vec<&str> = every.iter().chain(extra).copied().collect();
        map_with_summary(&log, &out.path().join(name), &args)
    };
    let (stderr, summary) = run("variant", &["--config", variant.to_str().unwrap()]);
    assert!(stderr.contains(warning), "{stderr}");
    let consistency = &summary["map_consistency"];
    assert_eq!(consistency["walls_seen_through"], true, "{consistency}");
    let named = consistency["seen_through_scans"].as_array().unwrap();
    let late = named.iter().any(|r| {
        let last = r[1].as_u64().unwrap();
        (2540..=2725).contains(&last)
    });
    assert!(late, "{named:?}");
    let (stderr, summary) = run("default", &[]);
    assert!(!stderr.contains(warning), "{stderr}");
    assert_eq!(summary["map_consistency"]["walls_seen_through"], false);
}

/// Intel every 5th scan, phase 4, under a nuisance variant of the thinning (0.054 m between
/// points, 44 rotation search points): the robot spins on the spot at about 25° per kept scan.
/// At kept scan 2502 the tracked turn must be within 10° of the log's odometry (27°: over one
/// step of a spin on the spot the odometry's turn is good to a degree or two). The case of
/// `rival_fits_better`: a first pose there that turned 0.2°, a poor fit (44 % of the points),
/// where ICP from the window search's rival turned 32° and fitted 60 %. Tracking as it is takes
/// the turn at once (one ICP run, 80 % of the points): this test guards the case, and
/// `a_rival_that_fits_clearly_more_points_replaces_the_mirror_image` the rule. The run as a
/// whole is broken by other spins (0.40 m): this checks the one step. Whole log, release
/// build: about 2 s.
#[test]
fn intel_every_fifth_scan_tracks_a_spins_turn() {
    let Some(dir) = datasets() else {
        eprintln!("SKIPPED: ../shared/datasets is absent");
        return;
    };
    let out = tempfile::tempdir().unwrap();
    let config = out.path().join("variant.toml");
    std::fs::write(
        &config,
        "[align]\npoint_spacing_m = 0.051\nrotation_search_points = 43\n",
    )
    .unwrap();
    let log = dir.join("intel").join("intel.clf");
    let run = out.path().join("run");
    let o = map_quietly(
        &log,
        &run,
        &[
            "--every",
            "5",
            "--every-offset",
            "4",
            "--config",
            config.to_str().unwrap(),
            "--diagnostics",
        ],
    );
    assert!(o.status.success(), "{}", text(&o));
    let heading = |scan: u64| -> f64 {
        let diagnostics = std::fs::read_to_string(run.join("diagnostics.jsonl")).unwrap();
        let line = diagnostics
            .lines()
            .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
            .find(|v| v["scan"] == scan)
            .expect("the scan's diagnostics");
        line["pose"]["theta_rad"].as_f64().unwrap()
    };
    // Kept scan `t` is the log's FLASER line 4 + 5 t (from 0); its odometry heading follows
    // the ranges, x and y.
    let clf = std::fs::read_to_string(&log).unwrap();
    let flaser: Vec<&str> = clf.lines().filter(|l| l.starts_with("FLASER ")).collect();
    let odometry_heading = |scan: usize| -> f64 {
        let fields: Vec<&str> = flaser[4 + 5 * scan].split_whitespace().collect();
        let n: usize = fields[1].parse().unwrap();
        fields[2 + n + 2].parse().unwrap()
    };
    let turn = |a: f64, b: f64| polymap::geometry::normalize_angle_rad(b - a).to_degrees();
    let tracked = turn(heading(2501), heading(2502));
    let odometry = turn(odometry_heading(2501), odometry_heading(2502));
    eprintln!("kept scans 2501-2502: tracked turn {tracked:.1}°, odometry {odometry:.1}°");
    assert!(odometry > 20.0, "not the spin: {odometry:.1}°");
    assert!(
        (tracked - odometry).abs() < 10.0,
        "{tracked:.1}° against {odometry:.1}°"
    );
}

/// FR079 every 3rd scan seen by a short-range laser (returns beyond 5.6 m dropped, as a
/// Hokuyo URG-04LX's would be): in a corridor whose far walls are out of range, a few points
/// put five steps 0.2-0.4 m back where the robot drove 0.3 m on, each `weakly_observed`, and
/// the map would come out 1.09 m off with no warning. A step back against the speed last
/// observed is checked along the weak axis as a stop is (0.21 m). The run stays right (0.06 m)
/// without that check ever acting (other rules keep it): this test guards the case, and `a_fast_robot_icp_stops_on_weak_evidence_is_checked_along_the_axis` the check.
/// Whole log, release build: about 2 s.
#[test]
fn fr079_every_third_scan_with_a_short_range_laser_does_not_back_on_weak_evidence() {
    let Some(dir) = datasets() else {
        eprintln!("SKIPPED: ../shared/datasets is absent");
        return;
    };
    let out = tempfile::tempdir().unwrap();
    let log = out.path().join("fr079-short.clf");
    let clf = std::fs::read_to_string(dir.join("fr079").join("fr079.clf")).unwrap();
    let mut short = String::with_capacity(clf.len());
    for line in clf.lines() {
        let mut fields: Vec<String> = line.split_whitespace().map(str::to_owned).collect();
        if fields.first().map(String::as_str) == Some("FLASER") {
            let n: usize = fields[1].parse().unwrap();
            for r in &mut fields[2..2 + n] {
                if r.parse::<f64>().unwrap() > 5.6 {
                    // Beyond the log's maximum range: no return.
                    *r = "1000.0".to_owned();
                }
            }
        }
        short.push_str(&fields.join(" "));
        short.push('\n');
    }
    std::fs::write(&log, short).unwrap();
    let run = out.path().join("run");
    let o = map_quietly(&log, &run, &["--every", "3"]);
    assert!(o.status.success(), "{}", text(&o));
    let mean = mean_relation_error(&run, &dir.join("fr079").join("fr079.relations"));
    eprintln!("fr079 every 3rd scan, 5.6 m laser: {mean:.3} m mean relation error");
    assert!(mean < 0.5, "{mean} m");
}

/// Maps `log` (a directory name under the datasets) every `every`th scan from `offset`, and
/// returns the mean relation error of the run, metres, and what it printed on stderr.
fn every_kth(dir: &std::path::Path, log: &str, every: &str, offset: &str) -> (f64, String) {
    every_kth_with(dir, log, every, offset, &[])
}

/// [`every_kth`] with `extra` arguments to `polymap map`.
fn every_kth_with(
    dir: &std::path::Path,
    log: &str,
    every: &str,
    offset: &str,
    extra: &[&str],
) -> (f64, String) {
    let out = tempfile::tempdir().unwrap();
    let mut args = vec!["--every", every, "--every-offset", offset];
    args.extend_from_slice(extra);
    let o = map_quietly(&dir.join(log).join(format!("{log}.clf")), out.path(), &args);
    assert!(o.status.success(), "{}", text(&o));
    let relations = dir.join(log).join(format!("{log}.relations"));
    let mean = mean_relation_error(out.path(), &relations);
    eprintln!("{log} every {every}th scan, phase {offset}: {mean:.3} m mean relation error");
    (mean, String::from_utf8_lossy(&o.stderr).into_owned())
}

/// The mean translation error, metres, of the run in `run` (its `trajectory.tum`) against
/// the ground-truth `relations` file (`polymap eval relations`).
fn mean_relation_error(run: &std::path::Path, relations: &std::path::Path) -> f64 {
    let e = polymap(&[
        "eval",
        "relations",
        run.join("trajectory.tum").to_str().unwrap(),
        relations.to_str().unwrap(),
        "--json",
    ]);
    assert!(e.status.success(), "{}", text(&e));
    let v: serde_json::Value = serde_json::from_slice(&e.stdout).unwrap();
    v["translation_m"]["mean"].as_f64().unwrap()
}

/// Intel every 10th scan, phase 9: the robot turns on the spot at corridor junctions and drives
/// on into corridors that ICP observes only weakly along. Taking the turn's standstill as the
/// speed there holds the robot at every junction (6.24 m mean relation error, the map called
/// inconsistent); the speed driven before the turn keeps it. Judged by the median over the
/// default run and four nuisance variants (small changes of the point spacing and of the
/// rotation search points): the phase is scored on 16 relations, and one run of it may
/// break elsewhere (near the log's end a few weak steps tracked short put two of the 16
/// relations 2.5 m off: 0.34 m) while the others stay under the bound (0.03-0.18 m, median
/// 0.13 m). Whole log five times, release build: about 10 s.
#[test]
fn intel_every_tenth_scan_drives_on_after_turns_on_the_spot() {
    let Some(dir) = datasets() else {
        eprintln!("SKIPPED: ../shared/datasets is absent");
        return;
    };
    let (default, stderr) = every_kth(&dir, "intel", "10", "9");
    assert!(!stderr.contains("inconsistent"), "{stderr}");
    let configs = tempfile::tempdir().unwrap();
    let mut means = vec![default];
    for (k, (spacing_m, rotations)) in [(0.045, 40), (0.055, 42), (0.05, 38), (0.05, 44)]
        .into_iter()
        .enumerate()
    {
        let config = configs.path().join(format!("variant-{k}.toml"));
        std::fs::write(
            &config,
            format!(
                "[align]\npoint_spacing_m = {spacing_m}\nrotation_search_points = {rotations}\n"
            ),
        )
        .unwrap();
        let config = config.to_str().unwrap();
        means.push(every_kth_with(&dir, "intel", "10", "9", &["--config", config]).0);
    }
    means.sort_by(f64::total_cmp);
    let median = means[means.len() / 2];
    // The bound at K = 10; a robot held at every junction is 25 times over it.
    assert!(median < 0.25, "{means:?} m");
}

/// FR079 every 10th scan, phase 0: at scan 363, in a zig-zag of turns, the window search
/// scored the corridor turned by 180° just above the truth, and ICP from the former fitted 85
/// of 176 points where ICP from the truth, the search's rival, fitted 111. Taking the former
/// builds the rest of the map half turned (8.44 m); ICP from the rival replaces it (0.02 m).
/// Whole log, release build: about 1 s.
#[test]
fn fr079_every_tenth_scan_takes_the_rival_that_fits_over_a_mirror_image() {
    let Some(dir) = datasets() else {
        eprintln!("SKIPPED: ../shared/datasets is absent");
        return;
    };
    let (mean, _) = every_kth(&dir, "fr079", "10", "0");
    assert!(mean < 0.25, "{mean} m");
}

/// Örebro (sparse: about one scan per metre, no odometry), its first 20 scans: between scans
/// 13 and 15 the robot turns 50° and then 42° while it creeps 0.3 m, and drives on 1 m and 2 m
/// a scan. At scan 14 ICP from the prediction fits 3 of 181 points; the whole-circle recovery
/// within 1 m of the last pose (`Attempt::recover`) finds the pose after the turns (99 fit).
/// Without it the turns still come out right but the steps do not (0.31 m and 1.96 m at scans
/// 15 and 16 where the robot went 0.09 m and 1.00 m): scans 12 to 18 come out 2.80 m off the
/// ground truth's relative pose, 0.02 m with it. A few scans, release build:
/// well under a second.
#[test]
fn orebro_sparse_turns_the_prediction_misses_are_recovered() {
    let Some(dir) = datasets() else {
        eprintln!("SKIPPED: ../shared/datasets is absent");
        return;
    };
    let sparse = dir.join("sparse").join("orebro");
    let out = tempfile::tempdir().unwrap();
    let run = out.path().join("run");
    let o = map_quietly(&sparse.join("orebro.clf"), &run, &["--max-scans", "20"]);
    assert!(o.status.success(), "{}", text(&o));
    let tracked = polymap_io::tum::read_tum(run.join("trajectory.tum")).unwrap();
    let truth = polymap_io::tum::read_tum(sparse.join("orebro.gt.tum")).unwrap();
    assert_eq!(tracked.len(), 20);
    for i in [12, 18] {
        let (a, b) = (tracked[i].stamp.seconds, truth[i].stamp.seconds);
        assert!((a - b).abs() < 1e-3, "scan {i}: stamps {a} and {b}");
    }
    let step = |poses: &[polymap_io::tum::StampedPose]| {
        poses[12].map_from_robot.between(&poses[18].map_from_robot)
    };
    let (got, want) = (step(&tracked), step(&truth));
    let off_m = (got.translation() - want.translation()).length();
    eprintln!("orebro scans 12-18: {off_m:.2} m off the ground truth's relative pose");
    assert!(
        off_m < 0.3,
        "scans 12-18: {got:?} against {want:?} ({off_m:.2} m)"
    );
}
