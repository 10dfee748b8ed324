//! Malformed input: errors name the file and line; skip mode counts; nothing panics.

use std::path::Path;

use proptest::prelude::*;

use super::tests::{flaser, reader};
use super::*;

/// The error for `text`, which must be malformed on some line.
fn first_error(text: &str) -> CarmenError {
    let mut r = reader(text, ReaderOptions::default());
    loop {
        match r.next_scan() {
            Ok(Some(_)) => {}
            Ok(None) => panic!("no error in {text:?}"),
            Err(e) => return e,
        }
    }
}

fn problem_at(text: &str, line: u64) -> LineProblem {
    match first_error(text) {
        CarmenError::Malformed {
            path,
            line: l,
            problem,
        } => {
            assert_eq!(path, Path::new("test.clf"));
            assert_eq!(l, line, "{text:?}: {problem}");
            problem
        }
        other => panic!("{other}"),
    }
}

/// Malformed lines and a fragment of the `Debug` form of the problem each must produce.
const BAD_LINES: [(&str, &str); 21] = [
    (
        "FLASER 3 1.0 x 1.0 0 0 0 0 0 0 1 h 1",
        "BadNumber { message: \"FLASER\", field: \"range_reading\"",
    ),
    (
        "FLASER 3 1.0 1.0 0 0 0 0 0 0 1 h 1",
        "TokenCount { message: \"FLASER\", expected: 14, found: 13",
    ),
    (
        "FLASER 3 1.0 1.0 1.0 0 0 0 0 0 0 1 h 1 extra",
        "TokenCount { message: \"FLASER\", expected: 14, found: 15",
    ),
    (
        "FLASER -3 1.0",
        "BadNumber { message: \"FLASER\", field: \"num_readings\"",
    ),
    (
        "FLASER 3.0 1 2 3 0 0 0 0 0 0 1 h 1",
        "field: \"num_readings\", token: \"3.0\"",
    ),
    (
        "FLASER",
        "MissingField { message: \"FLASER\", field: \"num_readings\"",
    ),
    (
        "FLASER 1000000000000 1 2",
        "CountTooLarge { message: \"FLASER\", field: \"num_readings\"",
    ),
    (
        "FLASER 99999999999999999999999 1",
        "BadNumber { message: \"FLASER\", field: \"num_readings\"",
    ),
    (
        "FLASER 50000 1 2 3",
        "TokenCount { message: \"FLASER\", expected: 50011, found: 5",
    ),
    (
        "FLASER 3 1 1 1 nan 0 0 0 0 0 1 h 1",
        "field: \"laser_pose\", token: \"nan\"",
    ),
    (
        "FLASER 3 1 1 1 0 0 0 0 inf 0 1 h 1",
        "field: \"odometry_pose\", token: \"inf\"",
    ),
    (
        "FLASER 3 1 1 1 0 0 0 0 0 0 nan h 1",
        "field: \"ipc_timestamp\"",
    ),
    (
        "FLASER 3 1 1 1 0 0 0 0 0 0 1 h x",
        "field: \"logger_timestamp\"",
    ),
    (
        "ODOM 1 2 3 4 5 6 7 h",
        "TokenCount { message: \"ODOM\", expected: 10, found: 9",
    ),
    (
        "ODOM 1 2 3 4 5 z 7 h 8",
        "BadNumber { message: \"ODOM\", field: \"accel\"",
    ),
    (
        "PARAM robot_frontlaser_offset abc h 0",
        "BadNumber { message: \"PARAM\", field: \"param_value\"",
    ),
    (
        "PARAM robot_front_laser_max -1 h 0",
        "BadNumber { message: \"PARAM\", field: \"param_value\"",
    ),
    (
        "PARAM lonely",
        "MissingField { message: \"PARAM\", field: \"param_value\"",
    ),
    (
        "ROBOTLASER1 0 -1.5 3 0.75 30 0.01 0 2 1 2 1 5",
        "TokenCount { message: \"ROBOTLASER1\"",
    ),
    (
        "ROBOTLASER1 0 -1.5 3 0.003 30 0.01 0 900 1 2",
        "expected: 924, found: 11",
    ),
    (
        "ROBOTLASER1 x",
        "BadNumber { message: \"ROBOTLASER1\", field: \"laser_type\"",
    ),
];

#[test]
fn every_kind_of_bad_line_is_an_error_on_its_line() {
    let good = flaser(3, "1.0", "1.0");
    for (bad, expected) in BAD_LINES {
        let text = format!("# header\n{good}{bad}\n{good}");
        let problem = format!("{:?}", problem_at(&text, 3));
        assert!(problem.contains(expected), "{bad:?} gave {problem}");
    }
}

