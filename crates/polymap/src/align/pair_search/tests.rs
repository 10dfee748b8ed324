use super::*;
use crate::testutil::map_of;

fn seg(x0: f64, y0: f64, x1: f64, y1: f64) -> Segment {
    Segment::new(Vec2::new(x0, y0), Vec2::new(x1, y1))
}

/// An office floor: an L-shaped 20 × 12 m outline, a corridor along y = 4..6 (off the middle), rooms of different widths
/// on both sides with doorways, and a slanted cupboard: no symmetry.
fn office() -> Vec<Segment> {
    let mut s = vec![
        seg(0.0, 0.0, 20.0, 0.0),
        seg(20.0, 0.0, 20.0, 9.0),
        seg(20.0, 9.0, 15.0, 9.0), // the outline's notch: an L, not a rectangle
        seg(15.0, 9.0, 15.0, 12.0),
        seg(15.0, 12.0, 0.0, 12.0),
        seg(0.0, 12.0, 0.0, 0.0),
    ];
    // Corridor walls with doorways (1 m gaps) into the rooms.
    for (y, doors) in [(4.0, [2.0, 7.5, 13.0, 17.0]), (6.0, [1.5, 9.0, 11.5, 18.0])] {
        let mut x = 0.0;
        for d in doors {
            s.push(seg(x, y, d, y));
            x = d + 1.0;
        }
        s.push(seg(x, y, 20.0, y));
    }
    // Room walls: 4 rooms below (widths 4, 5, 6, 5), 3 above (widths 7, 5, 8).
    for x in [4.0, 9.0, 15.0] {
        s.push(seg(x, 0.0, x, 4.0));
    }
    for x in [7.0, 12.0] {
        s.push(seg(x, 6.0, x, 12.0));
    }
    s.push(seg(16.0, 1.0, 17.5, 2.2)); // a slanted cupboard
    s.push(seg(2.5, 9.0, 4.0, 9.0)); // a desk
    s.push(seg(4.0, 9.0, 4.0, 10.5));
    s
}

fn run(fixed: &[Segment], moving: &[Segment]) -> Option<GlobalMatch> {
    run_with_paths(fixed, &[], moving, &[])
}

fn run_with_paths(
    fixed: &[Segment],
    fixed_path: &[Vec2],
    moving: &[Segment],
    moving_path: &[Vec2],
) -> Option<GlobalMatch> {
    let points = points_along(moving, 0.05);
    let side = MovingSide {
        segments: moving,
        points: &points,
        path: moving_path,
    };
    global_match(
        &map_of(fixed, 0.5),
        fixed_path,
        &side,
        &GlobalParams::default(),
        &AlignParams::default(),
    )
}

/// The robot's path along the office's corridor and into two rooms, office frame.
fn office_path() -> Vec<Vec2> {
    let mut path: Vec<Vec2> = (0..=38)
        .map(|i| Vec2::new(0.5 + 0.5 * i as f64, 5.0))
        .collect();
    path.extend((0..7).map(|i| Vec2::new(2.5, 4.5 - 0.5 * i as f64)));
    path.extend((0..10).map(|i| Vec2::new(9.5, 5.5 + 0.5 * i as f64)));
    path
}

/// Segments and path of the fixed frame seen from `fixed_from_moving` (in the moving frame).
fn moved(
    segments: &[Segment],
    path: &[Vec2],
    fixed_from_moving: &Pose2,
) -> (Vec<Segment>, Vec<Vec2>) {
    let to_moving = fixed_from_moving.inverse();
    (
        segments.iter().map(|s| s.transformed(&to_moving)).collect(),
        path.iter().map(|p| to_moving.transform_point(*p)).collect(),
    )
}

fn error(truth: &Pose2, found: &Pose2) -> (f64, f64) {
    let d = truth.between(found);
    (d.translation().length(), d.theta_rad.abs().to_degrees())
}

#[test]
fn a_turned_and_shifted_copy_is_found_exactly() {
    let a = office();
    for truth in [
        Pose2::new(3.0, -2.0, 0.7),
        Pose2::new(-12.0, 30.0, -2.9),
        Pose2::new(0.0, 0.0, std::f64::consts::FRAC_PI_2),
    ] {
        let (b, path_b) = moved(&a, &office_path(), &truth);
        let m = run_with_paths(&a, &office_path(), &b, &path_b).expect("corners on both sides");
        let (dm, ddeg) = error(&truth, &m.fixed_from_moving);
        assert!(
            dm < 1e-4 && ddeg < 1e-3,
            "{truth:?}: {dm} m, {ddeg}°: {m:?}"
        );
        assert_eq!(m.verdict(&GlobalParams::default()), MatchVerdict::Accepted);
        assert!(m.overlap > 0.99 && m.best.score > 0.9, "{m:?}");
    }
}

