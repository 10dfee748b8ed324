//! The simulated environment: straight walls, round pillars and the robot's tour through them.
//!
//! All coordinates are metres in the **world frame**, the frame ground truth is reported in.

use std::f64::consts::TAU;

use polymap::geometry::{Pose2, Segment, Vec2};
use serde::{Deserialize, Serialize};

use crate::laser::LaserParams;
use crate::params::SimParams;
use crate::worlds;

/// Target side length of the polygon that stands in for a pillar in the ground-truth walls, metres.
const PILLAR_SIDE_M: f64 = 0.1;
/// Fewest sides of a pillar polygon.
const PILLAR_MIN_SIDES: usize = 8;
/// Most sides of a pillar polygon.
const PILLAR_MAX_SIDES: usize = 64;

/// A round pillar (a column), world frame.
///
/// ```
/// use polymap::geometry::Vec2;
/// use polymap_sim::Pillar;
/// let p = Pillar { center: Vec2::new(1.0, 1.0), radius_m: 0.3 };
/// assert_eq!(p.sides(), 19);
/// assert_eq!(p.polygon().len(), 19);
/// assert!((p.distance_to_point(Vec2::new(2.0, 1.0)) - 0.7).abs() < 1e-12);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Pillar {
    /// Centre, metres, world frame.
    pub center: Vec2,
    /// Radius, metres.
    pub radius_m: f64,
}

impl Pillar {
    /// Number of sides of the ground-truth polygon: sides about 0.1 m long, 8 to 64 of them.
    pub fn sides(&self) -> usize {
        let n = (TAU * self.radius_m / PILLAR_SIDE_M).ceil();
        if n.is_finite() && n > 0.0 {
            (n as usize).clamp(PILLAR_MIN_SIDES, PILLAR_MAX_SIDES)
        } else {
            PILLAR_MIN_SIDES
        }
    }

    /// The pillar as a closed polygon of [`Pillar::sides`] segments with vertices on the circle,
    /// counter-clockwise from bearing 0; side `k` spans bearings `[k, k + 1] · 2π / sides`.
    pub fn polygon(&self) -> Vec<Segment> {
        let n = self.sides();
        let vertex = |k: usize| {
            let a = TAU * k as f64 / n as f64;
            self.center + Vec2::new(a.cos(), a.sin()) * self.radius_m
        };
        (0..n)
            .map(|k| Segment::new(vertex(k), vertex(k + 1)))
            .collect()
    }

    /// Which polygon side faces the surface point `p_in_world` (by its bearing from the centre).
    pub fn side_at(&self, p_in_world: Vec2) -> usize {
        let n = self.sides();
        let v = p_in_world - self.center;
        let bearing = v.y.atan2(v.x).rem_euclid(TAU);
        ((bearing / TAU * n as f64) as usize).min(n - 1)
    }

    /// Distance from a point to the pillar's surface, metres (negative inside).
    pub fn distance_to_point(&self, p: Vec2) -> f64 {
        (p - self.center).length() - self.radius_m
    }

    /// True when centre and radius are finite and the radius is positive.
    pub fn is_valid(&self) -> bool {
        self.center.is_finite() && self.radius_m.is_finite() && self.radius_m > 0.0
    }
}

/// A 2D world: walls, pillars, and the waypoints of the robot's tour, all in the world frame.
///
/// ```
/// use polymap::geometry::{Pose2, Segment, Vec2};
/// use polymap_sim::World;
/// let world = World {
///     moved: None,
///     name: "box".into(),
///     description: "a 4 m square".into(),
///     walls: vec![
///         Segment::new(Vec2::new(0.0, 0.0), Vec2::new(4.0, 0.0)),
///         Segment::new(Vec2::new(4.0, 0.0), Vec2::new(4.0, 4.0)),
///     ],
///     pillars: vec![],
///     waypoints: vec![Vec2::new(1.0, 1.0), Vec2::new(2.0, 2.0)],
///     laser: Default::default(),
/// };
/// assert_eq!(world.clearance_m(Vec2::new(1.0, 1.0)), 1.0);
/// assert_eq!(world.total_wall_length_m(), 8.0);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct World {
    /// Short name, as used by [`World::by_name`].
    pub name: String,
    /// One or two sentences: what the world is for.
    pub description: String,
    /// Straight walls, metres, world frame.
    pub walls: Vec<Segment>,
    /// Round pillars, world frame.
    pub pillars: Vec<Pillar>,
    /// The robot's tour, metres, world frame; [`crate::path::trajectory`] smooths it.
    pub waypoints: Vec<Vec2>,
    /// The laser the world is meant to be seen with ([`World::sim_params`] puts it into the
    /// default parameters). Default [`LaserParams::default`] (180°, 30 m).
    #[serde(default)]
    pub laser: LaserParams,
    /// Walls that move during the tour, if any: [`World::walls`] is the world at the end of the
    /// tour (the ground truth of the finished map), [`Moved`] says what stood before.
    #[serde(default)]
    pub moved: Option<Moved>,
}

