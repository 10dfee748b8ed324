//! Loop closure (an addition to the paper): a pose graph over short stretches of the
//! trajectory, matched against earlier stretches when the robot comes back.
//!
//! The mapper aligns each scan to the global map, so a robot that comes back with little drift
//! snaps onto what it mapped before. With more drift than ICP's basin it maps the place a second
//! time beside the first, and from then on tracks against the copy. Here:
//!
//! - Every `node_scans` scans start a **node**, posed at its first scan; a node keeps a small
//!   submap in its own frame (the points and segments of every `node_keep_every`-th of its
//!   scans, points thinned to `node_point_spacing_m`).
//! - Consecutive nodes are joined by a **sequential edge**: the mapper's relative pose.
//! - When a node is complete, older nodes (at least `min_node_gap` nodes back) whose pose lies
//!   within `search_radius_m` are **candidates**. The node's points are aligned by ICP to the
//!   candidate's submap (with its neighbours'), from the relative pose the graph predicts; when
//!   that fails or moves more than 0.3 m, a grid of starts within `search_translation_m` and
//!   `search_rotation_deg` is scored on a raster of the submap (given up when nothing scores)
//!   and ICP runs from the best start of the best peak and of up to two distinct rival peaks
//!   scoring at least 75 % of it. A match is kept only when enough points found a wall
//!   (`min_matched_share`), most of those fit it within ICP's robust scale
//!   (`min_inlier_share`), ICP left no direction unobservable (a corridor), and no result from
//!   another peak has `max_ambiguity` of its inliers: a **loop edge**.
//! - A loop edge that disagrees with the graph by more than `confirm_above_m` (or
//!   `confirm_above_deg`) is held until a second one, within `confirm_within_nodes` nodes,
//!   agrees with it on where the node belongs: a false match rarely repeats consistently. Off by
//!   default (`confirm_within_nodes = 0`): on the benchmark logs it cost more true closures
//!   than it caught false ones (none were seen).
//! - A loop edge in the graph that disagrees with it by more than `optimize_min_error_m` (or
//!   `optimize_min_error_deg`) triggers a least-squares solution of the graph from the loop's
//!   older end on ([`graph::optimize`]; loop edges carry Cauchy weights); node 0, the map
//!   frame, never moves. The mapper then moves every map segment and pose by the correction of
//!   the node it was born in.

pub(crate) mod field;
pub mod graph;

use std::collections::VecDeque;
use std::panic::AssertUnwindSafe;
use std::sync::mpsc::Sender;
use std::sync::{Arc, Mutex, OnceLock};

use serde::{Deserialize, Serialize};

use crate::align::{AlignParams, AlignResult, align_points, score_sample};
use crate::geometry::{Pose2, Segment, Vec2};
use crate::map::{GlobalMap, MapSegment};
use field::{PoseGrid, ScoreField, distinct_peaks};
pub use graph::Edge;

