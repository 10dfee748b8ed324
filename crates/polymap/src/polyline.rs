//! Generalized polylines (section 2): segments ordered so that consecutive ones have near
//! endpoints, split where the gap exceeds a threshold. Vertices of consecutive segments need not
//! coincide.
//!
//! Ordering to minimise the sum of endpoint gaps is a travelling-salesman-like problem; like the
//! greedy matching heuristic for it, endpoint pairs are joined closest first, as long as both
//! endpoints are still free and the join closes no cycle. Pairs further apart than the threshold
//! are never joined, which is the split.

use serde::{Deserialize, Serialize};

use crate::check::{Checks, InvalidParam};
use crate::geometry::{Segment, Vec2};
use crate::segment_index::BoxIndex;

/// Parameters of polyline grouping.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PolylineParams {
    /// Consecutive segments of a polyline have endpoints at most this far apart, metres.
    pub max_gap_m: f64,
}

impl Default for PolylineParams {
    fn default() -> Self {
        PolylineParams { max_gap_m: 0.5 }
    }
}

impl PolylineParams {
    /// Checks every key's range; the error names the first key out of range.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        Checks::new()
            .within("max_gap_m", self.max_gap_m, 0.0, 100.0)
            .done()
    }
}

/// Groups segments into generalized polylines: lists of segment indices in polyline order.
///
/// Every segment appears in exactly one polyline. Polylines are listed by their smallest index.
///
/// ```
/// use polymap::polyline::group_polylines;
/// use polymap::geometry::{Segment, Vec2};
/// let segs = [
///     Segment::new(Vec2::new(2.0, 0.0), Vec2::new(3.0, 0.0)),
///     Segment::new(Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0)),
///     Segment::new(Vec2::new(1.1, 0.0), Vec2::new(1.9, 0.0)),
///     Segment::new(Vec2::new(9.0, 0.0), Vec2::new(9.0, 1.0)),
/// ];
/// assert_eq!(group_polylines(&segs, 0.5), vec![vec![0, 2, 1], vec![3]]);
/// ```
pub fn group_polylines(segments: &[Segment], max_gap_m: f64) -> Vec<Vec<usize>> {
    let n = segments.len();
    // Endpoint e = 2·i (start) or 2·i + 1 (end) of segment i.
    let point = |e: usize| {
        if e.is_multiple_of(2) {
            segments[e / 2].start
        } else {
            segments[e / 2].end
        }
    };
    // Endpoints as segments of length zero; the box query's candidates are then measured.
    let index = BoxIndex::from_keyed((0..2 * n).map(|e| (e, Segment::new(point(e), point(e)))));
    let max_gap_2 = max_gap_m * max_gap_m;
    let mut joins: Vec<(f64, usize, usize)> = Vec::new();
    for e in 0..2 * n {
        let p = point(e);
        let reach = Vec2::splat(max_gap_m.abs());
        for o in index.intersecting_iter(p - reach, p + reach) {
            if o / 2 > e / 2 && (point(o) - p).length_squared() <= max_gap_2 {
                joins.push((p.distance(point(o)), e, o));
            }
        }
    }
    joins.sort_by(|a, b| a.0.total_cmp(&b.0).then((a.1, a.2).cmp(&(b.1, b.2))));
    let mut partner = vec![usize::MAX; 2 * n];
    let mut chains = UnionFind::new(n);
    for (_, a, b) in joins {
        if partner[a] == usize::MAX && partner[b] == usize::MAX && chains.union(a / 2, b / 2) {
            partner[a] = b;
            partner[b] = a;
        }
    }
    walk_chains(n, &partner)
}

/// Follows the joins from every chain end; a chain is reported from its end with the smaller
/// segment index, and chains are listed by their smallest index.
fn walk_chains(n: usize, partner: &[usize]) -> Vec<Vec<usize>> {
    let mut seen = vec![false; n];
    let mut out: Vec<Vec<usize>> = Vec::new();
    for i in 0..n {
        for free_end in [2 * i, 2 * i + 1] {
            if seen[i] || partner[free_end] != usize::MAX {
                continue;
            }
            let mut chain = Vec::new();
            let mut e = free_end;
            loop {
                let s = e / 2;
                seen[s] = true;
                chain.push(s);
                let other_end = e ^ 1;
                match partner[other_end] {
                    usize::MAX => break,
                    next => e = next,
                }
            }
            if chain.last() < chain.first() {
                chain.reverse();
            }
            out.push(chain);
        }
    }
    out.sort_by_key(|c| c.iter().copied().min());
    out
}

struct UnionFind {
    parent: Vec<usize>,
}

impl UnionFind {
    fn new(n: usize) -> Self {
        UnionFind {
            parent: (0..n).collect(),
        }
    }

    fn find(&mut self, mut x: usize) -> usize {
        while self.parent[x] != x {
            self.parent[x] = self.parent[self.parent[x]];
            x = self.parent[x];
        }
        x
    }

    /// Joins the sets of `a` and `b`; false when they were already one.
    fn union(&mut self, a: usize, b: usize) -> bool {
        let (ra, rb) = (self.find(a), self.find(b));
        self.parent[ra] = rb;
        ra != rb
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Vec2;
    use proptest::prelude::*;

    #[test]
    fn closed_loop_is_cut_once() {
        let sq = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)];
        let segs: Vec<Segment> = (0..4)
            .map(|i| Segment::new(Vec2::from(sq[i]), Vec2::from(sq[(i + 1) % 4])))
            .collect();
        let p = group_polylines(&segs, 0.1);
        assert_eq!(p.len(), 1);
        assert_eq!(p[0].len(), 4);
    }

    #[test]
    fn empty_input() {
        assert!(group_polylines(&[], 1.0).is_empty());
    }

    proptest! {
        #[test]
        fn every_segment_once_and_gaps_bounded(
            raw in proptest::collection::vec((0.0f64..10.0, 0.0f64..10.0, 0.0f64..10.0, 0.0f64..10.0), 0..40),
            gap in 0.0f64..2.0,
        ) {
            let segs: Vec<Segment> = raw.iter().map(|&(a, b, c, d)| Segment::new(Vec2::new(a, b), Vec2::new(c, d))).collect();
            let polys = group_polylines(&segs, gap);
            let mut all: Vec<usize> = polys.iter().flatten().copied().collect();
            all.sort_unstable();
            prop_assert_eq!(all, (0..segs.len()).collect::<Vec<_>>());
            for p in &polys {
                for w in p.windows(2) {
                    let (a, b) = (segs[w[0]], segs[w[1]]);
                    let d = [a.start, a.end].iter().flat_map(|x| [b.start, b.end].map(|y| x.distance(y))).fold(f64::INFINITY, f64::min);
                    prop_assert!(d <= gap + 1e-9);
                }
            }
        }
    }
}
