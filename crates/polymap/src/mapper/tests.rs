use super::*;
use crate::testutil::scan_from;
use crate::tracking::MotionPrior;

fn seg(ax: f64, ay: f64, bx: f64, by: f64) -> Segment {
    Segment::new(Vec2::new(ax, ay), Vec2::new(bx, by))
}

/// A 12 × 5 m room with a pillar box and a notch: enough structure in every direction.
fn room() -> Vec<Segment> {
    vec![
        seg(-2.0, -2.5, 10.0, -2.5),
        seg(10.0, -2.5, 10.0, 2.5),
        seg(10.0, 2.5, 4.0, 2.5),
        seg(4.0, 2.5, 4.0, 1.8),
        seg(4.0, 1.8, 3.0, 1.8),
        seg(3.0, 1.8, 3.0, 2.5),
        seg(3.0, 2.5, -2.0, 2.5),
        seg(-2.0, 2.5, -2.0, -2.5),
        seg(6.0, -1.0, 6.6, -1.0),
        seg(6.6, -1.0, 6.6, -0.4),
        seg(6.6, -0.4, 6.0, -0.4),
        seg(6.0, -0.4, 6.0, -1.0),
    ]
}

fn drive(config: Config) -> (Mapper, Vec<(Pose2, Pose2)>) {
    let walls = room();
    let mut mapper = Mapper::new(config);
    let mut pairs = Vec::new();
    for i in 0..60 {
        // 5 cm and 0.5° per scan: forward along x with a gentle turn.
        let truth = Pose2::new(
            0.05 * i as f64,
            0.3 * (i as f64 / 20.0).sin(),
            (0.5 * i as f64).to_radians() * 0.3,
        );
        let u = mapper.push(&scan_from(&walls, &truth, i as f64 * 0.1));
        pairs.push((truth, u.map_from_robot));
    }
    (mapper, pairs)
}

fn max_error(pairs: &[(Pose2, Pose2)]) -> (f64, f64) {
    // The map frame is the first scan's pose: compare motions from the first pose.
    let (t0, e0) = pairs[0];
    pairs.iter().fold((0.0f64, 0.0f64), |(dt, dr), (t, e)| {
        let d = t0.between(t).between(&e0.between(e));
        (
            dt.max(d.translation().length()),
            dr.max(d.theta_rad.abs().to_degrees()),
        )
    })
}

#[test]
fn first_map_is_the_first_scan() {
    let mut mapper = Mapper::new(Config::default());
    let u = mapper.push(&scan_from(&room(), &Pose2::IDENTITY, 0.0));
    assert_eq!(u.map_from_robot, Pose2::IDENTITY);
    assert!(u.diagnostics.align.is_none());
    assert_eq!(mapper.map().len(), u.diagnostics.scan_segments);
    assert!(u.diagnostics.scan_segments >= 5);
}

#[test]
fn default_config_tracks_and_keeps_the_map_small() {
    let (mapper, pairs) = drive(Config::default());
    let (dt, dr) = max_error(&pairs);
    assert!(dt < 0.03 && dr < 0.3, "trajectory error {dt} m, {dr}°");
    // 12 walls in the room, about 10 visible from the path: at most about twice that.
    assert!(mapper.map().len() <= 24, "{} segments", mapper.map().len());
}

/// The paper's endpoint ICP is coarser than point-to-segment: segment endpoints sit at occlusion
/// boundaries and move with the view (measured 5.1 cm worst case on this path).
#[test]
fn paper_config_tracks_and_keeps_the_map_small() {
    let (mapper, pairs) = drive(Config::paper());
    let (dt, dr) = max_error(&pairs);
    assert!(dt < 0.08 && dr < 0.5, "trajectory error {dt} m, {dr}°");
    assert!(mapper.map().len() <= 24, "{} segments", mapper.map().len());
}

