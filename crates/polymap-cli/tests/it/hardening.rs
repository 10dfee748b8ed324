//! Nothing lost, nothing half-written, nothing odd accepted in silence: the run
//! folder's writes, inputs from stdin and compressed files, interruption, odd logs.

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use crate::support::{map_quietly, polymap, text};

/// A simulated office log (whole) in `dir`.
fn office_log(dir: &Path) -> PathBuf {
    let o = polymap(&["simulate", "office", "-o", dir.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    dir.join("office.clf")
}

fn polymap_env(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_polymap"));
    c.args(args);
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().expect("the polymap binary runs")
}

/// Every file in the folder is whole: JSON parses, TUM lines have 8 fields (a killed run may
/// leave a hidden temporary file, which the next run removes). Returns the trajectory's line
/// count.
fn assert_whole(dir: &Path) -> usize {
    let mut poses = 0;
    for entry in fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if name.starts_with('.') && name.contains(".tmp-") {
            continue;
        }
        if name.ends_with(".json") {
            let text = fs::read_to_string(&path).unwrap();
            serde_json::from_str::<serde_json::Value>(&text)
                .unwrap_or_else(|e| panic!("{name} is cut or invalid: {e}"));
        }
        if name == "trajectory.tum" {
            let text = fs::read_to_string(&path).unwrap();
            assert!(text.ends_with('\n'), "trajectory.tum ends mid-line");
            for line in text.lines() {
                assert_eq!(line.split_whitespace().count(), 8, "{line}");
            }
            poses = text.lines().count();
        }
    }
    poses
}

/// A run killed while it writes history.json (about 2 MB) leaves no file cut short (invalid
/// JSON). The fault hook aborts the process in the middle of that file, as a kill would.
#[test]
fn a_run_killed_while_writing_leaves_no_cut_file() {
    let dir = tempfile::tempdir().unwrap();
    let log = office_log(dir.path());
    let run = dir.path().join("run");
    let (l, r) = (log.to_str().unwrap(), run.to_str().unwrap());
    // An earlier, complete run in the same folder.
    let o = polymap(&["map", l, "-o", r, "-q", "--max-scans", "100"]);
    assert!(o.status.success(), "{}", text(&o));
    let old_history = fs::read(run.join("history.json")).unwrap();
    let o = polymap_env(
        &["map", l, "-o", r, "-q", "--max-scans", "300"],
        &[("POLYMAP_TEST_FAULT", "history.json:abort")],
    );
    assert!(
        !o.status.success(),
        "the fault must kill the run: {}",
        text(&o)
    );
    // The contract files come first and are the new run's; history.json is the old one whole.
    assert_eq!(assert_whole(&run), 300);
    assert_eq!(fs::read(run.join("history.json")).unwrap(), old_history);
    // The next run removes the killed run's temporary file.
    let temps = |dir: &Path| {
        fs::read_dir(dir)
            .unwrap()
            .filter(|e| {
                e.as_ref()
                    .unwrap()
                    .file_name()
                    .to_string_lossy()
                    .contains(".tmp-")
            })
            .count()
    };
    assert_eq!(temps(&run), 1);
    let o = polymap(&["map", l, "-o", r, "-q", "--max-scans", "100"]);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(temps(&run), 0);
}

/// The same with a real `kill -9` at whatever moment: every file present is whole.
#[test]
fn kill_9_at_any_moment_leaves_whole_files() {
    let dir = tempfile::tempdir().unwrap();
    let log = office_log(dir.path());
    for delay_ms in [0u64, 30, 80, 150] {
        let run = dir.path().join(format!("run{delay_ms}"));
        let mut child = Command::new(env!("CARGO_BIN_EXE_polymap"))
            .args([
                "map",
                log.to_str().unwrap(),
                "-o",
                run.to_str().unwrap(),
                "-q",
            ])
            .args(["--export", "html,png,pgm,dxf"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let t0 = Instant::now();
        // Kill as soon as the first output appears (plus a delay), or after 20 s.
        while !run.join("map.json").exists() && t0.elapsed() < Duration::from_secs(20) {
            std::thread::sleep(Duration::from_millis(2));
        }
        std::thread::sleep(Duration::from_millis(delay_ms));
        let _ = child.kill();
        let _ = child.wait();
        if run.is_dir() {
            assert_whole(&run);
        }
    }
}

/// On a full disk map.json and trajectory.tum survive (written before the 6 MB report), and the
/// error names the file that failed. Through a small tmpfs when this runs as root (mount
/// allowed), else an injected ENOSPC.
#[test]
fn a_full_disk_keeps_the_contract_files_and_says_which_file_failed() {
    let dir = tempfile::tempdir().unwrap();
    let log = office_log(dir.path());
    let mnt = dir.path().join("small-disk");
    fs::create_dir_all(&mnt).unwrap();
    let mounted = Command::new("mount")
        .args(["-t", "tmpfs", "-o", "size=400k", "tmpfs"])
        .arg(&mnt)
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    let run = mnt.join("run");
    let args = [
        "map",
        log.to_str().unwrap(),
        "-o",
        run.to_str().unwrap(),
        "-q",
        "--export",
        "html",
    ];
    let o = if mounted {
        eprintln!("full disk: a 400 KB tmpfs");
        polymap(&args)
    } else {
        eprintln!("full disk: cannot mount a tmpfs here; injecting ENOSPC into report.html");
        polymap_env(&args, &[("POLYMAP_TEST_FAULT", "report.html:enospc")])
    };
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    let poses = run.is_dir().then(|| assert_whole(&run));
    if mounted {
        let _ = Command::new("umount").arg(&mnt).status();
    }
    assert!(!o.status.success(), "{}", text(&o));
    assert!(stderr.contains("No space left on device"), "{stderr}");
    assert!(
        poses.is_some_and(|n| n > 100),
        "trajectory.tum kept: {stderr}"
    );
    assert!(!run.join("report.html").exists() || !mounted);
}

/// A read-only output folder, or an output that is a file, is refused before mapping, not
/// after the whole run.
#[test]
fn an_unwritable_or_wrong_output_is_refused_before_mapping() {
    let dir = tempfile::tempdir().unwrap();
    let ro = dir.path().join("ro");
    fs::create_dir_all(&ro).unwrap();
    let mounted = Command::new("mount")
        .args(["-t", "tmpfs", "-o", "ro,size=64k", "tmpfs"])
        .arg(&ro)
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !mounted {
        use std::os::unix::fs::PermissionsExt;
        fs::set_permissions(&ro, fs::Permissions::from_mode(0o555)).unwrap();
    }
    // The log does not exist: the folder must be refused before the log is even opened.
    let o = polymap(&["map", "/nonexistent/log.clf", "-o", ro.to_str().unwrap()]);
    if mounted {
        let _ = Command::new("umount").arg(&ro).status();
    }
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        stderr.contains("cannot write outputs there") && !stderr.contains("log.clf"),
        "{}",
        text(&o)
    );
    // -o naming a file: "not a folder", not "cannot create: File exists".
    let file = dir.path().join("a-file");
    fs::write(&file, "x").unwrap();
    let o = polymap(&["map", "/nonexistent/log.clf", "-o", file.to_str().unwrap()]);
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("not a folder"),
        "{}",
        text(&o)
    );
}

/// A folder holding an earlier run: its exports that this run does not write (map.png,
/// map.dxf …) are removed, and said so, so that none stands beside the new map.json.
#[test]
fn exports_of_an_earlier_run_are_removed_and_said_so() {
    let dir = tempfile::tempdir().unwrap();
    let log = office_log(dir.path());
    let run = dir.path().join("run");
    let (l, r) = (log.to_str().unwrap(), run.to_str().unwrap());
    let o = polymap(&[
        "map",
        l,
        "-o",
        r,
        "-q",
        "--max-scans",
        "50",
        "--export",
        "png,dxf,pgm",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    fs::write(run.join("notes.txt"), "mine").unwrap();
    let o = polymap(&[
        "map",
        l,
        "-o",
        r,
        "-q",
        "--max-scans",
        "60",
        "--export",
        "dxf",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    for gone in ["map.png", "map.pgm", "map.yaml"] {
        assert!(!run.join(gone).exists(), "{gone} left from the earlier run");
    }
    assert!(run.join("map.dxf").exists() && run.join("notes.txt").exists());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("removed map.png, map.pgm, map.yaml from an earlier run"),
        "{stderr}"
    );
}

fn map_from_stdin(log: &Path, run: &Path, extra: &[&str]) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_polymap"))
        .args(["map", "-", "-o", run.to_str().unwrap(), "-q"])
        .args(extra)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let bytes = fs::read(log).unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let feeder = std::thread::spawn(move || {
        let _ = stdin.write_all(&bytes);
    });
    let out = child.wait_with_output().unwrap();
    feeder.join().unwrap();
    out
}

/// A log on standard input (`polymap map - -o out`) maps with every export, `--export pgm`
/// (which needs the scans again) included; a later `polymap export` that needs the log is
/// refused at once instead of waiting silently on the terminal.
#[test]
fn a_log_on_stdin_maps_with_every_export_and_a_later_export_refuses() {
    let dir = tempfile::tempdir().unwrap();
    let log = office_log(dir.path());
    let run = dir.path().join("run");
    let o = map_from_stdin(
        &log,
        &run,
        &["--max-scans", "200", "--export", "pgm,png,dxf"],
    );
    assert!(o.status.success(), "{}", text(&o));
    for f in ["map.pgm", "map.yaml", "map.png", "map.dxf"] {
        assert!(run.join(f).is_file(), "{f}");
    }
    // The same grid as from the file.
    let from_file = dir.path().join("file-run");
    let o = polymap(&[
        "map",
        log.to_str().unwrap(),
        "-o",
        from_file.to_str().unwrap(),
        "-q",
        "--max-scans",
        "200",
        "--export",
        "pgm",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(
        fs::read(run.join("map.pgm")).unwrap(),
        fs::read(from_file.join("map.pgm")).unwrap()
    );
    let summary: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(run.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["log"], "-");
    // A later export needs the log again: refused at once, with stdin left open.
    let mut child = Command::new(env!("CARGO_BIN_EXE_polymap"))
        .args(["export", run.to_str().unwrap(), "--format", "pgm"])
        .stdin(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break Some(s);
        }
        if t0.elapsed() > Duration::from_secs(10) {
            let _ = child.kill();
            break None;
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        status.is_some_and(|s| !s.success()),
        "waited on stdin: {stderr}"
    );
    assert!(
        stderr.contains("standard input") && stderr.contains("--log"),
        "{stderr}"
    );
}

/// Compressed logs (gzip, bzip2) are read directly, not refused as invalid UTF-8, and map as
/// the plain log does.
#[test]
fn gzip_and_bzip2_logs_map_like_the_plain_log() {
    let dir = tempfile::tempdir().unwrap();
    let log = office_log(dir.path());
    let mut maps = Vec::new();
    for (name, cmd) in [
        ("plain", None),
        ("gz", Some("gzip")),
        ("bz2", Some("bzip2")),
    ] {
        let path = match cmd {
            None => log.clone(),
            Some(cmd) => {
                let path = dir.path().join(format!("office.clf.{name}"));
                let ok = Command::new(cmd)
                    .args(["-c", log.to_str().unwrap()])
                    .stdout(fs::File::create(&path).unwrap())
                    .status()
                    .is_ok_and(|s| s.success());
                if !ok {
                    eprintln!("SKIP {name}: `{cmd}` is not installed");
                    continue;
                }
                path
            }
        };
        let run = dir.path().join(format!("run-{name}"));
        let o = polymap(&[
            "map",
            path.to_str().unwrap(),
            "-o",
            run.to_str().unwrap(),
            "-q",
            "--max-scans",
            "150",
        ]);
        assert!(o.status.success(), "{name}: {}", text(&o));
        maps.push(fs::read(run.join("map.json")).unwrap());
    }
    assert!(maps.len() >= 2, "gzip or bzip2 must be available");
    assert!(maps.windows(2).all(|w| w[0] == w[1]));
}

/// Control and escape bytes from a log are escaped in every message, never sent to the
/// terminal raw (a binary file read as a log holds 1.7 KB of them, ESC sequences included).
#[test]
fn control_bytes_from_a_log_are_escaped_in_every_message() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("evil.clf");
    fs::write(
        &bad,
        b"\x1b[31mRED 1 2 3\nFLASER 2 1.0 \x1b]0;title\x07 0 0 0 0 0 0 5 h 0\n",
    )
    .unwrap();
    let binary = dir.path().join("binary.clf");
    let bytes: Vec<u8> = (0..4096u32).map(|i| (i * 7 % 32) as u8).collect();
    fs::write(&binary, bytes).unwrap();
    for (log, extra) in [
        (&bad, None),
        (&bad, Some("--skip-bad-lines")),
        (&binary, None),
    ] {
        let run = dir.path().join("run");
        let mut args = vec![
            "map",
            log.to_str().unwrap(),
            "-o",
            run.to_str().unwrap(),
            "-q",
        ];
        args.extend(extra);
        let o = polymap(&args);
        assert!(!o.status.success() || extra.is_some());
        let raw = o.stderr.iter().filter(|&&b| b < 0x20 && b != b'\n').count();
        assert_eq!(raw, 0, "raw control bytes in: {}", text(&o));
        if log == &bad {
            assert!(
                String::from_utf8_lossy(&o.stderr).contains("\\x1b"),
                "{}",
                text(&o)
            );
        }
    }
}

/// `-q` prints nothing on success, not even the summary line.
#[test]
fn quiet_prints_nothing_on_success() {
    let dir = tempfile::tempdir().unwrap();
    let log = office_log(dir.path());
    let run = dir.path().join("run");
    let o = polymap(&[
        "map",
        log.to_str().unwrap(),
        "-o",
        run.to_str().unwrap(),
        "-q",
        "--max-scans",
        "50",
        "--export",
        "dxf",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(o.stdout.is_empty(), "{}", text(&o));
}

/// Ctrl-C mid-run saves what was mapped, says so and exits with 130.
#[test]
fn ctrl_c_saves_what_was_mapped() {
    let dir = tempfile::tempdir().unwrap();
    let log = office_log(dir.path());
    let run = dir.path().join("run");
    let mut child = Command::new(env!("CARGO_BIN_EXE_polymap"))
        .args(["map", "-", "-o", run.to_str().unwrap(), "-q"])
        .stdin(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Half the log, then the stream stays open (a live robot).
    let text_log = fs::read_to_string(&log).unwrap();
    let lines: Vec<&str> = text_log.lines().collect();
    let mut stdin = child.stdin.take().unwrap();
    for line in &lines[..lines.len() / 2] {
        writeln!(stdin, "{line}").unwrap();
    }
    stdin.flush().unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    let pid = child.id().to_string();
    assert!(
        Command::new("kill")
            .args(["-INT", &pid])
            .status()
            .unwrap()
            .success()
    );
    let t0 = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(20),
            "did not stop on Ctrl-C"
        );
        std::thread::sleep(Duration::from_millis(10));
    };
    drop(stdin);
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(status.code(), Some(130), "{stderr}");
    assert!(stderr.contains("interrupted: saved the"), "{stderr}");
    let poses = assert_whole(&run);
    assert!(poses > 10, "{poses} poses saved");
    let summary: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(run.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["interrupted"], true);
}

/// ROBOTLASER1 lines with an angular resolution of 0, 1e-300 or 1e9 (taken as given they map
/// to 0–2 segments) are refused or warned about, not mapped in silence.
#[test]
fn odd_carmen_logs_are_refused_or_warned() {
    let dir = tempfile::tempdir().unwrap();
    let ranges = vec!["2.0"; 181].join(" ");
    for res in ["0", "1e-300", "1e9"] {
        let log = dir.path().join(format!("res-{res}.clf"));
        let line = format!(
            "ROBOTLASER1 0 -1.5708 3.1416 {res} 80 0.01 0 181 {ranges} 0 0 0 0 0 0 0 0 0 0 0 0 1.0 h 1.0\n"
        );
        fs::write(&log, line).unwrap();
        let o = polymap(&[
            "map",
            log.to_str().unwrap(),
            "-o",
            dir.path().join("r").to_str().unwrap(),
            "-q",
        ]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(
            !o.status.success() && stderr.contains(":1:") && stderr.contains("angular_resolution"),
            "{res}: {}",
            text(&o)
        );
    }
    // Stamps going backwards and repeating: counted warnings naming the first line.
    let log = dir.path().join("stamps.clf");
    let scan = |t: &str| format!("FLASER 3 1.0 2.0 3.0 0 0 0 0 0 0 {t} h 0\n");
    fs::write(
        &log,
        [scan("2.0"), scan("1.0"), scan("1.0"), scan("3.0")].concat(),
    )
    .unwrap();
    let o = polymap(&[
        "map",
        log.to_str().unwrap(),
        "-o",
        dir.path().join("r2").to_str().unwrap(),
        "-q",
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        stderr.contains("1 scan(s) stamped earlier than the scan before them")
            && stderr.contains("(first: line 2)")
            && stderr.contains("1 scan(s) stamped the same")
            && stderr.contains("(first: line 3)"),
        "{stderr}"
    );
}

/// `eval relations` with its files swapped names the file that is not what its place says,
/// rather than reporting that no relation matched; a trajectory covering a small part of the
/// relations is warned about.
#[test]
fn eval_relations_names_a_swapped_file_and_warns_on_low_coverage() {
    let dir = tempfile::tempdir().unwrap();
    let log = office_log(dir.path());
    // Relations between consecutive true poses (identity offsets are fine for this check).
    let truth = fs::read_to_string(dir.path().join("office.truth.tum")).unwrap();
    let stamps: Vec<&str> = truth
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .collect();
    let relations: String = stamps
        .windows(2)
        .map(|w| format!("{} {} 0.1 0.0 0.000000 0.000000 0.000000 0.0\n", w[0], w[1]))
        .collect();
    let rel = dir.path().join("office.relations");
    fs::write(&rel, relations).unwrap();
    let run = dir.path().join("run");
    let o = polymap(&[
        "map",
        log.to_str().unwrap(),
        "-o",
        run.to_str().unwrap(),
        "-q",
        "--max-scans",
        "100",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let traj = run.join("trajectory.tum");
    let (t, r) = (traj.to_str().unwrap(), rel.to_str().unwrap());
    let o = polymap(&["eval", "relations", t, r]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        stderr.contains("warning: only") && stderr.contains("of the relations"),
        "{stderr}"
    );
    let o = polymap(&["eval", "relations", r, t]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{}", text(&o));
    assert!(
        stderr.contains("office.relations: not a TUM trajectory"),
        "{stderr}"
    );
}

/// `eval map` lays the map onto the walls before scoring its shape and reports the placement
/// separately: in the first scan's frame the built-in world's map, which looks right, is
/// turned about half a degree as a whole, and scored there it gets precision 38 %, recall
/// 37 %. It also says how much of the map is drawn twice.
#[test]
fn eval_map_measures_the_shape_after_aligning_and_the_placement_apart() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("run");
    let o = polymap(&["map", "-o", run.to_str().unwrap(), "-q"]);
    assert!(o.status.success(), "{}", text(&o));
    let walls = run.join("sim/hallway45.walls.json");
    let o = polymap(&[
        "eval",
        "map",
        run.to_str().unwrap(),
        "--walls",
        walls.to_str().unwrap(),
        "--json",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let (p, r) = (
        v["walls"]["precision"].as_f64().unwrap(),
        v["walls"]["recall"].as_f64().unwrap(),
    );
    let turned = v["walls_alignment"]["theta_deg"].as_f64().unwrap();
    println!("hallway45: aligned precision {p:.3} recall {r:.3}, turned {turned:.2}°");
    // The aligned figures are one draw of the tracking and loop closure: 62–88 % measured over
    // the world's seeds 1–3; unaligned, 38 %.
    assert!(p > 0.55 && r > 0.55, "{v}");
    assert!(turned.abs() < 2.0, "{v}");
    assert!(v["walls_unaligned"]["precision"].as_f64().unwrap() <= p + 1e-9);
    // Its walls are drawn once: 1.3 % of the map's length lies beside another segment.
    let doubled = v["doubled"]["share"].as_f64().unwrap();
    assert!(doubled < 0.05, "{v}");
    // Nor do its walls cross.
    assert_eq!(v["crossed"]["share"].as_f64(), Some(0.0), "{v}");
}

/// Copies the CARMEN log `from` to `to`, moving the laser and odometry poses of the `k`-th
/// FLASER scan (1-based) by `shift(k)` metres along x where it says so.
fn shift_odometry(from: &Path, to: &Path, shift: impl Fn(usize) -> Option<f64>) {
    let mut k = 0;
    let shifted: String = fs::read_to_string(from)
        .unwrap()
        .lines()
        .map(|l| {
            let mut f: Vec<String> = l.split_whitespace().map(str::to_owned).collect();
            if f.first().map(String::as_str) == Some("FLASER") {
                k += 1;
                if let Some(dx) = shift(k) {
                    let i = 2 + f[1].parse::<usize>().unwrap();
                    for j in [i, i + 3] {
                        f[j] = (f[j].parse::<f64>().unwrap() + dx).to_string();
                    }
                }
            }
            f.join(" ") + "\n"
        })
        .collect();
    fs::write(to, shifted).unwrap();
}

/// A 1 km odometry jump with --odometry is counted, warned about, and that scan's odometry is
/// not used (taken at its word, it puts Intel's mean error at 261 m).
#[test]
fn an_odometry_jump_is_warned_and_does_not_wreck_the_map() {
    let dir = tempfile::tempdir().unwrap();
    let log = office_log(dir.path());
    let jump = dir.path().join("jump.clf");
    shift_odometry(&log, &jump, |k| (k >= 500).then_some(1000.0));
    let run = dir.path().join("run");
    let o = polymap(&[
        "map",
        jump.to_str().unwrap(),
        "-o",
        run.to_str().unwrap(),
        "-q",
        "--odometry",
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        stderr.contains("odometry jumped (largest 1000.0 m)"),
        "{stderr}"
    );
    let o = polymap(&[
        "eval",
        "trajectory",
        run.join("trajectory.tum").to_str().unwrap(),
        dir.path().join("office.truth.tum").to_str().unwrap(),
        "--json",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let rmse = v["ate"]["position_m"]["rms"]
        .as_f64()
        .unwrap_or_else(|| panic!("no ATE rms in {v}"));
    assert!(rmse < 0.5, "ATE {rmse} m");
}

/// Without `--odometry`, the log's odometry witnesses the steps: 14 scans of the simulated
/// office whose odometry reads 0.5 m ahead (two steps off each) are counted in `summary.json`
/// and warned about with a hint to try `--odometry`; the trajectory is the one the clean log
/// gives (a label, not a correction), and the clean log raises no such warning.
#[test]
fn steps_the_logs_odometry_contradicts_are_warned_without_changing_the_map() {
    let dir = tempfile::tempdir().unwrap();
    let clean = office_log(dir.path());
    let log = dir.path().join("spiked.clf");
    shift_odometry(&clean, &log, |k| (k >= 300 && k % 100 == 0).then_some(0.5));
    let run = |log: &Path, name: &str| {
        let out = dir.path().join(name);
        let o = map_quietly(log, &out, &[]);
        assert!(o.status.success(), "{}", text(&o));
        let summary: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
        let trajectory = fs::read_to_string(out.join("trajectory.tum")).unwrap();
        (
            String::from_utf8_lossy(&o.stderr).into_owned(),
            summary,
            trajectory,
        )
    };
    let (stderr, summary, trajectory) = run(&log, "spiked");
    assert!(stderr.contains("off the log's odometry"), "{stderr}");
    assert!(stderr.contains("try --odometry"), "{stderr}");
    let off = summary["tracking"]["off_odometry"].as_u64().unwrap();
    assert!((20..=30).contains(&off), "{off} steps off: {summary}");
    let first = summary["tracking"]["off_odometry_scans"][0]
        .as_u64()
        .unwrap();
    assert!(first >= 299, "first step off at scan {first}");
    let (clean_stderr, clean_summary, clean_trajectory) = run(&clean, "clean");
    assert!(
        !clean_stderr.contains("off the log's odometry"),
        "{clean_stderr}"
    );
    assert_eq!(clean_summary["tracking"]["off_odometry"], 0);
    assert_eq!(trajectory, clean_trajectory);
}

/// A ROS recording's odometry witnesses the steps without `--odometry` too: the simulated
/// office as MCAP reports the odometry's travel beside the scans' and no step off it.
#[test]
fn a_ros_recordings_odometry_witnesses_the_steps_without_the_odometry_prior() {
    let dir = tempfile::tempdir().unwrap();
    let o = polymap(&[
        "simulate",
        "office",
        "--ros",
        "-o",
        dir.path().to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let run = dir.path().join("run");
    let mcap = dir.path().join("office.mcap");
    let o = map_quietly(&mcap, &run, &[]);
    assert!(o.status.success(), "{}", text(&o));
    let summary: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(run.join("summary.json")).unwrap()).unwrap();
    let t = &summary["tracking"];
    let odometry_m = t["odometry_travel_m"].as_f64().unwrap();
    let tracked_m = t["tracked_travel_m"].as_f64().unwrap();
    assert!(
        odometry_m > 50.0,
        "odometry travel {odometry_m} m: {summary}"
    );
    assert!((odometry_m / tracked_m - 1.0).abs() < 0.05, "{summary}");
    assert_eq!(t["off_odometry"], 0, "{summary}");
}

/// Scans missing from a log (15 in a row dropped from the simulated office): a counted warning
/// naming the scan after the gap, and `summary.json` `tracking.gaps`; the whole log has none.
#[test]
fn a_gap_in_the_log_is_warned() {
    let dir = tempfile::tempdir().unwrap();
    let whole = office_log(dir.path());
    let mut flaser = 0;
    let gapped: String = fs::read_to_string(&whole)
        .unwrap()
        .lines()
        .filter(|l| {
            if !l.starts_with("FLASER") {
                return true;
            }
            flaser += 1;
            !(301..=315).contains(&flaser)
        })
        .map(|l| format!("{l}\n"))
        .collect();
    let log = dir.path().join("gapped.clf");
    fs::write(&log, gapped).unwrap();
    let run = |log: &Path, name: &str| {
        let out = dir.path().join(name);
        let o = crate::support::map_quietly(log, &out, &[]);
        assert!(o.status.success(), "{}", text(&o));
        let summary: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
        (String::from_utf8_lossy(&o.stderr).into_owned(), summary)
    };
    let (stderr, summary) = run(&log, "gapped");
    assert!(
        stderr.contains("1 gap(s) in the log") && stderr.contains("the scans after them: 300)"),
        "{stderr}"
    );
    assert_eq!(summary["tracking"]["gaps"], 1, "{summary}");
    assert_eq!(summary["tracking"]["gap_scans"][0], 300, "{summary}");
    let (stderr, summary) = run(&whole, "whole");
    assert!(!stderr.contains("gap(s) in the log"), "{stderr}");
    assert_eq!(summary["tracking"]["gaps"], 0, "{summary}");
}

/// A CARMEN log whose odometry messages stop over a gap (the simulated office with an `ODOM`
/// line before each scan, 15 scans and their messages dropped): the scan after the gap carries
/// the last message's pose, 1.6 s old, as ACES's scan 2945 does. It is interpolated from the
/// message after it, counted in `summary.json` and warned about; the whole log has none.
#[test]
fn odometry_older_than_its_scan_is_interpolated_and_said_so() {
    let dir = tempfile::tempdir().unwrap();
    let whole = office_log(dir.path());
    let logged = fs::read_to_string(&whole).unwrap();
    let mut with_odom = String::new();
    let mut stale = String::new();
    let mut flaser = 0;
    let mut last_before_gap = None;
    for l in logged.lines() {
        let f: Vec<&str> = l.split_whitespace().collect();
        if f.first() != Some(&"FLASER") {
            with_odom += &format!("{l}\n");
            stale += &format!("{l}\n");
            continue;
        }
        flaser += 1;
        let i = 2 + f[1].parse::<usize>().unwrap();
        let (odom, stamp) = (&f[i + 3..i + 6], f[i + 6]);
        let message = format!("ODOM {} 0 0 0 {stamp} sim 0\n", odom.join(" "));
        with_odom += &message;
        with_odom += &format!("{l}\n");
        match flaser {
            ..=300 => {
                stale += &message;
                stale += &format!("{l}\n");
                last_before_gap = Some(odom.join(" "));
            }
            301..=315 => {}
            316 => {
                // The scan first, with the odometry of before the gap; the message after it.
                let mut g: Vec<String> = f.iter().map(|s| s.to_string()).collect();
                let old: Vec<String> = last_before_gap
                    .clone()
                    .unwrap()
                    .split(' ')
                    .map(str::to_owned)
                    .collect();
                g.splice(i + 3..i + 6, old);
                stale += &format!("{}\n", g.join(" "));
                let later: f64 = stamp.parse::<f64>().unwrap() + 0.01;
                stale += &format!("ODOM {} 0 0 0 {later:.6} sim 0\n", odom.join(" "));
            }
            _ => {
                stale += &message;
                stale += &format!("{l}\n");
            }
        }
    }
    let run = |name: &str, log: &str| {
        let path = dir.path().join(format!("{name}.clf"));
        fs::write(&path, log).unwrap();
        let out = dir.path().join(name);
        let o = crate::support::map_quietly(&path, &out, &["--odometry"]);
        assert!(o.status.success(), "{}", text(&o));
        let summary: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
        (String::from_utf8_lossy(&o.stderr).into_owned(), summary)
    };
    let (stderr, summary) = run("stale", &stale);
    assert!(
        stderr.contains("1 scan(s) whose odometry was up to 1.6 s older than the scan"),
        "{stderr}"
    );
    // `info` says it too, beside the scans with odometry.
    let info = polymap(&["info", dir.path().join("stale.clf").to_str().unwrap()]);
    let info = String::from_utf8_lossy(&info.stdout);
    assert!(
        info.contains("older than the scan") && info.contains("odometry: in every scan line"),
        "{info}"
    );
    assert_eq!(
        summary["reader"]["odometry_interpolated_stale"], 1,
        "{summary}"
    );
    let (stderr, summary) = run("whole", &with_odom);
    assert!(!stderr.contains("older than the scan"), "{stderr}");
    assert_eq!(
        summary["reader"]["odometry_interpolated_stale"], 0,
        "{summary}"
    );
}

/// A log whose odometry fields are all zeros (a converted log, a robot that did not record
/// its odometry): the run says so, with the advice that fits `--odometry` or not; the log's
/// own odometry raises nothing.
#[test]
fn odometry_that_never_moves_is_warned() {
    let dir = tempfile::tempdir().unwrap();
    let whole = office_log(dir.path());
    let zeroed: String = fs::read_to_string(&whole)
        .unwrap()
        .lines()
        .map(|l| {
            let mut f: Vec<String> = l.split_whitespace().map(str::to_owned).collect();
            if f.first().map(String::as_str) == Some("FLASER") {
                let i = 2 + f[1].parse::<usize>().unwrap();
                for v in &mut f[i..i + 6] {
                    *v = "0".to_string();
                }
            }
            f.join(" ") + "\n"
        })
        .collect();
    let stuck = dir.path().join("stuck.clf");
    fs::write(&stuck, zeroed).unwrap();
    let run = |log: &Path, name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let o = crate::support::map_quietly(log, &out, extra);
        assert!(o.status.success(), "{}", text(&o));
        let summary: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
        (String::from_utf8_lossy(&o.stderr).into_owned(), summary)
    };
    let (stderr, summary) = run(&stuck, "stuck", &[]);
    assert!(
        stderr.contains("the log's odometry travelled 0.0 m")
            && stderr.contains("do not map this log with --odometry"),
        "{stderr}"
    );
    assert_eq!(summary["tracking"]["odometry_travel_m"], 0.0, "{summary}");
    let (stderr, _) = run(&stuck, "stuck-odometry", &["--odometry"]);
    assert!(stderr.contains("map without --odometry"), "{stderr}");
    let (stderr, summary) = run(&whole, "whole", &["--odometry"]);
    assert!(!stderr.contains("odometry travelled"), "{stderr}");
    let (odo, scans) = (
        summary["tracking"]["odometry_travel_m"].as_f64().unwrap(),
        summary["tracking"]["tracked_travel_m"].as_f64().unwrap(),
    );
    assert!(
        scans > 20.0 && (odo / scans - 1.0).abs() < 0.1,
        "{odo} {scans}"
    );
}
