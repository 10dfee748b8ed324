//! Map quality: the map against the data, and the map against the true walls.
//!
//! - [`map_fit_to_points`]: share of scan points near the map, RMS distance.
//! - [`map_vs_walls`]: precision and recall of the map against a simulated world's walls.
//! - [`doubled_walls`]: the share of the map's length drawn twice, side by side.
//!
//! All find nearest segments with the workspace's one index, `polymap::segment_index`.

mod doubled;
mod points;
mod walls;

pub use doubled::{DoubledParams, DoubledWalls, doubled_walls};
pub use points::{PointFit, PointFitParams, map_fit_to_points};
pub use walls::{TrueWall, WallParams, WallScore, align_map_to_walls, map_vs_walls};

/// Cell size of the segment indexes, metres (as the map's, `map.grid_cell_m`).
const CELL_M: f64 = 0.5;
/// Nearest queries up to this distance look at one cell, metres: the gates used here (point
/// tolerances, the wall alignment's 1 m first gate) are within it.
const REACH_M: f64 = 1.0;

#[cfg(test)]
mod tests;
