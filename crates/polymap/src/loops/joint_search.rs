//! Seeds of the joint pose graph found without a guess: every few of B's loop nodes searched
//! over the whole of map A by the whole-map correlative search ([`GlobalSearch`]), each of its
//! distinct peaks checked by the loop matcher against A's nodes there (as the joint graph
//! matches a seeded node), the matches confirmed as the joint graph confirms its cross
//! constraints, and the placements of B that most confirmed matches agree on returned.
//!
//! A rigid match of the whole of B lays a drifted map well only where B agrees with A as a
//! whole; a node's submap is small enough to lie where it belongs even when B as a whole is
//! bent, so the nodes find the places the rigid match misses.

use crate::align::{AlignParams, GlobalSearch};
use crate::check::{Checks, InvalidParam};
use crate::geometry::Pose2;
use crate::map::{GlobalMap, MapSegment};

use super::joint::{CrossEdge, CrossVerdict, JointParams, confirm, cross_of, joint_nodes};
use super::nodes::MIN_NODE_POINTS;
use super::{LoopDiagnostics, LoopParams, SavedNode};

/// Parameters of the per-node search for seeds (the matching itself is loop closure's).
#[derive(Debug, Clone, PartialEq)]
pub struct NodeSearchParams {
    /// Raster cell of the search over A, metres.
    pub cell_m: f64,
    /// Kernel scale of that raster, metres.
    pub sigma_m: f64,
    /// Distinct peaks of each node's search checked by the loop matcher, at most.
    pub peaks_per_node: usize,
    /// Two peaks are distinct beyond this distance, metres…
    pub peaks_apart_m: f64,
    /// …or this turn, degrees.
    pub peaks_apart_deg: f64,
    /// A node's points farther than this from its origin are left out of its search when
    /// enough are nearer, metres.
    pub max_range_m: f64,
    /// Every `node_step`-th of B's nodes is searched (the first, then every step): the
    /// search over the whole of A is the cost of a merge, and a true placement is confirmed
    /// by searched nodes a few apart (within [`JointParams::agree_within_nodes`]).
    pub node_step: usize,
    /// Seeds returned, at most.
    pub max_seeds: usize,
    /// Two placements of B agree (and make one seed) when they put a node within this
    /// distance, metres…
    pub seeds_apart_m: f64,
    /// …and this turn of each other, degrees.
    pub seeds_apart_deg: f64,
}

impl Default for NodeSearchParams {
    fn default() -> Self {
        NodeSearchParams {
            cell_m: 0.2,
            sigma_m: 0.3,
            peaks_per_node: 3,
            peaks_apart_m: 1.0,
            peaks_apart_deg: 10.0,
            max_range_m: 10.0,
            node_step: 3,
            max_seeds: 3,
            seeds_apart_m: 2.0,
            seeds_apart_deg: 10.0,
        }
    }
}

impl NodeSearchParams {
    /// Checks every key's range; the error names the first key out of range.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        Checks::new()
            .above("cell_m", self.cell_m, 0.0, 10.0)
            .above("sigma_m", self.sigma_m, 0.0, 10.0)
            .within("peaks_per_node", self.peaks_per_node, 1, 100)
            .within("peaks_apart_m", self.peaks_apart_m, 0.0, 100.0)
            .within("peaks_apart_deg", self.peaks_apart_deg, 0.0, 180.0)
            .above("max_range_m", self.max_range_m, 0.0, 1000.0)
            .within("node_step", self.node_step, 1, 1000)
            .within("max_seeds", self.max_seeds, 1, 100)
            .within("seeds_apart_m", self.seeds_apart_m, 0.0, 1000.0)
            .within("seeds_apart_deg", self.seeds_apart_deg, 0.0, 180.0)
            .done()
    }
}

