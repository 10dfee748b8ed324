use super::*;
use crate::geometry::Segment;

fn wall(from: Vec2, to: Vec2, n: usize) -> Vec<Vec2> {
    (0..n)
        .map(|i| from + (to - from) * (i as f64 / (n - 1) as f64))
        .collect()
}

/// Deterministic pseudo-noise in [-a, a].
fn wiggle(i: usize, a: f64) -> f64 {
    let x = ((i as f64 * 12.9898).sin() * 43758.5453).fract();
    (2.0 * x.abs() - 1.0) * a
}

#[test]
fn straight_noisy_wall_is_one_segment() {
    let pts: Vec<Vec2> = wall(Vec2::new(3.0, -2.0), Vec2::new(3.0, 2.0), 80)
        .into_iter()
        .enumerate()
        .map(|(i, p)| p + Vec2::new(wiggle(i, 0.015), 0.0))
        .collect();
    let segs = extract_segments(&pts, 0.0175, &ExtractParams::default());
    assert_eq!(segs.len(), 1);
    let s = segs[0].segment;
    assert!((s.start.x - 3.0).abs() < 0.01 && (s.end.x - 3.0).abs() < 0.01);
    assert_eq!(segs[0].point_count, 80);
}

#[test]
fn range_jump_splits_runs() {
    let mut pts = wall(Vec2::new(2.0, -1.0), Vec2::new(2.0, 0.0), 20);
    pts.extend(wall(Vec2::new(5.0, 0.1), Vec2::new(5.0, 2.0), 20));
    let segs = extract_segments(&pts, 0.0175, &ExtractParams::default());
    assert_eq!(segs.len(), 2);
    assert!(segs.iter().all(|s| s.point_count == 20));
}

#[test]
fn short_and_sparse_pieces_are_dropped() {
    let params = ExtractParams::default();
    let pts = wall(Vec2::new(2.0, 0.0), Vec2::new(2.0, 0.1), 10);
    assert!(
        extract_segments(&pts, 0.0175, &params).is_empty(),
        "too short"
    );
    let pts = wall(Vec2::new(2.0, 0.0), Vec2::new(2.0, 0.28), 3);
    assert!(
        extract_segments(&pts, 0.0175, &params).is_empty(),
        "too few points"
    );
}

#[test]
fn every_point_is_within_tolerance_of_the_simplified_curve() {
    // A zig-zag of amplitude 0.2 m must keep its corners.
    let pts: Vec<Vec2> = (0..60)
        .map(|i| Vec2::new(i as f64 * 0.1, if (i / 10) % 2 == 0 { 0.0 } else { 0.2 }))
        .collect();
    let mut v = Vec::new();
    simplify_run(&pts, 0.05, &mut v);
    for w in v.windows(2) {
        let edge = Segment::new(pts[w[0]], pts[w[1]]);
        for p in &pts[w[0]..=w[1]] {
            assert!(edge.distance_to_point(*p) <= 0.05 + 1e-12);
        }
    }
    assert!(v.len() >= 12, "corners kept: {v:?}");
}

#[test]
fn tls_refit_is_not_biased_by_endpoint_noise() {
    // Points on y = 1 with the first and last points displaced: the refit line stays on y = 1.
    let mut pts = wall(Vec2::new(-1.0, 1.0), Vec2::new(1.0, 1.0), 41);
    pts[0].y += 0.03;
    pts[40].y -= 0.03;
    let segs = extract_segments(&pts, 0.0175, &ExtractParams::default());
    assert_eq!(segs.len(), 1);
    assert!((segs[0].segment.midpoint().y - 1.0).abs() < 0.002);
}

#[test]
fn degenerate_inputs_do_not_panic() {
    let p = ExtractParams::default();
    assert!(extract_segments(&[], 0.01, &p).is_empty());
    assert!(extract_segments(&[Vec2::ONE], 0.01, &p).is_empty());
    assert!(extract_segments(&[Vec2::ONE; 20], 0.01, &p).is_empty());
}

mod prop {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn dce_keeps_endpoints_and_tolerance(ys in proptest::collection::vec(-0.5f64..0.5, 3..80), tol in 0.01f64..0.2) {
            let pts: Vec<Vec2> = ys.iter().enumerate().map(|(i, y)| Vec2::new(i as f64 * 0.05, *y)).collect();
            let mut v = Vec::new();
            simplify_run(&pts, tol, &mut v);
            prop_assert_eq!(v[0], 0);
            prop_assert_eq!(*v.last().unwrap(), pts.len() - 1);
            for w in v.windows(2) {
                prop_assert!(w[0] < w[1]);
                let edge = Segment::new(pts[w[0]], pts[w[1]]);
                for p in &pts[w[0]..=w[1]] {
                    prop_assert!(edge.distance_to_point(*p) <= tol + 1e-9);
                }
            }
        }
    }
}