/// Parameters of loop closure.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LoopParams {
    /// Loop closure on or off (off: the paper's single pass).
    pub enabled: bool,
    /// Match and optimise on a second thread while the mapper goes on. The outcome for a node
    /// is taken in at the same scan either way (see `apply_after_nodes`), so results do not
    /// depend on it.
    pub background: bool,
    /// The graph's outcome for node `k` is taken in at the end of node `k +
    /// apply_after_nodes` (the mapper waits for it then if need be).
    pub apply_after_nodes: usize,
    /// Scans per node.
    pub node_scans: u32,
    /// Every this many scans of a node feed its submap.
    pub node_keep_every: u32,
    /// The submap's points are thinned to this spacing, metres.
    pub node_point_spacing_m: f64,
    /// Candidates are at least this many nodes older than the node matched.
    pub min_node_gap: usize,
    /// After a node gets a loop edge, the next `skip_after_closure` nodes are not matched
    /// (the robot is on mapped ground; an edge every few nodes holds the graph).
    pub skip_after_closure: usize,
    /// Candidates' poses lie within this distance of the node's, metres.
    pub search_radius_m: f64,
    /// At most this many candidates (the nearest) per node.
    pub max_candidates: usize,
    /// ICP's first correspondence gate when matching submaps, metres (at most ICP's own).
    pub match_gate_m: f64,
    /// Half-width of the grid of translations searched around the predicted pose, metres.
    pub search_translation_m: f64,
    /// Step of that grid, metres.
    pub search_step_m: f64,
    /// Half-width of the rotations searched, degrees.
    pub search_rotation_deg: f64,
    /// Step of the rotations searched, degrees.
    pub search_rotation_step_deg: f64,
    /// Least share of the node's points that must find a map segment within ICP's final gate.
    pub min_matched_share: f64,
    /// Least share of those that must lie within ICP's robust scale.
    pub min_inlier_share: f64,
    /// A different start (more than 0.5 m or 5° away) whose ICP reaches this share of the best
    /// result's inliers makes the match ambiguous.
    pub max_ambiguity: f64,
    /// Standard deviation of a sequential edge's translation, metres...
    pub sequential_sigma_m: f64,
    /// ...and rotation, degrees.
    pub sequential_sigma_deg: f64,
    /// Standard deviation of a loop edge's translation, metres...
    pub loop_sigma_m: f64,
    /// ...and rotation, degrees.
    pub loop_sigma_deg: f64,
    /// A loop edge this far (metres)...
    pub confirm_above_m: f64,
    /// ...or this far (degrees) from the graph's prediction is held until another loop edge
    /// within `confirm_within_nodes` nodes agrees with it to within the same distances.
    pub confirm_above_deg: f64,
    /// How long a held loop edge waits for one that agrees, nodes (0, the default: edges are
    /// never held).
    pub confirm_within_nodes: usize,
    /// A loop edge this far (metres)...
    pub optimize_min_error_m: f64,
    /// ...or this far (degrees) from the graph's prediction triggers optimisation.
    pub optimize_min_error_deg: f64,
    /// Gauss–Newton iterations per optimisation.
    pub max_iterations: usize,
}

impl Default for LoopParams {
    fn default() -> Self {
        LoopParams {
            enabled: true,
            background: true,
            apply_after_nodes: 5,
            node_scans: 20,
            node_keep_every: 5,
            node_point_spacing_m: 0.1,
            min_node_gap: 15,
            skip_after_closure: 2,
            search_radius_m: 6.0,
            max_candidates: 2,
            match_gate_m: 0.5,
            search_translation_m: 2.4,
            search_step_m: 0.3,
            search_rotation_deg: 10.0,
            search_rotation_step_deg: 2.0,
            min_matched_share: 0.5,
            min_inlier_share: 0.6,
            max_ambiguity: 0.9,
            sequential_sigma_m: 0.05,
            sequential_sigma_deg: 0.5,
            loop_sigma_m: 0.05,
            loop_sigma_deg: 0.5,
            confirm_above_m: 0.3,
            confirm_above_deg: 2.0,
            confirm_within_nodes: 0,
            optimize_min_error_m: 0.1,
            optimize_min_error_deg: 1.0,
            max_iterations: 10,
        }
    }
}

