//! When to search beyond ICP's basin and how wide: ICP from the motion prior is exact and
//! cheap when the prior is close, which it is on dense logs. It is not when the robot moved
//! far or turned fast between scans (sparse logs, fast robots), or when ICP's fit is poor.
//! Then the [`CorrelativeMatcher`] searches a window around the prediction on a likelihood
//! raster of the map near it and of the recent scan points that form no segment, and ICP
//! refines its best pose; the better of the two fits wins. The window grows with the
//! predicted motion (a constant-velocity prediction is wrong by about as much as the robot
//! moved), and with every scan that found no match.

use super::params::TrackParams;
use super::recent::RecentMotion;
use crate::align::{
    AlignResult, Candidate, CorrelativeMatcher, ScoreRaster, SearchWindow, WindowBest, map_bounds,
    score_sample_n,
};
use crate::geometry::{Pose2, Vec2, normalize_angle_rad};
use crate::map::GlobalMap;
use crate::tracking::params::{
    LOST_WINDOW_GROWTH_M, LOST_WINDOW_MAX_M, SEARCH_CELL_M, SEARCH_MAX_RANGE_M, SEARCH_POINTS,
    SEARCH_SIGMA_M, SEARCH_SKIP_ABOVE_INLIER_SHARE, WINDOW_DEG_PER_M, WINDOW_PER_RECENT,
    WINDOW_PER_STEP, WINDOW_PER_TURN,
};

/// Whether the window search should run: large motion (predicted, or of any of the last few
/// scans: a robot that moves far per scan may stop or turn at any scan) unless ICP's pose fits
/// at least [`SEARCH_SKIP_ABOVE_INLIER_SHARE`] of the points, a poor fit, or lost before.
pub fn should_search(
    prediction: &Pose2,
    anchor: &Pose2,
    recent: &RecentMotion,
    icp: Option<&AlignResult>,
    thinned_points: usize,
    lost_streak: u32,
    params: &TrackParams,
) -> bool {
    if !params.search.enabled || thinned_points == 0 {
        return false;
    }
    let motion = anchor.between(prediction);
    let step_m = motion.translation().length().max(recent.step_m());
    let turn_deg = normalize_angle_rad(motion.theta_rad)
        .abs()
        .to_degrees()
        .max(recent.turn_deg());
    let share = icp.map_or(0.0, |r| r.inliers as f64 / thinned_points as f64);
    let moved = step_m > params.search.search_above_step_m
        || turn_deg > params.search.search_above_turn_deg;
    lost_streak > 0
        || (moved && share < SEARCH_SKIP_ABOVE_INLIER_SHARE)
        || share < params.search.search_below_inlier_share
}

/// The window around `prediction`: wider for a larger predicted motion, and for every scan lost
/// in a row (then over the whole circle). Its rotation reaches at most `max_window_deg`
/// (`odometry_max_window_deg` when the prediction is odometry's), and always the anchor's
/// heading with `min_window_deg` to spare, however far the prediction turned.
pub fn search_window(
    prediction: &Pose2,
    anchor: &Pose2,
    recent: &RecentMotion,
    lost_streak: u32,
    odometry: bool,
    params: &TrackParams,
) -> SearchWindow {
    let motion = anchor.between(prediction);
    if lost_streak > 0 {
        let half = params.search.max_window_m + LOST_WINDOW_GROWTH_M * lost_streak as f64;
        return SearchWindow {
            center: *prediction,
            half_xy_m: half.min(LOST_WINDOW_MAX_M.max(params.search.max_window_m)),
            half_theta_rad: std::f64::consts::PI,
        };
    }
    let per_recent = match params.recent_window {
        true => WINDOW_PER_RECENT,
        false => 0.0,
    };
    let step = motion
        .translation()
        .length()
        .max(per_recent * recent.step_m());
    let turn_deg = normalize_angle_rad(motion.theta_rad)
        .abs()
        .to_degrees()
        .max(per_recent * recent.turn_deg());
    let half_xy = (params.search.min_window_m + WINDOW_PER_STEP * step).clamp(
        params.search.min_window_m,
        params.search.max_window_m.max(params.search.min_window_m),
    );
    let half_deg = (params.search.min_window_deg
        + WINDOW_PER_TURN * turn_deg
        + WINDOW_DEG_PER_M * step)
        .clamp(
            params.search.min_window_deg,
            params.widest_window_deg(odometry),
        )
        // The anchor's heading stays inside the window: a predicted turn beyond the widest
        // window (a turn the last step took, perhaps wrongly) must not exclude no turn.
        .max(
            normalize_angle_rad(motion.theta_rad).abs().to_degrees() + params.search.min_window_deg,
        )
        .min(180.0);
    SearchWindow {
        center: *prediction,
        half_xy_m: half_xy,
        half_theta_rad: half_deg.to_radians(),
    }
}

/// A window search's best pose must explain at least this mean raster value per point.
const MIN_SCORE: f64 = 0.05;