/// A change of the world during the tour: a cupboard carried elsewhere, a door that opened.
///
/// Until scan `at_share` × (number of scans) the last `replaces_last` of [`World::walls`] are
/// not there and `before` stands instead.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Moved {
    /// Share of the tour's scans after which the world is [`World::walls`], in `[0, 1]`.
    pub at_share: f64,
    /// How many of the last walls of [`World::walls`] stand only after the change.
    pub replaces_last: usize,
    /// Walls standing only before the change, metres, world frame.
    pub before: Vec<Segment>,
}

/// Name of the world mapped when no log is given: [`World::hallway45`].
pub const DEFAULT_WORLD_NAME: &str = "hallway45";

impl Default for World {
    /// The default world, [`World::hallway45`].
    fn default() -> Self {
        World::hallway45()
    }
}

impl World {
    /// The ring hallway with one 45° stretch (the paper's Bremen hallway, Fig. 7); the default.
    pub fn hallway45() -> World {
        worlds::hallway45::build()
    }

    /// A hexagonal ring corridor with walls at 0° and ±60° only (the paper's Figs. 2, 3, 6).
    pub fn hex60() -> World {
        worlds::hex60::build()
    }

    /// An irregular open area with rotated boxes and round pillars: no dominant direction.
    pub fn clutter() -> World {
        worlds::clutter::build()
    }

    /// A ring corridor lined with rooms whose doorways cut otherwise collinear walls.
    pub fn office() -> World {
        worlds::office::build()
    }

    /// A 40 m corridor, bare but for features at its two ends, seen with a 10 m laser: along
    /// most of it the motion along the corridor is unobservable.
    pub fn corridor() -> World {
        worlds::corridor::build()
    }

    /// A rectangular ring hallway whose only features are one round pillar and one box (180°
    /// laser, 20 m range).
    pub fn ring() -> World {
        worlds::ring::build()
    }

    /// A curved hallway: two circular bends, along which the motion is a rotation about the
    /// bend's centre that the walls do not observe; door niches and the ends do.
    pub fn curve() -> World {
        worlds::curve::build()
    }

    /// An L-shaped hall with pillars and boxes, mapped by a 360° laser; the tour turns on the
    /// spot.
    pub fn hall360() -> World {
        worlds::hall360::build()
    }

    /// The names of the built-in worlds, default first.
    pub fn names() -> [&'static str; 9] {
        [
            "hallway45",
            "hex60",
            "clutter",
            "office",
            "corridor",
            "ring",
            "curve",
            "hall360",
            "moved",
        ]
    }

    /// Every built-in world, default first.
    pub fn catalogue() -> Vec<World> {
        World::names()
            .into_iter()
            .filter_map(World::by_name)
            .collect()
    }

    /// A room whose cupboard is carried to another place half way through the tour, the
    /// robot going round twice: the old place is seen empty on the second round.
    pub fn moved() -> World {
        worlds::moved::build()
    }

    /// The world as it stood before its change ([`World::moved`]), `None` when it does not
    /// change.
    ///
    /// ```
    /// use polymap_sim::World;
    /// let after = World::moved();
    /// let before = after.before_change().unwrap();
    /// assert_eq!(before.walls.len(), after.walls.len());
    /// assert_ne!(before.walls, after.walls);
    /// assert!(World::office().before_change().is_none());
    /// ```
    pub fn before_change(&self) -> Option<World> {
        let m = self.moved.as_ref()?;
        let kept = self.walls.len().saturating_sub(m.replaces_last);
        let mut walls = self.walls[..kept].to_vec();
        walls.extend(m.before.iter().copied());
        Some(World {
            walls,
            moved: None,
            ..self.clone()
        })
    }

    /// The default simulation parameters with this world's laser ([`World::laser`]).
    ///
    /// ```
    /// use polymap_sim::World;
    /// assert_eq!(World::ring().sim_params().laser.max_range_m, 20.0);
    /// assert_eq!(World::office().sim_params(), polymap_sim::SimParams::default());
    /// ```
    pub fn sim_params(&self) -> SimParams {
        SimParams {
            laser: self.laser.clone(),
            ..SimParams::default()
        }
    }

    /// A built-in world by name, or `None` for an unknown name.
    ///
    /// ```
    /// use polymap_sim::World;
    /// assert_eq!(World::by_name("hex60").map(|w| w.name), Some("hex60".to_string()));
    /// assert!(World::by_name("atlantis").is_none());
    /// ```
    pub fn by_name(name: &str) -> Option<World> {
        match name {
            "hallway45" => Some(World::hallway45()),
            "hex60" => Some(World::hex60()),
            "clutter" => Some(World::clutter()),
            "office" => Some(World::office()),
            "corridor" => Some(World::corridor()),
            "ring" => Some(World::ring()),
            "curve" => Some(World::curve()),
            "hall360" => Some(World::hall360()),
            "moved" => Some(World::moved()),
            _ => None,
        }
    }

