//! Alignment of a new scan to the map by ICP (section 2: correspondence and alignment).
//!
//! Two correspondence schemes share one robust Gauss–Newton solver over point-to-line
//! constraints (a point-to-point pair is two such constraints, along x and along y):
//!
//! - [`AlignMethod::Endpoints`], the paper's: every segment endpoint of the scan is paired with
//!   its closest point of the map, and every map endpoint in the scan's neighbourhood with its
//!   closest point of the scan.
//! - [`AlignMethod::PointToSegment`], an addition: every scan point (thinned to a minimum
//!   spacing) is paired with the nearest map segment and constrained along its normal. Points
//!   whose closest map point is an endpoint reached from beyond the segment's end see unmapped
//!   space and are left out.
//!
//! Both reject pairs beyond a correspondence gate that shrinks over the iterations and weight
//! the rest with a Cauchy kernel. The solver is degeneracy-aware: it only moves the pose along
//! directions that the correspondences constrain (eigenvectors of the normal matrix with enough
//! information), so in a featureless corridor the along-corridor position stays where the
//! motion prior put it instead of sliding on noise.
//!
//! Without a guess, [`global_match`] finds where a second map or a scan lies in a map: pose
//! hypotheses from pairs of segments (`pairs.rs`), verified on a [`ScoreRaster`], refined by
//! [`CorrelativeMatcher`] and ICP (`global.rs`).

mod buffers;
mod correlative;
mod endpoints;
mod global;
mod global_params;
mod nearest;
mod pair_search;
mod pairs;
mod point_to_segment;
mod raster;
mod search;
mod solver;

use serde::{Deserialize, Serialize};

use crate::check::{Checks, InvalidParam};
use crate::geometry::{Pose2, Segment, SegmentProjection, Vec2};
use crate::segment_index::NearestCertificate;
pub use correlative::{Candidate, CorrelativeMatcher, Exclusion, SearchWindow, WindowBest};
pub use endpoints::align_endpoints;
pub(crate) use global::bounds;
pub use global::{GLOBAL_MIN_SCORE, GLOBAL_SEARCH_POINTS, GlobalSearch, map_bounds};
pub use pair_search::{
    GlobalMatch, GlobalParams, MatchVerdict, MovingSide, ScoredPose, global_match, overlap_share,
    points_along,
};
pub(crate) use pair_search::{best_distinct, hypotheses, raster_score};
pub use pairs::{Corner, corner_poses, corners};
pub use point_to_segment::{
    EDGE_ON_BELOW, LOOSE_DISTINCT_M, LOOSE_GATE_M, LOOSE_LINE_BELOW, LOOSE_MIN_NEIGHBOURS,
    LOOSE_NEIGHBOURHOOD_M, PointTargets, align_points, align_points_and_loose,
    align_points_past_ends, thin_points,
};
pub use raster::{MAX_RASTER_CELLS, ScoreRaster};
pub use search::{fit_score, fit_score_above, rotation_search, score_sample, score_sample_n};
pub(crate) use solver::symmetric_eigen;
pub use solver::{Constraint, PosePrior};

/// Which correspondences drive ICP.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AlignMethod {
    /// The paper's: segment endpoints to closest points, both ways.
    Endpoints,
    /// Scan points to map segments, along the segment normals (an addition).
    PointToSegment,
}

/// Parameters of alignment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AlignParams {
    /// The correspondence scheme.
    pub method: AlignMethod,
    /// Most ICP iterations.
    pub max_iterations: usize,
    /// Correspondence gate in the first iteration, metres.
    pub initial_gate_m: f64,
    /// The gate shrinks by `gate_decay` every iteration down to this, metres.
    pub final_gate_m: f64,
    /// Factor applied to the gate after every iteration, in (0, 1].
    pub gate_decay: f64,
    /// Scale of the Cauchy kernel, metres.
    pub robust_scale_m: f64,
    /// Point-to-segment: scan points closer than this to the last kept one are skipped, metres.
    pub point_spacing_m: f64,
    /// Point-to-segment: a point may project this far beyond a segment's end and still count,
    /// metres.
    pub endpoint_slack_m: f64,
    /// Least information (eigenvalue of the weighted normal matrix, in fully weighted
    /// correspondences per metre² along that direction; rotation in metres at 1 m) for the
    /// solver to move along a direction.
    pub min_information: f64,
    /// Iteration stops when the update is below this translation, metres...
    pub converged_translation_m: f64,
    /// ...and this rotation, degrees.
    pub converged_rotation_deg: f64,
    /// With fewer correspondences than this the initial guess is kept.
    pub min_correspondences: usize,
    /// Coarse rotation search before ICP (an addition): half-width of the searched range around
    /// the guess, degrees; 0 turns it off.
    pub rotation_search_deg: f64,
    /// Step of the rotation search, degrees.
    pub rotation_search_step_deg: f64,
    /// About this many scan points are scored per candidate rotation.
    pub rotation_search_points: usize,
    /// Scale of the soft inlier count of the rotation search, metres.
    pub rotation_search_sigma_m: f64,
}

impl Default for AlignParams {
    fn default() -> Self {
        AlignParams {
            method: AlignMethod::PointToSegment,
            max_iterations: 30,
            initial_gate_m: 1.0,
            final_gate_m: 0.25,
            gate_decay: 0.8,
            robust_scale_m: 0.05,
            point_spacing_m: 0.05,
            endpoint_slack_m: 0.1,
            min_information: 0.2,
            converged_translation_m: 1e-4,
            converged_rotation_deg: 0.005,
            min_correspondences: 8,
            rotation_search_deg: 24.0,
            rotation_search_step_deg: 2.0,
            rotation_search_points: 40,
            rotation_search_sigma_m: 0.3,
        }
    }
}

