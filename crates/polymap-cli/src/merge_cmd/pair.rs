//! Laying one map onto another: the rigid match, else the joint pose graph; what was decided
//! and, when accepted, the second map's walls, trajectory and loop nodes in the first's frame.

use std::time::Instant;

use polymap::align::{
    GlobalMatch, GlobalParams, MatchVerdict, MovingSide, global_match, overlap_share, points_along,
};
use polymap::config::Config;
use polymap::geometry::{Pose2, Segment};
use polymap::loops::{CrossVerdict, SavedNode};
use polymap::map::{GlobalMap, MapSegment};
use polymap::segment_index::SegmentIndex;
use polymap_io::loop_nodes::LOOP_NODES_FILE;
use polymap_io::tum::StampedPose;
use serde_json::json;

use super::SAMPLE_SPACING_M;
use super::bend::{Tried, bend_refusal, by_pose_graph, pose_graph_json};
use super::input::Input;
use super::report::{merge_json, pose_json, refusal};
use crate::args::MergeBy;

/// What laying map B onto map A decided.
pub(super) struct Laid {
    /// `merge.json` of the pair, without the merged map's counts.
    pub report: serde_json::Value,
    pub verdict: MatchVerdict,
    /// Why B is not merged, with the figures (`None` when accepted).
    pub refusal: Option<String>,
    /// The share of B's walls within `inlier_m` of A's as laid (rigidly or bent).
    pub overlap: f64,
    /// B's walls in A's frame (empty when refused).
    pub b_segments: Vec<MapSegment>,
    /// B's trajectory in A's frame (empty when refused or without `trajectory.tum`).
    pub b_trajectory: Vec<StampedPose>,
    /// B's loop nodes in A's frame (`None` when refused or B has none).
    pub b_nodes: Option<Vec<SavedNode>>,
    /// Lines for the terminal when merged.
    pub said: Vec<String>,
}

impl Laid {
    fn refused(report: serde_json::Value, verdict: MatchVerdict, why: String) -> Laid {
        Laid {
            report,
            verdict,
            refusal: Some(why),
            overlap: 0.0,
            b_segments: Vec::new(),
            b_trajectory: Vec::new(),
            b_nodes: None,
            said: Vec::new(),
        }
    }
}

/// Finds where `b` lies in `a` (`fixed`: A's segments indexed) and lays it there, by `by`.
pub(super) fn lay(a: &Input, fixed: &GlobalMap, b: &Input, by: MergeBy, config: &Config) -> Laid {
    let params = GlobalParams::default();
    let started = Instant::now();
    let b_segments: Vec<Segment> = b.segments.iter().map(|s| s.segment).collect();
    let b_points = points_along(&b_segments, SAMPLE_SPACING_M);
    let moving = MovingSide {
        segments: &b_segments,
        points: &b_points,
        path: &b.path,
    };
    let found = global_match(fixed, &a.path, &moving, &params, &config.align);
    let search_s = started.elapsed().as_secs_f64();
    let Some(found) = found else {
        let report = json!({
            "a": a.path_text,
            "b": b.path_text,
            "verdict": MatchVerdict::NoOverlap,
            "reason": "no corner of B matches a corner of A",
            "segments": {"a": a.segments.len(), "b": b.segments.len()},
        });
        let why = format!(
            "{} and {} do not overlap: no corner of B (two non-parallel walls meeting) matches \
             a corner of A in angle, so there is no pose to try: not merged (see merge.json)",
            a.label, b.label
        );
        return Laid::refused(report, MatchVerdict::NoOverlap, why);
    };
    let a_from_b = found.fixed_from_moving;
    let overlap_a = overlap_of_a(a, &b_segments, &a_from_b, &params);
    let rigid_verdict = found.verdict(&params);
    let mut report = merge_json(a, b, &found, rigid_verdict, overlap_a, search_s);
    report["method"] = json!("rigid");
    let bend = match (by, rigid_verdict) {
        (MergeBy::Rigid, _) | (MergeBy::Auto, MatchVerdict::Accepted) => None,
        // A map that fits in two places is refused however it is laid.
        (_, MatchVerdict::Ambiguous) => None,
        _ => match (&a.nodes, &b.nodes) {
            (Some(na), Some(nb)) if !na.is_empty() && !nb.is_empty() => {
                let started = Instant::now();
                let tried = by_pose_graph(fixed, b, na, nb, &found, &params, config);
                report["pose_graph"] = pose_graph_json(&tried, started.elapsed().as_secs_f64());
                Some(tried)
            }
            _ if by == MergeBy::PoseGraph => {
                let why = format!(
                    "--by pose-graph needs the loop nodes of both maps: {} or {} has no \
                     {LOOP_NODES_FILE} (written by polymap map): not merged",
                    a.label, b.label
                );
                return Laid::refused(report, rigid_verdict, why);
            }
            _ => None,
        },
    };
    let verdict = bend.as_ref().map_or(rigid_verdict, |t| t.verdict);
    report["verdict"] = json!(verdict);
    if verdict != MatchVerdict::Accepted {
        let why = match &bend {
            Some(t) => bend_refusal(a, b, t, &found, &params),
            None => refusal(a, b, &found, verdict, &params),
        };
        return Laid::refused(report, verdict, why);
    }
    match bend.as_ref().and_then(|t| t.best.as_ref()) {
        Some(_) => bent_laid(report, bend, b, &found, overlap_a),
        None => rigid_laid(report, b, &found, overlap_a),
    }
}

