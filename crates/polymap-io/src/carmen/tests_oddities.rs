//! Odd CARMEN input the reader does not accept in silence: refused naming the line, or counted.

use super::tests::{flaser, read_all, reader};
use super::*;
use polymap::geometry::Pose2;

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

/// An `ODOM` line at `x` metres, heading `theta` radians, stamped `t` seconds.
fn odom(x: f64, theta: f64, t: f64) -> String {
    format!("ODOM {x} 0 {theta} 0 0 0 {t} h 0\n")
}

/// A `FLASER` line whose odometry pose is `x` metres, heading `theta`, stamped `t`.
fn scan_at(x: f64, theta: f64, t: f64) -> String {
    format!("FLASER 3 1.0 1.0 1.0 0 0 0 {x} 0 {theta} {t} h 0\n")
}

#[test]
fn odometry_older_than_the_scan_is_interpolated_from_the_odometry_messages_around_it() {
    // Odometry stops 2.9 s before the scan after a gap; the scan carries that last reading,
    // and the next message reads the turn made meanwhile.
    let text = [
        odom(0.0, 0.0, 1.0),
        scan_at(0.0, 0.0, 1.05),
        odom(0.1, 0.0, 1.1),
        scan_at(0.1, 0.0, 4.0),
        odom(3.1, 1.5, 4.1),
        scan_at(3.1, 1.5, 4.2),
    ]
    .concat();
    let mut r = reader(&text, ReaderOptions::default());
    let mut order = Vec::new();
    let mut scans = Vec::new();
    while let Some(record) = r.next_record().unwrap() {
        match record {
            CarmenRecord::Scan(s) => {
                order.push('s');
                scans.push(s);
            }
            CarmenRecord::Odometry(_) => order.push('o'),
        }
    }
    assert_eq!(order, ['o', 's', 'o', 's', 'o', 's'], "file order kept");
    let f = 2.9 / 3.0;
    let expected = Pose2::new(0.1 + f * 3.0, 0.0, f * 1.5);
    let got = scans[1].odom_from_robot.unwrap();
    assert!(
        (got.translation() - expected.translation()).length() < 1e-9
            && (got.theta_rad - expected.theta_rad).abs() < 1e-9,
        "{got:?}"
    );
    // The others keep their odometry as logged.
    assert_eq!(scans[0].odom_from_robot, Some(Pose2::new(0.0, 0.0, 0.0)));
    assert_eq!(scans[2].odom_from_robot, Some(Pose2::new(3.1, 0.0, 1.5)));
    let stats = r.stats();
    assert_eq!(
        (stats.stale_odometry.count, stats.stale_odometry.first_line),
        (1, 4)
    );
    assert!((stats.stale_odometry.largest - 2.9).abs() < 1e-9);
    assert!(
        stats.warnings()[0].contains("older than the scan"),
        "{:?}",
        stats.warnings()
    );
}

#[test]
fn odometry_is_left_as_logged_unless_it_is_the_last_message_and_older_than_the_bound() {
    let cases = [
        // The scan's own odometry differs from the last message's: it is the scan's.
        [
            odom(0.1, 0.0, 1.1),
            scan_at(0.2, 0.0, 4.0),
            odom(3.1, 1.5, 4.1),
        ],
        // The last message is 0.9 s old: within the bound.
        [
            odom(0.1, 0.0, 1.1),
            scan_at(0.1, 0.0, 2.0),
            odom(3.1, 1.5, 4.1),
        ],
        // The next message is stamped before the scan: nothing brackets its stamp.
        [
            odom(0.1, 0.0, 1.1),
            scan_at(0.1, 0.0, 4.0),
            odom(3.1, 1.5, 3.9),
        ],
    ];
    for (i, case) in cases.iter().enumerate() {
        let (scans, stats) = read_all(&case.concat());
        assert_eq!(scans.len(), 1, "case {i}");
        let x = scans[0].odom_from_robot.unwrap().x_m;
        assert!(x == 0.1 || x == 0.2, "case {i}: {x}");
        assert_eq!(stats.stale_odometry.count, 0, "case {i}");
        // Stale and not mended is said so; fresh odometry raises nothing.
        let kept = u64::from(i == 2);
        assert_eq!(stats.stale_odometry_kept.count, kept, "case {i}");
        assert_eq!(stats.warnings().len() as u64, kept, "case {i}");
    }
    // Odometry that jumped over the gap (a reset): not interpolated across the jump.
    let text = [
        odom(0.1, 0.0, 1.1),
        scan_at(0.1, 0.0, 4.0),
        odom(500.0, 0.0, 4.1),
    ]
    .concat();
    let (scans, stats) = read_all(&text);
    assert_eq!(scans[0].odom_from_robot.unwrap().x_m, 0.1);
    assert_eq!(
        (stats.stale_odometry.count, stats.stale_odometry_kept.count),
        (0, 1)
    );
}

