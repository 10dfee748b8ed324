//! Restrictive pairing (section 2.1): children of map/scan pairs cheaper than `T_p`.

use super::bands::{band_m, band_pairs};
use super::{MergeParams, best_merge_at_most, pairs_within, units};
use crate::geometry::Segment;

/// A segment created by pairing, `ms(L1, L2, ad)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Child {
    /// The merged segment.
    pub segment: Segment,
    /// Its cost `C(L1, L2, ad)`.
    pub cost: f64,
    /// Index of the map parent (class C1).
    pub map_parent: usize,
    /// Index of the scan parent (class C2).
    pub scan_parent: usize,
    /// Index of the main direction used.
    pub direction: usize,
}

/// The output of pairing: `A_t = C1' ∪ C2' ∪ children`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Pairing {
    /// The children, cheapest first.
    pub children: Vec<Child>,
    /// For each map segment, whether it became a parent (and so leaves the map).
    pub map_is_parent: Vec<bool>,
    /// For each scan segment, whether it became a parent.
    pub scan_is_parent: Vec<bool>,
}

/// Pairs map segments (`c1`) with scan segments (`c2`).
///
/// Every pair within the proximity gate is costed under each main direction and the cheapest
/// direction kept. Pairs cheaper than `T_p` become children, cheapest first, as long as neither
/// parent already has `max_children` children. Pairs within one class are never formed.
///
/// ```
/// use polymap::merge::{restrictive_pairing, MergeParams};
/// use polymap::geometry::{Segment, Vec2};
/// let c1 = [Segment::new(Vec2::new(0.0, 0.0), Vec2::new(2.0, 0.0))];
/// let c2 = [Segment::new(Vec2::new(0.0, 0.04), Vec2::new(2.0, 0.04)), Segment::new(Vec2::new(0.0, 3.0), Vec2::new(2.0, 3.0))];
/// let p = restrictive_pairing(&c1, &c2, &[0.0], &MergeParams::default());
/// assert_eq!(p.children.len(), 1);
/// assert!((p.children[0].segment.start.y - 0.02).abs() < 1e-12);
/// assert_eq!(p.scan_is_parent, vec![true, false]);
/// ```
pub fn restrictive_pairing(
    c1: &[Segment],
    c2: &[Segment],
    directions_rad: &[f64],
    params: &MergeParams,
) -> Pairing {
    let directions = units(directions_rad);
    // Without a proximity gate, the cost's bound finds the pairs that can pair at all.
    let band =
        band_m(params.k, params.pairing_threshold).filter(|_| params.max_gap_m.is_infinite());
    let pairs = match band {
        Some(band) => band_pairs(c1, Some(c2), &directions, band),
        None => pairs_within(c1, c2, params.max_gap_m),
    };
    let mut candidates: Vec<Child> = pairs
        .into_iter()
        .filter_map(|(i, j)| {
            let (dir, m) = best_merge_at_most(
                &c1[i],
                &c2[j],
                &directions,
                params.k,
                params.pairing_threshold,
            )?;
            (m.cost < params.pairing_threshold).then_some(Child {
                segment: m.segment,
                cost: m.cost,
                map_parent: i,
                scan_parent: j,
                direction: dir,
            })
        })
        .collect();
    candidates.sort_by(|a, b| {
        a.cost
            .total_cmp(&b.cost)
            .then((a.map_parent, a.scan_parent).cmp(&(b.map_parent, b.scan_parent)))
    });
    let mut n1 = vec![0usize; c1.len()];
    let mut n2 = vec![0usize; c2.len()];
    let mut children = Vec::new();
    for c in candidates {
        if n1[c.map_parent] < params.max_children && n2[c.scan_parent] < params.max_children {
            n1[c.map_parent] += 1;
            n2[c.scan_parent] += 1;
            children.push(c);
        }
    }
    Pairing {
        children,
        map_is_parent: n1.iter().map(|&n| n > 0).collect(),
        scan_is_parent: n2.iter().map(|&n| n > 0).collect(),
    }
}
