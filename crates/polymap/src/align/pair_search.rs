//! Global alignment without a guess (an addition to the paper): where a set of segments — a
//! second map, or a scan — lies in a map, from anywhere and at any heading.
//!
//! Pose hypotheses come from pairs of non-parallel segments of one side matched to pairs of
//! the other ([`corners`], [`corner_poses`]) and are verified by a raster score
//! ([`ScoreRaster`] of the fixed segments, points of the moving side):
//!
//! 1. every hypothesis is scored on a coarse raster (wide kernel) with a small sample of the
//!    moving points;
//! 2. the best are clustered (one per `seed_apart_m` / `seed_apart_deg`), and each cluster's
//!    best is refined by ICP ([`align_points`]) and scored on a fine raster with a larger
//!    sample, less `conflict_weight` times its conflicts: the share of each side's robot
//!    positions (free space: the robot stood there) that the pose puts within `clearance_m`
//!    of the other side's walls, or that the robot reached through one of them;
//! 3. the best refined pose wins; the best one apart from it (beyond `apart_m` or
//!    `apart_deg`) is its rival (a symmetric corridor has a rival nearly as good);
//! 4. a last ICP from the winner on the larger sample gives the pose, and the share of moving
//!    points then within `inlier_m` of the map is the overlap.
//!
//! Office floors repeat themselves: along a corridor of alike rooms, a pose shifted by a few
//! rooms explains about as many walls as the true one (FR079's two halves: 0.416 against
//! 0.413). What tells them apart is free space: shifted, one map's walls stand where the other
//! map's robot drove (27 % of the robot positions against 4 % at the true pose).
//!
//! [`GlobalMatch::verdict`] turns score, overlap, conflicts and rival into accepted, no
//! overlap, conflicting or ambiguous.

use serde::{Deserialize, Serialize};

pub use super::global_params::GlobalParams;
use super::pairs::{Corner, corner_poses, corners};
use super::raster::ScoreRaster;
use super::search::score_sample_n;
use super::{AlignParams, AlignResult, SegmentLookup, align_points, thin_points};
use crate::geometry::{Pose2, Segment, Vec2, normalize_angle_rad};
use crate::map::GlobalMap;

/// A pose of the moving side in the fixed frame with its scores.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ScoredPose {
    /// The pose, `fixed_from_moving`.
    pub fixed_from_moving: Pose2,
    /// What ranks the poses: `raster_score − conflict_weight · conflicts`.
    pub score: f64,
    /// Mean fine raster value under the moving sample, `[0, 1]`.
    pub raster_score: f64,
    /// Mean over the sides with a path of the share of robot positions within `clearance_m`
    /// of the other side's walls (0 without paths).
    pub conflicts: f64,
}

/// The moving side of a global search, all in the moving frame.
#[derive(Debug, Clone, Copy)]
pub struct MovingSide<'a> {
    /// Its segments (a map's, or a scan's), metres.
    pub segments: &'a [Segment],
    /// Points on them that scores count: [`points_along`] a map's segments, or a scan's points.
    pub points: &'a [Vec2],
    /// Where the robot was (free space), metres; may be empty (a scan: its origin).
    pub path: &'a [Vec2],
}

/// The outcome of a global search, with what a caller needs to judge it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GlobalMatch {
    /// The best pose after ICP, `fixed_from_moving`.
    pub fixed_from_moving: Pose2,
    /// The best pose of the raster search (before ICP), with its score.
    pub best: ScoredPose,
    /// The best pose apart from it (beyond `apart_m` or `apart_deg`), if any was refined.
    pub rival: Option<ScoredPose>,
    /// Every refined pose, best first (the best and the rival among them).
    pub candidates: Vec<ScoredPose>,
    /// Share of the moving sample within `inlier_m` of the map at the final pose.
    pub overlap: f64,
    /// The ICP refinement's diagnostics.
    pub icp: AlignResult,
    /// Corners found on the fixed side.
    pub fixed_corners: usize,
    /// Corners found on the moving side.
    pub moving_corners: usize,
    /// Pose hypotheses scored.
    pub hypotheses: usize,
}

/// Whether a match can be trusted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MatchVerdict {
    /// One pose explains the moving side well and no other comes close.
    Accepted,
    /// No pose explains enough of the moving side: the two do not overlap.
    NoOverlap,
    /// The best pose puts walls of one side where the other side's robot drove.
    Conflicting,
    /// A pose apart from the best explains the moving side nearly as well, or would pass on
    /// its own.
    Ambiguous,
}

impl GlobalMatch {
    /// The rival's score as a share of the best's (0 without a rival; 1 when the best scores
    /// nothing).
    pub fn rival_ratio(&self) -> f64 {
        match self.rival {
            Some(r) if self.best.score > 0.0 => r.score.max(0.0) / self.best.score,
            Some(_) => 1.0,
            None => 0.0,
        }
    }

