//! # polymap — geometric robot mapping
//!
//! Turns a stream of 2D laser range scans into a compact global map of a few generalized
//! polylines and the robot's trajectory, following "Geometric Robot Mapping" (Lakaemper,
//! Latecki, Sun, Wolter). Metres and radians throughout; frames are named in identifiers.
//!
//! The pipeline, one module per stage, in order:
//!
//! - [`scan`]: range scans and their conversion to points.
//! - [`extract`]: points to segments (Discrete Curve Evolution, total least squares refit).
//! - [`polyline`]: segments to generalized polylines.
//! - [`align`]: ICP of a scan against the map (endpoint and point-to-segment correspondences,
//!   coarse rotation search); global alignment of a second map or a scan without a guess.
//! - [`directions`]: main directions from the length-weighted direction histogram.
//! - [`cost`]: the merged segment `ms(L1, L2, ad)` and the cost `C(L1, L2, ad)`.
//! - [`merge`]: vertex insertion, restrictive pairing, simplification; a second map into the
//!   map.
//! - [`mapper`]: the incremental loop owning `G_t`.
//! - [`loops`]: loop closure over a pose graph of trajectory stretches (an addition).
//! - [`observe`]: what each scan saw of the map and saw through, and pruning the segments
//!   later scans contradict (an addition).
//!
//! Support: [`geometry`] (points, SE(2) poses, segments, undirected angles), [`map`] (the map
//! store), [`segment_index`] (the workspace's one spatial index over segments: the map's, ICP's,
//! the merge's and the evaluation's), [`config`] (the configuration tree and presets).

#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod align;
pub mod check;
pub mod config;
pub mod cost;
pub mod directions;
pub mod extract;
pub mod geometry;
pub mod loops;
pub mod map;
pub mod mapper;
pub mod merge;
pub mod motion;
pub mod observe;
pub mod polyline;
pub mod scan;
pub mod segment_index;

#[cfg(test)]
mod testutil;
