//! An estimated trajectory against the true one (both `(stamp_s, pose)` lists, e.g. two TUM
//! files, as a simulator writes them).
//!
//! Poses are first associated by time stamp ([`associate`]); then
//! - [`absolute_trajectory_error`]: ATE after a rigid SE(2) alignment of estimate to truth;
//! - [`relative_pose_errors`]: RPE over a fixed frame offset or a distance travelled.
//!
//! [`evaluate_trajectory`] does all three.

mod ate;
mod rpe;

pub use ate::{AteAlignment, AteMetrics, absolute_trajectory_error};
pub use rpe::{RpeDelta, RpeMetrics, relative_pose_errors};

use polymap::geometry::Pose2;
use serde::Serialize;

use crate::stamp_index::{DEFAULT_STAMP_TOLERANCE_S, StampIndex};

/// An estimated pose and the true pose at the same time stamp.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PosePair {
    /// The estimate's time stamp, seconds.
    pub stamp_s: f64,
    /// Estimated `map_from_robot` (the estimate's map frame).
    pub estimate: Pose2,
    /// True `world_from_robot` (the truth's frame).
    pub truth: Pose2,
}

/// Settings of the trajectory metrics.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrajectoryParams {
    /// Largest stamp difference for an estimated and a true pose to be associated, seconds.
    /// Default [`DEFAULT_STAMP_TOLERANCE_S`] (1 ms).
    pub stamp_tolerance_s: f64,
    /// How the estimate is brought into the truth's frame for the ATE. Default least squares.
    pub alignment: AteAlignment,
    /// Offset between the two poses of each RPE pair. Default one frame.
    pub rpe_delta: RpeDelta,
}

impl Default for TrajectoryParams {
    fn default() -> Self {
        TrajectoryParams {
            stamp_tolerance_s: DEFAULT_STAMP_TOLERANCE_S,
            alignment: AteAlignment::LeastSquares,
            rpe_delta: RpeDelta::Frames(1),
        }
    }
}

/// All trajectory metrics of one estimate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrajectoryMetrics {
    /// Number of estimated poses given.
    pub estimate_poses: usize,
    /// Number of true poses given.
    pub truth_poses: usize,
    /// Number of associated pairs.
    pub associated: usize,
    /// Absolute trajectory error; `None` when nothing was associated.
    pub ate: Option<AteMetrics>,
    /// Relative pose error; `None` when no pair of poses is `rpe_delta` apart.
    pub rpe: Option<RpeMetrics>,
}

/// Pairs each estimated pose with the true pose at the same stamp (within `stamp_tolerance_s`),
/// sorted by stamp.
///
/// Both inputs may be in any order. When several estimated poses share a stamp only the first
/// (in the input order) is used; the true pose is found as in [`StampIndex::find`]. Poses with a
/// non-finite field and stamps without a partner are left out.
///
/// ```
/// use polymap::geometry::Pose2;
/// use polymap_eval::trajectory::associate;
/// let est = [(2.0, Pose2::new(2.0, 0.0, 0.0)), (1.0, Pose2::new(1.0, 0.0, 0.0)), (5.0, Pose2::IDENTITY)];
/// let truth = [(1.0004, Pose2::new(1.1, 0.0, 0.0)), (2.0, Pose2::new(2.1, 0.0, 0.0))];
/// let pairs = associate(&est, &truth, 1e-3);
/// assert_eq!(pairs.len(), 2);
/// assert_eq!(pairs[0].stamp_s, 1.0);
/// assert_eq!(pairs[0].truth.x_m, 1.1);
/// ```
pub fn associate(
    estimate: &[(f64, Pose2)],
    truth: &[(f64, Pose2)],
    stamp_tolerance_s: f64,
) -> Vec<PosePair> {
    let truth_index = StampIndex::new(truth.iter().map(|(t, _)| *t), stamp_tolerance_s);
    let est_index = StampIndex::new(estimate.iter().map(|(t, _)| *t), 0.0);
    let mut pairs: Vec<PosePair> = Vec::with_capacity(estimate.len());
    for i in est_index.sorted_positions() {
        let (stamp_s, est_pose) = estimate[i];
        if pairs.last().is_some_and(|p| p.stamp_s == stamp_s) || !est_pose.is_finite() {
            continue;
        }
        let Some(j) = truth_index.find(stamp_s) else {
            continue;
        };
        if truth[j].1.is_finite() {
            pairs.push(PosePair {
                stamp_s,
                estimate: est_pose,
                truth: truth[j].1,
            });
        }
    }
    pairs
}

/// Associates the two trajectories and computes the ATE and the RPE.
///
/// ```
/// use polymap::geometry::Pose2;
/// use polymap_eval::trajectory::{evaluate_trajectory, TrajectoryParams};
/// let truth: Vec<(f64, Pose2)> = (0..5).map(|i| (i as f64, Pose2::new(i as f64, 0.0, 0.0))).collect();
/// let world_from_map = Pose2::new(3.0, 4.0, 1.0);
/// let est: Vec<(f64, Pose2)> = truth.iter().map(|(t, p)| (*t, world_from_map.inverse().compose(p))).collect();
/// let m = evaluate_trajectory(&est, &truth, &TrajectoryParams::default());
/// assert_eq!(m.associated, 5);
/// assert!(m.ate.unwrap().position_m.rms < 1e-9);
/// assert!(m.rpe.unwrap().translation_m.max < 1e-9);
/// ```
pub fn evaluate_trajectory(
    estimate: &[(f64, Pose2)],
    truth: &[(f64, Pose2)],
    params: &TrajectoryParams,
) -> TrajectoryMetrics {
    let pairs = associate(estimate, truth, params.stamp_tolerance_s);
    TrajectoryMetrics {
        estimate_poses: estimate.len(),
        truth_poses: truth.len(),
        associated: pairs.len(),
        ate: absolute_trajectory_error(&pairs, params.alignment),
        rpe: relative_pose_errors(&pairs, params.rpe_delta),
    }
}

#[cfg(test)]
mod tests;