/// Every ICP run tracking makes for a scan is in its diagnostics (`tries`) where asked for, the
/// pose taken among them: a scan after a jump the prediction does not foresee is searched, and
/// the starts it passed over are there beside the pose taken.
#[test]
fn a_scans_diagnostics_hold_every_pose_tracking_tried_the_one_taken_among_them() {
    let walls = room();
    let mut quiet = Mapper::new(Config::default());
    quiet.push(&scan_from(&walls, &Pose2::IDENTITY, 0.0));
    let u = quiet.push(&scan_from(&walls, &Pose2::new(0.05, 0.0, 0.0), 0.1));
    assert!(u.diagnostics.align.is_some() && u.diagnostics.tries.is_empty());
    let mut mapper = Mapper::new(Config::default());
    mapper.record_tries(true);
    let first = mapper.push(&scan_from(&walls, &Pose2::IDENTITY, 0.0));
    assert!(
        first.diagnostics.tries.is_empty(),
        "nothing to align the first scan to"
    );
    let mut most = 0;
    for i in 1..30 {
        // 5 cm a scan, then 1.2 m sideways and 40° in one step.
        let jump = if i >= 20 {
            Pose2::new(0.0, 1.2, 0.7)
        } else {
            Pose2::IDENTITY
        };
        let truth = jump.compose(&Pose2::new(0.05 * i as f64, 0.0, 0.0));
        let u = mapper.push(&scan_from(&walls, &truth, i as f64 * 0.1));
        let taken = u
            .diagnostics
            .align
            .expect("a map to align to")
            .map_from_robot;
        let tries = &u.diagnostics.tries;
        assert!(
            tries.iter().any(|t| t.map_from_robot == taken),
            "scan {i}: the pose taken {taken:?} is not among {tries:?}"
        );
        assert!(tries.iter().all(|t| t.inliers <= t.correspondences));
        most = most.max(tries.len());
    }
    assert!(most >= 2, "no scan tried more than one pose");
}

#[test]
fn odometry_prior_starts_in_the_odometry_frame() {
    let mut config = Config::default();
    config.mapper.motion_prior = MotionPrior::Odometry;
    let mut mapper = Mapper::new(config);
    let mut scan = scan_from(&room(), &Pose2::IDENTITY, 0.0);
    scan.odom_from_robot = Some(Pose2::new(5.0, 1.0, 0.2));
    assert_eq!(mapper.push(&scan).map_from_robot, Pose2::new(5.0, 1.0, 0.2));
}

#[test]
fn empty_scans_do_not_break_the_loop() {
    let mut mapper = Mapper::new(Config::default());
    let mut empty = scan_from(&room(), &Pose2::IDENTITY, 0.0);
    empty.ranges_m.iter_mut().for_each(|r| *r = f64::NAN);
    let u = mapper.push(&empty);
    assert_eq!(u.diagnostics.points, 0);
    assert!(mapper.map().is_empty());
    let u = mapper.push(&scan_from(&room(), &Pose2::IDENTITY, 0.1));
    assert!(u.diagnostics.scan_segments > 0 && !mapper.map().is_empty());
}

/// A scan without a valid point stays where the last scan was: kept at the constant-velocity
/// guess, the robot would drive on through every blind scan.
#[test]
fn blind_scans_after_the_first_stay_put() {
    let walls = room();
    let mut mapper = Mapper::new(Config::default());
    for i in 0..5 {
        mapper.push(&scan_from(
            &walls,
            &Pose2::new(0.1 * i as f64, 0.0, 0.0),
            i as f64 * 0.1,
        ));
    }
    let before = mapper
        .push(&scan_from(&walls, &Pose2::new(0.4, 0.0, 0.0), 0.5))
        .map_from_robot;
    let mut blind = scan_from(&walls, &Pose2::new(0.4, 0.0, 0.0), 0.6);
    blind.ranges_m.iter_mut().for_each(|r| *r = f64::NAN);
    for k in 0..3 {
        let u = mapper.push(&blind);
        assert!(
            (u.map_from_robot.translation() - before.translation()).length() < 1e-9,
            "blind scan {k}: {:?}",
            u.map_from_robot
        );
    }
}