impl LoopParams {
    /// The first invalid key, if any.
    pub fn invalid_key(&self) -> Option<&'static str> {
        let positive = |v: f64| v.is_finite() && v > 0.0;
        let checks = [
            ("loops.node_scans", (1..=100_000).contains(&self.node_scans)),
            (
                "loops.node_keep_every",
                self.node_keep_every >= 1 && self.node_keep_every <= self.node_scans,
            ),
            (
                "loops.node_point_spacing_m",
                positive(self.node_point_spacing_m),
            ),
            ("loops.min_node_gap", self.min_node_gap >= 2),
            ("loops.apply_after_nodes", self.apply_after_nodes <= 1000),
            (
                "loops.skip_after_closure",
                self.skip_after_closure <= 1_000_000,
            ),
            (
                "loops.search_radius_m",
                self.search_radius_m.is_finite() && self.search_radius_m >= 0.0,
            ),
            ("loops.max_candidates", self.max_candidates <= 64),
            (
                "loops.search_translation_m",
                (0.0..=20.0).contains(&self.search_translation_m),
            ),
            ("loops.match_gate_m", positive(self.match_gate_m)),
            (
                "loops.search_step_m",
                self.search_step_m >= 0.01 && self.search_step_m.is_finite(),
            ),
            (
                "loops.search_rotation_deg",
                (0.0..=180.0).contains(&self.search_rotation_deg),
            ),
            (
                "loops.search_rotation_step_deg",
                (0.1..=90.0).contains(&self.search_rotation_step_deg),
            ),
            (
                "loops.min_matched_share",
                (0.0..=1.0).contains(&self.min_matched_share),
            ),
            (
                "loops.min_inlier_share",
                (0.0..=1.0).contains(&self.min_inlier_share),
            ),
            (
                "loops.max_ambiguity",
                (0.0..=1.0).contains(&self.max_ambiguity),
            ),
            (
                "loops.sequential_sigma_m",
                positive(self.sequential_sigma_m),
            ),
            (
                "loops.sequential_sigma_deg",
                positive(self.sequential_sigma_deg),
            ),
            ("loops.loop_sigma_m", positive(self.loop_sigma_m)),
            ("loops.loop_sigma_deg", positive(self.loop_sigma_deg)),
            (
                "loops.optimize_min_error_m",
                self.optimize_min_error_m >= 0.0,
            ),
            (
                "loops.optimize_min_error_deg",
                self.optimize_min_error_deg >= 0.0,
            ),
            ("loops.max_iterations", self.max_iterations <= 1000),
        ];
        if let Some(k) = checks.iter().find(|(_, ok)| !ok).map(|(k, _)| *k) {
            return Some(k);
        }
        // The grid search holds every start's score: bounded.
        let steps_t = (self.search_translation_m / self.search_step_m).floor() + 0.5;
        let steps_r = (self.search_rotation_deg / self.search_rotation_step_deg).floor() + 0.5;
        let starts = (2.0 * steps_t).powi(2) * 2.0 * steps_r;
        (starts > MAX_SEARCH_STARTS).then_some("loops.search_step_m")
    }
}

/// What loop closure did after one scan.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct LoopDiagnostics {
    /// Older nodes matched against the node just completed.
    pub candidates: usize,
    /// Candidates the predicted pose did not explain, matched by a grid search.
    pub searches: usize,
    /// Loop edges added to the graph.
    pub accepted: usize,
    /// Loop edges held, waiting for a second that agrees (see `confirm_above_m`).
    pub held: usize,
    /// Nodes moved by the corrections taken in (optimised, and the newer ones that ride along;
    /// 0: none).
    pub optimized_nodes: usize,
    /// The largest translation of a node by the optimisation, metres.
    pub largest_correction_m: f64,
    /// Wall-clock seconds spent matching submaps...
    pub match_s: f64,
    /// ...and optimising the graph and computing corrections.
    pub optimize_s: f64,
}

/// A node's submap, in the node's frame.
#[derive(Debug, Clone, Default)]
struct Submap {
    points: Vec<Vec2>,
    segments: Vec<Segment>,
}

/// The node being filled by the mapper.
#[derive(Debug, Clone, Default)]
struct OpenNode {
    /// Its pose relative to the node before (the mapper's motion between their first scans).
    from_previous: Option<Pose2>,
    submap: Submap,
    /// Cells of the kept points, for thinning.
    cells: rustc_hash::FxHashSet<(i64, i64)>,
}

/// Corrections after an optimisation: node `first_node + i` moved by `new_from_old[i]` (new
/// pose ∘ old pose⁻¹, map frame).
#[derive(Debug, Clone, PartialEq)]
pub struct Correction {
    /// The first node that moved.
    pub first_node: usize,
    /// Per node from `first_node` on, the transform from its old to its new place.
    pub new_from_old: Vec<Pose2>,
}