    /// Accepted when raster score and overlap reach their minimums, the conflicts stay within
    /// `max_conflicts`, the rival stays below `max_rival_ratio` of the best, and no pose apart
    /// from the best ([`GlobalMatch::passing_rival`]) would pass on its own; checked in that
    /// order.
    pub fn verdict(&self, params: &GlobalParams) -> MatchVerdict {
        if self.best.raster_score < params.min_score || self.overlap < params.min_overlap {
            MatchVerdict::NoOverlap
        } else if self.best.conflicts > params.max_conflicts {
            MatchVerdict::Conflicting
        } else if self.rival_ratio() >= params.max_rival_ratio
            || self.passing_rival(params).is_some()
        {
            MatchVerdict::Ambiguous
        } else {
            MatchVerdict::Accepted
        }
    }

    /// The best-ranked candidate apart from the best (beyond `apart_m` or `apart_deg`) that
    /// would pass on its own (raster score at least `min_score`, conflicts at most
    /// `max_conflicts`) and scores at least `min_passing_ratio` of the best. A building seen
    /// in two halves that mirror each other (a ring corridor turned by half a turn) has one.
    pub fn passing_rival(&self, params: &GlobalParams) -> Option<&ScoredPose> {
        self.candidates.iter().find(|c| {
            !near(&c.fixed_from_moving, &self.best.fixed_from_moving, params)
                && c.raster_score >= params.min_score
                && c.conflicts <= params.max_conflicts
                && c.score >= params.min_passing_ratio * self.best.score
        })
    }
}

/// Points every `spacing_m` along each segment, both ends included: a map's segments as the
/// points a search scores.
///
/// ```
/// use polymap::align::points_along;
/// use polymap::geometry::{Segment, Vec2};
/// let pts = points_along(&[Segment::new(Vec2::ZERO, Vec2::new(1.0, 0.0))], 0.25);
/// assert_eq!(pts.len(), 5);
/// ```
pub fn points_along(segments: &[Segment], spacing_m: f64) -> Vec<Vec2> {
    let spacing = spacing_m.max(1e-3);
    segments
        .iter()
        .filter(|s| s.is_finite())
        .flat_map(|s| {
            let n = ((s.length() / spacing).ceil() as usize).clamp(1, 1_000_000);
            (0..=n).map(move |i| s.start + s.vector() * (i as f64 / n as f64))
        })
        .collect()
}

/// The share of `points` (moving frame) within `inlier_m` of `fixed` at `fixed_from_moving`.
pub fn overlap_share(
    points: &[Vec2],
    fixed: &impl SegmentLookup,
    fixed_from_moving: &Pose2,
    inlier_m: f64,
) -> f64 {
    if points.is_empty() {
        return 0.0;
    }
    let near = points
        .iter()
        .filter(|p| {
            let q = fixed_from_moving.transform_point(**p);
            fixed.nearest_segment_only(q, inlier_m).is_some()
        })
        .count();
    near as f64 / points.len() as f64
}

/// Finds where the moving side lies in `fixed` (with `fixed_path`, where its robot was: free
/// space, fixed frame; may be empty), with no initial guess. `None` when no hypothesis could
/// be formed (no corner on either side, or no moving points).
pub fn global_match(
    fixed: &GlobalMap,
    fixed_path: &[Vec2],
    moving: &MovingSide<'_>,
    params: &GlobalParams,
    align: &AlignParams,
) -> Option<GlobalMatch> {
    let fixed_segments: Vec<Segment> = fixed.iter().map(|(_, s)| s.segment).collect();
    let corner_of = |segs: &[Segment]| {
        corners(
            segs,
            params.min_segment_m,
            params.max_segments,
            params.min_corner_angle_deg.to_radians(),
            params.corner_reach_m,
        )
    };
    let fixed_corners = corner_of(&fixed_segments);
    let moving_corners = corner_of(moving.segments);
    let hypotheses = hypotheses(&fixed_corners, &moving_corners, params);
    if hypotheses.is_empty() || moving.points.is_empty() {
        return None;
    }
    let raster = |cell_m, sigma_m| ScoreRaster::of(&fixed_segments, &[], cell_m, sigma_m);
    let coarse = raster(params.coarse_cell_m, params.coarse_sigma_m);
    let seeds = coarse_seeds(&coarse, &hypotheses, moving.points, params);
    let judge = Judge {
        fixed,
        fine: raster(params.fine_cell_m, params.fine_sigma_m),
        sample: score_sample_n(moving.points, params.fine_points),
        fixed_path: thin_path(fixed_path, params),
        moving_map: map_of(moving.segments, fixed),
        moving_path: thin_path(moving.path, params),
        params,
    };
    let icp_sample = score_sample_n(moving.points, params.icp_points);
    let refined = refine(&judge, &seeds, &icp_sample, align);
    let best = *refined.first()?;
    let rival = refined
        .iter()
        .find(|r| !near(&r.fixed_from_moving, &best.fixed_from_moving, params))
        .copied();
    let start = best.fixed_from_moving;
    let icp = align_points(&judge.sample, fixed, start, start, align);
    let overlap = overlap_share(&judge.sample, fixed, &icp.map_from_robot, params.inlier_m);
    Some(GlobalMatch {
        fixed_from_moving: icp.map_from_robot,
        best,
        rival,
        candidates: refined,
        overlap,
        icp,
        fixed_corners: fixed_corners.len(),
        moving_corners: moving_corners.len(),
        hypotheses: hypotheses.len(),
    })
}

