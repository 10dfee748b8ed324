//! What the reader once accepted in silence: refused naming the line, or counted.

use super::tests::{flaser, read_all, reader};
use super::*;

fn robotlaser(fov: &str, res: &str, n: usize, stamp: &str) -> String {
    let ranges = vec!["2.0"; n].join(" ");
    format!(
        "ROBOTLASER1 0 -1.5 {fov} {res} 30.0 0.01 0 {n} {ranges} 0 0 0 0 0 0 0 0.1 0.2 0.3 0.4 0.5 {stamp} host 0.1\n"
    )
}

#[test]
fn impossible_angular_resolutions_are_refused_naming_the_line() {
    for res in ["0", "1e-300", "-0.01", "1e9"] {
        let text = format!(
            "{}{}",
            flaser(3, "1.0", "1.0"),
            robotlaser("3.0", res, 181, "2.0")
        );
        let mut r = reader(&text, ReaderOptions::default());
        assert!(r.next_scan().unwrap().is_some());
        let e = r.next_scan().unwrap_err();
        assert_eq!(e.line(), Some(2), "{res}: {e}");
        assert!(e.to_string().contains("angular_resolution"), "{e}");
    }
    // A real one passes: 181 beams at 1° over 180°.
    let ok = robotlaser("3.14159", "0.0174533", 181, "2.0");
    assert_eq!(read_all(&ok).0.len(), 1);
}

#[test]
fn a_field_of_view_that_contradicts_the_beams_is_counted() {
    // 181 beams at 1°: 180° (n − 1 steps) and 181° (n steps) match; 90° does not.
    let text = [
        robotlaser("3.14159", "0.0174533", 181, "1.0"),
        robotlaser("3.15905", "0.0174533", 181, "2.0"),
        robotlaser("1.5708", "0.0174533", 181, "3.0"),
    ]
    .concat();
    let (scans, stats) = read_all(&text);
    assert_eq!(scans.len(), 3);
    assert_eq!(stats.fov_mismatches.count, 1);
    assert_eq!(stats.fov_mismatches.first_line, 3);
    assert!(
        stats.warnings()[0].contains("field of view"),
        "{:?}",
        stats.warnings()
    );
}

#[test]
fn stamps_going_back_or_repeating_are_counted_with_their_first_line() {
    let text = [
        flaser(3, "1.0", "5.0"),
        flaser(3, "1.0", "4.0"),
        flaser(3, "1.0", "4.0"),
        flaser(3, "1.0", "3.0"),
        flaser(3, "1.0", "6.0"),
    ]
    .concat();
    let (scans, stats) = read_all(&text);
    assert_eq!(scans.len(), 5, "scans stay in file order, none dropped");
    assert_eq!(
        (
            stats.stamps_backwards.count,
            stats.stamps_backwards.first_line
        ),
        (2, 2)
    );
    assert_eq!(
        (
            stats.stamps_repeated.count,
            stats.stamps_repeated.first_line
        ),
        (1, 3)
    );
    assert_eq!(stats.warnings().len(), 2);
}

#[test]
fn an_odometry_jump_is_counted_and_its_odometry_dropped() {
    let scan = |x: f64, t: f64| {
        let ranges = ["1.0"; 3].join(" ");
        format!("FLASER 3 {ranges} {x} 0 0 {x} 0 0 {t} h 0\n")
    };
    let text = [
        scan(0.0, 1.0),
        scan(0.1, 2.0),
        scan(1000.1, 3.0),
        scan(1000.2, 4.0),
    ]
    .concat();
    let (scans, stats) = read_all(&text);
    let odom: Vec<Option<f64>> = scans
        .iter()
        .map(|s| s.odom_from_robot.map(|p| p.x_m))
        .collect();
    assert_eq!(odom, [Some(0.0), Some(0.1), None, Some(1000.2)]);
    assert_eq!(
        (stats.odometry_jumps.count, stats.odometry_jumps.first_line),
        (1, 3)
    );
    assert!((stats.odometry_jumps.largest - 1000.0).abs() < 1e-9);
    assert!(stats.warnings()[0].contains("largest 1000.0 m"));
}

#[test]
fn control_bytes_of_a_line_are_escaped_in_errors_and_counts() {
    let text = "\u{1b}[2JBOGUS 1 2\nFLASER 2 1.0 \u{1b}]0;x\u{7} 0 0 0 0 0 0 1 h 0\n";
    let mut r = reader(text, ReaderOptions::default());
    let e = r.next_scan().unwrap_err().to_string();
    assert!(
        !e.contains('\u{1b}') && !e.contains('\u{7}') && e.contains("\\x1b]0;x\\x07"),
        "{e}"
    );
    assert!(r.stats().skipped_types.contains_key("\\x1b[2JBOGUS"));
}
