//! `merge.json` of a pair of maps, and why a rigid match is refused.

use polymap::align::{GlobalMatch, GlobalParams, MatchVerdict, ScoredPose};
use polymap::geometry::Pose2;
use serde_json::json;

use super::input::Input;

/// Refined poses listed in `merge.json`, best first.
const CANDIDATES_SHOWN: usize = 8;

pub(super) fn pose_json(p: &Pose2) -> serde_json::Value {
    json!({"x": p.x_m, "y": p.y_m, "yaw": p.theta_rad})
}

/// `merge.json` without the merged counts.
pub(super) fn merge_json(
    map_a: &Input,
    map_b: &Input,
    found: &GlobalMatch,
    verdict: MatchVerdict,
    overlap_a: f64,
    search_s: f64,
) -> serde_json::Value {
    let scored = |r: &ScoredPose| {
        let d = r.fixed_from_moving.between(&found.best.fixed_from_moving);
        json!({
            "a_from_b": pose_json(&r.fixed_from_moving),
            "score": r.score,
            "raster_score": r.raster_score,
            "conflicts": r.conflicts,
            "distance_m": d.translation().length(),
            "turn_deg": d.theta_rad.to_degrees().abs(),
        })
    };
    let candidates: Vec<serde_json::Value> = found
        .candidates
        .iter()
        .take(CANDIDATES_SHOWN)
        .map(scored)
        .collect();
    json!({
        "a": map_a.path_text,
        "b": map_b.path_text,
        "frame": format!("{} of A", map_a.frame),
        "verdict": verdict,
        "a_from_b": pose_json(&found.fixed_from_moving),
        "overlap": found.overlap,
        "overlap_of_a": overlap_a,
        "score": found.best.score,
        "raster_score": found.best.raster_score,
        "conflicts": found.best.conflicts,
        "rival": found.rival.as_ref().map(scored),
        "rival_ratio": found.rival_ratio(),
        "passing_rival": found.passing_rival(&GlobalParams::default()).map(scored),
        "candidates": candidates,
        "icp": {
            "iterations": found.icp.iterations,
            "correspondences": found.icp.correspondences,
            "inliers": found.icp.inliers,
            "residual_rms_m": found.icp.residual_rms_m,
            "converged": found.icp.converged,
            "weak_directions": found.icp.weak_directions,
        },
        "search": {
            "corners_a": found.fixed_corners,
            "corners_b": found.moving_corners,
            "hypotheses": found.hypotheses,
            "seconds": search_s,
        },
        "segments": {"a": map_a.segments.len(), "b": map_b.segments.len()},
        "scans": {"a": map_a.scans, "b": map_b.scans},
    })
}

/// Why the maps are not merged, with the figures.
pub(super) fn refusal(
    a: &Input,
    b: &Input,
    found: &GlobalMatch,
    verdict: MatchVerdict,
    params: &GlobalParams,
) -> String {
    let (a, b) = (&a.label, &b.label);
    let rival = found.passing_rival(params).or(found.rival.as_ref());
    match (verdict, rival) {
        (MatchVerdict::Ambiguous, Some(r)) => {
            let d = r.fixed_from_moving.between(&found.best.fixed_from_moving);
            format!(
                "{b} fits {a} in two places: a pose {:.2} m and {:.1}° from the best explains \
                 {:.0} % of B's walls with {:.0} % conflicts, {:.0} % of the best's score (refused \
                 when another pose would pass on its own or reaches {:.0} %; a symmetric place, \
                 or halves that mirror each other?): not merged (see merge.json)",
                d.translation().length(),
                d.theta_rad.to_degrees().abs(),
                100.0 * r.raster_score,
                100.0 * r.conflicts,
                100.0 * r.score.max(0.0) / found.best.score.max(1e-9),
                100.0 * params.max_rival_ratio
            )
        }
        (MatchVerdict::Conflicting, _) => format!(
            "{a} and {b} contradict each other at the best alignment: {:.0} % of the robots' \
             positions lie within {} m of the other map's walls or were reached through one \
             (refused above {:.0} %): not the same place, or a map is bent: not merged (see \
             merge.json)",
            100.0 * found.best.conflicts,
            params.clearance_m,
            100.0 * params.max_conflicts
        ),
        _ => format!(
            "{a} and {b} do not overlap: the best alignment scores {:.2} (needs {:.2}) and puts \
             {:.0} % of B's walls within {} m of A's (needs {:.0} %): not merged (see merge.json)",
            found.best.raster_score,
            params.min_score,
            100.0 * found.overlap,
            params.inlier_m,
            100.0 * params.min_overlap
        ),
    }
}
