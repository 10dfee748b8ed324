//! Nearest-segment queries: an R-tree over map segments, and a brute-force oracle.

use polymap::geometry::{Segment, Vec2};
use rstar::{AABB, PointDistance, RTree, RTreeObject};

/// Beyond this distance from the hinted segment, a plain nearest query is cheaper than
/// collecting every segment within that distance, metres.
const HINT_MAX_DISTANCE_M: f64 = 1.0;

/// The segment nearest to a query point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NearestSegment {
    /// Index of the segment in the slice the index was built from.
    pub index: usize,
    /// Distance from the query point to the segment, metres.
    pub distance_m: f64,
}

/// A segment with its position in the caller's slice, as stored in the R-tree.
#[derive(Debug, Clone, Copy)]
struct IndexedSegment {
    segment: Segment,
    index: usize,
}

impl RTreeObject for IndexedSegment {
    type Envelope = AABB<[f64; 2]>;

    fn envelope(&self) -> Self::Envelope {
        let (lo, hi) = self.segment.bounds();
        AABB::from_corners([lo.x, lo.y], [hi.x, hi.y])
    }
}

impl PointDistance for IndexedSegment {
    fn distance_2(&self, point: &[f64; 2]) -> f64 {
        self.segment
            .distance_2_to_point(Vec2::new(point[0], point[1]))
    }
}

/// An R-tree over segments (all in one frame) answering nearest-segment queries.
///
/// Segments with a non-finite endpoint are left out.
///
/// ```
/// use polymap::geometry::{Segment, Vec2};
/// use polymap_eval::map_quality::SegmentIndex;
/// let segments = [
///     Segment::new(Vec2::new(0.0, 0.0), Vec2::new(4.0, 0.0)),
///     Segment::new(Vec2::new(0.0, 2.0), Vec2::new(4.0, 2.0)),
/// ];
/// let index = SegmentIndex::new(&segments);
/// let n = index.nearest(Vec2::new(1.0, 1.5)).unwrap();
/// assert_eq!(n.index, 1);
/// assert!((n.distance_m - 0.5).abs() < 1e-12);
/// assert!(index.any_within(Vec2::new(5.0, 0.0), 1.0));
/// assert!(!index.any_within(Vec2::new(5.0, 0.0), 0.9));
/// ```
#[derive(Debug, Clone)]
pub struct SegmentIndex {
    tree: RTree<IndexedSegment>,
    /// The caller's segments, by their index, for [`SegmentIndex::nearest_with_hint`].
    segments: Vec<Segment>,
}

impl SegmentIndex {
    /// Builds the index (bulk-loaded, O(n log n)).
    pub fn new(segments: &[Segment]) -> SegmentIndex {
        let items: Vec<IndexedSegment> = segments
            .iter()
            .enumerate()
            .filter(|(_, s)| s.is_finite())
            .map(|(index, segment)| IndexedSegment {
                segment: *segment,
                index,
            })
            .collect();
        SegmentIndex {
            tree: RTree::bulk_load(items),
            segments: segments.to_vec(),
        }
    }

    /// Number of indexed segments.
    pub fn len(&self) -> usize {
        self.tree.size()
    }

    /// True when no segment was indexed.
    pub fn is_empty(&self) -> bool {
        self.tree.size() == 0
    }

    /// The segment nearest to `p`; `None` when the index is empty or `p` is not finite.
    pub fn nearest(&self, p: Vec2) -> Option<NearestSegment> {
        if !p.is_finite() {
            return None;
        }
        let (item, distance_2) = self.tree.nearest_neighbor_with_distance_2([p.x, p.y])?;
        Some(NearestSegment {
            index: item.index,
            distance_m: distance_2.sqrt(),
        })
    }

