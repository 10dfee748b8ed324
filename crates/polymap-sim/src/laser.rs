//! The laser model: ideal ranges from the ray caster, then noise, dropouts and no-returns.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use polymap::geometry::Pose2;
use rand::{Rng, RngExt};
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use crate::raycast::{RayCaster, RayHit};

/// Shortest range ever written, metres: noise never produces a zero or negative reading.
const MIN_WRITTEN_RANGE_M: f64 = 1e-3;

/// A planar laser range finder. Defaults: a SICK LMS as logged by CARMEN (`FLASER`), with
/// a shorter range so that worlds stay small.
///
/// Beam `i` of `num_beams` points at `angle_min_rad + i · fov_rad / num_beams` in the laser
/// frame (x forward, y left): with the defaults, −90°, −89°, …, +89°.
///
/// ```
/// use polymap_sim::LaserParams;
/// let laser = LaserParams::default();
/// assert_eq!(laser.num_beams, 180);
/// assert!((laser.angle_increment_rad().to_degrees() - 1.0).abs() < 1e-12);
/// assert_eq!(LaserParams::full_circle().num_beams, 360);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct LaserParams {
    /// Number of beams per scan. Default 180.
    pub num_beams: usize,
    /// Angle covered by the beams, radians. Default π (180°).
    pub fov_rad: f64,
    /// Bearing of the first beam in the laser frame, radians. Default −π/2.
    pub angle_min_rad: f64,
    /// Range limit, metres: farther hits, and misses, are written as exactly this value,
    /// which [`polymap::scan::RangeScan`] reads as a no-return. Default 30.
    pub max_range_m: f64,
    /// Standard deviation of the Gaussian range noise, metres. Default 0.01 (a SICK LMS 200).
    pub range_sigma_m: f64,
    /// Chance that a beam returns nothing (written as `max_range_m`). Default 0.01.
    pub dropout_probability: f64,
    /// Standard deviation of the beam's true bearing about its nominal one, radians. The
    /// scan reports the nominal bearing. Default 0 (off).
    pub bearing_sigma_rad: f64,
    /// Mounting of the laser on the robot. Default identity.
    pub robot_from_laser: Pose2,
}

impl Default for LaserParams {
    fn default() -> Self {
        LaserParams {
            num_beams: 180,
            fov_rad: PI,
            angle_min_rad: -FRAC_PI_2,
            max_range_m: 30.0,
            range_sigma_m: 0.01,
            dropout_probability: 0.01,
            bearing_sigma_rad: 0.0,
            robot_from_laser: Pose2::IDENTITY,
        }
    }
}

impl LaserParams {
    /// A 360° scanner: 360 beams one degree apart from −180°, otherwise the defaults.
    pub fn full_circle() -> Self {
        LaserParams {
            num_beams: 360,
            fov_rad: TAU,
            angle_min_rad: -PI,
            ..LaserParams::default()
        }
    }

    /// A scanner of `fov_deg` degrees with one beam per degree, centred ahead (the first beam
    /// at −fov/2), otherwise the defaults: 180 is the default SICK, 270 a Hokuyo-like
    /// scanner, 360 [`full_circle`](Self::full_circle).
    ///
    /// ```
    /// use polymap_sim::LaserParams;
    /// let l = LaserParams::one_beam_per_degree(270);
    /// assert_eq!(l.num_beams, 270);
    /// assert!((l.angle_min_rad.to_degrees() + 135.0).abs() < 1e-9);
    /// assert_eq!(LaserParams::one_beam_per_degree(360), LaserParams::full_circle());
    /// ```
    pub fn one_beam_per_degree(fov_deg: u16) -> Self {
        let fov_rad = f64::from(fov_deg).to_radians();
        LaserParams {
            num_beams: usize::from(fov_deg),
            fov_rad,
            angle_min_rad: -fov_rad / 2.0,
            ..LaserParams::default()
        }
    }

    /// Bearing step between consecutive beams, radians: `fov_rad / num_beams`.
    pub fn angle_increment_rad(&self) -> f64 {
        self.fov_rad / self.num_beams.max(1) as f64
    }
}

/// One simulated scan before it is wrapped into a [`polymap::scan::RangeScan`].
#[derive(Debug, Clone, PartialEq)]
pub struct LaserReading {
    /// Written ranges, metres, one per beam; `max_range_m` marks a no-return.
    pub ranges_m: Vec<f64>,
    /// Per beam, the true (noise-free) hit behind a written return; `None` for no-returns.
    pub hits: Vec<Option<RayHit>>,
}

