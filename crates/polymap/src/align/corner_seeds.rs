//! Pose hypotheses for a scan that moved beyond the window search (issue 10, large motions):
//! the scan's corners (pairs of its non-parallel segments that meet, [`corners`]) matched to
//! the corners of the map near the prediction, each match one rigid pose ([`corner_poses`](crate::align::corner_poses):
//! the paper's own vocabulary of segments), any rotation, verified by the search raster's
//! score. The window search is exact but only within its window (at most ±1 m and ±90° while
//! tracking); a corner seen in both the scan and the map gives the true pose wherever it is.

use super::correlative::Candidate;
use super::pair_search::{GlobalParams, hypotheses, raster_score};
use super::pairs::corners;
use super::track::{TrackParams, search_raster, search_sample};
use crate::geometry::{Pose2, Segment, Vec2};
use crate::map::GlobalMap;

/// The best-scoring distinct poses (at least `rival_apart_m` or `rival_apart_deg` apart, at
/// most `corner_seeds`, best first) that put a corner of the scan (`segments_in_robot`, robot
/// frame) on a corner of the map within `corner_reach_m` of `prediction`, scored like the
/// window search (the mean search-raster value of the scan's points, `points_in_robot`, on
/// the map's segments and the loose points it leaves unexplained, map frame). Only poses
/// scoring above `beat` (ICP's pose) are kept. Empty when the scan or the map near has no
/// corner.
///
/// Corners are formed as for merging maps ([`GlobalParams`]' defaults: segments ≥ 0.5 m,
/// ≥ 30° from parallel, lines crossing within 1 m of both, angles matched within 4°).
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
    let corners_of = |segments: &[Segment]| {
        corners(
            segments,
            params.corner_min_segment_m,
            corner.max_segments,
            corner.min_corner_angle_deg.to_radians(),
            corner.corner_reach_m,
        )
    };
    let scan_corners = corners_of(segments_in_robot);
    let sample = search_sample(points_in_robot, params);
    if scan_corners.is_empty() || sample.is_empty() {
        return Vec::new();
    }
    // Map segments any scan corner could land on: the prediction's reach widened by the
    // farthest scan corner and sample point.
    let scan_reach = scan_corners
        .iter()
        .map(|c| c.point.length())
        .chain(sample.iter().map(|p| p.length()))
        .fold(0.0, f64::max);
    let margin = Vec2::splat(params.corner_reach_m + scan_reach + params.search_sigma_m);
    let center = prediction.translation();
    let (lo, hi) = (center - margin, center + margin);
    let near: Vec<Segment> = map
        .query(lo, hi)
        .into_iter()
        .filter_map(|id| map.get(id))
        .map(|s| s.segment)
        .collect();
    let map_corners = corners_of(&near);
    let poses: Vec<Pose2> = hypotheses(&map_corners, &scan_corners, &corner)
        .into_iter()
        .filter(|p| p.translation().distance(center) <= params.corner_reach_m)
        .collect();
    if poses.is_empty() {
        return Vec::new();
    }
    let Some(raster) = search_raster(map, loose_points_in_map, lo, hi, params) else {
        return Vec::new();
    };
    let floor = beat.map_or(0.0, |p| raster_score(&raster, &sample, p));
    let mut scored: Vec<Candidate> = poses
        .into_iter()
        .map(|p| Candidate {
            map_from_robot: p,
            score: raster_score(&raster, &sample, &p),
        })
        .filter(|c| c.score > floor)
        .collect();
    scored.sort_by(|a, b| b.score.total_cmp(&a.score));
    let (apart_m, apart_rad) = (params.rival_apart_m, params.rival_apart_deg.to_radians());
    let mut seeds: Vec<Candidate> = Vec::new();
    for c in scored {
        if seeds.len() >= params.corner_seeds {
            break;
        }
        let distinct = seeds.iter().all(|s| {
            let d = s.map_from_robot.between(&c.map_from_robot);
            d.translation().length() >= apart_m || d.theta_rad.abs() >= apart_rad
        });
        if distinct {
            seeds.push(c);
        }
    }
    seeds
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
        assert!(!seeds.is_empty() && seeds.len() <= params.corner_seeds);
        let best = seeds[0].map_from_robot;
        let d = truth.between(&best);
        assert!(
            d.translation().length() < 0.05 && d.theta_rad.abs() < 0.02,
            "{best:?} against {truth:?}"
        );
        // Beyond the reach, nothing.
        let far = Pose2::new(20.0, 20.0, 0.0);
        let none = corner_seeds(&map, &[], &points, &scan_segments, &far, None, &params);
        assert!(none.is_empty());
    }
}
