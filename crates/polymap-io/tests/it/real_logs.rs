//! The real CARMEN logs in `../shared/datasets`; each test skips with a message when absent.

use std::path::PathBuf;

use polymap::geometry::Pose2;
use polymap_io::carmen::{CarmenReader, CarmenRecord, CarmenStats, ReaderOptions};

/// The datasets folder: `$POLYMAP_DATASETS`, else `../shared/datasets` beside the repository.
fn datasets() -> PathBuf {
    match std::env::var_os("POLYMAP_DATASETS") {
        Some(dir) => PathBuf::from(dir),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/datasets"),
    }
}

/// What a whole log should contain.
struct Expected {
    scans: u64,
    beams: usize,
    odometry: u64,
    no_returns: u64,
    max_range_m: f64,
    frontlaser_offset_m: f64,
    backward_stamps: usize,
}

/// Reads a whole log; `None` (with a message) when the file is absent.
fn read_log(relative: &str, expected: &Expected) -> Option<CarmenStats> {
    let path = datasets().join(relative);
    if !path.exists() {
        eprintln!("SKIPPED: {} is absent", path.display());
        return None;
    }
    let mut reader = CarmenReader::open(&path, ReaderOptions::default()).unwrap();
    let mut last_seconds = f64::NEG_INFINITY;
    let mut backward = 0;
    while let Some(record) = reader.next_record().unwrap() {
        let CarmenRecord::Scan(scan) = record else {
            continue;
        };
        assert_eq!(
            scan.ranges_m.len(),
            expected.beams,
            "{relative} at {}",
            scan.stamp.text
        );
        assert_eq!(scan.max_range_m, expected.max_range_m);
        assert!(scan.odom_from_robot.is_some_and(|p| p.is_finite()));
        backward += usize::from(scan.stamp.seconds < last_seconds);
        last_seconds = scan.stamp.seconds;
        if reader.stats().scans > 1 {
            assert_eq!(
                scan.robot_from_laser,
                Pose2::new(expected.frontlaser_offset_m, 0.0, 0.0)
            );
        }
    }
    let stats = reader.stats().clone();
    assert_eq!(stats.scans, expected.scans, "{relative}");
    assert_eq!(stats.odometry_messages, expected.odometry, "{relative}");
    assert_eq!(stats.no_return_readings, expected.no_returns, "{relative}");
    assert_eq!(
        stats.valid_readings + stats.no_return_readings,
        expected.scans * expected.beams as u64
    );
    assert_eq!(stats.bad_lines, 0);
    assert!(stats.skipped_types.is_empty(), "{:?}", stats.skipped_types);
    assert_eq!(
        backward, expected.backward_stamps,
        "{relative}: backward time steps"
    );
    Some(stats)
}

#[test]
fn intel_has_13631_scans_of_180_beams() {
    let expected = Expected {
        scans: 13_631,
        beams: 180,
        odometry: 26_915,
        no_returns: 68_313, // all 81.83
        max_range_m: 50.0,
        frontlaser_offset_m: 0.0,
        backward_stamps: 631,
    };
    if let Some(stats) = read_log("intel/intel.clf", &expected) {
        assert_eq!(stats.params, 2);
    }
}

#[test]
fn aces_has_7374_scans_of_180_beams() {
    let expected = Expected {
        scans: 7_374,
        beams: 180,
        odometry: 7_375,
        no_returns: 11_139, // all 50.00, the log's cap
        max_range_m: 50.0,
        frontlaser_offset_m: 0.0,
        backward_stamps: 0,
    };
    read_log("aces/aces.clf", &expected);
}

#[test]
fn fr079_has_4934_scans_of_360_beams() {
    let expected = Expected {
        scans: 4_934,
        beams: 360,
        odometry: 8_951,
        no_returns: 36_881, // all 81.91
        max_range_m: 80.99, // PARAM robot_front_laser_max
        frontlaser_offset_m: -0.04,
        backward_stamps: 0,
    };
    if let Some(stats) = read_log("fr079/fr079.clf", &expected) {
        assert_eq!(stats.params, 187);
    }
}
