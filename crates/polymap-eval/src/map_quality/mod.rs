//! Map quality: the map against the data, and the map against the true walls.
//!
//! - [`map_fit_to_points`]: share of scan points near the map, RMS distance.
//! - [`map_vs_walls`]: precision and recall of the map against a simulated world's walls.
//! - [`SegmentIndex`]: the R-tree nearest-segment query both use, beside a brute-force oracle.

mod points;
mod segment_index;
mod walls;

pub use points::{PointFit, PointFitParams, map_fit_to_points};
pub use segment_index::{NearestSegment, SegmentIndex, nearest_segment_brute_force};
pub use walls::{TrueWall, WallParams, WallScore, align_map_to_walls, map_vs_walls};

#[cfg(test)]
mod tests;
