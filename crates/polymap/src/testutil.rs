//! Test helpers: a tiny ray caster producing range scans from a wall world.

use crate::geometry::{Pose2, Segment, Vec2};
use crate::scan::{RangeScan, Stamp};

/// The nearest hit of a ray with the walls, metres.
pub(crate) fn ray_hit(walls: &[Segment], origin: Vec2, dir: Vec2) -> Option<f64> {
    walls
        .iter()
        .filter_map(|s| {
            let v = s.vector();
            let den = dir.perp_dot(v);
            if den.abs() < 1e-12 {
                return None;
            }
            let w = s.start - origin;
            let t = w.perp_dot(v) / den;
            let u = w.perp_dot(dir) / den;
            (t > 0.0 && (0.0..=1.0).contains(&u)).then_some(t)
        })
        .min_by(f64::total_cmp)
}

/// A 181-beam, 180° scan (like a CARMEN FLASER) from `map_from_robot`, no noise, 30 m range.
pub(crate) fn scan_from(walls: &[Segment], map_from_robot: &Pose2, stamp_s: f64) -> RangeScan {
    let max_range_m = 30.0;
    let n = 181;
    let inc = std::f64::consts::PI / (n - 1) as f64;
    let ranges_m = (0..n)
        .map(|i| {
            let a = map_from_robot.theta_rad - std::f64::consts::FRAC_PI_2 + i as f64 * inc;
            ray_hit(
                walls,
                map_from_robot.translation(),
                Vec2::new(a.cos(), a.sin()),
            )
            .filter(|r| *r < max_range_m)
            .unwrap_or(max_range_m)
        })
        .collect();
    RangeScan {
        stamp: Stamp::from_seconds(stamp_s),
        ranges_m,
        angle_min_rad: -std::f64::consts::FRAC_PI_2,
        angle_increment_rad: inc,
        max_range_m,
        robot_from_laser: Pose2::IDENTITY,
        odom_from_robot: None,
    }
}