#[test]
fn a_part_of_the_map_is_found_in_it_and_a_corridor_shift_passes_too() {
    let a = office();
    let truth = Pose2::new(-5.0, 4.0, 1.2);
    // The right part only (what a second run that saw part of the floor would map), cut at
    // x = 12, with the robot's path there.
    let part: Vec<Segment> = a
        .iter()
        .filter(|s| s.start.x.max(s.end.x) > 12.0)
        .map(|s| {
            let clip = |p: Vec2| Vec2::new(p.x.max(12.0), p.y);
            Segment::new(clip(s.start), clip(s.end))
        })
        .filter(|s| s.length() > 0.1)
        .collect();
    let path: Vec<Vec2> = office_path().into_iter().filter(|p| p.x > 12.0).collect();
    let (b, path_b) = moved(&part, &path, &truth);
    let m = run_with_paths(&a, &office_path(), &b, &path_b).expect("corners on both sides");
    let (dm, ddeg) = error(&truth, &m.fixed_from_moving);
    assert!(dm < 1e-3 && ddeg < 0.01, "{dm} m, {ddeg}°: {m:?}");
    assert!(m.overlap > 0.99 && m.best.conflicts == 0.0, "{m:?}");
    // Shifted 11 m along the corridor the part explains 69 % of its walls, and its path, all
    // in the corridor, contradicts nothing: a pose that would pass on its own, so the match is
    // refused as ambiguous (the safe side; `polymap merge` then says so).
    let params = GlobalParams::default();
    let rival = m.passing_rival(&params).expect("a shifted part passes");
    let (shift_m, turn_deg) = error(&truth, &rival.fixed_from_moving);
    assert!(
        (shift_m - 11.0).abs() < 0.01 && turn_deg < 0.01,
        "{rival:?}"
    );
    assert_eq!(m.verdict(&params), MatchVerdict::Ambiguous);
}

#[test]
fn another_building_is_no_overlap() {
    let a = office();
    // A different floor: a 30 m square hall of 1.6 m cubicles open to the south.
    let mut b = vec![
        seg(0.0, 0.0, 30.0, 0.0),
        seg(30.0, 0.0, 30.0, 30.0),
        seg(30.0, 30.0, 0.0, 30.0),
        seg(0.0, 30.0, 0.0, 0.0),
    ];
    for i in 0..5 {
        for j in 0..5 {
            let (x, y) = (3.0 + 5.0 * i as f64, 3.0 + 5.0 * j as f64);
            b.push(seg(x, y, x, y + 1.6));
            b.push(seg(x, y + 1.6, x + 1.6, y + 1.6));
            b.push(seg(x + 1.6, y + 1.6, x + 1.6, y));
        }
    }
    let m = run(&a, &b).expect("corners on both sides");
    assert_eq!(
        m.verdict(&GlobalParams::default()),
        MatchVerdict::NoOverlap,
        "{m:?}"
    );
}

#[test]
fn no_corner_no_match() {
    let a = office();
    let corridor = [seg(0.0, 0.0, 10.0, 0.0), seg(0.0, 2.0, 10.0, 2.0)];
    assert!(run(&a, &corridor).is_none());
    assert!(run(&[], &a).is_none());
}

#[test]
fn a_symmetric_room_is_ambiguous() {
    // A bare rectangle looks the same turned by half a turn.
    let room = [
        seg(0.0, 0.0, 8.0, 0.0),
        seg(8.0, 0.0, 8.0, 5.0),
        seg(8.0, 5.0, 0.0, 5.0),
        seg(0.0, 5.0, 0.0, 0.0),
    ];
    let truth = Pose2::new(1.0, 2.0, 0.3);
    let b: Vec<Segment> = room
        .iter()
        .map(|s| s.transformed(&truth.inverse()))
        .collect();
    let m = run(&room, &b).expect("corners on both sides");
    assert!(m.rival_ratio() > 0.95, "{m:?}");
    assert_eq!(m.verdict(&GlobalParams::default()), MatchVerdict::Ambiguous);
}

