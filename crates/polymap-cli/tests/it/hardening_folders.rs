//! Run folders across failed, mixed and concurrent runs: a run that fails leaves the previous
//! run's folder readable, `export` lists only what it wrote, readers hold the folder's lock
//! while they read it.

use std::fs;
use std::path::{Path, PathBuf};

use crate::support::{map_quietly, polymap, text};

/// A simulated office log in `dir`.
fn office_log(dir: &Path) -> PathBuf {
    let o = polymap(&["simulate", "office", "-o", dir.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    dir.join("office.clf")
}

fn o_str(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Every file of a folder with its size and a hash of its bytes, for a before-and-after
/// comparison.
fn contents(dir: &Path) -> Vec<(String, usize, u64)> {
    use std::hash::{DefaultHasher, Hash, Hasher};
    let mut all: Vec<(String, usize, u64)> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            let bytes = fs::read(&p).unwrap();
            let mut h = DefaultHasher::new();
            bytes.hash(&mut h);
            (name, bytes.len(), h.finish())
        })
        .collect();
    all.sort();
    all
}

/// A run refused after mapping but before writing (here: a log without a single scan) leaves
/// the previous run's folder byte for byte as it was, and readable: the manifest that marks a
/// folder as being written is written only once the first file is about to change.
#[test]
fn a_run_refused_before_writing_leaves_the_previous_folder_readable() {
    let dir = tempfile::tempdir().unwrap();
    let log = office_log(dir.path());
    let run = dir.path().join("run");
    let o = map_quietly(&log, &run, &["--max-scans", "60", "--diagnostics"]);
    assert!(o.status.success(), "{}", text(&o));
    let before = contents(&run);
    let empty = dir.path().join("empty.clf");
    fs::write(&empty, "ODOM 0 0 0 0 0 0 1.0 host 1.0\n").unwrap();
    for extra in [&[][..], &["--diagnostics"][..], &["--export", "png"][..]] {
        let o = map_quietly(&empty, &run, extra);
        assert!(!o.status.success(), "{}", text(&o));
        assert!(text(&o).contains("no laser scans"), "{}", text(&o));
        assert_eq!(contents(&run), before, "{extra:?}");
    }
    let o = polymap(&["export", o_str(&run), "--format", "png"]);
    assert!(o.status.success(), "{}", text(&o));
    let other = dir.path().join("other");
    let args = ["--max-scans", "10", "--initial-pose", "0,0,0"];
    let o = polymap(
        &[
            &["localize", o_str(&log), "--map", o_str(&run), "-o"][..],
            &[o_str(&other), "-q"],
            &args,
        ]
        .concat(),
    );
    assert!(o.status.success(), "{}", text(&o));
}

/// `export` listed its files in the manifest by computing the size and CRC-32 of every file
/// listed, so a file it never read (here another run's `loop_nodes.json`) was certified as the
/// run's. It now adds entries for the files it wrote only; the folder stays refused as mixed.
#[test]
fn export_certifies_only_the_files_it_wrote() {
    let dir = tempfile::tempdir().unwrap();
    let log = office_log(dir.path());
    let (run, earlier) = (dir.path().join("run"), dir.path().join("earlier"));
    for (out, scans) in [(&run, "60"), (&earlier, "30")] {
        let o = map_quietly(&log, out, &["--max-scans", scans]);
        assert!(o.status.success(), "{}", text(&o));
    }
    fs::copy(earlier.join("loop_nodes.json"), run.join("loop_nodes.json")).unwrap();
    let o = polymap(&["export", o_str(&run), "--format", "png"]);
    assert!(o.status.success(), "{}", text(&o));
    let manifest = fs::read_to_string(run.join("manifest.json")).unwrap();
    assert!(manifest.contains("map.png"), "{manifest}");
    let other = dir.path().join("other");
    let o = polymap(&[
        "localize",
        o_str(&log),
        "--map",
        o_str(&run),
        "-o",
        o_str(&other),
        "-q",
        "--max-scans",
        "10",
    ]);
    assert!(!o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("loop_nodes.json: not the file run"),
        "{}",
        text(&o)
    );
}

/// A run that reads a saved map checked the folder under a shared lock and dropped the lock at
/// once, so a run could write the map between the check and the read. The lock is now held
/// while the map is read and used: here `localize` reads its log from standard input, and once
/// it has taken more than a pipe holds (so it has read the map), a writer of the map's folder
/// is refused, told the folder is being read.
#[test]
fn a_saved_map_stays_locked_while_a_run_uses_it() {
    use std::io::Write;
    let dir = tempfile::tempdir().unwrap();
    let log = office_log(dir.path());
    let run = dir.path().join("run");
    let o = map_quietly(&log, &run, &["--max-scans", "60"]);
    assert!(o.status.success(), "{}", text(&o));
    let other = dir.path().join("other");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_polymap"))
        .args(["localize", "-", "--map", o_str(&run), "-o", o_str(&other)])
        .args(["-q", "--initial-pose", "0,0,0"])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let bytes = fs::read(&log).unwrap();
    // The first 200 scans or so, cut at a line's end.
    let end = bytes[..250_000].iter().rposition(|&b| b == b'\n').unwrap() + 1;
    let mut stdin = child.stdin.take().unwrap();
    // More than a pipe holds: written only once polymap reads its log, the map read before.
    stdin.write_all(&bytes[..200_000]).unwrap();
    let taken = polymap_pipeline::manifest::FolderLock::exclusive(&run);
    stdin.write_all(&bytes[200_000..end]).unwrap();
    drop(stdin);
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", text(&o));
    let e = taken.expect_err("the map's folder is locked while localize uses it");
    assert!(
        e.to_string()
            .contains("another polymap run is reading this folder"),
        "{e}"
    );
}
