//! Loop closure on the mapper's side: scans grouped into nodes with their submaps, each
//! completed node handed to the graph, and the graph's outcome taken in at a fixed later scan
//! as a correction of the node poses.

use glam::DMat2;

use crate::align::AlignParams;
use crate::geometry::{Pose2, Segment, Vec2};

use super::nodes::{NodeDone, NodeGraph, Submap};
use super::worker::Worker;
use super::{Correction, LoopDiagnostics, LoopFailure, LoopParams};

/// The node being filled by the mapper.
#[derive(Debug, Clone, Default)]
struct OpenNode {
    /// Its pose relative to the node before (the mapper's motion between their first scans).
    from_previous: Option<Pose2>,
    /// The doubt on that motion beyond a confident match's ([`MotionDoubt`]), m², in this
    /// node's frame.
    doubt_m2: DMat2,
    submap: Submap,
    /// Cells of the kept points, for thinning.
    cells: rustc_hash::FxHashSet<(i64, i64)>,
    /// Scans in the node so far.
    scans: u32,
    /// Path length since the node's first scan, metres.
    travel_m: f64,
    /// Scans and path length (metres) since the last scan that fed the submap.
    since_kept: (u32, f64),
    /// The last scan's pose, map frame.
    last: Pose2,
}

/// A node of a saved map's loop closure: what a run that continues the map needs of it to
/// close loops into it (its submap's segments; its points are only matched when it is new).
#[derive(Debug, Clone, PartialEq)]
pub struct SavedNode {
    /// The node's pose (its first scan's), map frame, after every correction.
    pub pose: Pose2,
    /// Its submap's segments, in the node's frame, metres.
    pub segments: Vec<Segment>,
}

/// Loop closure for the mapper: node bookkeeping on the mapper's side, the pose graph on a
/// second thread (with `background`).
///
/// The mapper hands every completed node to the graph, which matches it against older nodes
/// and optimises. The outcome for node `k` is taken in at the end of node `k +
/// apply_after_nodes` (waiting for it if need be), so results never depend on timing.
#[derive(Debug, Clone)]
pub struct LoopCloser {
    params: LoopParams,
    /// The mapper's view of the node poses (map frame), with every correction taken in.
    poses: Vec<Pose2>,
    /// The node being filled; `None` before the first scan and after a node ends.
    open: Option<OpenNode>,
    pub(super) worker: Worker,
    loop_edges: usize,
    /// The first failure of the graph's work; loop closure stops there.
    failure: Option<LoopFailure>,
    /// Nodes of a saved map before this run's first node (0 for a new map).
    first_new: usize,
    /// The first scan (`t`) of each of this run's nodes.
    node_starts: Vec<u32>,
    /// The last scan's pose, map frame.
    last_scan: Option<Pose2>,
    /// The doubt ([`MotionDoubt`]) on the motion since the open node's first scan, m², map
    /// frame.
    doubt_m2: DMat2,
}

/// How far the mapper's motion into a scan may be off beyond a confident match's error, for
/// the pose graph's sequential edges (`LoopParams::doubtful_step_sigma`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum MotionDoubt {
    /// Tracked `ok`: no more than any match.
    #[default]
    None,
    /// The translation along this map-frame unit vector was not observed (a corridor's axis):
    /// the motion along it came from the motion prior.
    Along(Vec2),
}

impl MotionDoubt {
    /// The covariance this doubt adds to a step of `step_m` metres, m², map frame: a standard
    /// deviation of `params.doubtful_step_sigma` × the step (at least
    /// `params.sequential_sigma_m`) along the unobserved direction.
    fn covariance_m2(&self, step_m: f64, params: &LoopParams) -> DMat2 {
        if params.doubtful_step_sigma <= 0.0 {
            return DMat2::ZERO;
        }
        let sigma = (params.doubtful_step_sigma * step_m).max(params.sequential_sigma_m);
        let variance = sigma * sigma;
        match self {
            MotionDoubt::None => DMat2::ZERO,
            MotionDoubt::Along(u) => DMat2::from_cols(*u * u.x, *u * u.y) * variance,
        }
    }
}

/// The ICP of submap matching: `align` with its first gate at most `params.match_gate_m` (the
/// grid search covers larger offsets).
pub(super) fn matching_align(align: AlignParams, params: &LoopParams) -> AlignParams {
    let initial_gate_m = align
        .initial_gate_m
        .min(params.match_gate_m)
        .max(align.final_gate_m);
    AlignParams {
        initial_gate_m,
        ..align
    }
}

/// A map-frame covariance `map_m2` in the frame of a pose heading `heading_rad`: `Rᵀ C R`.
fn in_frame(map_m2: &DMat2, heading_rad: f64) -> DMat2 {
    let (s, c) = heading_rad.sin_cos();
    // Rᵀ, column by column.
    let frame_from_map = DMat2::from_cols(glam::DVec2::new(c, -s), glam::DVec2::new(s, c));
    frame_from_map * *map_m2 * frame_from_map.transpose()
}

