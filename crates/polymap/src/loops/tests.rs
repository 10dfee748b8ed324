//! Tests of loop closure on scans ray-cast in small worlds, with drift added to the poses.

use super::closer::merge_corrections;
use super::*;
use crate::align::AlignParams;
use crate::config::Config;
use crate::geometry::{Pose2, Segment, Vec2};
use crate::mapper::Mapper;
use crate::testutil::scan_from;

fn seg(ax: f64, ay: f64, bx: f64, by: f64) -> Segment {
    Segment::new(Vec2::new(ax, ay), Vec2::new(bx, by))
}

/// A ring corridor around a 14 × 6 m block inside a 20 × 12 m room, with notches so that no
/// two places look alike.
fn ring() -> Vec<Segment> {
    vec![
        // Outer walls with a notch on the south side and one on the east.
        seg(0.0, 0.0, 8.0, 0.0),
        seg(8.0, 0.0, 8.0, -1.0),
        seg(8.0, -1.0, 9.5, -1.0),
        seg(9.5, -1.0, 9.5, 0.0),
        seg(9.5, 0.0, 20.0, 0.0),
        seg(20.0, 0.0, 20.0, 7.0),
        seg(20.0, 7.0, 21.0, 7.0),
        seg(21.0, 7.0, 21.0, 8.0),
        seg(21.0, 8.0, 20.0, 8.0),
        seg(20.0, 8.0, 20.0, 12.0),
        seg(20.0, 12.0, 0.0, 12.0),
        seg(0.0, 12.0, 0.0, 0.0),
        // The block, with a box on its north side.
        seg(3.0, 3.0, 17.0, 3.0),
        seg(17.0, 3.0, 17.0, 9.0),
        seg(17.0, 9.0, 12.0, 9.0),
        seg(12.0, 9.0, 12.0, 9.8),
        seg(12.0, 9.8, 11.0, 9.8),
        seg(11.0, 9.8, 11.0, 9.0),
        seg(11.0, 9.0, 3.0, 9.0),
        seg(3.0, 9.0, 3.0, 3.0),
    ]
}

/// True poses around the ring's corridor, counter-clockwise, about 0.15 m per scan, turning
/// in place at the corners; `sides` sides of the corridor (4: once round).
fn lap(sides: usize) -> Vec<Pose2> {
    let corners = [
        Vec2::new(1.5, 1.5),
        Vec2::new(18.5, 1.5),
        Vec2::new(18.5, 10.5),
        Vec2::new(1.5, 10.5),
    ];
    let mut poses = Vec::new();
    for i in 0..=sides {
        let a = corners[i % 4];
        let b = corners[(i + 1) % 4];
        let heading = (b - a).y.atan2((b - a).x);
        if let Some(last) = poses.last().copied() {
            let last: Pose2 = last;
            let turn = normalize(heading - last.theta_rad);
            for s in 1..=6 {
                poses.push(Pose2::new(a.x, a.y, last.theta_rad + turn * s as f64 / 6.0));
            }
        }
        if i == sides {
            break;
        }
        let steps = ((b - a).length() / 0.15).ceil() as usize;
        for s in 0..steps {
            let p = a + (b - a) * (s as f64 / steps as f64);
            poses.push(Pose2::new(p.x, p.y, heading));
        }
    }
    poses
}

fn normalize(a: f64) -> f64 {
    crate::geometry::normalize_angle_rad(a)
}

/// The mapper's poses with drift: heading error growing 0.01° per scan (and the position
/// error it causes), as dead reckoning would have.
fn drifted(truth: &[Pose2]) -> Vec<Pose2> {
    let mut out = vec![truth[0]];
    let bias = Pose2::new(0.0, 0.0, 0.01f64.to_radians());
    for w in truth.windows(2) {
        let step = w[0].between(&w[1]);
        let last = *out.last().unwrap();
        out.push(last.compose(&step).compose(&bias));
    }
    out
}

fn params() -> LoopParams {
    LoopParams {
        node_scans: 10,
        node_keep_every: 2,
        ..LoopParams::default()
    }
}