/// After a gap in the log the robot has turned 70° in place, far beyond the rotation search:
/// the scan fits nowhere near the guess, and the tracker puts it back. The corner hypotheses,
/// the search as far as the robot can turn since its last scan, and the window as far as it
/// can go in the gap's time each do on their own (the whole-circle recovery alone takes the
/// room's half-turned twin, 180° off, also before the last two existed).
#[test]
fn a_turn_during_a_gap_is_recovered() {
    let walls = room();
    let run = |config: Config| {
        let mut mapper = Mapper::new(config);
        let mut headings: Vec<f64> = (0..=24).map(|i| 5.0 * i as f64).collect();
        headings.extend((0..24).rev().map(|i| 5.0 * i as f64));
        let mut t = 0.0;
        for h in headings {
            mapper.push(&scan_from(&walls, &Pose2::new(4.0, 0.0, h.to_radians()), t));
            t += 0.1;
        }
        let truth = Pose2::new(4.0, 0.0, 70f64.to_radians());
        let u = mapper.push(&scan_from(&walls, &truth, t + 3.0));
        (u.map_from_robot.theta_rad - truth.theta_rad)
            .to_degrees()
            .abs()
    };
    let recovered = run(Config::default());
    assert!(recovered < 1.0, "{recovered}° off");
    // The corner hypotheses find the turn as well, on their own...
    let mut none = Config::default();
    none.mapper.recover_below_inlier_share = 0.0;
    none.tracking.turn_on_the_spot = false;
    none.tracking.gap_window = false;
    none.tracking.corner_hypotheses = false;
    let mut corners_only = none.clone();
    corners_only.tracking.corner_hypotheses = true;
    let by_corners = run(corners_only);
    assert!(by_corners < 1.0, "{by_corners}° off by the corners alone");
    // ...and so do the search of a turn on the spot and the window after a gap.
    let mut turn_only = none.clone();
    turn_only.tracking.turn_on_the_spot = true;
    let by_turn = run(turn_only);
    assert!(
        by_turn < 1.0,
        "{by_turn}° off by the turn on the spot alone"
    );
    let mut gap_only = none.clone();
    gap_only.tracking.gap_window = true;
    let by_gap = run(gap_only);
    assert!(
        by_gap < 1.0,
        "{by_gap}° off by the window after a gap alone"
    );
    let off = none;
    assert!(
        run(off) > 10.0,
        "the test needs a turn the normal search misses"
    );
}

/// A scan that fits badly (mostly unmapped clutter) where no map lies within the recovery's
/// reach keeps its ICP result rather than falling back to the anchor.
#[test]
fn a_bad_fit_far_from_the_map_keeps_its_icp_result() {
    let far = vec![
        seg(-25.0, -25.0, 25.0, -25.0),
        seg(25.0, -25.0, 25.0, 25.0),
        seg(25.0, 25.0, -25.0, 25.0),
        seg(-25.0, 25.0, -25.0, -25.0),
    ];
    // A ring of short walls 3 m around the robot with a 10° gap ahead, towards the far wall.
    let mut world = far.clone();
    for i in 0..72 {
        let (a0, a1) = (
            (i as f64 * 5.0).to_radians(),
            ((i + 1) as f64 * 5.0).to_radians(),
        );
        let mid = (i as f64 * 5.0 + 182.5).rem_euclid(360.0) - 180.0;
        if mid.abs() < 5.0 {
            continue;
        }
        world.push(seg(
            0.3 + 3.0 * a0.cos(),
            3.0 * a0.sin(),
            0.3 + 3.0 * a1.cos(),
            3.0 * a1.sin(),
        ));
    }
    let mut mapper = Mapper::new(Config::default());
    mapper.push(&scan_from(&far, &Pose2::IDENTITY, 0.0));
    let u = mapper.push(&scan_from(&world, &Pose2::new(0.3, 0.0, 0.0), 0.1));
    let a = u.diagnostics.align.expect("aligned");
    assert!(
        (a.inliers as f64) < 0.15 * u.diagnostics.points as f64,
        "the fit is meant to be bad"
    );
    assert!(
        (u.map_from_robot.x_m - 0.3).abs() < 0.05,
        "{:?}",
        u.map_from_robot
    );
}

/// A kidnapped robot: after mapping one end of the room it is carried 5 m away and turned; its
/// scans are lost (not merged) until the whole-map search finds it again.
#[test]
#[ignore = "not handled: the first carried scan fits 51 % of its points at a wrong pose (70 \
            of 73 correspondences within 5 cm), so it is only `weak` and enters the map; the \
            following scans then fit that copy. Needs a free-space check that works on \
            cluttered maps (rays through map walls: 11-56 % median on the real logs)."]
