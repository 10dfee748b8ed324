//! # polymap-io — reading logs and writing results
//!
//! File formats at the edges of the polymap pipeline. Everything inside is in metres and
//! radians; frames are named in identifiers (`odom_from_robot`, `p_in_map`).
//!
//! Readers (logs in):
//!
//! - [`carmen`]: a streaming CARMEN log reader (`FLASER`, `ROBOTLASER1`, `ODOM`, `PARAM`), one
//!   [`RangeScan`](polymap::scan::RangeScan) at a time, and a writer of the same format.
//! - [`source`]: the [`ScanSource`](source::ScanSource) trait the mapping pipeline reads, and
//!   [`open_log`](source::open_log) (files or standard input, gzip and bzip2 read directly).
//!
//! - [`ros`]: ROS recordings — ROS 1 bags, ROS 2 MCAP files, rosbag2 sqlite3 files and
//!   folders — read without ROS (`LaserScan` and `Odometry` decoded by hand), and writers of
//!   bags and MCAP files.
//! - [`log`]: the one entry point, [`log::LogSource`], that tells a log's kind by its content
//!   and yields its scans whatever the format.
//!
//! Writers (results out, formats in `docs/MAP_FORMAT.md`):
//!
//! - [`tum`]: trajectories in the TUM format (`stamp x y z qx qy qz qw`), and a reader.
//! - [`map_json`]: the `map.json` contract (segments, polylines), and a reader.
//! - [`snapshot`]: the map snapshot every writer takes (here and in `polymap-export`).
//! - [`atomic`]: every output is written to a temporary file and renamed into place.
//!
//! [`input_file`] refuses what is not a regular file where a file is needed (a device, a FIFO)
//! and bounds what a file read whole may weigh.
//!
//! [`printable`] escapes control bytes from a log before they reach a terminal.
//!
//! Each format has its own error type carrying the file and, where it applies, the 1-based line.

#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod atomic;
pub mod carmen;
pub mod input_file;
pub mod log;
pub mod loop_nodes;
pub mod map_json;
pub mod printable;
pub mod ros;
pub mod snapshot;
pub mod source;
pub mod tum;