/// A placement of all of B in A's frame that confirmed node matches agree on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodeSeed {
    /// B's frame in A's: metres and radians.
    pub a_from_b: Pose2,
    /// B's nodes whose confirmed matches put them within `seeds_apart_m` and
    /// `seeds_apart_deg` of where this placement puts them.
    pub support: usize,
}

/// The outcome of [`node_search_seeds`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct NodeSearch {
    /// The seeds, most supported first, each apart from those before it.
    pub seeds: Vec<NodeSeed>,
    /// B's nodes searched (every `node_step`-th, of those with enough points).
    pub searched: usize,
    /// Matches the loop matcher accepted at the peaks.
    pub matched: usize,
    /// Of these, confirmed by a match of a nearby B node.
    pub confirmed: usize,
}

/// Searches every `node_step`-th of B's nodes (`b`, B's frame) over the whole of A (`a`) and
/// returns the placements of B its confirmed matches agree on (see the module's
/// documentation); `loops`, `align` and `grid_cell_m` (metres) as for [`super::joint_graph`].
pub fn node_search_seeds(
    a: &[SavedNode],
    b: &[SavedNode],
    loops: &LoopParams,
    align: &AlignParams,
    grid_cell_m: f64,
    joint: &JointParams,
    params: &NodeSearchParams,
) -> NodeSearch {
    let Some(search) = whole_of(a, grid_cell_m, params) else {
        return NodeSearch::default();
    };
    let loops = LoopParams {
        enabled: true,
        ..loops.clone()
    };
    let b_own: Vec<Pose2> = b.iter().map(|n| n.pose).collect();
    let mut graph = joint_nodes(a, b, &b_own, &loops, align, grid_cell_m);
    let na = a.len();
    let apart = (params.peaks_apart_m, params.peaks_apart_deg.to_radians());
    let mut diagnostics = LoopDiagnostics::default();
    let mut cross: Vec<CrossEdge> = Vec::new();
    let mut searched = 0;
    for k in (0..b.len()).step_by(params.node_step.max(1)) {
        let points = graph.submaps[na + k].points.clone();
        if points.len() < MIN_NODE_POINTS {
            continue;
        }
        searched += 1;
        let peaks = search.peaks(
            &points,
            None,
            params.peaks_per_node,
            params.max_range_m,
            apart,
        );
        for peak in peaks {
            graph.poses[na + k] = peak.map_from_robot;
            cross_of(&graph, na, k, &mut cross, &mut diagnostics);
        }
    }
    let matched = cross.len();
    confirm(&mut cross, a, &b_own, joint);
    cross.retain(|c| c.verdict == CrossVerdict::Used);
    NodeSearch {
        seeds: agreed_seeds(&cross, a, &b_own, params),
        searched,
        matched,
        confirmed: cross.len(),
    }
}

/// A's nodes' segments in A's frame, prepared for whole-map searches; `None` without any.
fn whole_of(a: &[SavedNode], grid_cell_m: f64, params: &NodeSearchParams) -> Option<GlobalSearch> {
    let mut map = GlobalMap::new(grid_cell_m, 1.0);
    for n in a {
        for s in &n.segments {
            map.insert(MapSegment {
                segment: s.transformed(&n.pose),
                born_scan: 0,
            });
        }
    }
    GlobalSearch::new(&map, params.cell_m, params.sigma_m)
}