#[test]
fn paths_agree_at_the_true_pose_and_conflict_elsewhere() {
    let a = office();
    let truth = Pose2::new(4.0, 1.0, -0.4);
    let (b, path_b) = moved(&a, &office_path(), &truth);
    let m = run_with_paths(&a, &office_path(), &b, &path_b).expect("corners on both sides");
    let (dm, ddeg) = error(&truth, &m.fixed_from_moving);
    assert!(dm < 1e-4 && ddeg < 1e-3, "{m:?}");
    assert_eq!(m.best.conflicts, 0.0);
    assert_eq!(m.verdict(&GlobalParams::default()), MatchVerdict::Accepted);
    // A path a metre off, along the corridor's wall, conflicts; so does one through a wall.
    let (map, params) = (map_of(&a, 0.5), GlobalParams::default());
    let path = office_path();
    let on_wall: Vec<Vec2> = path.iter().map(|p| *p + Vec2::new(0.0, 1.0)).collect();
    let share = path_conflicts(&on_wall, &map, &Pose2::IDENTITY, &params).unwrap();
    assert!(share > 0.5, "{share}");
    assert_eq!(
        path_conflicts(&path, &map, &Pose2::IDENTITY, &params),
        Some(0.0)
    );
    assert_eq!(path_conflicts(&[], &map, &truth, &params), None);
}

#[test]
fn a_path_through_a_wall_conflicts_where_it_crosses() {
    let map = map_of(&[seg(0.0, -2.0, 0.0, 2.0)], 0.5);
    let params = GlobalParams::default();
    let path: Vec<Vec2> = (0..8)
        .map(|i| Vec2::new(-1.75 + 0.5 * i as f64, 0.0))
        .collect();
    // Positions at x = -0.25 and 0.25 are 0.25 m from the wall: only the step between them,
    // through it, conflicts.
    assert_eq!(
        path_conflicts(&path, &map, &Pose2::IDENTITY, &params),
        Some(1.0 / 8.0)
    );
}

#[test]
fn without_paths_a_corridor_floor_is_ambiguous() {
    // Shifted along its corridor, the office explains 70 % of its own walls (the corridor's
    // and the outline's) with no robot path to contradict it: a pose that would pass on its
    // own. With the paths, the same pair is accepted (`a_turned_and_shifted_copy…`).
    let a = office();
    let m = run(&a, &a).expect("corners on both sides");
    let (dm, ddeg) = error(&Pose2::IDENTITY, &m.fixed_from_moving);
    assert!(dm < 1e-4 && ddeg < 1e-3, "{m:?}");
    let params = GlobalParams::default();
    let rival = m.passing_rival(&params).expect("a shifted copy passes");
    assert!(
        rival.raster_score > 0.5 && rival.conflicts == 0.0,
        "{rival:?}"
    );
    assert_eq!(m.verdict(&params), MatchVerdict::Ambiguous);
}

#[test]
fn a_match_with_conflicts_is_refused() {
    let path = office_path();
    let mut m = run_with_paths(&office(), &path, &office(), &path).expect("corners on both sides");
    assert_eq!(m.verdict(&GlobalParams::default()), MatchVerdict::Accepted);
    m.best.conflicts = 0.3;
    assert_eq!(
        m.verdict(&GlobalParams::default()),
        MatchVerdict::Conflicting
    );
}

#[test]
fn a_scan_is_placed_in_the_map_without_a_guess() {
    // What a robot in the lower-left room sees: the walls within 4.5 m, in its own frame
    // (as a scan's segments are), with the robot's own position as the free space.
    let a = office();
    let map_from_robot = Pose2::new(2.0, 2.0, 2.0);
    let robot_from_map = map_from_robot.inverse();
    let seen: Vec<Segment> = a
        .iter()
        .filter(|s| s.distance_to_point(map_from_robot.translation()) < 4.5)
        .map(|s| s.transformed(&robot_from_map))
        .collect();
    let points = points_along(&seen, 0.05);
    let side = MovingSide {
        segments: &seen,
        points: &points,
        path: &[Vec2::ZERO],
    };
    let params = GlobalParams::default();
    let m = global_match(
        &map_of(&a, 0.5),
        &[],
        &side,
        &params,
        &AlignParams::default(),
    )
    .expect("corners in the room");
    let (dm, ddeg) = error(&map_from_robot, &m.fixed_from_moving);
    assert!(dm < 1e-3 && ddeg < 0.01, "{dm} m, {ddeg}°: {m:?}");
    assert_eq!(m.best.conflicts, 0.0);
}

#[test]
fn default_params_are_valid() {
    GlobalParams::default().validate().unwrap();
    let bad = GlobalParams {
        min_overlap: 1.5,
        ..GlobalParams::default()
    };
    assert!(bad.validate().is_err());
}