fn a_kidnapped_robot_is_lost_then_found_again() {
    let walls = room();
    let mut mapper = Mapper::new(Config::default());
    for i in 0..40 {
        let truth = Pose2::new(0.05 * i as f64, 0.0, 0.0);
        mapper.push(&scan_from(&walls, &truth, i as f64 * 0.1));
    }
    let segments_before = mapper.map().len();
    let carried = Pose2::new(7.5, 0.5, 150f64.to_radians());
    let mut verdicts = Vec::new();
    let mut last = Pose2::IDENTITY;
    for k in 0..25 {
        let u = mapper.push(&scan_from(&walls, &carried, 10.0 + k as f64 * 0.1));
        verdicts.push(u.diagnostics.tracking.verdict);
        last = u.map_from_robot;
    }
    let found = last.between(&carried);
    assert!(
        found.translation().length() < 0.1 && found.theta_rad.abs() < 0.02,
        "not found again: {last:?} ({verdicts:?})"
    );
    assert_eq!(verdicts.last(), Some(&Verdict::Ok), "{verdicts:?}");
    let summary = mapper.tracking_summary();
    assert!(
        summary.lost == 0 || mapper.map().len() <= segments_before + 30,
        "lost scans entered the map"
    );
}

/// A corridor 2 m wide with a few door recesses at uneven spacing: ICP observes a step along it
/// only near a recess, and a long step not at all.
fn recessed_corridor() -> Vec<Segment> {
    let mut walls = Vec::new();
    let mut wall = |y: f64, doors: &[f64]| {
        let side = y.signum();
        let mut x0 = -3.0;
        for &d in doors {
            walls.push(seg(x0, y, d, y));
            walls.push(seg(d, y, d, y + 0.3 * side));
            walls.push(seg(d, y + 0.3 * side, d + 0.9, y + 0.3 * side));
            walls.push(seg(d + 0.9, y + 0.3 * side, d + 0.9, y));
            x0 = d + 0.9;
        }
        walls.push(seg(x0, y, 40.0, y));
    };
    wall(-1.0, &[2.0, 6.5, 13.0]);
    wall(1.0, &[4.2, 9.5, 15.5]);
    walls.push(seg(-3.0, -1.0, -3.0, 1.0));
    walls
}

/// Scans missing from a log (a gap of 1.5 s where the laser gives one every 0.1 s, the robot
/// going on at 1 m/s): the scan after the gap is predicted over the gap's time, and the
/// corridor is tracked (stamps that bunch say nothing about time:
/// `tracking::speed`'s `bunched_stamps_do_not_time_a_gap`).
#[test]
fn a_gap_in_the_log_is_predicted_over_its_time() {
    let walls = recessed_corridor();
    let run = |gap_scans: usize, stamp_of: &dyn Fn(usize) -> f64| {
        let mut mapper = Mapper::new(Config::default());
        let mut pairs = Vec::new();
        let mut step_after_gap = None;
        for i in (0..40).chain(40 + gap_scans..80 + gap_scans) {
            let truth = Pose2::new(0.1 * i as f64, 0.0, 0.0);
            let u = mapper.push(&scan_from(&walls, &truth, stamp_of(i)));
            pairs.push((truth, u.map_from_robot));
            if i == 40 + gap_scans {
                // The prediction for the next scan: one scan's motion, not the gap's.
                let (guess, _, _) = mapper.tracker.guess(None, Some(stamp_of(i + 1)));
                step_after_gap = Some(u.map_from_robot.between(&guess).x_m);
            }
        }
        let summary = mapper.tracking_summary().clone();
        (
            max_error(&pairs).0,
            summary,
            step_after_gap.unwrap_or(f64::NAN),
        )
    };
    let timed = |i: usize| 0.1 * i as f64;
    let (error, summary, step) = run(15, &timed);
    assert!(error < 0.1, "{error} m off after the gap");
    assert!(
        (step - 0.1).abs() < 0.02,
        "{step} m predicted after the gap"
    );
    // The scan after the gap, 41st pushed, is counted.
    assert_eq!((summary.gaps, summary.gap_scans), (1, vec![40]));
    let (unbroken, summary, _) = run(0, &timed);
    assert!(unbroken < 0.1, "{unbroken} m off without a gap");
    assert_eq!(summary.gaps, 0);
}

/// What [`drive_witnessed`] returns: each scan's update, the run's summary, the final map.
type Witnessed = (Vec<Update>, TrackingSummary, Vec<MapSegment>);

