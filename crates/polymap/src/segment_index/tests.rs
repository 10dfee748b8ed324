use super::*;
use proptest::prelude::*;

fn brute(segs: &[Segment], p: Vec2, max_d: f64) -> Option<usize> {
    segs.iter()
        .enumerate()
        .map(|(i, s)| (s.distance_2_to_point(p), i))
        .filter(|(d, _)| *d <= max_d * max_d)
        .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
        .map(|(_, i)| i)
}

proptest! {
    #[test]
    fn grid_nearest_agrees_with_brute_force_through_removals(
        raw in proptest::collection::vec((-8.0f64..8.0, -8.0f64..8.0, -8.0f64..8.0, -8.0f64..8.0), 1..30),
        removed in proptest::collection::vec(any::<bool>(), 30),
        qx in -9.0f64..9.0, qy in -9.0f64..9.0, d in 0.0f64..3.0,
    ) {
        let segs: Vec<Segment> = raw.iter().map(|&(a, b, c, e)| Segment::new(Vec2::new(a, b), Vec2::new(c, e))).collect();
        let mut grid = SegmentIndex::new(0.5, 1.0);
        for (i, s) in segs.iter().enumerate() { grid.insert(i, *s); }
        let mut kept = Vec::new();
        for (i, s) in segs.iter().enumerate() {
            if removed[i] { grid.remove(i, s); } else { kept.push((i, *s)); }
        }
        // Some removed segments come back, into cells a removal emptied.
        for (i, s) in segs.iter().enumerate().filter(|(i, _)| removed[*i] && i % 3 == 0) {
            grid.insert(i, *s);
            kept.push((i, *s));
        }
        kept.sort_by_key(|k| k.0);
        // Emptied cells are counted, and never outnumber the occupied ones.
        let empty = grid.cells.values().filter(|l| l.is_empty()).count();
        prop_assert_eq!(grid.empty_cells, empty);
        prop_assert!(2 * empty <= grid.cells.len());
        prop_assert_eq!(grid.is_empty(), kept.is_empty());
        let q = Vec2::new(qx, qy);
        let kept_segs: Vec<Segment> = kept.iter().map(|(_, s)| *s).collect();
        let expect = brute(&kept_segs, q, d).map(|j| kept[j].0);
        prop_assert_eq!(grid.nearest(q, d).map(|(k, _, _)| k), expect);
        let probe = Segment::new(q, q + Vec2::new(1.0, 0.5));
        let near: Vec<usize> = kept.iter().filter(|(_, s)| s.distance_to_segment(&probe) <= d).map(|(i, _)| *i).collect();
        prop_assert_eq!(grid.near_segment(&probe, d), near);
    }
}

fn boxes_meet(s: &Segment, lo: Vec2, hi: Vec2) -> bool {
    let (a, b) = s.bounds();
    a.x <= hi.x && lo.x <= b.x && a.y <= hi.y && lo.y <= b.y
}

/// Whether the segment crosses the box `[lo, hi]` (some point of it inside), by sampling
/// finely: a test of the box query's promise, which is about crossing, not about boxes.
fn crosses(s: &Segment, lo: Vec2, hi: Vec2) -> bool {
    (0..=1000).any(|i| {
        let p = s.start + s.vector() * (i as f64 / 1000.0);
        lo.x <= p.x && p.x <= hi.x && lo.y <= p.y && p.y <= hi.y
    })
}

fn segments() -> impl Strategy<Value = Vec<Segment>> {
    proptest::collection::vec(
        (-20.0f64..20.0, -20.0f64..20.0, -4.0f64..4.0, -4.0f64..4.0)
            .prop_map(|(x, y, dx, dy)| Segment::new(Vec2::new(x, y), Vec2::new(x + dx, y + dy))),
        0..40,
    )
}

