//! Doubled walls: map length that another, nearly parallel map segment lies beside.
//!
//! A wall drawn twice a few centimetres apart (a scan's sighting the merge did not join, or a
//! loop that did not close) explains the scan points as well as one wall, so the points near
//! the map do not show it; this measure does. Collinear pieces that meet end to end are not
//! doubled: a sample counts only where it lies beside the other segment, its foot strictly
//! inside it.

use polymap::geometry::{Segment, Vec2, angle_between_directions_rad};
use polymap::segment_index::SegmentIndex;
use serde::Serialize;

use super::{CELL_M, REACH_M, coverage};

/// Settings of [`doubled_walls`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DoubledParams {
    /// A sample is doubled when another segment lies within this distance of it, metres.
    /// Default 0.15.
    pub within_m: f64,
    /// ...and turns from its segment by at most this, degrees. Default 10.
    pub within_deg: f64,
    /// Segments are cut into pieces of at most this length, each tested at its midpoint,
    /// metres. Default 0.05. Non-positive or non-finite values fall back to the default.
    pub sample_step_m: f64,
}

impl Default for DoubledParams {
    fn default() -> Self {
        DoubledParams {
            within_m: 0.15,
            within_deg: 10.0,
            sample_step_m: 0.05,
        }
    }
}

/// How much of a map's length is doubled.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DoubledWalls {
    /// The parameters used.
    pub params: DoubledParams,
    /// Total map segment length, metres.
    pub map_length_m: f64,
    /// Map length beside another segment (see the module docs), metres.
    pub doubled_length_m: f64,
    /// `doubled_length_m / map_length_m`, in `[0, 1]`; `None` for an empty map.
    pub share: Option<f64>,
}

/// Measures the doubled length of a map's segments (any frame, metres).
///
/// ```
/// use polymap::geometry::{Segment, Vec2};
/// use polymap_eval::map_quality::{DoubledParams, doubled_walls};
/// // A 4 m wall drawn twice 5 cm apart over its first 2 m, and a wall continuing it end to end.
/// let map = [
///     Segment::new(Vec2::new(0.0, 0.0), Vec2::new(4.0, 0.0)),
///     Segment::new(Vec2::new(0.0, 0.05), Vec2::new(2.0, 0.05)),
///     Segment::new(Vec2::new(4.0, 0.0), Vec2::new(6.0, 0.0)),
/// ];
/// let d = doubled_walls(&map, &DoubledParams::default());
/// // 2 m of the long wall and the whole 2 m copy; the continuation is not doubled.
/// assert!((d.doubled_length_m - 4.0).abs() < 0.11);
/// assert!((d.share.unwrap() - 4.0 / 8.0).abs() < 0.02);
/// ```
pub fn doubled_walls(segments: &[Segment], params: &DoubledParams) -> DoubledWalls {
    let step_m = if params.sample_step_m > 0.0 && params.sample_step_m.is_finite() {
        params.sample_step_m
    } else {
        DoubledParams::default().sample_step_m
    };
    let within_m = params.within_m.max(0.0);
    let within_rad = params.within_deg.to_radians();
    let reach = Vec2::splat(within_m);
    let directions: Vec<f64> = segments.iter().map(Segment::direction_rad).collect();
    let index = SegmentIndex::from_segments(segments, CELL_M, REACH_M);
    let c = coverage(segments, step_m, |i, p| {
        let mut beside = false;
        index.for_keys_in_box(p - reach, p + reach, |j| {
            if beside
                || j == i
                || angle_between_directions_rad(directions[j], directions[i]) > within_rad
            {
                return;
            }
            let foot = segments[j].project(p);
            beside = foot.t > 0.0 && foot.t < 1.0 && foot.distance_2 <= within_m * within_m;
        });
        beside
    });
    DoubledWalls {
        params: *params,
        map_length_m: c.total_m,
        doubled_length_m: c.covered_m,
        share: c.ratio(),
    }
}
