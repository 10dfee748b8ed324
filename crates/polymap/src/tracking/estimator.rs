//! The fit and the motion prior in information form: where a scan's fit observes a direction
//! weakly, its pose takes the motion prior's in proportion.
//!
//! ICP's final correspondences give the fit's information over (x, y, θ)
//! ([`TranslationInformation::pose`]). The motion prior is one of two:
//!
//! - **the odometry's step** ([`odometry_information`]), with an error that grows with the
//!   distance driven and the turn, over translation and heading. It is weighed inside ICP
//!   ([`odometry_prior`], `align::PosePrior`): the pose the strategy chose is refined by ICP
//!   minimizing the fit plus the prior, so that along a direction the scan observes by a few
//!   points ICP does not first slide to the nearest pose the map's ends or a bend's chords pull
//!   it to. Fused after ICP instead, the fit's information at that pose (which counts the pull
//!   as evidence) outweighed or contradicted the odometry there: the simulated curved hallway
//!   ended 2.1–2.5 m off with odometry read without fault. Only where the weighed pose lies
//!   beyond the odometry's spread does the fit keep its own pose, which is then fused below;
//! - **without odometry, the previous pose moved by the speed last observed**
//!   ([`constant_velocity_information`]), spread as far as a robot's acceleration takes it from
//!   constant velocity in the time since the last scan and since its speed was last observed;
//!   translation only, its turn being the last observed step's, stale in a bend.
//!
//! The pose minimizing both quadratic forms is the fit's moved towards the prior by
//! `(H_fit + H_prior)⁻¹ H_prior (prior − fit)`: along a wall's normal the fit's hundreds of
//! points outweigh the prior; along a bare corridor, or round a circular bend (where the weak
//! direction turns the robot as it moves), a prior of a few millimetres outweighs a fit held by
//! a few points, whose pull is more often the map's end or a chord's kink than the robot's
//! motion. At one scan a second the constant-velocity prior spreads over half a metre and tells
//! the fit next to nothing. A prior the fit contradicts where the fit is sure (a slipping wheel)
//! is not fused at all. Without odometry the prior is fused after ICP: weighed inside it, the
//! constant-velocity prior mended the sparse logs but pushed a robot that stops in a corridor
//! on (`docs/decisions/2026-12-03-motion-prior-in-icp-measured.md`).
//!
//! The information the pose rests on (the fit's, with the prior's where it was fused or weighed)
//! gives its covariance ([`covariance_of`]): what a consumer of the pose (a ROS
//! `PoseWithCovarianceStamped`, `diagnostics.jsonl`) learns of how far to trust each direction.
//!
//! [`TranslationInformation::pose`]: crate::align::TranslationInformation::pose

use glam::{DMat3, DVec3};

use super::params::{
    FIT_VARIANCE_M2, ODOMETRY_FLOOR_M, ODOMETRY_PER_M, ODOMETRY_TURN_FLOOR_DEG,
    ODOMETRY_TURN_PER_M_DEG, ODOMETRY_TURN_SHARE, PRIOR_ACCEL_M_S2, PRIOR_FLOOR_M,
};
use crate::align::{PosePrior, TranslationInformation, symmetric_eigen};
use crate::geometry::{Pose2, normalize_angle_rad};

/// The variance of a direction nothing observed (a lost scan, a bare corridor's axis without a
/// motion prior), m² or rad²: "unknown", as the usual consumers of a ROS covariance read a huge
/// variance.
pub const UNKNOWN_VARIANCE: f64 = 1e4;

/// A pose's covariance over (x, y, θ), map frame, row-major: m², m·rad, rad².
pub type PoseCovariance = [[f64; 3]; 3];

/// The covariance of a pose that rests on `information` (over (x, y, θ), map frame, 1/m²,
/// 1/(m·rad), 1/rad²): its inverse, each direction whose variance would exceed
/// [`UNKNOWN_VARIANCE`] (or is not finite) held at it.
pub fn covariance_of(information: &DMat3) -> PoseCovariance {
    if !information.is_finite() {
        return unknown_covariance();
    }
    let (values, vectors) = symmetric_eigen(*information);
    let mut c = DMat3::ZERO;
    for (i, &value) in values.iter().enumerate() {
        let v = vectors.col(i);
        let variance = match value > 1.0 / UNKNOWN_VARIANCE {
            true => 1.0 / value,
            false => UNKNOWN_VARIANCE,
        };
        c += DMat3::from_cols(v * v.x, v * v.y, v * v.z) * variance;
    }
    c.transpose().to_cols_array_2d()
}

