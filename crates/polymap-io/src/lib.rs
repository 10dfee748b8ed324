//! # polymap-io — reading logs and writing results
//!
//! File formats at the edges of the polymap pipeline. Everything inside is in metres and
//! radians; frames are named in identifiers (`odom_from_robot`, `p_in_map`).
//!
//! Readers (logs in):
//!
//! - [`carmen`]: a streaming CARMEN log reader (`FLASER`, `ROBOTLASER1`, `ODOM`, `PARAM`), one
//!   [`RangeScan`](polymap::scan::RangeScan) at a time, and a writer of the same format.
//!
//! Writers (results out, see "Contracts other tools rely on" in `ARCHITECTURE.md`):
//!
//! - [`tum`]: trajectories in the TUM format (`stamp x y z qx qy qz qw`), and a reader.
//! - [`map_json`]: the `map.json` contract (segments, polylines), and a reader.
//! - [`svg`]: the map, polylines, trajectory and scan points as a picture for a person.
//! - [`picture`]: what every map picture shares (extent, scale bar, palette).
//!
//! Each format has its own error type carrying the file and, where it applies, the 1-based line.

#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod carmen;
pub mod map_json;
pub mod picture;
pub mod svg;
pub mod tum;
