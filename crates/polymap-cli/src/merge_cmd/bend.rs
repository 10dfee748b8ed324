//! B bent onto A by the joint pose graph of both maps' loop nodes
//! ([`polymap::loops::joint_graph`]), seeded by the rigid match's best poses and, when none
//! of them passes, by a search of every few of B's nodes over A
//! ([`polymap::loops::node_search_seeds`]).

use std::time::Instant;

use polymap::align::{GlobalMatch, GlobalParams, MatchVerdict, overlap_share, points_along};
use polymap::config::Config;
use polymap::geometry::{Pose2, Segment};
use polymap::loops::{
    CrossVerdict, JointGraph, JointParams, NodeSearch, NodeSearchParams, SavedNode, joint_graph,
    node_search_seeds,
};
use polymap::map::{GlobalMap, MapSegment};
use polymap::segment_index::SegmentIndex;
use polymap_io::tum::StampedPose;
use serde_json::json;

use super::SAMPLE_SPACING_M;
use super::input::Input;
use super::report::pose_json;

/// Seeds of the joint pose graph tried, at most: the rigid match's best poses.
const MAX_SEEDS: usize = 3;
/// A seed after the first explains at least this mean raster value of B's points.
const SEED_MIN_RASTER: f64 = 0.15;
/// Least cross constraints a merge by the joint pose graph keeps.
const MIN_CROSS: usize = 5;
/// Least share of B's bent walls within `inlier_m` of A's in a merge by the joint pose graph.
const MIN_BENT_OVERLAP: f64 = 0.2;
/// B's bent walls within this of A's are where the maps meet, metres.
const NEAR_M: f64 = 0.5;
/// Least share of B's bent walls where the maps meet (within `NEAR_M` of A's) that lie on
/// A's (within `inlier_m`): bent onto the right place, the two maps' walls coincide there.
const MIN_AGREEMENT: f64 = 0.5;
/// Cross constraints listed in `merge.json`, at most (the rejected first).
const CROSS_SHOWN: usize = 10;

/// B bent onto A by the joint pose graph from one seed.
pub(super) struct Bent {
    /// B's placement in A seeding the graph.
    pub seed: Pose2,
    pub graph: JointGraph,
    /// B's segments moved with their nodes, A's frame.
    pub b_segments: Vec<MapSegment>,
    /// B's trajectory moved with its nodes, A's frame (empty without `trajectory.tum`).
    pub b_trajectory: Vec<StampedPose>,
    /// The share of B's bent walls within `inlier_m` of A's.
    pub overlap: f64,
    /// Of B's bent walls within `NEAR_M` of A's, the share within `inlier_m`.
    pub agreement: f64,
    /// Enough cross constraints kept and enough overlap.
    pub passes: bool,
}

/// The outcome of laying B onto A by the joint pose graph.
pub(super) struct Tried {
    pub verdict: MatchVerdict,
    /// Every seed tried: its pose, cross constraints used, overlap, agreement, whether it
    /// passed.
    pub seeds: Vec<(Pose2, usize, f64, f64, bool)>,
    /// The first this many seeds are the rigid match's; the others the node search's.
    pub rigid_seeds: usize,
    /// The search of B's nodes over A with its wall-clock seconds; `None` when a rigid seed
    /// passed and it was not needed.
    pub node_search: Option<(NodeSearch, f64)>,
    /// The first passing attempt in seed order, else the first attempt.
    pub best: Option<Bent>,
    /// Another passing attempt that puts B elsewhere (the merge is then ambiguous).
    pub rival: Option<Pose2>,
}