/// B laid by the rigid match.
fn rigid_laid(report: serde_json::Value, b: &Input, found: &GlobalMatch, overlap_a: f64) -> Laid {
    let a_from_b = found.fixed_from_moving;
    Laid {
        report,
        verdict: MatchVerdict::Accepted,
        refusal: None,
        overlap: found.overlap,
        b_segments: moved_rigidly(&b.segments, &a_from_b),
        b_trajectory: b
            .trajectory
            .iter()
            .map(|p| StampedPose {
                stamp: p.stamp.clone(),
                map_from_robot: a_from_b.compose(&p.map_from_robot),
            })
            .collect(),
        b_nodes: b.nodes.as_ref().map(|nodes| {
            nodes
                .iter()
                .map(|n| SavedNode {
                    pose: a_from_b.compose(&n.pose),
                    segments: n.segments.clone(),
                })
                .collect()
        }),
        said: rigid_said(found, overlap_a),
    }
}

/// B bent onto A by the joint pose graph (`bend` holds an accepted attempt).
fn bent_laid(
    mut report: serde_json::Value,
    bend: Option<Tried>,
    b: &Input,
    found: &GlobalMatch,
    overlap_a: f64,
) -> Laid {
    let Some(c) = bend.and_then(|t| t.best) else {
        return rigid_laid(report, b, found, overlap_a);
    };
    report["method"] = json!("pose_graph");
    report["a_from_b"] = pose_json(&c.seed);
    let (max, mean, _) = c.graph.moved();
    let mut said = rigid_said(found, overlap_a);
    said.push(format!(
        "bent by a joint pose graph: {} cross constraints used ({} rejected), B's nodes moved \
         up to {max:.2} m (mean {mean:.2} m)",
        c.graph.count(CrossVerdict::Used),
        c.graph.cross.len() - c.graph.count(CrossVerdict::Used)
    ));
    let b_nodes = b.nodes.as_ref().map(|nodes| {
        nodes
            .iter()
            .zip(&c.graph.b_poses)
            .map(|(n, pose)| SavedNode {
                pose: *pose,
                segments: n.segments.clone(),
            })
            .collect()
    });
    Laid {
        report,
        verdict: MatchVerdict::Accepted,
        refusal: None,
        overlap: c.overlap,
        b_segments: c.b_segments,
        b_trajectory: c.b_trajectory,
        b_nodes,
        said,
    }
}

/// The rigid match's figures for the terminal.
fn rigid_said(found: &GlobalMatch, overlap_a: f64) -> Vec<String> {
    let p = found.fixed_from_moving;
    vec![
        format!(
            "a_from_b: x {:.3} m, y {:.3} m, yaw {:.2}°",
            p.x_m,
            p.y_m,
            p.theta_rad.to_degrees()
        ),
        format!(
            "score {:.3}, rival {:.0} % of it; {:.0} % of B and {:.0} % of A within 0.1 m of the \
             other",
            found.best.score,
            100.0 * found.rival_ratio(),
            100.0 * found.overlap,
            100.0 * overlap_a
        ),
    ]
}

/// The share of A's walls within the inlier distance of B's, B placed by `a_from_b`.
fn overlap_of_a(a: &Input, b: &[Segment], a_from_b: &Pose2, params: &GlobalParams) -> f64 {
    let b_in_a: Vec<Segment> = b.iter().map(|s| s.transformed(a_from_b)).collect();
    let a_segments: Vec<Segment> = a.segments.iter().map(|s| s.segment).collect();
    let points = points_along(&a_segments, SAMPLE_SPACING_M);
    overlap_share(
        &points,
        &SegmentIndex::from_segments(&b_in_a, 1.0, params.inlier_m.max(0.5)),
        &Pose2::IDENTITY,
        params.inlier_m,
    )
}

/// B's segments placed in A's frame by one transform.
fn moved_rigidly(b: &[MapSegment], a_from_b: &Pose2) -> Vec<MapSegment> {
    b.iter()
        .map(|s| MapSegment {
            segment: s.segment.transformed(a_from_b),
            born_scan: s.born_scan,
        })
        .collect()
}
