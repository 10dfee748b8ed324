use super::*;
use crate::geometry::{Pose2, Vec2};
use std::f64::consts::PI;

fn seg(ax: f64, ay: f64, bx: f64, by: f64) -> Segment {
    Segment::new(Vec2::new(ax, ay), Vec2::new(bx, by))
}

fn deg(d: f64) -> f64 {
    d.to_radians().rem_euclid(PI)
}

/// The paper's main directions in Figs. 2 and 3: 0°, +60°, −60°.
fn dirs60() -> Vec<f64> {
    vec![deg(0.0), deg(60.0), deg(-60.0)]
}

fn direction_error_deg(s: &Segment, ad: f64) -> f64 {
    crate::geometry::angle_between_directions_rad(s.direction_rad(), ad).to_degrees()
}

/// A tent of two 1 m segments at ±60° with its left foot at `(x, y)`.
fn tent(x: f64, y: f64) -> [Segment; 2] {
    let top = Vec2::new(x + 0.5, y + 0.75f64.sqrt());
    [
        Segment::new(Vec2::new(x, y), top),
        Segment::new(top, Vec2::new(x + 1.0, y)),
    ]
}

/// Pairing then simplification, as the mapper runs them.
fn pair_and_simplify(
    c1: &[Segment],
    c2: &[Segment],
    dirs: &[f64],
    p: &MergeParams,
) -> (Pairing, Simplified) {
    let pairing = restrictive_pairing(c1, c2, dirs, p);
    let mut a_t: Vec<Segment> = pairing.children.iter().map(|c| c.segment).collect();
    a_t.extend(
        c1.iter()
            .zip(&pairing.map_is_parent)
            .filter(|(_, p)| !**p)
            .map(|(s, _)| *s),
    );
    a_t.extend(
        c2.iter()
            .zip(&pairing.scan_is_parent)
            .filter(|(_, p)| !**p)
            .map(|(s, _)| *s),
    );
    let s = simplify(&a_t, dirs, p);
    (pairing, s)
}

/// Fig. 2: map and scan see the same corner (a 0° wall and a 60° wall) slightly apart and
/// slightly rotated. Pairing makes children along the main directions; simplification leaves one
/// segment per wall, each exactly along its main direction.
#[test]
fn fig2_pairing_and_simplification_follow_main_directions() {
    let c1 = [
        seg(0.0, 0.0, 3.0, 0.0),
        Segment::new(Vec2::new(3.0, 0.0), Vec2::new(3.0 + 1.0, 3f64.sqrt())),
    ];
    let moved = Pose2::new(0.03, 0.04, 1.5f64.to_radians());
    let c2: Vec<Segment> = c1.iter().map(|s| s.transformed(&moved)).collect();
    let p = MergeParams::default();
    let (pairing, simplified) = pair_and_simplify(&c1, &c2, &dirs60(), &p);
    assert!(pairing.children.len() >= 2, "{:?}", pairing.children);
    for c in &pairing.children {
        assert!(direction_error_deg(&c.segment, dirs60()[c.direction]) < 1e-9);
    }
    assert_eq!(simplified.segments.len(), 2, "{:?}", simplified.segments);
    let mut found: Vec<f64> = simplified
        .segments
        .iter()
        .map(|s| s.segment.direction_rad().to_degrees())
        .collect();
    found.sort_by(f64::total_cmp);
    assert!(
        found[0].abs() < 1e-9 && (found[1] - 60.0).abs() < 1e-9,
        "{found:?}"
    );
}

/// Fig. 3: a straight wall and a tent in both map and scan. Both features survive: the tent's
/// ±60° segments do not merge into the straight line, and the result has one segment per part.
#[test]
fn fig3_both_shape_features_are_preserved() {
    let [t1, t2] = tent(1.0, 0.6);
    let c1 = [seg(0.0, 0.0, 4.0, 0.0), t1, t2];
    let moved = Pose2::new(0.02, -0.03, (-1.0f64).to_radians());
    let c2: Vec<Segment> = c1.iter().map(|s| s.transformed(&moved)).collect();
    let (pairing, simplified) = pair_and_simplify(&c1, &c2, &dirs60(), &MergeParams::default());
    assert_eq!(pairing.children.len(), 3);
    assert_eq!(simplified.segments.len(), 3);
    let mut found: Vec<f64> = simplified
        .segments
        .iter()
        .map(|s| s.segment.direction_rad().to_degrees())
        .collect();
    found.sort_by(f64::total_cmp);
    assert!(
        found[0].abs() < 1e-9 && (found[1] - 60.0).abs() < 1e-9 && (found[2] - 120.0).abs() < 1e-9,
        "{found:?}"
    );
}