#[test]
fn scans_held_for_odometry_that_never_comes_are_returned_as_logged_in_file_order() {
    // A stale scan, then one more scan, then the end of the log: no message says better.
    let text = [
        odom(0.1, 0.0, 1.1),
        scan_at(0.1, 0.0, 4.0),
        scan_at(0.1, 0.0, 4.2),
    ]
    .concat();
    let (scans, stats) = read_all(&text);
    let stamps: Vec<f64> = scans.iter().map(|s| s.stamp.seconds).collect();
    assert_eq!(stamps, [4.0, 4.2]);
    assert!(
        scans
            .iter()
            .all(|s| s.odom_from_robot == Some(Pose2::new(0.1, 0.0, 0.0)))
    );
    // Both are stale (the last message's odometry, over 1 s old), neither mended.
    assert_eq!(
        (stats.stale_odometry.count, stats.stale_odometry_kept.count),
        (0, 2)
    );
    assert!(
        stats.warnings()[0].contains("as logged"),
        "{:?}",
        stats.warnings()
    );
    // Odometry that never resumes: the scans go on as logged, never more than
    // `MAX_HELD_SCANS` of them waiting.
    let mut text = odom(0.1, 0.0, 1.1);
    for k in 0..3 * MAX_HELD_SCANS {
        text += &scan_at(0.1, 0.0, 4.0 + 0.1 * k as f64);
    }
    text += &odom(3.1, 1.5, 100.0);
    let mut r = reader(&text, ReaderOptions::default());
    let mut most_waiting = 0;
    let mut stamps = Vec::new();
    while let Some(scan) = r.next_scan().unwrap() {
        stamps.push(scan.stamp.seconds);
        most_waiting = most_waiting.max(r.waiting());
    }
    assert_eq!(stamps.len(), 3 * MAX_HELD_SCANS);
    assert!(stamps.windows(2).all(|w| w[0] < w[1]), "file order");
    assert!(most_waiting < MAX_HELD_SCANS, "{most_waiting}");
    // Held across a skipped bad line, and still interpolated by the message after it.
    let text = [
        odom(0.1, 0.0, 1.1),
        scan_at(0.1, 0.0, 4.0),
        "FLASER 3 1.0\n".to_string(),
        odom(3.1, 1.5, 4.1),
    ]
    .concat();
    let options = ReaderOptions {
        skip_bad_lines: true,
        ..ReaderOptions::default()
    };
    let mut r = reader(&text, options);
    let scan = r.next_scan().unwrap().unwrap();
    assert!(scan.odom_from_robot.unwrap().x_m > 3.0);
    assert!(r.next_scan().unwrap().is_none());
    assert_eq!(
        (r.stats().bad_lines, r.stats().stale_odometry.count),
        (1, 1)
    );
    // A bad line that stops the reading: the held scans before it come first, as logged.
    let text = [
        odom(0.1, 0.0, 1.1),
        scan_at(0.1, 0.0, 4.0),
        scan_at(0.1, 0.0, 4.2),
        "FLASER 3 1.0\n".to_string(),
        odom(3.1, 1.5, 4.3),
    ]
    .concat();
    let mut r = reader(&text, ReaderOptions::default());
    let first = r.next_scan().unwrap().unwrap();
    let second = r.next_scan().unwrap().unwrap();
    assert_eq!((first.stamp.seconds, second.stamp.seconds), (4.0, 4.2));
    let e = r.next_scan().unwrap_err();
    assert_eq!(e.line(), Some(4), "{e}");
}