/// Hands scan `t`, ray-cast at its true pose, to `closer` at `poses[t]` (with drift).
fn feed(
    closer: &mut LoopCloser,
    walls: &[Segment],
    truth: &[Pose2],
    poses: &[Pose2],
    t: usize,
    d: &mut LoopDiagnostics,
    doubt: MotionDoubt,
) -> Option<Correction> {
    let prepared = Mapper::prepare(
        &Config::default(),
        &scan_from(walls, &truth[t], t as f64 * 0.1),
    );
    closer.add_scan(
        t as u32,
        poses[t],
        (&prepared.points_in_robot, &prepared.segments_in_robot),
        doubt,
        d,
    )
}

/// Feeds the drifted poses to a loop closer, applying its corrections to them (as the mapper
/// does); returns the corrected poses and the closer.
fn run(truth: &[Pose2], walls: &[Segment], params: LoopParams) -> (Vec<Pose2>, LoopCloser) {
    let closer = LoopCloser::new(params.clone(), Config::default().align, 0.5);
    run_from(closer, truth, walls, drifted(truth))
}

/// [`run`] with a given closer and the poses the mapper tracked.
fn run_from(
    closer: LoopCloser,
    truth: &[Pose2],
    walls: &[Segment],
    poses: Vec<Pose2>,
) -> (Vec<Pose2>, LoopCloser) {
    run_doubted(closer, truth, walls, poses, |_| MotionDoubt::None)
}

/// [`run_from`] with the doubt on each scan's motion.
fn run_doubted(
    mut closer: LoopCloser,
    truth: &[Pose2],
    walls: &[Segment],
    mut poses: Vec<Pose2>,
    doubt: impl Fn(usize) -> MotionDoubt,
) -> (Vec<Pose2>, LoopCloser) {
    let mut diagnostics = LoopDiagnostics::default();
    let apply = |closer: &LoopCloser, poses: &mut [Pose2], c: &Correction, upto: usize| {
        for (t, p) in poses.iter_mut().enumerate().take(upto) {
            let n = closer.node_of(t as u32);
            if let Some(d) = n
                .checked_sub(c.first_node)
                .and_then(|i| c.new_from_old.get(i))
            {
                *p = d.compose(p);
            }
        }
    };
    for t in 0..truth.len() {
        if let Some(c) = feed(
            &mut closer,
            walls,
            truth,
            &poses,
            t,
            &mut diagnostics,
            doubt(t),
        ) {
            // Poses not yet handed over move with the newest node.
            let newest = *c.new_from_old.last().unwrap();
            apply(&closer, &mut poses, &c, t + 1);
            for p in &mut poses[t + 1..] {
                *p = newest.compose(p);
            }
        }
    }
    if let Some(c) = closer.finish(&mut diagnostics) {
        let n = poses.len();
        apply(&closer, &mut poses, &c, n);
    }
    (poses, closer)
}

/// Largest error of the poses relative to the first, metres.
fn worst(truth: &[Pose2], poses: &[Pose2]) -> f64 {
    truth
        .iter()
        .zip(poses)
        .map(|(t, p)| {
            truth[0]
                .between(t)
                .between(&poses[0].between(p))
                .translation()
                .length()
        })
        .fold(0.0, f64::max)
}

#[test]
fn returning_to_mapped_ground_removes_most_of_the_drift() {
    let truth = lap(5);
    let walls = ring();
    let before = worst(&truth, &drifted(&truth));
    let (after_poses, closer) = run(&truth, &walls, params());
    let after = worst(&truth, &after_poses);
    assert!(before > 0.5, "the drift is meant to be large: {before}");
    assert!(closer.loop_edges() > 0);
    // The end of the lap is where the drift was largest; the loop edge ties it to the start.
    let end_before = truth[0]
        .between(truth.last().unwrap())
        .between(&drifted(&truth)[0].between(drifted(&truth).last().unwrap()));
    assert!(end_before.translation().length() > 0.5);
    assert!(
        after < 0.5 * before,
        "worst error {before:.3} m before, {after:.3} m after"
    );
}

