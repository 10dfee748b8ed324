//! End to end on every simulated world against its ground truth.
//!
//! Bounds, and why: the worlds are 60–85 m paths, and the trajectory error is mostly drift
//! (loop closure ties returns to earlier passes where the paths cross); the bounds are about
//! twice what the default configuration measured without loop closure (ATE RMSE after SE(2)
//! alignment: hallway45 0.05 m, hex60 0.09 m, clutter 0.20 m, office 0.04 m; with it: 0.06,
//! 0.04, 0.13, 0.04 m), so a regression shows while floating-point or ordering changes do not.
//! The map must explain the data (share of scan points within 10 cm of a segment, with the
//! final poses), lie on the true walls after the same alignment (precision within 10 cm), and
//! stay small: at most about twice the number of true walls the laser saw.

use polymap::config::Config;
use polymap::geometry::{Pose2, Segment};
use polymap_eval::map_quality::{
    PointFitParams, TrueWall, WallParams, map_fit_to_points, map_vs_walls,
};
use polymap_eval::trajectory::{AteAlignment, PosePair, absolute_trajectory_error};

use crate::support::{map_run, pose_pairs, sim};

struct Bounds {
    ate_m: f64,
    points_within_10cm: f64,
    precision_10cm: f64,
}

fn check_world(name: &str, b: Bounds) {
    let run = sim(name);
    let (mapper, _) = map_run(&run, Config::default());
    let pairs: Vec<PosePair> = pose_pairs(&run, &mapper)
        .into_iter()
        .enumerate()
        .map(|(i, (estimate, truth))| PosePair {
            stamp_s: i as f64,
            estimate,
            truth,
        })
        .collect();
    let ate =
        absolute_trajectory_error(&pairs, AteAlignment::LeastSquares).expect("poses associated");
    let segments: Vec<Segment> = mapper.segments().iter().map(|s| s.segment).collect();
    let poses: Vec<Pose2> = mapper.trajectory().to_vec();
    let fit = map_fit_to_points(
        &segments,
        &run.scans,
        &poses,
        &PointFitParams {
            scan_stride: 5,
            ..PointFitParams::default()
        },
    );
    let walls: Vec<TrueWall> = run
        .walls_in_first_frame()
        .into_iter()
        .map(TrueWall::from)
        .collect();
    let score = map_vs_walls(
        &segments,
        &walls,
        &ate.truth_from_estimate,
        &WallParams {
            tolerance_m: 0.10,
            ..WallParams::default()
        },
    );
    let precision = score.precision.unwrap_or(0.0);
    let seen = run.walls_seen.len();
    eprintln!(
        "{name}: {} scans, ATE {:.3} m, {} segments for {seen} walls seen, points within 10 cm {:.1}%, precision {:.1}%, recall {:.1}%",
        run.scans.len(),
        ate.position_m.rms,
        segments.len(),
        100.0 * fit.share_within_loose,
        100.0 * precision,
        100.0 * score.recall.unwrap_or(0.0)
    );
    assert!(
        ate.position_m.rms <= b.ate_m,
        "{name}: ATE {} m > {} m",
        ate.position_m.rms,
        b.ate_m
    );
    assert!(
        fit.share_within_loose >= b.points_within_10cm,
        "{name}: {:.3} of points within 10 cm",
        fit.share_within_loose
    );
    assert!(
        precision >= b.precision_10cm,
        "{name}: precision {precision:.3}"
    );
    assert!(
        segments.len() <= 2 * seen + 5,
        "{name}: {} segments for {seen} walls seen",
        segments.len()
    );
}

#[test]
fn hallway45_against_ground_truth() {
    check_world(
        "hallway45",
        Bounds {
            ate_m: 0.12,
            points_within_10cm: 0.95,
            precision_10cm: 0.6,
        },
    );
}

#[test]
fn hex60_against_ground_truth() {
    check_world(
        "hex60",
        Bounds {
            ate_m: 0.2,
            points_within_10cm: 0.85,
            precision_10cm: 0.5,
        },
    );
}

#[test]
fn clutter_against_ground_truth() {
    check_world(
        "clutter",
        Bounds {
            ate_m: 0.4,
            points_within_10cm: 0.5,
            precision_10cm: 0.3,
        },
    );
}

#[test]
fn office_against_ground_truth() {
    check_world(
        "office",
        Bounds {
            ate_m: 0.1,
            points_within_10cm: 0.9,
            precision_10cm: 0.6,
        },
    );
}
