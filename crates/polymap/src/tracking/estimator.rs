//! The fit and the motion prior in information form: where a scan's fit observes a direction
//! weakly, its pose takes the motion prior's in proportion.
//!
//! ICP's final correspondences give the fit's information over (x, y, θ)
//! ([`TranslationInformation::pose`]); the motion prior (the previous pose moved by the speed
//! last observed) is spread as far as a robot's acceleration takes it from constant velocity in
//! the time since the last scan, and since its speed was last observed. The pose minimizing both quadratic forms is the fit's moved
//! towards the prior by `(H_fit + H_prior)⁻¹ H_prior (prior − fit)`: along a wall's normal the
//! fit's hundreds of points outweigh the prior; along a bare corridor, or round a circular bend
//! (where the weak direction turns the robot as it moves), the prior's few millimetres at ten
//! scans a second outweigh a fit held by a few points, whose pull is more often the map's end
//! or a chord's kink than the robot's motion. At one scan a second the prior spreads over
//! half a metre and tells the fit next to nothing. The heading is the fit's: the prior's turn
//! is the last observed step's, stale in a bend.
//!
//! [`TranslationInformation::pose`]: crate::align::TranslationInformation::pose

use glam::{DMat3, DVec3};

use super::params::{FIT_VARIANCE_M2, PRIOR_ACCEL_M_S2, PRIOR_FLOOR_M};
use crate::align::TranslationInformation;
use crate::geometry::{Pose2, normalize_angle_rad};

/// The prior moves a fit only where its information reaches this share of the fit's along the
/// fit's weakest direction (it then moves the pose by at least a tenth of the way).
const PRIOR_SIGNIFICANT_SHARE: f64 = 0.1;

