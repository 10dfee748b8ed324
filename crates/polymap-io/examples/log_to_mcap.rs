//! Writes any log polymap reads (CARMEN, ROS 1 bag, MCAP, rosbag2) as a ROS 2 MCAP file with
//! `/scan`, `/odom` and tf, for playing it into `polymap ros2` (`scripts/live`):
//!
//! ```text
//! cargo run --release -p polymap-io --example log_to_mcap -- LOG OUT.mcap
//! ```
use std::path::PathBuf;
use std::process::ExitCode;

use polymap_io::log::{LogOptions, LogSource};
use polymap_io::ros::mcap_file::McapCompression;
use polymap_io::ros::{RecordOptions, write_mcap_with};

fn main() -> ExitCode {
    let args: Vec<PathBuf> = std::env::args_os().skip(1).map(PathBuf::from).collect();
    let [log, out] = &args[..] else {
        eprintln!("usage: log_to_mcap LOG OUT.mcap");
        return ExitCode::from(2);
    };
    let options = LogOptions {
        // Every scan with the odometry the log has, so that the recording carries it.
        witness_odometry: true,
        ..LogOptions::default()
    };
    let result = (|| -> Result<usize, Box<dyn std::error::Error>> {
        let mut source = LogSource::open(log, &options)?;
        let mut scans = Vec::new();
        while let Some(scan) = source.next_scan()? {
            scans.push(scan);
        }
        let with_odometry = RecordOptions {
            odometry_topic: true,
            tf: true,
        };
        write_mcap_with(out, &scans, McapCompression::Zstd, with_odometry)?;
        Ok(scans.len())
    })();
    match result {
        Ok(n) => {
            eprintln!("wrote {n} scans to {}", out.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("log_to_mcap: {e}");
            ExitCode::FAILURE
        }
    }
}
