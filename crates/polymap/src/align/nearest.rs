//! Nearest-segment queries for ICP.

use rstar::RTree;
use rstar::primitives::{GeomWithData, Line};

use crate::geometry::{Segment, SegmentProjection, Vec2};

/// The nearest segment to a query point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NearestSegment {
    /// Index of the segment in the indexed slice.
    pub index: usize,
    /// Where the query point projects onto it.
    pub projection: SegmentProjection,
}

/// An R-tree over a set of segments answering nearest-segment queries.
///
/// ```
/// use polymap::align::SegmentIndex;
/// use polymap::geometry::{Segment, Vec2};
/// let segs = vec![Segment::new(Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0)), Segment::new(Vec2::new(0.0, 2.0), Vec2::new(1.0, 2.0))];
/// let index = SegmentIndex::new(segs);
/// let hit = index.nearest(Vec2::new(0.5, 1.5), 1.0).unwrap();
/// assert_eq!(hit.index, 1);
/// assert!(index.nearest(Vec2::new(0.5, 5.0), 1.0).is_none());
/// ```
pub struct SegmentIndex {
    segments: Vec<Segment>,
    tree: RTree<GeomWithData<Line<[f64; 2]>, usize>>,
}

impl SegmentIndex {
    /// Indexes the segments.
    pub fn new(segments: Vec<Segment>) -> Self {
        let items = segments
            .iter()
            .enumerate()
            .map(|(i, s)| {
                GeomWithData::new(Line::new([s.start.x, s.start.y], [s.end.x, s.end.y]), i)
            })
            .collect();
        SegmentIndex {
            tree: RTree::bulk_load(items),
            segments,
        }
    }

    /// The indexed segments.
    pub fn segments(&self) -> &[Segment] {
        &self.segments
    }

    /// The nearest segment within `max_distance_m` of `p`; ties go to the lower index.
    pub fn nearest(&self, p: Vec2, max_distance_m: f64) -> Option<NearestSegment> {
        let mut best: Option<NearestSegment> = None;
        for (e, d_2) in self.tree.nearest_neighbor_iter_with_distance_2([p.x, p.y]) {
            if d_2 > max_distance_m * max_distance_m
                || best.is_some_and(|b| d_2 > b.projection.distance_2)
            {
                break;
            }
            let projection = self.segments[e.data].project(p);
            if best.is_none_or(|b| {
                (projection.distance_2, e.data) < (b.projection.distance_2, b.index)
            }) {
                best = Some(NearestSegment {
                    index: e.data,
                    projection,
                });
            }
        }
        best
    }
}

/// The obviously correct version of [`SegmentIndex::nearest`], for tests.
#[cfg(test)]
pub fn nearest_brute(segments: &[Segment], p: Vec2, max_distance_m: f64) -> Option<NearestSegment> {
    segments
        .iter()
        .enumerate()
        .map(|(index, s)| NearestSegment {
            index,
            projection: s.project(p),
        })
        .filter(|n| n.projection.distance_2 <= max_distance_m * max_distance_m)
        .min_by(|a, b| {
            a.projection
                .distance_2
                .total_cmp(&b.projection.distance_2)
                .then(a.index.cmp(&b.index))
        })
}

impl super::SegmentLookup for SegmentIndex {
    fn nearest_segment(
        &self,
        p: Vec2,
        max_distance_m: f64,
    ) -> Option<(Segment, SegmentProjection)> {
        self.nearest(p, max_distance_m)
            .map(|n| (self.segments[n.index], n.projection))
    }
}