impl AlignParams {
    /// Checks every key's range; the error names the first key out of range.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        Checks::new()
            .within("max_iterations", self.max_iterations, 1, 10_000)
            .above("initial_gate_m", self.initial_gate_m, 0.0, 100.0)
            .above("final_gate_m", self.final_gate_m, 0.0, self.initial_gate_m)
            .above("gate_decay", self.gate_decay, 0.0, 1.0)
            .above("robust_scale_m", self.robust_scale_m, 0.0, 10.0)
            .within("point_spacing_m", self.point_spacing_m, 0.0, 10.0)
            .within("endpoint_slack_m", self.endpoint_slack_m, 0.0, 10.0)
            .within("min_information", self.min_information, 0.0, 1e6)
            .within(
                "converged_translation_m",
                self.converged_translation_m,
                0.0,
                1.0,
            )
            .within(
                "converged_rotation_deg",
                self.converged_rotation_deg,
                0.0,
                10.0,
            )
            .within(
                "min_correspondences",
                self.min_correspondences,
                1,
                1_000_000,
            )
            .within("rotation_search_deg", self.rotation_search_deg, 0.0, 180.0)
            .within(
                "rotation_search_step_deg",
                self.rotation_search_step_deg,
                0.1,
                90.0,
            )
            .within(
                "rotation_search_points",
                self.rotation_search_points,
                1,
                100_000,
            )
            .above(
                "rotation_search_sigma_m",
                self.rotation_search_sigma_m,
                0.0,
                10.0,
            )
            .done()
    }
}

impl AlignParams {
    /// The correspondence gate at iteration `i` (0-based), metres.
    pub fn gate_m(&self, i: usize) -> f64 {
        (self.initial_gate_m * self.gate_decay.clamp(0.0, 1.0).powi(i.min(1000) as i32))
            .max(self.final_gate_m)
    }
}

/// The outcome of one alignment, with diagnostics.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AlignResult {
    /// The estimated pose of the robot in the map.
    pub map_from_robot: Pose2,
    /// Iterations run.
    pub iterations: usize,
    /// Correspondences in the last iteration.
    pub correspondences: usize,
    /// Correspondences in the last iteration with a residual within the robust scale.
    pub inliers: usize,
    /// RMS residual of the last iteration's correspondences, metres.
    pub residual_rms_m: f64,
    /// True when the update fell below the convergence thresholds.
    pub converged: bool,
    /// Directions (of x, y, rotation combined) the correspondences left unobservable; along
    /// them the pose was put on the anchor. 3 when there were too few correspondences.
    pub weak_directions: u8,
    /// Map-frame direction, degrees in `[0, 180)`, of the least observed translation when a
    /// direction was unobservable (along a corridor, its axis); `None` otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub weak_direction_deg: Option<f64>,
    /// How well the final correspondences fix the translation (before the weak directions
    /// were put on the anchor).
    #[serde(default)]
    pub translation_information: TranslationInformation,
    /// Whether ICP weighed a motion prior with the fit at every step ([`PosePrior`]): the pose
    /// is then the estimate of both, the information still the fit's own.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub weighed_prior: bool,
}

/// How well a fit fixes the translation, the rotation marginalized out: the eigenvalues of the
/// translation information, in fully weighted correspondences per m² (a wall seen by n inlier
/// points adds about n across itself and nothing along it).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct TranslationInformation {
    /// Along the least observed direction (near 0 along a bare corridor).
    pub weakest: f64,
    /// Along the best observed direction.
    pub strongest: f64,
    /// Map-frame direction of the least observed translation, degrees in `[0, 180)`.
    pub weakest_deg: f64,
    /// The whole information of the fit over (x, y, θ), map frame, in the same units
    /// (rotation in radians, so its entries carry metres): the upper triangle `[xx, xy, xθ,
    /// yy, yθ, θθ]`. Not written out.
    #[serde(skip)]
    pub pose: [f64; 6],
}

impl TranslationInformation {
    /// The least observed direction as a map-frame unit vector.
    pub fn weakest_axis(&self) -> Vec2 {
        let a = self.weakest_deg.to_radians();
        Vec2::new(a.cos(), a.sin())
    }
}

/// Nearest-segment queries against a set of map segments (map frame).
pub trait SegmentLookup {
    /// The segment nearest to `p` within `max_distance_m`, with the projection of `p` onto it.
    fn nearest_segment(&self, p: Vec2, max_distance_m: f64)
    -> Option<(Segment, SegmentProjection)>;

    /// [`SegmentLookup::nearest_segment`] without the projection (which an implementation may
    /// then skip computing).
    fn nearest_segment_only(&self, p: Vec2, max_distance_m: f64) -> Option<Segment> {
        self.nearest_segment(p, max_distance_m).map(|(s, _)| s)
    }

    /// The nearest segment to `p` with a certificate that answers later queries near `p`
    /// exactly as [`SegmentLookup::nearest_segment_only`] would, without a search; `None` when
    /// the implementation offers none.
    fn nearest_certified(&self, _p: Vec2) -> Option<NearestCertificate> {
        None
    }
}

#[cfg(test)]
mod tests;