/// The covariance of a pose nothing observed: [`UNKNOWN_VARIANCE`] in every direction.
pub fn unknown_covariance() -> PoseCovariance {
    let u = UNKNOWN_VARIANCE;
    [[u, 0.0, 0.0], [0.0, u, 0.0], [0.0, 0.0, u]]
}

/// The fit's information over (x, y, θ), map frame, in 1/m² (and 1/rad²): ICP's final
/// correspondences' ([`TranslationInformation::pose`]) over [`FIT_VARIANCE_M2`], the variance
/// one weighted point is counted at.
///
/// [`TranslationInformation::pose`]: crate::align::TranslationInformation::pose
pub(super) fn fit_information(information: &TranslationInformation) -> DMat3 {
    let [xx, xy, xr, yy, yr, rr] = information.pose.map(|v| v / FIT_VARIANCE_M2);
    DMat3::from_cols_array(&[xx, xy, xr, xy, yy, yr, xr, yr, rr])
}

/// What the covariance takes from the fit: [`fit_information`] counted at the larger of
/// [`FIT_VARIANCE_M2`] and the fit's own residuals' mean square `residual_rms_m²` (a poor fit's
/// points say less), and as far as the verdict trusts it: where the fit observed its weakest
/// translation direction by under `weak_below` points' worth (`tracking.verdict.
/// weak_below_information`, the verdict `weakly_observed`), nothing along that direction, the
/// rest marginalized over it (what the fit says of the other directions without knowing that
/// one). A few points' pull there is more often the map's frontier or one feature matched to its
/// neighbour than the robot's motion (ACES every 10th scan: a corridor step 0.58 m short on 0.4
/// points' worth, whose fit alone said ±4.5 cm), so the pose's covariance there is the prior's,
/// or unknown.
pub(super) fn trusted_fit_information(
    information: &TranslationInformation,
    residual_rms_m: f64,
    weak_below: f64,
) -> DMat3 {
    let full = fit_information(information) * (FIT_VARIANCE_M2 / point_variance_m2(residual_rms_m));
    if information.weakest >= weak_below {
        return full;
    }
    // In the frame (u, u⊥, θ) of the weakest axis u: u's row and column out, the rest its
    // Schur complement.
    let u = information.weakest_axis();
    let to_axis = DMat3::from_cols(
        DVec3::new(u.x, -u.y, 0.0),
        DVec3::new(u.y, u.x, 0.0),
        DVec3::Z,
    );
    let h = to_axis * full * to_axis.transpose();
    let huu = h.x_axis.x;
    let coupling = DVec3::new(0.0, h.x_axis.y, h.x_axis.z);
    let mut rest = match huu > 0.0 && huu.is_finite() {
        true => {
            h - DMat3::from_cols(
                coupling * coupling.x,
                coupling * coupling.y,
                coupling * coupling.z,
            ) / huu
        }
        false => h,
    };
    rest.x_axis = DVec3::ZERO;
    rest.y_axis.x = 0.0;
    rest.z_axis.x = 0.0;
    to_axis.transpose() * rest * to_axis
}

/// The motion prior's information over (x, y, θ) under `model` (1/m², 1/rad²).
pub(super) fn prior_information(model: MotionModel) -> DMat3 {
    match model {
        MotionModel::ConstantVelocity { dt_s, age_s } => constant_velocity_information(dt_s, age_s),
        MotionModel::Odometry { step } => odometry_information(&step),
    }
}

/// The prior moves a fit only where its information reaches this share of the fit's along the
/// fit's weakest direction (it then moves the pose by at least a tenth of the way).
const PRIOR_SIGNIFICANT_SHARE: f64 = 0.1;

