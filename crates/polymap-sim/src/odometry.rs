//! The odometry model: true motion increments, corrupted step by step and integrated.
//!
//! Each step's true motion (the robot's motion in its own frame between two scans) is scaled
//! by a systematic bias plus random noise, given additive noise, and the heading picks up a
//! steady drift per metre driven (as with unequal wheel diameters). The noisy steps are
//! composed, so errors accumulate the way real dead reckoning does: heading errors turn into
//! position errors that grow with distance.
//!
//! [`OdometryFaults`] adds what a bad odometry does, before that noise: slips (for a while the
//! wheels report more or less motion than the robot made), a heading bias (turns read tens of
//! degrees off) and a stalled wheel (one wheel reads zero, so the odometry turns while the
//! robot goes straight). All are off by default; their random draws come from a generator of
//! their own, so turning them on leaves the noise of every other step unchanged.

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
    /// Gross faults: slips, heading bias, a stalled wheel. Default: none.
    pub faults: OdometryFaults,
}

/// Gross odometry faults, applied to each step's true motion before the noise of
/// [`OdometryParams`]. Every fault is off by default.
///
/// ```
/// use polymap_sim::odometry::OdometryFaults;
/// assert!(!OdometryFaults::default().any());
/// assert!(OdometryFaults::bad().any());
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct OdometryFaults {
    /// Chance per scan step that a slip starts (when none is under way), in `[0, 1]`. Default
    /// 0 (off).
    pub slip_probability: f64,
    /// Length of a slip, scan steps. Default 10 (1 s at 10 Hz).
    pub slip_steps: u32,
    /// During a slip, each step's distance and turn read as the true ones times a factor
    /// drawn once per slip, uniformly in `[0, slip_max_factor]`: below 1 the odometry misses
    /// motion the robot made, above 1 it reports motion the robot did not make. Default 3.
    pub slip_max_factor: f64,
    /// Relative error of every turn (0.3: a 90° turn reads 117°), on top of
    /// [`OdometryParams::rotation_scale_bias`]. Default 0 (off).
    pub turn_bias_frac: f64,
    /// Chance per scan step that one wheel stalls (when no stall is under way), in `[0, 1]`:
    /// it reads zero distance, the other reads its true distance. Default 0 (off).
    pub stall_probability: f64,
    /// Length of a stall, scan steps. Default 20 (2 s at 10 Hz).
    pub stall_steps: u32,
    /// Distance between the two wheels, metres: turns wheel distances into a turn during a
    /// stall. Default 0.4 (at 0.05 m per step straight ahead, a stall reads 7.2° per step).
    pub wheel_base_m: f64,
}

impl Default for OdometryFaults {
    fn default() -> Self {
        OdometryFaults {
            slip_probability: 0.0,
            slip_steps: 10,
            slip_max_factor: 3.0,
            turn_bias_frac: 0.0,
            stall_probability: 0.0,
            stall_steps: 20,
            wheel_base_m: 0.4,
        }
    }
}

impl OdometryFaults {
    /// A bad odometry: a slip every 30 s and a stall every 60 s on average (at 10 Hz), turns
    /// read 30 % large (a 90° turn reads 117°).
    pub fn bad() -> Self {
        OdometryFaults {
            slip_probability: 1.0 / 300.0,
            turn_bias_frac: 0.3,
            stall_probability: 1.0 / 600.0,
            ..OdometryFaults::default()
        }
    }

    /// Whether any fault is on.
    pub fn any(&self) -> bool {
        self.slip_probability > 0.0 || self.turn_bias_frac != 0.0 || self.stall_probability > 0.0
    }
}

/// Slips and stalls under way while the odometry is integrated.
#[derive(Debug, Clone, Copy, Default)]
struct FaultState {
    /// Steps left in the current slip, and its factor.
    slip: (u32, f64),
    /// Steps left in the current stall, and whether the left wheel is the stalled one.
    stall: (u32, bool),
}

