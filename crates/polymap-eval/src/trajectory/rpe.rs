//! Relative pose error (RPE): the drift between poses a fixed offset apart.

use polymap::geometry::Pose2;
use serde::Serialize;

use super::PosePair;
use crate::stats::ErrorStats;

/// Which poses are paired for the RPE.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum RpeDelta {
    /// Pose `i` with pose `i + n` of the associated (stamp-sorted) sequence; `n ≥ 1`.
    Frames(usize),
    /// Pose `i` with the first later pose at least this far along the **true** path, metres
    /// (> 0); poses with no such partner are left out.
    DistanceM(f64),
}

/// Relative pose error over the pairs chosen by an [`RpeDelta`].
///
/// For true poses `Q_i`, `Q_j` and estimated `P_i`, `P_j`, the error is
/// `E = inv(inv(Q_i)·Q_j) · (inv(P_i)·P_j)`; its translation length and `|angle|` are reported.
/// The RPE needs no alignment: it is invariant to the estimate's frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RpeMetrics {
    /// The offset used.
    pub delta: RpeDelta,
    /// Number of pose pairs compared.
    pub pairs: usize,
    /// Translational error, metres (`rms` is the usual "RPE RMSE").
    pub translation_m: ErrorStats,
    /// Rotational error, degrees.
    pub rotation_deg: ErrorStats,
}

/// The RPE of stamp-sorted associated poses; `None` when no two poses are `delta` apart or
/// `delta` is invalid (`Frames(0)`, a non-positive or non-finite distance).
///
/// ```
/// use polymap::geometry::Pose2;
/// use polymap_eval::trajectory::{relative_pose_errors, PosePair, RpeDelta};
/// let pairs: Vec<PosePair> = (0..4)
///     .map(|i| PosePair {
///         stamp_s: i as f64,
///         estimate: Pose2::new(1.1 * i as f64, 0.0, 0.0),
///         truth: Pose2::new(i as f64, 0.0, 0.0),
///     })
///     .collect();
/// let rpe = relative_pose_errors(&pairs, RpeDelta::Frames(1)).unwrap();
/// assert_eq!(rpe.pairs, 3);
/// assert!((rpe.translation_m.mean - 0.1).abs() < 1e-12);
/// let by_distance = relative_pose_errors(&pairs, RpeDelta::DistanceM(2.0)).unwrap();
/// assert_eq!(by_distance.pairs, 2);
/// assert!((by_distance.translation_m.mean - 0.2).abs() < 1e-12);
/// ```
pub fn relative_pose_errors(pairs: &[PosePair], delta: RpeDelta) -> Option<RpeMetrics> {
    let partners = match delta {
        RpeDelta::Frames(n) if n >= 1 => frame_partners(pairs.len(), n),
        RpeDelta::DistanceM(d) if d > 0.0 && d.is_finite() => distance_partners(pairs, d),
        _ => return None,
    };
    let mut translation_m = Vec::with_capacity(partners.len());
    let mut rotation_deg = Vec::with_capacity(partners.len());
    for (i, j) in partners {
        let true_motion = pairs[i].truth.between(&pairs[j].truth);
        let est_motion = pairs[i].estimate.between(&pairs[j].estimate);
        let error = true_motion.between(&est_motion);
        translation_m.push(error.translation().length());
        rotation_deg.push(error.theta_rad.abs().to_degrees());
    }
    Some(RpeMetrics {
        delta,
        pairs: translation_m.len(),
        translation_m: ErrorStats::from_values(&translation_m)?,
        rotation_deg: ErrorStats::from_values(&rotation_deg)?,
    })
}

/// `(i, i + n)` for every valid `i`.
fn frame_partners(len: usize, n: usize) -> Vec<(usize, usize)> {
    (0..len.saturating_sub(n)).map(|i| (i, i + n)).collect()
}

/// `(i, j)` with `j` the first pose at least `distance_m` further along the true path than `i`.
fn distance_partners(pairs: &[PosePair], distance_m: f64) -> Vec<(usize, usize)> {
    let path_m = cumulative_path_m(pairs.iter().map(|p| &p.truth));
    let mut partners = Vec::new();
    let mut j = 0;
    for i in 0..pairs.len() {
        // The path length is non-decreasing, so the partner index only moves forward.
        j = j.max(i + 1);
        while j < pairs.len() && path_m[j] - path_m[i] < distance_m {
            j += 1;
        }
        if j == pairs.len() {
            break;
        }
        partners.push((i, j));
    }
    partners
}

/// Distance travelled from the first pose to each pose, metres.
fn cumulative_path_m<'a>(poses: impl Iterator<Item = &'a Pose2>) -> Vec<f64> {
    let mut out = Vec::new();
    let mut last: Option<&Pose2> = None;
    let mut s = 0.0;
    for p in poses {
        if let Some(q) = last {
            s += (p.translation() - q.translation()).length();
        }
        out.push(s);
        last = Some(p);
    }
    out
}
