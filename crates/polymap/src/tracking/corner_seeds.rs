//! Pose hypotheses for a scan that moved beyond the window search (a large motion):
//! the scan's corners (pairs of its non-parallel segments that meet, [`corners`]) matched to
//! the corners of the map near the prediction, each match one rigid pose ([`corner_poses`](crate::align::corner_poses):
//! the paper's own vocabulary of segments), any rotation, verified by the search raster's
//! score. The window search is exact but only within its window (at most ±1 m and ±90° while
//! tracking); a corner seen in both the scan and the map gives the true pose wherever it is.

use super::params::TrackParams;
use super::window::{search_raster, search_sample};
use crate::align::{Candidate, GlobalParams, best_distinct, corners, hypotheses, raster_score};
use crate::geometry::{Pose2, Segment, Vec2};
use crate::map::GlobalMap;
use crate::tracking::params::{CORNER_MIN_SEGMENT_M, CORNER_REACH_M, CORNER_SEEDS, SEARCH_SIGMA_M};

/// A scan's corners come from at most this many of its longest segments (a bound on the
/// hypotheses: a scan has a few dozen).
const SCAN_CORNER_SEGMENTS: usize = 30;

/// The best-scoring distinct poses (more than `rival_apart_m` or `rival_apart_deg` apart, at
/// most `corner_seeds`, best first) that put a corner of the scan (`segments_in_robot`, robot
/// frame) on a corner of the map, with the robot within [`CORNER_REACH_M`] of `prediction`,
/// scored like the window search (the mean search-raster value of the scan's points,
/// `points_in_robot`, on the map's segments and the loose points it leaves unexplained, map
/// frame). Only poses scoring above `beat` (ICP's pose) are kept. Empty when the scan or the
/// map near has no corner.
///
/// Corners are formed from segments at least [`CORNER_MIN_SEGMENT_M`] long, at least 30° from
/// parallel, whose lines cross within 1 m of both, and matched when their angles agree within
/// 4° ([`GlobalParams`]' defaults, as for merging maps). At most the
/// `SCAN_CORNER_SEGMENTS` (30) longest segments of the scan take part, and the
/// `GlobalParams::max_segments` longest of the map where a scan corner can land from a pose in
/// reach: the hypotheses stay bounded whatever the map's size (a far scan corner widens that
/// box, and in a large map its short walls may then be left out).
pub fn corner_seeds(
    map: &GlobalMap,
    loose_points_in_map: &[Vec2],
    points_in_robot: &[Vec2],
    segments_in_robot: &[Segment],
    prediction: &Pose2,
    beat: Option<&Pose2>,
    params: &TrackParams,
) -> Vec<Candidate> {
    let corner = GlobalParams::default();
    let corners_of = |segments: &[Segment], max_segments: usize| {
        corners(
            segments,
            CORNER_MIN_SEGMENT_M,
            max_segments,
            corner.min_corner_angle_deg.to_radians(),
            corner.corner_reach_m,
        )
    };
    let scan_corners = corners_of(segments_in_robot, SCAN_CORNER_SEGMENTS);
    let sample = search_sample(points_in_robot);
    if scan_corners.is_empty() || sample.is_empty() {
        return Vec::new();
    }
    // The raster covers every pose in reach with the sample's farthest point; map corners
    // are looked for wherever a scan corner can land (far corners count: FR079 at K = 5 lost
    // its right pose when only corners within 8 m took part).
    let center = prediction.translation();
    let sample_reach = sample.iter().map(|p| p.length()).fold(0.0, f64::max);
    let raster_margin = Vec2::splat(CORNER_REACH_M + sample_reach + SEARCH_SIGMA_M);
    let far = scan_corners
        .iter()
        .map(|c| c.point.length())
        .fold(0.0, f64::max);
    let corner_margin = Vec2::splat(CORNER_REACH_M + far + corner.corner_reach_m);
    let near: Vec<Segment> = map
        .query(center - corner_margin, center + corner_margin)
        .into_iter()
        .filter_map(|id| map.get(id))
        .map(|s| s.segment)
        .collect();
    let map_corners = corners_of(&near, corner.max_segments);
    let poses: Vec<Pose2> = hypotheses(&map_corners, &scan_corners, &corner)
        .into_iter()
        .filter(|p| p.translation().distance(center) <= CORNER_REACH_M)
        .collect();
    if poses.is_empty() {
        return Vec::new();
    }
    let (lo, hi) = (center - raster_margin, center + raster_margin);
    let Some(raster) = search_raster(map, loose_points_in_map, lo, hi) else {
        return Vec::new();
    };
    let floor = beat.map_or(0.0, |p| raster_score(&raster, &sample, p));
    let distinct = |a: &Pose2, b: &Pose2| params.apart(a, b);
    best_distinct(&raster, &sample, &poses, floor, CORNER_SEEDS, distinct)
        .into_iter()
        .map(|(score, map_from_robot)| Candidate {
            map_from_robot,
            score,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::{cast_360, map_of, room};

    #[test]
    fn a_far_turned_scan_is_found_among_the_corner_seeds() {
        // The scan is taken 2.5 m and 70° from the prediction, beyond any
        // tracking window.
        let walls = room();
        let map = map_of(&walls, 0.5);
        let truth = Pose2::new(-2.0, 1.0, 70f64.to_radians());
        let points = cast_360(&walls, &truth);
        let scan_segments: Vec<Segment> = walls
            .iter()
            .map(|s| s.transformed(&truth.inverse()))
            .collect();
        let prediction = Pose2::new(0.0, -0.5, 0.0);
        let params = TrackParams::default();
        let seeds = corner_seeds(
            &map,
            &[],
            &points,
            &scan_segments,
            &prediction,
            Some(&prediction),
            &params,
        );
        assert!(!seeds.is_empty() && seeds.len() <= CORNER_SEEDS);
        let best = seeds[0].map_from_robot;
        let d = truth.between(&best);
        assert!(
            d.translation().length() < 0.05 && d.theta_rad.abs() < 0.02,
            "{best:?} against {truth:?}"
        );
        // Beyond the reach (`CORNER_REACH_M`), nothing: the map is near, but the truth is
        // 3.4 m from the guess.
        let near_truth = |seeds: &[Candidate]| {
            seeds.iter().any(|c| {
                let d = truth.between(&c.map_from_robot);
                d.translation().length() < 0.5 && d.theta_rad.abs() < 0.2
            })
        };
        let beyond = Pose2::new(1.3, 0.2, 0.0);
        assert!(beyond.translation().distance(truth.translation()) > CORNER_REACH_M);
        let seeds = corner_seeds(&map, &[], &points, &scan_segments, &beyond, None, &params);
        assert!(!near_truth(&seeds), "{seeds:?}");
    }
}
