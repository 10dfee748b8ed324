//! # polymap-sim — synthetic laser logs with exact ground truth
//!
//! Builds 2D worlds of walls and round pillars, drives a robot through them, and records
//! what a laser range finder and wheel odometry would have reported, together with the true
//! poses and the true walls. Pure data in, data out: no file I/O (writers live in
//! `polymap-io`). Metres and radians; ground truth is in the **world frame**, and
//! [`poses_in_first_frame`] re-expresses it in the first scan's frame, where a mapper works.
//!
//! The parts, in the order a run uses them:
//!
//! - [`world`]: [`World`] (walls, pillars, waypoints) and the catalogue of built-in worlds:
//!   [`World::hallway45`] (default), [`World::hex60`], [`World::clutter`], [`World::office`],
//!   and four that make tracking hard: [`World::corridor`] (bare in the middle),
//!   [`World::ring`] (a pillar and a box its only features), [`World::curve`] (two circular
//!   bends), [`World::hall360`] (360° laser); and one that changes during the tour:
//!   [`World::moved`] (a cupboard carried elsewhere half way, [`world::Moved`]).
//!   Each world names the laser it is seen with ([`World::sim_params`]).
//! - [`path`]: waypoints → a smooth, speed- and turn-rate-limited trajectory.
//! - [`raycast`]: nearest hit along a ray; a grid-accelerated [`RayCaster`] and a brute-force
//!   oracle.
//! - [`laser`]: beams, range noise, dropouts and no-returns ([`LaserParams`]).
//! - [`odometry`]: drifting dead reckoning ([`OdometryParams`]).
//! - [`truth`]: which truth walls were seen, and frame changes.
//! - [`simulate()`]: all of the above, one call, deterministic for a seed ([`SimParams`] in,
//!   [`SimRun`] out).
//!
//! ```
//! use polymap_sim::{SimParams, World, simulate};
//! let run = simulate(&World::default(), &SimParams { max_scans: Some(5), ..SimParams::default() }, 1);
//! assert_eq!(run.world_name, "hallway45");
//! assert_eq!(run.scans.len(), run.true_poses.len());
//! assert_eq!(run.scans[0].ranges_m.len(), 180);
//! ```

#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod laser;
pub mod odometry;
pub mod params;
pub mod path;
pub mod raycast;
mod simulate;
pub mod truth;
pub mod world;
mod worlds;

pub use laser::LaserParams;
pub use odometry::OdometryParams;
pub use params::{ParamError, SimParams};
pub use path::PathParams;
pub use raycast::RayCaster;
pub use simulate::{SimRun, simulate};
pub use truth::poses_in_first_frame;
pub use world::{DEFAULT_WORLD_NAME, Pillar, World, world_by_name};