/// Forward 4 m along the room and back, 0.1 m per scan, with the log's odometry as `odometry`
/// makes it of the truth, under `config`; the scans `blind` picks have no valid point (lost).
fn drive_witnessed(
    config: Config,
    blind: impl Fn(usize) -> bool,
    odometry: impl Fn(usize, &Pose2) -> Pose2,
) -> Witnessed {
    let walls = room();
    let mut mapper = Mapper::new(config);
    let updates = (0..80)
        .map(|i| {
            let x = 0.1 * if i < 40 { i } else { 80 - i } as f64;
            let truth = Pose2::new(x, 0.2, 0.0);
            let mut scan = scan_from(&walls, &truth, i as f64 * 0.1);
            if blind(i) {
                scan.ranges_m.iter_mut().for_each(|r| *r = f64::NAN);
            }
            scan.odom_from_robot = Some(odometry(i, &truth));
            mapper.push(&scan)
        })
        .collect();
    (
        updates,
        mapper.tracking_summary().clone(),
        mapper.segments(),
    )
}

/// The default configuration with the odometry witness at `witness_m` (0: off).
fn witnessed_at(witness_m: f64) -> Config {
    let mut config = Config::default();
    config.tracking.odometry.odometry_witness_m = witness_m;
    config
}

#[test]
fn a_step_the_logs_odometry_contradicts_is_weak_and_counted() {
    // The odometry slips 0.5 m forward on scan 70 only (it reads a step of 0.6 m where the
    // robot went 0.1 m back), once 5 m of travel agreed.
    let slip = |i: usize, truth: &Pose2| match i {
        70 => Pose2::new(truth.x_m + 0.6, truth.y_m, truth.theta_rad),
        _ => *truth,
    };
    let sighted = |_: usize| false;
    let (updates, summary, map) = drive_witnessed(witnessed_at(0.3), sighted, slip);
    assert_eq!(summary.off_odometry_scans, [70, 71], "{summary:?}");
    assert_eq!(summary.off_odometry, 2);
    let t = updates[70].diagnostics.tracking;
    assert_eq!((t.verdict, t.reason), (Verdict::Weak, Reason::OffOdometry));
    assert!(updates[70].diagnostics.off_odometry && !updates[69].diagnostics.off_odometry);
    // The label alone: the poses and the map are those of a run the odometry does not
    // witness.
    let (unwitnessed, quiet, unwitnessed_map) = drive_witnessed(witnessed_at(0.0), sighted, slip);
    assert_eq!(quiet.off_odometry, 0);
    let poses = |u: &[Update]| u.iter().map(|u| u.map_from_robot).collect::<Vec<_>>();
    assert_eq!(poses(&updates), poses(&unwitnessed));
    assert_eq!(map, unwitnessed_map);
    // Scan 70 is 1 m along x from the first, the map frame's origin.
    let off = updates[70]
        .map_from_robot
        .between(&Pose2::new(1.0, 0.0, 0.0));
    assert!(off.translation().length() < 0.05, "{off:?}");
    // With the odometry prior the odometry is no witness: the scans check it otherwise.
    let mut prior = witnessed_at(0.3);
    prior.mapper.motion_prior = MotionPrior::Odometry;
    let (_, with_prior, _) = drive_witnessed(prior, sighted, slip);
    assert_eq!(with_prior.off_odometry, 0);
}

#[test]
fn odometry_that_cannot_witness_flags_nothing() {
    let quiet = |odometry: &dyn Fn(usize, &Pose2) -> Pose2, blind: &dyn Fn(usize) -> bool| {
        let (updates, summary, _) = drive_witnessed(witnessed_at(0.3), blind, odometry);
        let relabelled = updates
            .iter()
            .filter(|u| u.diagnostics.tracking.reason == Reason::OffOdometry)
            .count();
        (summary.off_odometry, relabelled)
    };
    let sighted = |_: usize| false;
    // Odometry that agrees.
    assert_eq!(quiet(&|_, truth| *truth, &sighted), (0, 0));
    // Odometry that reads the backward half as forward: the reverse witnesses the line.
    let forward = |i: usize, t: &Pose2| Pose2::new(0.1 * i as f64, t.y_m, t.theta_rad);
    assert_eq!(quiet(&forward, &sighted), (0, 0));
    // Odometry five times too long never agreed with the scans' travel.
    let scaled = |_: usize, t: &Pose2| Pose2::new(5.0 * t.x_m, t.y_m, t.theta_rad);
    assert_eq!(quiet(&scaled, &sighted), (0, 0));
    // A slip before 5 m of tracked travel agreed (scan 20, 2 m along) goes unwitnessed.
    let early = |i: usize, t: &Pose2| match i {
        20 => Pose2::new(t.x_m + 0.6, t.y_m, t.theta_rad),
        _ => *t,
    };
    assert_eq!(quiet(&early, &sighted), (0, 0));
    // Four lost scans (no valid point): the scan after them is witnessed from the last `ok`
    // one, not from the held pose of the last lost one, and is tracked right.
    let blind = |i: usize| (60..64).contains(&i);
    assert_eq!(quiet(&|_, truth| *truth, &blind), (0, 0));
}

