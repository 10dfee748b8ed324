use polymap::geometry::Pose2;

use super::*;

/// A wiggly true path: forward steps with changing turns, 1 s apart.
fn true_path(n: usize) -> Vec<(f64, Pose2)> {
    let mut pose = Pose2::new(0.5, -1.0, 0.2);
    let mut out = vec![(100.0, pose)];
    for i in 1..n {
        let step = Pose2::new(
            0.3 + 0.05 * (i % 3) as f64,
            0.02 * (i % 2) as f64,
            0.1 * ((i as f64) * 0.7).sin(),
        );
        pose = pose.compose(&step);
        out.push((100.0 + i as f64, pose));
    }
    out
}

#[test]
fn rigidly_moved_copy_has_zero_ate_and_alignment_is_recovered() {
    let truth = true_path(40);
    let world_from_map = Pose2::new(-4.0, 2.5, 2.2);
    let map_from_world = world_from_map.inverse();
    let est: Vec<(f64, Pose2)> = truth
        .iter()
        .map(|(t, p)| (*t, map_from_world.compose(p)))
        .collect();
    let m = evaluate_trajectory(&est, &truth, &TrajectoryParams::default());
    let ate = m.ate.unwrap();
    assert!(ate.position_m.max < 1e-9, "{ate:?}");
    assert!(ate.heading_deg.max < 1e-7);
    let found = ate.truth_from_estimate;
    assert!((found.translation() - world_from_map.translation()).length() < 1e-9);
    assert!((found.theta_rad - world_from_map.theta_rad).abs() < 1e-12);
}

#[test]
fn first_pose_alignment_and_identity_differ_as_expected() {
    let truth = true_path(10);
    let shift = Pose2::new(1.0, 0.0, 0.0);
    let est: Vec<(f64, Pose2)> = truth.iter().map(|(t, p)| (*t, shift.compose(p))).collect();
    let pairs = associate(&est, &truth, 1e-3);
    let none = absolute_trajectory_error(&pairs, AteAlignment::Identity).unwrap();
    assert!((none.position_m.mean - 1.0).abs() < 1e-12);
    let first = absolute_trajectory_error(&pairs, AteAlignment::FirstPose).unwrap();
    assert!(first.position_m.max < 1e-9);
}

#[test]
fn rpe_of_constant_per_step_error() {
    let truth = true_path(30);
    let per_step_error = Pose2::new(0.01, 0.0, 0.5f64.to_radians());
    let mut est = vec![(truth[0].0, Pose2::IDENTITY)];
    for w in truth.windows(2) {
        let step = w[0].1.between(&w[1].1).compose(&per_step_error);
        let last = est[est.len() - 1].1;
        est.push((w[1].0, last.compose(&step)));
    }
    let m = evaluate_trajectory(&est, &truth, &TrajectoryParams::default());
    let rpe = m.rpe.unwrap();
    assert_eq!(rpe.pairs, 29);
    assert!((rpe.translation_m.mean - 0.01).abs() < 1e-9 && rpe.translation_m.std < 1e-9);
    assert!((rpe.rotation_deg.mean - 0.5).abs() < 1e-9);
    // The ATE sees the accumulated drift.
    assert!(m.ate.unwrap().position_m.max > 0.05);
}

#[test]
fn rpe_offsets_and_invalid_deltas() {
    let truth = true_path(10);
    let pairs = associate(&truth, &truth, 1e-3);
    assert_eq!(
        relative_pose_errors(&pairs, RpeDelta::Frames(3))
            .unwrap()
            .pairs,
        7
    );
    assert!(relative_pose_errors(&pairs, RpeDelta::Frames(10)).is_none());
    assert!(relative_pose_errors(&pairs, RpeDelta::Frames(0)).is_none());
    assert!(relative_pose_errors(&pairs, RpeDelta::DistanceM(0.0)).is_none());
    assert!(relative_pose_errors(&pairs, RpeDelta::DistanceM(f64::NAN)).is_none());
    let by_1m = relative_pose_errors(&pairs, RpeDelta::DistanceM(1.0)).unwrap();
    assert!(by_1m.pairs > 0 && by_1m.translation_m.max < 1e-9);
}

#[test]
fn association_handles_unsorted_duplicates_and_gaps() {
    let truth = true_path(5);
    let mut est: Vec<(f64, Pose2)> = truth.iter().rev().copied().collect();
    est.push((102.0, Pose2::new(50.0, 0.0, 0.0))); // duplicate stamp, later in file: ignored
    est.push((102.5, Pose2::IDENTITY)); // no true pose
    est.push((f64::NAN, Pose2::IDENTITY));
    let pairs = associate(&est, &truth, 1e-3);
    assert_eq!(pairs.len(), 5);
    assert!(pairs.windows(2).all(|w| w[0].stamp_s < w[1].stamp_s));
    assert_eq!(pairs[2].estimate, truth[2].1);
}

#[test]
fn empty_inputs_give_no_metrics() {
    let m = evaluate_trajectory(&[], &true_path(3), &TrajectoryParams::default());
    assert_eq!(m.associated, 0);
    assert!(m.ate.is_none() && m.rpe.is_none());
}
