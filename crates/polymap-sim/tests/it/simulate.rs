//! Whole runs: determinism, time stamps, scan layout, odometry drift, parameters.

use std::time::Instant;

use polymap::geometry::Pose2;
use polymap_sim::{LaserParams, OdometryParams, SimParams, World, poses_in_first_frame, simulate};

fn short(max_scans: usize) -> SimParams {
    SimParams {
        max_scans: Some(max_scans),
        ..SimParams::default()
    }
}

#[test]
fn a_seed_determines_the_run() {
    let w = World::clutter();
    let a = simulate(&w, &short(300), 42);
    assert_eq!(a, simulate(&w, &short(300), 42));
    let b = simulate(&w, &short(300), 43);
    assert_eq!(
        a.true_poses, b.true_poses,
        "the path does not depend on the seed"
    );
    assert_ne!(a.scans, b.scans);
}

#[test]
fn laser_and_odometry_noise_are_independent_streams() {
    let w = World::office();
    let a = simulate(&w, &short(200), 5);
    let mut params = short(200);
    params.laser.range_sigma_m = 0.05;
    let b = simulate(&w, &params, 5);
    let odom = |r: &polymap_sim::SimRun| {
        r.scans
            .iter()
            .map(|s| s.odom_from_robot)
            .collect::<Vec<_>>()
    };
    assert_eq!(odom(&a), odom(&b));
    assert_ne!(a.scans[10].ranges_m, b.scans[10].ranges_m);
}

#[test]
fn stamps_step_at_the_scan_rate_with_six_decimals() {
    let r = simulate(&World::hex60(), &short(50), 1);
    assert_eq!(r.scans[0].stamp.text, "1000000000.000000");
    assert_eq!(r.scans[49].stamp.text, "1000000004.900000");
    for (k, s) in r.scans.iter().enumerate() {
        assert_eq!(s.stamp.text.parse::<f64>().ok(), Some(s.stamp.seconds));
        assert!((s.stamp.seconds - 1e9 - k as f64 * 0.1).abs() < 1e-6);
    }
}

#[test]
fn scans_have_the_laser_layout() {
    let laser = LaserParams {
        robot_from_laser: Pose2::new(0.2, 0.0, 0.0),
        ..LaserParams::full_circle()
    };
    let params = SimParams { laser, ..short(30) };
    let r = simulate(&World::hallway45(), &params, 1);
    for s in &r.scans {
        assert_eq!(s.ranges_m.len(), 360);
        assert!((s.angle_min_rad + std::f64::consts::PI).abs() < 1e-12);
        assert!((s.angle_increment_rad.to_degrees() - 1.0).abs() < 1e-12);
        assert_eq!(s.max_range_m, 30.0);
        assert_eq!(s.robot_from_laser, Pose2::new(0.2, 0.0, 0.0));
        assert!(s.ranges_m.iter().all(|&x| x > 0.0 && x <= 30.0));
        let no_returns = s.ranges_m.iter().filter(|&&x| x == 30.0).count();
        assert_eq!(no_returns, s.ranges_m.len() - s.valid_count());
    }
}

#[test]
fn odometry_drifts_while_truth_stays_exact() {
    let r = simulate(&World::hallway45(), &SimParams::default(), 9);
    let truth = r.true_poses_in_first_frame();
    let odom = r.odometry_poses();
    assert_eq!(odom.len(), truth.len());
    assert_eq!(odom[0], Pose2::IDENTITY);
    let err = |k: usize| (odom[k].translation() - truth[k].translation()).length();
    let n = truth.len();
    let (early, middle, end) = (err(n / 10), err(n / 2), err(n - 1));
    assert!(early < middle && middle < end, "{early} {middle} {end}");
    assert!(end > 0.5 && end < 5.0, "{end}");
    // The truth moves within the robot's limits and re-expresses exactly.
    let p = &r.params.path;
    for w in r.true_poses.windows(2) {
        let d = w[0].between(&w[1]);
        assert!(d.translation().length() <= p.speed_mps / r.params.rate_hz + 1e-9);
        assert!(d.theta_rad.abs() <= p.max_turn_rate_rad_s / r.params.rate_hz + 1e-9);
    }
    assert_eq!(truth, poses_in_first_frame(&r.true_poses));
    assert_eq!(truth[0], Pose2::IDENTITY);
    assert_ne!(
        r.true_poses[0],
        Pose2::IDENTITY,
        "the world frame is not the first pose's"
    );
}