#[test]
fn a_run_on_a_saved_map_placed_a_little_off_is_pulled_onto_it_by_its_loops() {
    // A lap mapped without drift is saved; a second lap of the same ring, placed 0.2 m and 1°
    // off but tracked without drift from there, closes loops with the saved nodes. Its first
    // node, tied to the saved map by its placement only, moves onto it with the rest.
    let truth = lap(4);
    let mapping = LoopCloser::new(params(), Config::default().align, 0.5);
    let (_, first) = run_from(mapping, &truth, &ring(), truth.clone());
    let saved = first.saved_nodes();
    let off = Pose2::new(0.0, 0.2, 1f64.to_radians());
    let placed: Vec<Pose2> = truth.iter().map(|p| off.compose(p)).collect();
    let closer = LoopCloser::continuing(params(), Config::default().align, 0.5, saved.clone());
    let (poses, second) = run_from(closer, &truth, &ring(), placed);
    let node = second.saved_nodes()[saved.len()].pose;
    let d = truth[0].between(&node);
    assert!(
        d.translation().length() < 0.05 && d.theta_rad.abs() < 0.3f64.to_radians(),
        "the run's first node stays {d:?} off"
    );
    let far = truth
        .iter()
        .zip(&poses)
        .map(|(t, p)| t.between(p).translation().length())
        .fold(0.0, f64::max);
    assert!(far < 0.1, "a pose stays {far} m off");
}

#[test]
fn with_confirmation_the_loop_still_closes() {
    let truth = lap(5);
    let before = worst(&truth, &drifted(&truth));
    let (poses, closer) = run(
        &truth,
        &ring(),
        LoopParams {
            confirm_within_nodes: 10,
            ..params()
        },
    );
    assert!(closer.loop_edges() >= 2);
    let after = worst(&truth, &poses);
    assert!(
        after < 0.5 * before,
        "worst error {before:.3} m before, {after:.3} m after"
    );
}

#[test]
fn results_do_not_depend_on_the_thread() {
    let truth = lap(5);
    let walls = ring();
    let (a, ca) = run(&truth, &walls, params());
    let (b, cb) = run(
        &truth,
        &walls,
        LoopParams {
            background: false,
            ..params()
        },
    );
    assert_eq!(a, b);
    assert_eq!(ca.loop_edges(), cb.loop_edges());
    assert!(ca.loop_edges() > 0);
}

#[test]
fn disabled_changes_nothing() {
    let truth = lap(5);
    let (poses, closer) = run(
        &truth,
        &ring(),
        LoopParams {
            enabled: false,
            ..params()
        },
    );
    assert_eq!(poses, drifted(&truth));
    assert_eq!(closer.loop_edges(), 0);
}

#[test]
fn a_featureless_corridor_gives_no_loop_edge() {
    // Walls 200 m long: along the corridor nothing tells one place from another.
    let walls = vec![seg(-100.0, -1.5, 100.0, -1.5), seg(-100.0, 1.5, 100.0, 1.5)];
    let mut truth: Vec<Pose2> = (0..200)
        .map(|i| Pose2::new(0.1 * i as f64, 0.0, 0.0))
        .collect();
    let back: Vec<Pose2> = (0..200)
        .map(|i| Pose2::new(20.0 - 0.1 * i as f64, 0.0, std::f64::consts::PI))
        .collect();
    truth.extend(back);
    let (_, closer) = run(&truth, &walls, params());
    assert_eq!(closer.loop_edges(), 0);
}

#[test]
fn a_clone_carries_on_like_the_original() {
    let truth = lap(5);
    let walls = ring();
    let mut a = LoopCloser::new(params(), Config::default().align, 0.5);
    let poses = drifted(&truth);
    let mut d = LoopDiagnostics::default();
    let half = truth.len() / 2;
    for t in 0..half {
        feed(&mut a, &walls, &truth, &poses, t, &mut d, MotionDoubt::None);
    }
    let mut b = a.clone();
    for t in half..truth.len() {
        assert_eq!(
            feed(&mut a, &walls, &truth, &poses, t, &mut d, MotionDoubt::None),
            feed(&mut b, &walls, &truth, &poses, t, &mut d, MotionDoubt::None)
        );
    }
    assert_eq!(a.finish(&mut d), b.finish(&mut d));
}

