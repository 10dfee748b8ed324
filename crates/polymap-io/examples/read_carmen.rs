//! Reads a CARMEN log and prints what it holds and how long reading took.
//!
//! `cargo run --release -p polymap-io --example read_carmen -- ../shared/datasets/intel/intel.clf`

use std::process::ExitCode;
use std::time::Instant;

use polymap_io::carmen::{CarmenReader, ReaderOptions};

fn main() -> ExitCode {
    let Some(path) = std::env::args().nth(1) else {
        eprintln!("usage: read_carmen LOG.clf");
        return ExitCode::FAILURE;
    };
    let start = Instant::now();
    let mut reader = match CarmenReader::open(&path, ReaderOptions::default()) {
        Ok(reader) => reader,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let mut beams = 0usize;
    loop {
        match reader.next_scan() {
            Ok(Some(scan)) => beams += scan.ranges_m.len(),
            Ok(None) => break,
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::FAILURE;
            }
        }
    }
    let elapsed_s = start.elapsed().as_secs_f64();
    let stats = reader.stats();
    println!(
        "{path}: {} scans, {beams} readings in {elapsed_s:.3} s",
        stats.scans
    );
    println!("{stats:#?}");
    ExitCode::SUCCESS
}
