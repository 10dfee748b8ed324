//! The HTML report built from a synthetic run and opened in headless Chromium (when installed)
//! by `scripts/check-report-in-browser.sh`: the page's self-test must pass.

use std::path::{Path, PathBuf};
use std::process::Command;

use polymap::directions::DirectionParams;
use polymap::map::MapSegment;
use polymap_export::report::{
    ReportBudget, ReportData, ReportRecorder, ScanStat, SnapshotContent, write_report_html,
};
use polymap_io::snapshot::MapSnapshot;

use crate::{room, tools};

/// A run of `n` scans round the room: the map is the wall pieces seen so far. Returns the final
/// map (one polyline through every piece) and the replay.
fn synthetic_report(n: u32, budget: ReportBudget) -> (MapSnapshot, ReportData) {
    let pieces = room::wall_pieces();
    let mut born: Vec<Option<u32>> = vec![None; pieces.len()];
    let mut recorder = ReportRecorder::new("square room <synthetic>", budget);
    let seen = |born: &[Option<u32>]| -> Vec<MapSegment> {
        pieces
            .iter()
            .zip(born)
            .filter_map(|(s, b)| {
                b.map(|born_scan| MapSegment {
                    segment: *s,
                    born_scan,
                })
            })
            .collect()
    };
    for t in 0..n {
        let pose = room::pose(t, n);
        for hit in room::scan(&pose) {
            let p = pose.transform_point(hit);
            if let Some(k) = pieces.iter().position(|s| s.distance_to_point(p) < 1e-6) {
                born[k].get_or_insert(t);
            }
        }
        let map = seen(&born);
        let stat = ScanStat {
            scan_index: t,
            icp_residual_m: (t > 0).then(|| 0.01 + 0.005 * (f64::from(t) * 0.3).sin()),
            icp_iterations: 4 + t % 3,
            scan_segments: 6,
            map_segments: map.len() as u32,
            lost: false,
            // A gap mark on the time lines, drawn by the page.
            after_gap: t == 12,
            // A mark of a step off the odometry, drawn by the page.
            off_odometry: t == 20,
        };
        recorder.record(stat, pose, || {
            SnapshotContent::of_map(&map, t + 1, &DirectionParams::default())
        });
    }
    let map = seen(&born);
    let polylines = vec![(0..map.len()).collect()];
    let content = SnapshotContent::of_map(&map, n, &DirectionParams::default());
    let snapshot = MapSnapshot::from_parts(map, polylines, &[], Vec::new());
    (snapshot, recorder.finish(content))
}

fn chromium_on_path() -> Option<PathBuf> {
    tools::required(
        &["chromium", "chromium-browser"],
        ".ci/run and scripts/check-report-in-browser.sh install it",
    )
}

fn script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scripts/check-report-in-browser.sh")
}

#[test]
fn report_of_a_synthetic_run_is_small_and_self_contained() {
    let (map, data) = synthetic_report(300, ReportBudget::default());
    assert_eq!(data.total_scans, 300);
    assert_eq!(map.segments.len(), 36, "every wall piece seen");
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("report.html");
    write_report_html(&path, &map, &data).expect("written");
    let html = std::fs::read_to_string(&path).expect("read back");
    assert!(html.starts_with("<!DOCTYPE html>"));
    assert!(html.contains("square room &lt;synthetic&gt;"));
    assert!(html.contains("<pre id=\"selftest\""));
    assert!(html.len() < 2_000_000, "{} bytes", html.len());
}

#[test]
fn report_passes_its_self_test_in_headless_chromium() {
    let Some(chromium) = chromium_on_path() else {
        return;
    };
    let budget = ReportBudget {
        max_snapshot_numbers: 20_000,
        ..ReportBudget::default()
    };
    let (map, data) = synthetic_report(400, budget);
    assert!(
        data.snapshots.len() < 400,
        "the budget thinned the snapshots"
    );
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("polymap-export-report");
    std::fs::create_dir_all(&dir).expect("target tmp dir");
    let report = dir.join("report.html");
    let screenshot = dir.join("report.png");
    let _ = std::fs::remove_file(&screenshot);
    write_report_html(&report, &map, &data).expect("written");
    let output = Command::new("bash")
        .arg(script())
        .arg(&report)
        .arg(&screenshot)
        .env("CHROMIUM", &chromium)
        .output()
        .expect("bash runs");
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        output.status.success(),
        "script failed:\n{stdout}\n{stderr}"
    );
    assert!(stdout.contains("SELFTEST PASS"), "{stdout}");
    let png = std::fs::read(&screenshot).expect("screenshot written");
    assert!(png.starts_with(b"\x89PNG"));
    println!(
        "report: {}\nscreenshot: {}",
        report.display(),
        screenshot.display()
    );
}

/// A report whose script dies fails the browser check with its reason (`SELFTEST FAIL: init:`):
/// the page's own script text holds "SELFTEST PASS", so finding it there proves nothing.
#[test]
fn a_broken_report_fails_the_browser_check_with_its_reason() {
    let Some(chromium) = chromium_on_path() else {
        return;
    };
    let dir = tempfile::tempdir().expect("temp dir");
    let report = dir.path().join("broken.html");
    let (map, data) = synthetic_report(20, ReportBudget::default());
    write_report_html(&report, &map, &data).expect("written");
    let html = std::fs::read_to_string(&report).expect("read back");
    let broken = html.replacen("\"snapshots\":[", "\"snapshots\":[null,", 1);
    assert_ne!(broken, html);
    std::fs::write(&report, broken).expect("rewritten");
    let output = Command::new("bash")
        .arg(script())
        .arg(&report)
        .arg(dir.path().join("broken.png"))
        .env("CHROMIUM", &chromium)
        .output()
        .expect("bash runs");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success(), "a broken page passed");
    assert!(stderr.contains("SELFTEST FAIL: init:"), "{stderr}");
}
