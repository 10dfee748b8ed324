//! Scan to segments: split the points at range jumps, simplify each run by Discrete Curve
//! Evolution, refit each final segment to its points by total least squares.
//!
//! DCE (Latecki & Lakaemper) repeatedly removes the vertex of least relevance
//! `K = β·l1·l2 / (l1 + l2)`, where `β` is the turn angle at the vertex and `l1`, `l2` the lengths of
//! its two edges. A removal is only made while the simplified curve stays within
//! `tolerance_m` of every point it replaces; a vertex that cannot go is set aside until one of
//! its neighbours changes. With a binary heap this is O(n log n) for the usual scan.

mod dce;
mod fit;

use serde::{Deserialize, Serialize};

use crate::check::{Checks, InvalidParam};
use crate::geometry::{Segment, Vec2};
pub use dce::simplify_run;
pub use fit::{LineFit, fit_line};

/// Parameters of segment extraction.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ExtractParams {
    /// Consecutive points further apart than this always start a new run, metres.
    pub jump_min_m: f64,
    /// A gap also breaks a run when it exceeds this many beam spacings at the nearer point's
    /// range (the beam spacing at range `r` is `r · angle_increment`).
    pub jump_beam_factor: f64,
    /// Largest distance of a point from the simplified curve, metres.
    pub tolerance_m: f64,
    /// Segments supported by fewer points are dropped.
    pub min_points: usize,
    /// Segments shorter than this after the refit are dropped, metres.
    pub min_length_m: f64,
    /// Points further than this from the robot are ignored, metres (a log's own maximum range
    /// may claim far more; absurd ranges would otherwise make huge segments).
    pub max_range_m: f64,
}

impl Default for ExtractParams {
    fn default() -> Self {
        ExtractParams {
            jump_min_m: 0.3,
            jump_beam_factor: 5.0,
            tolerance_m: 0.05,
            min_points: 5,
            min_length_m: 0.15,
            max_range_m: 100.0,
        }
    }
}

impl ExtractParams {
    /// Checks every key's range; the error names the first key out of range.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        Checks::new()
            .above("jump_min_m", self.jump_min_m, 0.0, 100.0)
            .within("jump_beam_factor", self.jump_beam_factor, 0.0, 1e3)
            .above("tolerance_m", self.tolerance_m, 0.0, 10.0)
            .within("min_points", self.min_points, 2, 100_000)
            .within("min_length_m", self.min_length_m, 0.0, 100.0)
            .above("max_range_m", self.max_range_m, 0.0, 1e4)
            .done()
    }
}

/// A segment fitted to scan points, with its support.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExtractedSegment {
    /// The fitted segment, in the frame of the points.
    pub segment: Segment,
    /// Index of the first supporting point in the input slice.
    pub first_point: usize,
    /// Number of supporting points (consecutive from `first_point`).
    pub point_count: usize,
    /// RMS distance of the supporting points from the fitted line, metres.
    pub rms_m: f64,
}

/// Extracts line segments from points in beam order.
///
/// `angle_increment_rad` is the scan's bearing step, used to scale the range-jump threshold.
/// Points are in any frame whose origin is near the sensor (the robot frame is fine).
///
/// ```
/// use polymap::extract::{extract_segments, ExtractParams};
/// use polymap::geometry::Vec2;
/// // Two walls meeting at a right-angle corner, sampled every 5 cm.
/// let mut pts: Vec<Vec2> = (0..=40).map(|i| Vec2::new(2.0, -1.0 + 0.05 * i as f64)).collect();
/// pts.extend((1..=40).map(|i| Vec2::new(2.0 - 0.05 * i as f64, 1.0)));
/// let segs = extract_segments(&pts, 0.01, &ExtractParams::default());
/// assert_eq!(segs.len(), 2);
/// assert!((segs[0].segment.length() - 2.0).abs() < 0.01);
/// ```
pub fn extract_segments(
    points: &[Vec2],
    angle_increment_rad: f64,
    params: &ExtractParams,
) -> Vec<ExtractedSegment> {
    let mut out = Vec::new();
    let mut vertices = Vec::new();
    for run in split_runs(points, angle_increment_rad, params) {
        let run_points = &points[run.clone()];
        if run_points.len() < params.min_points.max(2) {
            continue;
        }
        simplify_run(run_points, params.tolerance_m, &mut vertices);
        for w in vertices.windows(2) {
            let (a, b) = (w[0], w[1]);
            if let Some(s) = refit(run_points, a, b, params) {
                out.push(ExtractedSegment {
                    first_point: run.start + a,
                    ..s
                });
            }
        }
    }
    out
}

/// Index ranges of runs of points without a range jump.
fn split_runs(
    points: &[Vec2],
    angle_increment_rad: f64,
    params: &ExtractParams,
) -> Vec<std::ops::Range<usize>> {
    let mut runs = Vec::new();
    let mut start = 0;
    for i in 1..points.len() {
        let r = points[i - 1].length().min(points[i].length());
        let jump_m = params
            .jump_min_m
            .max(params.jump_beam_factor * r * angle_increment_rad.abs());
        if points[i].distance_squared(points[i - 1]) > jump_m * jump_m {
            runs.push(start..i);
            start = i;
        }
    }
    if start < points.len() {
        runs.push(start..points.len());
    }
    runs
}

/// Refits the points `a..=b` of a run; `None` when the support is too small or short.
fn refit(
    run_points: &[Vec2],
    a: usize,
    b: usize,
    params: &ExtractParams,
) -> Option<ExtractedSegment> {
    let support = &run_points[a..=b];
    if support.len() < params.min_points {
        return None;
    }
    let fit = fit_line(support)?;
    let segment = Segment::new(
        fit.project(support[0]),
        fit.project(support[support.len() - 1]),
    );
    (segment.length() >= params.min_length_m).then_some(ExtractedSegment {
        segment,
        first_point: a,
        point_count: support.len(),
        rms_m: fit.rms_m,
    })
}

#[cfg(test)]
mod tests;
