//! `hallway45`: a ring hallway with walls at 0° and 90° and one stretch at 45°.
//!
//! Modelled on the paper's Bremen hallway (Fig. 7): the robot drives east along a 0°/90°
//! corridor, approaches a 45° corner, follows the 45° stretch (a new main direction must
//! appear), and then goes once round the ring back to where it started.

use super::build::{Niche, offset_polygon, polygon_with_niches, v};
use crate::world::World;

/// Half the corridor width, metres (the corridor is 2 m wide).
const HALF_WIDTH_M: f64 = 1.0;
/// Depth of the door niches, metres.
const NICHE_DEPTH_M: f64 = 0.4;

/// The ring corridor's centre line, counter-clockwise; edge 1 is the 45° stretch.
fn centre_line() -> Vec<polymap::geometry::Vec2> {
    vec![
        v(0.0, 0.0),
        v(18.0, 0.0),
        v(24.0, 6.0),
        v(24.0, 16.0),
        v(0.0, 16.0),
    ]
}

/// Niches in the outer wall (outward), per edge of the outer polygon.
fn outer_niches() -> Vec<(usize, Niche)> {
    let n = |edge, at, width| (edge, Niche::rect(at, width, NICHE_DEPTH_M));
    vec![
        n(0, 4.0, 1.0),
        n(0, 9.5, 1.2),
        n(0, 14.0, 1.0),
        n(2, 4.0, 1.0),
        n(2, 8.5, 1.0),
        n(3, 5.0, 1.0),
        n(3, 11.0, 1.2),
        n(3, 16.0, 3.0),
        n(3, 22.0, 1.0),
        n(4, 6.0, 1.0),
        n(4, 12.5, 1.0),
    ]
}

/// Niches in the inner wall (into the inner block), per edge of the inner polygon.
fn inner_niches() -> Vec<(usize, Niche)> {
    let n = |edge, at, width| (edge, Niche::rect(at, width, -NICHE_DEPTH_M));
    vec![
        n(0, 7.0, 1.0),
        n(0, 12.0, 2.0),
        n(2, 5.0, 1.0),
        n(3, 8.0, 1.0),
        n(3, 15.0, 1.0),
        n(4, 7.0, 1.5),
    ]
}

/// Builds the world.
pub(crate) fn build() -> World {
    let centre = centre_line();
    let outer = offset_polygon(&centre, HALF_WIDTH_M);
    let inner = offset_polygon(&centre, -HALF_WIDTH_M);
    let mut walls = polygon_with_niches(&outer, &outer_niches());
    walls.extend(polygon_with_niches(&inner, &inner_niches()));
    World {
        moved: None,
        name: "hallway45".into(),
        description: "Ring hallway, 2 m wide and about 78 m round, walls at 0° and 90° with \
                      door niches, and one 8.5 m stretch at 45° (the paper's Bremen hallway, \
                      Fig. 7). The robot goes once round and returns past its start."
            .into(),
        walls,
        pillars: vec![],
        waypoints: vec![
            v(2.0, 0.0),
            v(18.0, 0.0),
            v(24.0, 6.0),
            v(24.0, 16.0),
            v(0.0, 16.0),
            v(0.0, 0.0),
            v(4.0, 0.0),
        ],
        laser: Default::default(),
    }
}
