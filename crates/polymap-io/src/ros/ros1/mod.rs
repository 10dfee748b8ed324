//! ROS 1 bags (format 2.0): a reader in file order and a writer.
//!
//! A bag is the line `#ROSBAG V2.0`, then records: `uint32` header length, header fields
//! (`uint32` length, `name=value`), `uint32` data length, data. The header's `op` field says
//! what the record is: bag header (3), chunk (5), connection (7), message data (2), index data
//! (4), chunk info (6). Chunks hold connection and message records, compressed as their
//! `compression` field says.

mod fields;
mod reader;
mod writer;

pub use reader::{BAG_MAGIC, BagReader};
pub use writer::{BagCompression, BagWriter};