/// B bent onto A by the joint pose graph from each of the rigid match's best distinct poses
/// and, when none of them passes, from the node search's placements; accepted when one passes
/// (see [`Bent::passes`]) and no other passing one puts B elsewhere.
///
/// The node search (most of the cost) runs only when no rigid seed passes: it only adds
/// seeds, so it could turn a passing rigid seed into an ambiguous merge but never into a
/// refusal for lack of overlap, and foreign maps, which pass from no seed, are searched as
/// before.
pub(super) fn by_pose_graph(
    fixed: &GlobalMap,
    b: &Input,
    a_nodes: &[SavedNode],
    b_nodes: &[SavedNode],
    found: &GlobalMatch,
    params: &GlobalParams,
    config: &Config,
) -> Tried {
    let mut seeds = vec![found.fixed_from_moving];
    for c in &found.candidates {
        if seeds.len() >= MAX_SEEDS {
            break;
        }
        if c.raster_score >= SEED_MIN_RASTER
            && seeds.iter().all(|s| apart(s, &c.fixed_from_moving, params))
        {
            seeds.push(c.fixed_from_moving);
        }
    }
    let rigid_seeds = seeds.len();
    let a_segments: Vec<Segment> = fixed.iter().map(|(_, s)| s.segment).collect();
    let a_index = SegmentIndex::from_segments(&a_segments, 1.0, NEAR_M);
    let attempt = |seed: &Pose2| bent_from(&a_index, b, a_nodes, b_nodes, seed, params, config);
    let mut attempts: Vec<Bent> = seeds.iter().map(attempt).collect();
    let mut node_search = None;
    if !attempts.iter().any(|t| t.passes) {
        let started = Instant::now();
        let searched = node_search_seeds(
            a_nodes,
            b_nodes,
            &config.loops,
            &config.align,
            config.map.grid_cell_m,
            &JointParams::default(),
            &NodeSearchParams::default(),
        );
        let seconds = started.elapsed().as_secs_f64();
        for s in &searched.seeds {
            if seeds.iter().all(|t| apart(t, &s.a_from_b, params)) {
                seeds.push(s.a_from_b);
                attempts.push(attempt(&s.a_from_b));
            }
        }
        node_search = Some((searched, seconds));
    }
    let summary = attempts
        .iter()
        .map(|t| {
            (
                t.seed,
                t.graph.count(CrossVerdict::Used),
                t.overlap,
                t.agreement,
                t.passes,
            )
        })
        .collect();
    // The passing attempts first, each group in seed order (the rigid match's best first).
    attempts.sort_by_key(|t| !t.passes);
    let rival = attempts.first().filter(|t| t.passes).and_then(|best| {
        attempts
            .iter()
            .skip(1)
            .find(|t| t.passes && elsewhere(best, t, params))
            .map(|t| t.seed)
    });
    let best = attempts.into_iter().next();
    let verdict = match (&best, rival) {
        (Some(t), None) if t.passes => MatchVerdict::Accepted,
        (Some(t), Some(_)) if t.passes => MatchVerdict::Ambiguous,
        _ => MatchVerdict::NoOverlap,
    };
    Tried {
        verdict,
        seeds: summary,
        rigid_seeds,
        node_search,
        best,
        rival,
    }
}

/// B bent onto A (`a_index`: A's walls) by the joint pose graph from `seed`, judged.
fn bent_from(
    a_index: &SegmentIndex<usize>,
    b: &Input,
    a_nodes: &[SavedNode],
    b_nodes: &[SavedNode],
    seed: &Pose2,
    params: &GlobalParams,
    config: &Config,
) -> Bent {
    let graph = joint_graph(
        a_nodes,
        b_nodes,
        seed,
        &config.loops,
        &config.align,
        config.map.grid_cell_m,
        &JointParams::default(),
    );
    let (b_segments, b_trajectory) = bend_b(b, b_nodes, &graph, seed, config.loops.node_scans);
    let bent: Vec<Segment> = b_segments.iter().map(|s| s.segment).collect();
    let points = points_along(&bent, SAMPLE_SPACING_M);
    let overlap = overlap_share(&points, a_index, &Pose2::IDENTITY, params.inlier_m);
    let near = overlap_share(&points, a_index, &Pose2::IDENTITY, NEAR_M);
    let agreement = if near > 0.0 { overlap / near } else { 0.0 };
    let passes = graph.count(CrossVerdict::Used) >= MIN_CROSS
        && overlap >= MIN_BENT_OVERLAP
        && agreement >= MIN_AGREEMENT;
    Bent {
        seed: *seed,
        graph,
        b_segments,
        b_trajectory,
        overlap,
        agreement,
        passes,
    }
}

/// True when two bent Bs lie in different places: half of B's nodes or more are farther
/// apart than `apart_m` or turned more than `apart_deg` between the two (parts of B far from
/// A may bend differently from different seeds; a second place moves all of B).
fn elsewhere(one: &Bent, other: &Bent, params: &GlobalParams) -> bool {
    let (a, b) = (&one.graph.b_poses, &other.graph.b_poses);
    if a.is_empty() || a.len() != b.len() {
        return apart(&one.seed, &other.seed, params);
    }
    let moved = a.iter().zip(b).filter(|(p, q)| apart(p, q, params)).count();
    2 * moved >= a.len()
}