/// What a refined pose is scored with.
struct Judge<'a> {
    fixed: &'a GlobalMap,
    fine: ScoreRaster,
    sample: Vec<Vec2>,
    fixed_path: Vec<Vec2>,
    moving_map: GlobalMap,
    moving_path: Vec<Vec2>,
    params: &'a GlobalParams,
}

impl Judge<'_> {
    fn score(&self, pose: Pose2) -> ScoredPose {
        let raster_score = raster_score(&self.fine, &self.sample, &pose);
        let conflicts = self.conflicts(&pose);
        ScoredPose {
            fixed_from_moving: pose,
            score: raster_score - self.params.conflict_weight * conflicts,
            raster_score,
            conflicts,
        }
    }

    /// The mean, over the sides with a path, of the share of its robot positions that `pose`
    /// puts on the other side's walls (see [`path_conflicts`]).
    fn conflicts(&self, pose: &Pose2) -> f64 {
        let p = self.params;
        let moving_from_fixed = pose.inverse();
        let shares = [
            path_conflicts(&self.moving_path, self.fixed, pose, p),
            path_conflicts(&self.fixed_path, &self.moving_map, &moving_from_fixed, p),
        ];
        let given: Vec<f64> = shares.into_iter().flatten().collect();
        match given.len() {
            0 => 0.0,
            n => given.iter().sum::<f64>() / n as f64,
        }
    }
}

/// A path thinned to positions `path_spacing_m` apart, then to at most about `path_points`.
fn thin_path(path: &[Vec2], params: &GlobalParams) -> Vec<Vec2> {
    score_sample_n(
        &thin_points(path, params.path_spacing_m),
        params.path_points,
    )
}

/// The share of `path` (robot positions in order, path frame) that `walls_from_path` puts on
/// `walls`: within `clearance_m` of a wall, or reached from the position before (at most
/// `max_step_m` away) through a wall. `None` for an empty path.
fn path_conflicts(
    path: &[Vec2],
    walls: &GlobalMap,
    walls_from_path: &Pose2,
    params: &GlobalParams,
) -> Option<f64> {
    if path.is_empty() {
        return None;
    }
    let moved: Vec<Vec2> = path
        .iter()
        .map(|p| walls_from_path.transform_point(*p))
        .collect();
    let crosses = |step: Segment| {
        walls
            .near_segment(&step, 0.0)
            .into_iter()
            .filter_map(|id| walls.get(id))
            .any(|w| w.segment.intersects(&step))
    };
    let hits = moved
        .iter()
        .enumerate()
        .filter(|(i, q)| {
            let near = walls
                .nearest_segment_only(**q, params.clearance_m)
                .is_some();
            let through = i.checked_sub(1).is_some_and(|j| {
                let step = Segment::new(moved[j], **q);
                step.length() <= params.max_step_m && crosses(step)
            });
            near || through
        })
        .count();
    Some(hits as f64 / path.len() as f64)
}

/// `segments` in a map store like `like`'s (born at scan 0).
fn map_of(segments: &[Segment], like: &GlobalMap) -> GlobalMap {
    let mut map = like.empty_like();
    for s in segments {
        map.insert(crate::map::MapSegment {
            segment: *s,
            born_scan: 0,
        });
    }
    map
}

