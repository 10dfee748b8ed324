//! The node graph on the loop side: the node submaps, the pose graph's edges, candidate choice,
//! the confirmation of far loop edges and the optimisation trigger.

use crate::align::AlignParams;
use crate::geometry::{Pose2, Segment, Vec2};

use super::graph::{self, Edge};
use super::{LoopDiagnostics, LoopParams};

/// A node's submap, in the node's frame.
#[derive(Debug, Clone, Default)]
pub(super) struct Submap {
    pub(super) points: Vec<Vec2>,
    pub(super) segments: Vec<Segment>,
}

/// A completed node, handed from the mapper to the graph.
#[derive(Debug)]
pub(super) struct NodeDone {
    pub(super) node: usize,
    /// The mapper's pose of the node (used for the first node only).
    pub(super) pose: Pose2,
    /// The mapper's motion from the node before.
    pub(super) from_previous: Option<Pose2>,
    /// The doubt on that motion beyond a confident match's, m², in this node's frame.
    pub(super) doubt_m2: glam::DMat2,
    pub(super) submap: Submap,
}

/// An older node to match against, with its submap (and its neighbours') in its frame.
#[derive(Debug, Clone)]
pub(super) struct Candidate {
    pub(super) j: usize,
    pub(super) predicted: Pose2,
    pub(super) target: Vec<Segment>,
    /// Half-width of the grid of translations searched around `predicted`, metres.
    pub(super) search_half_m: f64,
}

/// The pose graph with the node submaps.
#[derive(Debug, Clone)]
pub(super) struct NodeGraph {
    pub(super) params: LoopParams,
    pub(super) align: AlignParams,
    pub(super) grid_cell_m: f64,
    pub(super) submaps: Vec<Submap>,
    pub(super) poses: Vec<Pose2>,
    pub(super) edges: Vec<Edge>,
    /// The last node that got a loop edge.
    pub(super) last_closed: Option<usize>,
    /// Loop edges waiting for a second that agrees: those that would bend the graph a lot
    /// (with `confirm_within_nodes`), and those a grid grown with the travel found (`true`).
    pub(super) held: Vec<(Edge, bool)>,
    /// Nodes below this never move: node 0 (the map frame), or the nodes of a saved map.
    pub(super) fixed: usize,
    /// This run's first node: 0, or after a saved map's nodes their count.
    pub(super) first_run_node: usize,
}

/// What the graph did with one node: loop edges found, and the optimised poses of nodes
/// `first..=node` if it optimised.
#[derive(Debug, Clone, Default)]
pub(super) struct JobResult {
    pub(super) optimized: Option<(usize, Vec<Pose2>)>,
    pub(super) diagnostics: LoopDiagnostics,
}

/// Candidates whose poses are within this many nodes of a chosen one are skipped: two
/// neighbours of one place would test the same thing.
pub(super) const CANDIDATE_SPACING_NODES: usize = 2;

impl NodeGraph {
    /// An empty graph; `align` is the ICP used to match submaps, `grid_cell_m` the cell size
    /// of their spatial index (speed only).
    pub(super) fn new(params: LoopParams, align: AlignParams, grid_cell_m: f64) -> Self {
        NodeGraph {
            params,
            align,
            grid_cell_m,
            submaps: Vec::new(),
            poses: Vec::new(),
            edges: Vec::new(),
            last_closed: None,
            held: Vec::new(),
            fixed: 1,
            first_run_node: 0,
        }
    }

    /// Adds a completed node (after its sequential edge), matches it against older nodes near
    /// it, and optimises when a new loop edge disagrees with the graph.
    pub(super) fn add(&mut self, done: NodeDone) -> JobResult {
        let k = self.push_node(done);
        let mut out = JobResult::default();
        let clock = std::time::Instant::now();
        let found = self.find_loop_edges(k, &mut out.diagnostics);
        let take = self.confirm(k, found);
        out.diagnostics.held = self.held.len();
        let optimize_from = self.take_edges(k, take, &mut out.diagnostics);
        out.diagnostics.match_s = clock.elapsed().as_secs_f64();
        // Node 0 holds the map frame (the first scan's pose): it never moves; nor do a saved
        // map's nodes (the node where a run continuing it placed itself is tied to them by
        // its placement).
        let Some(first) = optimize_from.map(|f| f.max(self.fixed)) else {
            return out;
        };
        if first > k {
            return out;
        }
        let clock = std::time::Instant::now();
        graph::optimize(
            &mut self.poses,
            &self.edges,
            first..k + 1,
            self.params.max_iterations,
        );
        out.optimized = Some((first, self.poses[first..=k].to_vec()));
        out.diagnostics.optimize_s = clock.elapsed().as_secs_f64();
        out
    }

