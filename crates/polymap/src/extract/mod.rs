//! Scan to segments ([`extract_segments`]; [`extract_segments_closed`] for a 360° scan, whose
//! last point neighbours its first): split the points at range jumps, simplify each run by Discrete Curve
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
    /// Number of supporting points (consecutive from `first_point`; in a closed scan they may
    /// wrap past the last point to the first, see [`extract_segments_closed`]).
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
        extract_run(
            &points[run.clone()],
            run.start,
            params,
            &mut vertices,
            &mut out,
        );
    }
    out
}

/// Extracts line segments from the points of a scan that closes on itself (a 360° scan):
/// the last point is followed by the first.
///
/// The curve is not broken at the seam between the last beam and the first: when no range
/// jump separates them, the run that ends the scan and the run that starts it are one run. A
/// scan without any jump is one closed curve, cut at one of its corners (a vertex kept by DCE),
/// so that no wall is split by the cut. A real gap at the seam splits the curve as anywhere
/// else. A segment's points then run from `first_point` on, wrapping past the last point to
/// the first.
///
/// ```
/// use polymap::extract::{extract_segments_closed, ExtractParams};
/// use polymap::geometry::Vec2;
/// // A 4 m × 4 m room seen from its centre, one point per degree, starting mid-wall.
/// let pts: Vec<Vec2> = (0..360)
///     .map(|i| {
///         let a = (i as f64).to_radians();
///         let r = 2.0 / a.cos().abs().max(a.sin().abs());
///         Vec2::new(r * a.cos(), r * a.sin())
///     })
///     .collect();
/// let segs = extract_segments_closed(&pts, 1f64.to_radians(), &ExtractParams::default());
/// assert_eq!(segs.len(), 4); // four walls, the one at the seam in one piece
/// assert!(segs.iter().all(|s| (s.segment.length() - 4.0).abs() < 0.2));
/// ```
pub fn extract_segments_closed(
    points: &[Vec2],
    angle_increment_rad: f64,
    params: &ExtractParams,
) -> Vec<ExtractedSegment> {
    let n = points.len();
    let runs = split_runs(points, angle_increment_rad, params);
    if n < 3 || is_jump(points[n - 1], points[0], angle_increment_rad, params) {
        return extract_segments(points, angle_increment_rad, params);
    }
    let mut out = Vec::new();
    let mut vertices = Vec::new();
    let ring: Vec<Vec2>;
    let start;
    if runs.len() == 1 {
        // One closed curve: start it at a corner, and close it by repeating that point.
        simplify_run(points, params.tolerance_m, &mut vertices);
        start = corner(points, &vertices);
        ring = points[start..]
            .iter()
            .chain(&points[..=start])
            .copied()
            .collect();
    } else {
        // The last run continues into the first.
        let (first, last) = (runs[0].clone(), runs[runs.len() - 1].clone());
        for run in &runs[1..runs.len() - 1] {
            extract_run(
                &points[run.clone()],
                run.start,
                params,
                &mut vertices,
                &mut out,
            );
        }
        start = last.start;
        ring = points[last].iter().chain(&points[first]).copied().collect();
    }
    let mut wrapped = Vec::new();
    extract_run(&ring, 0, params, &mut vertices, &mut wrapped);
    out.extend(wrapped.into_iter().map(|s| ExtractedSegment {
        first_point: (start + s.first_point) % n,
        ..s
    }));
    out
}

/// The interior DCE vertex where the curve turns most: a corner to cut a closed curve at.
fn corner(points: &[Vec2], vertices: &[usize]) -> usize {
    let turn = |w: &[usize]| {
        let (a, b, c) = (points[w[0]], points[w[1]], points[w[2]]);
        let (u, v) = (b - a, c - b);
        let cos = u.dot(v) / (u.length() * v.length()).max(1e-12);
        -cos
    };
    vertices
        .windows(3)
        .max_by(|x, y| turn(x).total_cmp(&turn(y)))
        .map_or(0, |w| w[1])
}

/// Simplifies one run and refits its segments; `offset` is the run's first index.
fn extract_run(
    run_points: &[Vec2],
    offset: usize,
    params: &ExtractParams,
    vertices: &mut Vec<usize>,
    out: &mut Vec<ExtractedSegment>,
) {
    if run_points.len() < params.min_points.max(2) {
        return;
    }
    simplify_run(run_points, params.tolerance_m, vertices);
    for w in vertices.windows(2) {
        let (a, b) = (w[0], w[1]);
        if let Some(s) = refit(run_points, a, b, params) {
            out.push(ExtractedSegment {
                first_point: offset + a,
                ..s
            });
        }
    }
}

/// True when consecutive points `a` and `b` are too far apart to be on one surface.
fn is_jump(a: Vec2, b: Vec2, angle_increment_rad: f64, params: &ExtractParams) -> bool {
    let r = a.length().min(b.length());
    let jump_m = params
        .jump_min_m
        .max(params.jump_beam_factor * r * angle_increment_rad.abs());
    b.distance_squared(a) > jump_m * jump_m
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
        if is_jump(points[i - 1], points[i], angle_increment_rad, params) {
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
