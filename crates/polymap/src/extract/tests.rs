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

/// A square room of half-width `h` seen from its centre, one point per degree from `start_deg`.
fn room_scan(h: f64, start_deg: f64) -> Vec<Vec2> {
    (0..360)
        .map(|i| {
            let a = (start_deg + i as f64).to_radians();
            let r = h / a.cos().abs().max(a.sin().abs());
            Vec2::new(r * a.cos(), r * a.sin())
        })
        .collect()
}

#[test]
fn a_closed_scan_is_not_cut_at_its_seam() {
    let pts = room_scan(2.0, 0.0); // the seam lies in the middle of the wall at x = 2
    let open = extract_segments(&pts, 1f64.to_radians(), &ExtractParams::default());
    let closed = extract_segments_closed(&pts, 1f64.to_radians(), &ExtractParams::default());
    assert_eq!(
        open.len(),
        5,
        "read as an open curve the seam splits a wall"
    );
    assert_eq!(closed.len(), 4);
    assert!(
        closed
            .iter()
            .all(|s| (s.segment.length() - 4.0).abs() < 0.2)
    );
    let support: usize = closed.iter().map(|s| s.point_count).sum();
    assert!(support >= 356, "{support}");
}

#[test]
fn a_closed_scan_with_a_gap_elsewhere_joins_the_runs_at_its_seam() {
    // A pillar in front of the wall at y = 2 makes two range jumps; the seam is on x = 2.
    let mut pts = room_scan(2.0, 0.0);
    for p in &mut pts[80..100] {
        *p *= 0.5;
    }
    let closed = extract_segments_closed(&pts, 1f64.to_radians(), &ExtractParams::default());
    let seam_wall: Vec<_> = closed
        .iter()
        .filter(|s| (s.segment.start.x - 2.0).abs() < 0.05 && (s.segment.end.x - 2.0).abs() < 0.05)
        .collect();
    assert_eq!(seam_wall.len(), 1, "{closed:?}");
    assert!((seam_wall[0].segment.length() - 4.0).abs() < 0.2);
    assert!(
        seam_wall[0].first_point + seam_wall[0].point_count > pts.len(),
        "wraps"
    );
}

#[test]
fn a_real_gap_at_the_seam_is_not_joined() {
    // The scan starts just past a doorway: the last point (on the wall at x = 2, y < 0) and the
    // first (on a wall 1 m further out) are 1 m apart.
    let mut pts = room_scan(2.0, 0.0);
    for p in &mut pts[..40] {
        *p *= 1.5;
    }
    let open = extract_segments(&pts, 1f64.to_radians(), &ExtractParams::default());
    let closed = extract_segments_closed(&pts, 1f64.to_radians(), &ExtractParams::default());
    assert_eq!(closed, open);
}