/// A prior further from the fit than this, in the squared Mahalanobis distance of their
/// difference under both errors together, contradicts it and is not fused: 16.3 is the 99.9 %
/// point of χ² with three degrees of freedom (a slipping wheel's odometry beside a fit that
/// observed the step).
const PRIOR_CONTRADICTS_CHI2: f64 = 16.3;

/// The constant-velocity prior's information over (x, y, θ) (1/m², and none on the heading:
/// its turn is the last observed step's, stale in a bend), `dt_s` seconds after the scan it
/// moves on from, its speed last observed `age_s` seconds before that scan: spread as far as
/// a robot's acceleration takes it from constant velocity in that time.
fn constant_velocity_information(dt_s: f64, age_s: f64) -> DMat3 {
    // Since the speed was last observed (`age_s` before this step) it may have changed by the
    // acceleration times that age, and this step by that times its time.
    let spread_m = PRIOR_FLOOR_M + PRIOR_ACCEL_M_S2 * dt_s * (0.5 * dt_s + age_s.max(0.0));
    let along = 1.0 / (spread_m * spread_m);
    DMat3::from_diagonal(DVec3::new(along, along, 0.0))
}

/// The variance a fit's weighted point is counted at, m²: [`FIT_VARIANCE_M2`], or the fit's
/// residuals' mean square where that is larger (a poor fit says less).
fn point_variance_m2(residual_rms_m: f64) -> f64 {
    FIT_VARIANCE_M2.max(residual_rms_m * residual_rms_m)
}

/// A fit's standard deviation along its weakest translation direction, metres
/// ([`TranslationInformation::weakest`] points' worth, each at [`point_variance_m2`]).
///
/// [`TranslationInformation::weakest`]: crate::align::TranslationInformation::weakest
pub(super) fn weakest_sigma_m(information: &TranslationInformation, residual_rms_m: f64) -> f64 {
    (point_variance_m2(residual_rms_m) / information.weakest.max(f64::MIN_POSITIVE)).sqrt()
}

/// How far the robot may be from the constant-velocity prediction `dt_s` seconds after the
/// scan it moves on from, its speed known to `speed_sigma_m_s` (m/s, one standard deviation;
/// [`ObservedSpeed::weigh`]), metres, one standard deviation: the floor, the speed's error
/// over the step, and half the acceleration's ([`acceleration_sigma_m_s2`]) over it.
///
/// [`ObservedSpeed::weigh`]: super::speed::ObservedSpeed::weigh
pub(super) fn speed_spread_m(dt_s: f64, speed_sigma_m_s: f64) -> f64 {
    PRIOR_FLOOR_M + dt_s * (speed_sigma_m_s + 0.5 * acceleration_sigma_m_s2() * dt_s)
}

/// The standard deviation of a robot's acceleration where the speed's spread judges a pose,
/// m/s²: [`PRIOR_ACCEL_M_S2`], the largest, put at the point the judgement stops at
/// ([`SPEED_CONTRADICTS_CHI2`], 3.7 standard deviations). Counted as one standard deviation,
/// it let a pose lie 3.7 times as far from the prediction as a robot's largest acceleration
/// takes it: in the simulated ring at every 5th scan (a 360° laser, seed 3), after two
/// ambiguous scans in the bare hallway the spread had grown from 0.14 to 0.48 m, and a pose
/// 0.99 m behind the prediction of a robot going 0.25 m a scan (a speed change of 2 m/s in
/// 0.5 s) passed it, one of five such jumps back and forth (0.39 m ATE, no warning naming a
/// place; 0.06 m with this).
pub(super) fn acceleration_sigma_m_s2() -> f64 {
    PRIOR_ACCEL_M_S2 / SPEED_CONTRADICTS_CHI2.sqrt()
}

/// A pose further from the constant-velocity prediction than this, in the squared distance of
/// their translations over [`speed_spread_m`] squared, lies where the robot could be only if
/// its speed changed beyond a robot's acceleration: 13.8 is the 99.9 % point of χ² with two
/// degrees of freedom (the prediction holds no heading).
const SPEED_CONTRADICTS_CHI2: f64 = 13.8;