    /// Like [`SegmentIndex::nearest`], but starts from a guess: the index of a segment likely
    /// to be near (e.g. the nearest one of the previous beam). Much faster on scan points, which
    /// come in runs along the same wall; the answer's distance is the same as without a hint.
    pub fn nearest_with_hint(&self, p: Vec2, hint: Option<usize>) -> Option<NearestSegment> {
        let Some(guess) = hint
            .and_then(|i| self.segments.get(i))
            .filter(|s| s.is_finite())
        else {
            return self.nearest(p);
        };
        let bound_2 = guess.distance_2_to_point(p);
        if !p.is_finite() || bound_2 > HINT_MAX_DISTANCE_M * HINT_MAX_DISTANCE_M {
            return self.nearest(p);
        }
        // Every segment closer than the guess lies within `bound_2`; the guess itself does too.
        let best = self
            .tree
            .locate_within_distance([p.x, p.y], bound_2)
            .map(|item| (item.index, item.segment.distance_2_to_point(p)))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        match best {
            Some((index, d_2)) => Some(NearestSegment {
                index,
                distance_m: d_2.sqrt(),
            }),
            None => self.nearest(p),
        }
    }

    /// True when some segment lies within `max_distance_m` of `p` (inclusive).
    pub fn any_within(&self, p: Vec2, max_distance_m: f64) -> bool {
        p.is_finite()
            && self
                .tree
                .locate_within_distance([p.x, p.y], max_distance_m * max_distance_m)
                .next()
                .is_some()
    }
}

/// The nearest segment by trying every one: the slow, obviously correct oracle for
/// [`SegmentIndex::nearest`]. Ties go to the lowest index; non-finite segments are skipped.
///
/// ```
/// use polymap::geometry::{Segment, Vec2};
/// use polymap_eval::map_quality::nearest_segment_brute_force;
/// let segments = [Segment::new(Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0))];
/// let n = nearest_segment_brute_force(&segments, Vec2::new(2.0, 0.0)).unwrap();
/// assert_eq!((n.index, n.distance_m), (0, 1.0));
/// ```
pub fn nearest_segment_brute_force(segments: &[Segment], p: Vec2) -> Option<NearestSegment> {
    if !p.is_finite() {
        return None;
    }
    let mut best: Option<(usize, f64)> = None;
    for (index, s) in segments.iter().enumerate().filter(|(_, s)| s.is_finite()) {
        let d_2 = s.distance_2_to_point(p);
        if best.is_none_or(|(_, b)| d_2 < b) {
            best = Some((index, d_2));
        }
    }
    best.map(|(index, d_2)| NearestSegment {
        index,
        distance_m: d_2.sqrt(),
    })
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    fn segment() -> impl Strategy<Value = Segment> {
        (-20.0..20.0f64, -20.0..20.0f64, -3.0..3.0f64, -3.0..3.0f64)
            .prop_map(|(x, y, dx, dy)| Segment::new(Vec2::new(x, y), Vec2::new(x + dx, y + dy)))
    }

    proptest! {
        #[test]
        fn rtree_agrees_with_brute_force(
            segments in prop::collection::vec(segment(), 1..60),
            points in prop::collection::vec((-30.0..30.0f64, -30.0..30.0f64), 1..40),
        ) {
            let index = SegmentIndex::new(&segments);
            for (x, y) in points {
                let p = Vec2::new(x, y);
                let fast = index.nearest(p).unwrap();
                let slow = nearest_segment_brute_force(&segments, p).unwrap();
                prop_assert!((fast.distance_m - slow.distance_m).abs() < 1e-12);
                let d_fast = segments[fast.index].distance_to_point(p);
                prop_assert!((d_fast - slow.distance_m).abs() < 1e-12);
                prop_assert_eq!(index.any_within(p, slow.distance_m + 1e-9), true);
                for hint in [Some(0), Some(segments.len() - 1), Some(usize::MAX), None] {
                    let hinted = index.nearest_with_hint(p, hint).unwrap();
                    prop_assert!((hinted.distance_m - slow.distance_m).abs() < 1e-12);
                }
            }
        }
    }

    #[test]
    fn empty_and_non_finite_inputs() {
        let bad = Segment::new(Vec2::new(f64::NAN, 0.0), Vec2::ZERO);
        let index = SegmentIndex::new(&[bad]);
        assert!(index.is_empty());
        assert!(index.nearest(Vec2::ZERO).is_none());
        assert!(nearest_segment_brute_force(&[bad], Vec2::ZERO).is_none());
        let ok = SegmentIndex::new(&[Segment::new(Vec2::ZERO, Vec2::X)]);
        assert!(ok.nearest(Vec2::new(f64::NAN, 0.0)).is_none());
        assert!(!ok.any_within(Vec2::new(f64::INFINITY, 0.0), 1.0));
    }
}
