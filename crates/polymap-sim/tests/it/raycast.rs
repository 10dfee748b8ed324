//! Ray caster: exact hits on known geometry, and the grid against the brute-force oracle.

use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

use polymap::geometry::{Segment, Vec2};
use polymap_sim::raycast::{Obstacle, RayCaster, cast_ray_brute};
use polymap_sim::{Pillar, World};
use proptest::prelude::*;

fn world(walls: Vec<Segment>, pillars: Vec<Pillar>) -> World {
    World {
        moved: None,
        name: "test".into(),
        description: String::new(),
        walls,
        pillars,
        waypoints: vec![],
        laser: Default::default(),
    }
}

fn seg(x0: f64, y0: f64, x1: f64, y1: f64) -> Segment {
    Segment::new(Vec2::new(x0, y0), Vec2::new(x1, y1))
}

fn both(w: &World, origin: Vec2, bearing: f64, max_m: f64) -> Option<f64> {
    let fast = RayCaster::new(w)
        .cast(origin, bearing, max_m)
        .map(|h| h.range_m);
    let brute = cast_ray_brute(w, origin, bearing, max_m).map(|h| h.range_m);
    assert_eq!(fast, brute, "origin {origin} bearing {bearing}");
    fast
}

#[test]
fn wall_hit_distance_matches_geometry() {
    let w = world(vec![seg(4.0, -10.0, 4.0, 10.0)], vec![]);
    let r = both(&w, Vec2::new(1.0, 0.0), PI / 3.0, 30.0).unwrap_or(f64::NAN);
    // 3 m across at 60° from the wall's normal: 3 / cos 60° = 6 m.
    assert!((r - 6.0).abs() < 1e-12, "{r}");
    let diagonal = world(vec![seg(0.0, 2.0, 2.0, 0.0)], vec![]);
    let r = both(&diagonal, Vec2::ZERO, FRAC_PI_4, 30.0).unwrap_or(f64::NAN);
    assert!((r - 2f64.sqrt()).abs() < 1e-12, "{r}");
}

#[test]
fn nearest_of_several_walls_wins() {
    let w = world(
        vec![
            seg(5.0, -1.0, 5.0, 1.0),
            seg(3.0, -1.0, 3.0, 1.0),
            seg(7.0, -1.0, 7.0, 1.0),
        ],
        vec![],
    );
    let hit = RayCaster::new(&w).cast(Vec2::ZERO, 0.0, 30.0);
    assert_eq!(
        hit.map(|h| (h.range_m, h.obstacle)),
        Some((3.0, Obstacle::Wall(1)))
    );
}

#[test]
fn circle_hits_front_surface_and_exit_from_inside() {
    let p = Pillar {
        center: Vec2::new(10.0, 0.0),
        radius_m: 1.0,
    };
    let w = world(vec![], vec![p]);
    assert_eq!(both(&w, Vec2::ZERO, 0.0, 30.0), Some(9.0));
    // Half a radius off-centre: the hit is √(1 - 0.25) m short of the centre's abscissa.
    let r = both(&w, Vec2::new(0.0, 0.5), 0.0, 30.0).unwrap_or(f64::NAN);
    assert!((r - (10.0 - 0.75f64.sqrt())).abs() < 1e-12, "{r}");
    assert_eq!(both(&w, Vec2::new(10.0, 0.0), FRAC_PI_2, 30.0), Some(1.0));
    assert_eq!(both(&w, Vec2::ZERO, 0.2, 30.0), None);
}

#[test]
fn beyond_max_range_is_none() {
    let w = world(
        vec![seg(20.0, -5.0, 20.0, 5.0)],
        vec![Pillar {
            center: Vec2::new(0.0, 25.0),
            radius_m: 1.0,
        }],
    );
    assert_eq!(both(&w, Vec2::ZERO, 0.0, 19.999), None);
    assert_eq!(both(&w, Vec2::ZERO, 0.0, 20.0), None);
    assert_eq!(both(&w, Vec2::ZERO, 0.0, 20.001), Some(20.0));
    assert_eq!(both(&w, Vec2::ZERO, FRAC_PI_2, 23.5), None);
    assert_eq!(both(&w, Vec2::ZERO, PI, 1000.0), None);
}

