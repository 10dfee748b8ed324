//! The parameters of the global search ([`global_match`](super::global_match)): how
//! hypotheses are sampled, clustered, refined and judged.

use serde::{Deserialize, Serialize};

use crate::check::{Checks, InvalidParam};

/// Parameters of the global search.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GlobalParams {
    /// Segments shorter than this form no corner, metres.
    pub min_segment_m: f64,
    /// Only this many of the longest segments of each side form corners.
    pub max_segments: usize,
    /// A corner's segments are at least this far from parallel, degrees.
    pub min_corner_angle_deg: f64,
    /// A corner's lines cross within this distance of both segments, metres.
    pub corner_reach_m: f64,
    /// Two corners match when their angles agree within this, degrees.
    pub angle_tolerance_deg: f64,
    /// Moving points scoring each hypothesis on the coarse raster.
    pub coarse_points: usize,
    /// Kernel scale of the coarse raster, metres (wide: a hypothesis is a corner's pose, off by
    /// its directions' error times the distance from the corner).
    pub coarse_sigma_m: f64,
    /// Cell of the coarse raster, metres.
    pub coarse_cell_m: f64,
    /// Clusters of the best coarse hypotheses refined by ICP and scored on the fine raster.
    pub refined_clusters: usize,
    /// Hypotheses closer than this in translation…, metres
    pub seed_apart_m: f64,
    /// …and this in rotation are one cluster, degrees.
    pub seed_apart_deg: f64,
    /// Moving points driving the ICP of each cluster.
    pub icp_points: usize,
    /// Moving points scoring the refinement on the fine raster.
    pub fine_points: usize,
    /// Kernel scale of the fine raster, metres.
    pub fine_sigma_m: f64,
    /// Cell of the fine raster, metres.
    pub fine_cell_m: f64,
    /// The rival of the best pose lies farther than this in translation…, metres
    pub apart_m: f64,
    /// …or this in rotation, degrees.
    pub apart_deg: f64,
    /// A moving point within this of the map after ICP counts to the overlap, metres.
    pub inlier_m: f64,
    /// A robot position this close to the other side's walls is a conflict, metres.
    pub clearance_m: f64,
    /// Robot positions closer than this to the one kept before are skipped, metres.
    pub path_spacing_m: f64,
    /// At most about this many robot positions of each side are checked (evenly spread).
    pub path_points: usize,
    /// A step between kept positions longer than this is not checked for crossing a wall (the
    /// robot may have gone round a corner between them), metres.
    pub max_step_m: f64,
    /// Weight of the conflicts (a share) against the raster score in the ranking.
    pub conflict_weight: f64,
    /// Most conflicts (a share) of an accepted match.
    pub max_conflicts: f64,
    /// Least fine score (mean raster value, `[0, 1]`) of an accepted match.
    pub min_score: f64,
    /// Least overlap (share of moving points within `inlier_m`) of an accepted match.
    pub min_overlap: f64,
    /// A rival scoring at least this share of the best makes the match ambiguous.
    pub max_rival_ratio: f64,
    /// A rival that would pass on its own makes the match ambiguous when it scores at least
    /// this share of the best.
    pub min_passing_ratio: f64,
}

impl Default for GlobalParams {
    fn default() -> Self {
        GlobalParams {
            min_segment_m: 0.5,
            max_segments: 150,
            min_corner_angle_deg: 30.0,
            corner_reach_m: 1.0,
            angle_tolerance_deg: 4.0,
            coarse_points: 200,
            coarse_sigma_m: 0.5,
            coarse_cell_m: 0.1,
            refined_clusters: 64,
            seed_apart_m: 0.5,
            seed_apart_deg: 3.0,
            icp_points: 500,
            fine_points: 2000,
            fine_sigma_m: 0.2,
            fine_cell_m: 0.05,
            apart_m: 2.0,
            apart_deg: 10.0,
            inlier_m: 0.1,
            clearance_m: 0.2,
            path_spacing_m: 0.25,
            path_points: 2000,
            max_step_m: 1.0,
            conflict_weight: 1.0,
            max_conflicts: 0.15,
            min_score: 0.3,
            min_overlap: 0.3,
            max_rival_ratio: 0.85,
            min_passing_ratio: 0.5,
        }
    }
}

impl GlobalParams {
    /// Checks every key's range; the error names the first key out of range.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        Checks::new()
            .within("min_segment_m", self.min_segment_m, 0.0, 1e3)
            .within("max_segments", self.max_segments, 2, 100_000)
            .within("min_corner_angle_deg", self.min_corner_angle_deg, 1.0, 89.0)
            .above("corner_reach_m", self.corner_reach_m, 0.0, 100.0)
            .above("angle_tolerance_deg", self.angle_tolerance_deg, 0.0, 45.0)
            .within("coarse_points", self.coarse_points, 1, 1_000_000)
            .above("coarse_sigma_m", self.coarse_sigma_m, 0.0, 10.0)
            .above("coarse_cell_m", self.coarse_cell_m, 0.0, 10.0)
            .within("refined_clusters", self.refined_clusters, 1, 10_000)
            .above("seed_apart_m", self.seed_apart_m, 0.0, 1e3)
            .above("seed_apart_deg", self.seed_apart_deg, 0.0, 180.0)
            .within("icp_points", self.icp_points, 1, 10_000_000)
            .within("fine_points", self.fine_points, 1, 10_000_000)
            .above("fine_sigma_m", self.fine_sigma_m, 0.0, 10.0)
            .above("fine_cell_m", self.fine_cell_m, 0.0, 10.0)
            .above("apart_m", self.apart_m, 0.0, 1e3)
            .above("apart_deg", self.apart_deg, 0.0, 180.0)
            .above("inlier_m", self.inlier_m, 0.0, 10.0)
            .within("clearance_m", self.clearance_m, 0.0, 10.0)
            .above("path_spacing_m", self.path_spacing_m, 0.0, 100.0)
            .within("path_points", self.path_points, 1, 10_000_000)
            .within("max_step_m", self.max_step_m, 0.0, 1e3)
            .within("conflict_weight", self.conflict_weight, 0.0, 1e3)
            .share("max_conflicts", self.max_conflicts)
            .share("min_score", self.min_score)
            .share("min_overlap", self.min_overlap)
            .share("max_rival_ratio", self.max_rival_ratio)
            .share("min_passing_ratio", self.min_passing_ratio)
            .done()
    }
}
