use super::*;
use crate::map::MapSegment;

fn seg(x0: f64, y0: f64, x1: f64, y1: f64) -> Segment {
    Segment::new(Vec2::new(x0, y0), Vec2::new(x1, y1))
}

/// An office floor: a 20 × 12 m outline, a corridor along y = 5..7, rooms of different widths
/// on both sides with doorways, and a slanted cupboard: no symmetry.
fn office() -> Vec<Segment> {
    let mut s = vec![
        seg(0.0, 0.0, 20.0, 0.0),
        seg(20.0, 0.0, 20.0, 12.0),
        seg(20.0, 12.0, 0.0, 12.0),
        seg(0.0, 12.0, 0.0, 0.0),
    ];
    // Corridor walls with doorways (1 m gaps) into the rooms.
    for (y, doors) in [(5.0, [2.0, 7.5, 13.0, 17.0]), (7.0, [1.5, 9.0, 11.5, 18.0])] {
        let mut x = 0.0;
        for d in doors {
            s.push(seg(x, y, d, y));
            x = d + 1.0;
        }
        s.push(seg(x, y, 20.0, y));
    }
    // Room walls: 4 rooms below (widths 4, 5, 6, 5), 3 above (widths 7, 5, 8).
    for x in [4.0, 9.0, 15.0] {
        s.push(seg(x, 0.0, x, 5.0));
    }
    for x in [7.0, 12.0] {
        s.push(seg(x, 7.0, x, 12.0));
    }
    s.push(seg(16.0, 1.0, 17.5, 2.2)); // a slanted cupboard
    s.push(seg(2.5, 9.0, 4.0, 9.0)); // a desk
    s.push(seg(4.0, 9.0, 4.0, 10.5));
    s
}

fn map_of(segments: &[Segment]) -> GlobalMap {
    let mut map = GlobalMap::new(0.5, 1.0);
    for s in segments {
        map.insert(MapSegment {
            segment: *s,
            born_scan: 0,
        });
    }
    map
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
        &map_of(fixed),
        fixed_path,
        &side,
        &GlobalParams::default(),
        &AlignParams::default(),
    )
}

/// The robot's path along the office's corridor and into two rooms, office frame.
fn office_path() -> Vec<Vec2> {
    let mut path: Vec<Vec2> = (0..=38)
        .map(|i| Vec2::new(0.5 + 0.5 * i as f64, 6.0))
        .collect();
    path.extend((0..8).map(|i| Vec2::new(2.5, 5.5 - 0.5 * i as f64)));
    path.extend((0..8).map(|i| Vec2::new(9.5, 6.5 + 0.5 * i as f64)));
    path
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
        let b: Vec<Segment> = a.iter().map(|s| s.transformed(&truth.inverse())).collect();
        let m = run(&a, &b).expect("corners on both sides");
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
fn a_part_of_the_map_is_found_in_it() {
    let a = office();
    let truth = Pose2::new(-5.0, 4.0, 1.2);
    // The left half only (what a second run that saw half the floor would map), cut at x = 11.
    let half: Vec<Segment> = a
        .iter()
        .filter(|s| s.start.x.min(s.end.x) < 11.0)
        .map(|s| {
            let clip = |p: Vec2| Vec2::new(p.x.min(11.0), p.y);
            Segment::new(clip(s.start), clip(s.end))
        })
        .filter(|s| s.length() > 0.1)
        .collect();
    let b: Vec<Segment> = half
        .iter()
        .map(|s| s.transformed(&truth.inverse()))
        .collect();
    let m = run(&a, &b).expect("corners on both sides");
    let (dm, ddeg) = error(&truth, &m.fixed_from_moving);
    assert!(dm < 1e-3 && ddeg < 0.01, "{dm} m, {ddeg}°: {m:?}");
    assert_eq!(m.verdict(&GlobalParams::default()), MatchVerdict::Accepted);
}

#[test]
fn another_building_is_no_overlap() {
    let a = office();
    // A different floor: a long hall with a row of small square rooms.
    let mut b = vec![
        seg(0.0, 0.0, 40.0, 0.0),
        seg(40.0, 0.0, 40.0, 3.0),
        seg(40.0, 3.0, 0.0, 3.0),
        seg(0.0, 3.0, 0.0, 0.0),
    ];
    for i in 0..13 {
        let x = 3.0 * i as f64;
        b.push(seg(x, 3.0, x, 6.0));
        b.push(seg(x, 6.0, x + 3.0, 6.0));
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
    let to_b = truth.inverse();
    let b: Vec<Segment> = a.iter().map(|s| s.transformed(&to_b)).collect();
    let path_b: Vec<Vec2> = office_path()
        .iter()
        .map(|p| to_b.transform_point(*p))
        .collect();
    let m = run_with_paths(&a, &office_path(), &b, &path_b).expect("corners on both sides");
    let (dm, ddeg) = error(&truth, &m.fixed_from_moving);
    assert!(dm < 1e-4 && ddeg < 1e-3, "{m:?}");
    assert_eq!(m.best.conflicts, 0.0);
    assert_eq!(m.verdict(&GlobalParams::default()), MatchVerdict::Accepted);
    // A path a metre off, along the corridor's wall, conflicts.
    let map = map_of(&a);
    let path = office_path();
    let on_wall: Vec<Vec2> = path.iter().map(|p| *p + Vec2::new(0.0, 1.0)).collect();
    let share = path_conflicts(&on_wall, &map, &Pose2::IDENTITY, 0.2).unwrap();
    assert!(share > 0.5, "{share}");
    assert_eq!(
        path_conflicts(&path, &map, &Pose2::IDENTITY, 0.2),
        Some(0.0)
    );
    assert_eq!(path_conflicts(&[], &map, &truth, 0.2), None);
}

#[test]
fn a_match_with_conflicts_is_refused() {
    let mut m = run(&office(), &office()).expect("corners on both sides");
    assert_eq!(m.verdict(&GlobalParams::default()), MatchVerdict::Accepted);
    m.best.conflicts = 0.3;
    assert_eq!(
        m.verdict(&GlobalParams::default()),
        MatchVerdict::Conflicting
    );
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
