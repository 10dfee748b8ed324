//! A coarse rotation search before ICP, for turns faster than ICP's basin (an addition).
//!
//! With the translation held at the guess, rotations around the guess are scored by a soft
//! inlier count of a sample of scan points: a point at distance `d` from the map counts
//! `max(0, 1 − d²/σ²)`. ICP then also starts from the best rotation.

use super::{AlignParams, SegmentLookup};
use crate::geometry::{Pose2, Vec2};

/// The rotation around `guess` (translation kept) that best explains the points; `guess` itself
/// when the search is off or nothing scores better.
///
/// ```
/// use polymap::align::{rotation_search, AlignParams};
/// use polymap::segment_index::SegmentIndex;
/// use polymap::geometry::{Pose2, Segment, Vec2};
/// // An L-shaped corner seen by a robot at the origin; the guess is 15° off.
/// let map = SegmentIndex::from_segments(&[Segment::new(Vec2::new(3.0, -3.0), Vec2::new(3.0, 3.0)), Segment::new(Vec2::new(3.0, 3.0), Vec2::new(-3.0, 3.0))], 0.5, 1.0);
/// let points: Vec<Vec2> = (0..=30).map(|i| Vec2::new(3.0, -3.0 + 0.2 * i as f64)).chain((1..=30).map(|i| Vec2::new(3.0 - 0.2 * i as f64, 3.0))).collect();
/// let found = rotation_search(&points, &map, Pose2::new(0.0, 0.0, 15f64.to_radians()), &AlignParams::default());
/// assert!(found.theta_rad.abs() < 1.5f64.to_radians());
/// ```
pub fn rotation_search(
    points_in_robot: &[Vec2],
    map: &impl SegmentLookup,
    guess: Pose2,
    params: &AlignParams,
) -> Pose2 {
    let steps =
        (params.rotation_search_deg / params.rotation_search_step_deg.max(0.1)).floor() as i32;
    if steps <= 0 || points_in_robot.is_empty() {
        return guess;
    }
    let sample = score_sample(points_in_robot, params);
    let score = |theta: f64, to_beat: f64| {
        fit_score_above(
            &sample,
            map,
            &Pose2::new(guess.x_m, guess.y_m, theta),
            params,
            to_beat,
        )
    };
    let at_guess = score(guess.theta_rad, f64::NEG_INFINITY).unwrap_or(0.0);
    let step = params.rotation_search_step_deg.to_radians();
    let mut best = (at_guess, 0);
    for k in (1..=steps).flat_map(|k| [k, -k]) {
        if let Some(s) = score(guess.theta_rad + k as f64 * step, best.0) {
            best = (s, k);
        }
    }
    Pose2::new(guess.x_m, guess.y_m, guess.theta_rad + best.1 as f64 * step)
}

/// About `rotation_search_points` of the points, evenly spread, for scoring poses.
pub fn score_sample(points_in_robot: &[Vec2], params: &AlignParams) -> Vec<Vec2> {
    score_sample_n(points_in_robot, params.rotation_search_points)
}

/// About `n` of the points, evenly spread.
pub fn score_sample_n(points_in_robot: &[Vec2], n: usize) -> Vec<Vec2> {
    let stride = (points_in_robot.len() / n.max(1)).max(1);
    points_in_robot.iter().step_by(stride).copied().collect()
}

/// The soft inlier count of sampled points at a pose: each point within
/// `rotation_search_sigma_m` of the map counts `1 − d²/σ²`.
pub fn fit_score(
    sample: &[Vec2],
    map: &impl SegmentLookup,
    map_from_robot: &Pose2,
    params: &AlignParams,
) -> f64 {
    fit_score_above(sample, map, map_from_robot, params, f64::NEG_INFINITY).unwrap_or(0.0)
}

/// [`fit_score`] when it exceeds `to_beat`, `None` otherwise. Every point counts at most 1, so
/// the sum stops as soon as the points left cannot lift it above `to_beat` (with a margin for
/// the rounding of the sum); the score, when returned, is the same sum in the same order as
/// `fit_score`'s.
pub fn fit_score_above(
    sample: &[Vec2],
    map: &impl SegmentLookup,
    map_from_robot: &Pose2,
    params: &AlignParams,
    to_beat: f64,
) -> Option<f64> {
    let sigma = params.rotation_search_sigma_m;
    let mut sum = 0.0;
    for (i, p) in sample.iter().enumerate() {
        let left = (sample.len() - i) as f64;
        if sum + left < to_beat - 1e-9 * (1.0 + to_beat.abs()) {
            return None;
        }
        if let Some((_, pr)) = map.nearest_segment(map_from_robot.transform_point(*p), sigma) {
            sum += 1.0 - pr.distance_2 / (sigma * sigma);
        }
    }
    (sum > to_beat).then_some(sum)
}
