//! Test helpers: range scans ray-cast in a wall world (the unit tests cannot link the
//! simulator, which depends on this crate; they share its ray–segment test instead).

use crate::geometry::{Pose2, Segment, Vec2};
use crate::map::{GlobalMap, MapSegment};
use crate::scan::{RangeScan, Stamp};

/// The nearest hit of a ray with the walls, metres (the simulator's ray–segment test,
/// [`Segment::ray_hit_m`]).
pub(crate) fn ray_hit(walls: &[Segment], origin: Vec2, dir: Vec2) -> Option<f64> {
    walls
        .iter()
        .filter_map(|s| s.ray_hit_m(origin, dir))
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

/// A segment from `(ax, ay)` to `(bx, by)`, metres.
pub(crate) fn seg(ax: f64, ay: f64, bx: f64, by: f64) -> Segment {
    Segment::new(Vec2::new(ax, ay), Vec2::new(bx, by))
}

/// A 10 × 6 m room with a box and a slanted wall piece: constrains every direction.
pub(crate) fn room() -> Vec<Segment> {
    vec![
        seg(-5.0, -3.0, 5.0, -3.0),
        seg(5.0, -3.0, 5.0, 3.0),
        seg(5.0, 3.0, -5.0, 3.0),
        seg(-5.0, 3.0, -5.0, -3.0),
        seg(1.0, 0.5, 2.0, 0.5),
        seg(2.0, 0.5, 2.0, 1.5),
        seg(2.0, 1.5, 1.0, 1.5),
        seg(1.0, 1.5, 1.0, 0.5),
        seg(-3.0, -3.0, -4.0, -1.5),
    ]
}

/// A 360-beam, 360° scan without noise or range limit from `map_from_robot`, as points in the
/// robot frame.
pub(crate) fn cast_360(world: &[Segment], map_from_robot: &Pose2) -> Vec<Vec2> {
    let o = map_from_robot.translation();
    (0..360)
        .filter_map(|i| {
            let a = map_from_robot.theta_rad + f64::from(i).to_radians();
            let d = Vec2::new(a.cos(), a.sin());
            let hit = ray_hit(world, o, d)?;
            Some(map_from_robot.inverse().transform_point(o + d * hit))
        })
        .collect()
}

/// A global map of `segments` (born at scan 0) with `cell_m` grid cells.
pub(crate) fn map_of(segments: &[Segment], cell_m: f64) -> GlobalMap {
    let mut map = GlobalMap::new(cell_m, 1.0);
    for s in segments {
        map.insert(MapSegment {
            segment: *s,
            born_scan: 0,
        });
    }
    map
}
