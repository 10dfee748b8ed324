//! The odometry model: true motion increments, corrupted step by step and integrated.
//!
//! Each step's true motion (the robot's motion in its own frame between two scans) is scaled
//! by a systematic bias plus random noise, given additive noise, and the heading picks up a
//! steady drift per metre driven (as with unequal wheel diameters). The noisy steps are
//! composed, so errors accumulate the way real dead reckoning does: heading errors turn into
//! position errors that grow with distance.

use polymap::geometry::Pose2;
use rand::{Rng, RngExt};
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

/// Below this, a step counts as standing still and gets no additive noise (metres or radians).
const STILL: f64 = 1e-9;

/// Odometry noise. Defaults give a few degrees and a metre or two of drift over an 80 m loop,
/// like a differential-drive indoor robot on a good floor; every noise term is per scan step.
///
/// ```
/// use polymap_sim::OdometryParams;
/// let o = OdometryParams::default();
/// assert!(o.enabled);
/// assert_eq!(o.translation_scale_bias, 0.01);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct OdometryParams {
    /// Fill `odom_from_robot` into the scans. Default true.
    pub enabled: bool,
    /// Odometry pose at the first scan. Default identity: the odometry frame is the first
    /// robot pose, the same frame a mapper that starts at identity builds its map in.
    pub initial_odom_from_robot: Pose2,
    /// Systematic relative error of distances (0.01: odometry reads 1 % long). Default 0.01.
    pub translation_scale_bias: f64,
    /// Systematic relative error of turns (0.01: turns read 1 % large). Default 0.01.
    pub rotation_scale_bias: f64,
    /// Steady heading drift per metre driven, rad/m. Default 0.05°/m (8.7e-4 rad/m).
    pub heading_drift_rad_per_m: f64,
    /// Standard deviation of the random relative error of each step's distance. Default 0.02.
    pub translation_sigma_frac: f64,
    /// Standard deviation of the random relative error of each step's turn. Default 0.02.
    pub rotation_sigma_frac: f64,
    /// Standard deviation of each step's sideways slip, as a fraction of its distance.
    /// Default 0.01.
    pub lateral_sigma_frac: f64,
    /// Standard deviation of each moving step's additive distance noise, metres. Default 0.001.
    pub translation_sigma_m: f64,
    /// Standard deviation of each moving step's additive turn noise, radians. Default 0.0005
    /// (0.03°).
    pub rotation_sigma_rad: f64,
}

impl Default for OdometryParams {
    fn default() -> Self {
        OdometryParams {
            enabled: true,
            initial_odom_from_robot: Pose2::IDENTITY,
            translation_scale_bias: 0.01,
            rotation_scale_bias: 0.01,
            heading_drift_rad_per_m: 0.05f64.to_radians(),
            translation_sigma_frac: 0.02,
            rotation_sigma_frac: 0.02,
            lateral_sigma_frac: 0.01,
            translation_sigma_m: 0.001,
            rotation_sigma_rad: 0.0005,
        }
    }
}

impl OdometryParams {
    /// Perfect odometry: every bias and noise term zero.
    pub fn exact() -> Self {
        OdometryParams {
            translation_scale_bias: 0.0,
            rotation_scale_bias: 0.0,
            heading_drift_rad_per_m: 0.0,
            translation_sigma_frac: 0.0,
            rotation_sigma_frac: 0.0,
            lateral_sigma_frac: 0.0,
            translation_sigma_m: 0.0,
            rotation_sigma_rad: 0.0,
            ..OdometryParams::default()
        }
    }

