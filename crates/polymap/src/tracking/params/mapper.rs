//! `[mapper]` ([`MapperParams`]): the motion prior and where ICP starts.

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

/// Where ICP starts for each scan (section `[mapper]`): the motion prior, the extra starts and
/// how one is chosen, the whole-circle recovery, and a localize run's own tracking. Every key
/// but `icp_from_best_start_only` and `localize_own_motion_s` is one the paper preset sets
/// otherwise, so that its printed configuration reads back as it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MapperParams {
    /// The first guess for ICP.
    pub motion_prior: MotionPrior,
    /// When the motion prior's guess differs from the anchor (the previous pose), also run ICP
    /// from the anchor and keep the better fit (more inliers, then lower residual).
    pub also_start_at_anchor: bool,
    /// With the constant-velocity prior, directions ICP cannot observe fall back to the
    /// previous pose moved by the last motion that was observed (a step between two scans that
    /// were both tracked `ok` with every direction observed) instead of
    /// [`WEAK_DIRECTION_VELOCITY`](crate::tracking::WEAK_DIRECTION_VELOCITY) of the last
    /// motion: a robot keeps its speed along a bare corridor, and a motion that was itself
    /// taken from the prior never feeds back.
    pub keep_observed_velocity: bool,
    /// With several ICP starts, score them by the soft inlier count of a sample of points and
    /// run ICP from the best one only (faster; it must beat the first start by
    /// [`START_SCORE_MARGIN`](crate::tracking::START_SCORE_MARGIN)); otherwise run ICP from each
    /// and keep the best. `--odometry` turns it off: from an odometry guess, ICP from every
    /// start measured better.
    pub icp_from_best_start_only: bool,
    /// When ICP's inliers are fewer than this share of the scan's (thinned) points (the scan
    /// fits nowhere near the guess: the robot turned during a gap in the log), poses over the
    /// whole circle and within 1 m of the anchor are scored, ICP runs from the best three, and
    /// the best result is kept if it has at least twice the inliers and twice this share (0
    /// turns this off); turned from the guess beyond the window search's rotation window, it
    /// must also beat the window search's pose by 1.5 times the inliers. Not with the odometry
    /// prior, whose guess carries the turn.
    pub recover_below_inlier_share: f64,
    /// In a localize run, the span over which the trajectory takes its motion from the run's
    /// own tracking on a fresh map of its scans rather than from the saved map (the standard
    /// deviation of a Gaussian window in time, seconds; 0 turns the own tracking off): over
    /// short spans, a scan tracked against a finished map is less precise than against the walls
    /// the last scans built. See `mapper/own_motion.rs`.
    pub localize_own_motion_s: f64,
}

impl Default for MapperParams {
    fn default() -> Self {
        MapperParams {
            motion_prior: MotionPrior::ConstantVelocity,
            also_start_at_anchor: true,
            keep_observed_velocity: true,
            icp_from_best_start_only: true,
            recover_below_inlier_share: 0.15,
            localize_own_motion_s: 3.0,
        }
    }
}

impl MapperParams {
    /// Checks every key's range; the error names the first key out of range.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        Checks::new()
            .share(
                "recover_below_inlier_share",
                self.recover_below_inlier_share,
            )
            .within(
                "localize_own_motion_s",
                self.localize_own_motion_s,
                0.0,
                60.0,
            )
            .done()
    }
}
