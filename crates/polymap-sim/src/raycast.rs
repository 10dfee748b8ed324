//! Ray casting against a [`World`]: the nearest wall or pillar along a ray.
//!
//! [`RayCaster`] walks a uniform grid cell by cell (Amanatides–Woo) and stops at the first
//! cell whose far side lies beyond the best hit so far. [`cast_ray_brute`] tests every
//! obstacle; it is the oracle the grid is checked against. Both use the same intersection
//! primitives, so they agree to the last bit on the range.

use polymap::geometry::{Segment, Vec2};

use crate::world::{Pillar, World};

/// What a ray hit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Obstacle {
    /// Index into [`World::walls`].
    Wall(usize),
    /// Index into [`World::pillars`].
    Pillar(usize),
}

/// The nearest hit along a ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayHit {
    /// Distance from the ray's origin to the hit, metres.
    pub range_m: f64,
    /// The hit point, metres, world frame.
    pub point: Vec2,
    /// What was hit.
    pub obstacle: Obstacle,
}

/// Distance along the unit ray `origin + t·dir` to a segment, if it crosses at `t > 0`.
///
/// A ray parallel to the segment (grazing along it) does not hit it.
///
/// ```
/// use polymap::geometry::{Segment, Vec2};
/// use polymap_sim::raycast::ray_segment_m;
/// let wall = Segment::new(Vec2::new(3.0, -1.0), Vec2::new(3.0, 1.0));
/// assert_eq!(ray_segment_m(Vec2::ZERO, Vec2::X, &wall), Some(3.0));
/// assert_eq!(ray_segment_m(Vec2::ZERO, -Vec2::X, &wall), None);
/// ```
pub fn ray_segment_m(origin: Vec2, dir: Vec2, wall: &Segment) -> Option<f64> {
    wall.ray_hit_m(origin, dir)
}

/// Distance along the unit ray `origin + t·dir` to a pillar's circle, if at `t > 0`: the
/// entry point, or the exit point for an origin inside the pillar.
///
/// ```
/// use polymap::geometry::Vec2;
/// use polymap_sim::{Pillar, raycast::ray_circle_m};
/// let p = Pillar { center: Vec2::new(5.0, 0.0), radius_m: 1.0 };
/// assert_eq!(ray_circle_m(Vec2::ZERO, Vec2::X, &p), Some(4.0));
/// assert_eq!(ray_circle_m(Vec2::ZERO, Vec2::Y, &p), None);
/// ```
pub fn ray_circle_m(origin: Vec2, dir: Vec2, pillar: &Pillar) -> Option<f64> {
    let m = origin - pillar.center;
    let b = m.dot(dir);
    let c = m.length_squared() - pillar.radius_m * pillar.radius_m;
    if c > 0.0 && b > 0.0 {
        return None;
    }
    let disc = b * b - c;
    if disc < 0.0 || !disc.is_finite() {
        return None;
    }
    let root = disc.sqrt();
    let t = if -b - root > 0.0 {
        -b - root
    } else {
        -b + root
    };
    (t > 0.0).then_some(t)
}

/// The hit of one obstacle, if nearer than `best_m`.
fn closer(t: Option<f64>, best_m: f64) -> Option<f64> {
    t.filter(|&t| t < best_m)
}

/// Unit direction of a bearing, radians from the world x axis.
fn direction(bearing_rad: f64) -> Vec2 {
    let (s, c) = bearing_rad.sin_cos();
    Vec2::new(c, s)
}

/// Builds the hit record for an obstacle at distance `range_m`.
fn hit(origin: Vec2, dir: Vec2, range_m: f64, obstacle: Obstacle) -> RayHit {
    RayHit {
        range_m,
        point: origin + dir * range_m,
        obstacle,
    }
}

/// The nearest hit by testing every wall and pillar: the oracle for [`RayCaster`].
///
/// Hits at or beyond `max_range_m` are `None`, as are non-finite walls and invalid pillars.
///
/// ```
/// use polymap::geometry::{Segment, Vec2};
/// use polymap_sim::{World, raycast::cast_ray_brute};
/// let world = World {
///     moved: None,
///     name: "one wall".into(),
///     description: String::new(),
///     walls: vec![Segment::new(Vec2::new(2.0, -5.0), Vec2::new(2.0, 5.0))],
///     pillars: vec![],
///     waypoints: vec![],
///     laser: Default::default(),
/// };
/// let hit = cast_ray_brute(&world, Vec2::ZERO, std::f64::consts::FRAC_PI_4, 30.0).unwrap();
/// assert!((hit.range_m - 2.0 * 2f64.sqrt()).abs() < 1e-12);
/// assert!(cast_ray_brute(&world, Vec2::ZERO, 0.0, 1.5).is_none());
/// ```
pub fn cast_ray_brute(
    world: &World,
    origin: Vec2,
    bearing_rad: f64,
    max_range_m: f64,
) -> Option<RayHit> {
    let dir = direction(bearing_rad);
    if !origin.is_finite() || !dir.is_finite() {
        return None;
    }
    let mut best: Option<(f64, Obstacle)> = None;
    let mut best_m = max_range_m;
    for (i, w) in world
        .walls
        .iter()
        .enumerate()
        .filter(|(_, w)| w.is_finite())
    {
        if let Some(t) = closer(ray_segment_m(origin, dir, w), best_m) {
            best = Some((t, Obstacle::Wall(i)));
            best_m = t;
        }
    }
    for (i, p) in world
        .pillars
        .iter()
        .enumerate()
        .filter(|(_, p)| p.is_valid())
    {
        if let Some(t) = closer(ray_circle_m(origin, dir, p), best_m) {
            best = Some((t, Obstacle::Pillar(i)));
            best_m = t;
        }
    }
    best.map(|(t, o)| hit(origin, dir, t, o))
}

mod grid;

pub use grid::RayCaster;