/// Odometry that reads scans 21-31 three times as long as the robot went (0.3 m a step where
/// the scans track 0.1 m): the tracked steps fall short of it over 3.3 m, one stretch from its
/// first short step to its last. A lost scan inside it starts the window over (five short
/// steps before it and four after make no short window); with the odometry prior the odometry is no
/// witness. The poses are those of a run the odometry does not witness.
#[test]
fn steps_short_of_the_odometry_over_metres_are_one_stretch() {
    let long = |i: usize, t: &Pose2| {
        let extra = 0.2 * (i.clamp(20, 31) - 20) as f64;
        Pose2::new(t.x_m + extra, t.y_m, t.theta_rad)
    };
    let sighted = |_: usize| false;
    let (updates, summary, _) = drive_witnessed(witnessed_at(0.3), sighted, long);
    let ranges: Vec<(u32, u32)> = summary
        .short_of_odometry
        .iter()
        .map(|s| (s.first, s.last))
        .collect();
    assert_eq!(ranges, [(21, 31)], "{summary:?}");
    let (unwitnessed, _, _) = drive_witnessed(witnessed_at(0.0), sighted, long);
    let poses = |u: &[Update]| u.iter().map(|u| u.map_from_robot).collect::<Vec<_>>();
    assert_eq!(poses(&updates), poses(&unwitnessed));
    let (_, broken, _) = drive_witnessed(witnessed_at(0.3), |i| i == 26, long);
    assert_eq!(broken.short_of_odometry, [], "{broken:?}");
    let mut prior = witnessed_at(0.3);
    prior.mapper.motion_prior = MotionPrior::Odometry;
    let (_, with_prior, _) = drive_witnessed(prior, sighted, long);
    assert_eq!(with_prior.short_of_odometry, [], "{with_prior:?}");
}

/// `walls` as a finished map whose walls are right on the whole but off by up to 8 cm in ways
/// that differ from place to place: each wall cut into pieces of at most 0.6 m, each piece
/// moved across the wall by its own amount.
fn uneven_saved_map(walls: &[Segment]) -> Vec<MapSegment> {
    let mut pieces = Vec::new();
    for (w, wall) in walls.iter().enumerate() {
        let along = wall.end - wall.start;
        let normal = Vec2::new(-along.y, along.x).normalize();
        let n = (along.length() / 0.6).ceil() as usize;
        for k in 0..n {
            let off = 0.08 * ((k * 7 + w * 3) as f64 * 2.4).sin();
            let (a, b) = (k as f64 / n as f64, (k + 1) as f64 / n as f64);
            pieces.push(MapSegment {
                segment: Segment::new(
                    wall.start + along * a + normal * off,
                    wall.start + along * b + normal * off,
                ),
                born_scan: 0,
            });
        }
    }
    pieces
}

/// Localizes a drive through the room in `uneven_saved_map`; returns the run's trajectory
/// (after `finish`) with the true poses.
fn localize_in_uneven_map(own_motion_s: f64) -> Vec<(Pose2, Pose2)> {
    let walls = room();
    let mut config = Config::default();
    config.mapper.localize_own_motion_s = own_motion_s;
    let prior = PriorMap {
        segments: uneven_saved_map(&walls),
        scans: 1,
        nodes: Vec::new(),
        observations: None,
    };
    let truth: Vec<Pose2> = (0..120)
        .map(|i| Pose2::new(0.05 * i as f64, 1.0, 0.1 * (i as f64 / 30.0).sin()))
        .collect();
    let mut mapper = Mapper::on_map(config, prior, MapRole::Localize, Some(truth[0]));
    for (i, t) in truth.iter().enumerate() {
        // A laser of 4 m with up to 1 cm of noise: pieces of wall come into sight and go out of
        // it as the robot drives.
        let mut scan = scan_from(&walls, t, i as f64 * 0.1);
        for (k, r) in scan.ranges_m.iter_mut().enumerate() {
            let noise = 0.01 * ((i * 181 + k) as f64 * 12.9898).sin();
            *r = if *r > 4.0 {
                scan.max_range_m
            } else {
                *r + noise
            };
        }
        mapper.push(&scan);
    }
    mapper.finish().unwrap();
    truth
        .into_iter()
        .zip(mapper.trajectory().iter().copied())
        .collect()
}