    /// One step's measured motion for the true motion `robot0_from_robot1`. Draws five
    /// standard normals from `rng`, always.
    pub fn noisy_step<R: Rng + ?Sized>(&self, robot0_from_robot1: &Pose2, rng: &mut R) -> Pose2 {
        let n: [f64; 5] = std::array::from_fn(|_| rng.sample(StandardNormal));
        let d = robot0_from_robot1.translation();
        let dist = d.length();
        let turn = robot0_from_robot1.theta_rad;
        let moving = if dist > STILL || turn.abs() > STILL {
            1.0
        } else {
            0.0
        };
        let along = d.normalize_or_zero();
        let side = along.perp();
        let scale = 1.0 + self.translation_scale_bias + self.translation_sigma_frac * n[0];
        let t = d * scale
            + along * (self.translation_sigma_m * n[1] * moving)
            + side * (self.lateral_sigma_frac * dist * n[2]);
        let theta = turn * (1.0 + self.rotation_scale_bias + self.rotation_sigma_frac * n[3])
            + self.rotation_sigma_rad * n[4] * moving
            + self.heading_drift_rad_per_m * dist;
        Pose2::new(t.x, t.y, theta)
    }
}

/// Odometry poses (`odom_from_robot`) for a sequence of true poses (`map_from_robot`).
///
/// ```
/// use polymap::geometry::Pose2;
/// use polymap_sim::{OdometryParams, odometry::odometry};
/// use rand::SeedableRng;
/// let truth = [Pose2::new(5.0, 5.0, 1.0), Pose2::new(5.0, 6.0, 1.0)];
/// let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
/// let odom = odometry(&truth, &OdometryParams::exact(), &mut rng);
/// assert_eq!(odom[0], Pose2::IDENTITY);
/// let step = odom[0].between(&odom[1]);
/// let truth_step = truth[0].between(&truth[1]);
/// assert!((step.translation() - truth_step.translation()).length() < 1e-12);
/// ```
pub fn odometry<R: Rng + ?Sized>(
    true_poses: &[Pose2],
    params: &OdometryParams,
    rng: &mut R,
) -> Vec<Pose2> {
    let mut out = Vec::with_capacity(true_poses.len());
    let mut odom_from_robot = params.initial_odom_from_robot;
    for (k, pose) in true_poses.iter().enumerate() {
        if k > 0 {
            let step = true_poses[k - 1].between(pose);
            odom_from_robot = odom_from_robot.compose(&params.noisy_step(&step, rng));
        }
        out.push(odom_from_robot);
    }
    out
}

#[cfg(test)]
mod tests {
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    use super::*;

    /// A robot driving a 10 m square, 0.05 m per step.
    fn square_drive() -> Vec<Pose2> {
        let mut poses = vec![Pose2::IDENTITY];
        for side in 0..4 {
            for _ in 0..200 {
                let last = poses[poses.len() - 1];
                poses.push(last.compose(&Pose2::new(0.05, 0.0, 0.0)));
            }
            let last = poses[poses.len() - 1];
            poses.push(Pose2::new(
                last.x_m,
                last.y_m,
                (side + 1) as f64 * std::f64::consts::FRAC_PI_2,
            ));
        }
        poses
    }

    #[test]
    fn standing_still_does_not_drift() {
        let truth = vec![Pose2::new(1.0, 2.0, 0.3); 50];
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let odom = odometry(&truth, &OdometryParams::default(), &mut rng);
        assert!(
            odom.iter()
                .all(|p| p.translation().length() < 1e-12 && p.theta_rad.abs() < 1e-12)
        );
    }

    #[test]
    fn error_grows_with_distance() {
        let truth = square_drive();
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let odom = odometry(&truth, &OdometryParams::default(), &mut rng);
        let err =
            |k: usize| (truth[0].between(&truth[k]).translation() - odom[k].translation()).length();
        let (early, late) = (err(100), err(truth.len() - 1));
        assert!(
            late > 3.0 * early && late > 0.2,
            "early {early} late {late}"
        );
    }

    #[test]
    fn exact_odometry_matches_truth() {
        let truth = square_drive();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let odom = odometry(&truth, &OdometryParams::exact(), &mut rng);
        let end = truth[0].between(&truth[truth.len() - 1]);
        assert!((odom[odom.len() - 1].translation() - end.translation()).length() < 1e-9);
    }
}
