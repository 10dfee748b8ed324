//! `curve`: a curved hallway, an S of two circular bends between two short straights.
//!
//! Along a circular bend the walls are the same however far the robot has driven round it:
//! the motion along the hallway is a rotation about the bend's centre, which the walls do not
//! observe (the unobservable direction couples translation and rotation, unlike a straight
//! corridor's). A few door niches in the outer walls and the two ends observe it. The walls are
//! arcs drawn as chords 0.5 m long, so the map must approximate curves with polylines.

use std::f64::consts::PI;

use polymap::geometry::Vec2;

use super::build::{chain_walls, v};
use crate::laser::LaserParams;
use crate::world::World;

/// Half the hallway width, metres (the hallway is 2.4 m wide).
const HALF_WIDTH_M: f64 = 1.2;
/// Length of the straight at each end, metres.
const STRAIGHT_M: f64 = 5.0;
/// The first bend (left): radius of its centre line, metres, and its turn, radians.
const BEND_1: (f64, f64) = (12.0, 100.0 * PI / 180.0);
/// The second bend (right).
const BEND_2: (f64, f64) = (8.0, -80.0 * PI / 180.0);
/// Length of the chords that draw a wall, metres (at most).
const CHORD_M: f64 = 0.5;
/// The laser's range, metres: a 15 m scanner sees little of a bend past its own part.
const LASER_RANGE_M: f64 = 15.0;
/// Door niches: (arc length along the centre line, metres; side, +1 left / −1 right).
const NICHES: [(f64, f64); 5] = [
    (9.0, -1.0),
    (18.0, -1.0),
    (24.5, 1.0),
    (31.0, -1.0),
    (38.0, 1.0),
];
/// Width and depth of a door niche, metres.
const NICHE_WIDTH_M: f64 = 1.0;
const NICHE_DEPTH_M: f64 = 0.3;

/// The centre line's pose at arc length `s` (metres from the west end): position and heading.
fn centre(s: f64) -> (Vec2, f64) {
    let legs = [
        (STRAIGHT_M, f64::INFINITY),
        (BEND_1.0 * BEND_1.1.abs(), BEND_1.0 * BEND_1.1.signum()),
        (BEND_2.0 * BEND_2.1.abs(), BEND_2.0 * BEND_2.1.signum()),
        (STRAIGHT_M, f64::INFINITY),
    ];
    let (mut p, mut heading) = (v(0.0, 0.0), 0.0_f64);
    let mut left = s.max(0.0);
    for (i, &(length, signed_radius)) in legs.iter().enumerate() {
        let last = i + 1 == legs.len();
        let d = if last { left } else { left.min(length) };
        let dir = Vec2::new(heading.cos(), heading.sin());
        if signed_radius.is_infinite() {
            p += dir * d;
        } else {
            let turn = d / signed_radius;
            let to_centre = dir.perp() * signed_radius;
            let c = p + to_centre;
            let (sin, cos) = turn.sin_cos();
            let r = -to_centre;
            p = c + Vec2::new(cos * r.x - sin * r.y, sin * r.x + cos * r.y);
            heading += turn;
        }
        left -= d;
        if left <= 0.0 {
            break;
        }
    }
    (p, heading)
}

/// The hallway's length along its centre line, metres.
fn length_m() -> f64 {
    2.0 * STRAIGHT_M + BEND_1.0 * BEND_1.1.abs() + BEND_2.0 * BEND_2.1.abs()
}

/// The point `offset` metres to the left of the centre line at arc length `s`.
fn beside(s: f64, offset: f64) -> Vec2 {
    let (p, heading) = centre(s);
    p + Vec2::new(-heading.sin(), heading.cos()) * offset
}

/// One side wall (`side` +1 left, −1 right) from the west end to the east end, niches cut in.
fn side_wall(side: f64) -> Vec<Vec2> {
    let length = length_m();
    let mut niches: Vec<(f64, f64)> = NICHES
        .iter()
        .filter(|(_, s)| *s == side)
        .map(|&(at, _)| (at - NICHE_WIDTH_M / 2.0, at + NICHE_WIDTH_M / 2.0))
        .collect();
    niches.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut points = Vec::new();
    let mut s = 0.0;
    let wall = side * HALF_WIDTH_M;
    let recess = side * (HALF_WIDTH_M + NICHE_DEPTH_M);
    for &(from, to) in niches.iter().chain([(length, length)].iter()) {
        let n = ((from - s) / CHORD_M).ceil().max(1.0) as usize;
        for k in 0..n {
            points.push(beside(s + (from - s) * k as f64 / n as f64, wall));
        }
        if to > from {
            points.push(beside(from, wall));
            let m = ((to - from) / CHORD_M).ceil().max(1.0) as usize;
            for k in 0..=m {
                points.push(beside(from + (to - from) * k as f64 / m as f64, recess));
            }
            points.push(beside(to, wall));
        }
        s = to;
    }
    points.push(beside(length, wall));
    points
}

/// Builds the world.
pub(crate) fn build() -> World {
    let length = length_m();
    let mut walls = chain_walls(&side_wall(1.0));
    walls.extend(chain_walls(&side_wall(-1.0)));
    walls.extend(chain_walls(&[
        beside(0.0, -HALF_WIDTH_M),
        beside(0.0, HALF_WIDTH_M),
    ]));
    walls.extend(chain_walls(&[
        beside(length, -HALF_WIDTH_M),
        beside(length, HALF_WIDTH_M),
    ]));
    // The tour: along the centre line every metre to 1 m short of the far end, and back.
    let n = (length - 2.0).floor() as usize;
    let out: Vec<Vec2> = (0..=n).map(|k| centre(1.0 + k as f64).0).collect();
    let mut waypoints = out.clone();
    waypoints.extend(out.iter().rev().skip(1).copied());
    World {
        moved: None,
        name: "curve".into(),
        description: "A curved hallway 2.4 m wide and 41 m long: a left bend of 12 m radius \
                      through 100° and a right bend of 8 m radius through 80° between two 5 m \
                      straights, with five door niches, seen with a 15 m laser. The robot drives \
                      to the far end, turns on the spot and comes back."
            .into(),
        walls,
        pillars: vec![],
        waypoints,
        laser: LaserParams {
            max_range_m: LASER_RANGE_M,
            ..LaserParams::default()
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_centre_line_is_continuous_and_turns_by_the_bends() {
        let step = 0.01;
        let mut last = centre(0.0);
        let mut s = step;
        while s <= length_m() {
            let now = centre(s);
            assert!(((now.0 - last.0).length() - step).abs() < 1e-6, "at {s}");
            last = now;
            s += step;
        }
        let turn = centre(length_m()).1 - centre(0.0).1;
        assert!((turn - (BEND_1.1 + BEND_2.1)).abs() < 1e-9, "{turn}");
    }

    #[test]
    fn the_walls_keep_the_hallways_width_along_the_bends() {
        let w = build();
        // From 1.5 m inside one end wall to 1.5 m inside the other.
        for k in 0..38 {
            let s = 1.5 + k as f64;
            let (p, _) = centre(s);
            let nearest = w
                .walls
                .iter()
                .map(|wall| wall.distance_to_point(p))
                .fold(f64::INFINITY, f64::min);
            // Chords of 0.5 m on an arc of 6.8 m radius lie within 5 mm inside it.
            assert!((nearest - HALF_WIDTH_M).abs() < 0.01, "{s}: {nearest}");
        }
    }
}