/// Whether `pose` (map frame) lies beyond the constant-velocity prediction `prediction` (map
/// frame) spread by `spread_m` ([`speed_spread_m`], [`SPEED_CONTRADICTS_CHI2`]).
pub(super) fn speed_contradicts(prediction: &Pose2, pose: &Pose2, spread_m: f64) -> bool {
    let d = pose.translation().distance(prediction.translation()) / spread_m;
    d.is_nan() || d * d > SPEED_CONTRADICTS_CHI2
}

/// The odometry prior's information over (x, y, θ) (1/m², 1/rad²) for a step the odometry
/// read as `step` (robot frame of the scan before): its error grows with the distance driven
/// and the turn, from a floor.
fn odometry_information(step: &Pose2) -> DMat3 {
    let driven_m = step.translation().length();
    let spread_m = ODOMETRY_FLOOR_M + ODOMETRY_PER_M * driven_m;
    let turn_deg = ODOMETRY_TURN_FLOOR_DEG
        + ODOMETRY_TURN_SHARE * normalize_angle_rad(step.theta_rad).abs().to_degrees()
        + ODOMETRY_TURN_PER_M_DEG * driven_m;
    let turn_rad = turn_deg.to_radians();
    DMat3::from_diagonal(DVec3::new(
        1.0 / (spread_m * spread_m),
        1.0 / (spread_m * spread_m),
        1.0 / (turn_rad * turn_rad),
    ))
}

/// The odometry's step as the prior ICP weighs with the fit ([`PosePrior`]): the guess
/// (map frame, the previous pose moved by `step`) with [`odometry_information`] in the fit's
/// units (the information per m² times [`FIT_VARIANCE_M2`], the variance one weighted point
/// is counted at).
pub(super) fn odometry_prior(guess: Pose2, step: &Pose2) -> PosePrior {
    PosePrior {
        pose: guess,
        information: odometry_information(step) * FIT_VARIANCE_M2,
    }
}

/// Whether `pose` (map frame) lies where the robot could be, after the odometry read a step of
/// `step` (robot frame of the scan before) to `guess` (map frame), only if the odometry failed:
/// the squared Mahalanobis distance of their difference under the odometry's spread
/// ([`odometry_information`]) over [`PRIOR_CONTRADICTS_CHI2`].
pub(super) fn odometry_contradicts(guess: &Pose2, pose: &Pose2, step: &Pose2) -> bool {
    let off = guess.offset_to(pose);
    let distance = off.dot(odometry_information(step) * off);
    distance.is_nan() || distance > PRIOR_CONTRADICTS_CHI2
}

/// Where the motion prior comes from, and what spreads it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum MotionModel {
    /// The previous pose moved by the speed last observed, `dt_s` seconds after the scan it
    /// moves on from, the speed last observed `age_s` seconds before that scan
    /// ([`constant_velocity_information`]).
    ConstantVelocity { dt_s: f64, age_s: f64 },
    /// The log's odometry, which read the step as `step` (robot frame of the scan before;
    /// [`odometry_information`]).
    Odometry { step: Pose2 },
}

/// A pose from the fit and the motion prior ([`fuse`]), and whether it rests on the prior.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Fused {
    /// The pose, map frame.
    pub pose: Pose2,
    /// Whether the pose rests on the prior as well as the fit: false where the prior
    /// contradicted the fit, or where the step towards it was not finite.
    pub with_prior: bool,
}

