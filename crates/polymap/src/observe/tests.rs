use proptest::prelude::*;

use super::*;
use crate::geometry::Segment;
use crate::map::{MapSegment, Observations};

fn seg(x0: f64, y0: f64, x1: f64, y1: f64) -> MapSegment {
    MapSegment {
        segment: Segment::new(Vec2::new(x0, y0), Vec2::new(x1, y1)),
        born_scan: 0,
    }
}

/// Returns of a 180° scan (one per degree) from `pose` against `walls` (map frame), robot
/// frame: the nearest wall along each beam, no return beyond 30 m.
fn scan_of(walls: &[Segment], pose: &Pose2) -> Vec<Vec2> {
    (0..=180)
        .filter_map(|k| {
            let bearing = (k as f64 - 90.0).to_radians();
            let dir = pose.rotate(Vec2::new(bearing.cos(), bearing.sin()));
            let r = walls
                .iter()
                .filter_map(|w| w.ray_hit_m(pose.translation(), dir))
                .fold(f64::INFINITY, f64::min);
            (r < 30.0).then(|| Vec2::new(bearing.cos(), bearing.sin()) * r)
        })
        .collect()
}

fn params_every_scan() -> ObserveParams {
    ObserveParams {
        min_travel_m: 0.0,
        ..ObserveParams::default()
    }
}

/// The walls of a room 10 × 6 m with a corner at the origin.
fn room() -> [Segment; 4] {
    [
        Segment::new(Vec2::new(0.0, 0.0), Vec2::new(10.0, 0.0)),
        Segment::new(Vec2::new(10.0, 0.0), Vec2::new(10.0, 6.0)),
        Segment::new(Vec2::new(10.0, 6.0), Vec2::new(0.0, 6.0)),
        Segment::new(Vec2::new(0.0, 6.0), Vec2::new(0.0, 0.0)),
    ]
}

#[test]
fn a_ghost_is_seen_through_and_pruned_and_the_walls_stay() {
    // The room; the map also holds a box face at x = 5 that is gone.
    let room = room();
    let mut map = GlobalMap::default();
    for w in &room {
        map.insert(MapSegment {
            segment: *w,
            born_scan: 0,
        });
    }
    let ghost = map.insert(seg(5.0, 2.0, 5.0, 4.0));
    let p = ObserveParams::default();
    for k in 0..6 {
        let pose = Pose2::new(1.0 + 0.3 * k as f64, 3.0, 0.0);
        let out = observe_scan(&mut map, &scan_of(&room, &pose), &pose, k + 1, true, &p);
        assert!(out.observed && out.rays > 80, "{out:?}");
    }
    let o = map.observations(ghost).unwrap();
    assert_eq!((o.seen, o.through_since_seen), (1, 6));
    assert_eq!(prune_contradicted(&mut map, &p), 1);
    assert_eq!(map.len(), 4);
    assert!(map.get(ghost).is_none());
}

#[test]
fn a_wall_seen_from_both_sides_is_never_seen_through() {
    let wall = Segment::new(Vec2::new(5.0, -3.0), Vec2::new(5.0, 3.0));
    let mut map = GlobalMap::default();
    let id = map.insert(MapSegment {
        segment: wall,
        born_scan: 0,
    });
    let p = params_every_scan();
    for (k, pose) in [Pose2::new(2.0, 0.0, 0.0), Pose2::new(8.0, 0.5, 3.1)]
        .iter()
        .enumerate()
    {
        observe_scan(
            &mut map,
            &scan_of(&[wall], pose),
            pose,
            k as u32 + 1,
            true,
            &p,
        );
    }
    let o = map.observations(id).unwrap();
    assert_eq!((o.seen, o.seen_through, o.last_seen_scan), (3, 0, 2));
}

