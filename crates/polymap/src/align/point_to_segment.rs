//! Point-to-segment ICP on the scan's points (an addition to the paper).

use super::solver::{Constraint, run_icp};
use super::{AlignParams, AlignResult, SegmentLookup};
use crate::geometry::{Pose2, Vec2};
use crate::segment_index::NearestCertificate;

/// Keeps points at least `spacing_m` from the previously kept one (in order), so that close
/// walls, sampled densely, do not outweigh far ones.
///
/// ```
/// use polymap::align::thin_points;
/// use polymap::geometry::Vec2;
/// let pts: Vec<Vec2> = (0..10).map(|i| Vec2::new(0.01 * i as f64, 0.0)).collect();
/// assert_eq!(thin_points(&pts, 0.05).len(), 2);
/// ```
pub fn thin_points(points: &[Vec2], spacing_m: f64) -> Vec<Vec2> {
    let mut out: Vec<Vec2> = Vec::with_capacity(points.len());
    for &p in points {
        if out
            .last()
            .is_none_or(|l| l.distance_squared(p) >= spacing_m * spacing_m)
        {
            out.push(p);
        }
    }
    out
}

/// Aligns scan points (robot frame) to map segments by point-to-line ICP, starting at `guess`;
/// unobservable directions end on `anchor`.
pub fn align_points(
    points_in_robot: &[Vec2],
    map: &impl SegmentLookup,
    guess: Pose2,
    anchor: Pose2,
    params: &AlignParams,
) -> AlignResult {
    // Per point, what the last search found: while a point moves little between iterations,
    // its nearest segment is known without searching again (same answers, exactly).
    let mut certificates: Vec<Option<NearestCertificate>> = vec![None; points_in_robot.len()];
    run_icp(guess, anchor, params, |pose, gate_m, out| {
        for (&p, certificate) in points_in_robot.iter().zip(&mut certificates) {
            let q = pose.transform_point(p);
            let known = certificate.and_then(|c| c.answer(q, gate_m));
            let nearest = match known {
                Some(answer) => answer,
                None => {
                    *certificate = map.nearest_certified(q);
                    match certificate.and_then(|c| c.answer(q, gate_m)) {
                        Some(answer) => answer,
                        None => map.nearest_segment_only(q, gate_m),
                    }
                }
            };
            let Some(s) = nearest else {
                continue;
            };
            let len = s.length();
            if len <= 0.0 {
                continue;
            }
            let dir = s.vector() / len;
            let along = (q - s.start).dot(dir);
            if along < -params.endpoint_slack_m || along > len + params.endpoint_slack_m {
                continue; // beyond the mapped part of the wall: unknown space
            }
            out.push(Constraint {
                p_in_robot: p,
                q_in_map: s.start,
                normal: dir.perp(),
            });
        }
    })
}
