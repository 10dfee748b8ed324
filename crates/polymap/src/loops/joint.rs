//! Two saved maps joined in one pose graph (multi-session mapping): map B's loop nodes, placed
//! in map A's frame by a rigid seed, are matched against A's nodes by the loop matcher; the
//! cross constraints join B's graph (its sequential edges from the saved poses, its loop edges
//! matched again as the loop closer matches them) to A's, and one optimisation bends B onto A.
//!
//! A stays fixed: it is the merged map's frame and its segments are kept as they are (only B's
//! move, each with its node), and A's own edges would then be constants. Cross constraints
//! are kept only when another one from a nearby B node agrees on where B lies (a false match
//! rarely repeats consistently) and when, after the optimisation, they still fit the graph;
//! the optimisation is repeated without the rejected ones.

use crate::align::{AlignParams, points_along};
use crate::geometry::Pose2;

use super::closer::matching_align;
use super::graph::{self, Edge};
use super::nodes::{Candidate, MIN_NODE_POINTS, NodeGraph, Submap};
use super::{LoopDiagnostics, LoopParams, SavedNode};
use crate::check::{Checks, InvalidParam};

/// Parameters of joining two maps' graphs (the matching itself is loop closure's, `[loops]`).
#[derive(Debug, Clone, PartialEq)]
pub struct JointParams {
    /// A cross constraint is kept only when one from a B node within this many nodes (a
    /// different node) agrees with it on where B lies.
    pub agree_within_nodes: usize,
    /// Two cross constraints agree when they put a B node within this distance, metres…
    pub agree_m: f64,
    /// …and this angle of each other, degrees.
    pub agree_deg: f64,
    /// After the optimisation, a cross constraint off the graph by more than this is
    /// rejected, metres…
    pub max_residual_m: f64,
    /// …or this angle, degrees.
    pub max_residual_deg: f64,
    /// Optimise, reject, optimise again: at most this many rounds.
    pub rounds: usize,
    /// Gauss–Newton iterations of each optimisation.
    pub max_iterations: usize,
}

impl Default for JointParams {
    fn default() -> Self {
        JointParams {
            agree_within_nodes: 10,
            agree_m: 0.3,
            agree_deg: 3.0,
            max_residual_m: 0.3,
            max_residual_deg: 3.0,
            rounds: 3,
            max_iterations: 30,
        }
    }
}

impl JointParams {
    /// Checks every key's range; the error names the first key out of range.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        Checks::new()
            .within("agree_within_nodes", self.agree_within_nodes, 1, 10_000)
            .within("agree_m", self.agree_m, 0.0, 100.0)
            .within("agree_deg", self.agree_deg, 0.0, 180.0)
            .within("max_residual_m", self.max_residual_m, 0.0, 100.0)
            .within("max_residual_deg", self.max_residual_deg, 0.0, 180.0)
            .within("rounds", self.rounds, 1, 100)
            .within("max_iterations", self.max_iterations, 1, 10_000)
            .done()
    }
}

/// What became of a cross constraint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CrossVerdict {
    /// In the graph's final optimisation.
    Used,
    /// No cross constraint of a nearby B node agreed with it.
    Unconfirmed,
    /// Off the optimised graph by more than `max_residual_m` / `max_residual_deg`.
    Residual,
}

/// A match of one of B's nodes against one of A's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CrossEdge {
    /// A's node (index in A's saved nodes).
    pub a_node: usize,
    /// B's node (index in B's saved nodes).
    pub b_node: usize,
    /// B's node in the frame of A's node, as matched: metres and radians.
    pub measured: Pose2,
    /// How far the final graph is from the measurement: metres…
    pub residual_m: f64,
    /// …and degrees (absolute).
    pub residual_deg: f64,
    /// Used or why rejected.
    pub verdict: CrossVerdict,
}

/// The outcome of [`joint_graph`]: B's node poses in A's frame before and after.
#[derive(Debug, Clone, PartialEq)]
pub struct JointGraph {
    /// B's node poses in A's frame by the seed alone (`a_from_b ∘ pose`).
    pub b_seeded: Vec<Pose2>,
    /// B's node poses in A's frame after the optimisation (the seeded ones when no cross
    /// constraint was used).
    pub b_poses: Vec<Pose2>,
    /// Every cross constraint the matcher found, in B's node order.
    pub cross: Vec<CrossEdge>,
    /// B's own loop edges, matched again from its saved nodes.
    pub b_loop_edges: usize,
    /// Node pairs matched across the maps (candidates tried).
    pub candidates: usize,
}

