//! Geometric robot mapping: 2D laser range scans, pushed one at a time, become the robot's
//! trajectory and a compact map of a few generalized polylines ("Geometric Robot Mapping",
//! Lakaemper, Latecki, Sun, Wolter). No I/O; metres and radians, frames named in identifiers.
//!
//! ```
//! use polymap::{config::Config, mapper::Mapper, tracking::Verdict};
//! use polymap_sim::{SimParams, World, simulate};
//!
//! // 60 scans of a simulated hallway: `RangeScan`s (ranges, beam angles, stamp, odometry).
//! let sim = SimParams { max_scans: Some(60), ..SimParams::default() };
//! let run = simulate(&World::hallway45(), &sim, 1);
//! let mut mapper = Mapper::new(Config::default());
//! let mut ok = 0;
//! for scan in &run.scans {
//!     let update = mapper.push(scan);
//!     let pose = update.map_from_robot; // map frame = the first scan's robot frame
//!     assert!(pose.x_m.is_finite() && pose.theta_rad.is_finite());
//!     // `Ok`, or `Weak` / `Lost` with a reason (a bare corridor, a poor fit, ...).
//!     ok += usize::from(update.diagnostics.tracking.verdict == Verdict::Ok);
//!     let (segments, polylines) = (mapper.segments(), mapper.polylines());
//!     assert!(polylines.iter().flatten().all(|&i| i < segments.len()));
//! }
//! mapper.finish().expect("loop closure ran"); // takes in pending loop corrections
//! let truth = run.true_poses_in_first_frame();
//! let (end, true_end) = (mapper.trajectory().last().unwrap(), truth.last().unwrap());
//! assert!(end.translation().distance(true_end.translation()) < 0.2);
//! assert!(!mapper.segments().is_empty());
//! assert!(ok * 10 >= run.scans.len() * 9, "{ok} scans ok");
//! ```
//!
//! Where to start: [`mapper::Mapper`] is the online mapper above (also continuing or
//! localizing on a saved map, [`mapper::Mapper::on_map`]); [`config::Config`] holds every
//! parameter, with presets. Reading logs is in `polymap-io`
//! (`polymap_io::log::LogSource::open` reads CARMEN logs and ROS recordings alike), a whole
//! run with its output folder in `polymap-pipeline` (`polymap_pipeline::pipeline::run`), and
//! simulated logs with ground truth in `polymap-sim`.
//!
//! The pipeline, one module per stage, in order:
//!
//! - [`scan`]: range scans and their conversion to points.
//! - [`extract`]: points to segments (Discrete Curve Evolution, total least squares refit).
//! - [`polyline`]: segments to generalized polylines.
//! - [`align`]: scan matching: ICP of a scan against the map (endpoint and point-to-segment
//!   correspondences, coarse rotation search), the likelihood raster and the exact correlative
//!   matcher, corner poses; global alignment of a second map or a scan without a guess.
//! - [`tracking`]: where each scan is: the motion prior, ICP from its starts, the window
//!   search, corner hypotheses and the verdict, with the state carried from scan to scan.
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
pub mod observe;
pub mod polyline;
pub mod scan;
pub mod segment_index;
pub mod tracking;

#[cfg(test)]
mod testutil;
