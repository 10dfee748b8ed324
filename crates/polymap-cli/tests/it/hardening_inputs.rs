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

/// Runs polymap with standard input from `stdin`, and how long it took.
fn polymap_with_stdin(args: &[&str], stdin: &Path) -> (std::process::Output, f64) {
    let started = std::time::Instant::now();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_polymap"))
        .args(args)
        .stdin(fs::File::open(stdin).unwrap())
        .output()
        .expect("the polymap binary runs");
    (o, started.elapsed().as_secs_f64())
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
        let (o, seconds) = polymap_with_stdin(args, stdin);
        assert!(!o.status.success(), "{args:?}: {}", text(&o));
        assert!(text(&o).contains(message), "{args:?}: {}", text(&o));
        assert!(seconds < 10.0, "{args:?} took {seconds} s");
    }
    let config = polymap(&["map", o_str(&log), "-o", o, "-q", "--config", "/dev/zero"]);
    assert!(!config.status.success());
    assert!(
        text(&config).contains("/dev/zero: cannot read: a character device"),
        "{}",
        text(&config)
    );
    let args = ["map", "-", "-o", o, "-q", "--max-scans", "30"];
    let (stdin, _) = polymap_with_stdin(&args, &log);
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