/// True when two poses are farther apart than `apart_m` or `apart_deg`.
fn apart(a: &Pose2, b: &Pose2, params: &GlobalParams) -> bool {
    let d = a.between(b);
    d.translation().length() > params.apart_m || d.theta_rad.abs() > params.apart_deg.to_radians()
}

/// The first scan of each of B's nodes: the scan of B's trajectory at the node's pose (a node
/// is posed at its first scan, both corrected alike), in order; every `node_scans`-th scan
/// when some node is not found there (no trajectory, or nodes of an earlier run).
fn node_starts(nodes: &[SavedNode], trajectory: &[StampedPose], node_scans: u32) -> Vec<u32> {
    const SAME_M: f64 = 1e-5;
    const SAME_RAD: f64 = 1e-5;
    let mut starts = Vec::with_capacity(nodes.len());
    let mut from = 0;
    for n in nodes {
        let at = trajectory.get(from..).and_then(|rest| {
            rest.iter().position(|p| {
                let d = p.map_from_robot.between(&n.pose);
                d.translation().length() <= SAME_M && d.theta_rad.abs() <= SAME_RAD
            })
        });
        match at {
            Some(i) => {
                starts.push((from + i) as u32);
                from += i + 1;
            }
            None => {
                return (0..nodes.len())
                    .map(|k| (k as u64 * node_scans as u64).min(u32::MAX as u64) as u32)
                    .collect();
            }
        }
    }
    starts
}

/// B's segments and trajectory in A's frame, each moved with its scan: a scan between two
/// nodes' first scans moves by the blend of the two nodes' corrections
/// ([`JointGraph::moved_pose`]); a segment moves with the scan it was born in.
fn bend_b(
    b: &Input,
    nodes: &[SavedNode],
    graph: &JointGraph,
    seed: &Pose2,
    node_scans: u32,
) -> (Vec<MapSegment>, Vec<StampedPose>) {
    let starts = node_starts(nodes, &b.trajectory, node_scans);
    let node_and_share = |t: u32| {
        let k = starts.partition_point(|&s| s <= t).saturating_sub(1);
        let share = match (starts.get(k), starts.get(k + 1)) {
            (Some(&s0), Some(&s1)) if s1 > s0 && t >= s0 => (t - s0) as f64 / (s1 - s0) as f64,
            _ => 0.0,
        };
        (k, share)
    };
    // The correction (new ∘ old⁻¹, A's frame) of scan t.
    let correction = |t: u32| -> Pose2 {
        let (k, share) = node_and_share(t);
        match b.trajectory.get(t as usize) {
            Some(p) => {
                let old = seed.compose(&p.map_from_robot);
                graph.moved_pose(k, share, &old).compose(&old.inverse())
            }
            None => match (graph.b_poses.get(k), graph.b_seeded.get(k)) {
                (Some(new), Some(old)) => new.compose(&old.inverse()),
                _ => Pose2::IDENTITY,
            },
        }
    };
    let segments = b
        .segments
        .iter()
        .map(|s| MapSegment {
            segment: s
                .segment
                .transformed(&correction(s.born_scan).compose(seed)),
            born_scan: s.born_scan,
        })
        .collect();
    let trajectory = b
        .trajectory
        .iter()
        .enumerate()
        .map(|(t, p)| StampedPose {
            stamp: p.stamp.clone(),
            map_from_robot: correction(t as u32).compose(&seed.compose(&p.map_from_robot)),
        })
        .collect();
    (segments, trajectory)
}