#[test]
fn corrections_in_a_row_compose() {
    let a = Correction {
        first_node: 2,
        new_from_old: vec![Pose2::new(1.0, 0.0, 0.0), Pose2::new(1.0, 0.0, 0.1)],
    };
    let b = Correction {
        first_node: 3,
        new_from_old: vec![Pose2::new(0.0, 2.0, 0.0), Pose2::new(0.0, 2.0, 0.2)],
    };
    let c = merge_corrections(Some(a.clone()), Some(b.clone())).unwrap();
    assert_eq!(c.first_node, 2);
    assert_eq!(c.new_from_old.len(), 3);
    assert_eq!(c.new_from_old[0], a.new_from_old[0]);
    assert_eq!(
        c.new_from_old[1],
        b.new_from_old[0].compose(&a.new_from_old[1])
    );
    assert_eq!(c.new_from_old[2], b.new_from_old[1]);
    assert_eq!(merge_corrections(None, Some(b.clone())), Some(b));
}

#[test]
fn every_key_is_checked() {
    let ok = LoopParams::default();
    assert_eq!(ok.validate(), Ok(()));
    let bad = [
        LoopParams {
            node_scans: 0,
            ..ok.clone()
        },
        LoopParams {
            node_keep_every: 0,
            ..ok.clone()
        },
        LoopParams {
            search_step_m: 0.0,
            ..ok.clone()
        },
        LoopParams {
            loop_sigma_m: f64::NAN,
            ..ok.clone()
        },
        LoopParams {
            min_inlier_share: 1.5,
            ..ok.clone()
        },
    ];
    for b in bad {
        assert!(b.validate().is_err(), "{b:?}");
    }
}

/// A panic on the loop thread stops loop closure and is reported with the node it failed on,
/// not turned into an empty outcome without a trace.
#[test]
fn a_failure_of_the_graph_stops_loop_closure_and_is_reported() {
    let params = LoopParams {
        background: false,
        ..LoopParams::default()
    };
    let mut closer = LoopCloser::new(params, AlignParams::default(), 0.5);
    closer.inject_failure(0, "boom");
    let mut diagnostics = LoopDiagnostics::default();
    assert_eq!(closer.finish(&mut diagnostics), None);
    let failure = closer.failure().expect("the failure is kept");
    assert_eq!((failure.node, failure.message.as_str()), (0, "boom"));
    assert!(failure.to_string().contains("enabled = false"), "{failure}");
    // Nothing more is handed to the graph.
    let points = [Vec2::new(1.0, 0.0)];
    for t in 0..100 {
        let c = closer.add_scan(
            t,
            Pose2::IDENTITY,
            (&points, &[]),
            MotionDoubt::None,
            &mut diagnostics,
        );
        assert_eq!(c, None);
    }
    assert_eq!(closer.loop_edges(), 0);
}

/// Sparse scans (a log at one scan per half metre, `--every 10`) make nodes of about the same
/// ground as dense ones: a node ends after `node_travel_m` of travel, before `node_scans`.
#[test]
fn nodes_end_after_their_travel_or_their_scans() {
    let params = LoopParams {
        background: false,
        node_scans: 20,
        node_travel_m: 2.0,
        node_keep_every: 5,
        node_keep_travel_m: 0.0,
        ..LoopParams::default()
    };
    let mut closer = LoopCloser::new(params, AlignParams::default(), 0.5);
    let mut diagnostics = LoopDiagnostics::default();
    let points = [Vec2::new(1.0, 0.0)];
    // 0.5 m per scan for 20 scans, then standing still for 30.
    let pose = |t: u32| Pose2::new(0.5 * t.min(20) as f64, 0.0, 0.0);
    for t in 0..50 {
        closer.add_scan(
            t,
            pose(t),
            (&points, &[]),
            MotionDoubt::None,
            &mut diagnostics,
        );
    }
    // Travel 2 m is reached at the 5th scan of a node (4 steps of 0.5 m).
    assert_eq!(
        (0..4).map(|n| closer.node_start(n)).collect::<Vec<_>>(),
        [0, 5, 10, 15]
    );
    assert_eq!(
        (closer.node_of(4), closer.node_of(5), closer.node_of(19)),
        (0, 1, 3)
    );
    // From scan 20 the robot stands: nodes end by their scan count again.
    assert_eq!(closer.node_start(4), 20);
    assert_eq!(closer.node_start(5), 40);
    assert_eq!(closer.node_of(39), 4);
    assert_eq!(closer.node_start(9), u32::MAX);
}