#[test]
fn error_message_names_file_and_line() {
    let text = format!(
        "{}FLASER 2 1.0 oops 0 0 0 0 0 0 1 h 1\n",
        flaser(2, "1", "1")
    );
    let message = first_error(&text).to_string();
    assert!(
        message.starts_with("test.clf:2: FLASER: field `range_reading`"),
        "{message}"
    );
    assert!(message.contains("`oops`"), "{message}");
}

#[test]
fn truncated_last_line_is_an_error() {
    let full = flaser(180, "1.5", "7.0");
    let text = format!("{full}{}", &full[..full.len() / 2]);
    assert!(matches!(
        problem_at(&text, 2),
        LineProblem::TokenCount { .. } | LineProblem::BadNumber { .. }
    ));
}

#[test]
fn non_utf8_is_an_error_naming_the_line() {
    let mut bytes = flaser(2, "1", "1").into_bytes();
    bytes.extend_from_slice(b"FLASER 1 \xff\xfe 0 0 0 0 0 0 1 h 1\n");
    let mut r = CarmenReader::from_reader(&bytes[..], "bin.clf", ReaderOptions::default());
    assert!(r.next_scan().unwrap().is_some());
    let e = r.next_scan().unwrap_err();
    assert_eq!(e.line(), Some(2));
    assert!(matches!(
        e,
        CarmenError::Malformed {
            problem: LineProblem::NotUtf8,
            ..
        }
    ));
}

#[test]
fn overlong_lines_are_rejected_and_skippable() {
    let options = ReaderOptions {
        max_line_bytes: 100,
        ..ReaderOptions::default()
    };
    let long = flaser(100, "1.0", "1.0");
    let text = format!("{long}{}", flaser(2, "1", "2"));
    let e = reader(&text, options.clone()).next_scan().unwrap_err();
    assert!(matches!(
        e,
        CarmenError::Malformed {
            line: 1,
            problem: LineProblem::TooLong { limit_bytes: 100 },
            ..
        }
    ));
    let mut r = reader(
        &text,
        ReaderOptions {
            skip_bad_lines: true,
            ..options
        },
    );
    let scan = r.next_scan().unwrap().unwrap();
    assert_eq!(scan.stamp.text, "2");
    assert_eq!((r.stats().bad_lines, r.stats().lines), (1, 2));
}

#[test]
fn skip_mode_counts_and_remembers_the_first_few() {
    let mut text = String::new();
    for i in 0..20 {
        text += &flaser(2, "1", &format!("{i}"));
        text += "FLASER 2 1 bad 0 0 0 0 0 0 1 h 1\n";
    }
    let options = ReaderOptions {
        skip_bad_lines: true,
        max_bad_line_messages: 3,
        ..ReaderOptions::default()
    };
    let mut r = reader(&text, options);
    let scans: Vec<_> = (&mut r).collect::<Result<_, _>>().unwrap();
    assert_eq!(scans.len(), 20);
    let stats = r.stats();
    assert_eq!((stats.bad_lines, stats.scans, stats.lines), (20, 20, 40));
    assert_eq!(stats.bad_line_messages.len(), 3);
    assert!(
        stats.bad_line_messages[0].starts_with("test.clf:2: "),
        "{}",
        stats.bad_line_messages[0]
    );
    assert!(stats.bad_line_messages[2].starts_with("test.clf:6: "));
}

#[test]
fn the_iterator_goes_on_after_a_bad_line() {
    let text = format!("{}FLASER x\n{}", flaser(2, "1", "1"), flaser(2, "1", "3"));
    let results: Vec<_> = reader(&text, ReaderOptions::default()).collect();
    assert_eq!(results.len(), 3);
    assert!(results[0].is_ok() && results[1].is_err() && results[2].is_ok());
}

#[test]
fn missing_file_is_an_io_error_naming_it() {
    let e = CarmenReader::open("/nonexistent/polymap/x.clf", ReaderOptions::default()).unwrap_err();
    assert!(matches!(e, CarmenError::Io { .. }));
    assert!(
        e.to_string().starts_with("/nonexistent/polymap/x.clf: "),
        "{e}"
    );
}

#[test]
fn many_distinct_unknown_types_stay_bounded() {
    let text: String = (0..1000)
        .map(|i| format!("TYPE{i} 1\n"))
        .collect::<String>()
        + &"X".repeat(500);
    let mut r = reader(&text, ReaderOptions::default());
    assert!(r.next_scan().unwrap().is_none());
    let stats = r.stats();
    assert!(stats.skipped_types.len() <= 257);
    assert_eq!(stats.skipped_lines(), 1001);
    assert_eq!(stats.skipped_types[OTHER_TYPES], 1000 - 256 + 1);
}