/// Mean error of the steps between consecutive scans, and the largest distance from the
/// truth (the saved map's frame is the truth's), metres.
fn step_and_place_errors(pairs: &[(Pose2, Pose2)]) -> (f64, f64) {
    let steps: Vec<f64> = pairs
        .windows(2)
        .map(|w| {
            let (true_step, step) = (w[0].0.between(&w[1].0), w[0].1.between(&w[1].1));
            (step.translation() - true_step.translation()).length()
        })
        .collect();
    let place = pairs
        .iter()
        .map(|(t, e)| t.translation().distance(e.translation()))
        .fold(0.0, f64::max);
    (steps.iter().sum::<f64>() / steps.len() as f64, place)
}

/// Tracked against a finished map whose walls are off by centimetres from place to place, each
/// scan is put off on its own by the pieces it sees; a localize run takes its motion over short
/// spans from its own map of the scans, and its place from the saved map. Measured: steps
/// 3.5 → 2.3 mm off on average, the farthest pose 8.1 → 3.9 cm from the truth.
#[test]
fn a_localize_run_takes_its_short_motion_from_its_own_map_and_its_place_from_the_saved_map() {
    let (raw_steps, raw_place) = step_and_place_errors(&localize_in_uneven_map(0.0));
    let (steps, place) = step_and_place_errors(&localize_in_uneven_map(3.0));
    assert!(
        steps < 0.8 * raw_steps,
        "steps {raw_steps} → {steps} m off on average"
    );
    assert!(place < raw_place, "{raw_place} → {place} m from the truth");
}

/// A curved hallway 2.4 m wide round a bend of 8 m radius (centre `(0, 8)`), its walls drawn as
/// chords of 0.25 m: along the bend the scan fits the map weakly (moving along it turns the
/// robot as it goes), and the chords' kinks pull ICP off by a little at every scan.
fn bend() -> Vec<Segment> {
    let centre = Vec2::new(0.0, 8.0);
    let mut walls = Vec::new();
    for radius in [6.8, 9.2] {
        let n = (2.2 * radius / 0.25) as usize;
        let at = |k: usize| {
            let a = -0.6 + 2.2 * k as f64 / n as f64 - std::f64::consts::FRAC_PI_2;
            centre + Vec2::new(a.cos(), a.sin()) * radius
        };
        walls.extend((0..n).map(|k| Segment::new(at(k), at(k + 1))));
    }
    walls
}

/// With odometry read exactly, a robot round the bend stays on the odometry's track: the pose the
/// fit chose is refined by ICP weighing the odometry's step with the fit, so the chords' pull
/// along the bend moves it by the share of the fit's few points there, not to wherever the fit
/// alone ends. A pose so weighed is not fused with the odometry a second time.
#[test]
fn with_odometry_a_curved_hallway_is_tracked_along_its_bend() {
    let walls = bend();
    let mut config = Config::default();
    config.mapper.motion_prior = MotionPrior::Odometry;
    // Without merging, the map is the scans' own chords: the merge's straightening of a bend
    // (`docs/ARCHITECTURE.md`, "Map and merge") is not what this test is about.
    config.merge.pairing_threshold = 0.0;
    config.merge.simplify_threshold = 0.0;
    let mut mapper = Mapper::new(config);
    let mut pairs = Vec::new();
    for i in 0..160 {
        // 5 cm per scan along the circle of 8 m radius.
        let a = 0.05 * i as f64 / 8.0;
        let truth = Pose2::new(8.0 * a.sin(), 8.0 - 8.0 * a.cos(), a);
        let mut scan = scan_from(&walls, &truth, i as f64 * 0.1);
        scan.odom_from_robot = Some(truth);
        let u = mapper.push(&scan);
        if let Some(a) = u.diagnostics.align.filter(|a| a.weighed_prior) {
            assert_eq!(u.map_from_robot, a.map_from_robot, "scan {i} fused twice");
        }
        pairs.push((truth, u.map_from_robot));
    }
    // Measured 0.13 m and 1.0° (the fit alone: 1.0 m and 7.6°, the robot held back along the
    // bend and turned short).
    let (dt, dr) = max_error(&pairs);
    assert!(dt < 0.25 && dr < 2.5, "trajectory error {dt} m, {dr}°");
}