impl LoopCloser {
    /// An empty graph; `align` is the ICP used to match submaps (with its first gate at most
    /// `match_gate_m`: the grid search covers larger offsets), `grid_cell_m` the cell size of
    /// their spatial index (speed only).
    pub fn new(params: LoopParams, align: AlignParams, grid_cell_m: f64) -> Self {
        let graph = NodeGraph::new(params.clone(), matching_align(align, &params), grid_cell_m);
        LoopCloser {
            worker: Worker::new(graph, params.background),
            params,
            poses: Vec::new(),
            open: None,
            loop_edges: 0,
            failure: None,
            first_new: 0,
            node_starts: Vec::new(),
            last_scan: None,
            doubt_m2: DMat2::ZERO,
        }
    }

    /// Loop closure that goes on from a saved map's nodes: this run's nodes are matched
    /// against them too, and they never move; this run's first node is tied to the last of
    /// them by where it placed itself ([`LoopParams::placed_sigma_m`]), and loops with them
    /// may move it.
    pub fn continuing(
        params: LoopParams,
        align: AlignParams,
        grid_cell_m: f64,
        saved: Vec<SavedNode>,
    ) -> Self {
        let mut closer = Self::new(params, align, grid_cell_m);
        if saved.is_empty() {
            return closer;
        }
        closer.first_new = saved.len();
        closer.poses = saved.iter().map(|n| n.pose).collect();
        let mut graph = closer.worker.read(|g| g.clone());
        graph.fixed = saved.len();
        graph.first_run_node = saved.len();
        for node in saved {
            graph.poses.push(node.pose);
            graph.submaps.push(Submap {
                points: Vec::new(),
                segments: node.segments,
            });
        }
        closer.worker = Worker::new(graph, closer.params.background);
        closer
    }

    /// The nodes to save for a run that continues the map: every completed node (a saved
    /// map's too), at its corrected pose. Call after [`LoopCloser::finish`].
    pub fn saved_nodes(&self) -> Vec<SavedNode> {
        self.worker.read(|g| {
            self.poses
                .iter()
                .zip(&g.submaps)
                .map(|(pose, submap)| SavedNode {
                    pose: *pose,
                    segments: submap.segments.clone(),
                })
                .collect()
        })
    }

    /// The first node of this run (the nodes before it are a saved map's).
    pub fn first_new_node(&self) -> usize {
        self.first_new
    }

    /// The node that scan `t` of this run belongs to (`t` counted from the scan where loop
    /// closure starts; a scan not yet handed over belongs to the last node started).
    pub fn node_of(&self, t: u32) -> usize {
        let started = self.node_starts.partition_point(|&s| s <= t);
        self.first_new + started.saturating_sub(1)
    }

    /// The first scan (`t`, counted like [`LoopCloser::node_of`]'s) of node `node` of this
    /// run; 0 for a saved map's node, `u32::MAX` for a node not yet started.
    pub fn node_start(&self, node: usize) -> u32 {
        match node.checked_sub(self.first_new) {
            None => 0,
            Some(i) => self.node_starts.get(i).copied().unwrap_or(u32::MAX),
        }
    }

    /// The failure that stopped loop closure, if one did (a panic while matching or
    /// optimising: a bug). Mapping goes on without loop closure from the scan it was taken in.
    pub fn failure(&self) -> Option<&LoopFailure> {
        self.failure.as_ref()
    }

    /// Queues a failure as if the graph had published it for `node`.
    #[cfg(test)]
    pub(super) fn inject_failure(&mut self, node: usize, message: &str) {
        let failure = LoopFailure {
            node,
            message: message.to_string(),
        };
        self.worker.push_outcome(node, Err(failure));
    }

    /// Loop edges taken in so far.
    pub fn loop_edges(&self) -> usize {
        self.loop_edges
    }