proptest! {
    /// The nearest segment at any distance, and whether any lies within a distance, are
    /// exactly what trying every segment gives (ties to the smaller index), with the grid's
    /// reach at 1 m and at 0.
    #[test]
    fn nearest_anywhere_and_any_within_agree_with_brute_force(
        segs in segments(),
        points in proptest::collection::vec((-40.0f64..40.0, -40.0f64..40.0, 0.0f64..5.0), 1..20),
        reach in prop_oneof![Just(0.0), Just(1.0)],
    ) {
        let index = SegmentIndex::from_segments(&segs, 0.5, reach);
        prop_assert_eq!(index.is_empty(), segs.is_empty());
        for &(x, y, d) in &points {
            let q = Vec2::new(x, y);
            prop_assert_eq!(index.nearest_anywhere(q).map(|n| n.0), brute(&segs, q, f64::INFINITY));
            prop_assert_eq!(index.nearest(q, d).map(|n| n.0), brute(&segs, q, d));
            prop_assert_eq!(index.any_within(q, d), brute(&segs, q, d).is_some());
        }
    }

    /// A box query holds every segment that crosses the box.
    #[test]
    fn in_box_holds_every_segment_crossing_the_box(
        segs in segments(),
        (x, y, w, h) in (-25.0f64..25.0, -25.0f64..25.0, 0.0f64..6.0, 0.0f64..6.0),
        reach in prop_oneof![Just(0.0), Just(1.0)],
    ) {
        let index = SegmentIndex::from_segments(&segs, 0.5, reach);
        let (lo, hi) = (Vec2::new(x, y), Vec2::new(x + w, y + h));
        let found = index.in_box(lo, hi);
        for (i, s) in segs.iter().enumerate() {
            if crosses(s, lo, hi) {
                prop_assert!(found.contains(&i), "segment {} crosses the box", i);
            }
        }
    }

    /// The R-tree's box query is exactly the segments whose bounding box meets the box,
    /// also after removals and insertions.
    #[test]
    fn box_index_agrees_with_brute_force(
        segs in segments(),
        removed in proptest::collection::vec(any::<bool>(), 40),
        added in segments(),
        (x, y, w, h) in (-25.0f64..25.0, -25.0f64..25.0, 0.0f64..10.0, 0.0f64..10.0),
    ) {
        let mut index = BoxIndex::from_segments(&segs);
        let mut kept: Vec<(usize, Segment)> = Vec::new();
        for (i, s) in segs.iter().enumerate() {
            if removed[i] {
                prop_assert!(index.remove(s, i));
            } else {
                kept.push((i, *s));
            }
        }
        for (j, s) in added.iter().enumerate() {
            index.insert(s, segs.len() + j);
            kept.push((segs.len() + j, *s));
        }
        let (lo, hi) = (Vec2::new(x, y), Vec2::new(x + w, y + h));
        let expect: Vec<usize> = kept.iter().filter(|(_, s)| boxes_meet(s, lo, hi)).map(|(i, _)| *i).collect();
        prop_assert_eq!(index.intersecting(lo, hi), expect);
    }
}

#[test]
fn non_finite_segments_and_points_are_not_found() {
    let bad = Segment::new(Vec2::new(f64::NAN, 0.0), Vec2::ZERO);
    let far = Segment::new(Vec2::new(f64::INFINITY, 0.0), Vec2::ZERO);
    let index = SegmentIndex::from_segments(&[bad, far], 0.5, 1.0);
    assert!(index.is_empty());
    assert!(index.nearest_anywhere(Vec2::ZERO).is_none());
    let ok = SegmentIndex::from_segments(&[Segment::new(Vec2::ZERO, Vec2::X)], 0.5, 1.0);
    assert!(ok.nearest_anywhere(Vec2::new(f64::NAN, 0.0)).is_none());
    assert!(!ok.any_within(Vec2::new(f64::INFINITY, 0.0), 1.0));
    assert_eq!(
        ok.nearest_anywhere(Vec2::new(100.0, 0.0)).map(|n| n.0),
        Some(0)
    );
}

proptest! {
    /// The crossing candidates hold every segment that crosses the probe (brute force).
    #[test]
    fn crossing_candidates_hold_every_crossing_segment(
        raw in proptest::collection::vec((-8.0f64..8.0, -8.0f64..8.0, -8.0f64..8.0, -8.0f64..8.0), 1..30),
        ax in -9.0f64..9.0, ay in -9.0f64..9.0, bx in -9.0f64..9.0, by in -9.0f64..9.0,
        axis in 0u8..3,
    ) {
        let segs: Vec<Segment> = raw.iter().map(|&(a, b, c, e)| Segment::new(Vec2::new(a, b), Vec2::new(c, e))).collect();
        let mut grid = SegmentIndex::new(0.5, 1.0);
        for (i, s) in segs.iter().enumerate() { grid.insert(i, *s); }
        // Also probes along the grid's axes and through its corners.
        let (a, b) = match axis {
            0 => (Vec2::new(ax, ay), Vec2::new(bx, by)),
            1 => (Vec2::new(ax, 0.5), Vec2::new(bx, 0.5)),
            _ => (Vec2::new(ax.round() * 0.5, ax.round() * 0.5), Vec2::new(bx.round() * 0.5, bx.round() * 0.5)),
        };
        let probe = Segment::new(a, b);
        let mut found = Vec::new();
        grid.for_crossing_candidates(a, b, |k, _| found.push(k));
        for (i, s) in segs.iter().enumerate() {
            if s.intersects(&probe) {
                prop_assert!(found.contains(&i), "segment {} crosses the probe but was not offered", i);
            }
        }
    }

    /// A certificate's answer, when it gives one, is the search's answer.
    #[test]
    fn certified_answers_agree_with_the_search(
        raw in proptest::collection::vec((-4.0f64..4.0, -4.0f64..4.0, -4.0f64..4.0, -4.0f64..4.0), 0..20),
        qx in -5.0f64..5.0, qy in -5.0f64..5.0,
        moves in proptest::collection::vec((-0.2f64..0.2, -0.2f64..0.2, 0.0f64..1.0), 1..8),
    ) {
        let mut grid = SegmentIndex::new(0.5, 1.0);
        for (i, &(a, b, c, e)) in raw.iter().enumerate() {
            grid.insert(i, Segment::new(Vec2::new(a, b), Vec2::new(c, e)));
        }
        let at = Vec2::new(qx, qy);
        let certificate = grid.nearest_certified(at);
        for &(dx, dy, gate) in &moves {
            let p = at + Vec2::new(dx, dy);
            if let Some(answer) = certificate.answer(p, gate) {
                prop_assert_eq!(answer, grid.nearest_segment(p, gate).map(|(_, s)| s));
            }
        }
    }
}