/// Simulates one scan taken with the robot at `map_from_robot` (world frame).
///
/// Per beam, in beam order, three numbers are drawn from `rng` (bearing noise, dropout,
/// range noise) whether or not they are used, so the stream stays aligned.
///
/// ```
/// use polymap::geometry::Pose2;
/// use polymap_sim::{LaserParams, World, laser::read_laser, raycast::RayCaster};
/// use rand::SeedableRng;
/// let world = World::hallway45();
/// let caster = RayCaster::new(&world);
/// let exact = LaserParams { range_sigma_m: 0.0, dropout_probability: 0.0, ..LaserParams::default() };
/// let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
/// let reading = read_laser(&caster, &Pose2::new(2.0, 0.0, 0.0), &exact, &mut rng);
/// // Beam 0 looks to the robot's right: the outer wall, 1 m away.
/// assert!((reading.ranges_m[0] - 1.0).abs() < 1e-12);
/// assert!((reading.ranges_m[180 - 1] - 1.0).abs() < 0.02);
/// ```
pub fn read_laser<R: Rng + ?Sized>(
    caster: &RayCaster,
    map_from_robot: &Pose2,
    laser: &LaserParams,
    rng: &mut R,
) -> LaserReading {
    let map_from_laser = map_from_robot.compose(&laser.robot_from_laser);
    let origin = map_from_laser.translation();
    let increment = laser.angle_increment_rad();
    let mut reading = LaserReading {
        ranges_m: Vec::with_capacity(laser.num_beams),
        hits: Vec::with_capacity(laser.num_beams),
    };
    for i in 0..laser.num_beams {
        let nominal = laser.angle_min_rad + i as f64 * increment;
        let bearing_noise: f64 = rng.sample(StandardNormal);
        let dropped = rng.random::<f64>() < laser.dropout_probability;
        let range_noise: f64 = rng.sample(StandardNormal);
        let bearing = map_from_laser.theta_rad + nominal + laser.bearing_sigma_rad * bearing_noise;
        let hit = caster
            .cast(origin, bearing, laser.max_range_m)
            .filter(|_| !dropped);
        let noisy =
            hit.map(|h| (h.range_m + laser.range_sigma_m * range_noise).max(MIN_WRITTEN_RANGE_M));
        match noisy.filter(|&r| r < laser.max_range_m) {
            Some(r) => {
                reading.ranges_m.push(r);
                reading.hits.push(hit);
            }
            None => {
                reading.ranges_m.push(laser.max_range_m);
                reading.hits.push(None);
            }
        }
    }
    reading
}

#[cfg(test)]
mod tests {
    use polymap::geometry::{Segment, Vec2};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    use super::*;
    use crate::world::World;

    fn wall_ahead() -> World {
        World {
            moved: None,
            name: "wall".into(),
            description: String::new(),
            walls: vec![Segment::new(Vec2::new(5.0, -100.0), Vec2::new(5.0, 100.0))],
            pillars: vec![],
            waypoints: vec![],
            laser: Default::default(),
        }
    }

    #[test]
    fn range_noise_has_the_requested_spread() {
        let caster = RayCaster::new(&wall_ahead());
        let laser = LaserParams {
            num_beams: 1,
            fov_rad: 0.01,
            angle_min_rad: 0.0,
            dropout_probability: 0.0,
            ..LaserParams::default()
        };
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let errs: Vec<f64> = (0..4000)
            .map(|_| read_laser(&caster, &Pose2::IDENTITY, &laser, &mut rng).ranges_m[0] - 5.0)
            .collect();
        let mean = errs.iter().sum::<f64>() / errs.len() as f64;
        let sd = (errs.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / errs.len() as f64).sqrt();
        assert!(
            mean.abs() < 0.001 && (sd - 0.01).abs() < 0.001,
            "mean {mean} sd {sd}"
        );
    }

    #[test]
    fn dropouts_are_written_as_max_range() {
        let caster = RayCaster::new(&wall_ahead());
        let laser = LaserParams {
            dropout_probability: 0.5,
            ..LaserParams::default()
        };
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let r = read_laser(&caster, &Pose2::IDENTITY, &laser, &mut rng);
        let dropped = r
            .ranges_m
            .iter()
            .filter(|&&x| x == laser.max_range_m)
            .count();
        assert!(dropped > 40 && dropped < 140, "{dropped}");
        assert!(
            r.ranges_m
                .iter()
                .zip(&r.hits)
                .all(|(&x, h)| (x == laser.max_range_m) == h.is_none())
        );
    }

    #[test]
    fn laser_offset_moves_the_origin() {
        let caster = RayCaster::new(&wall_ahead());
        let exact = LaserParams {
            range_sigma_m: 0.0,
            dropout_probability: 0.0,
            robot_from_laser: Pose2::new(0.5, 0.0, 0.0),
            ..LaserParams::default()
        };
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let r = read_laser(&caster, &Pose2::new(1.0, 0.0, 0.0), &exact, &mut rng);
        assert!((r.ranges_m[90] - 3.5).abs() < 1e-12);
    }
}