#[test]
fn the_grid_search_grows_with_the_travel_between_the_nodes() {
    let p = LoopParams::default();
    let half = |travel_m| nodes::search_half_m(&p, travel_m);
    assert_eq!(half(0.0), p.search_translation_m);
    assert_eq!(half(50.0), p.search_translation_m);
    assert!((half(150.0) - 0.03 * 150.0).abs() < 1e-9);
    assert_eq!(half(1000.0), p.search_radius_m);
    let fixed = LoopParams {
        search_translation_per_travel: 0.0,
        ..LoopParams::default()
    };
    assert_eq!(
        nodes::search_half_m(&fixed, 1000.0),
        fixed.search_translation_m
    );
    // However far the radius, the grid stays within the starts a search may score.
    let far = LoopParams {
        search_radius_m: 1e4,
        search_translation_per_travel: 1.0,
        ..LoopParams::default()
    };
    let half_m = nodes::search_half_m(&far, 1e4);
    let steps_t = (half_m / far.search_step_m).floor();
    let steps_r = (far.search_rotation_deg / far.search_rotation_step_deg).floor();
    let starts = (2.0 * steps_t + 1.0).powi(2) * (2.0 * steps_r + 1.0);
    assert!(
        starts <= params::MAX_SEARCH_STARTS,
        "{starts} starts at {half_m} m"
    );
    assert!(half_m > 10.0);
}

#[test]
fn a_return_drifted_past_the_fixed_grid_closes_with_the_grid_grown_by_the_travel() {
    // Once round the ring and along its first side again; down the last side of the first lap
    // (the west corridor) the poses slide 3.5 m north, along the corridor's axis, which those
    // scans could not observe: the return, after about 50 m of travel, lies 3.5 m from where
    // the graph predicts it, outside ±2.4 m and inside 7 % of the travel.
    let truth = lap(5);
    let walls = ring();
    let west = truth
        .iter()
        .position(|p| (p.theta_rad + std::f64::consts::FRAC_PI_2).abs() < 1e-9)
        .expect("the lap goes south down the west corridor");
    let slid = |t: usize| (west..west + 55).contains(&t);
    let poses: Vec<Pose2> = truth
        .iter()
        .enumerate()
        .map(|(t, p)| {
            let slide = 3.5 * ((t as f64 - west as f64) / 55.0).clamp(0.0, 1.0);
            Pose2::new(p.x_m, p.y_m + slide, p.theta_rad)
        })
        .collect();
    let doubt = |t| match slid(t) {
        true => MotionDoubt::Along(Vec2::Y),
        false => MotionDoubt::None,
    };
    let closer = |per_travel| {
        let params = LoopParams {
            search_translation_per_travel: per_travel,
            ..params()
        };
        LoopCloser::new(params, Config::default().align, 0.5)
    };
    let (fixed, _) = run_doubted(closer(0.0), &truth, &walls, poses.clone(), doubt);
    let (grown, _) = run_doubted(closer(0.07), &truth, &walls, poses.clone(), doubt);
    // The error of the last pose (back on the first lap's ground) relative to the first.
    let end = |poses: &[Pose2]| {
        let last = truth.len() - 1;
        truth[0]
            .between(&truth[last])
            .between(&poses[0].between(&poses[last]))
            .translation()
            .length()
    };
    let (before, fixed, grown) = (end(&poses), end(&fixed), end(&grown));
    let figures = format!("{before:.2} m as tracked, {fixed:.2} m fixed, {grown:.2} m grown");
    assert!(fixed > 0.8 * before, "the last pose off by {figures}");
    assert!(grown < 0.3 * before, "the last pose off by {figures}");
}

