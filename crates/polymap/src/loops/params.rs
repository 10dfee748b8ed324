//! The parameters of loop closure, their defaults and their checks.

use serde::{Deserialize, Serialize};

use crate::check::{Checks, InvalidParam};

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
    /// Scans per node at most.
    pub node_scans: u32,
    /// A node also ends once the robot has travelled this far (path length, metres) since its
    /// first scan, so that a node covers about the same ground however far apart the scans
    /// are (a sparse log, `--every K`); 0 (the default) turns it off. Measured in
    /// `docs/decisions/2026-11-27-tracking-ideas-not-kept.md` (dense runs fragile at 2 m) and
    /// `docs/decisions/2026-12-03-loop-nodes-by-travel-and-confirmation-measured.md` (5 to
    /// 12 m: every 10th scan mended, every 5th broken).
    pub node_travel_m: f64,
    /// Every this many scans of a node feed its submap...
    pub node_keep_every: u32,
    /// ...or sooner, once the robot has travelled this far (path length, metres) since the
    /// last scan that fed it; 0 (the default) turns it off.
    pub node_keep_travel_m: f64,
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
    /// Half-width of the grid of translations searched around the predicted pose, metres...
    pub search_translation_m: f64,
    /// Where that grid finds no match: a grid as wide as this share of the robot's travel
    /// since the older node, the last node that closed a loop or this run's first (at most
    /// `search_radius_m`), its match held until a second agrees (see the module docs). The
    /// graph's prediction drifts with the travel no loop edge holds (3 %: a heading off by
    /// 1.7° on average; ACES every 10th scan with odometry came back 3.4–4.8 m off after
    /// 155 m). Dimensionless; 0: no grown grid. Measured in
    /// `docs/decisions/2026-12-04-loop-search-grows-with-travel.md`.
    pub search_translation_per_travel: f64,
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
    /// A scan tracked `weak` for want of a direction (`degenerate`: its motion along that
    /// direction came from the motion prior) adds to its sequential edge a
    /// standard deviation of this share of its step (at least `sequential_sigma_m`) along
    /// that direction. A loop correction then goes where the motion was least known (along a
    /// bare corridor) instead of spreading evenly over every scan. Dimensionless; 0: every
    /// sequential edge alike.
    pub doubtful_step_sigma: f64,
    /// Standard deviation of a loop edge's translation, metres...
    pub loop_sigma_m: f64,
    /// ...and rotation, degrees.
    pub loop_sigma_deg: f64,
    /// Standard deviation of the edge that ties the first node of a run on a saved map to
    /// where the run placed itself (relative to the saved map's last node), metres...
    /// The placement is a measurement like any other: the loops the run closes with the
    /// saved nodes may move that node, so its error does not bend the run between it and
    /// them. 0.5 m and 10°: the placement's own agreement between successive searches.
    pub placed_sigma_m: f64,
    /// ...and rotation, degrees.
    pub placed_sigma_deg: f64,
    /// A loop edge this far (metres)...
    pub confirm_above_m: f64,
    /// ...or this far (degrees) from the graph's prediction is held until another loop edge
    /// within `confirm_within_nodes` nodes agrees with it to within the same distances.
    pub confirm_above_deg: f64,
    /// How long a held loop edge waits for one that agrees, nodes (0, the default: no edge is
    /// held for bending the graph; an edge the grid grown with the travel found always waits,
    /// 3 nodes, for another node's that agrees to within `confirm_above_m` and `_deg`).
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
            node_travel_m: 0.0,
            node_keep_every: 5,
            node_keep_travel_m: 0.0,
            node_point_spacing_m: 0.1,
            min_node_gap: 15,
            skip_after_closure: 2,
            search_radius_m: 6.0,
            max_candidates: 2,
            match_gate_m: 0.5,
            search_translation_m: 2.4,
            search_translation_per_travel: 0.03,
            search_step_m: 0.3,
            search_rotation_deg: 10.0,
            search_rotation_step_deg: 2.0,
            min_matched_share: 0.5,
            min_inlier_share: 0.6,
            max_ambiguity: 0.9,
            sequential_sigma_m: 0.05,
            sequential_sigma_deg: 0.5,
            doubtful_step_sigma: 1.0,
            loop_sigma_m: 0.05,
            loop_sigma_deg: 0.5,
            placed_sigma_m: 0.5,
            placed_sigma_deg: 10.0,
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
    /// Checks every key's range; the error names the first key out of range.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        let finite = f64::MAX;
        Checks::new()
            .within("apply_after_nodes", self.apply_after_nodes, 0, 1000)
            .within("node_scans", self.node_scans, 1, 100_000)
            .within("node_travel_m", self.node_travel_m, 0.0, 1e6)
            .within("node_keep_travel_m", self.node_keep_travel_m, 0.0, 1e6)
            .within(
                "node_keep_every",
                self.node_keep_every,
                1,
                self.node_scans.max(1),
            )
            .above("node_point_spacing_m", self.node_point_spacing_m, 0.0, 10.0)
            .within("min_node_gap", self.min_node_gap, 2, 1_000_000)
            .within("skip_after_closure", self.skip_after_closure, 0, 1_000_000)
            .within("search_radius_m", self.search_radius_m, 0.0, 1e4)
            .within("max_candidates", self.max_candidates, 0, 64)
            .above("match_gate_m", self.match_gate_m, 0.0, 100.0)
            .within("search_translation_m", self.search_translation_m, 0.0, 20.0)
            .share(
                "search_translation_per_travel",
                self.search_translation_per_travel,
            )
            .within("search_step_m", self.search_step_m, 0.01, 20.0)
            .within("search_rotation_deg", self.search_rotation_deg, 0.0, 180.0)
            .within(
                "search_rotation_step_deg",
                self.search_rotation_step_deg,
                0.1,
                90.0,
            )
            .share("min_matched_share", self.min_matched_share)
            .share("min_inlier_share", self.min_inlier_share)
            .share("max_ambiguity", self.max_ambiguity)
            .above("sequential_sigma_m", self.sequential_sigma_m, 0.0, finite)
            .above(
                "sequential_sigma_deg",
                self.sequential_sigma_deg,
                0.0,
                finite,
            )
            .within("doubtful_step_sigma", self.doubtful_step_sigma, 0.0, 100.0)
            .above("loop_sigma_m", self.loop_sigma_m, 0.0, finite)
            .above("loop_sigma_deg", self.loop_sigma_deg, 0.0, finite)
            .above("placed_sigma_m", self.placed_sigma_m, 0.0, finite)
            .above("placed_sigma_deg", self.placed_sigma_deg, 0.0, finite)
            .within("confirm_above_m", self.confirm_above_m, 0.0, 1e4)
            .within("confirm_above_deg", self.confirm_above_deg, 0.0, 180.0)
            .within(
                "confirm_within_nodes",
                self.confirm_within_nodes,
                0,
                1_000_000,
            )
            .within("optimize_min_error_m", self.optimize_min_error_m, 0.0, 1e4)
            .within(
                "optimize_min_error_deg",
                self.optimize_min_error_deg,
                0.0,
                180.0,
            )
            .within("max_iterations", self.max_iterations, 1, 1000)
            .rule(
                "search_step_m",
                self.search_starts() <= MAX_SEARCH_STARTS,
                self.search_step_m,
                format_args!(
                    "the grid search would score {:.0} starts, more than {MAX_SEARCH_STARTS}",
                    self.search_starts()
                ),
            )
            .done()
    }

    /// Starts of the grid search: its translation and rotation ranges over their steps.
    fn search_starts(&self) -> f64 {
        let steps_t = (self.search_translation_m / self.search_step_m).floor() + 0.5;
        (2.0 * steps_t).powi(2) * self.search_rotations()
    }

    /// The widest half-width of a grid search whose starts stay within [`MAX_SEARCH_STARTS`]
    /// (the inverse of `search_starts`), metres.
    pub(super) fn widest_search_m(&self) -> f64 {
        let steps_t = (MAX_SEARCH_STARTS / self.search_rotations()).sqrt() / 2.0 - 0.5;
        steps_t.floor().max(0.0) * self.search_step_m
    }

    /// Rotations of the grid search (its range over its step, both ends).
    fn search_rotations(&self) -> f64 {
        2.0 * ((self.search_rotation_deg / self.search_rotation_step_deg).floor() + 0.5)
    }
}

/// Most starts of the grid search (its translation and rotation ranges over their steps): the
/// search holds every start's score, so a configuration may not ask for billions.
pub const MAX_SEARCH_STARTS: f64 = 200_000.0;