/// The pose that best agrees with the fit (`fit`, map frame, its information `information`,
/// [`TranslationInformation::pose`]) and the motion prior's translation (`prior`, map frame),
/// `dt_s` seconds after the scan the prior moves on from, whose speed was last observed
/// `age_s` seconds before that scan: the fit where it is observed, the prior's translation in
/// proportion where the fit is weak; the fit itself when the information is not finite.
///
/// [`TranslationInformation::pose`]: crate::align::TranslationInformation::pose
pub(super) fn fuse(
    fit: Pose2,
    information: &TranslationInformation,
    prior: Pose2,
    dt_s: f64,
    age_s: f64,
) -> Pose2 {
    // Since the speed was last observed (`age_s` before this step) it may have changed by the
    // acceleration times that age, and this step by that times its time.
    let spread_m = PRIOR_FLOOR_M + PRIOR_ACCEL_M_S2 * dt_s * (0.5 * dt_s + age_s.max(0.0));
    let along = 1.0 / (spread_m * spread_m);
    // A prior that would move the pose by under a tenth of its distance from the fit even along
    // the fit's weakest direction leaves the fit alone: millimetres that change nothing but
    // which later decisions they tip.
    if along < PRIOR_SIGNIFICANT_SHARE * information.weakest / FIT_VARIANCE_M2 {
        return fit;
    }
    let [xx, xy, xr, yy, yr, rr] = information.pose.map(|v| v / FIT_VARIANCE_M2);
    let fit_information = DMat3::from_cols_array(&[xx, xy, xr, xy, yy, yr, xr, yr, rr]);
    let prior_information = DMat3::from_diagonal(DVec3::new(along, along, 0.0));
    let towards = DVec3::new(
        prior.x_m - fit.x_m,
        prior.y_m - fit.y_m,
        normalize_angle_rad(prior.theta_rad - fit.theta_rad),
    );
    let delta = (fit_information + prior_information).inverse() * (prior_information * towards);
    if !delta.is_finite() {
        return fit;
    }
    Pose2::new(
        fit.x_m + delta.x,
        fit.y_m + delta.y,
        fit.theta_rad + delta.z,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The information of a corridor along x seen by `n` points on each wall (1.2 m either
    /// side), `along` points' worth along it, as [`TranslationInformation::pose`] holds it.
    ///
    /// [`TranslationInformation::pose`]: crate::align::TranslationInformation::pose
    fn corridor(n: f64, along: f64) -> TranslationInformation {
        // Each wall point: normal (0, ±1), lever arm x·(∓1)…; spread along ±3 m its sum is
        // n·(x² mean) = n·3 in the rotation; the walls' y-rotation terms cancel.
        TranslationInformation {
            weakest: along,
            strongest: 2.0 * n,
            weakest_deg: 0.0,
            pose: [along, 0.0, 0.0, 2.0 * n, 0.0, 2.0 * n * 3.0],
        }
    }

    #[test]
    fn a_bare_corridor_takes_the_prior_along_it_and_the_fit_across() {
        let fit = Pose2::new(0.0, 0.0, 0.0);
        let prior = Pose2::new(0.05, 0.02, 0.01);
        // Ten scans a second, a corridor seen by 100 points a wall, held along by 1 point.
        let fused = fuse(fit, &corridor(100.0, 1.0), prior, 0.1, 0.0);
        // Along the corridor the prior's 5 cm nearly all; across it a tenth of its 2 cm at most.
        assert!((fused.x_m - 0.05).abs() < 0.01, "{fused:?}");
        assert!(fused.y_m.abs() < 0.1 * 0.02, "{fused:?}");
        assert_eq!(fused.theta_rad, 0.0);
        // Held along by a door frame's 200 points, the fit stays.
        let held = fuse(fit, &corridor(100.0, 200.0), prior, 0.1, 0.0);
        assert!(held.x_m.abs() < 0.005, "{held:?}");
    }

    #[test]
    fn a_speed_observed_long_ago_tells_the_fit_little() {
        // Ten scans a second along a corridor held by 5 points: a speed observed on the last
        // step takes the prior mostly, one observed 2 s ago (the robot may have stopped since)
        // under a fifth of the way.
        let fit = Pose2::new(0.0, 0.0, 0.0);
        let prior = Pose2::new(0.05, 0.0, 0.0);
        let fresh = fuse(fit, &corridor(100.0, 5.0), prior, 0.1, 0.0);
        let stale = fuse(fit, &corridor(100.0, 5.0), prior, 0.1, 2.0);
        assert!(fresh.x_m > 0.025, "{fresh:?}");
        assert!(stale.x_m < 0.01, "{stale:?}");
    }

    #[test]
    fn at_one_scan_a_second_the_prior_tells_the_fit_next_to_nothing() {
        let fit = Pose2::new(0.0, 0.0, 0.0);
        let prior = Pose2::new(0.5, 0.0, 0.0);
        let fused = fuse(fit, &corridor(100.0, 1.0), prior, 1.0, 0.0);
        assert!(fused.x_m < 0.01, "{fused:?}");
    }

    #[test]
    fn round_a_circular_bend_the_fit_keeps_the_robot_on_the_bend() {
        // A bend of radius 8 m about (0, 8): the fit cannot tell a rotation about the centre,
        // (dx, dy, dθ) = (8, 0, 1)·φ, and holds every other direction by 400 points' worth.
        let null = DVec3::new(8.0, 0.0, 1.0).normalize();
        let h = (DMat3::IDENTITY
            - glam::DMat3::from_cols(null * null.x, null * null.y, null * null.z))
            * 400.0;
        let information = TranslationInformation {
            weakest: 0.0,
            strongest: 400.0,
            weakest_deg: 0.0,
            pose: [
                h.x_axis.x, h.y_axis.x, h.z_axis.x, h.y_axis.y, h.z_axis.y, h.z_axis.z,
            ],
        };
        // The prior drives 5 cm straight on; the fused pose goes 5 cm round the bend and turns
        // by 5 cm / 8 m with it.
        let fused = fuse(
            Pose2::IDENTITY,
            &information,
            Pose2::new(0.05, 0.0, 0.0),
            0.1,
            0.0,
        );
        assert!((fused.x_m - 0.05).abs() < 0.002, "{fused:?}");
        assert!((fused.theta_rad - 0.05 / 8.0).abs() < 0.0005, "{fused:?}");
    }
}
