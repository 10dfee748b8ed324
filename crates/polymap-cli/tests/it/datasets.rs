//! Regression checks on the real logs, when `../shared/datasets` is present (skipped with a
//! visible message otherwise). Only short prefixes run here; whole logs are benchmarks.

use polymap::config::Config;
use polymap::mapper::Mapper;
use polymap_io::carmen::{CarmenReader, ReaderOptions};

use crate::support::datasets;

/// Intel's first 150 scans are taken standing still in a corridor. A constant-velocity guess
/// once turned ICP's drift along the corridor into a 47 m slide. A person walking by moves the
/// estimate a few centimetres (6.7 cm at scan 22 today); 15 cm catches any slide.
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