/// Loop closure for the mapper: node bookkeeping on the mapper's side, the pose graph on a
/// second thread (with `background`).
///
/// The mapper hands every completed node to the graph, which matches it against older nodes
/// and optimises. The outcome for node `k` is taken in at the end of node `k +
/// apply_after_nodes` (waiting for it if need be), so results never depend on timing.
#[derive(Debug)]
pub struct LoopCloser {
    params: LoopParams,
    /// The mapper's view of the node poses (map frame), with every correction taken in.
    poses: Vec<Pose2>,
    open: OpenNode,
    graph: Arc<Mutex<Graph>>,
    worker: Option<Sender<(NodeDone, Arc<OnceLock<JobResult>>)>>,
    pending: VecDeque<Pending>,
    loop_edges: usize,
}

impl Clone for LoopCloser {
    /// Waits for the graph to finish the nodes handed to it, then copies it.
    fn clone(&self) -> Self {
        for p in &self.pending {
            p.result.wait();
        }
        let graph = lock(&self.graph).clone();
        LoopCloser {
            params: self.params.clone(),
            poses: self.poses.clone(),
            open: self.open.clone(),
            graph: Arc::new(Mutex::new(graph)),
            worker: None,
            pending: self.pending.clone(),
            loop_edges: self.loop_edges,
        }
    }
}

/// The graph, also after a panic while it was locked (the panicking job's node then simply
/// has no loop edges).
fn lock(graph: &Mutex<Graph>) -> std::sync::MutexGuard<'_, Graph> {
    graph.lock().unwrap_or_else(|e| e.into_inner())
}

impl LoopCloser {
    /// An empty graph; `align` is the ICP used to match submaps (with its first gate at most
    /// `match_gate_m`: the grid search covers larger offsets), `grid_cell_m` the cell size of
    /// their spatial index (speed only).
    pub fn new(params: LoopParams, align: AlignParams, grid_cell_m: f64) -> Self {
        let initial_gate_m = align
            .initial_gate_m
            .min(params.match_gate_m)
            .max(align.final_gate_m);
        let graph = Graph {
            align: AlignParams {
                initial_gate_m,
                ..align
            },
            params: params.clone(),
            grid_cell_m,
            submaps: Vec::new(),
            poses: Vec::new(),
            edges: Vec::new(),
            last_closed: None,
            held: Vec::new(),
        };
        LoopCloser {
            params,
            poses: Vec::new(),
            open: OpenNode::default(),
            graph: Arc::new(Mutex::new(graph)),
            worker: None,
            pending: VecDeque::new(),
            loop_edges: 0,
        }
    }

    /// The node that scan `t` belongs to.
    pub fn node_of(&self, t: u32) -> usize {
        (t / self.params.node_scans) as usize
    }

    /// Loop edges taken in so far.
    pub fn loop_edges(&self) -> usize {
        self.loop_edges
    }

    /// Records scan `t` (scans come in order, from 0, without gaps) at `map_from_robot` with
    /// its points and segments (robot frame). When the scan completes a node, the node goes
    /// to the graph, and the graph's outcome for an earlier node is taken in: returns the
    /// correction when nodes moved. Call [`LoopCloser::finish`] after the last scan.
    pub fn add_scan(
        &mut self,
        t: u32,
        map_from_robot: Pose2,
        points_in_robot: &[Vec2],
        segments_in_robot: &[Segment],
        diagnostics: &mut LoopDiagnostics,
    ) -> Option<Correction> {
        let ns = self.params.node_scans;
        let k = self.node_of(t);
        if self.poses.len() <= k {
            self.open = OpenNode {
                from_previous: self.poses.last().map(|last| last.between(&map_from_robot)),
                ..OpenNode::default()
            };
            self.poses.push(map_from_robot);
        }
        if (t % ns) % self.params.node_keep_every == 0 {
            let node_from_robot = self.poses[k].between(&map_from_robot);
            let spacing = self.params.node_point_spacing_m;
            let open = &mut self.open;
            for p in points_in_robot {
                let q = node_from_robot.transform_point(*p);
                let cell = (
                    (q.x / spacing).floor() as i64,
                    (q.y / spacing).floor() as i64,
                );
                if open.cells.insert(cell) {
                    open.submap.points.push(q);
                }
            }
            open.submap.segments.extend(
                segments_in_robot
                    .iter()
                    .map(|s| s.transformed(&node_from_robot)),
            );
        }
        if (t + 1) % ns != 0 {
            return None;
        }
        let open = std::mem::take(&mut self.open);
        self.hand_over(NodeDone {
            node: k,
            pose: self.poses[k],
            from_previous: open.from_previous,
            submap: open.submap,
        });
        let due = k.checked_sub(self.params.apply_after_nodes)?;
        let mut correction = None;
        while self.pending.front().is_some_and(|p| p.node <= due) {
            correction = merge_corrections(correction, self.take_in(diagnostics));
        }
        correction
    }