    /// Appends the node with its sequential edge (the mapper's motion from the node before);
    /// returns its index.
    fn push_node(&mut self, done: NodeDone) -> usize {
        let k = self.poses.len();
        let pose = match (self.poses.last(), done.from_previous) {
            (Some(last), Some(z)) => {
                self.edges.push(Edge {
                    from: k - 1,
                    to: k,
                    measured: z,
                    sigma_m: self.params.sequential_sigma_m,
                    sigma_rad: self.params.sequential_sigma_deg.to_radians(),
                    doubt_m2: done.doubt_m2,
                    robust: false,
                });
                last.compose(&z)
            }
            // The first node of a run on a saved map: no motion joins it to the saved map's
            // last node, its placement does (`placed_sigma_m`).
            (Some(last), None) => {
                self.edges.push(Edge {
                    from: k - 1,
                    to: k,
                    measured: last.between(&done.pose),
                    sigma_m: self.params.placed_sigma_m,
                    sigma_rad: self.params.placed_sigma_deg.to_radians(),
                    doubt_m2: glam::DMat2::ZERO,
                    robust: false,
                });
                done.pose
            }
            _ => done.pose,
        };
        debug_assert_eq!(k, done.node);
        self.poses.push(pose);
        self.submaps.push(done.submap);
        k
    }

    /// The loop edges node `k` gets from matching its candidates, each with whether a grid
    /// grown with the travel found it.
    pub(super) fn find_loop_edges(
        &self,
        k: usize,
        diagnostics: &mut LoopDiagnostics,
    ) -> Vec<(Edge, bool)> {
        let mut found: Vec<(Edge, bool)> = Vec::new();
        for c in &self.candidates(k) {
            diagnostics.candidates += 1;
            let Some((measured, grown)) = self.match_nodes(k, c, diagnostics) else {
                continue;
            };
            let edge = Edge {
                from: c.j,
                to: k,
                measured,
                sigma_m: self.params.loop_sigma_m,
                sigma_rad: self.params.loop_sigma_deg.to_radians(),
                doubt_m2: glam::DMat2::ZERO,
                robust: true,
            };
            found.push((edge, grown));
        }
        found
    }

    /// The edges to take in now: an edge a grid grown with the travel found (for
    /// [`FAR_CONFIRM_WITHIN_NODES`] nodes), or (for `confirm_within_nodes` nodes) one that would
    /// bend the graph a lot, waits (held) for a second one of its kind that agrees with it to
    /// within `confirm_above_m` and `confirm_above_deg` (a false match rarely repeats
    /// consistently); the others go in at once, and so do held edges another confirms.
    pub(super) fn confirm(&mut self, k: usize, found: Vec<(Edge, bool)>) -> Vec<Edge> {
        let p = &self.params;
        let (confirm_m, confirm_rad) = (p.confirm_above_m, p.confirm_above_deg.to_radians());
        let within_nodes = |grown: bool| match grown {
            true => FAR_CONFIRM_WITHIN_NODES,
            false => p.confirm_within_nodes,
        };
        self.held
            .retain(|(e, grown)| e.to + within_nodes(*grown) >= k);
        let mut take: Vec<Edge> = Vec::new();
        for (e, grown) in found {
            // An edge a grid grown with the travel found always waits: the wider the search,
            // the likelier an alike place matches.
            let doubted =
                p.confirm_within_nodes > 0 && beyond(&off(&self.poses, &e), confirm_m, confirm_rad);
            match grown || doubted {
                false => take.push(e),
                true => self.held.push((e, grown)),
            }
        }
        let agree = |poses: &[Pose2], a: &Edge, b: &Edge| {
            // Where `a` puts b's node (moving it with a's node) against where `b` puts it.
            let a_moves = poses[a.from]
                .compose(&a.measured)
                .compose(&poses[a.to].inverse());
            let by_a = a_moves.compose(&poses[b.to]);
            let by_b = poses[b.from].compose(&b.measured);
            !beyond(&by_a.between(&by_b), confirm_m, confirm_rad)
        };
        // A grown edge is confirmed only by one of another node: one node's two candidates
        // match the same walls, an alike place as readily as the true one.
        let held = &self.held;
        let confirmed: Vec<bool> = (0..held.len())
            .map(|i| {
                let (a, a_grown) = &held[i];
                held.iter().enumerate().any(|(j, (b, b_grown))| {
                    i != j
                        && a_grown == b_grown
                        && (!a_grown || a.to != b.to)
                        && agree(&self.poses, a, b)
                })
            })
            .collect();
        let mut i = 0;
        self.held.retain(|(e, _)| {
            let keep = !confirmed[i];
            if !keep {
                take.push(*e);
            }
            i += 1;
            keep
        });
        take
    }

    /// Adds the loop edges to the graph; returns the oldest node an edge that disagrees with
    /// the graph by more than `optimize_min_error_m` / `_deg` reaches back to.
    fn take_edges(
        &mut self,
        k: usize,
        take: Vec<Edge>,
        diagnostics: &mut LoopDiagnostics,
    ) -> Option<usize> {
        let p = &self.params;
        let (optimize_m, optimize_rad) = (
            p.optimize_min_error_m,
            p.optimize_min_error_deg.to_radians(),
        );
        let mut optimize_from: Option<usize> = None;
        for e in take {
            if beyond(&off(&self.poses, &e), optimize_m, optimize_rad) {
                optimize_from = Some(optimize_from.map_or(e.from, |o: usize| o.min(e.from)));
            }
            diagnostics.accepted += 1;
            self.last_closed = Some(k);
            self.edges.push(e);
        }
        optimize_from
    }

