//! `clutter`: an open area with no dominant direction.
//!
//! An irregular outline encloses boxes turned to scattered angles and round pillars. The box
//! angles are a fixed list of arbitrary-looking values, so the world never changes.

use super::build::{closed_walls, rotated_box, v};
use crate::world::{Pillar, World};

/// The outline, counter-clockwise, metres.
fn outline() -> Vec<polymap::geometry::Vec2> {
    vec![
        v(0.0, 0.0),
        v(12.0, -2.5),
        v(24.0, -1.0),
        v(31.0, 6.0),
        v(29.5, 15.0),
        v(22.0, 21.0),
        v(10.0, 22.5),
        v(1.0, 18.0),
        v(-3.0, 9.0),
    ]
}

/// Boxes: centre x, centre y, half extents (m), rotation (degrees).
const BOXES: [(f64, f64, f64, f64, f64); 12] = [
    (10.0, 8.0, 0.8, 0.5, 17.0),
    (15.5, 6.5, 0.6, 0.6, 52.0),
    (19.5, 10.0, 1.0, 0.4, 8.0),
    (12.0, 12.5, 0.5, 0.9, 71.0),
    (17.0, 14.0, 0.7, 0.5, 33.0),
    (7.0, 11.5, 0.4, 0.4, 86.0),
    (12.0, 0.3, 0.6, 0.4, 24.0),
    (28.0, 10.5, 0.5, 0.8, 63.0),
    (20.0, 19.0, 0.9, 0.4, 41.0),
    (4.5, 18.0, 0.5, 0.5, 12.0),
    (-0.5, 9.0, 0.4, 0.7, 58.0),
    (21.0, 8.0, 0.5, 0.3, 77.0),
];

/// Pillars: centre x, centre y, radius (m).
const PILLARS: [(f64, f64, f64); 8] = [
    (13.5, 9.5, 0.3),
    (8.5, 13.5, 0.2),
    (20.5, 13.5, 0.35),
    (6.5, 8.0, 0.25),
    (27.0, 3.0, 0.3),
    (12.0, 20.0, 0.25),
    (26.5, 17.0, 0.3),
    (17.0, 1.0, 0.2),
];

/// Builds the world.
pub(crate) fn build() -> World {
    let mut walls = closed_walls(&outline());
    for &(x, y, hx, hy, deg) in &BOXES {
        walls.extend(rotated_box(v(x, y), hx, hy, deg.to_radians()));
    }
    let pillars = PILLARS
        .iter()
        .map(|&(x, y, r)| Pillar {
            center: v(x, y),
            radius_m: r,
        })
        .collect();
    World {
        moved: None,
        name: "clutter".into(),
        description: "Open area about 34 m × 25 m inside an irregular nine-sided outline, with \
                      twelve boxes at scattered angles and eight round pillars; no dominant \
                      direction. The robot drives one loop."
            .into(),
        walls,
        pillars,
        waypoints: vec![
            v(4.0, 3.2),
            v(20.0, 3.0),
            v(25.5, 8.5),
            v(24.5, 15.0),
            v(14.0, 17.5),
            v(4.0, 14.5),
            v(2.5, 6.5),
            v(6.0, 3.2),
        ],
        laser: Default::default(),
    }
}