impl OdometryFaults {
    /// The step `robot0_from_robot1` as the faulty wheels report it. Draws four uniforms from
    /// `rng`, always.
    fn apply<R: Rng + ?Sized>(
        &self,
        robot0_from_robot1: &Pose2,
        state: &mut FaultState,
        rng: &mut R,
    ) -> Pose2 {
        let u: [f64; 4] = std::array::from_fn(|_| rng.random::<f64>());
        if state.slip.0 == 0 && u[0] < self.slip_probability {
            state.slip = (self.slip_steps, u[1] * self.slip_max_factor);
        }
        if state.stall.0 == 0 && u[2] < self.stall_probability {
            state.stall = (self.stall_steps, u[3] < 0.5);
        }
        let d = robot0_from_robot1.translation();
        let mut dist = d.length().copysign(d.x);
        let mut turn = robot0_from_robot1.theta_rad * (1.0 + self.turn_bias_frac);
        if state.slip.0 > 0 {
            state.slip.0 -= 1;
            (dist, turn) = (dist * state.slip.1, turn * state.slip.1);
        }
        if state.stall.0 > 0 {
            state.stall.0 -= 1;
            (dist, turn) = self.stalled(dist, turn, state.stall.1);
        }
        let chord = turn / 2.0;
        Pose2::new(dist * chord.cos(), dist * chord.sin(), turn)
    }

