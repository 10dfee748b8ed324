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