#[test]
fn the_far_face_of_a_thick_wall_is_not_seen_through() {
    let near = Segment::new(Vec2::new(5.0, -3.0), Vec2::new(5.0, 3.0));
    let far = Segment::new(Vec2::new(5.2, -3.0), Vec2::new(5.2, 3.0));
    let mut map = GlobalMap::default();
    map.insert(MapSegment {
        segment: near,
        born_scan: 0,
    });
    let far_id = map.insert(MapSegment {
        segment: far,
        born_scan: 0,
    });
    let pose = Pose2::new(1.0, 0.0, 0.0);
    let out = observe_scan(
        &mut map,
        &scan_of(&[near], &pose),
        &pose,
        1,
        true,
        &params_every_scan(),
    );
    assert_eq!(out.seen_through, 0);
    assert_eq!(map.observations(far_id), Some(Observations::born(0)));
}

#[test]
fn rays_grazing_along_a_wall_do_not_see_through_it() {
    // A wall along the x axis, 5 cm beside the robot's line of sight; the returns come from a
    // wall further on; the rays cross the first at under 20°.
    let side = Segment::new(
        Vec2::new(2.0, 0.05),
        Vec2::new(2.0, 0.05) + Vec2::new(4.0, -0.6),
    );
    let end = Segment::new(Vec2::new(12.0, -5.0), Vec2::new(12.0, 5.0));
    let mut map = GlobalMap::default();
    let id = map.insert(MapSegment {
        segment: side,
        born_scan: 0,
    });
    let pose = Pose2::IDENTITY;
    let points: Vec<Vec2> = (-5..=5).map(|i| Vec2::new(12.0, 0.3 * i as f64)).collect();
    map.insert(MapSegment {
        segment: end,
        born_scan: 0,
    });
    let out = observe_scan(&mut map, &points, &pose, 1, true, &params_every_scan());
    assert!(out.rays > 0);
    assert_eq!(map.observations(id).unwrap().seen_through, 0);
}

#[test]
fn a_wall_overshooting_a_doorway_is_not_contradicted_through_the_door() {
    // The wall y = 0 ends at x = 5 (a doorway to x = 6), but the map's segment runs on to 5.4.
    // Rays from below through the doorway cross only its tip.
    let map_wall = Segment::new(Vec2::new(0.0, 0.0), Vec2::new(5.4, 0.0));
    let beyond = Segment::new(Vec2::new(-5.0, 4.0), Vec2::new(15.0, 4.0));
    let mut map = GlobalMap::default();
    let id = map.insert(MapSegment {
        segment: map_wall,
        born_scan: 0,
    });
    let pose = Pose2::new(5.5, -2.0, std::f64::consts::FRAC_PI_2);
    let points: Vec<Vec2> = (0..=10)
        .map(|i| Vec2::new(5.0 + 0.1 * i as f64, 4.0))
        .map(|p| pose.inverse().transform_point(p))
        .collect();
    map.insert(MapSegment {
        segment: beyond,
        born_scan: 0,
    });
    observe_scan(&mut map, &points, &pose, 1, true, &params_every_scan());
    assert_eq!(map.observations(id).unwrap().seen_through, 0);
}

#[test]
fn a_robot_standing_still_observes_once() {
    let wall = Segment::new(Vec2::new(5.0, -3.0), Vec2::new(5.0, 3.0));
    let mut map = GlobalMap::default();
    map.insert(MapSegment {
        segment: wall,
        born_scan: 0,
    });
    let p = ObserveParams::default();
    let pose = Pose2::new(1.0, 0.0, 0.0);
    let points = scan_of(&[wall], &pose);
    assert!(observe_scan(&mut map, &points, &pose, 1, true, &p).observed);
    assert!(!observe_scan(&mut map, &points, &pose, 2, true, &p).observed);
    let moved = Pose2::new(1.3, 0.0, 0.0);
    assert!(observe_scan(&mut map, &points, &moved, 3, true, &p).observed);
    let turned = Pose2::new(1.3, 0.0, 0.3);
    assert!(observe_scan(&mut map, &points, &turned, 4, true, &p).observed);
}