/// Every pose of every pair of matching corners, without repeats.
pub(crate) fn hypotheses(fixed: &[Corner], moving: &[Corner], params: &GlobalParams) -> Vec<Pose2> {
    let tolerance = params.angle_tolerance_deg.to_radians();
    let mut moving: Vec<&Corner> = moving.iter().collect();
    moving.sort_by(|a, b| a.angle_rad.total_cmp(&b.angle_rad));
    let mut out = Vec::new();
    for f in fixed {
        // The moving corner matches in either order: angle φ or π − φ.
        for target in [f.angle_rad, std::f64::consts::PI - f.angle_rad] {
            let lo = moving.partition_point(|m| m.angle_rad < target - tolerance);
            for m in moving[lo..]
                .iter()
                .take_while(|m| m.angle_rad <= target + tolerance)
            {
                out.extend(corner_poses(f, m, tolerance));
            }
        }
    }
    out.sort_by(|a, b| {
        (a.x_m, a.y_m, a.theta_rad)
            .partial_cmp(&(b.x_m, b.y_m, b.theta_rad))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    out.dedup();
    out
}

/// The mean raster value under `points` (moving frame) placed by `pose`.
pub(crate) fn raster_score(raster: &ScoreRaster, points: &[Vec2], pose: &Pose2) -> f64 {
    if points.is_empty() {
        return 0.0;
    }
    let (s, c) = pose.theta_rad.sin_cos();
    let t = pose.translation();
    let sum: f64 = points
        .iter()
        .map(|p| raster.at(Vec2::new(c * p.x - s * p.y, s * p.x + c * p.y) + t))
        .sum();
    sum / points.len() as f64
}

/// The best hypothesis of each of the best clusters by coarse score, best first.
fn coarse_seeds(
    coarse: &ScoreRaster,
    hypotheses: &[Pose2],
    moving_points: &[Vec2],
    params: &GlobalParams,
) -> Vec<Pose2> {
    let sample = score_sample_n(moving_points, params.coarse_points);
    let distinct = |a: &Pose2, b: &Pose2| !near_seed(a, b, params);
    best_distinct(
        coarse,
        &sample,
        hypotheses,
        f64::NEG_INFINITY,
        params.refined_clusters,
        distinct,
    )
    .into_iter()
    .map(|(_, p)| p)
    .collect()
}

/// The best-scoring of `poses` on `raster` (the mean value under `sample`, moving frame) that
/// score above `floor`, best first (equal scores in their given order), each `distinct` from
/// every one kept before it, at most `max`: the seeds of a search from many hypotheses.
pub(crate) fn best_distinct(
    raster: &ScoreRaster,
    sample: &[Vec2],
    poses: &[Pose2],
    floor: f64,
    max: usize,
    distinct: impl Fn(&Pose2, &Pose2) -> bool,
) -> Vec<(f64, Pose2)> {
    let mut scored: Vec<(f64, Pose2)> = poses
        .iter()
        .map(|h| (raster_score(raster, sample, h), *h))
        .filter(|(score, _)| *score > floor)
        .collect();
    scored.sort_by(|a, b| b.0.total_cmp(&a.0));
    let mut kept: Vec<(f64, Pose2)> = Vec::new();
    for (score, h) in scored {
        if kept.len() >= max {
            break;
        }
        if kept.iter().all(|(_, k)| distinct(k, &h)) {
            kept.push((score, h));
        }
    }
    kept
}

/// Each seed refined by ICP on `icp_sample` and scored by `judge`; best first, poses that
/// converged onto a better one's left out.
fn refine(
    judge: &Judge<'_>,
    seeds: &[Pose2],
    icp_sample: &[Vec2],
    align: &AlignParams,
) -> Vec<ScoredPose> {
    let mut refined: Vec<ScoredPose> = seeds
        .iter()
        .map(|seed| {
            judge.score(align_points(icp_sample, judge.fixed, *seed, *seed, align).map_from_robot)
        })
        .collect();
    refined.sort_by(|a, b| b.score.total_cmp(&a.score));
    let mut kept: Vec<ScoredPose> = Vec::new();
    for r in refined {
        let params = judge.params;
        if !kept
            .iter()
            .any(|k| near_seed(&k.fixed_from_moving, &r.fixed_from_moving, params))
        {
            kept.push(r);
        }
    }
    kept
}

/// Whether two hypotheses are one: within a cell-sized `seed_apart_m` and `seed_apart_deg`.
fn near_seed(a: &Pose2, b: &Pose2, params: &GlobalParams) -> bool {
    let turned = normalize_angle_rad(a.theta_rad - b.theta_rad).abs();
    a.translation().distance(b.translation()) < params.seed_apart_m
        && turned < params.seed_apart_deg.to_radians()
}

/// Whether two poses are within `apart_m` and `apart_deg` of each other.
fn near(a: &Pose2, b: &Pose2, params: &GlobalParams) -> bool {
    let turned = normalize_angle_rad(a.theta_rad - b.theta_rad).abs();
    a.translation().distance(b.translation()) < params.apart_m
        && turned < params.apart_deg.to_radians()
}

#[cfg(test)]
mod tests;