    /// Takes in every outcome still pending (at the end of the run); see
    /// [`LoopCloser::add_scan`].
    pub fn finish(&mut self, diagnostics: &mut LoopDiagnostics) -> Option<Correction> {
        let mut correction = None;
        while !self.pending.is_empty() {
            correction = merge_corrections(correction, self.take_in(diagnostics));
        }
        correction
    }

    /// Gives a completed node to the graph: to the worker thread with `background` (started
    /// on first use), here otherwise or when no thread can be started.
    fn hand_over(&mut self, done: NodeDone) {
        let result = Arc::new(OnceLock::new());
        self.pending.push_back(Pending {
            node: done.node,
            result: Arc::clone(&result),
        });
        if self.params.background && self.worker.is_none() {
            let (tx, rx) = std::sync::mpsc::channel::<(NodeDone, Arc<OnceLock<JobResult>>)>();
            let graph = Arc::clone(&self.graph);
            let started = std::thread::Builder::new()
                .name("polymap-loops".into())
                .spawn(move || {
                    for (done, slot) in rx {
                        run_node(&graph, done, &slot);
                    }
                });
            if started.is_ok() {
                self.worker = Some(tx);
            }
        }
        let done = match &self.worker {
            Some(tx) => match tx.send((done, Arc::clone(&result))) {
                Ok(()) => return,
                // The worker is gone (it cannot be, short of a crash): work here.
                Err(e) => {
                    self.worker = None;
                    e.0.0
                }
            },
            None => done,
        };
        run_node(&self.graph, done, &result);
    }

    /// Waits for the oldest pending outcome and applies it to the node poses; returns the
    /// correction when nodes moved.
    fn take_in(&mut self, diagnostics: &mut LoopDiagnostics) -> Option<Correction> {
        let pending = self.pending.pop_front()?;
        let result = pending.result.wait();
        let d = &result.diagnostics;
        diagnostics.candidates += d.candidates;
        diagnostics.searches += d.searches;
        diagnostics.accepted += d.accepted;
        diagnostics.held = d.held;
        diagnostics.match_s += d.match_s;
        diagnostics.optimize_s += d.optimize_s;
        self.loop_edges += d.accepted;
        let (first, optimized) = result.optimized.as_ref()?;
        let mut new_from_old: Vec<Pose2> = optimized
            .iter()
            .zip(self.poses.get(*first..=pending.node)?)
            .map(|(new, old)| new.compose(&old.inverse()))
            .collect();
        let newest = *new_from_old.last()?;
        // Nodes begun since the graph took the node in ride along with it.
        new_from_old.resize(self.poses.len() - first, newest);
        diagnostics.optimized_nodes = diagnostics.optimized_nodes.max(new_from_old.len());
        for (pose, d) in self.poses[*first..].iter_mut().zip(&new_from_old) {
            let moved = d.compose(pose);
            diagnostics.largest_correction_m = diagnostics
                .largest_correction_m
                .max(moved.translation().distance(pose.translation()));
            *pose = moved;
        }
        Some(Correction {
            first_node: *first,
            new_from_old,
        })
    }
}