/// `merge.json`'s `pose_graph`: the seeds tried, the cross constraints, how far each map's
/// nodes moved.
pub(super) fn pose_graph_json(t: &Tried, seconds: f64) -> serde_json::Value {
    let seeds: Vec<serde_json::Value> = t
        .seeds
        .iter()
        .enumerate()
        .map(|(i, (seed, used, overlap, agreement, passes))| {
            let from = if i < t.rigid_seeds {
                "rigid"
            } else {
                "node_search"
            };
            json!({"a_from_b": pose_json(seed), "from": from, "cross_used": used,
                   "overlap": overlap, "agreement": agreement, "passes": passes})
        })
        .collect();
    let mut out = json!({
        "verdict": t.verdict,
        "seeds": seeds,
        "min_cross": MIN_CROSS,
        "min_overlap": MIN_BENT_OVERLAP,
        "min_agreement": MIN_AGREEMENT,
        "rival": t.rival.as_ref().map(pose_json),
        "node_search": node_search_json(t.node_search.as_ref()),
        "seconds": seconds,
    });
    let Some(best) = &t.best else {
        return out;
    };
    let g = &best.graph;
    let (max_m, mean_m, max_deg) = g.moved();
    let mut shown: Vec<_> = g.cross.iter().collect();
    shown.sort_by_key(|c| c.verdict == CrossVerdict::Used);
    let shown: Vec<serde_json::Value> = shown
        .iter()
        .take(CROSS_SHOWN)
        .map(|c| {
            json!({"a_node": c.a_node, "b_node": c.b_node, "verdict": c.verdict,
                   "residual_m": c.residual_m, "residual_deg": c.residual_deg})
        })
        .collect();
    out["seed"] = pose_json(&best.seed);
    out["overlap"] = json!(best.overlap);
    out["moved"] = json!({
        "a": {"max_m": 0.0, "mean_m": 0.0, "max_deg": 0.0},
        "b": {"max_m": max_m, "mean_m": mean_m, "max_deg": max_deg},
    });
    out["nodes"] = json!({"b": g.b_poses.len()});
    out["b_loop_edges"] = json!(g.b_loop_edges);
    out["cross"] = json!({
        "tried": g.candidates,
        "found": g.cross.len(),
        "used": g.count(CrossVerdict::Used),
        "unconfirmed": g.count(CrossVerdict::Unconfirmed),
        "residual": g.count(CrossVerdict::Residual),
        "shown": shown,
    });
    out
}

/// `merge.json`'s `pose_graph.node_search`: what the search found, or why it did not run.
fn node_search_json(searched: Option<&(NodeSearch, f64)>) -> serde_json::Value {
    let Some((n, seconds)) = searched else {
        return json!({"skipped": "a seed of the rigid match passed"});
    };
    json!({
        "searched": n.searched,
        "matched": n.matched,
        "confirmed": n.confirmed,
        "seeds": n.seeds.iter().map(|s| json!({
            "a_from_b": pose_json(&s.a_from_b), "support": s.support,
        })).collect::<Vec<_>>(),
        "seconds": seconds,
    })
}

/// Why the maps are not merged by the joint pose graph either, with the figures.
pub(super) fn bend_refusal(
    a: &Input,
    b: &Input,
    t: &Tried,
    found: &GlobalMatch,
    params: &GlobalParams,
) -> String {
    let (a, b) = (&a.label, &b.label);
    let (used, overlap, agreement) = t.best.as_ref().map_or((0, 0.0, 0.0), |x| {
        (x.graph.count(CrossVerdict::Used), x.overlap, x.agreement)
    });
    match (t.verdict, t.rival, &t.best) {
        (MatchVerdict::Ambiguous, Some(r), Some(best)) => {
            let d = r.between(&best.seed);
            format!(
                "{b} fits {a} in two places: bent by a joint pose graph of their loop nodes \
                 from two seeds {:.1} m and {:.0}° apart, both keep enough cross constraints \
                 and overlap: not merged (see merge.json)",
                d.translation().length(),
                d.theta_rad.to_degrees().abs()
            )
        }
        _ => format!(
            "{a} and {b} do not overlap: the best rigid alignment scores {:.2} (needs {:.2}) \
             with {:.0} % of B's walls within {} m of A's (needs {:.0} %), and bent by a joint \
             pose graph of their loop nodes ({} seeds) B keeps {used} cross constraints (needs \
             {MIN_CROSS}) with {:.0} % of its walls within {} m of A's (needs {:.0} %), {:.0} % \
             of those within {NEAR_M} m (needs {:.0} %): not merged (see merge.json)",
            found.best.raster_score,
            params.min_score,
            100.0 * found.overlap,
            params.inlier_m,
            100.0 * params.min_overlap,
            t.seeds.len(),
            100.0 * overlap,
            params.inlier_m,
            100.0 * MIN_BENT_OVERLAP,
            100.0 * agreement,
            100.0 * MIN_AGREEMENT,
        ),
    }
}
