//! End-to-end criterion bench: what `polymap map` does for the map, without writing outputs.
//!
//! Each iteration opens the log, reads every scan with `polymap_io::carmen::CarmenReader` and
//! pushes it into a fresh default-configured `Mapper`:
//!
//! - `end_to_end/intel_first_2000`: the first 2,000 scans of the Intel log, read from the file
//!   (skipped, with a `SKIPPED` line, when `../shared/datasets/intel/intel.clf` is absent;
//!   `POLYMAP_DATASETS` points elsewhere).
//! - `end_to_end/hallway45_600`: 600 scans of the simulated `hallway45` world, written once as a
//!   CARMEN log in memory and read from there, so this one runs without the datasets.
//!
//! Throughput is in scans (`elem/s` = scans/s). Ten samples each, about 8 s of measurement
//! per bench: the group takes about 20 s (Intel's 2,000 scans are one run per sample).
//!
//! Run: `cargo bench -p polymap --bench end_to_end`.

mod support;

use std::hint::black_box;
use std::io::{BufRead, Cursor};
use std::path::Path;
use std::time::Duration;

use criterion::{Criterion, SamplingMode, Throughput};
use polymap::config::Config;
use polymap::mapper::Mapper;
use polymap_io::carmen::{CarmenReader, CarmenWriter, ReaderOptions};
use support::{hallway45_scans, intel_log};

const INTEL_SCANS: usize = 2_000;
const HALLWAY_SCANS: usize = 600;

/// Reads up to `max_scans` scans and maps them; returns the number of map segments.
/// (Intel's first 2,000 scans take about 0.6 s on the 2-core development machine.)
fn map_log<R: BufRead>(mut reader: CarmenReader<R>, max_scans: usize) -> usize {
    let mut mapper = Mapper::new(Config::default());
    for _ in 0..max_scans {
        match reader.next_scan() {
            Ok(Some(scan)) => {
                black_box(mapper.push(&scan));
            }
            Ok(None) => break,
            Err(e) => panic!("{e}"),
        }
    }
    mapper.map().len()
}

fn open(path: &Path) -> CarmenReader<std::io::BufReader<std::fs::File>> {
    CarmenReader::open(path, ReaderOptions::default())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The simulated scans as the text of a CARMEN log, and how many there are.
fn hallway45_log() -> (Vec<u8>, usize) {
    let scans = hallway45_scans(HALLWAY_SCANS);
    let mut w = CarmenWriter::new(Vec::new(), "hallway45.clf").expect("writing to memory");
    for scan in &scans {
        w.write_scan(scan).expect("writing to memory");
    }
    (w.finish().expect("writing to memory"), scans.len())
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    let mut g = c.benchmark_group("end_to_end");
    g.sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(8));
    if let Some(log) = intel_log() {
        g.throughput(Throughput::Elements(INTEL_SCANS as u64));
        g.bench_function(format!("intel_first_{INTEL_SCANS}"), |b| {
            b.iter(|| map_log(open(&log), INTEL_SCANS))
        });
    }
    let (text, n) = hallway45_log();
    g.throughput(Throughput::Elements(n as u64));
    g.bench_function(format!("hallway45_{n}"), |b| {
        b.iter(|| {
            let reader = CarmenReader::from_reader(
                Cursor::new(text.as_slice()),
                "hallway45.clf",
                ReaderOptions::default(),
            );
            map_log(reader, HALLWAY_SCANS)
        })
    });
    g.finish();
    c.final_summary();
}
