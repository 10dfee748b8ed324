use std::f64::consts::{FRAC_PI_2, PI};

use super::*;

fn rel(t1_s: f64, t2_s: f64, x_m: f64, y_m: f64, yaw_rad: f64) -> Relation {
    Relation {
        t1_s,
        t2_s,
        robot1_from_robot2: Pose2::new(x_m, y_m, yaw_rad),
        line: 0,
    }
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

#[test]
fn relative_pose_is_taken_in_the_first_robot_frame() {
    // Robot faces +y; it drives 2 m forward: in its own frame that is +x, in the map +y.
    let trajectory = [
        (1.0, Pose2::new(1.0, 1.0, FRAC_PI_2)),
        (2.0, Pose2::new(1.0, 3.0, FRAC_PI_2)),
    ];
    let exact = rel(1.0, 2.0, 2.0, 0.0, 0.0);
    let off = rel(1.0, 2.0, 2.0, 0.1, 0.05);
    let errs = relation_errors(&[exact, off], &trajectory, &RelationParams::default());
    assert!(
        close(errs.errors[0].translation_error_m, 0.0),
        "inv(P1)·P2, not P2 − P1"
    );
    assert!(close(errs.errors[1].translation_error_m, 0.1));
    assert!(close(errs.errors[1].rotation_error_rad, 0.05));
    let est = errs.errors[0].estimated_robot1_from_robot2;
    assert!(close(est.x_m, 2.0) && close(est.y_m, 0.0) && close(est.theta_rad, 0.0));
}

#[test]
fn rotation_error_wraps_at_half_turn() {
    let a = 179f64.to_radians();
    // The robot turns by +2° across ±180°.
    let trajectory = [
        (1.0, Pose2::new(0.0, 0.0, a)),
        (2.0, Pose2::new(0.0, 0.0, -a)),
    ];
    let m = evaluate_relations(
        &[rel(1.0, 2.0, 0.0, 0.0, 1f64.to_radians())],
        &trajectory,
        &RelationParams::default(),
    );
    assert!(close(m.rotation_deg.unwrap().mean, 1.0));
    // A true yaw just below +π against an estimate just above −π: tiny error, not ~360°.
    let e = pose_difference(
        &Pose2::new(0.0, 0.0, -PI + 0.01),
        &Pose2::new(0.0, 0.0, PI - 0.01),
    );
    assert!(close(e.rotation_rad, 0.02));
}

#[test]
fn unmatched_stamps_are_counted_not_scored() {
    let trajectory = [(1.0, Pose2::IDENTITY), (2.0, Pose2::new(1.0, 0.0, 0.0))];
    let rels = [
        rel(1.0, 2.0, 1.0, 0.0, 0.0),
        rel(1.0, 2.5, 1.0, 0.0, 0.0),
        rel(0.5, 2.0, 1.0, 0.0, 0.0),
    ];
    let errs = relation_errors(&rels, &trajectory, &RelationParams::default());
    assert_eq!(errs.unmatched, vec![1, 2]);
    let m = RelationMetrics::from_errors(&errs);
    assert_eq!((m.relations, m.matched, m.unmatched), (3, 1, 2));
}

#[test]
fn stamps_need_not_be_sorted() {
    let trajectory = [
        (3.0, Pose2::new(3.0, 0.0, 0.0)),
        (1.0, Pose2::new(1.0, 0.0, 0.0)),
        (2.0, Pose2::new(2.0, 0.0, 0.0)),
    ];
    let rels = [rel(1.0, 3.0, 2.0, 0.0, 0.0), rel(3.0, 2.0, -1.0, 0.0, 0.0)];
    let m = evaluate_relations(&rels, &trajectory, &RelationParams::default());
    assert_eq!(m.matched, 2);
    assert!(close(m.translation_m.unwrap().max, 0.0));
}

#[test]
fn duplicate_stamp_takes_first_pose_and_tolerance_is_honoured() {
    let trajectory = [
        (1.0, Pose2::IDENTITY),
        (2.0, Pose2::new(1.0, 0.0, 0.0)),
        (2.0, Pose2::new(9.0, 0.0, 0.0)),
    ];
    let near = rel(1.0, 2.000_002, 1.0, 0.0, 0.0);
    let m = evaluate_relations(&[near], &trajectory, &RelationParams::default());
    assert!(close(m.translation_m.unwrap().mean, 0.0));
    let strict = RelationParams {
        stamp_tolerance_s: 1e-6,
    };
    assert_eq!(evaluate_relations(&[near], &trajectory, &strict).matched, 0);
}

/// A relation names a scan by its stamp: where a log's stamps bunch (Intel's last scans, 1 ms
/// apart) and the trajectory lacks that scan (a run of every k-th scan), the scan next to it
/// is no match.
#[test]
fn a_relation_to_a_scan_the_trajectory_lacks_is_unmatched_where_stamps_bunch() {
    // Scans stamped 1 ms apart while the robot drives 0.4 m from one to the next; the run kept
    // the scans at 10.000 and 10.002, not the relation's at 10.001.
    let trajectory = [
        (10.000, Pose2::IDENTITY),
        (10.002, Pose2::new(0.8, 0.0, 0.0)),
    ];
    let rels = [rel(10.000, 10.001, 0.4, 0.0, 0.0)];
    let m = evaluate_relations(&rels, &trajectory, &RelationParams::default());
    assert_eq!(m.matched, 0);
    let loose = RelationParams {
        stamp_tolerance_s: 1e-3,
    };
    assert_eq!(evaluate_relations(&rels, &trajectory, &loose).matched, 1);
}

#[test]
fn non_finite_pose_counts_as_unmatched() {
    let trajectory = [
        (1.0, Pose2::IDENTITY),
        (
            2.0,
            Pose2 {
                x_m: f64::NAN,
                y_m: 0.0,
                theta_rad: 0.0,
            },
        ),
    ];
    let m = evaluate_relations(
        &[rel(1.0, 2.0, 1.0, 0.0, 0.0)],
        &trajectory,
        &RelationParams::default(),
    );
    assert_eq!((m.matched, m.unmatched), (0, 1));
    assert!(m.translation_m.is_none());
    assert!(m.to_table().contains("| translation (m)    |          - |"));
}

#[test]
fn mean_std_and_squares_by_hand() {
    // Errors 0.1 m and 0.3 m; 1° and 3°.
    let trajectory = [
        (1.0, Pose2::IDENTITY),
        (2.0, Pose2::new(1.0, 0.0, 0.0)),
        (3.0, Pose2::new(2.0, 0.0, 0.0)),
    ];
    let rels = [
        rel(1.0, 2.0, 0.9, 0.0, 1f64.to_radians()),
        rel(2.0, 3.0, 1.0, 0.3, -3f64.to_radians()),
    ];
    let m = evaluate_relations(&rels, &trajectory, &RelationParams::default());
    let t = m.translation_m.unwrap();
    assert!(close(t.mean, 0.2) && close(t.std, 0.1) && close(t.median, 0.2) && close(t.max, 0.3));
    let t2 = m.translation_2_m2.unwrap();
    assert!(close(t2.mean, 0.05) && close(t2.std, 0.04));
    let r = m.rotation_deg.unwrap();
    assert!(close(r.mean, 2.0) && close(r.std, 1.0));
    let r2 = m.rotation_2_deg2.unwrap();
    assert!(close(r2.mean, 5.0) && close(r2.std, 4.0));
}

#[test]
fn table_and_json_carry_the_numbers() {
    let trajectory = [(1.0, Pose2::IDENTITY), (2.0, Pose2::new(1.0, 0.0, 0.0))];
    let m = evaluate_relations(
        &[rel(1.0, 2.0, 1.25, 0.0, 0.0)],
        &trajectory,
        &RelationParams::default(),
    );
    let table = m.to_table();
    assert!(table.contains("0.2500"), "{table}");
    let lines: Vec<&str> = table.lines().collect();
    let widths: Vec<usize> = lines[..6].iter().map(|l| l.chars().count()).collect();
    assert!(widths.iter().all(|&w| w == widths[0]), "aligned: {table}");
    let json: serde_json::Value = serde_json::from_str(&m.to_json()).unwrap();
    assert_eq!(json["matched"], 1);
    assert_eq!(json["translation_m"]["mean"], 0.25);
}

#[test]
fn errors_are_split_by_how_far_apart_the_poses_are() {
    // The estimate stands still; the truth says the robot moved 0.1 m after 5 s, 0.3 m after
    // 50 s (and again from 10 s to 60 s: exactly 50 s apart) and 1 m after 500 s.
    let trajectory: Vec<(f64, Pose2)> = [0.0, 5.0, 10.0, 50.0, 60.0, 500.0]
        .iter()
        .map(|&t| (t, Pose2::IDENTITY))
        .collect();
    let rels = [
        rel(0.0, 5.0, 0.1, 0.0, 0.0),
        rel(0.0, 10.0, 0.2, 0.0, 0.0),
        rel(0.0, 50.0, 0.3, 0.0, 0.0),
        rel(10.0, 60.0, 0.3, 0.0, 0.0),
        rel(0.0, 500.0, 1.0, 0.0, 0.0),
    ];
    let m = evaluate_relations(&rels, &trajectory, &RelationParams::default());
    let classes = &m.by_time_apart;
    assert_eq!(classes.len(), 3);
    let counts: Vec<usize> = classes
        .iter()
        .map(|c| c.translation_m.map_or(0, |s| s.count))
        .collect();
    assert_eq!(counts, vec![2, 2, 1], "10 s belongs to the first class");
    assert!(close(classes[0].translation_m.unwrap().mean, 0.15));
    assert!(close(classes[1].translation_m.unwrap().mean, 0.3));
    assert!(close(classes[2].share_of_translation, 1.0 / 1.9));
    let shares: f64 = classes.iter().map(|c| c.share_of_translation).sum();
    assert!(close(shares, 1.0));
    let labels: Vec<String> = classes.iter().map(TimeApartClass::label).collect();
    assert_eq!(labels, vec!["≤ 10 s", "10–100 s", "> 100 s"]);
    assert!(m.to_table().contains("| > 100 s"));
}
