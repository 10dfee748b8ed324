//! Closed-form least-squares rigid alignment in the plane (2D Kabsch / Umeyama without scale).
//!
//! Given point pairs `(a_i, b_i)`, finds the rotation `R(θ)` and translation `t` minimising
//! `Σ |R a_i + t − b_i|²`. With centroids `ā`, `b̄` and centred points `a'`, `b'`:
//! `θ = atan2(Σ a' × b', Σ a' · b')`, `t = b̄ − R ā`. In 2D this is exact, no SVD needed.

use polymap::geometry::{Pose2, Vec2};
use serde::Serialize;

/// The best rigid transform taking the estimate's points onto the truth's.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Se2Alignment {
    /// Maps points from the estimate's frame into the truth's frame.
    pub truth_from_estimate: Pose2,
    /// Root mean square of the residuals `|R a_i + t − b_i|` after alignment, metres.
    pub rms_residual_m: f64,
    /// Number of point pairs used.
    pub pairs: usize,
}

/// Aligns `p_in_estimate[i]` onto `p_in_truth[i]` by least squares over rotation and translation.
///
/// `None` when the slices are empty or of different lengths. With one pair, or when all points
/// coincide, the rotation is undetermined and taken as zero.
///
/// ```
/// use polymap::geometry::{Pose2, Vec2};
/// use polymap_eval::align::align_se2;
/// let truth_from_est = Pose2::new(1.0, -2.0, 0.3);
/// let est = [Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 2.0)];
/// let truth: Vec<Vec2> = est.iter().map(|p| truth_from_est.transform_point(*p)).collect();
/// let a = align_se2(&est, &truth).unwrap();
/// assert!((a.truth_from_estimate.theta_rad - 0.3).abs() < 1e-12);
/// assert!((a.truth_from_estimate.x_m - 1.0).abs() < 1e-12);
/// assert!(a.rms_residual_m < 1e-12);
/// ```
pub fn align_se2(p_in_estimate: &[Vec2], p_in_truth: &[Vec2]) -> Option<Se2Alignment> {
    if p_in_estimate.is_empty() || p_in_estimate.len() != p_in_truth.len() {
        return None;
    }
    let n = p_in_estimate.len() as f64;
    let centroid_est = p_in_estimate.iter().copied().sum::<Vec2>() / n;
    let centroid_truth = p_in_truth.iter().copied().sum::<Vec2>() / n;
    let (mut cross, mut dot) = (0.0, 0.0);
    for (a, b) in p_in_estimate.iter().zip(p_in_truth) {
        let (a, b) = (*a - centroid_est, *b - centroid_truth);
        cross += a.perp_dot(b);
        dot += a.dot(b);
    }
    let theta_rad = if cross == 0.0 && dot == 0.0 {
        0.0
    } else {
        cross.atan2(dot)
    };
    let rotation = Pose2::new(0.0, 0.0, theta_rad);
    let t = centroid_truth - rotation.rotate(centroid_est);
    let truth_from_estimate = Pose2::new(t.x, t.y, theta_rad);
    let sum_2: f64 = p_in_estimate
        .iter()
        .zip(p_in_truth)
        .map(|(a, b)| (truth_from_estimate.transform_point(*a) - *b).length_squared())
        .sum();
    Some(Se2Alignment {
        truth_from_estimate,
        rms_residual_m: (sum_2 / n).sqrt(),
        pairs: p_in_estimate.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mismatched_or_empty_inputs_give_none() {
        assert!(align_se2(&[], &[]).is_none());
        assert!(align_se2(&[Vec2::ZERO], &[]).is_none());
    }

    #[test]
    fn single_pair_is_a_pure_translation() {
        let a = align_se2(&[Vec2::new(1.0, 1.0)], &[Vec2::new(3.0, 0.0)]).unwrap();
        assert_eq!(a.truth_from_estimate, Pose2::new(2.0, -1.0, 0.0));
    }

    #[test]
    fn half_turn_is_recovered() {
        let est = [
            Vec2::new(1.0, 0.0),
            Vec2::new(-1.0, 0.0),
            Vec2::new(0.0, 1.0),
        ];
        let truth: Vec<Vec2> = est.iter().map(|p| -*p).collect();
        let a = align_se2(&est, &truth).unwrap();
        assert!((a.truth_from_estimate.theta_rad.abs() - std::f64::consts::PI).abs() < 1e-12);
        assert!(a.rms_residual_m < 1e-12);
    }

    #[test]
    fn noisy_points_give_least_squares_residual() {
        // Truth is the estimate with ±0.1 m along y, symmetric: the best fit is the identity.
        let est = [
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(2.0, 0.0),
            Vec2::new(3.0, 0.0),
        ];
        let truth = [
            Vec2::new(0.0, 0.1),
            Vec2::new(1.0, -0.1),
            Vec2::new(2.0, -0.1),
            Vec2::new(3.0, 0.1),
        ];
        let a = align_se2(&est, &truth).unwrap();
        assert!(a.truth_from_estimate.translation().length() < 1e-12);
        assert!(a.truth_from_estimate.theta_rad.abs() < 1e-12);
        assert!((a.rms_residual_m - 0.1).abs() < 1e-12);
    }
}
