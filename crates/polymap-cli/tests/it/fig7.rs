//! Fig. 7 of the paper: a robot approaches a 45° corner while the main directions are 0° and
//! 90°; once enough 45° wall has been seen a new main direction appears, and the 45° segments
//! merge afterwards.
//!
//! The built-in `hallway45` world shows its diagonal from the first scan, so this test builds the
//! paper's situation: a corridor along x, a left turn, then a 45° bend hidden behind the corner.

use polymap::config::Config;
use polymap::geometry::{Vec2, angle_between_directions_rad};
use polymap::mapper::Update;
use polymap_sim::{SimParams, World, simulate};

use crate::support::map_run;

/// Corridor walls at `half_width_m` either side of a centre line, with mitred corners and
/// closed ends.
fn corridor(centre: &[Vec2], half_width_m: f64) -> Vec<polymap::geometry::Segment> {
    let n = centre.len();
    let normal = |i: usize| (centre[i + 1] - centre[i]).normalize().perp();
    let offset = |i: usize, side: f64| {
        let m = match i {
            0 => normal(0),
            i if i == n - 1 => normal(n - 2),
            i => {
                let (a, b) = (normal(i - 1), normal(i));
                (a + b) / (1.0 + a.dot(b))
            }
        };
        centre[i] + m * (side * half_width_m)
    };
    let mut walls = Vec::new();
    for side in [1.0, -1.0] {
        for i in 0..n - 1 {
            walls.push(polymap::geometry::Segment::new(
                offset(i, side),
                offset(i + 1, side),
            ));
        }
    }
    walls.push(polymap::geometry::Segment::new(
        offset(0, 1.0),
        offset(0, -1.0),
    ));
    walls.push(polymap::geometry::Segment::new(
        offset(n - 1, 1.0),
        offset(n - 1, -1.0),
    ));
    walls
}

fn bremen_like() -> World {
    let centre = [
        Vec2::new(0.0, 0.0),
        Vec2::new(16.0, 0.0),
        Vec2::new(16.0, 10.0),
        Vec2::new(24.0, 18.0),
        Vec2::new(30.0, 24.0),
    ];
    World {
        moved: None,
        name: "fig7".into(),
        description: "corridor, left turn, then a 45° bend hidden behind the corner".into(),
        walls: corridor(&centre, 1.0),
        pillars: Vec::new(),
        waypoints: vec![
            Vec2::new(1.0, 0.0),
            centre[1],
            centre[2],
            centre[3],
            Vec2::new(29.0, 23.0),
        ],
        laser: Default::default(),
    }
}

#[test]
fn fig7_a_new_main_direction_opens_for_the_45_degree_wall_and_its_segments_merge() {
    let world = bremen_like();
    let run = simulate(&world, &SimParams::default(), 1);
    // The map frame is the first robot pose; the diagonal runs at 45° in the world.
    let diagonal =
        (45f64.to_radians() - run.true_poses[0].theta_rad).rem_euclid(std::f64::consts::PI);
    let (mapper, updates) = map_run(&run, Config::default());
    let has_diagonal = |u: &Update| {
        u.diagnostics
            .main_directions_deg
            .iter()
            .any(|d| angle_between_directions_rad(d.to_radians(), diagonal).to_degrees() < 3.0)
    };
    let first = updates
        .iter()
        .position(has_diagonal)
        .expect("a 45° main direction appears");
    let at = run.true_poses[first].translation();
    assert!(
        at.x > 14.0,
        "it opens only at the turn, once the bend is in view (at {at:?}, scan {first})"
    );
    assert!(updates[..first].iter().all(|u| !has_diagonal(u)));
    let diagonal_segments: Vec<_> = mapper
        .segments()
        .into_iter()
        .filter(|s| {
            s.segment.length() > 0.3
                && angle_between_directions_rad(s.segment.direction_rad(), diagonal).to_degrees()
                    < 3.0
        })
        .collect();
    // Two 45° walls (8.5 m each, plus the end stretch): a handful of merged segments, not one
    // per scan for the ~300 scans that saw them.
    assert!(
        !diagonal_segments.is_empty() && diagonal_segments.len() <= 6,
        "{} diagonal segments",
        diagonal_segments.len()
    );
    let longest = diagonal_segments
        .iter()
        .map(|s| s.segment.length())
        .fold(0.0, f64::max);
    assert!(
        longest > 5.0,
        "merged along the new direction: longest diagonal segment {longest} m"
    );
}