impl JointGraph {
    /// Cross constraints with the given verdict.
    pub fn count(&self, verdict: CrossVerdict) -> usize {
        self.cross.iter().filter(|c| c.verdict == verdict).count()
    }

    /// How far each of B's nodes moved from its seeded pose: the largest and the mean
    /// translation (metres) and the largest turn (degrees); zeros without nodes.
    pub fn moved(&self) -> (f64, f64, f64) {
        let moves: Vec<Pose2> = self
            .b_seeded
            .iter()
            .zip(&self.b_poses)
            .map(|(old, new)| old.between(new))
            .collect();
        if moves.is_empty() {
            return (0.0, 0.0, 0.0);
        }
        let dist = |p: &Pose2| {
            // The node's own position moves by new - old; the between pose's translation is
            // that in the old node's frame, of the same length.
            p.translation().length()
        };
        let max = moves.iter().map(dist).fold(0.0, f64::max);
        let mean = moves.iter().map(dist).sum::<f64>() / moves.len() as f64;
        let turn = moves
            .iter()
            .map(|p| p.theta_rad.abs().to_degrees())
            .fold(0.0, f64::max);
        (max, mean, turn)
    }

    /// Where the merge puts a pose of B (`seeded`: already placed in A's frame by the seed)
    /// that lies `share` (0 to 1) of the way from node `node`'s first scan to the next node's:
    /// the pose kept relative to each of the two nodes, blended by `share`. Past the last node
    /// (or with `share` 0) it moves with `node` alone; an unknown node leaves it where it is.
    pub fn moved_pose(&self, node: usize, share: f64, seeded: &Pose2) -> Pose2 {
        let with = |k: usize| -> Option<Pose2> {
            let old = self.b_seeded.get(k)?;
            let new = self.b_poses.get(k)?;
            Some(new.compose(&old.between(seeded)))
        };
        let Some(here) = with(node) else {
            return *seeded;
        };
        let share = share.clamp(0.0, 1.0);
        match with(node + 1) {
            Some(next) if share > 0.0 => {
                let d = crate::geometry::normalize_angle_rad(next.theta_rad - here.theta_rad);
                Pose2::new(
                    here.x_m + share * (next.x_m - here.x_m),
                    here.y_m + share * (next.y_m - here.y_m),
                    here.theta_rad + share * d,
                )
            }
            _ => here,
        }
    }
}