/// The placements of B (`a_from_b`) implied by the confirmed matches `cross`, each with the
/// number of B nodes it agrees with, most supported first, each apart from those before it.
fn agreed_seeds(
    cross: &[CrossEdge],
    a: &[SavedNode],
    b_own: &[Pose2],
    params: &NodeSearchParams,
) -> Vec<NodeSeed> {
    let placed: Vec<Pose2> = cross
        .iter()
        .map(|c| a[c.a_node].pose.compose(&c.measured))
        .collect();
    let implied: Vec<Pose2> = cross
        .iter()
        .zip(&placed)
        .map(|(c, p)| p.compose(&b_own[c.b_node].inverse()))
        .collect();
    let near = |d: Pose2| {
        d.translation().length() <= params.seeds_apart_m
            && d.theta_rad.abs() <= params.seeds_apart_deg.to_radians()
    };
    let mut ranked: Vec<NodeSeed> = implied
        .iter()
        .map(|a_from_b| {
            let mut nodes: Vec<usize> = cross
                .iter()
                .zip(&placed)
                .filter(|(c, p)| near(a_from_b.compose(&b_own[c.b_node]).between(p)))
                .map(|(c, _)| c.b_node)
                .collect();
            nodes.sort_unstable();
            nodes.dedup();
            NodeSeed {
                a_from_b: *a_from_b,
                support: nodes.len(),
            }
        })
        .collect();
    // Most supported first; ties keep B's node order (stable sort).
    ranked.sort_by_key(|s| std::cmp::Reverse(s.support));
    let mut seeds: Vec<NodeSeed> = Vec::new();
    for s in ranked {
        if seeds.len() >= params.max_seeds {
            break;
        }
        if seeds.iter().all(|t| !near(t.a_from_b.between(&s.a_from_b))) {
            seeds.push(s);
        }
    }
    seeds
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::loops::joint::tests::nodes;

    #[test]
    fn b_far_from_any_rigid_guess_is_found_by_its_nodes() {
        // A: the corridor from x = 0; B: its stretch from x = 12, in its own first node's
        // frame, so B's frame lies 12 m along A's: nothing seeds it near the truth.
        let (a, _) = nodes(0.0, 38.0, 0.0);
        let (b, b_truth) = nodes(12.0, 30.0, 0.0);
        let found = node_search_seeds(
            &a,
            &b,
            &LoopParams::default(),
            &AlignParams::default(),
            1.0,
            &JointParams::default(),
            &NodeSearchParams::default(),
        );
        let best = found.seeds.first().expect("a seed");
        let d = b_truth[0].between(&best.a_from_b);
        assert!(
            d.translation().length() < 0.1 && d.theta_rad.abs() < 1f64.to_radians(),
            "{found:?}"
        );
        assert!(best.support >= 5, "{found:?}");
        assert!(found.confirmed >= best.support && found.matched >= found.confirmed);
        assert!(NodeSearchParams::default().validate().is_ok());
    }

    #[test]
    fn every_third_node_is_searched_and_still_finds_b() {
        // B's 19 nodes: the 1st, 4th, … 19th are searched by default (7), all with one step.
        let (a, _) = nodes(0.0, 38.0, 0.0);
        let (b, b_truth) = nodes(12.0, 30.0, 0.0);
        let search = |node_step| {
            node_search_seeds(
                &a,
                &b,
                &LoopParams::default(),
                &AlignParams::default(),
                1.0,
                &JointParams::default(),
                &NodeSearchParams {
                    node_step,
                    ..NodeSearchParams::default()
                },
            )
        };
        let (every, third) = (search(1), search(3));
        assert_eq!((every.searched, third.searched), (19, 7));
        assert!(third.matched < every.matched, "{third:?} {every:?}");
        let best = third.seeds.first().expect("a seed");
        let d = b_truth[0].between(&best.a_from_b);
        assert!(d.translation().length() < 0.1, "{third:?}");
    }

    #[test]
    fn without_nodes_there_is_no_seed() {
        let (a, _) = nodes(0.0, 10.0, 0.0);
        let found = node_search_seeds(
            &a,
            &[],
            &LoopParams::default(),
            &AlignParams::default(),
            1.0,
            &JointParams::default(),
            &NodeSearchParams::default(),
        );
        assert!(found.seeds.is_empty());
        let none = node_search_seeds(
            &[],
            &a,
            &LoopParams::default(),
            &AlignParams::default(),
            1.0,
            &JointParams::default(),
            &NodeSearchParams::default(),
        );
        assert_eq!(none, NodeSearch::default());
    }
}