/// The outcome of a window search: the best pose, and on demand a rival apart from it (only
/// a scan whose verdict is otherwise `ok`, or still in doubt after the corner hypotheses,
/// asks for it, so the search for a rival runs only when asked).
#[derive(Debug, Clone)]
pub struct WindowMatch {
    /// The best pose of the window.
    pub best: Candidate,
    matcher: CorrelativeMatcher,
    found: WindowBest,
    /// How far apart a rival is (`tracking.verdict.rival_apart_m`, `rival_apart_deg` in radians).
    apart: (f64, f64),
}

impl WindowMatch {
    /// Whether a distinct pose (more than `rival_apart_m` or `rival_apart_deg` from the best)
    /// scores at least `ambiguous_above` of the best's score.
    pub fn ambiguous(&self) -> bool {
        self.rival().is_some()
    }

    /// The best distinct pose scoring at least `ambiguous_above` of the best's score.
    pub fn rival(&self) -> Option<Candidate> {
        self.matcher.rival(&self.found, self.apart)
    }
}

/// The scan points (robot frame) a search scores: about [`SEARCH_POINTS`] of them, only those
/// within [`SEARCH_MAX_RANGE_M`] unless fewer than 20 are. Far points sharpen the rotation but
/// widen the raster (its cost).
pub(super) fn search_sample(points_in_robot: &[Vec2]) -> Vec<Vec2> {
    let near: Vec<Vec2> = points_in_robot
        .iter()
        .copied()
        .filter(|p| p.length() <= SEARCH_MAX_RANGE_M)
        .collect();
    let points = if near.len() >= 20 {
        &near[..]
    } else {
        points_in_robot
    };
    score_sample_n(points, SEARCH_POINTS)
}

/// The search raster over the box `lo`..`hi` (map frame, metres): the map's segments there and
/// the loose points (map frame) they leave unexplained; `None` when neither has any.
pub(super) fn search_raster(
    map: &GlobalMap,
    loose_points_in_map: &[Vec2],
    lo: Vec2,
    hi: Vec2,
) -> Option<ScoreRaster> {
    let mut raster = ScoreRaster::new(lo, hi, SEARCH_CELL_M, SEARCH_SIGMA_M);
    let mut any = false;
    for id in map.query(lo, hi) {
        if let Some(s) = map.get(id) {
            raster.add_segment(&s.segment);
            any = true;
        }
    }
    // Only points the segments leave unexplained: pillars, corners, door frames. Clutter the
    // map already covers would only flatten the score.
    let unexplained: Vec<Vec2> = loose_points_in_map
        .iter()
        .copied()
        .filter(|p| p.x >= lo.x && p.y >= lo.y && p.x <= hi.x && p.y <= hi.y)
        .filter(|p| raster.at(*p) < 0.5)
        .collect();
    for p in &unexplained {
        raster.add_point(*p);
        any = true;
    }
    any.then_some(raster)
}

/// The best pose of `window` for the scan's points (robot frame) on a raster of the map and
/// of the loose points near it that the map does not explain (map frame), and its rival on
/// demand ([`WindowMatch::rival`]); `None` when nothing scores. A `seed` pose (ICP's answer)
/// is the score to beat: the search then only opens blocks that could beat it, and returns
/// the seed when none does.
pub fn window_search(
    map: &GlobalMap,
    loose_points_in_map: &[Vec2],
    points_in_robot: &[Vec2],
    window: &SearchWindow,
    seed: Option<Pose2>,
    params: &TrackParams,
) -> Option<WindowMatch> {
    let sample = search_sample(points_in_robot);
    let reach_m = sample.iter().map(|p| p.length()).fold(0.0, f64::max);
    let margin = Vec2::splat(window.half_xy_m + reach_m + SEARCH_SIGMA_M);
    let (lo, hi) = (
        window.center.translation() - margin,
        window.center.translation() + margin,
    );
    let raster = search_raster(map, loose_points_in_map, lo, hi)?;
    let seeded = seed.map(|pose| Candidate {
        map_from_robot: pose,
        score: sample
            .iter()
            .map(|p| raster.at(pose.transform_point(*p)))
            .sum::<f64>()
            / sample.len().max(1) as f64,
    });
    let floor = seeded.map_or(MIN_SCORE, |c| c.score.max(MIN_SCORE));
    let matcher = CorrelativeMatcher::for_window(raster, window.half_xy_m);
    let found = matcher.window_best(
        &sample,
        window,
        floor,
        seeded,
        params.verdict.ambiguous_above,
    )?;
    Some(WindowMatch {
        best: found.best,
        matcher,
        found,
        apart: (
            params.verdict.rival_apart_m,
            params.verdict.rival_apart_deg.to_radians(),
        ),
    })
}

