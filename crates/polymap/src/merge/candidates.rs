//! Candidate pairs: segments that come within the proximity gate of each other.

use crate::geometry::{Segment, Vec2};
use crate::segment_index::BoxIndex;

/// The bounding box of `s` grown by `margin_m` on every side, as `(lo, hi)`, metres.
pub(crate) fn grown_box(s: &Segment, margin_m: f64) -> (Vec2, Vec2) {
    let (lo, hi) = s.bounds();
    (lo - Vec2::splat(margin_m), hi + Vec2::splat(margin_m))
}

/// Up to this many pairs, testing every pair beats building a `BoxIndex` (an R-tree) (measured: a scan meets
/// 20 to 90 segments of its local map; up to about 250 segments a side, 65,536 pairs, the
/// walk is faster).
pub(crate) const BRUTE_FORCE_PAIRS: usize = 65_536;

/// All pairs `(i, j)` with `a[i]` and `b[j]` no further than `gap_m` apart (segment to segment),
/// sorted. Uses a `BoxIndex` over `b` for large inputs; with an infinite gap every pair qualifies.
///
/// ```
/// use polymap::merge::pairs_within;
/// use polymap::geometry::{Segment, Vec2};
/// let a = [Segment::new(Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0))];
/// let b = [Segment::new(Vec2::new(0.0, 0.3), Vec2::new(1.0, 0.3)), Segment::new(Vec2::new(3.0, 0.0), Vec2::new(4.0, 0.0))];
/// assert_eq!(pairs_within(&a, &b, 0.5), vec![(0, 0)]);
/// ```
pub fn pairs_within(a: &[Segment], b: &[Segment], gap_m: f64) -> Vec<(usize, usize)> {
    pairs_within_walk_limit(a, b, gap_m, BRUTE_FORCE_PAIRS)
}

/// [`pairs_within`], testing every pair for up to `walk_limit` pairs.
pub(crate) fn pairs_within_walk_limit(
    a: &[Segment],
    b: &[Segment],
    gap_m: f64,
    walk_limit: usize,
) -> Vec<(usize, usize)> {
    if !gap_m.is_finite() || a.len().saturating_mul(b.len()) <= walk_limit {
        return walk_pairs(a, b, gap_m, false);
    }
    let index = BoxIndex::from_segments(b);
    let mut out = Vec::new();
    for (i, s) in a.iter().enumerate() {
        let (lo, hi) = grown_box(s, gap_m);
        for j in index.intersecting_iter(lo, hi) {
            if s.distance_to_segment_within(&b[j], gap_m).is_some() {
                out.push((i, j));
            }
        }
    }
    out.sort_unstable();
    out
}

/// The obviously correct version of [`pairs_within`]: every pair is tested.
pub fn pairs_within_brute(a: &[Segment], b: &[Segment], gap_m: f64) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    for (i, s) in a.iter().enumerate() {
        for (j, t) in b.iter().enumerate() {
            if s.distance_to_segment(t) <= gap_m {
                out.push((i, j));
            }
        }
    }
    out
}

/// Every pair `(i, j)` of `a` and `b` within `gap_m`, sorted, boxes compared first; with
/// `later_only` (when `a` and `b` are the same slice) only `i < j`.
fn walk_pairs(a: &[Segment], b: &[Segment], gap_m: f64, later_only: bool) -> Vec<(usize, usize)> {
    let boxes: Vec<(Vec2, Vec2)> = b.iter().map(Segment::bounds).collect();
    let mut out = Vec::new();
    for (i, s) in a.iter().enumerate() {
        let first = if later_only { i + 1 } else { 0 };
        let own = s.bounds();
        for (j, t) in b.iter().enumerate().skip(first) {
            if boxes_within(own, boxes[j], gap_m)
                && s.distance_to_segment_within(t, gap_m).is_some()
            {
                out.push((i, j));
            }
        }
    }
    out
}

/// The pairs `(i, j)`, `i < j`, of `segs` no further than `gap_m` apart, sorted: what
/// [`pairs_within`]`(segs, segs, gap_m)` holds with `i < j`, at half the tests.
pub fn pairs_within_self(segs: &[Segment], gap_m: f64) -> Vec<(usize, usize)> {
    pairs_within_self_walk_limit(segs, gap_m, BRUTE_FORCE_PAIRS)
}