/// Joins B's graph to A's: B's nodes (`b`, in B's frame) placed in A's frame by `a_from_b`,
/// matched against A's nodes (`a`) by the loop matcher (`loops`, with `align`'s ICP,
/// `grid_cell_m` the spatial index's cell, metres), and B bent onto A by one optimisation
/// with A fixed (see the module's documentation).
pub fn joint_graph(
    a: &[SavedNode],
    b: &[SavedNode],
    a_from_b: &Pose2,
    loops: &LoopParams,
    align: &AlignParams,
    grid_cell_m: f64,
    params: &JointParams,
) -> JointGraph {
    let loops = LoopParams {
        enabled: true,
        ..loops.clone()
    };
    let b_seeded: Vec<Pose2> = b.iter().map(|n| a_from_b.compose(&n.pose)).collect();
    let joint = joint_nodes(a, b, &b_seeded, &loops, align, grid_cell_m);
    let mut diagnostics = LoopDiagnostics::default();
    // B's own loop edges, matched again among its saved nodes as the loop closer does.
    let b_loops = own_loop_edges(&joint, b, &mut diagnostics);
    let na = a.len();
    let mut cross: Vec<CrossEdge> = Vec::new();
    let mut tried = 0;
    for k in 0..b.len() {
        tried += cross_of(&joint, na, k, &mut cross, &mut diagnostics);
    }
    confirm(&mut cross, a, &b_seeded, params);
    let mut edges: Vec<Edge> = (1..b.len())
        .map(|k| Edge {
            from: na + k - 1,
            to: na + k,
            measured: b[k - 1].pose.between(&b[k].pose),
            sigma_m: loops.sequential_sigma_m,
            sigma_rad: loops.sequential_sigma_deg.to_radians(),
            doubt_m2: glam::DMat2::ZERO,
            robust: false,
        })
        .collect();
    edges.extend(b_loops.iter().map(|e| Edge {
        from: na + e.from,
        to: na + e.to,
        ..*e
    }));
    let own_edges = edges.len();
    let cross_edge = |c: &CrossEdge| Edge {
        from: c.a_node,
        to: na + c.b_node,
        measured: c.measured,
        sigma_m: loops.loop_sigma_m,
        sigma_rad: loops.loop_sigma_deg.to_radians(),
        doubt_m2: glam::DMat2::ZERO,
        robust: true,
    };
    // B's own edges and the cross constraints used, then B's nodes optimised from their seeds
    // with A's fixed.
    let solve = |poses: &mut [Pose2], edges: &mut Vec<Edge>, cross: &[CrossEdge]| {
        edges.truncate(own_edges);
        edges.extend(
            cross
                .iter()
                .filter(|c| c.verdict == CrossVerdict::Used)
                .map(cross_edge),
        );
        poses[na..].copy_from_slice(&b_seeded);
        if edges.len() > own_edges {
            graph::optimize(poses, edges, na..na + b.len(), params.max_iterations);
        }
    };
    let mut poses = joint.poses;
    for _ in 0..params.rounds {
        if !cross.iter().any(|c| c.verdict == CrossVerdict::Used) {
            break;
        }
        solve(&mut poses, &mut edges, &cross);
        let mut rejected = false;
        for c in &mut cross {
            let off = poses[c.a_node]
                .between(&poses[na + c.b_node])
                .between(&c.measured);
            c.residual_m = off.translation().length();
            c.residual_deg = off.theta_rad.abs().to_degrees();
            if c.verdict == CrossVerdict::Used
                && (c.residual_m > params.max_residual_m
                    || c.residual_deg > params.max_residual_deg)
            {
                c.verdict = CrossVerdict::Residual;
                rejected = true;
            }
        }
        if !rejected {
            break;
        }
    }
    // The last round may have rejected edges it was optimised with: solve once more without
    // (with none left, B stays at its seeds).
    solve(&mut poses, &mut edges, &cross);
    JointGraph {
        b_poses: poses[na..].to_vec(),
        b_seeded,
        cross,
        b_loop_edges: b_loops.len(),
        candidates: tried,
    }
}

/// The joint graph's nodes: A's first (their segments only: A's nodes are matched against,
/// never matched), then B's at `b_poses` (A's frame) with their submaps. `align` is mapping's
/// ICP, narrowed as loop closure narrows it.
pub(super) fn joint_nodes(
    a: &[SavedNode],
    b: &[SavedNode],
    b_poses: &[Pose2],
    loops: &LoopParams,
    align: &AlignParams,
    grid_cell_m: f64,
) -> NodeGraph {
    let align = matching_align(align.clone(), loops);
    let mut joint = NodeGraph::new(loops.clone(), align, grid_cell_m);
    for n in a {
        joint.poses.push(n.pose);
        joint.submaps.push(Submap {
            points: Vec::new(),
            segments: n.segments.clone(),
        });
    }
    joint.poses.extend_from_slice(b_poses);
    joint.submaps.extend(b.iter().map(|n| Submap {
        points: points_along(&n.segments, loops.node_point_spacing_m),
        segments: n.segments.clone(),
    }));
    joint
}

/// B's own loop edges (indices in B), matched among B's nodes (the last of `joint`'s, with
/// their submaps) at their saved poses as the loop closer matches them.
fn own_loop_edges(
    joint: &NodeGraph,
    b: &[SavedNode],
    diagnostics: &mut LoopDiagnostics,
) -> Vec<Edge> {
    // Only what the fixed grid finds: an edge a grown grid found would wait for a second
    // that agrees, which this one pass over B does not keep.
    let params = LoopParams {
        search_translation_per_travel: 0.0,
        ..joint.params.clone()
    };
    let mut own = NodeGraph::new(params, joint.align.clone(), joint.grid_cell_m);
    own.poses = b.iter().map(|n| n.pose).collect();
    own.submaps = joint.submaps[joint.submaps.len() - b.len()..].to_vec();
    let mut edges = Vec::new();
    for k in 0..b.len() {
        let found: Vec<Edge> = own
            .find_loop_edges(k, diagnostics)
            .into_iter()
            .map(|(e, _)| e)
            .collect();
        if !found.is_empty() {
            own.last_closed = Some(k);
        }
        edges.extend(found);
    }
    edges
}