/// Two corrections in a row as one (the second applied after the first).
fn merge_corrections(a: Option<Correction>, b: Option<Correction>) -> Option<Correction> {
    match (a, b) {
        (None, b) => b,
        (a, None) => a,
        (Some(a), Some(b)) => {
            let first = a.first_node.min(b.first_node);
            let len = (a.first_node + a.new_from_old.len())
                .max(b.first_node + b.new_from_old.len())
                - first;
            let at = |c: &Correction, i: usize| {
                i.checked_sub(c.first_node)
                    .and_then(|j| c.new_from_old.get(j).copied())
                    .unwrap_or(Pose2::IDENTITY)
            };
            let new_from_old = (first..first + len)
                .map(|i| at(&b, i).compose(&at(&a, i)))
                .collect();
            Some(Correction {
                first_node: first,
                new_from_old,
            })
        }
    }
}

/// Runs the graph's work for one node and publishes the outcome (empty after a panic).
fn run_node(graph: &Mutex<Graph>, done: NodeDone, slot: &OnceLock<JobResult>) {
    let outcome = std::panic::catch_unwind(AssertUnwindSafe(|| lock(graph).add(done)));
    let _ = slot.set(outcome.unwrap_or_default());
}

/// An outcome on its way from the graph.
#[derive(Debug, Clone)]
struct Pending {
    node: usize,
    result: Arc<OnceLock<JobResult>>,
}

/// A completed node, handed from the mapper to the graph.
#[derive(Debug)]
struct NodeDone {
    node: usize,
    /// The mapper's pose of the node (used for the first node only).
    pose: Pose2,
    /// The mapper's motion from the node before.
    from_previous: Option<Pose2>,
    submap: Submap,
}

/// An older node to match against, with its submap (and its neighbours') in its frame.
#[derive(Debug, Clone)]
struct Candidate {
    j: usize,
    predicted: Pose2,
    target: Vec<Segment>,
}

/// What the graph did with one node: loop edges found, and the optimised poses of nodes
/// `first..=node` if it optimised.
#[derive(Debug, Clone, Default)]
struct JobResult {
    optimized: Option<(usize, Vec<Pose2>)>,
    diagnostics: LoopDiagnostics,
}

/// The pose graph with the node submaps.
#[derive(Debug, Clone)]
struct Graph {
    params: LoopParams,
    align: AlignParams,
    grid_cell_m: f64,
    submaps: Vec<Submap>,
    poses: Vec<Pose2>,
    edges: Vec<Edge>,
    /// The last node that got a loop edge.
    last_closed: Option<usize>,
    /// Loop edges that would bend the graph a lot, waiting for a second that agrees.
    held: Vec<Edge>,
}

