//! [`BoxIndex`]: an R-tree of segments' bounding boxes, for sets built once and asked a few box
//! queries (see the parent module for when the grid serves instead).

use rstar::primitives::{GeomWithData, Rectangle};
use rstar::{AABB, RTree};

use crate::geometry::{Segment, Vec2};

/// An R-tree entry: a segment's bounding box with its key.
type BoxEntry = GeomWithData<Rectangle<[f64; 2]>, usize>;

fn box_entry(s: &Segment, key: usize) -> BoxEntry {
    let (lo, hi) = s.bounds();
    GeomWithData::new(Rectangle::from_corners([lo.x, lo.y], [hi.x, hi.y]), key)
}

/// Bounding boxes of segments keyed by `usize`, in an R-tree (bulk-loaded): for a set indexed
/// once and asked a few box queries (see the module's measurements). Point sets are indexed as
/// segments of length zero.
///
/// ```
/// use polymap::segment_index::BoxIndex;
/// use polymap::geometry::{Segment, Vec2};
/// let segs = [Segment::new(Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0)), Segment::new(Vec2::new(5.0, 5.0), Vec2::new(6.0, 5.0))];
/// let mut index = BoxIndex::from_segments(&segs);
/// assert_eq!(index.intersecting(Vec2::new(0.5, -1.0), Vec2::new(2.0, 1.0)), vec![0]);
/// index.remove(&segs[0], 0);
/// index.insert(&Segment::new(Vec2::new(1.5, 0.5), Vec2::new(3.0, 0.5)), 2);
/// assert_eq!(index.intersecting(Vec2::new(0.5, -1.0), Vec2::new(2.0, 1.0)), vec![2]);
/// ```
#[derive(Debug, Clone)]
pub struct BoxIndex {
    tree: RTree<BoxEntry>,
}

impl BoxIndex {
    /// The segments of a slice, keyed by their position in it.
    pub fn from_segments(segments: &[Segment]) -> BoxIndex {
        BoxIndex::from_keyed(segments.iter().enumerate().map(|(i, s)| (i, *s)))
    }

    /// Segments with their keys (keys need not be distinct, but [`BoxIndex::remove`] removes one
    /// entry of a key and box).
    pub fn from_keyed(segments: impl IntoIterator<Item = (usize, Segment)>) -> BoxIndex {
        BoxIndex {
            tree: RTree::bulk_load(
                segments
                    .into_iter()
                    .map(|(k, s)| box_entry(&s, k))
                    .collect(),
            ),
        }
    }

    /// Adds a segment under `key`.
    pub fn insert(&mut self, segment: &Segment, key: usize) {
        self.tree.insert(box_entry(segment, key));
    }

    /// Removes the entry of `segment` under `key` (the same segment as inserted); false when
    /// there is none.
    pub fn remove(&mut self, segment: &Segment, key: usize) -> bool {
        self.tree.remove(&box_entry(segment, key)).is_some()
    }

    /// Keys of the segments whose bounding box meets the box `[lo, hi]` (edges included), in
    /// the tree's order.
    pub fn intersecting_iter(&self, lo: Vec2, hi: Vec2) -> impl Iterator<Item = usize> + '_ {
        let envelope = AABB::from_corners([lo.x, lo.y], [hi.x, hi.y]);
        self.tree
            .locate_in_envelope_intersecting(envelope)
            .map(|e| e.data)
    }

    /// [`BoxIndex::intersecting_iter`], sorted.
    pub fn intersecting(&self, lo: Vec2, hi: Vec2) -> Vec<usize> {
        let mut keys: Vec<usize> = self.intersecting_iter(lo, hi).collect();
        keys.sort_unstable();
        keys
    }
}