/// [`pairs_within_self`], testing every pair for up to `walk_limit` pairs.
pub(crate) fn pairs_within_self_walk_limit(
    segs: &[Segment],
    gap_m: f64,
    walk_limit: usize,
) -> Vec<(usize, usize)> {
    if gap_m.is_finite() && segs.len().saturating_mul(segs.len()) > walk_limit {
        let mut pairs = pairs_within_walk_limit(segs, segs, gap_m, walk_limit);
        pairs.retain(|(i, j)| i < j);
        return pairs;
    }
    sweep_pairs(segs, gap_m)
}

/// [`walk_pairs`] of `segs` with itself, `later_only`, by a sweep along x: with the segments in
/// order of their boxes' lowest x, a segment meets only those after it whose box starts within
/// the gap of its box's end; beyond, their boxes are further than `gap_m` apart along x alone
/// (by a margin of 10⁻⁹ relative, far above rounding, so [`boxes_within`] would be false too).
/// Every other pair is tested as the walk tests it: the same pairs, at a fraction of the tests
/// (a simplified local map holds a few hundred segments, most far apart).
fn sweep_pairs(segs: &[Segment], gap_m: f64) -> Vec<(usize, usize)> {
    let boxes: Vec<(Vec2, Vec2)> = segs.iter().map(Segment::bounds).collect();
    let finite = boxes
        .iter()
        .all(|(lo, hi)| lo.is_finite() && hi.is_finite());
    if !(finite && gap_m.is_finite()) {
        return walk_pairs(segs, segs, gap_m, true);
    }
    let reach = gap_m.abs() * (1.0 + 1e-9) + 1e-9;
    let mut order: Vec<usize> = (0..segs.len()).collect();
    order.sort_unstable_by(|&a, &b| boxes[a].0.x.total_cmp(&boxes[b].0.x));
    let mut out = Vec::new();
    for (k, &i) in order.iter().enumerate() {
        let limit = boxes[i].1.x + reach;
        for &j in &order[k + 1..] {
            if boxes[j].0.x > limit {
                break;
            }
            // The lower index first, as the walk tests the pair.
            let (a, b) = (i.min(j), i.max(j));
            if boxes_within(boxes[a], boxes[b], gap_m)
                && segs[a]
                    .distance_to_segment_within(&segs[b], gap_m)
                    .is_some()
            {
                out.push((a, b));
            }
        }
    }
    out.sort_unstable();
    out
}

/// False when two bounding boxes are further than `gap_m` apart, so that the segments inside
/// are too; a cheap first test before [`Segment::distance_to_segment_within`].
pub(crate) fn boxes_within(a: (Vec2, Vec2), b: (Vec2, Vec2), gap_m: f64) -> bool {
    let gap = (b.0 - a.1).max(a.0 - b.1).max(Vec2::ZERO);
    gap.length_squared() <= gap_m * gap_m
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sweep finds exactly the walk's pairs, boxes exactly the gap apart included.
    #[test]
    fn the_sweep_finds_the_walks_pairs() {
        let mut seed = 7u64;
        let mut next = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for round in 0..40 {
            let n = 5 + round * 7;
            let mut segs: Vec<Segment> = (0..n)
                .map(|_| {
                    let a = Vec2::new(next() * 12.0, next() * 12.0);
                    let d = Vec2::new(next() * 2.0 - 1.0, next() * 2.0 - 1.0);
                    Segment::new(a, a + d)
                })
                .collect();
            // Boxes exactly 0.5 m apart along x, and touching.
            segs.push(Segment::new(Vec2::new(20.0, 0.0), Vec2::new(21.0, 0.0)));
            segs.push(Segment::new(Vec2::new(21.5, 0.0), Vec2::new(22.0, 0.0)));
            segs.push(Segment::new(Vec2::new(22.0, 0.0), Vec2::new(22.0, 1.0)));
            for gap in [0.0, 0.1, 0.5, 1.3] {
                assert_eq!(
                    sweep_pairs(&segs, gap),
                    walk_pairs(&segs, &segs, gap, true),
                    "{n} segments, gap {gap}"
                );
            }
        }
    }
}
