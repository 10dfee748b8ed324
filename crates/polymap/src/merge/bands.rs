//! Candidate pairs without a proximity gate (the paper's `max_gap_m = ∞`): an index over the
//! cost's lower bound instead of over distance.
//!
//! Along a main direction `ad` with unit normal `n`, [`crate::cost`] bounds the cost from below
//! by `(d1 + d2) / (2(1 + K)²)`, where `di` sums the distances of `Li`'s endpoints from the line
//! `ld`. Whatever the offset of `ld`, `d1 + d2` is at least
//!
//! - `w1 + w2`, the segments' extents across `ad` (`wi = |n·(endᵢ − startᵢ)|`), and
//! - `2 |o1 − o2|`, twice the gap between their midpoints across `ad` (`oi = n·midᵢ`).
//!
//! So a pair can cost at most `T` along `ad` only when both are at most the band
//! `B = 2(1 + K)²·T` (plus a margin for rounding). Sorting the segments by `o` and sweeping a
//! window of `B / 2` finds exactly those pairs, instead of costing all `n²`: the same merges,
//! found faster. With `K < 0` or an infinite threshold there is no bound, and every pair is a
//! candidate.

use crate::geometry::{Segment, Vec2};

/// A segment's place across one main direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct BandKey {
    /// Extent across the direction, metres.
    width_m: f64,
    /// Offset of the midpoint across the direction, metres.
    offset_m: f64,
}

/// The band `B` for the cost bound `max_cost` under `K = k`: pairs outside it cannot merge;
/// `None` when the bound does not hold (`k < 0`) or says nothing (`max_cost` infinite).
pub(crate) fn band_m(k: f64, max_cost: f64) -> Option<f64> {
    if k.is_nan() || k < 0.0 || !max_cost.is_finite() {
        return None;
    }
    // The bound as `cost_at_most` applies it (with its own margin), widened by a relative
    // millionth and a micrometre so that rounding in these keys never drops a pair it keeps.
    let bound = 2.0 * (1.0 + k) * (1.0 + k) * (max_cost * (1.0 + 1e-9) + 1e-12);
    Some(bound * (1.0 + 1e-6) + 1e-6)
}

/// The keys of a segment across every direction (unit vectors).
pub(crate) fn keys(s: &Segment, directions: &[Vec2]) -> Vec<BandKey> {
    directions
        .iter()
        .map(|u| {
            let n = u.perp();
            BandKey {
                width_m: n.dot(s.vector()).abs(),
                offset_m: n.dot(s.midpoint()),
            }
        })
        .collect()
}

/// Whether two segments (their keys across the same directions) may merge within the band
/// along one of the directions.
pub(crate) fn may_merge(a: &[BandKey], b: &[BandKey], band_m: f64) -> bool {
    a.iter().zip(b).any(|(a, b)| within(a, b, band_m))
}

fn within(a: &BandKey, b: &BandKey, band_m: f64) -> bool {
    a.width_m + b.width_m <= band_m && 2.0 * (a.offset_m - b.offset_m).abs() <= band_m
}

/// The pairs `(i, j)` of `a` and `b` that may merge within the band along one of the
/// directions, sorted, no repeats; with `b` `None`, the pairs `i < j` of `a` with itself.
pub(crate) fn band_pairs(
    a: &[Segment],
    b: Option<&[Segment]>,
    directions: &[Vec2],
    band_m: f64,
) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    for u in directions {
        let ka = sorted_keys(a, *u, band_m);
        let kb = match b {
            Some(b) => sorted_keys(b, *u, band_m),
            None => ka.clone(),
        };
        let mut lo = 0;
        for (ia, key_a) in &ka {
            while lo < kb.len() && 2.0 * (key_a.offset_m - kb[lo].1.offset_m) > band_m {
                lo += 1;
            }
            for (ib, key_b) in &kb[lo..] {
                if 2.0 * (key_b.offset_m - key_a.offset_m) > band_m {
                    break;
                }
                if (b.is_some() || ia < ib) && within(key_a, key_b, band_m) {
                    out.push((*ia, *ib));
                }
            }
        }
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// The segments narrow enough across `u` to merge at all, by offset across it.
fn sorted_keys(segs: &[Segment], u: Vec2, band_m: f64) -> Vec<(usize, BandKey)> {
    let mut keyed: Vec<(usize, BandKey)> = segs
        .iter()
        .enumerate()
        .map(|(i, s)| (i, keys(s, &[u])[0]))
        .filter(|(_, k)| k.width_m <= band_m)
        .collect();
    keyed.sort_by(|x, y| x.1.offset_m.total_cmp(&y.1.offset_m).then(x.0.cmp(&y.0)));
    keyed
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::merge::{best_merge_at_most, units};
    use proptest::prelude::*;

    fn segment() -> impl Strategy<Value = Segment> {
        (
            0.0f64..8.0,
            0.0f64..8.0,
            0.0f64..3.0,
            0usize..3,
            -0.1f64..0.1,
        )
            .prop_map(|(x, y, len, d, noise)| {
                let a = [0.0, 1.0, 2.0][d] + noise;
                Segment::new(
                    Vec2::new(x, y),
                    Vec2::new(x + len * a.cos(), y + len * a.sin()),
                )
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]

        /// Every pair that merges within the threshold (costed in full) is a band pair.
        #[test]
        fn every_pair_that_merges_is_found(
            a in proptest::collection::vec(segment(), 0..30),
            b in proptest::collection::vec(segment(), 0..30),
            k in prop_oneof![Just(0.0), Just(1.0), 0.0f64..5.0],
            max_cost in 0.0f64..0.5,
        ) {
            let directions = units(&[0.0, 1.0, 2.0]);
            let band = band_m(k, max_cost).unwrap();
            let merges = |x: &Segment, y: &Segment| {
                best_merge_at_most(x, y, &directions, k, f64::INFINITY)
                    .is_some_and(|(_, m)| m.cost <= max_cost * (1.0 + 1e-9) + 1e-12)
            };
            let found = band_pairs(&a, Some(&b), &directions, band);
            for (i, x) in a.iter().enumerate() {
                for (j, y) in b.iter().enumerate() {
                    if merges(x, y) {
                        prop_assert!(found.binary_search(&(i, j)).is_ok(), "{:?}", (i, j));
                    }
                }
            }
            let found_self = band_pairs(&a, None, &directions, band);
            for (i, x) in a.iter().enumerate() {
                for (j, y) in a.iter().enumerate().skip(i + 1) {
                    if merges(x, y) {
                        prop_assert!(found_self.binary_search(&(i, j)).is_ok(), "{:?}", (i, j));
                    }
                    let keyed = may_merge(&keys(x, &directions), &keys(y, &directions), band);
                    prop_assert_eq!(keyed, found_self.binary_search(&(i, j)).is_ok());
                }
            }
        }
    }

    /// The band cuts the pairs down: parallel walls 1 m apart never pair at the default
    /// threshold, collinear ones at any distance do (the paper's trap, kept as printed).
    #[test]
    fn far_parallel_walls_are_not_candidates_and_collinear_ones_are() {
        let s = |y: f64, x: f64| Segment::new(Vec2::new(x, y), Vec2::new(x + 1.0, y));
        let walls = [s(0.0, 0.0), s(1.0, 0.0), s(0.0, 50.0)];
        let band = band_m(1.0, 0.05).unwrap();
        assert_eq!(band_pairs(&walls, None, &[Vec2::X], band), vec![(0, 2)]);
        assert_eq!(band_m(-1.0, 0.05), None);
        assert_eq!(band_m(1.0, f64::INFINITY), None);
    }
}