/// Matches B's node `k` (index in B), as `joint` (whose first `na` nodes are A's) places it,
/// against A's nodes near it: each accepted match is appended to `cross`. Returns the
/// candidates tried.
pub(super) fn cross_of(
    joint: &NodeGraph,
    na: usize,
    k: usize,
    cross: &mut Vec<CrossEdge>,
    diagnostics: &mut LoopDiagnostics,
) -> usize {
    let candidates = cross_candidates(joint, na, na + k);
    for c in &candidates {
        if let Some((measured, _)) = joint.match_nodes(na + k, c, diagnostics) {
            cross.push(CrossEdge {
                a_node: c.j,
                b_node: k,
                measured,
                residual_m: 0.0,
                residual_deg: 0.0,
                verdict: CrossVerdict::Used,
            });
        }
    }
    candidates.len()
}

/// A's nodes to match B's node `k` (index in `joint`, whose first `na` nodes are A's) against:
/// within `search_radius_m`, nearest first, apart from each other, with their neighbours'
/// submaps in their frame.
fn cross_candidates(joint: &NodeGraph, na: usize, k: usize) -> Vec<Candidate> {
    if na == 0 || joint.submaps[k].points.len() < MIN_NODE_POINTS {
        return Vec::new();
    }
    joint.near_candidates(k, na - 1, na - 1)
}