/// Fig. 5 geometry in metres: a straight 2.5 m scan segment 5 cm below a map wall that carries a
/// 6 cm high triangle whose sides run at ±62°. (The paper gives no units; at this scale its
/// thresholds T_p = 0.05 … 0.01 with K = 1 reproduce the progression of Fig. 6.)
fn fig5() -> (Vec<Segment>, Vec<Segment>) {
    let (h, sep) = (0.06, 0.05);
    let w = h / 62f64.to_radians().tan();
    let map = vec![
        seg(0.0, 0.0, 1.0, 0.0),
        seg(1.0, 0.0, 1.0 + w, h),
        seg(1.0 + w, h, 1.0 + 2.0 * w, 0.0),
        seg(1.0 + 2.0 * w, 0.0, 2.5, 0.0),
    ];
    let scan = vec![seg(0.0, -sep, 2.5, -sep)];
    (map, scan)
}

/// Fig. 5 needs cuts closer together than the default minimum piece.
fn fig5_params() -> MergeParams {
    MergeParams {
        insert_min_piece_m: 0.005,
        ..MergeParams::default()
    }
}

/// Fig. 5: the straight scan segment is split at the projections of the triangle's vertices.
#[test]
fn fig5_scan_segment_is_split_at_projected_vertices() {
    let (map, scan) = fig5();
    let p = fig5_params();
    let (map_pieces, scan_pieces) = insert_vertices(&map, &scan, &p);
    assert_eq!(
        map_pieces.len(),
        4,
        "map unchanged: the scan's endpoints project onto map endpoints"
    );
    let xs: Vec<f64> = scan_pieces.iter().map(|q| q.segment.end.x).collect();
    let w = 0.06 / 62f64.to_radians().tan();
    let expect = [1.0, 1.0 + w, 1.0 + 2.0 * w, 2.5];
    assert_eq!(xs.len(), 4, "{xs:?}");
    for (x, e) in xs.iter().zip(expect) {
        assert!((x - e).abs() < 1e-12, "{xs:?}");
    }
    assert!(
        scan_pieces
            .iter()
            .all(|q| q.source == 0 && (q.segment.start.y + 0.05).abs() < 1e-12)
    );
}

/// Fig. 6: with main directions 0°, ±62°, lowering T_p goes from only children (every segment
/// of map and scan is a parent) to no children at all.
#[test]
fn fig6_lowering_tp_goes_from_only_children_to_none() {
    let (map, scan) = fig5();
    let p = fig5_params();
    let (mp, sp) = insert_vertices(&map, &scan, &p);
    let c1: Vec<Segment> = mp.iter().map(|q| q.segment).collect();
    let c2: Vec<Segment> = sp.iter().map(|q| q.segment).collect();
    let dirs = [deg(0.0), deg(62.0), deg(-62.0)];
    let mut children_by_tp = Vec::new();
    for tp in [0.05, 0.04, 0.03, 0.01] {
        let pairing = restrictive_pairing(
            &c1,
            &c2,
            &dirs,
            &MergeParams {
                pairing_threshold: tp,
                ..p.clone()
            },
        );
        let parents = pairing
            .map_is_parent
            .iter()
            .chain(&pairing.scan_is_parent)
            .filter(|x| **x)
            .count();
        children_by_tp.push((tp, pairing.children.len(), parents));
    }
    let (_, first_children, first_parents) = children_by_tp[0];
    assert!(
        first_children > 0 && first_parents == c1.len() + c2.len(),
        "only children at T_p = 0.05: {children_by_tp:?}"
    );
    let (_, _, some_parents) = children_by_tp[2];
    assert!(
        some_parents > 0 && some_parents < first_parents,
        "only some pair at T_p = 0.03: {children_by_tp:?}"
    );
    assert_eq!(
        children_by_tp[3].1, 0,
        "no children at T_p = 0.01: {children_by_tp:?}"
    );
    assert!(
        children_by_tp.windows(2).all(|w| w[0].1 >= w[1].1),
        "monotone: {children_by_tp:?}"
    );
}

