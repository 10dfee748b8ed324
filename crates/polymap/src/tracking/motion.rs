//! Where ICP starts for a new scan: the motion prior and the mapper's start policy (section
//! `[mapper]`). A leaf module, so that the configuration tree and the mapper do not import
//! each other.

use serde::{Deserialize, Serialize};

use crate::check::{Checks, InvalidParam};

/// Where ICP starts for a new scan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MotionPrior {
    /// The previous scan's pose (the paper).
    Previous,
    /// The previous pose moved by the last scan-to-scan motion.
    ConstantVelocity,
    /// The previous pose moved by the odometry increment between the scans (falls back to the
    /// previous pose when a scan has no odometry).
    Odometry,
}

/// Parameters of the mapping loop.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MapperParams {
    /// The first guess for ICP.
    pub motion_prior: MotionPrior,
    /// When the motion prior's guess differs from the anchor (the previous pose), also run ICP
    /// from the anchor and keep the better fit (more inliers, then lower residual).
    pub also_start_at_anchor: bool,
    /// Share of the last scan-to-scan motion kept along directions ICP cannot observe, with the
    /// constant-velocity prior (0: assume no motion there; 1: assume the same motion again).
    pub weak_direction_velocity: f64,
    /// With the constant-velocity prior, directions ICP cannot observe fall back to the
    /// previous pose moved by the last motion that was observed (a step between two scans that
    /// were both tracked `ok` with every direction observed) instead of
    /// `weak_direction_velocity` of the last motion: a robot keeps its speed along a bare
    /// corridor, and a motion that was itself taken from the prior never feeds back.
    pub keep_observed_velocity: bool,
    /// With several ICP starts, score them by the soft inlier count of a sample of points and
    /// run ICP from the best one only (faster); otherwise run ICP from each and keep the best.
    pub icp_from_best_start_only: bool,
    /// Soft inlier points by which another start must beat the first (the anchor, "no
    /// motion", when it is a start) to be chosen.
    pub start_score_margin: f64,
    /// When ICP's inliers are fewer than this share of the scan's (thinned) points (the scan
    /// fits nowhere near the guess: the robot turned during a gap in the log), poses over the
    /// whole circle and within 1 m of the anchor are scored, ICP runs from the best three, and
    /// the best result is kept if it has at least twice the inliers and twice this share (0
    /// turns this off). Not with the odometry prior, whose guess carries the turn.
    pub recover_below_inlier_share: f64,
}

impl Default for MapperParams {
    fn default() -> Self {
        MapperParams {
            motion_prior: MotionPrior::ConstantVelocity,
            also_start_at_anchor: true,
            weak_direction_velocity: 0.0,
            keep_observed_velocity: true,
            icp_from_best_start_only: true,
            start_score_margin: 1.0,
            recover_below_inlier_share: 0.15,
        }
    }
}

impl MapperParams {
    /// Checks every key's range; the error names the first key out of range.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        Checks::new()
            .share("weak_direction_velocity", self.weak_direction_velocity)
            .within("start_score_margin", self.start_score_margin, 0.0, 1e6)
            .share(
                "recover_below_inlier_share",
                self.recover_below_inlier_share,
            )
            .done()
    }
}