impl Graph {
    /// Adds a completed node (after its sequential edge), matches it against older nodes near
    /// it, and optimises when a new loop edge disagrees with the graph.
    fn add(&mut self, done: NodeDone) -> JobResult {
        let k = self.poses.len();
        let pose = match (self.poses.last(), done.from_previous) {
            (Some(last), Some(z)) => {
                self.edges.push(Edge {
                    from: k - 1,
                    to: k,
                    measured: z,
                    sigma_m: self.params.sequential_sigma_m,
                    sigma_rad: self.params.sequential_sigma_deg.to_radians(),
                    robust: false,
                });
                last.compose(&z)
            }
            _ => done.pose,
        };
        debug_assert_eq!(k, done.node);
        self.poses.push(pose);
        self.submaps.push(done.submap);
        let mut out = JobResult::default();
        let candidates = self.candidates(k);
        let mut optimize_from: Option<usize> = None;
        let clock = std::time::Instant::now();
        let p = &self.params;
        let (confirm_m, confirm_rad) = (p.confirm_above_m, p.confirm_above_deg.to_radians());
        let (optimize_m, optimize_rad) = (
            p.optimize_min_error_m,
            p.optimize_min_error_deg.to_radians(),
        );
        let mut found: Vec<Edge> = Vec::new();
        for c in &candidates {
            out.diagnostics.candidates += 1;
            let Some(measured) = self.match_nodes(k, c, &mut out.diagnostics) else {
                continue;
            };
            found.push(Edge {
                from: c.j,
                to: k,
                measured,
                sigma_m: self.params.loop_sigma_m,
                sigma_rad: self.params.loop_sigma_deg.to_radians(),
                robust: true,
            });
        }
        // An edge that would bend the graph a lot waits for a second one that agrees with it
        // (a false match rarely repeats consistently); the others go in at once.
        let off =
            |poses: &[Pose2], e: &Edge| poses[e.from].between(&poses[e.to]).between(&e.measured);
        let beyond =
            |d: &Pose2, m: f64, rad: f64| d.translation().length() > m || d.theta_rad.abs() > rad;
        self.held
            .retain(|e| e.to + self.params.confirm_within_nodes >= k);
        let mut take: Vec<Edge> = Vec::new();
        for e in found {
            if self.params.confirm_within_nodes == 0
                || !beyond(&off(&self.poses, &e), confirm_m, confirm_rad)
            {
                take.push(e);
            } else {
                self.held.push(e);
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
        let confirmed: Vec<bool> = (0..self.held.len())
            .map(|i| {
                (0..self.held.len())
                    .any(|j| i != j && agree(&self.poses, &self.held[i], &self.held[j]))
            })
            .collect();
        let mut i = 0;
        self.held.retain(|e| {
            let keep = !confirmed[i];
            if !keep {
                take.push(*e);
            }
            i += 1;
            keep
        });
        out.diagnostics.held = self.held.len();
        for e in take {
            if beyond(&off(&self.poses, &e), optimize_m, optimize_rad) {
                optimize_from = Some(optimize_from.map_or(e.from, |o: usize| o.min(e.from)));
            }
            out.diagnostics.accepted += 1;
            self.last_closed = Some(k);
            self.edges.push(e);
        }
        out.diagnostics.match_s = clock.elapsed().as_secs_f64();
        // Node 0 holds the map frame (the first scan's pose): it never moves.
        let Some(first) = optimize_from.map(|f| f.max(1)) else {
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

    /// Older nodes to match node `k` against: at least `min_node_gap` nodes back, within
    /// `search_radius_m`, nearest first, apart from each other.
    fn candidates(&self, k: usize) -> Vec<Candidate> {
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
        let here = self.poses[k].translation();
        let mut near: Vec<(f64, usize)> = (0..=k - p.min_node_gap)
            .filter_map(|j| {
                let d = self.poses[j].translation().distance(here);
                (d <= p.search_radius_m).then_some((d, j))
            })
            .collect();
        near.sort_by(|a, b| a.0.total_cmp(&b.0));
        // Two neighbours of one place would test the same thing.
        let mut chosen: Vec<usize> = Vec::new();
        for (_, j) in near {
            if chosen.len() >= p.max_candidates {
                break;
            }
            if chosen.iter().all(|c| c.abs_diff(j) > 2) {
                chosen.push(j);
            }
        }
        chosen
            .into_iter()
            .map(|j| {
                let mut target: Vec<Segment> = Vec::new();
                for i in j.saturating_sub(1)..=(j + 1).min(k - 1) {
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
                }
            })
            .collect()
    }

    /// The pose of the node in candidate `c`'s frame from their submaps, or `None` when the
    /// match is weak or ambiguous.
    fn match_nodes(
        &self,
        k: usize,
        c: &Candidate,
        diagnostics: &mut LoopDiagnostics,
    ) -> Option<Pose2> {
        let p = &self.params;
        if c.target.is_empty() {
            return None;
        }
        let predicted = c.predicted;
        let reach_m = self.align.initial_gate_m.max(self.align.final_gate_m);
        let mut index = GlobalMap::new(self.grid_cell_m, reach_m);
        for s in &c.target {
            index.insert(MapSegment {
                segment: *s,
                born_scan: 0,
            });
        }
        let points = &self.submaps[k].points;
        let good = |r: &AlignResult| {
            r.weak_directions == 0
                && r.correspondences as f64 >= p.min_matched_share * points.len() as f64
                && r.inliers as f64 >= p.min_inlier_share * r.correspondences as f64
        };
        let direct = align_points(points, &index, predicted, predicted, &self.align);
        // The prediction is right (the common case on a return with little drift): one ICP.
        if good(&direct)
            && predicted
                .between(&direct.map_from_robot)
                .translation()
                .length()
                < 0.3
        {
            return Some(direct.map_from_robot);
        }
        // Otherwise: the best starts of a grid around the prediction, each refined by ICP.
        diagnostics.searches += 1;
        let sample = score_sample(points, &self.align);
        let steps_r = (p.search_rotation_deg / p.search_rotation_step_deg).floor() as i32;
        let field = ScoreField::new(&c.target, self.align.rotation_search_sigma_m, SCORE_CELL_M);
        let scored = field.scored_grid(
            &sample,
            &PoseGrid {
                center: predicted,
                steps_xy: (p.search_translation_m / p.search_step_m).floor() as i32,
                step_m: p.search_step_m,
                rotations: -steps_r..steps_r + 1,
                step_rad: p.search_rotation_step_deg.to_radians(),
            },
        );
        let top = scored.first().map_or(0.0, |s| s.0);
        // Too few points near the submap anywhere in the search for half of them to match.
        if top < MIN_TOP_SCORE_SHARE * p.min_matched_share * sample.len() as f64 {
            return None;
        }
        // ICP from the best starts of distinct peaks (each more than a search step and the
        // score's reach, or two rotation steps, from those before and from the prediction)
        // that score at least `RIVAL_SCORE_SHARE` of the best (a peak far below it cannot
        // come near its inliers): a rival place is tried too, not only the best place's
        // neighbourhood.
        let starts = distinct_peaks(
            &scored,
            &[predicted],
            p.search_step_m + self.align.rotation_search_sigma_m,
            (2.0 * p.search_rotation_step_deg).to_radians(),
            SEARCH_PEAKS,
            RIVAL_SCORE_SHARE * top,
        );
        let mut results: Vec<AlignResult> = vec![direct];
        results.extend(
            starts
                .iter()
                .map(|start| align_points(points, &index, *start, *start, &self.align)),
        );
        let best = *results.iter().max_by(|a, b| {
            (a.inliers, -a.residual_rms_m)
                .partial_cmp(&(b.inliers, -b.residual_rms_m))
                .unwrap_or(std::cmp::Ordering::Equal)
        })?;
        if !good(&best) {
            return None;
        }
        let rival = results
            .iter()
            .filter(|r| !close(&r.map_from_robot, &best.map_from_robot, 0.5, 5.0))
            .map(|r| r.inliers)
            .max()
            .unwrap_or(0);
        (rival as f64 <= p.max_ambiguity * best.inliers as f64).then_some(best.map_from_robot)
    }
}

/// Most starts of the grid search (its translation and rotation ranges over their steps).
const MAX_SEARCH_STARTS: f64 = 200_000.0;

/// ICP runs from the best starts of at most this many distinct peaks of the grid search (the
/// best and its rivals).
const SEARCH_PEAKS: usize = 3;

/// The grid search gives up when its best soft score is below this share of
/// `min_matched_share` of the sample (a point within ICP's final gate scores at least 0.3).
const MIN_TOP_SCORE_SHARE: f64 = 0.3;

/// Peaks of the grid search scoring below this share of the best are not tried.
const RIVAL_SCORE_SHARE: f64 = 0.75;

/// A node with fewer points (after thinning) is not matched.
const MIN_NODE_POINTS: usize = 20;

/// Cell size of the score field of the grid search, metres.
const SCORE_CELL_M: f64 = 0.1;

/// True when two poses are within `m` metres and `deg` degrees.
fn close(a: &Pose2, b: &Pose2, m: f64, deg: f64) -> bool {
    let d = a.between(b);
    d.translation().length() <= m && d.theta_rad.abs() <= deg.to_radians()
}

#[cfg(test)]
mod tests;
