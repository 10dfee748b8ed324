use std::f64::consts::FRAC_PI_2;

use polymap::geometry::{Pose2, Segment, Vec2};
use polymap::scan::{RangeScan, Stamp};

use super::*;

fn scan(ranges_m: Vec<f64>, angle_min_rad: f64, angle_increment_rad: f64) -> RangeScan {
    RangeScan {
        stamp: Stamp::from_seconds(0.0),
        ranges_m,
        angle_min_rad,
        angle_increment_rad,
        max_range_m: 50.0,
        robot_from_laser: Pose2::IDENTITY,
        odom_from_robot: None,
    }
}

fn seg(x0: f64, y0: f64, x1: f64, y1: f64) -> Segment {
    Segment::new(Vec2::new(x0, y0), Vec2::new(x1, y1))
}

#[test]
fn points_on_near_and_far_from_the_map() {
    // The robot at (2, 0) faces +y; its beams at −90°, 0°, +90° point to +x, +y, −x of the map.
    // Map wall y = 3 from x = 0 to 4: the forward beam (3 m) ends exactly on it.
    // Wall x = 3.07: the right beam (1 m) ends 7 cm short. The left beam hits nothing near.
    let map = [seg(0.0, 3.0, 4.0, 3.0), seg(3.07, -1.0, 3.07, 1.0)];
    let s = scan(vec![1.0, 3.0, 10.0, 60.0], -FRAC_PI_2, FRAC_PI_2);
    let pose = Pose2::new(2.0, 0.0, FRAC_PI_2);
    let fit = map_fit_to_points(&map, &[s], &[pose], &PointFitParams::default());
    assert_eq!(fit.points, 3, "the 60 m reading is a no-return");
    assert!((fit.share_within_tight - 1.0 / 3.0).abs() < 1e-12);
    assert!((fit.share_within_loose - 2.0 / 3.0).abs() < 1e-12);
    // Left point at (−8, 0): nearest map point (0, 3), distance √73.
    let rms = ((0.07f64.powi(2) + 73.0) / 3.0).sqrt();
    assert!((fit.rms_m.unwrap() - rms).abs() < 1e-9);
    assert_eq!(fit.points_within_cutoff, 2);
    assert!((fit.rms_within_cutoff_m.unwrap() - (0.07f64.powi(2) / 2.0).sqrt()).abs() < 1e-9);
}

#[test]
fn stride_and_bad_poses_skip_scans() {
    let map = [seg(-5.0, 1.0, 5.0, 1.0)];
    let scans = vec![scan(vec![1.0], FRAC_PI_2, 0.1); 5];
    let mut poses = vec![Pose2::IDENTITY; 5];
    poses[2] = Pose2 {
        x_m: f64::NAN,
        y_m: 0.0,
        theta_rad: 0.0,
    };
    let params = PointFitParams {
        scan_stride: 2,
        ..PointFitParams::default()
    };
    let fit = map_fit_to_points(&map, &scans, &poses, &params);
    assert_eq!(
        (fit.scans_used, fit.points),
        (2, 2),
        "scans 0, 2 (bad pose), 4"
    );
    assert_eq!(fit.share_within_tight, 1.0);
    let zero_stride = PointFitParams {
        scan_stride: 0,
        ..PointFitParams::default()
    };
    assert_eq!(
        map_fit_to_points(&map, &scans, &poses[..3], &zero_stride).scans_used,
        2
    );
}

#[test]
fn empty_map_or_no_points() {
    let s = scan(vec![1.0, 2.0], 0.0, 0.1);
    let fit = map_fit_to_points(
        &[],
        std::slice::from_ref(&s),
        &[Pose2::IDENTITY],
        &PointFitParams::default(),
    );
    assert_eq!(fit.points, 2);
    assert_eq!(
        (fit.share_within_loose, fit.rms_m, fit.rms_within_cutoff_m),
        (0.0, None, None)
    );
    let none = map_fit_to_points(
        &[seg(0.0, 0.0, 1.0, 0.0)],
        &[s],
        &[],
        &PointFitParams::default(),
    );
    assert_eq!(
        (none.points, none.share_within_tight, none.rms_m),
        (0, 0.0, None)
    );
}