    /// Ground-truth walls for scoring maps: the walls in order, then each pillar's polygon
    /// ([`Pillar::polygon`]) in pillar order. Metres, world frame.
    pub fn truth_walls(&self) -> Vec<Segment> {
        let mut out = self.walls.clone();
        for p in &self.pillars {
            out.extend(p.polygon());
        }
        out
    }

    /// Distance from a point to the nearest wall or pillar surface, metres (infinite when the
    /// world is empty).
    pub fn clearance_m(&self, p_in_world: Vec2) -> f64 {
        let walls = self.walls.iter().map(|w| w.distance_to_point(p_in_world));
        let pillars = self.pillars.iter().map(|c| c.distance_to_point(p_in_world));
        walls.chain(pillars).fold(f64::INFINITY, f64::min)
    }

    /// Sum of wall lengths (pillars excluded), metres.
    pub fn total_wall_length_m(&self) -> f64 {
        self.walls.iter().map(Segment::length).sum()
    }

    /// The same world moved rigidly by `new_from_world`: walls, pillars and waypoints. Use it
    /// to test that nothing depends on the world being axis-aligned.
    ///
    /// ```
    /// use polymap::geometry::{Pose2, Vec2};
    /// use polymap_sim::World;
    /// let turned = World::office().transformed(&Pose2::new(0.0, 0.0, std::f64::consts::FRAC_PI_2));
    /// assert!((turned.waypoints[0] - Vec2::new(0.0, 2.0)).length() < 1e-12);
    /// assert_eq!(turned.walls.len(), World::office().walls.len());
    /// ```
    pub fn transformed(&self, new_from_world: &Pose2) -> World {
        World {
            name: self.name.clone(),
            description: self.description.clone(),
            walls: self
                .walls
                .iter()
                .map(|w| w.transformed(new_from_world))
                .collect(),
            pillars: self
                .pillars
                .iter()
                .map(|p| Pillar {
                    center: new_from_world.transform_point(p.center),
                    radius_m: p.radius_m,
                })
                .collect(),
            waypoints: self
                .waypoints
                .iter()
                .map(|&p| new_from_world.transform_point(p))
                .collect(),
            laser: self.laser.clone(),
            moved: self.moved.as_ref().map(|m| Moved {
                before: m
                    .before
                    .iter()
                    .map(|w| w.transformed(new_from_world))
                    .collect(),
                ..m.clone()
            }),
        }
    }

    /// Axis-aligned bounds `(min, max)` of the finite walls and pillars, or `None` if there are
    /// none.
    pub fn bounds(&self) -> Option<(Vec2, Vec2)> {
        let walls = self
            .walls
            .iter()
            .filter(|w| w.is_finite())
            .map(Segment::bounds);
        let pillars = self.pillars.iter().filter(|p| p.is_valid()).map(|p| {
            let r = Vec2::splat(p.radius_m);
            (p.center - r, p.center + r)
        });
        walls
            .chain(pillars)
            .reduce(|(a0, a1), (b0, b1)| (a0.min(b0), a1.max(b1)))
    }
}

/// A built-in world by name: same as [`World::by_name`].
pub fn world_by_name(name: &str) -> Option<World> {
    World::by_name(name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pillar_polygon_is_closed_and_on_the_circle() {
        let p = Pillar {
            center: Vec2::new(2.0, -1.0),
            radius_m: 0.25,
        };
        let poly = p.polygon();
        assert_eq!(poly.len(), p.sides());
        for (a, b) in poly.iter().zip(poly.iter().cycle().skip(1)) {
            assert!((a.end - b.start).length() < 1e-12);
            assert!((p.distance_to_point(a.start)).abs() < 1e-12);
        }
    }

    #[test]
    fn pillar_side_at_matches_polygon() {
        let p = Pillar {
            center: Vec2::ZERO,
            radius_m: 1.0,
        };
        let poly = p.polygon();
        for (k, side) in poly.iter().enumerate() {
            assert_eq!(p.side_at(side.midpoint()), k);
        }
    }

    #[test]
    fn degenerate_pillar_has_minimum_sides() {
        let p = Pillar {
            center: Vec2::ZERO,
            radius_m: f64::NAN,
        };
        assert_eq!(p.sides(), PILLAR_MIN_SIDES);
        assert!(!p.is_valid());
    }

    #[test]
    fn catalogue_names_round_trip() {
        for (w, name) in World::catalogue().iter().zip(World::names()) {
            assert_eq!(w.name, name);
            assert_eq!(World::by_name(name).as_ref(), Some(w));
        }
        assert_eq!(World::default().name, DEFAULT_WORLD_NAME);
    }

    #[test]
    fn truth_walls_append_pillar_polygons() {
        for w in World::catalogue() {
            let sides: usize = w.pillars.iter().map(Pillar::sides).sum();
            assert_eq!(w.truth_walls().len(), w.walls.len() + sides, "{}", w.name);
        }
    }
}