/// A wheel that stalls while the robot drives on through a room the scan observes in every
/// direction: the odometry's step, weighed with the fit, would hold each pose back by its share;
/// the pose found contradicts the step, so the scan is tracked on its fit alone.
#[test]
fn with_odometry_a_stalled_wheel_beside_a_sure_fit_is_tracked_on_the_fit() {
    let walls = room();
    let mut config = Config::default();
    config.mapper.motion_prior = MotionPrior::Odometry;
    let mut mapper = Mapper::new(config);
    let mut pairs = Vec::new();
    for i in 0..40 {
        let truth = Pose2::new(0.1 * i as f64, 0.0, 0.0);
        // The wheels stall from scan 10 on: the odometry stays where it was.
        let read = Pose2::new(0.1 * i.min(10) as f64, 0.0, 0.0);
        let mut scan = scan_from(&walls, &truth, i as f64 * 0.1);
        scan.odom_from_robot = Some(read);
        pairs.push((truth, mapper.push(&scan).map_from_robot));
    }
    let (dt, dr) = max_error(&pairs);
    assert!(dt < 0.01 && dr < 0.2, "trajectory error {dt} m, {dr}°");
}

/// In a bare corridor along x (walls far beyond the laser's 30 m at both ends), a scan's pose
/// is sure across the corridor and in heading, and along it rests on the motion prior alone:
/// its covariance says so, larger along x than across by orders of magnitude. The first scan
/// sets the map frame (no uncertainty); in the room every direction is observed.
#[test]
fn the_pose_covariance_is_large_only_along_what_the_scan_does_not_observe() {
    let walls = [seg(-100.0, -1.0, 100.0, -1.0), seg(-100.0, 1.0, 100.0, 1.0)];
    let mut mapper = Mapper::new(Config::default());
    let mut last = None;
    for i in 0..20 {
        let truth = Pose2::new(0.05 * i as f64, 0.0, 0.0);
        let u = mapper.push(&scan_from(&walls, &truth, i as f64 * 0.1));
        let c = u.diagnostics.pose_covariance;
        if i == 0 {
            assert_eq!(c, [[0.0; 3]; 3]);
        }
        last = Some(c);
    }
    let c = last.unwrap();
    assert!(
        c[1][1] < 1e-4 && c[2][2] < 1e-4,
        "across and heading: {c:?}"
    );
    assert!(c[0][0] > 100.0 * c[1][1], "along the corridor: {c:?}");
    assert_eq!(c[0][1], c[1][0]);
    let mut in_room = Mapper::new(Config::default());
    let mut worst = 0.0f64;
    for i in 0..10 {
        let truth = Pose2::new(0.05 * i as f64, 0.0, 0.0);
        let u = in_room.push(&scan_from(&room(), &truth, i as f64 * 0.1));
        let c = u.diagnostics.pose_covariance;
        worst = worst.max(c[0][0]).max(c[1][1]);
    }
    assert!(worst < 1e-4, "the room observes every direction: {worst}");
}

/// Along the recessed corridor at 1 m/s and ten scans a second, the steps near a recess observe
/// the speed; between recesses the pose along the corridor rests on that speed (the prior fused
/// with a fit that observed it weakly or not at all): its variance there is the prior's, above
/// the fit's across the corridor and far below "unknown".
#[test]
fn along_a_corridor_the_speed_last_observed_holds_the_pose_and_its_covariance() {
    let walls = recessed_corridor();
    let mut mapper = Mapper::new(Config::default());
    let mut held = 0;
    for i in 0..120 {
        let truth = Pose2::new(0.1 * i as f64, 0.0, 0.0);
        let u = mapper.push(&scan_from(&walls, &truth, 0.1 * i as f64));
        let c = u.diagnostics.pose_covariance;
        let reason = u.diagnostics.tracking.reason;
        if i > 20 && matches!(reason, Reason::WeaklyObserved | Reason::Degenerate) {
            assert!(c[1][1] < 1e-3, "scan {i}: across {c:?}");
            // The prior's spread at ten scans a second: 5 mm plus 1 m/s² × 0.1 s × (0.05 s and
            // the time since the speed was observed), a centimetre or a few.
            if c[0][0] >= 1e-4 && c[0][0] < 1e-2 && c[0][0] > 4.0 * c[1][1] {
                held += 1;
            }
        }
    }
    assert!(held > 0, "no weak scan held by the speed prior");
}