#[test]
fn grazing_and_degenerate_inputs_do_not_hit_or_panic() {
    let w = world(
        vec![seg(1.0, 0.0, 5.0, 0.0), seg(f64::NAN, 0.0, 1.0, 1.0)],
        vec![Pillar {
            center: Vec2::new(3.0, 3.0),
            radius_m: -1.0,
        }],
    );
    assert_eq!(both(&w, Vec2::ZERO, 0.0, 30.0), None);
    assert_eq!(both(&w, Vec2::new(f64::NAN, 0.0), 0.0, 30.0), None);
    assert_eq!(both(&w, Vec2::ZERO, f64::INFINITY, 30.0), None);
    assert_eq!(
        RayCaster::new(&world(vec![], vec![])).cast(Vec2::ZERO, 0.0, 30.0),
        None
    );
}

#[test]
fn rays_from_outside_the_grid_enter_it() {
    let w = world(vec![seg(0.0, 0.0, 0.0, 2.0)], vec![]);
    assert_eq!(both(&w, Vec2::new(-50.0, 1.0), 0.0, 100.0), Some(50.0));
    assert_eq!(both(&w, Vec2::new(50.0, 1.0), PI, 100.0), Some(50.0));
    assert_eq!(both(&w, Vec2::new(-50.0, 1.0), PI, 100.0), None);
}

#[test]
fn grid_agrees_with_brute_force_in_every_world() {
    for w in World::catalogue() {
        let caster = RayCaster::new(&w);
        let (lo, hi) = w.bounds().unwrap_or_default();
        for k in 0..4000 {
            // A deterministic scatter of origins and bearings (golden-ratio sequences).
            let f = |m: f64| (k as f64 * m).fract();
            let origin = lo + (hi - lo + Vec2::splat(4.0)) * Vec2::new(f(0.618_034), f(0.754_878))
                - Vec2::splat(2.0);
            let bearing = f(0.569_840) * 2.0 * PI;
            let fast = caster.cast(origin, bearing, 30.0).map(|h| h.range_m);
            let brute = cast_ray_brute(&w, origin, bearing, 30.0).map(|h| h.range_m);
            assert_eq!(fast, brute, "{} origin {origin} bearing {bearing}", w.name);
        }
    }
}

fn arb_wall() -> impl Strategy<Value = Segment> {
    (-20.0..20.0f64, -20.0..20.0f64, -8.0..8.0f64, -8.0..8.0f64)
        .prop_map(|(x, y, dx, dy)| seg(x, y, x + dx, y + dy))
}

fn arb_pillar() -> impl Strategy<Value = Pillar> {
    (-20.0..20.0f64, -20.0..20.0f64, 0.05..2.0f64).prop_map(|(x, y, r)| Pillar {
        center: Vec2::new(x, y),
        radius_m: r,
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]
    #[test]
    fn grid_caster_agrees_with_brute_force(
        walls in prop::collection::vec(arb_wall(), 0..60),
        pillars in prop::collection::vec(arb_pillar(), 0..10),
        rays in prop::collection::vec((-30.0..30.0f64, -30.0..30.0f64, -4.0..4.0f64, 0.5..60.0f64), 1..40),
    ) {
        let w = world(walls, pillars);
        let caster = RayCaster::new(&w);
        for (x, y, bearing, max_m) in rays {
            let origin = Vec2::new(x, y);
            let fast = caster.cast(origin, bearing, max_m);
            let brute = cast_ray_brute(&w, origin, bearing, max_m);
            prop_assert_eq!(fast.map(|h| h.range_m), brute.map(|h| h.range_m));
            if let Some(h) = fast {
                prop_assert!((h.point - origin).length() - h.range_m < 1e-9);
            }
        }
    }
}
