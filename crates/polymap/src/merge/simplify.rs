//! Simplification (section 2.1): repeatedly merge the cheapest pair, over all pairs and main
//! directions, until the cheapest costs more than `T_s`.
//!
//! The fast version keeps the candidate pairs in a binary heap with lazy invalidation (a pair is
//! dropped when popped if either segment has already merged) and finds the new partners of a
//! merged segment with a `BoxIndex` (an R-tree), so only pairs within the proximity gate are ever costed.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use super::bands::{BandKey, band_m, band_pairs, keys, may_merge};
use super::candidates::{BRUTE_FORCE_PAIRS, boxes_within, grown_box, pairs_within_self_walk_limit};
use super::{MergeParams, best_merge, best_merge_at_most, units};
use crate::geometry::{Segment, Vec2};
use crate::segment_index::BoxIndex;

/// One segment of the simplified set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimplifiedSegment {
    /// The segment.
    pub segment: Segment,
    /// `Some(i)` when this is input segment `i`, untouched; `None` for a merge result.
    pub input: Option<usize>,
}

/// The result of simplification.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Simplified {
    /// Surviving segments: untouched inputs in input order, then merge results in creation order.
    pub segments: Vec<SimplifiedSegment>,
    /// Number of merges made.
    pub merges: usize,
}

/// A candidate merge in the heap, ordered by cost, then by the pair's indices.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    cost: f64,
    i: usize,
    j: usize,
    segment: Segment,
}

impl Candidate {
    fn key(&self) -> (f64, usize, usize) {
        (self.cost, self.i, self.j)
    }
}

