//! `ring`: a rectangular ring hallway whose only features are one round pillar and one box.
//!
//! Plain walls everywhere else: between the corners, the motion along a hallway is
//! observable only through the pillar, the box, or the next corner when it is within the
//! laser's 20 m. Seen with a 180° laser.

use super::build::{closed_walls, offset_polygon, rotated_box, v};
use crate::laser::LaserParams;
use crate::world::{Pillar, World};

/// Half the hallway width, metres (the hallway is 2.4 m wide).
const HALF_WIDTH_M: f64 = 1.2;
/// The laser's range, metres.
const LASER_RANGE_M: f64 = 20.0;

/// The ring's centre line, counter-clockwise, metres.
fn centre_line() -> Vec<polymap::geometry::Vec2> {
    vec![v(0.0, 0.0), v(44.0, 0.0), v(44.0, 18.0), v(0.0, 18.0)]
}

/// Builds the world.
pub(crate) fn build() -> World {
    let centre = centre_line();
    let mut walls = closed_walls(&offset_polygon(&centre, HALF_WIDTH_M));
    walls.extend(closed_walls(&offset_polygon(&centre, -HALF_WIDTH_M)));
    // A box against the outer wall of the north hallway.
    walls.extend(rotated_box(
        v(26.0, 18.0 + HALF_WIDTH_M - 0.3),
        0.5,
        0.25,
        0.0,
    ));
    World {
        moved: None,
        name: "ring".into(),
        description: "Rectangular ring hallway, 2.4 m wide and 124 m round, plain walls but for \
                      one round pillar (south hallway) and one box (north hallway), seen with a \
                      180° laser of 20 m range. The robot goes once round."
            .into(),
        walls,
        pillars: vec![Pillar {
            center: v(16.0, 0.3 - HALF_WIDTH_M),
            radius_m: 0.15,
        }],
        waypoints: vec![
            v(2.0, 0.0),
            v(44.0, 0.0),
            v(44.0, 18.0),
            v(0.0, 18.0),
            v(0.0, 0.0),
            v(4.0, 0.0),
        ],
        laser: LaserParams {
            max_range_m: LASER_RANGE_M,
            ..LaserParams::default()
        },
    }
}