/// The pose that best agrees with the fit (`fit`, map frame, its information `information`,
/// [`TranslationInformation::pose`]) and the motion prior (`prior`, map frame, spread as
/// `model` says): the fit where it is observed, the prior in proportion where the fit is weak.
/// The fit itself when the prior is too weak to matter, when the information is not finite,
/// or when odometry contradicts the fit ([`PRIOR_CONTRADICTS_CHI2`]; the speed prior is not
/// tested: measured, that moved Intel 0.0263 → 0.0278 m, a fit that disagrees with the speed
/// being more often the wrong one than a robot that changed its speed). The pose rests on the
/// prior too ([`Fused::with_prior`]) unless the prior contradicted the fit or the step towards
/// it was not finite: a prior too weak to move the pose still counts in its covariance.
///
/// [`TranslationInformation::pose`]: crate::align::TranslationInformation::pose
pub(super) fn fuse(
    fit: Pose2,
    information: &TranslationInformation,
    prior: Pose2,
    model: MotionModel,
) -> Fused {
    let prior_information = prior_information(model);
    let tested = matches!(model, MotionModel::Odometry { .. });
    let fit_information = fit_information(information);
    let alone = Fused {
        pose: fit,
        with_prior: false,
    };
    let towards = fit.offset_to(&prior);
    let both = (fit_information + prior_information).inverse();
    // (H_fit⁻¹ + H_prior⁻¹)⁻¹ = H_prior (H_fit + H_prior)⁻¹ H_fit, finite where either is.
    let contradiction = towards.dot(prior_information * (both * (fit_information * towards)));
    let contradicts = tested && (contradiction.is_nan() || contradiction > PRIOR_CONTRADICTS_CHI2);
    if contradicts {
        return alone;
    }
    let rests_on = Fused {
        pose: fit,
        with_prior: true,
    };
    // A prior that would move the pose by under a tenth of its distance from the fit even along
    // the fit's weakest direction leaves the fit where it is: millimetres that change nothing
    // but which later decisions they tip (its information still counts).
    let along = prior_information.x_axis.x.min(prior_information.y_axis.y);
    if along < PRIOR_SIGNIFICANT_SHARE * information.weakest / FIT_VARIANCE_M2 {
        return rests_on;
    }
    let delta = both * (prior_information * towards);
    if !delta.is_finite() {
        return alone;
    }
    Fused {
        pose: Pose2::new(
            fit.x_m + delta.x,
            fit.y_m + delta.y,
            fit.theta_rad + delta.z,
        ),
        ..rests_on
    }
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

    /// The constant-velocity prior `dt_s` after the last scan, its speed `age_s` old.
    fn speed(dt_s: f64, age_s: f64) -> MotionModel {
        MotionModel::ConstantVelocity { dt_s, age_s }
    }

    /// The information of a fit round a bend of radius 8 m about (0, 8): it cannot tell a
    /// rotation about the centre, (dx, dy, dθ) = (8, 0, 1)·φ, and holds every other direction by
    /// 400 points' worth.
    fn bend() -> TranslationInformation {
        let null = DVec3::new(8.0, 0.0, 1.0).normalize();
        let h = (DMat3::IDENTITY
            - glam::DMat3::from_cols(null * null.x, null * null.y, null * null.z))
            * 400.0;
        TranslationInformation {
            weakest: 0.0,
            strongest: 400.0,
            weakest_deg: 0.0,
            pose: [
                h.x_axis.x, h.y_axis.x, h.z_axis.x, h.y_axis.y, h.z_axis.y, h.z_axis.z,
            ],
        }
    }

    /// At ten scans a second, a speed known to 0.1 m/s spreads the prediction by 1.6 cm: a
    /// pose 6 cm off (3.7 spreads, χ² 13.5) is within it, one 6.2 cm off (χ² 14.4) is not,
    /// and one 0.84 m behind a robot going 0.15 m a scan is far beyond.
    #[test]
    fn a_pose_beyond_the_speeds_spread_contradicts_it() {
        let spread = speed_spread_m(0.1, 0.1);
        let expected = 0.005 + 0.1 * (0.1 + 0.5 * 0.1 / 13.8f64.sqrt());
        assert!((spread - expected).abs() < 1e-12, "{spread}");
        let prediction = Pose2::new(3.0, 1.0, 0.4);
        let at = |dx: f64| Pose2::new(3.0 + dx, 1.0, 1.2);
        assert!(!speed_contradicts(&prediction, &at(0.06), spread));
        assert!(speed_contradicts(&prediction, &at(-0.062), spread));
        assert!(speed_contradicts(&prediction, &at(-0.84), spread));
        // The heading is the fit's: the prediction holds none.
        assert!(!speed_contradicts(
            &prediction,
            &Pose2::new(3.0, 1.0, -2.0),
            spread
        ));
    }

    /// A robot's largest acceleration bounds the speed's spread at the point the judgement
    /// stops at: two scans a second, the speed observed to 1 cm/s, then two steps unobserved
    /// (the simulated ring's bare hallway): a pose 0.99 m behind the prediction of a robot
    /// going 0.5 m/s would take a speed change of 2 m/s in half a second, and contradicts
    /// the speed (with the largest acceleration as one standard deviation it did not: the
    /// spread had grown to 0.48 m); one 0.4 m off, a robot that braked hard, does not.
    #[test]
    fn the_largest_acceleration_bounds_the_speeds_spread() {
        let mut speed = crate::tracking::speed::ObservedSpeed::default();
        speed.weigh(Some(0.005), Some(0.5));
        speed.weigh(None, Some(0.5));
        speed.weigh(None, Some(0.5));
        let spread = speed_spread_m(0.5, speed.speed_sigma_m_s().expect("a spread"));
        let prediction = Pose2::new(3.0, 1.0, 0.0);
        let behind = |m: f64| Pose2::new(3.0 - m, 1.0, 0.0);
        assert!(
            speed_contradicts(&prediction, &behind(0.99), spread),
            "{spread}"
        );
        assert!(
            !speed_contradicts(&prediction, &behind(0.4), spread),
            "{spread}"
        );
    }

    #[test]
    fn a_pose_beyond_the_odometrys_spread_contradicts_it() {
        let guess = Pose2::new(2.0, 1.0, 0.5);
        // A step of 0.5 m and 30°: spread 5.5 cm, and 4.5° in the heading.
        let step = Pose2::new(0.5, 0.0, 30f64.to_radians());
        let off = |x: f64, y: f64, deg: f64| {
            let pose = Pose2::new(
                guess.x_m + x,
                guess.y_m + y,
                guess.theta_rad + deg.to_radians(),
            );
            odometry_contradicts(&guess, &pose, &step)
        };
        assert!(!off(0.0, 0.0, 0.0));
        assert!(!off(0.1, 0.0, 0.0) && off(0.25, 0.0, 0.0));
        assert!(!off(0.0, -0.1, 5.0) && off(0.0, 0.0, 20.0));
        assert!(off(0.0, 0.0, 90.0) && off(0.0, 0.0, -270.0));
        // Across ±180°: 3.1 and −3.1 rad are 4.7° apart.
        let back = Pose2::new(0.0, 0.0, 3.1);
        let across = Pose2 {
            theta_rad: -3.1,
            ..back
        };
        assert!(!odometry_contradicts(&back, &across, &step));
        assert!(odometry_contradicts(
            &guess,
            &Pose2::new(f64::NAN, 0.0, 0.0),
            &step
        ));
    }

    #[test]
    fn a_bare_corridor_takes_the_prior_along_it_and_the_fit_across() {
        let fit = Pose2::new(0.0, 0.0, 0.0);
        let prior = Pose2::new(0.05, 0.02, 0.01);
        // Ten scans a second, a corridor seen by 100 points a wall, held along by 1 point.
        let fused = fuse(fit, &corridor(100.0, 1.0), prior, speed(0.1, 0.0)).pose;
        // Along the corridor the prior's 5 cm nearly all; across it a tenth of its 2 cm at most.
        assert!((fused.x_m - 0.05).abs() < 0.01, "{fused:?}");
        assert!(fused.y_m.abs() < 0.1 * 0.02, "{fused:?}");
        assert_eq!(fused.theta_rad, 0.0);
        // Held along by a door frame's 200 points, the fit stays.
        let held = fuse(fit, &corridor(100.0, 200.0), prior, speed(0.1, 0.0)).pose;
        assert!(held.x_m.abs() < 0.005, "{held:?}");
    }

    #[test]
    fn a_speed_observed_long_ago_tells_the_fit_little() {
        // Ten scans a second along a corridor held by 5 points: a speed observed on the last
        // step takes the prior mostly, one observed 2 s ago (the robot may have stopped since)
        // under a fifth of the way.
        let fit = Pose2::new(0.0, 0.0, 0.0);
        let prior = Pose2::new(0.05, 0.0, 0.0);
        let fresh = fuse(fit, &corridor(100.0, 5.0), prior, speed(0.1, 0.0)).pose;
        let stale = fuse(fit, &corridor(100.0, 5.0), prior, speed(0.1, 2.0)).pose;
        assert!(fresh.x_m > 0.025, "{fresh:?}");
        assert!(stale.x_m < 0.01, "{stale:?}");
    }

    #[test]
    fn at_one_scan_a_second_the_prior_tells_the_fit_next_to_nothing() {
        let fit = Pose2::new(0.0, 0.0, 0.0);
        let prior = Pose2::new(0.5, 0.0, 0.0);
        let fused = fuse(fit, &corridor(100.0, 1.0), prior, speed(1.0, 0.0)).pose;
        assert!(fused.x_m < 0.01, "{fused:?}");
    }

    #[test]
    fn round_a_bend_the_odometry_holds_the_turn_with_the_travel() {
        // The bend of the test below, now with odometry: the step straight on by 5 cm at ten
        // scans a second while the fit, held by nothing along the bend, stayed put.
        let information = bend();
        let step = Pose2::new(0.05, 0.0, 0.05 / 8.0);
        let fused = fuse(
            Pose2::IDENTITY,
            &information,
            step,
            MotionModel::Odometry { step },
        )
        .pose;
        assert!((fused.x_m - 0.05).abs() < 0.002, "{fused:?}");
        assert!((fused.theta_rad - 0.05 / 8.0).abs() < 0.0005, "{fused:?}");
    }

    #[test]
    fn odometry_that_slipped_beside_a_sure_fit_is_not_fused() {
        // A corridor along x held along by a door frame's 5 points. The wheels read 0.25 m where
        // the fit saw 0.05 m: the fit stays exactly. Read 0.055 m, the odometry is fused.
        let information = TranslationInformation {
            weakest: 5.0,
            strongest: 300.0,
            weakest_deg: 0.0,
            pose: [5.0, 0.0, 0.0, 300.0, 0.0, 3000.0],
        };
        let fit = Pose2::new(0.05, 0.0, 0.0);
        let read = |step: Pose2| fuse(fit, &information, step, MotionModel::Odometry { step });
        let slipped = read(Pose2::new(0.25, 0.0, 0.0));
        // Not fused, the odometry is not what the pose rests on (its covariance).
        assert_eq!((slipped.pose, slipped.with_prior), (fit, false));
        let near = Pose2::new(0.055, 0.0, 0.0);
        let fused = read(near);
        assert!(fused.with_prior);
        let fused = fused.pose;
        assert!(fused.x_m > fit.x_m && fused.x_m < near.x_m, "{fused:?}");
    }

    #[test]
    fn the_odometry_spreads_with_the_distance_and_the_turn() {
        let still = odometry_information(&Pose2::IDENTITY);
        let driven = odometry_information(&Pose2::new(1.0, 0.0, 0.0));
        let turned = odometry_information(&Pose2::new(0.0, 0.0, 1.0));
        assert!(driven.x_axis.x < still.x_axis.x / 100.0);
        assert!(driven.z_axis.z < still.z_axis.z);
        assert!(turned.z_axis.z < still.z_axis.z);
        assert_eq!(turned.x_axis.x, still.x_axis.x);
    }

    #[test]
    fn round_a_circular_bend_the_fit_keeps_the_robot_on_the_bend() {
        // The fit round the bend (`bend`) and the prior straight on.
        let information = bend();
        // The prior drives 5 cm straight on; the fused pose goes 5 cm round the bend and turns
        // by 5 cm / 8 m with it.
        let fused = fuse(
            Pose2::IDENTITY,
            &information,
            Pose2::new(0.05, 0.0, 0.0),
            speed(0.1, 0.0),
        )
        .pose;
        assert!((fused.x_m - 0.05).abs() < 0.002, "{fused:?}");
        assert!((fused.theta_rad - 0.05 / 8.0).abs() < 0.0005, "{fused:?}");
    }

    #[test]
    fn the_covariance_is_the_information_inverted_and_unknown_where_nothing_observed() {
        // A corridor along x: 100 points a wall, 1 point's worth along it. Alone, the fit leaves
        // the corridor's axis unknown-ish (0.0008 m² over one point's information) and holds
        // across it by two hundred points.
        let fit = corridor(100.0, 1.0);
        let alone = covariance_of(&fit_information(&fit));
        assert!((alone[0][0] - FIT_VARIANCE_M2).abs() < 1e-9, "{alone:?}");
        assert!(
            (alone[1][1] - FIT_VARIANCE_M2 / 200.0).abs() < 1e-9,
            "{alone:?}"
        );
        assert_eq!(alone[0][1], alone[1][0]);
        // Not observed at all along it: unknown there, and only there.
        let bare = covariance_of(&fit_information(&corridor(100.0, 0.0)));
        assert_eq!(bare[0][0], UNKNOWN_VARIANCE);
        assert!(bare[1][1] < 1e-4, "{bare:?}");
        assert_eq!(covariance_of(&DMat3::ZERO), unknown_covariance());
        assert_eq!(
            covariance_of(&(DMat3::IDENTITY * f64::NAN)),
            unknown_covariance()
        );
        // Fused with the speed prior at ten scans a second, the pose along the corridor rests
        // on the prior: its variance is about the prior's (5 mm plus 1 m/s² × 0.1 s × 0.05 s).
        let fused = fuse(
            Pose2::IDENTITY,
            &corridor(100.0, 0.0),
            Pose2::new(0.05, 0.0, 0.0),
            speed(0.1, 0.0),
        );
        assert!(fused.with_prior);
        let rests_on = fit_information(&corridor(100.0, 0.0)) + prior_information(speed(0.1, 0.0));
        let along = covariance_of(&rests_on)[0][0];
        let spread_m = PRIOR_FLOOR_M + PRIOR_ACCEL_M_S2 * 0.1 * 0.05;
        assert!((along - spread_m * spread_m).abs() < 1e-6, "{along}");
        // Observed along it by 1 point's worth, under the verdict's 5: the covariance takes
        // nothing from the fit there (unknown without a prior), and all of it across.
        let trusted = covariance_of(&trusted_fit_information(&fit, 0.0, 5.0));
        assert_eq!(trusted[0][0], UNKNOWN_VARIANCE);
        assert!(
            (trusted[1][1] - FIT_VARIANCE_M2 / 200.0).abs() < 1e-9,
            "{trusted:?}"
        );
        assert_eq!(
            trusted_fit_information(&fit, 0.01, 1.0),
            fit_information(&fit),
            "observed by as many points as the verdict asks"
        );
    }

    #[test]
    fn the_covariance_of_a_coupled_fit_is_its_inverse_and_a_weak_axis_at_an_angle_leaves_it() {
        // A fit coupled in every direction (a corridor at 30° seen with a door frame ahead):
        // the covariance is the matrix's inverse.
        let pose = [40.0, 12.0, 3.0, 25.0, -4.0, 900.0];
        let information = TranslationInformation {
            weakest: 2.0,
            strongest: 50.0,
            weakest_deg: 30.0,
            pose,
        };
        let h = fit_information(&information);
        let c = covariance_of(&h);
        let inverse = h.inverse().to_cols_array_2d();
        for (row, want) in c.iter().zip(inverse) {
            for (got, want) in row.iter().zip(want) {
                assert!((got - want).abs() < 1e-9 * want.abs().max(1e-9), "{c:?}");
            }
        }
        // Trusted with the verdict's 5: nothing along 30°, and across it what the fit says
        // without knowing the position along it (the Schur complement over that axis).
        let trusted = trusted_fit_information(&information, 0.0, 5.0);
        let u = DVec3::new(30f64.to_radians().cos(), 30f64.to_radians().sin(), 0.0);
        assert!((trusted * u).length() < 1e-6 * h.x_axis.x, "{trusted:?}");
        let across = DVec3::new(-u.y, u.x, 0.0);
        let (hua, huu, haa) = (u.dot(h * across), u.dot(h * u), across.dot(h * across));
        let want = haa - hua * hua / huu;
        assert!(
            (across.dot(trusted * across) - want).abs() < 1e-6 * haa,
            "{trusted:?}"
        );
        // A fit whose residuals are 5 cm says less than one at the counted 2.8 cm.
        let poor = trusted_fit_information(&information, 0.05, 0.0);
        assert!((poor.x_axis.x - h.x_axis.x * FIT_VARIANCE_M2 / 0.0025).abs() < 1e-9 * h.x_axis.x);
    }
}
