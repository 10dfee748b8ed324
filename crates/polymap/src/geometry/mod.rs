//! Plain geometric types: points, SE(2) poses, line segments and undirected angles; grid cells.
//!
//! Everything is in metres and radians. Frames are named in variable names
//! (`p_in_map`, `map_from_scan`), never implied.

mod angle;
mod cells;
mod pose;
mod segment;

pub use angle::{angle_between_directions_rad, normalize_angle_rad, undirected_angle_rad};
pub use cells::floor_i64;
pub use pose::Pose2;
pub use segment::{Segment, SegmentProjection};

/// A 2D point or vector, in metres.
pub type Vec2 = glam::DVec2;
