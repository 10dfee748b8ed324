//! The paper's correspondences: segment endpoints to closest points, both ways.

use super::solver::{Constraint, PosePrior, run_icp};
use super::{AlignParams, AlignResult, SegmentLookup};
use crate::geometry::{Pose2, Segment};

/// Aligns scan segments (robot frame) to map segments by the paper's endpoint ICP.
///
/// Each scan endpoint is paired with its closest map point, and each endpoint of `map_near`
/// (the map segments in the scan's neighbourhood) within the gate of the scan with its closest
/// scan point; every pair constrains both coordinates. Unobservable directions end on `anchor`;
/// a `prior` is weighed with the fit at every step ([`PosePrior`]).
pub fn align_endpoints(
    scan_in_robot: &[Segment],
    map: &impl SegmentLookup,
    map_near: &[Segment],
    guess: Pose2,
    anchor: Pose2,
    prior: Option<&PosePrior>,
    params: &AlignParams,
) -> AlignResult {
    run_icp(guess, anchor, prior, params, |pose, gate_m, out| {
        for e in scan_in_robot.iter().flat_map(|s| [s.start, s.end]) {
            if let Some((_, projection)) = map.nearest_segment(pose.transform_point(e), gate_m) {
                out.extend(Constraint::point_pair(e, projection.point));
            }
        }
        let robot_from_map = pose.inverse();
        for m in map_near.iter().flat_map(|s| [s.start, s.end]) {
            let m_in_robot = robot_from_map.transform_point(m);
            let nearest = scan_in_robot
                .iter()
                .map(|s| s.project(m_in_robot))
                .filter(|p| p.distance_2 <= gate_m * gate_m)
                .min_by(|a, b| a.distance_2.total_cmp(&b.distance_2));
            if let Some(p) = nearest {
                out.extend(Constraint::point_pair(p.point, m));
            }
        }
    })
}
