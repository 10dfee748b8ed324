//! `moved`: a room whose cupboard is carried to another place half way through the tour.
//!
//! The robot goes twice round the cupboard standing in the middle of a 16 m × 10 m room; before
//! the second round the cupboard is carried to the north wall. On the second round the rays pass
//! where it stood: a map that keeps it keeps a ghost. Two boxes and a pillar by the walls keep
//! the room's shape unambiguous for tracking.

use polymap::geometry::Segment;

use super::build::{closed_walls, rotated_box, v};
use crate::world::{Moved, Pillar, World};

/// The cupboard's half extents, metres.
const CUPBOARD_HALF_M: (f64, f64) = (0.6, 0.3);

/// The cupboard before the change: in the middle of the room, turned a little.
fn cupboard_before() -> Vec<Segment> {
    rotated_box(
        v(8.0, 5.0),
        CUPBOARD_HALF_M.0,
        CUPBOARD_HALF_M.1,
        10f64.to_radians(),
    )
}

/// The cupboard after the change: against the north wall, east of the middle.
fn cupboard_after() -> Vec<Segment> {
    rotated_box(v(11.0, 9.6), CUPBOARD_HALF_M.0, CUPBOARD_HALF_M.1, 0.0)
}

/// Builds the world.
pub(crate) fn build() -> World {
    let mut walls = closed_walls(&[v(0.0, 0.0), v(16.0, 0.0), v(16.0, 10.0), v(0.0, 10.0)]);
    walls.extend(rotated_box(v(3.0, 0.4), 0.8, 0.4, 0.0));
    walls.extend(rotated_box(v(15.5, 4.0), 0.5, 1.0, 0.0));
    let after = cupboard_after();
    let replaces_last = after.len();
    walls.extend(after);
    World {
        name: "moved".into(),
        description: "Room 16 m × 10 m with a cupboard in the middle that is carried to the \
                      north wall half way through the tour; the robot goes twice round it, so \
                      the second round sees the old place empty."
            .into(),
        walls,
        pillars: vec![Pillar {
            center: v(0.8, 7.0),
            radius_m: 0.2,
        }],
        waypoints: vec![
            v(3.0, 2.5),
            v(13.0, 2.5),
            v(13.0, 7.5),
            v(3.0, 7.5),
            v(3.0, 2.5),
            v(13.0, 2.5),
            v(13.0, 7.5),
            v(3.0, 7.5),
            v(3.0, 2.5),
        ],
        laser: Default::default(),
        moved: Some(Moved {
            at_share: 0.5,
            replaces_last,
            before: cupboard_before(),
        }),
    }
}
