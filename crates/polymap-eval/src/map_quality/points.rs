//! The map against the data: how close the scan points, placed by the estimated poses, fall to
//! the map's segments.

use polymap::geometry::{Pose2, Segment, Vec2};
use polymap::scan::RangeScan;
use serde::Serialize;

use super::{CELL_M, REACH_M};
use polymap::segment_index::SegmentIndex;

/// Settings of [`map_fit_to_points`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PointFitParams {
    /// Use every `scan_stride`-th scan (1: all; 0 is treated as 1). Default 1.
    pub scan_stride: usize,
    /// First "near" tolerance, metres. Default 0.05.
    pub tight_tolerance_m: f64,
    /// Second "near" tolerance, metres. Default 0.10.
    pub loose_tolerance_m: f64,
    /// Points farther than this from every segment are left out of the robust RMS, metres.
    /// Default 0.5.
    pub rms_cutoff_m: f64,
}

impl Default for PointFitParams {
    fn default() -> Self {
        PointFitParams {
            scan_stride: 1,
            tight_tolerance_m: 0.05,
            loose_tolerance_m: 0.10,
            rms_cutoff_m: 0.5,
        }
    }
}

/// How well the map explains the scan points.
///
/// Two RMS figures: `rms_m` over every point (one far outlier, e.g. a person or a window, can
/// dominate it) and `rms_within_cutoff_m` over the points within `rms_cutoff_m` of the map only.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PointFit {
    /// The parameters used.
    pub params: PointFitParams,
    /// Scans used (after striding, skipping scans without a finite pose).
    pub scans_used: usize,
    /// Valid scan points evaluated.
    pub points: usize,
    /// Share of points within `tight_tolerance_m` of a segment, in `[0, 1]` (0 without points).
    pub share_within_tight: f64,
    /// Share of points within `loose_tolerance_m` of a segment, in `[0, 1]`.
    pub share_within_loose: f64,
    /// Root mean square of the point-to-nearest-segment distance over all points, metres;
    /// `None` without points or segments.
    pub rms_m: Option<f64>,
    /// Points within `rms_cutoff_m` of a segment.
    pub points_within_cutoff: usize,
    /// Root mean square distance over the points within `rms_cutoff_m`, metres; `None` if none.
    pub rms_within_cutoff_m: Option<f64>,
}

/// Running sums over point-to-map distances.
#[derive(Debug, Clone, Copy, Default)]
struct DistanceTally {
    points: usize,
    within_tight: usize,
    within_loose: usize,
    sum_2: f64,
    within_cutoff: usize,
    sum_2_within_cutoff: f64,
}

impl DistanceTally {
    fn add(&mut self, distance_m: f64, params: &PointFitParams) {
        self.points += 1;
        self.within_tight += usize::from(distance_m <= params.tight_tolerance_m);
        self.within_loose += usize::from(distance_m <= params.loose_tolerance_m);
        self.sum_2 += distance_m * distance_m;
        if distance_m <= params.rms_cutoff_m {
            self.within_cutoff += 1;
            self.sum_2_within_cutoff += distance_m * distance_m;
        }
    }
}

/// Scores the map against the scans: `map_segments` in the map frame, `scans[i]` taken at
/// `map_from_robot[i]`.
///
/// Only the first `min(scans.len(), map_from_robot.len())` scans can be placed; scans whose pose
/// has a non-finite field are skipped. With an empty map every point counts as far.
///
/// ```
/// use polymap::geometry::{Pose2, Segment, Vec2};
/// use polymap::scan::{RangeScan, Stamp};
/// use polymap_eval::map_quality::{map_fit_to_points, PointFitParams};
/// // One beam straight ahead, 2 m; the wall is 2.07 m ahead of the robot.
/// let scan = RangeScan {
///     stamp: Stamp::from_seconds(0.0), ranges_m: vec![2.0], angle_min_rad: 0.0,
///     angle_increment_rad: 0.01, max_range_m: 10.0, robot_from_laser: Pose2::IDENTITY,
///     odom_from_robot: None,
/// };
/// let wall = Segment::new(Vec2::new(3.07, -1.0), Vec2::new(3.07, 1.0));
/// let fit = map_fit_to_points(&[wall], &[scan], &[Pose2::new(1.0, 0.0, 0.0)], &PointFitParams::default());
/// assert_eq!(fit.points, 1);
/// assert_eq!((fit.share_within_tight, fit.share_within_loose), (0.0, 1.0));
/// assert!((fit.rms_m.unwrap() - 0.07).abs() < 1e-9);
/// ```
pub fn map_fit_to_points(
    map_segments: &[Segment],
    scans: &[RangeScan],
    map_from_robot: &[Pose2],
    params: &PointFitParams,
) -> PointFit {
    let index = SegmentIndex::from_segments(map_segments, CELL_M, REACH_M);
    let stride = params.scan_stride.max(1);
    let mut tally = DistanceTally::default();
    let mut scans_used = 0;
    let mut p_in_robot: Vec<Vec2> = Vec::new();
    for (scan, pose) in scans.iter().zip(map_from_robot).step_by(stride) {
        if !pose.is_finite() {
            continue;
        }
        scans_used += 1;
        scan.points_in_robot(&mut p_in_robot);
        for p in &p_in_robot {
            let nearest = index.nearest_anywhere(pose.transform_point(*p));
            let distance_m = nearest.map_or(f64::INFINITY, |(_, _, pr)| pr.distance_2.sqrt());
            tally.add(distance_m, params);
        }
    }
    finish(tally, scans_used, index.is_empty(), params)
}

/// Turns the running sums into the reported figures.
fn finish(
    tally: DistanceTally,
    scans_used: usize,
    map_is_empty: bool,
    params: &PointFitParams,
) -> PointFit {
    let share = |k: usize| {
        if tally.points == 0 {
            0.0
        } else {
            k as f64 / tally.points as f64
        }
    };
    let rms = |sum_2: f64, n: usize| (n > 0).then(|| (sum_2 / n as f64).sqrt());
    PointFit {
        params: *params,
        scans_used,
        points: tally.points,
        share_within_tight: share(tally.within_tight),
        share_within_loose: share(tally.within_loose),
        rms_m: if map_is_empty {
            None
        } else {
            rms(tally.sum_2, tally.points)
        },
        points_within_cutoff: tally.within_cutoff,
        rms_within_cutoff_m: rms(tally.sum_2_within_cutoff, tally.within_cutoff),
    }
}
