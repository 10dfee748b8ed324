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
    walk_pairs(segs, segs, gap_m, true)
}

/// False when two bounding boxes are further than `gap_m` apart, so that the segments inside
/// are too; a cheap first test before [`Segment::distance_to_segment_within`].
pub(crate) fn boxes_within(a: (Vec2, Vec2), b: (Vec2, Vec2), gap_m: f64) -> bool {
    let gap = (b.0 - a.1).max(a.0 - b.1).max(Vec2::ZERO);
    gap.length_squared() <= gap_m * gap_m
}
