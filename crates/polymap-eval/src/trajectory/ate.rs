//! Absolute trajectory error (ATE) after a rigid alignment.

use polymap::geometry::{Pose2, Vec2, normalize_angle_rad};
use serde::Serialize;

use super::PosePair;
use crate::align::align_se2;
use crate::stats::ErrorStats;

/// How the estimate is brought into the truth's frame before measuring the ATE.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum AteAlignment {
    /// Least-squares rigid fit of the estimated positions to the true ones (no scale).
    LeastSquares,
    /// Make the first associated estimated pose coincide with its true pose.
    FirstPose,
    /// No alignment: both are assumed to be in the same frame already.
    Identity,
}

/// Absolute trajectory error: position and heading errors of every associated pose after the
/// alignment.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AteMetrics {
    /// Number of associated poses.
    pub pairs: usize,
    /// The alignment applied: maps the estimate's map frame into the truth's frame.
    pub truth_from_estimate: Pose2,
    /// `|aligned estimated position − true position|`, metres (`rms` is the usual "ATE RMSE").
    pub position_m: ErrorStats,
    /// `|wrap(aligned estimated heading − true heading)|`, degrees.
    pub heading_deg: ErrorStats,
}

/// The ATE of associated pose pairs; `None` when `pairs` is empty.
///
/// ```
/// use polymap::geometry::Pose2;
/// use polymap_eval::trajectory::{absolute_trajectory_error, AteAlignment, PosePair};
/// let pairs = [
///     PosePair { stamp_s: 0.0, estimate: Pose2::IDENTITY, truth: Pose2::new(0.0, 0.1, 0.0) },
///     PosePair { stamp_s: 1.0, estimate: Pose2::new(1.0, 0.0, 0.0), truth: Pose2::new(1.0, -0.1, 0.0) },
/// ];
/// let ate = absolute_trajectory_error(&pairs, AteAlignment::Identity).unwrap();
/// assert!((ate.position_m.rms - 0.1).abs() < 1e-12);
/// ```
pub fn absolute_trajectory_error(
    pairs: &[PosePair],
    alignment: AteAlignment,
) -> Option<AteMetrics> {
    let truth_from_estimate = alignment_of(pairs, alignment)?;
    let mut position_m = Vec::with_capacity(pairs.len());
    let mut heading_deg = Vec::with_capacity(pairs.len());
    for pair in pairs {
        let aligned = truth_from_estimate.compose(&pair.estimate);
        position_m.push((aligned.translation() - pair.truth.translation()).length());
        heading_deg.push(
            normalize_angle_rad(aligned.theta_rad - pair.truth.theta_rad)
                .abs()
                .to_degrees(),
        );
    }
    Some(AteMetrics {
        pairs: pairs.len(),
        truth_from_estimate,
        position_m: ErrorStats::from_values(&position_m)?,
        heading_deg: ErrorStats::from_values(&heading_deg)?,
    })
}

/// The transform `truth_from_estimate` chosen by `alignment`; `None` when `pairs` is empty.
fn alignment_of(pairs: &[PosePair], alignment: AteAlignment) -> Option<Pose2> {
    let first = pairs.first()?;
    Some(match alignment {
        AteAlignment::Identity => Pose2::IDENTITY,
        AteAlignment::FirstPose => first.truth.compose(&first.estimate.inverse()),
        AteAlignment::LeastSquares => {
            let est: Vec<Vec2> = pairs.iter().map(|p| p.estimate.translation()).collect();
            let truth: Vec<Vec2> = pairs.iter().map(|p| p.truth.translation()).collect();
            align_se2(&est, &truth)?.truth_from_estimate
        }
    })
}
