//! ICP's nearest-segment queries, answered by the workspace's one index
//! ([`crate::segment_index::SegmentIndex`]); the map ([`crate::map::GlobalMap`]) answers them
//! through the same index.

use crate::geometry::{Segment, SegmentProjection, Vec2};
use crate::segment_index::{NearestCertificate, SegmentIndex};

/// ICP against a fixed set of segments, e.g. `SegmentIndex::from_segments(&walls, 0.5, 1.0)`;
/// ties go to the smaller key.
impl<K: Copy + Ord> super::SegmentLookup for SegmentIndex<K> {
    fn nearest_segment(
        &self,
        p: Vec2,
        max_distance_m: f64,
    ) -> Option<(Segment, SegmentProjection)> {
        self.nearest(p, max_distance_m).map(|(_, s, pr)| (s, pr))
    }

    fn nearest_segment_only(&self, p: Vec2, max_distance_m: f64) -> Option<Segment> {
        SegmentIndex::nearest_segment(self, p, max_distance_m).map(|(_, s)| s)
    }

    fn nearest_certified(&self, p: Vec2) -> Option<NearestCertificate> {
        Some(SegmentIndex::nearest_certified(self, p))
    }
}
