//! # polymap — geometric robot mapping
//!
//! Turns a stream of 2D laser range scans into a compact global map of a few generalized
//! polylines and the robot's trajectory, following "Geometric Robot Mapping" (Lakaemper,
//! Latecki, Sun, Wolter). Metres and radians throughout; frames are named in identifiers.
//!
//! The pipeline, one module per stage, in order:
//!
//! - [`scan`]: range scans and their conversion to points.
//! - [`geometry`]: points, SE(2) poses, segments, undirected angles.

#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod align;
pub mod config;
pub mod cost;
pub mod directions;
pub mod extract;
pub mod geometry;
pub mod grid;
pub mod map;
pub mod mapper;
pub mod merge;
pub mod polyline;
pub mod scan;

#[cfg(test)]
mod testutil;