#[test]
fn proximity_gate_keeps_collinear_walls_apart_across_a_doorway() {
    let left = seg(0.0, 0.0, 3.0, 0.0);
    let right = seg(3.9, 0.0, 7.0, 0.0);
    let gated = simplify(&[left, right], &[0.0], &MergeParams::default());
    assert_eq!(gated.merges, 0);
    let paper = simplify(
        &[left, right],
        &[0.0],
        &MergeParams {
            max_gap_m: f64::INFINITY,
            ..MergeParams::default()
        },
    );
    assert_eq!(paper.merges, 1, "without the gate the doorway closes");
}

#[test]
fn a_parent_keeps_its_three_cheapest_children() {
    let c1 = [seg(0.0, 0.0, 4.0, 0.0)];
    // Five scan segments along the wall at growing offsets: the three nearest are cheapest.
    let c2: Vec<Segment> = (0..5)
        .map(|i| {
            seg(
                i as f64 * 0.8,
                0.01 + 0.01 * i as f64,
                i as f64 * 0.8 + 0.7,
                0.01 + 0.01 * i as f64,
            )
        })
        .collect();
    let params = MergeParams::default();
    let p = restrictive_pairing(&c1, &c2, &[0.0], &params);
    let mut costs: Vec<(f64, usize)> = c2
        .iter()
        .enumerate()
        .map(|(j, s)| (best_merge(&c1[0], s, &[0.0], params.k).unwrap().1.cost, j))
        .collect();
    costs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut cheapest: Vec<usize> = costs[..3].iter().map(|c| c.1).collect();
    let mut kept: Vec<usize> = p.children.iter().map(|c| c.scan_parent).collect();
    cheapest.sort_unstable();
    kept.sort_unstable();
    assert_eq!(kept, cheapest);
    assert_eq!(p.scan_is_parent.iter().filter(|x| **x).count(), 3);
}

#[test]
fn no_main_direction_means_no_merging() {
    let c1 = [seg(0.0, 0.0, 4.0, 0.0)];
    let c2 = [seg(0.0, 0.01, 4.0, 0.01)];
    assert!(
        restrictive_pairing(&c1, &c2, &[], &MergeParams::default())
            .children
            .is_empty()
    );
    assert_eq!(
        simplify(&[c1[0], c2[0]], &[], &MergeParams::default()).merges,
        0
    );
}

mod prop {
    use super::*;
    use proptest::prelude::*;

