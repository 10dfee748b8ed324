//! The parameters of loop closure, their defaults and their checks.

use serde::{Deserialize, Serialize};

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

/// Most starts of the grid search (its translation and rotation ranges over their steps): the
/// search holds every start's score, so a configuration may not ask for billions.
pub const MAX_SEARCH_STARTS: f64 = 200_000.0;