/// Mutations of a valid log: arbitrary bytes anywhere must give scans or errors, never a panic.
fn exercise(bytes: &[u8], skip_bad_lines: bool) {
    let options = ReaderOptions {
        skip_bad_lines,
        max_line_bytes: 4096,
        ..ReaderOptions::default()
    };
    let mut r = CarmenReader::from_reader(bytes, "fuzz.clf", options);
    for _ in 0..10_000 {
        match r.next_record() {
            Ok(None) => break,
            Ok(Some(_)) => {}
            Err(e) => {
                assert!(e.line().is_some());
                assert!(!skip_bad_lines);
            }
        }
    }
    let stats = r.stats();
    assert!(stats.scans + stats.bad_lines <= stats.lines);
}

fn carmen_like_text() -> impl Strategy<Value = String> {
    let token = prop_oneof![
        Just("FLASER".to_string()),
        Just("ROBOTLASER1".to_string()),
        Just("ODOM".to_string()),
        Just("PARAM".to_string()),
        Just("robot_frontlaser_offset".to_string()),
        Just("nan".to_string()),
        Just("\n".to_string()),
        (0u32..400).prop_map(|n| n.to_string()),
        (-1e3f64..1e3).prop_map(|v| v.to_string()),
        "[a-z#]{1,4}",
    ];
    proptest::collection::vec(token, 0..400).prop_map(|t| t.join(" "))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..2000)) {
        exercise(&bytes, false);
        exercise(&bytes, true);
    }

    #[test]
    fn carmen_like_tokens_never_panic(text in carmen_like_text()) {
        exercise(text.as_bytes(), false);
        exercise(text.as_bytes(), true);
    }

    #[test]
    fn corrupting_a_valid_line_never_panics(at in 0usize..600, byte in any::<u8>(), cut in 0usize..700) {
        let mut bytes = flaser(30, "1.25", "5.5").into_bytes();
        bytes.extend_from_slice(b"ROBOTLASER1 0 -1.5 3 0.75 30 0.01 0 2 1 2 1 5 0 0 0 0 0 0 0 0 0 0 0 1 h 1\n");
        let at = at % bytes.len();
        bytes[at] = byte;
        bytes.truncate(cut.min(bytes.len()));
        exercise(&bytes, false);
        exercise(&bytes, true);
    }
}

/// A log of `ODOM` and `FLASER` lines from `(is_odometry, step of the stamp, same pose)`
/// triples (stamps may stall or go back; a scan may carry the last message's pose), and each
/// line's kind and stamp text in file order.
fn odometry_and_scans(lines: &[(bool, f64, bool)]) -> (String, Vec<(bool, String)>) {
    let (mut text, mut order) = (String::new(), Vec::new());
    let (mut t, mut x) = (100.0, 0.0);
    for (i, &(is_odometry, step, same)) in lines.iter().enumerate() {
        t += step;
        let stamp = format!("{:.6}", t + i as f64 * 1e-6);
        if !same {
            x += 0.1;
        }
        text += &match is_odometry {
            true => format!("ODOM {x} 0 0 0 0 0 {stamp} h 0\n"),
            false => format!("FLASER 2 1.0 1.0 0 0 0 {x} 0 0 {stamp} h 0\n"),
        };
        order.push((is_odometry, stamp));
    }
    (text, order)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// Scans held for later odometry (stale odometry, `ReaderOptions::stale_odometry_s`) come
    /// back, every one, in file order among the odometry messages.
    #[test]
    fn held_scans_keep_the_file_order(
        lines in proptest::collection::vec((any::<bool>(), -1.0f64..3.0, any::<bool>()), 0..300)
    ) {
        let (text, order) = odometry_and_scans(&lines);
        let mut r = reader(&text, ReaderOptions::default());
        let mut got = Vec::new();
        while let Some(record) = r.next_record().unwrap() {
            got.push(match record {
                CarmenRecord::Odometry(o) => (true, o.stamp.text),
                CarmenRecord::Scan(s) => (false, s.stamp.text),
            });
        }
        prop_assert_eq!(got, order);
        let s = r.stats();
        prop_assert!(s.stale_odometry.count + s.stale_odometry_kept.count <= s.scans);
    }
}

/// `polymap map - < /dev/zero` spun forever, discarding a line that never ends: without
/// skipping the first line too long is the error; with skipping, a line without an end after
/// 16 times the limit is.
#[test]
fn an_endless_line_ends_the_reader() {
    let options = ReaderOptions {
        max_line_bytes: 100,
        ..ReaderOptions::default()
    };
    let endless = || std::io::BufReader::new(std::io::repeat(0));
    let mut r = CarmenReader::from_reader(endless(), "<stdin>", options.clone());
    assert!(matches!(
        r.next_scan(),
        Err(CarmenError::Malformed {
            problem: LineProblem::TooLong { .. },
            ..
        })
    ));
    let skipping = ReaderOptions {
        skip_bad_lines: true,
        ..options
    };
    let mut r = CarmenReader::from_reader(endless(), "<stdin>", skipping);
    let e = r.next_scan().unwrap_err();
    assert!(
        e.to_string().contains("without an end: not a text log"),
        "{e}"
    );
}
