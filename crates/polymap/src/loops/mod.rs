//! Loop closure (an addition to the paper): a pose graph over short stretches of the
//! trajectory, matched against earlier stretches when the robot comes back.
//!
//! The mapper aligns each scan to the global map, so a robot that comes back with little drift
//! snaps onto what it mapped before. With more drift than ICP's basin it maps the place a second
//! time beside the first, and from then on tracks against the copy. Here:
//!
//! - A **node** is a run of consecutive scans, posed at its first: it ends after `node_scans`
//!   scans or once the robot has travelled `node_travel_m` since its first scan, whichever
//!   comes first (so that sparse scans do not make nodes span more ground; off by default). A node keeps a small
//!   submap in its own frame (the points and segments of its first scan and then of every
//!   `node_keep_every`-th scan, or sooner after `node_keep_travel_m` of travel; points thinned
//!   to `node_point_spacing_m`).
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
//! - The graph's prediction drifts with the travel no loop edge holds (since the older node,
//!   the last node that closed a loop, or this run's first node on a saved map): where the
//!   grid finds no match, a grid `search_translation_per_travel` of that travel wide (up to
//!   `search_radius_m`, and within `MAX_SEARCH_STARTS`) is searched, and a loop edge it finds
//!   is held until another node's, within 3 nodes, agrees with it to within `confirm_above_m`
//!   and `confirm_above_deg`: the wider the search, the likelier an alike place matches, so it
//!   neither displaces what the fixed grid finds nor goes in alone.
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

mod closer;
pub(crate) mod field;
pub mod graph;
mod joint;
mod joint_search;
mod matching;
mod nodes;
mod params;
mod worker;

use serde::{Deserialize, Serialize};

use crate::geometry::Pose2;
pub use closer::{LoopCloser, MotionDoubt, SavedNode};
pub use graph::Edge;
pub use joint::{CrossEdge, CrossVerdict, JointGraph, JointParams, joint_graph};
pub use joint_search::{NodeSearch, NodeSearchParams, NodeSeed, node_search_seeds};
pub use params::{LoopParams, MAX_SEARCH_STARTS};

/// The graph's work for a node failed (a panic while matching or optimising: a bug, never
/// expected). Loop closure stops there; the mapper reports it from
/// [`crate::mapper::Mapper::finish`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "loop closure failed on node {node}: {message} (set `[loops] enabled = false` to map without it)"
)]
pub struct LoopFailure {
    /// The node whose matching or optimisation failed.
    pub node: usize,
    /// What the failure said.
    pub message: String,
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

/// Corrections after an optimisation: node `first_node + i` moved by `new_from_old[i]` (new
/// pose ∘ old pose⁻¹, map frame).
#[derive(Debug, Clone, PartialEq)]
pub struct Correction {
    /// The first node that moved.
    pub first_node: usize,
    /// Per node from `first_node` on, the transform from its old to its new place.
    pub new_from_old: Vec<Pose2>,
}

#[cfg(test)]
mod tests;