    /// Older nodes to match node `k` against: at least `min_node_gap` nodes back, within
    /// `search_radius_m`, nearest first, apart from each other.
    pub(super) fn candidates(&self, k: usize) -> Vec<Candidate> {
        let p = &self.params;
        if !p.enabled
            || k < p.min_node_gap
            || self.submaps[k].points.len() < MIN_NODE_POINTS
            || self
                .last_closed
                .is_some_and(|c| k <= c + p.skip_after_closure)
        {
            return Vec::new();
        }
        let mut candidates = self.near_candidates(k, k - p.min_node_gap, k - 1);
        // The graph's prediction drifts with the travel between the two nodes that no loop
        // edge holds: since the older node, or since the last node that closed a loop (the
        // graph up to it agrees with its loops), or since this run's first node (where it
        // placed itself on a saved map). The grid grows with it, at most as wide as the
        // candidates' radius.
        let anchor = self.last_closed.unwrap_or(0).max(self.first_run_node);
        for c in &mut candidates {
            let from = anchor.max(c.j);
            c.search_half_m = search_half_m(p, self.travel_m(from, k));
        }
        candidates
    }

    /// Path length over the graph's node poses from node `from` to node `to`, metres.
    fn travel_m(&self, from: usize, to: usize) -> f64 {
        let to = to.min(self.poses.len().saturating_sub(1));
        (from..to)
            .map(|i| {
                self.poses[i]
                    .translation()
                    .distance(self.poses[i + 1].translation())
            })
            .sum()
    }

    /// The nodes `0..=last` within `search_radius_m` of node `k`, nearest first, at most
    /// `max_candidates` of them more than `CANDIDATE_SPACING_NODES` apart, each with its own
    /// and its neighbours' (up to node `neighbours_to`) segments in its frame.
    pub(super) fn near_candidates(
        &self,
        k: usize,
        last: usize,
        neighbours_to: usize,
    ) -> Vec<Candidate> {
        let p = &self.params;
        let here = self.poses[k].translation();
        let mut near: Vec<(f64, usize)> = (0..=last)
            .filter_map(|j| {
                let d = self.poses[j].translation().distance(here);
                (d <= p.search_radius_m).then_some((d, j))
            })
            .collect();
        near.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut chosen: Vec<usize> = Vec::new();
        for (_, j) in near {
            if chosen.len() >= p.max_candidates {
                break;
            }
            if chosen
                .iter()
                .all(|c| c.abs_diff(j) > CANDIDATE_SPACING_NODES)
            {
                chosen.push(j);
            }
        }
        chosen
            .into_iter()
            .map(|j| {
                let mut target: Vec<Segment> = Vec::new();
                for i in j.saturating_sub(1)..=(j + 1).min(neighbours_to) {
                    let j_from_i = self.poses[j].between(&self.poses[i]);
                    target.extend(
                        self.submaps[i]
                            .segments
                            .iter()
                            .map(|s| s.transformed(&j_from_i)),
                    );
                }
                Candidate {
                    j,
                    predicted: self.poses[j].between(&self.poses[k]),
                    target,
                    search_half_m: p.search_translation_m,
                }
            })
            .collect()
    }
}

/// The half-width of the grid search between two nodes `travel_m` metres of travel apart:
/// `search_translation_m`, or `search_translation_per_travel` of the travel where that is
/// more, at most `search_radius_m` (a node farther off is no candidate) and at most as wide as
/// keeps the grid within [`MAX_SEARCH_STARTS`](super::params::MAX_SEARCH_STARTS), metres.
pub(super) fn search_half_m(p: &LoopParams, travel_m: f64) -> f64 {
    let grown = (p.search_translation_per_travel * travel_m).min(p.search_radius_m);
    p.search_translation_m.max(grown.min(p.widest_search_m()))
}

/// A loop edge found by a grid grown with the travel (`search_translation_per_travel`) waits
/// this many nodes for a second that agrees.
const FAR_CONFIRM_WITHIN_NODES: usize = 3;

/// A node with fewer points (after thinning) is not matched.
pub(super) const MIN_NODE_POINTS: usize = 20;

/// How far the graph's poses are from edge `e`'s measurement (`measured⁻¹ ∘ (from⁻¹ ∘ to)`).
fn off(poses: &[Pose2], e: &Edge) -> Pose2 {
    poses[e.from].between(&poses[e.to]).between(&e.measured)
}

/// True when `d` moves more than `m` metres or turns more than `rad` radians.
fn beyond(d: &Pose2, m: f64, rad: f64) -> bool {
    d.translation().length() > m || d.theta_rad.abs() > rad
}
