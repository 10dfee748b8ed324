//! A synthetic square room, 10 m × 8 m, and a robot driving round it: exact walls, poses and
//! ray-cast scans.

use polymap::geometry::{Pose2, Segment, Vec2};
use polymap::map::MapSegment;

/// The four walls, metres, map frame.
pub fn walls() -> Vec<Segment> {
    let c = [
        Vec2::new(0.0, 0.0),
        Vec2::new(10.0, 0.0),
        Vec2::new(10.0, 8.0),
        Vec2::new(0.0, 8.0),
    ];
    (0..4).map(|i| Segment::new(c[i], c[(i + 1) % 4])).collect()
}

/// The walls as map segments split into 1 m pieces, born when first seen.
pub fn wall_pieces() -> Vec<Segment> {
    walls()
        .iter()
        .flat_map(|w| {
            let n = w.length().round() as usize;
            (0..n).map(move |k| {
                let a = w.start + w.vector() * (k as f64 / n as f64);
                let b = w.start + w.vector() * ((k + 1) as f64 / n as f64);
                Segment::new(a, b)
            })
        })
        .collect()
}

/// The robot's pose at scan `t` of `n`: once round an ellipse inside the room, facing forward.
pub fn pose(t: u32, n: u32) -> Pose2 {
    let a = std::f64::consts::TAU * f64::from(t) / f64::from(n.max(1));
    let (x, y) = (5.0 + 3.0 * a.cos(), 4.0 + 2.0 * a.sin());
    Pose2::new(x, y, a + std::f64::consts::FRAC_PI_2)
}

/// A 180° scan of 91 beams: hit points in the robot frame.
pub fn scan(map_from_robot: &Pose2) -> Vec<Vec2> {
    let walls = walls();
    (0..91)
        .filter_map(|k| {
            let bearing = (f64::from(k) * 2.0 - 90.0).to_radians();
            let dir_in_robot = Vec2::new(bearing.cos(), bearing.sin());
            let dir_in_map = map_from_robot.rotate(dir_in_robot);
            let origin = map_from_robot.translation();
            let range = walls
                .iter()
                .filter_map(|w| w.ray_hit_m(origin, dir_in_map))
                .fold(f64::INFINITY, f64::min);
            range.is_finite().then(|| dir_in_robot * range)
        })
        .collect()
}

/// Wrapped as map segments, all born at scan 0, with one polyline per wall.
pub fn map_segments() -> (Vec<MapSegment>, Vec<Vec<usize>>) {
    let segments: Vec<MapSegment> = wall_pieces()
        .into_iter()
        .map(|segment| MapSegment {
            segment,
            born_scan: 0,
        })
        .collect();
    let (mut polylines, mut start) = (Vec::new(), 0);
    for w in walls() {
        let n = w.length().round() as usize;
        polylines.push((start..start + n).collect());
        start += n;
    }
    (segments, polylines)
}

#[test]
fn scans_hit_the_walls() {
    let p = pose(0, 100);
    let hits = scan(&p);
    assert_eq!(hits.len(), 91);
    for h in hits {
        let h_in_map = p.transform_point(h);
        let d = walls()
            .iter()
            .map(|w| w.distance_to_point(h_in_map))
            .fold(f64::INFINITY, f64::min);
        assert!(d < 1e-9, "{h_in_map}");
    }
}
