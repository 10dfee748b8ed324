//! `hall360`: an L-shaped hall with pillars and boxes, mapped by a 360° laser.
//!
//! A laser that sees all round keeps what lies behind the robot in view, and a turn on the
//! spot does not change what it sees; the tour ends with one (a 180° turn) and a return.

use super::build::{closed_walls, rotated_box, v};
use crate::laser::LaserParams;
use crate::world::{Pillar, World};

/// The outline, counter-clockwise, metres.
fn outline() -> Vec<polymap::geometry::Vec2> {
    vec![
        v(0.0, 0.0),
        v(24.0, 0.0),
        v(24.0, 10.0),
        v(14.0, 10.0),
        v(14.0, 18.0),
        v(0.0, 18.0),
    ]
}

/// Pillars: centre x, centre y, radius (m).
const PILLARS: [(f64, f64, f64); 3] = [(6.0, 6.0, 0.3), (12.0, 6.0, 0.3), (5.5, 9.0, 0.25)];

/// Builds the world.
pub(crate) fn build() -> World {
    let mut walls = closed_walls(&outline());
    walls.extend(rotated_box(v(17.0, 5.5), 1.0, 0.5, 20f64.to_radians()));
    walls.extend(rotated_box(v(7.5, 12.5), 0.6, 0.4, 35f64.to_radians()));
    let pillars = PILLARS
        .iter()
        .map(|&(x, y, r)| Pillar {
            center: v(x, y),
            radius_m: r,
        })
        .collect();
    World {
        moved: None,
        name: "hall360".into(),
        description: "L-shaped hall 24 m × 18 m with three round pillars and two boxes, mapped \
                      by a 360° laser. The robot goes once round, then 6 m on, turns on \
                      the spot and comes back."
            .into(),
        walls,
        pillars,
        waypoints: vec![
            v(3.0, 3.0),
            v(21.0, 3.0),
            v(21.0, 7.5),
            v(11.0, 8.5),
            v(11.0, 15.5),
            v(3.0, 15.5),
            v(3.0, 3.0),
            v(9.0, 3.0),
            v(3.0, 3.0),
        ],
        laser: LaserParams::full_circle(),
    }
}