impl PartialEq for Candidate {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Candidate {}
impl PartialOrd for Candidate {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Candidate {
    fn cmp(&self, other: &Self) -> Ordering {
        let (a, b) = (self.key(), other.key());
        // Reversed for a min-heap.
        b.0.total_cmp(&a.0).then(b.1.cmp(&a.1)).then(b.2.cmp(&a.2))
    }
}

/// Simplifies a set of segments (any classes) under the main directions.
///
/// ```
/// use polymap::merge::{simplify, MergeParams};
/// use polymap::geometry::{Segment, Vec2};
/// let bundle = [
///     Segment::new(Vec2::new(0.0, 0.0), Vec2::new(2.0, 0.0)),
///     Segment::new(Vec2::new(0.5, 0.02), Vec2::new(2.5, 0.02)),
///     Segment::new(Vec2::new(0.0, 2.0), Vec2::new(0.0, 4.0)),
/// ];
/// let s = simplify(&bundle, &[0.0, std::f64::consts::FRAC_PI_2], &MergeParams::default());
/// assert_eq!(s.merges, 1);
/// assert_eq!(s.segments.len(), 2);
/// ```
pub fn simplify(input: &[Segment], directions_rad: &[f64], params: &MergeParams) -> Simplified {
    simplify_with_walk_limit(input, directions_rad, params, BRUTE_FORCE_PAIRS)
}

/// [`simplify`], finding partners by walking all segments for up to `walk_limit` pairs.
pub(crate) fn simplify_with_walk_limit(
    input: &[Segment],
    directions_rad: &[f64],
    params: &MergeParams,
    walk_limit: usize,
) -> Simplified {
    let directions = units(directions_rad);
    let mut segs: Vec<Segment> = input.to_vec();
    let mut alive = vec![true; segs.len()];
    let mut heap = BinaryHeap::new();
    let push = |heap: &mut BinaryHeap<Candidate>, segs: &[Segment], i: usize, j: usize| {
        if let Some((_, m)) = best_merge_at_most(
            &segs[i],
            &segs[j],
            &directions,
            params.k,
            params.simplify_threshold,
        ) && m.cost <= params.simplify_threshold
        {
            heap.push(Candidate {
                cost: m.cost,
                i,
                j,
                segment: m.segment,
            });
        }
    };
    // Without a proximity gate, the cost's bound finds the pairs that can merge at all.
    let band =
        band_m(params.k, params.simplify_threshold).filter(|_| params.max_gap_m.is_infinite());
    let pairs = match band {
        Some(band) => band_pairs(&segs, None, &directions, band),
        None => pairs_within_self_walk_limit(&segs, params.max_gap_m, walk_limit),
    };
    for (i, j) in pairs {
        push(&mut heap, &segs, i, j);
    }
    let mut boxes: Vec<(Vec2, Vec2)> = segs.iter().map(Segment::bounds).collect();
    let mut band_keys: Vec<Vec<BandKey>> = match band {
        Some(_) => segs.iter().map(|s| keys(s, &directions)).collect(),
        None => Vec::new(),
    };
    // New partners are found by walking all segments while that is cheap, by a `BoxIndex`
    // after (by the band's keys without a proximity gate).
    let mut index = (band.is_none() && segs.len() * segs.len() > walk_limit)
        .then(|| BoxIndex::from_segments(&segs));
    let mut merges = 0;
    while let Some(c) = heap.pop() {
        if !alive[c.i] || !alive[c.j] {
            continue;
        }
        alive[c.i] = false;
        alive[c.j] = false;
        let k = segs.len();
        segs.push(c.segment);
        boxes.push(c.segment.bounds());
        alive.push(true);
        merges += 1;
        let near = |o: &usize| {
            boxes_within(boxes[*o], boxes[k], params.max_gap_m)
                && segs[*o]
                    .distance_to_segment_within(&c.segment, params.max_gap_m)
                    .is_some()
        };
        if let Some(band) = band {
            band_keys.push(keys(&c.segment, &directions));
            let partners =
                (0..k).filter(|o| alive[*o] && may_merge(&band_keys[*o], &band_keys[k], band));
            for o in partners.collect::<Vec<_>>() {
                push(&mut heap, &segs, o, k);
            }
            continue;
        }
        let mut partners: Vec<usize> = match &mut index {
            Some(index) => {
                index.remove(&segs[c.i], c.i);
                index.remove(&segs[c.j], c.j);
                let (lo, hi) = grown_box(&c.segment, params.max_gap_m);
                let found = index.intersecting_iter(lo, hi).filter(near).collect();
                index.insert(&c.segment, k);
                found
            }
            None => (0..k).filter(|o| alive[*o]).filter(near).collect(),
        };
        partners.sort_unstable();
        for o in partners {
            push(&mut heap, &segs, o, k);
        }
    }
    collect(input.len(), &segs, &alive, merges)
}

/// The obviously correct O(n³) version of [`simplify`], as the oracle for tests.
pub fn simplify_brute(
    input: &[Segment],
    directions_rad: &[f64],
    params: &MergeParams,
) -> Simplified {
    let mut segs: Vec<Segment> = input.to_vec();
    let mut alive = vec![true; segs.len()];
    let mut merges = 0;
    loop {
        let mut best: Option<Candidate> = None;
        for i in 0..segs.len() {
            for j in i + 1..segs.len() {
                if !alive[i]
                    || !alive[j]
                    || segs[i].distance_to_segment(&segs[j]) > params.max_gap_m
                {
                    continue;
                }
                // The full cost over every direction: the oracle does not share the pruning.
                if let Some((_, m)) = best_merge(&segs[i], &segs[j], directions_rad, params.k) {
                    let c = Candidate {
                        cost: m.cost,
                        i,
                        j,
                        segment: m.segment,
                    };
                    if m.cost <= params.simplify_threshold && best.is_none_or(|b| c > b) {
                        best = Some(c);
                    }
                }
            }
        }
        let Some(c) = best else { break };
        alive[c.i] = false;
        alive[c.j] = false;
        segs.push(c.segment);
        alive.push(true);
        merges += 1;
    }
    collect(input.len(), &segs, &alive, merges)
}

fn collect(n_input: usize, segs: &[Segment], alive: &[bool], merges: usize) -> Simplified {
    let segments = segs
        .iter()
        .zip(alive)
        .enumerate()
        .filter(|(_, (_, a))| **a)
        .map(|(i, (s, _))| SimplifiedSegment {
            segment: *s,
            input: (i < n_input).then_some(i),
        })
        .collect();
    Simplified { segments, merges }
}
