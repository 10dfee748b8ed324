//! `corridor`: a 40 m corridor, bare but for features at its two ends.
//!
//! The robot drives the length of it, turns on the spot and drives back. Its laser reaches
//! 10 m (a Hokuyo UST-10LX), so along the middle 20-odd metres it sees only the two parallel
//! side walls: the motion across the corridor and the turn are observable, the motion along
//! it is not. A tracker must say so (a `weak` verdict) rather than report a confident pose.

use super::build::{Niche, chain_walls, edge_points, rotated_box, v};
use crate::laser::LaserParams;
use crate::world::{Pillar, World};

/// Length of the corridor between its end walls, metres.
const LENGTH_M: f64 = 42.0;
/// Half the corridor width, metres (the corridor is 2.4 m wide).
const HALF_WIDTH_M: f64 = 1.2;
/// The laser's range, metres.
const LASER_RANGE_M: f64 = 10.0;

/// South wall (west to east) with a door recess near each end.
fn south_wall() -> Vec<polymap::geometry::Vec2> {
    let (a, b) = (v(-1.0, -HALF_WIDTH_M), v(LENGTH_M - 1.0, -HALF_WIDTH_M));
    let mut p = edge_points(
        a,
        b,
        &[
            Niche::rect(2.5, 1.2, 0.5),
            Niche::hex(LENGTH_M - 4.0, 1.6, 0.5),
        ],
    );
    p.push(b);
    p
}

/// North wall (west to east) with a recess near the west end.
fn north_wall() -> Vec<polymap::geometry::Vec2> {
    let (a, b) = (v(-1.0, HALF_WIDTH_M), v(LENGTH_M - 1.0, HALF_WIDTH_M));
    let mut p = edge_points(a, b, &[Niche::rect(4.5, 1.0, -0.4)]);
    p.push(b);
    p
}

/// Builds the world.
pub(crate) fn build() -> World {
    let end = LENGTH_M - 1.0;
    let mut walls = chain_walls(&south_wall());
    walls.extend(chain_walls(&north_wall()));
    walls.extend(chain_walls(&[
        v(-1.0, -HALF_WIDTH_M),
        v(-1.0, HALF_WIDTH_M),
    ]));
    walls.extend(chain_walls(&[v(end, -HALF_WIDTH_M), v(end, HALF_WIDTH_M)]));
    // A cabinet against the north wall near the east end.
    walls.extend(rotated_box(
        v(end - 2.5, HALF_WIDTH_M - 0.3),
        0.4,
        0.25,
        0.0,
    ));
    World {
        moved: None,
        name: "corridor".into(),
        description: "A 42 m × 2.4 m corridor, bare but for recesses, a cabinet and a pillar near \
                      its two ends, seen with a 10 m laser. The robot drives to the far end, \
                      turns on the spot and comes back."
            .into(),
        walls,
        pillars: vec![Pillar {
            center: v(end - 5.5, 0.3 - HALF_WIDTH_M),
            radius_m: 0.15,
        }],
        waypoints: vec![v(0.5, 0.0), v(end - 1.5, 0.0), v(0.5, 0.0)],
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
    fn the_middle_is_bare() {
        let w = build();
        let across = |s: &polymap::geometry::Segment| {
            let d = s.end - s.start;
            d.x.abs() < d.y.abs()
        };
        let cross_x: Vec<f64> = w
            .walls
            .iter()
            .filter(|s| across(s))
            .flat_map(|s| [s.start.x, s.end.x])
            .chain(w.pillars.iter().map(|p| p.center.x))
            .collect();
        let bare = cross_x
            .iter()
            .all(|&x| !(6.0..=LENGTH_M - 9.0).contains(&x));
        assert!(bare, "{cross_x:?}");
    }
}