#[test]
fn a_run_on_a_saved_map_grows_its_grid_with_its_own_travel_only() {
    // A saved map of 10 nodes round a 270 m loop that ends where it began, then this run's
    // 17 nodes within a metre of the map's first node: the run's own travel is short, and
    // the saved map's path says nothing of how far its prediction drifted.
    let mut graph = nodes::NodeGraph::new(LoopParams::default(), Config::default().align, 0.5);
    let saved = [
        (0.0, 0.0),
        (30.0, 0.0),
        (60.0, 0.0),
        (90.0, 0.0),
        (90.0, 30.0),
        (90.0, 60.0),
        (60.0, 60.0),
        (30.0, 60.0),
        (0.0, 60.0),
        (0.0, 30.0),
    ];
    let run = (0..17).map(|i| (0.5 + 0.03 * i as f64, 0.2));
    for (x, y) in saved.into_iter().chain(run) {
        graph.poses.push(Pose2::new(x, y, 0.0));
        graph.submaps.push(nodes::Submap {
            points: (0..40).map(|i| Vec2::new(0.1 * i as f64, 1.0)).collect(),
            segments: vec![seg(0.0, 1.0, 4.0, 1.0)],
        });
    }
    graph.first_run_node = saved.len();
    let k = graph.poses.len() - 1;
    let candidates = graph.candidates(k);
    assert!(
        candidates.iter().any(|c| c.j == 0),
        "the map's first node is a candidate"
    );
    let fixed = LoopParams::default().search_translation_m;
    for c in &candidates {
        assert_eq!(c.search_half_m, fixed, "candidate {}", c.j);
    }
}

#[test]
fn a_grown_grid_match_goes_in_only_once_another_nodes_match_agrees() {
    // Nodes 0..=20 along a line 1 m apart; nodes 19 and 20 matched node 0 and 1 as if they
    // stood 3 m further on (the grown grid's kind of find).
    let mut graph = nodes::NodeGraph::new(LoopParams::default(), Config::default().align, 0.5);
    graph.poses = (0..=20).map(|i| Pose2::new(i as f64, 0.0, 0.0)).collect();
    let edge = |from: usize, to: usize| graph::Edge {
        from,
        to,
        measured: Pose2::new(to as f64 - from as f64 + 3.0, 0.0, 0.0),
        sigma_m: 0.05,
        sigma_rad: 0.01,
        doubt_m2: glam::DMat2::ZERO,
        robust: true,
    };
    // Alone, and with the same node's match of another candidate: held.
    assert!(graph.confirm(19, vec![(edge(0, 19), true)]).is_empty());
    assert!(graph.confirm(19, vec![(edge(1, 19), true)]).is_empty());
    assert_eq!(graph.held.len(), 2);
    // The next node's match agrees: all three go in.
    assert_eq!(graph.confirm(20, vec![(edge(0, 20), true)]).len(), 3);
    assert!(graph.held.is_empty());
    // A lone one waits at most `FAR_CONFIRM_WITHIN_NODES` nodes.
    assert!(graph.confirm(20, vec![(edge(2, 20), true)]).is_empty());
    assert!(graph.confirm(24, Vec::new()).is_empty());
    assert!(graph.held.is_empty());
}

#[test]
fn a_run_continuing_a_saved_map_counts_its_travel_from_its_own_first_node() {
    let saved: Vec<SavedNode> = (0..4)
        .map(|i| SavedNode {
            pose: Pose2::new(10.0 * i as f64, 0.0, 0.0),
            segments: vec![seg(0.0, 1.0, 4.0, 1.0)],
        })
        .collect();
    let closer = LoopCloser::continuing(params(), Config::default().align, 0.5, saved);
    assert_eq!(closer.worker.read(|g| g.first_run_node), 4);
}