#[test]
fn exact_odometry_and_disabled_odometry() {
    let exact = SimParams {
        odometry: OdometryParams::exact(),
        ..short(400)
    };
    let r = simulate(&World::office(), &exact, 2);
    let truth = r.true_poses_in_first_frame();
    for (s, t) in r.scans.iter().zip(&truth) {
        let o = s.odom_from_robot.unwrap_or(Pose2::new(f64::NAN, 0.0, 0.0));
        assert!((o.translation() - t.translation()).length() < 1e-9);
    }
    let off = SimParams {
        odometry: OdometryParams {
            enabled: false,
            ..OdometryParams::default()
        },
        ..short(10)
    };
    assert!(
        simulate(&World::office(), &off, 2)
            .scans
            .iter()
            .all(|s| s.odom_from_robot.is_none())
    );
}

#[test]
fn walls_in_first_frame_match_scan_points() {
    let exact_laser = LaserParams {
        range_sigma_m: 0.0,
        dropout_probability: 0.0,
        ..LaserParams::default()
    };
    let r = simulate(
        &World::clutter(),
        &SimParams {
            laser: exact_laser,
            ..short(100)
        },
        3,
    );
    let walls = r.walls_in_first_frame();
    let truth = r.true_poses_in_first_frame();
    let mut pts = Vec::new();
    for (s, first_from_robot) in r.scans.iter().zip(&truth).step_by(20) {
        s.points_in_robot(&mut pts);
        for p in &pts {
            let q = first_from_robot.transform_point(*p);
            let d = walls
                .iter()
                .map(|w| w.distance_to_point(q))
                .fold(f64::MAX, f64::min);
            // Pillars are polygons inscribed in the circle: a few millimetres of sagitta.
            assert!(d < 0.01, "point {q} is {d} m off the truth");
        }
    }
}

#[test]
fn invalid_parameters_fall_back_to_defaults_without_panicking() {
    let mut p = SimParams {
        rate_hz: f64::NAN,
        max_scans: Some(5),
        ..SimParams::default()
    };
    p.laser.num_beams = 0;
    p.laser.dropout_probability = 7.0;
    p.path.speed_mps = -1.0;
    assert!(p.validate().is_err());
    let r = simulate(&World::hex60(), &p, 0);
    assert_eq!(r.scans.len(), 5);
    assert_eq!(r.scans[0].ranges_m.len(), 180);
    assert_eq!(r.params.validate(), Ok(()));
}

#[test]
fn degenerate_worlds_give_empty_or_tiny_runs() {
    let empty = World {
        moved: None,
        name: "empty".into(),
        description: String::new(),
        walls: vec![],
        pillars: vec![],
        waypoints: vec![],
        laser: Default::default(),
    };
    let r = simulate(&empty, &SimParams::default(), 0);
    assert!(r.scans.is_empty() && r.walls_seen.is_empty());
    let dot = World {
        moved: None,
        waypoints: vec![polymap::geometry::Vec2::ONE],
        laser: Default::default(),
        ..empty
    };
    let r = simulate(&dot, &SimParams::default(), 0);
    assert_eq!(r.scans.len(), 1);
    assert_eq!(r.scans[0].valid_count(), 0);
}

#[test]
fn every_world_simulates_a_tour() {
    let t0 = Instant::now();
    let mut scans = 0;
    for w in World::catalogue() {
        let run = simulate(&w, &SimParams::default(), 1);
        assert!(
            run.scans.len() >= 100,
            "{}: {} scans",
            run.world_name,
            run.scans.len()
        );
        assert_eq!(run.scans.len(), run.true_poses.len(), "{}", run.world_name);
        scans += run.scans.len();
    }
    // How long it takes is for the benches; printed here for a look.
    println!("{scans} scans in {:.2} s", t0.elapsed().as_secs_f64());
}

#[test]
fn a_turned_world_gives_the_same_scans() {
    let params = SimParams {
        odometry: OdometryParams::exact(),
        ..short(150)
    };
    let w = World::hex60();
    let turned = w.transformed(&Pose2::new(3.0, -7.0, 0.3));
    let (a, b) = (simulate(&w, &params, 8), simulate(&turned, &params, 8));
    for (ta, tb) in a
        .true_poses_in_first_frame()
        .iter()
        .zip(&b.true_poses_in_first_frame())
    {
        let d = ta.between(tb);
        assert!(
            d.translation().length() < 1e-9 && d.theta_rad.abs() < 1e-9,
            "{d:?}"
        );
    }
    // At grazing incidence a rounding-sized change of pose moves a range a lot, so count the
    // beams that agree closely rather than demanding all of them.
    let pairs = a
        .scans
        .iter()
        .zip(&b.scans)
        .flat_map(|(sa, sb)| sa.ranges_m.iter().zip(&sb.ranges_m));
    let (close, total) = pairs.fold((0, 0), |(c, t), (ra, rb)| {
        (c + usize::from((ra - rb).abs() < 1e-6), t + 1)
    });
    assert!(close as f64 > 0.999 * total as f64, "{close} of {total}");
    assert_eq!(a.walls_seen, b.walls_seen);
}