#[test]
fn perfect_map_has_full_precision_and_recall() {
    let walls: Vec<TrueWall> = [seg(0.0, 0.0, 5.0, 0.0), seg(5.0, 0.0, 5.0, 3.0)]
        .map(TrueWall::from)
        .to_vec();
    // The map is in a frame rotated by 90° and shifted against the world.
    let world_from_map = Pose2::new(1.0, 2.0, FRAC_PI_2);
    let map_from_world = world_from_map.inverse();
    let map: Vec<Segment> = walls
        .iter()
        .map(|w| w.segment.transformed(&map_from_world))
        .collect();
    let s = map_vs_walls(&map, &walls, &world_from_map, &WallParams::default());
    assert!((s.precision.unwrap() - 1.0).abs() < 1e-12 && (s.recall.unwrap() - 1.0).abs() < 1e-12);
    assert!((s.map_length_m - 8.0).abs() < 1e-12 && (s.wall_length_m - 8.0).abs() < 1e-12);
    let unaligned = map_vs_walls(&map, &walls, &Pose2::IDENTITY, &WallParams::default());
    assert!(unaligned.precision.unwrap() < 0.5);
}

#[test]
fn offset_map_and_unseen_walls() {
    // Map: the 2 m wall shifted 4 cm (within 5 cm) and a second piece shifted 8 cm (outside).
    let walls = [
        TrueWall::from(seg(0.0, 0.0, 2.0, 0.0)),
        TrueWall {
            segment: seg(0.0, 5.0, 3.0, 5.0),
            seen: false,
        },
        TrueWall::from(seg(10.0, 0.0, 10.0, 1.0)),
    ];
    let map = [seg(0.0, 0.04, 2.0, 0.04), seg(10.08, 0.0, 10.08, 1.0)];
    let s = map_vs_walls(&map, &walls, &Pose2::IDENTITY, &WallParams::default());
    assert!((s.precision.unwrap() - 2.0 / 3.0).abs() < 1e-9);
    assert!(
        (s.wall_length_m - 3.0).abs() < 1e-12,
        "the unseen wall is left out"
    );
    assert!((s.recall.unwrap() - 2.0 / 3.0).abs() < 1e-9);
    let all = WallParams {
        recall_only_seen: false,
        ..WallParams::default()
    };
    let s_all = map_vs_walls(&map, &walls, &Pose2::IDENTITY, &all);
    assert!((s_all.recall.unwrap() - 2.0 / 6.0).abs() < 1e-9);
    let loose = WallParams {
        tolerance_m: 0.1,
        ..WallParams::default()
    };
    assert!(
        (map_vs_walls(&map, &walls, &Pose2::IDENTITY, &loose)
            .precision
            .unwrap()
            - 1.0)
            .abs()
            < 1e-9
    );
}

#[test]
fn degenerate_wall_inputs() {
    let s = map_vs_walls(&[], &[], &Pose2::IDENTITY, &WallParams::default());
    assert_eq!((s.precision, s.recall), (None, None));
    let bad_step = WallParams {
        sample_step_m: 0.0,
        ..WallParams::default()
    };
    let nan = seg(f64::NAN, 0.0, 1.0, 0.0);
    let s = map_vs_walls(
        &[nan, seg(0.0, 0.0, 1.0, 0.0)],
        &[TrueWall::from(nan)],
        &Pose2::IDENTITY,
        &bad_step,
    );
    assert_eq!(s.precision, Some(0.0));
    assert_eq!(s.recall, None);
}

#[test]
fn a_wall_drawn_twice_side_by_side_is_doubled_and_one_continuing_or_crossing_it_is_not() {
    let d = |map: &[Segment]| doubled_walls(map, &DoubledParams::default());
    // Two copies 10 cm apart: every sample of both lies beside the other.
    let twice = d(&[seg(0.0, 0.0, 3.0, 0.0), seg(0.0, 0.1, 3.0, 0.1)]);
    assert!((twice.share.unwrap() - 1.0).abs() < 1e-9, "{twice:?}");
    // 20 cm apart (two faces of a thick wall, a corridor): not doubled.
    assert_eq!(
        d(&[seg(0.0, 0.0, 3.0, 0.0), seg(0.0, 0.2, 3.0, 0.2)]).doubled_length_m,
        0.0
    );
    // End to end on one line, or crossing at a right angle, or 15° apart: not doubled.
    assert_eq!(
        d(&[seg(0.0, 0.0, 3.0, 0.0), seg(3.0, 0.0, 6.0, 0.0)]).doubled_length_m,
        0.0
    );
    assert_eq!(
        d(&[seg(0.0, 0.0, 3.0, 0.0), seg(1.5, -1.0, 1.5, 1.0)]).doubled_length_m,
        0.0
    );
    let turned = 15f64.to_radians();
    let (c, s) = (turned.cos(), turned.sin());
    assert_eq!(
        d(&[seg(0.0, 0.0, 3.0, 0.0), seg(0.0, 0.0, 3.0 * c, 3.0 * s)]).doubled_length_m,
        0.0
    );
    // Nothing to measure.
    assert_eq!(d(&[]).share, None);
}