/// A window over the whole map and the whole circle, centred on the map's bounding box with
/// `guess`'s heading, for re-localizing a robot lost for a while (it may have been carried
/// anywhere); `None` for an empty map.
pub fn whole_map_window(map: &GlobalMap, guess: &Pose2) -> Option<SearchWindow> {
    let (lo, hi) = map_bounds(map)?;
    let center = (lo + hi) * 0.5;
    Some(SearchWindow {
        center: Pose2::new(center.x, center.y, guess.theta_rad),
        half_xy_m: ((hi - lo) * 0.5).max_element(),
        half_theta_rad: std::f64::consts::PI,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::align::TranslationInformation;

    #[test]
    fn the_window_grows_with_the_motion_and_when_lost() {
        let p = TrackParams::default();
        let anchor = Pose2::IDENTITY;
        let still = search_window(&anchor, &anchor, &RecentMotion::default(), 0, false, &p);
        assert_eq!(still.half_xy_m, p.search.min_window_m);
        assert!((still.half_theta_rad.to_degrees() - p.search.min_window_deg).abs() < 1e-9);
        let fast = Pose2::new(0.5, 0.0, 30f64.to_radians());
        let w = search_window(&fast, &anchor, &RecentMotion::default(), 0, false, &p);
        assert!((w.half_xy_m - 0.8).abs() < 1e-9);
        assert!((w.half_theta_rad.to_degrees() - 75.0).abs() < 1e-9);
        // Without odometry a large predicted turn widens the window up to the whole circle
        // (15° + the turn + 60°/m of the 0.2 m step). With odometry the window stops at 90°,
        // but a predicted turn beyond it (the last step's, perhaps a wrong flip) still leaves
        // the anchor's heading inside, with the smallest margin, and at most the whole circle.
        for (turn_deg, cv_deg, odometry_deg) in [
            (60.0, 87.0, 87.0),
            (80.0, 107.0, 95.0),
            (100.0, 127.0, 115.0),
            (172.0, 180.0, 180.0),
        ] {
            let spun = Pose2::new(0.2, 0.0, f64::to_radians(turn_deg));
            for (odometry, half_deg) in [(false, cv_deg), (true, odometry_deg)] {
                let w = search_window(&spun, &anchor, &RecentMotion::default(), 0, odometry, &p);
                assert!(
                    (w.half_theta_rad.to_degrees() - half_deg).abs() < 1e-9,
                    "{turn_deg}° {odometry}: {}",
                    w.half_theta_rad.to_degrees()
                );
            }
        }
        let lost = search_window(&fast, &anchor, &RecentMotion::default(), 3, false, &p);
        assert!((lost.half_xy_m - 2.5).abs() < 1e-9);
        assert_eq!(lost.half_theta_rad, std::f64::consts::PI);
        // A robot that stood still for a scan after moving fast: the window of its recent
        // motion (0.5 m, 30°), and of the prediction alone without `recent_window`.
        let mut moved = RecentMotion::default();
        moved.push(&anchor, &fast);
        moved.push(&fast, &fast);
        let after_stop = search_window(&anchor, &anchor, &moved, 0, false, &p);
        assert_eq!(after_stop.center, anchor);
        assert_eq!(
            (after_stop.half_xy_m, after_stop.half_theta_rad),
            (w.half_xy_m, w.half_theta_rad)
        );
        let alone = TrackParams {
            recent_window: false,
            ..p.clone()
        };
        assert_eq!(
            search_window(&anchor, &anchor, &moved, 0, false, &alone),
            still
        );
        let mut recent = RecentMotion::default();
        assert!(should_search(&fast, &anchor, &recent, None, 10, 0, &p));
        assert!(!should_search(&anchor, &anchor, &recent, None, 0, 0, &p));
        // A good fit with no motion predicted still searches when the robot moved far lately.
        let good = AlignResult {
            map_from_robot: anchor,
            iterations: 3,
            correspondences: 10,
            inliers: 8,
            residual_rms_m: 0.01,
            converged: true,
            weak_directions: 0,
            weak_direction_deg: None,
            translation_information: TranslationInformation {
                weakest: 50.0,
                strongest: 100.0,
                weakest_deg: 0.0,
                ..Default::default()
            },
            weighed_prior: false,
        };
        assert!(!should_search(
            &anchor,
            &anchor,
            &recent,
            Some(&good),
            10,
            0,
            &p
        ));
        recent.push(&anchor, &fast);
        assert!(should_search(
            &anchor,
            &anchor,
            &recent,
            Some(&good),
            10,
            0,
            &p
        ));
        // ...but not when ICP's pose fits nearly every point
        // (`SEARCH_SKIP_ABOVE_INLIER_SHARE`), only when it fits fewer.
        let sure = AlignResult {
            inliers: 10,
            ..good
        };
        assert!(!should_search(
            &fast,
            &anchor,
            &recent,
            Some(&sure),
            10,
            0,
            &p
        ));
        assert!(should_search(
            &fast,
            &anchor,
            &recent,
            Some(&good),
            10,
            0,
            &p
        ));
    }
}