#[test]
fn a_certificate_answers_small_moves_near_a_lone_wall() {
    let mut grid = SegmentIndex::new(0.5, 1.0);
    let wall = Segment::new(Vec2::new(0.0, 0.0), Vec2::new(4.0, 0.0));
    grid.insert(1u8, wall);
    let certificate = grid.nearest_certified(Vec2::new(2.0, 0.1));
    // Nothing else within the reach: moves up to (1.0 − 0.1) / 2 are decided.
    assert_eq!(
        certificate.answer(Vec2::new(2.3, 0.2), 0.25),
        Some(Some(wall))
    );
    assert_eq!(certificate.answer(Vec2::new(2.3, 0.2), 0.1), Some(None));
    assert_eq!(certificate.answer(Vec2::new(2.0, 0.7), 0.25), None);
}

/// The search squares the distance it is given, so a negative one counts as its absolute
/// value; the certificate must not compare it as it is.
#[test]
fn a_certificate_treats_a_negative_distance_as_the_search_does() {
    let mut grid = SegmentIndex::new(0.5, 1.0);
    let wall = Segment::new(Vec2::new(2.0, -3.0), Vec2::new(2.0, 3.0));
    grid.insert(1u8, wall);
    let certificate = grid.nearest_certified(Vec2::new(0.1, 0.1));
    let p = Vec2::new(1.2, 0.1);
    let searched = grid.nearest_segment(p, -0.9).map(|(_, s)| s);
    assert_eq!(searched, Some(wall));
    assert!(certificate.answer(p, -0.9).is_none_or(|a| a == searched));
}

#[test]
fn removing_everything_empties_the_grid() {
    let mut grid = SegmentIndex::new(0.5, 1.0);
    let s = Segment::new(Vec2::new(0.0, 0.0), Vec2::new(10.0, 3.0));
    grid.insert(1u8, s);
    grid.remove(1, &s);
    assert!(grid.cells.is_empty());
}

/// A diagonal wall 85 km long is listed in the strip of cells along it, a few per metre,
/// not in every cell of its bounding box (about 1.4e10 cells: minutes and gigabytes).
#[test]
fn a_long_diagonal_is_listed_in_cells_along_its_length() {
    let cell_m = 0.5;
    let mut grid = SegmentIndex::new(cell_m, 0.0);
    let s = Segment::new(Vec2::new(3e4, 3e4), Vec2::new(-3e4, -3e4));
    grid.insert(1u8, s);
    let listed: usize = grid.cells.values().map(Vec::len).sum();
    let along = (s.length() / cell_m).ceil() as usize;
    assert!(
        listed >= along && listed <= 4 * along,
        "listed in {listed} cells for {along} cells of length"
    );
    assert_eq!(
        grid.nearest(Vec2::new(10.0, 10.2), 0.5).map(|h| h.0),
        Some(1)
    );
    grid.remove(1, &s);
    assert!(grid.is_empty());
}

/// Cells are i64: with i32 cells, beyond about 1.07e9 m every segment would fall in no cell
/// and the mapper would silently stop finding anything.
#[test]
fn far_coordinates_still_index() {
    for offset in [1e8, 1.2e9, 1e12] {
        let mut grid = SegmentIndex::new(0.5, 1.0);
        let s = Segment::new(Vec2::new(offset, offset), Vec2::new(offset + 3.0, offset));
        grid.insert(1u8, s);
        let hit = grid.nearest(Vec2::new(offset + 1.0, offset + 0.2), 1.0);
        assert_eq!(hit.map(|h| h.0), Some(1), "at {offset}");
        assert_eq!(grid.near_segment(&s, 0.5), vec![1]);
    }
}

/// A copy of a grid counts its emptied cells as the grid does: the count follows the lists, not
/// their allocations (a copied empty list has none, so an allocation cannot tell a kept cell).
#[test]
fn a_copy_keeps_count_of_its_emptied_cells() {
    let mut grid = SegmentIndex::new(0.5, 1.0);
    let a = Segment::new(Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0));
    let b = Segment::new(Vec2::new(0.0, 5.0), Vec2::new(8.0, 5.0));
    grid.insert(1u8, a);
    grid.insert(2u8, b);
    grid.remove(1, &a);
    let mut copy = grid.clone();
    copy.insert(1, a);
    let empty = copy.cells.values().filter(|l| l.is_empty()).count();
    assert_eq!(copy.empty_cells, empty);
    copy.remove(2, &b);
    assert!(!copy.is_empty());
    assert_eq!(copy.nearest(Vec2::new(0.5, 0.1), 1.0).map(|h| h.0), Some(1));
}