#[test]
fn a_long_seen_segment_needs_the_window_of_contradictions() {
    let p = ObserveParams::default();
    let mut o = Observations::born(0);
    for t in 1..100 {
        o.saw(t);
    }
    for _ in 1..p.prune_window {
        o.saw_through();
    }
    assert!(!p.contradicted(&o));
    o.saw_through();
    assert!(p.contradicted(&o));
}

/// Every segment `cast` sees through, by brute force over all segments.
fn brute_through(segs: &[Segment], origin: Vec2, end: Vec2, p: &ObserveParams) -> Vec<usize> {
    let length = (end - origin).length();
    let reach = length - p.through_margin_m;
    let dir = (end - origin) / length;
    let min_sin = p.min_crossing_deg.to_radians().sin();
    (0..segs.len())
        .filter(|&i| {
            let s = segs[i];
            let hit = s.ray_hit_m(origin, dir).is_some_and(|d| d <= reach);
            hit && reach > 0.0 && dir.perp_dot(s.vector()).abs() / s.length() >= min_sin
        })
        .collect()
}

proptest! {
    /// The grid's candidates miss no crossing: `cast` finds what testing every segment finds.
    #[test]
    fn cast_agrees_with_brute_force(
        raw in proptest::collection::vec((-8.0f64..8.0, -8.0f64..8.0, -8.0f64..8.0, -8.0f64..8.0), 1..25),
        ox in -6.0f64..6.0, oy in -6.0f64..6.0, ex in -9.0f64..9.0, ey in -9.0f64..9.0,
    ) {
        let segs: Vec<Segment> = raw
            .iter()
            .map(|&(a, b, c, d)| Segment::new(Vec2::new(a, b), Vec2::new(c, d)))
            .filter(|s| s.length() > 1e-3)
            .collect();
        let mut map = GlobalMap::default();
        let ids: Vec<SegmentId> = segs
            .iter()
            .map(|s| map.insert(MapSegment { segment: *s, born_scan: 0 }))
            .collect();
        let (origin, end) = (Vec2::new(ox, oy), Vec2::new(ex, ey));
        prop_assume!((end - origin).length() > 1e-3);
        let p = ObserveParams::default();
        let mut found = FxHashMap::default();
        cast(&map, origin, end, &p, &mut found);
        let mut crossed: Vec<usize> = found
            .iter()
            .filter(|(_, c)| c.t_hi >= c.t_lo)
            .filter_map(|(id, _)| ids.iter().position(|i| i == id))
            .collect();
        crossed.sort_unstable();
        prop_assert_eq!(crossed, brute_through(&segs, origin, end, &p));
    }
}

#[test]
fn a_doubled_room_is_seen_through_and_a_true_one_is_not() {
    // The room of a run whose poses were right, and the map of one where the second visit
    // was mapped 0.6 m off: the first visit's walls stand inside the second's room.
    let room = room();
    let shift = Pose2::new(0.6, -0.6, 0.0);
    let p = ObserveParams::default();
    let share = |doubled: bool| {
        let mut map = GlobalMap::default();
        for w in &room {
            map.insert(MapSegment {
                segment: *w,
                born_scan: 0,
            });
            if doubled {
                map.insert(MapSegment {
                    segment: Segment::new(
                        shift.transform_point(w.start),
                        shift.transform_point(w.end),
                    ),
                    born_scan: 0,
                });
            }
        }
        // The second visit: scans of the true room, placed 0.6 m off.
        for k in 0..8u32 {
            let true_pose = Pose2::new(2.0 + 0.8 * k as f64, 3.0, 0.3 * k as f64);
            let mapped_pose = match doubled {
                true => shift.compose(&true_pose),
                false => true_pose,
            };
            observe_scan(
                &mut map,
                &scan_of(&room, &true_pose),
                &mapped_pose,
                k + 1,
                true,
                &p,
            );
        }
        seen_through_share(&map).expect("walls seen")
    };
    let (right, doubled) = (share(false), share(true));
    assert_eq!(right, 0.0);
    assert!(doubled > 1.5 * p.warn_seen_through_above, "{doubled}");
    assert_eq!(seen_through_share(&GlobalMap::default()), None);
}
