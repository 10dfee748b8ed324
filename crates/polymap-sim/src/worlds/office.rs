//! `office`: a ring corridor lined with rooms, each reached through a 0.9 m doorway.
//!
//! The corridor walls are long straight lines broken only by doorways, so segments on one
//! line face each other across every door: the "collinear walls across a doorway" trap of
//! the merge step.

use polymap::geometry::Segment;

use super::build::{v, wall_with_doors};
use crate::world::World;

/// Doorway width, metres.
const DOOR_M: f64 = 0.9;

/// Doorways as `(start, end)` distances along a wall, from the positions of their starts.
fn doors(starts: &[f64]) -> Vec<(f64, f64)> {
    starts.iter().map(|&s| (s, s + DOOR_M)).collect()
}

/// The corridor's walls: outer ring (rooms outside) and inner ring (rooms in the core).
fn corridor_walls() -> Vec<Segment> {
    let mut w = Vec::new();
    // Outer south wall y = -1 and north wall y = 13, from x = -1 to 31.
    w.extend(wall_with_doors(
        v(-1.0, -1.0),
        v(31.0, -1.0),
        &doors(&[2.5, 8.5, 14.5, 20.5, 27.0]),
    ));
    w.extend(wall_with_doors(
        v(-1.0, 13.0),
        v(31.0, 13.0),
        &doors(&[4.0, 10.0, 16.0, 22.0, 28.5]),
    ));
    // Inner ring: y = 1 and y = 11 from x = 1 to 29, x = 1 and x = 29 from y = 1 to 11.
    w.extend(wall_with_doors(
        v(1.0, 1.0),
        v(29.0, 1.0),
        &doors(&[2.0, 9.0, 16.0, 23.0]),
    ));
    w.extend(wall_with_doors(
        v(1.0, 11.0),
        v(29.0, 11.0),
        &doors(&[4.5, 11.5, 18.5, 25.5]),
    ));
    w.extend(wall_with_doors(v(29.0, 1.0), v(29.0, 11.0), &doors(&[2.0])));
    w.extend(wall_with_doors(v(1.0, 1.0), v(1.0, 11.0), &doors(&[7.0])));
    w
}

/// The building's shell and the walls between rooms.
fn room_walls() -> Vec<Segment> {
    let s = |x0, y0, x1, y1| Segment::new(v(x0, y0), v(x1, y1));
    let mut w = vec![
        s(-1.0, -5.0, 31.0, -5.0),
        s(31.0, -5.0, 31.0, 17.0),
        s(31.0, 17.0, -1.0, 17.0),
        s(-1.0, 17.0, -1.0, -5.0),
        s(1.0, 6.0, 29.0, 6.0),
    ];
    for x in [5.0, 11.0, 17.0, 23.0] {
        w.push(s(x, -5.0, x, -1.0));
        w.push(s(x, 13.0, x, 17.0));
    }
    for x in [8.0, 15.0, 22.0] {
        w.push(s(x, 1.0, x, 11.0));
    }
    w
}

/// Builds the world.
pub(crate) fn build() -> World {
    let mut walls = corridor_walls();
    walls.extend(room_walls());
    World {
        moved: None,
        name: "office".into(),
        description: "Office floor 32 m × 22 m: a 2 m ring corridor with five rooms on each long \
                      outer side and eight rooms in the core, all behind 0.9 m doorways in \
                      otherwise collinear walls. The robot goes once round."
            .into(),
        walls,
        pillars: vec![],
        waypoints: vec![
            v(2.0, 0.0),
            v(30.0, 0.0),
            v(30.0, 12.0),
            v(0.0, 12.0),
            v(0.0, 0.0),
            v(4.0, 0.0),
        ],
        laser: Default::default(),
    }
}
