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

use polymap::geometry::{Segment, Vec2};

/// Cell size of the segment indexes, metres (as the map's, `map.grid_cell_m`).
const CELL_M: f64 = 0.5;
/// Nearest queries up to this distance look at one cell, metres: the gates used here (point
/// tolerances, the wall alignment's 1 m first gate) are within it.
const REACH_M: f64 = 1.0;

/// Most sample pieces taken along one segment; bounds the work on absurdly long input.
const MAX_PIECES_PER_SEGMENT: f64 = 1.0e6;

/// Length of some segments, and how much of it a test covers.
#[derive(Debug, Clone, Copy, Default)]
struct Coverage {
    total_m: f64,
    covered_m: f64,
}

impl Coverage {
    fn ratio(&self) -> Option<f64> {
        (self.total_m > 0.0).then(|| self.covered_m / self.total_m)
    }
}

/// The segments cut into pieces of at most `step_m` (metres), each piece's midpoint given to
/// `covered` with its segment's index; a piece counts as covered by its whole length. Segments
/// that are not finite, or of zero length, are left out.
fn coverage(
    segments: &[Segment],
    step_m: f64,
    mut covered: impl FnMut(usize, Vec2) -> bool,
) -> Coverage {
    let mut c = Coverage::default();
    for (i, s) in segments.iter().enumerate().filter(|(_, s)| s.is_finite()) {
        let length_m = s.length();
        if length_m == 0.0 {
            continue;
        }
        let pieces = (length_m / step_m)
            .ceil()
            .clamp(1.0, MAX_PIECES_PER_SEGMENT);
        let near = (0..pieces as usize)
            .filter(|&k| covered(i, s.start + s.vector() * ((k as f64 + 0.5) / pieces)))
            .count();
        c.total_m += length_m;
        c.covered_m += near as f64 * (length_m / pieces);
    }
    c
}

#[cfg(test)]
mod tests;