    fn segment_near_directions() -> impl Strategy<Value = Segment> {
        (
            0.0f64..6.0,
            0.0f64..6.0,
            0.2f64..3.0,
            0usize..3,
            -0.05f64..0.05,
        )
            .prop_map(|(x, y, len, d, noise)| {
                let a = [0.0, PI / 3.0, 2.0 * PI / 3.0][d] + noise;
                Segment::new(
                    Vec2::new(x, y),
                    Vec2::new(x + len * a.cos(), y + len * a.sin()),
                )
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn candidate_search_agrees_with_brute_force(
            a in proptest::collection::vec(segment_near_directions(), 0..40),
            b in proptest::collection::vec(segment_near_directions(), 0..40),
            gap in 0.0f64..1.5,
        ) {
            use crate::merge::candidates::{pairs_within_self_walk_limit, pairs_within_walk_limit};
            let expect = pairs_within_brute(&a, &b, gap);
            prop_assert_eq!(&pairs_within(&a, &b, gap), &expect);
            // Both ways of finding candidates: the R-tree (walk limit 0) and the walk.
            prop_assert_eq!(&pairs_within_walk_limit(&a, &b, gap, 0), &expect);
            let mut within_a = pairs_within_brute(&a, &a, gap);
            within_a.retain(|(i, j)| i < j);
            prop_assert_eq!(&pairs_within_self(&a, gap), &within_a);
            prop_assert_eq!(&pairs_within_self_walk_limit(&a, gap, 0), &within_a);
        }

        #[test]
        fn greedy_simplification_agrees_with_brute_force(
            segs in proptest::collection::vec(segment_near_directions(), 0..22),
            ts in 0.01f64..0.3,
            gap in prop_oneof![Just(f64::INFINITY), 0.1f64..1.0],
        ) {
            let p = MergeParams { simplify_threshold: ts, max_gap_m: gap, ..MergeParams::default() };
            let dirs = dirs60();
            let expect = simplify_brute(&segs, &dirs, &p);
            prop_assert_eq!(&simplify(&segs, &dirs, &p), &expect);
            // New partners by the R-tree (walk limit 0) as well as by the walk.
            let by_tree = crate::merge::simplify::simplify_with_walk_limit(&segs, &dirs, &p, 0);
            prop_assert_eq!(&by_tree, &expect);
        }
    }
}

/// The observation records through one merge: the wall the scan saw again is seen at `t` with
/// its counts kept; a ghost near the scan that paired with nothing keeps its record; a scan
/// segment that paired with nothing is born at `t`. The merged wall must not take the crossing
/// ghost's counts: a record is inherited only from roughly parallel members.
#[test]
fn merged_segments_inherit_their_sources_records() {
    use crate::map::{GlobalMap, MapSegment, Observations};
    let mut map = GlobalMap::default();
    let mut wall_record = Observations::born(0);
    for t in 1..6 {
        wall_record.saw(t);
    }
    for _ in 0..3 {
        wall_record.saw_through();
    }
    let wall = MapSegment {
        segment: seg(0.0, 0.0, 4.0, 0.0),
        born_scan: 0,
    };
    map.insert_observed(wall, wall_record);
    let mut ghost_record = Observations::born(2);
    for _ in 0..4 {
        ghost_record.saw_through();
    }
    let ghost = MapSegment {
        segment: seg(1.0, 0.5, 1.0, 1.2),
        born_scan: 2,
    };
    map.insert_observed(ghost, ghost_record);
    let scan = [seg(0.5, 0.01, 4.5, 0.01), seg(2.0, 3.0, 3.0, 3.0)];
    merge_scan(
        &MergeParams::default(),
        &mut map,
        &scan,
        &[0.0, deg(90.0)],
        9,
        true,
    );
    let records: Vec<(Segment, Observations)> = map
        .iter()
        .map(|(id, s)| (s.segment, map.observations(id).unwrap()))
        .collect();
    let on = |y: f64, x: f64| {
        records
            .iter()
            .find(|(s, _)| (s.midpoint().y - y).abs() < 0.1 && (s.midpoint().x - x).abs() < 0.6)
            .map(|(_, o)| *o)
            .expect("a segment there")
    };
    let merged = on(0.0, 2.2);
    assert_eq!(merged.last_seen_scan, 9);
    assert_eq!((merged.seen, merged.seen_through), (7, 3));
    assert_eq!(merged.through_since_seen, 0);
    assert_eq!(on(0.85, 1.0), ghost_record);
    assert_eq!(on(3.0, 2.5), Observations::born(9));
}

/// A child lies between its parents by length × support: a wall many scans tracked `ok` saw
/// moves a little towards one new sighting (support capped by `support_cap`), a wall seen once
/// halfway as in the paper, and with a cap of 1 every wall halfway. Sightings by `weak` scans
/// add no support; a record from a map written before support was kept counts every sighting.
#[test]
fn a_wall_many_scans_saw_moves_little_towards_one_new_sighting() {
    use crate::map::{GlobalMap, MapSegment, Observations};
    let record = |seen: u32, confirmed: bool| {
        let mut record = Observations::born_by(0, confirmed);
        for t in 1..seen {
            record.saw_by(t, confirmed);
        }
        assert_eq!(record.seen, seen);
        record
    };
    let child_y = |record: Observations, cap: f64| {
        let mut map = GlobalMap::default();
        let wall = MapSegment {
            segment: seg(0.0, 0.0, 4.0, 0.0),
            born_scan: 0,
        };
        map.insert_observed(wall, record);
        let params = MergeParams {
            support_cap: cap,
            ..MergeParams::default()
        };
        let scan = [seg(0.0, 0.03, 4.0, 0.03)];
        merge_scan(&params, &mut map, &scan, &[0.0], 40, true);
        assert_eq!(map.len(), 1);
        map.iter().next().unwrap().1.segment.midpoint().y
    };
    let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
    assert!(close(child_y(record(1, true), 10.0), 0.015));
    assert!(close(child_y(record(6, true), 10.0), 0.03 / 7.0));
    assert!(close(child_y(record(30, true), 10.0), 0.03 / 11.0));
    assert!(close(child_y(record(30, true), 1.0), 0.015));
    assert!(close(child_y(record(30, false), 10.0), 0.015));
    let older = Observations {
        confirmed: None,
        ..record(30, false)
    };
    assert!(close(child_y(older, 10.0), 0.03 / 11.0));
}