    /// Distance and turn read when one wheel reads zero (`left`: the left one): the other
    /// wheel's distance, halved, and a turn of that distance over the wheel base.
    fn stalled(&self, dist_m: f64, turn_rad: f64, left: bool) -> (f64, f64) {
        let half_turn_m = turn_rad * self.wheel_base_m / 2.0;
        let (wheel_left, wheel_right) = if left {
            (0.0, dist_m + half_turn_m)
        } else {
            (dist_m - half_turn_m, 0.0)
        };
        (
            (wheel_left + wheel_right) / 2.0,
            (wheel_right - wheel_left) / self.wheel_base_m,
        )
    }
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
            faults: OdometryFaults::default(),
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

/// Odometry poses (`odom_from_robot`) for a sequence of true poses (`map_from_robot`): each
/// step's true motion goes through the faults (drawing from `fault_rng`), then the noise
/// (drawing from `rng`).
///
/// ```
/// use polymap::geometry::Pose2;
/// use polymap_sim::{OdometryParams, odometry::odometry};
/// use rand::SeedableRng;
/// let truth = [Pose2::new(5.0, 5.0, 1.0), Pose2::new(5.0, 6.0, 1.0)];
/// let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
/// let mut fault_rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
/// let odom = odometry(&truth, &OdometryParams::exact(), &mut rng, &mut fault_rng);
/// assert_eq!(odom[0], Pose2::IDENTITY);
/// let step = odom[0].between(&odom[1]);
/// let truth_step = truth[0].between(&truth[1]);
/// assert!((step.translation() - truth_step.translation()).length() < 1e-12);
/// ```
pub fn odometry<R: Rng + ?Sized, F: Rng + ?Sized>(
    true_poses: &[Pose2],
    params: &OdometryParams,
    rng: &mut R,
    fault_rng: &mut F,
) -> Vec<Pose2> {
    let mut out = Vec::with_capacity(true_poses.len());
    let mut odom_from_robot = params.initial_odom_from_robot;
    let mut faults = FaultState::default();
    for (k, pose) in true_poses.iter().enumerate() {
        if k > 0 {
            let mut step = true_poses[k - 1].between(pose);
            if params.faults.any() {
                step = params.faults.apply(&step, &mut faults, fault_rng);
            }
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

    fn fault_rng() -> ChaCha8Rng {
        ChaCha8Rng::seed_from_u64(99)
    }

    /// Exact odometry with these faults.
    fn exact_with(faults: OdometryFaults) -> OdometryParams {
        OdometryParams {
            faults,
            ..OdometryParams::exact()
        }
    }

    /// Each step of `odom` next to the true step.
    fn steps(truth: &[Pose2], odom: &[Pose2]) -> Vec<(Pose2, Pose2)> {
        (1..truth.len())
            .map(|k| {
                (
                    truth[k - 1].between(&truth[k]),
                    odom[k - 1].between(&odom[k]),
                )
            })
            .collect()
    }

    /// Straight ahead, 0.05 m per step.
    fn straight(n: usize) -> Vec<Pose2> {
        (0..n)
            .map(|k| Pose2::new(0.05 * k as f64, 0.0, 0.0))
            .collect()
    }

    #[test]
    fn heading_bias_reads_a_quarter_turn_as_117_degrees() {
        let truth: Vec<Pose2> = (0..=90)
            .map(|k| Pose2::new(0.0, 0.0, (k as f64).to_radians()))
            .collect();
        let params = exact_with(OdometryFaults {
            turn_bias_frac: 0.3,
            ..OdometryFaults::default()
        });
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let odom = odometry(&truth, &params, &mut rng, &mut fault_rng());
        let turned: f64 = steps(&truth, &odom).iter().map(|(_, o)| o.theta_rad).sum();
        assert!((turned.to_degrees() - 117.0).abs() < 1e-9, "{turned}");
    }

    #[test]
    fn a_stalled_wheel_turns_the_odometry_while_the_robot_goes_straight() {
        let truth = straight(41);
        let params = exact_with(OdometryFaults {
            stall_probability: 1.0,
            ..OdometryFaults::default()
        });
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let odom = odometry(&truth, &params, &mut rng, &mut fault_rng());
        for (t, o) in steps(&truth, &odom) {
            assert_eq!(t.theta_rad, 0.0);
            // One wheel 0.05 m, the other 0: half the distance, 0.05 / 0.4 rad of turn.
            assert!((o.theta_rad.abs() - 0.125).abs() < 1e-12, "{o:?}");
            assert!((o.translation().length() - 0.025).abs() < 1e-12, "{o:?}");
        }
    }

    #[test]
    fn slips_read_more_and_less_motion_than_made() {
        let truth = straight(2001);
        let params = exact_with(OdometryFaults {
            slip_probability: 0.05,
            ..OdometryFaults::default()
        });
        let mut rng = ChaCha8Rng::seed_from_u64(6);
        let odom = odometry(&truth, &params, &mut rng, &mut fault_rng());
        let ratios: Vec<f64> = steps(&truth, &odom)
            .iter()
            .map(|(t, o)| o.translation().length() / t.translation().length())
            .collect();
        let (short, long) = (
            ratios.iter().filter(|&&r| r < 0.5).count(),
            ratios.iter().filter(|&&r| r > 1.5).count(),
        );
        let exact = ratios.iter().filter(|&&r| (r - 1.0).abs() < 1e-9).count();
        assert!(
            short >= 50 && long >= 100 && exact >= 200,
            "{short} {long} {exact}"
        );
        assert!(ratios.iter().all(|&r| (0.0..=3.0 + 1e-9).contains(&r)));
    }

    #[test]
    fn faults_leave_the_noise_of_other_steps_unchanged_and_are_seeded() {
        let truth = straight(400);
        let run = |faults: OdometryFaults, fault_seed: u64| {
            let mut rng = ChaCha8Rng::seed_from_u64(7);
            let mut frng = ChaCha8Rng::seed_from_u64(fault_seed);
            let params = OdometryParams {
                faults,
                ..OdometryParams::default()
            };
            odometry(&truth, &params, &mut rng, &mut frng)
        };
        let clean = run(OdometryFaults::default(), 1);
        let slips = OdometryFaults {
            slip_probability: 0.01,
            ..OdometryFaults::default()
        };
        let (a, b, c) = (run(slips.clone(), 1), run(slips.clone(), 1), run(slips, 2));
        assert_eq!(a, b);
        assert_ne!(a, c);
        let same = steps(&truth, &clean)
            .iter()
            .zip(steps(&truth, &a))
            .filter(|((_, x), (_, y))| (x.translation() - y.translation()).length() < 1e-12)
            .count();
        assert!(same > 300 && same < 399, "{same}");
    }

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
        let odom = odometry(
            &truth,
            &OdometryParams::default(),
            &mut rng,
            &mut fault_rng(),
        );
        assert!(
            odom.iter()
                .all(|p| p.translation().length() < 1e-12 && p.theta_rad.abs() < 1e-12)
        );
    }

    #[test]
    fn error_grows_with_distance() {
        let truth = square_drive();
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let odom = odometry(
            &truth,
            &OdometryParams::default(),
            &mut rng,
            &mut fault_rng(),
        );
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
        let odom = odometry(&truth, &OdometryParams::exact(), &mut rng, &mut fault_rng());
        let end = truth[0].between(&truth[truth.len() - 1]);
        assert!((odom[odom.len() - 1].translation() - end.translation()).length() < 1e-9);
    }
}