/// Marks `Unconfirmed` every cross constraint that no constraint of another B node within
/// `agree_within_nodes` agrees with: B's shape over a few nodes is trusted, so two true
/// matches put the other's node where it matched.
pub(super) fn confirm(
    cross: &mut [CrossEdge],
    a: &[SavedNode],
    b_seeded: &[Pose2],
    params: &JointParams,
) {
    // Where each constraint puts its B node in A's frame, and the B frame's placement it
    // implies (B's node poses relative to each other as seeded).
    let placed: Vec<Pose2> = cross
        .iter()
        .map(|c| a[c.a_node].pose.compose(&c.measured))
        .collect();
    let moves: Vec<Pose2> = cross
        .iter()
        .zip(&placed)
        .map(|(c, p)| p.compose(&b_seeded[c.b_node].inverse()))
        .collect();
    let agree_rad = params.agree_deg.to_radians();
    let confirmed: Vec<bool> = (0..cross.len())
        .map(|i| {
            (0..cross.len()).any(|j| {
                let (ci, cj) = (&cross[i], &cross[j]);
                if ci.b_node == cj.b_node
                    || ci.b_node.abs_diff(cj.b_node) > params.agree_within_nodes
                {
                    return false;
                }
                let by_i = moves[i].compose(&b_seeded[cj.b_node]);
                let d = by_i.between(&placed[j]);
                d.translation().length() <= params.agree_m && d.theta_rad.abs() <= agree_rad
            })
        })
        .collect();
    for (c, ok) in cross.iter_mut().zip(confirmed) {
        if !ok {
            c.verdict = CrossVerdict::Unconfirmed;
        }
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::geometry::{Segment, Vec2};

    /// A corridor world: walls with doors and cross walls, no symmetry over a few metres.
    fn world() -> Vec<Segment> {
        let s =
            |x0: f64, y0: f64, x1: f64, y1: f64| Segment::new(Vec2::new(x0, y0), Vec2::new(x1, y1));
        let mut w = Vec::new();
        let mut x = 0.0;
        let mut i = 0;
        while x < 40.0 {
            let len = 1.5 + (i % 3) as f64 * 0.7;
            w.push(s(x, 1.0, x + len, 1.0));
            w.push(s(x + 0.4, -1.0, x + 0.4 + len * 0.8, -1.0));
            w.push(s(x + len, 1.0, x + len, 1.0 + 0.5 + (i % 2) as f64));
            w.push(s(x + 0.4, -1.0, x + 0.4, -1.8 - (i % 4) as f64 * 0.3));
            x += len + 0.8;
            i += 1;
        }
        w
    }

    /// Nodes along the corridor every metre from `x0` to `x1`, each holding the walls within
    /// 5 m in its frame; poses bent by `bend` (radians per metre travelled) from the truth.
    pub(in crate::loops) fn nodes(x0: f64, x1: f64, bend: f64) -> (Vec<SavedNode>, Vec<Pose2>) {
        let walls = world();
        let mut saved = Vec::new();
        let mut truth = Vec::new();
        let mut drifted = Pose2::new(0.0, 0.0, 0.0);
        let mut x = x0;
        while x <= x1 {
            let t = Pose2::new(x, 0.0, 0.0);
            if saved.is_empty() {
                drifted = Pose2::IDENTITY;
            } else {
                let step = truth.last().map(|p: &Pose2| p.between(&t)).unwrap();
                drifted = drifted.compose(&Pose2::new(step.x_m, step.y_m, bend));
            }
            let inverse = t.inverse();
            let segments = walls
                .iter()
                .filter(|s| {
                    s.start.distance(t.translation()) < 5.0 || s.end.distance(t.translation()) < 5.0
                })
                .map(|s| s.transformed(&inverse))
                .collect();
            saved.push(SavedNode {
                pose: drifted,
                segments,
            });
            truth.push(t);
            x += 1.0;
        }
        (saved, truth)
    }

    #[test]
    fn a_bent_map_is_bent_back_onto_the_fixed_one() {
        // A: the truth in its own frame (starting at x = 0); B: the same corridor again from
        // x = 2, bent by 0.3° a metre, in its own first node's frame.
        let (a, _) = nodes(0.0, 38.0, 0.0);
        let (b, b_truth) = nodes(2.0, 36.0, 0.3f64.to_radians());
        let a_from_b = b_truth[0];
        let loops = LoopParams::default();
        let g = joint_graph(
            &a,
            &b,
            &a_from_b,
            &loops,
            &AlignParams::default(),
            1.0,
            &JointParams::default(),
        );
        assert!(g.count(CrossVerdict::Used) >= 10, "{:?}", g.cross);
        // Seeded, the far end is off by the bend; after, every node is near its truth.
        let far = b.len() - 1;
        assert!(
            g.b_seeded[far]
                .translation()
                .distance(b_truth[far].translation())
                > 0.5
        );
        for (k, (p, t)) in g.b_poses.iter().zip(&b_truth).enumerate() {
            let d = p.between(t);
            assert!(
                d.translation().length() < 0.1 && d.theta_rad.abs() < 1f64.to_radians(),
                "node {k}: {p:?} against {t:?}"
            );
        }
        let (max, mean, _) = g.moved();
        assert!(max > 0.5 && mean < max, "{max} {mean}");
        // A pose halfway between two nodes moves halfway between their corrections.
        let mid = g.moved_pose(
            far - 1,
            0.5,
            &g.b_seeded[far - 1].compose(&Pose2::new(0.5, 0.0, 0.0)),
        );
        let expected = b_truth[far - 1].compose(&Pose2::new(0.5, 0.0, 0.0));
        assert!(
            mid.translation().distance(expected.translation()) < 0.1,
            "{mid:?}"
        );
    }

    #[test]
    fn a_lone_false_match_is_not_confirmed() {
        let (a, _) = nodes(0.0, 10.0, 0.0);
        let b_seeded: Vec<Pose2> = (0..6).map(|i| Pose2::new(i as f64, 0.0, 0.0)).collect();
        let truth = |k: usize, j: usize| a[j].pose.between(&b_seeded[k]);
        let mut cross = vec![
            CrossEdge {
                a_node: 1,
                b_node: 1,
                measured: truth(1, 1),
                residual_m: 0.0,
                residual_deg: 0.0,
                verdict: CrossVerdict::Used,
            },
            CrossEdge {
                a_node: 3,
                b_node: 3,
                measured: truth(3, 3),
                residual_m: 0.0,
                residual_deg: 0.0,
                verdict: CrossVerdict::Used,
            },
            CrossEdge {
                a_node: 4,
                b_node: 5,
                measured: truth(5, 4).compose(&Pose2::new(1.5, 0.0, 0.0)),
                residual_m: 0.0,
                residual_deg: 0.0,
                verdict: CrossVerdict::Used,
            },
        ];
        confirm(&mut cross, &a, &b_seeded, &JointParams::default());
        let verdicts: Vec<CrossVerdict> = cross.iter().map(|c| c.verdict).collect();
        assert_eq!(
            verdicts,
            [
                CrossVerdict::Used,
                CrossVerdict::Used,
                CrossVerdict::Unconfirmed
            ]
        );
        assert!(JointParams::default().validate().is_ok());
    }
}
