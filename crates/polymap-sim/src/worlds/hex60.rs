//! `hex60`: a hexagonal building whose walls all run at 0° or ±60° (the paper's Figs. 2, 3, 6).
//!
//! A hexagonal ring corridor round a hexagonal core, with trapezoidal niches and two
//! half-hexagon rooms opening off it, and triangular notches in the core. Every wall, niche
//! sides included, lies on the 60° lattice.

use std::f64::consts::FRAC_PI_3;

use polymap::geometry::Vec2;

use super::build::{Niche, offset_polygon, polygon_with_niches, v};
use crate::world::World;

/// Circumradius of the corridor's centre line, metres (its side is as long).
const CENTRE_RADIUS_M: f64 = 10.0;
/// Half the corridor width, metres.
const HALF_WIDTH_M: f64 = 1.2;

/// Vertex `k` of a flat-topped regular hexagon of circumradius `r` centred at the origin.
fn hex_vertex(r: f64, k: usize) -> Vec2 {
    let a = FRAC_PI_3 * k as f64;
    Vec2::new(r * a.cos(), r * a.sin())
}

/// Niches of the outer wall: small trapezoids and two large half-hexagon rooms.
fn outer_niches() -> Vec<(usize, Niche)> {
    let small = |edge, at| (edge, Niche::hex(at, 1.2, 0.4));
    vec![
        small(0, 3.0),
        small(0, 8.0),
        (1, Niche::hex(5.7, 6.0, 2.6)),
        small(2, 4.0),
        small(2, 8.5),
        small(3, 3.5),
        small(3, 7.5),
        (4, Niche::hex(5.7, 6.0, 2.6)),
        small(5, 2.5),
        small(5, 8.0),
    ]
}

/// Niches of the core's wall (pointing into the core): triangles and trapezoids.
fn inner_niches() -> Vec<(usize, Niche)> {
    vec![
        (0, Niche::hex(4.3, 1.6, 2.0)),
        (1, Niche::hex(3.0, 2.0, 0.5)),
        (2, Niche::hex(5.0, 1.6, 2.0)),
        (3, Niche::hex(4.3, 2.0, 0.5)),
        (4, Niche::hex(3.5, 1.6, 2.0)),
        (5, Niche::hex(5.5, 2.0, 0.5)),
    ]
    .into_iter()
    .map(|(e, mut n)| {
        n.depth_m = -n.depth_m;
        (e, n)
    })
    .collect()
}

/// Builds the world.
pub(crate) fn build() -> World {
    let centre: Vec<Vec2> = (0..6).map(|k| hex_vertex(CENTRE_RADIUS_M, k)).collect();
    let outer = offset_polygon(&centre, HALF_WIDTH_M);
    let inner = offset_polygon(&centre, -HALF_WIDTH_M);
    let mut walls = polygon_with_niches(&outer, &outer_niches());
    walls.extend(polygon_with_niches(&inner, &inner_niches()));
    let y_bottom = -CENTRE_RADIUS_M * FRAC_PI_3.sin();
    let mut waypoints = vec![v(-2.0, y_bottom)];
    waypoints.extend((0..6).map(|k| hex_vertex(CENTRE_RADIUS_M, (k + 5) % 6)));
    waypoints.push(v(1.0, y_bottom));
    World {
        moved: None,
        name: "hex60".into(),
        description: "Hexagonal ring corridor, 2.4 m wide and 60 m round, with walls at 0° and \
                      ±60° only: trapezoidal niches, two half-hexagon rooms and triangular \
                      notches. The robot goes once round."
            .into(),
        walls,
        pillars: vec![],
        waypoints,
        laser: Default::default(),
    }
}