    /// Records scan `t` (scans come in order, from 0, without gaps) at `map_from_robot` with
    /// its points and segments (robot frame), and the doubt on the motion into it. When the
    /// scan completes a node, the node goes to the graph, and the graph's outcome for an
    /// earlier node is taken in: returns the correction when nodes moved. Call
    /// [`LoopCloser::finish`] after the last scan.
    pub fn add_scan(
        &mut self,
        t: u32,
        map_from_robot: Pose2,
        (points_in_robot, segments_in_robot): (&[Vec2], &[Segment]),
        doubt: MotionDoubt,
        diagnostics: &mut LoopDiagnostics,
    ) -> Option<Correction> {
        if self.failure.is_some() {
            return None;
        }
        if let Some(last) = self.last_scan.replace(map_from_robot) {
            let step_m = (map_from_robot.translation() - last.translation()).length();
            self.doubt_m2 += doubt.covariance_m2(step_m, &self.params);
        }
        if self.open.is_none() {
            self.node_starts.push(t);
            // A saved map's last node is no neighbour of this run's first: no motion joins them.
            let first = self.node_starts.len() == 1;
            let previous = self.poses.last().filter(|_| !first);
            // The doubt since the node before, turned into this node's frame (the frame of
            // the sequential edge's residual).
            let since = std::mem::replace(&mut self.doubt_m2, DMat2::ZERO);
            let doubt_m2 = in_frame(&since, map_from_robot.theta_rad);
            self.open = Some(OpenNode {
                from_previous: previous.map(|last| last.between(&map_from_robot)),
                doubt_m2,
                last: map_from_robot,
                ..OpenNode::default()
            });
            self.poses.push(map_from_robot);
        }
        let k = self.poses.len() - 1;
        let p = &self.params;
        let open = self.open.as_mut()?;
        let step_m = (map_from_robot.translation() - open.last.translation()).length();
        open.last = map_from_robot;
        open.travel_m += step_m;
        open.since_kept.1 += step_m;
        let keep = open.scans == 0
            || open.since_kept.0 + 1 >= p.node_keep_every
            || (p.node_keep_travel_m > 0.0 && open.since_kept.1 >= p.node_keep_travel_m);
        open.scans += 1;
        open.since_kept.0 += 1;
        if keep {
            open.since_kept = (0, 0.0);
            let node_from_robot = self.poses[k].between(&map_from_robot);
            let spacing = p.node_point_spacing_m;
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
        let ends = open.scans >= p.node_scans
            || (p.node_travel_m > 0.0 && open.travel_m >= p.node_travel_m);
        if !ends {
            return None;
        }
        let open = self.open.take()?;
        self.worker.hand_over(NodeDone {
            node: k,
            pose: self.poses[k],
            from_previous: open.from_previous,
            doubt_m2: open.doubt_m2,
            submap: open.submap,
        });
        let due = k.checked_sub(self.params.apply_after_nodes)?;
        let mut correction = None;
        while self.worker.pending.front().is_some_and(|p| p.node <= due) {
            correction = merge_corrections(correction, self.take_in(diagnostics));
        }
        correction
    }

    /// Takes in every outcome still pending (at the end of the run); see
    /// [`LoopCloser::add_scan`].
    pub fn finish(&mut self, diagnostics: &mut LoopDiagnostics) -> Option<Correction> {
        let mut correction = None;
        while !self.worker.pending.is_empty() {
            correction = merge_corrections(correction, self.take_in(diagnostics));
        }
        correction
    }

    /// Waits for the oldest pending outcome and applies it to the node poses; returns the
    /// correction when nodes moved.
    fn take_in(&mut self, diagnostics: &mut LoopDiagnostics) -> Option<Correction> {
        let pending = self.worker.pending.pop_front()?;
        let result = match pending.result.wait() {
            Ok(result) => result,
            Err(failure) => {
                self.failure.get_or_insert_with(|| failure.clone());
                self.worker.pending.clear();
                return None;
            }
        };
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
        // The last scan belongs to the newest node: it moves with it, and so does the doubt
        // gathered since that node began (a map-frame covariance, turned by the correction).
        self.last_scan = self.last_scan.map(|p| newest.compose(&p));
        self.doubt_m2 = in_frame(&self.doubt_m2, -newest.theta_rad);
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
pub(super) fn merge_corrections(
    a: Option<Correction>,
    b: Option<Correction>,
) -> Option<Correction> {
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

#[cfg(test)]
mod doubt_tests {
    use super::*;

    /// A step doubted along the map's y axis, seen from a node heading 90° (its x axis is the
    /// map's y), is doubted along the node's x; heading 30°, a doubt along the heading lies
    /// along the node's x too.
    #[test]
    fn a_doubt_turns_into_the_nodes_frame() {
        let params = LoopParams::default();
        let along_y = MotionDoubt::Along(Vec2::new(0.0, 1.0)).covariance_m2(1.0, &params);
        assert_eq!(along_y, DMat2::from_cols(Vec2::ZERO, Vec2::new(0.0, 1.0)));
        let turned = in_frame(&along_y, 90f64.to_radians());
        assert!((turned.x_axis.x - 1.0).abs() < 1e-12, "{turned:?}");
        assert!(turned.y_axis.y.abs() < 1e-12 && turned.x_axis.y.abs() < 1e-12);
        let heading = 30f64.to_radians();
        let u = Vec2::new(heading.cos(), heading.sin());
        let along_heading = MotionDoubt::Along(u).covariance_m2(0.5, &params);
        let turned = in_frame(&along_heading, heading);
        assert!((turned.x_axis.x - 0.25).abs() < 1e-12, "{turned:?}");
        assert!(turned.y_axis.y.abs() < 1e-12 && turned.x_axis.y.abs() < 1e-12);
        // A scan tracked `ok` adds nothing; a short doubted step at least `sequential_sigma_m`.
        assert_eq!(MotionDoubt::None.covariance_m2(1.0, &params), DMat2::ZERO);
        let short = MotionDoubt::Along(Vec2::X).covariance_m2(0.001, &params);
        assert!((short.x_axis.x - params.sequential_sigma_m.powi(2)).abs() < 1e-15);
    }
}
