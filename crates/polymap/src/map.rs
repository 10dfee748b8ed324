//! The global map `G_t`: segments with their birth scan, a spatial index, and the queue of
//! recent births that the main directions are computed from.

use serde::{Deserialize, Serialize};

use crate::align::SegmentLookup;
use crate::check::{Checks, InvalidParam};
use crate::geometry::{Segment, SegmentProjection, Vec2};
use crate::segment_index::{NearestCertificate, SegmentIndex};

/// Parameters of the map store (section `[map]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MapParams {
    /// Cell size of the map's grid index (and of the loop closer's submap indexes), metres;
    /// speed only, results do not depend on it.
    pub grid_cell_m: f64,
}

impl Default for MapParams {
    fn default() -> Self {
        MapParams { grid_cell_m: 0.5 }
    }
}

impl MapParams {
    /// Checks every key's range; the error names the first key out of range.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        Checks::new()
            .within("grid_cell_m", self.grid_cell_m, 0.05, 100.0)
            .done()
    }
}

/// One segment of the global map, in the map frame, with its provenance.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MapSegment {
    /// The segment, metres, map frame.
    pub segment: Segment,
    /// Index (0-based, in processing order) of the scan whose merge created this segment.
    pub born_scan: u32,
}

/// A handle to a map segment; stale handles (of removed segments) are detected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SegmentId {
    slot: u32,
    generation: u32,
}

/// The global map.
///
/// ```
/// use polymap::map::{GlobalMap, MapSegment};
/// use polymap::geometry::{Segment, Vec2};
/// let mut map = GlobalMap::default();
/// let id = map.insert(MapSegment { segment: Segment::new(Vec2::ZERO, Vec2::X), born_scan: 0 });
/// assert_eq!(map.len(), 1);
/// assert_eq!(map.query(Vec2::new(-1.0, -1.0), Vec2::new(0.5, 0.5)), vec![id]);
/// map.remove(id);
/// assert!(map.is_empty() && map.get(id).is_none());
/// ```
#[derive(Debug, Clone)]
pub struct GlobalMap {
    slots: Vec<(u32, Option<MapSegment>)>,
    free: Vec<u32>,
    grid: SegmentIndex<SegmentId>,
    recent: Vec<(u32, SegmentId)>,
    len: usize,
}

impl Default for GlobalMap {
    /// 0.5 m cells answering nearest queries up to 1 m from one cell.
    fn default() -> Self {
        GlobalMap::new(0.5, 1.0)
    }
}

impl GlobalMap {
    /// An empty map indexed by a grid of `cell_m` cells answering nearest-segment queries up to
    /// `reach_m` from a single cell (further queries stay exact, only slower); metres.
    pub fn new(cell_m: f64, reach_m: f64) -> Self {
        GlobalMap {
            slots: Vec::new(),
            free: Vec::new(),
            grid: SegmentIndex::new(cell_m, reach_m),
            recent: Vec::new(),
            len: 0,
        }
    }

    /// An empty map indexed like this one (same cell and reach).
    pub fn empty_like(&self) -> Self {
        GlobalMap {
            slots: Vec::new(),
            free: Vec::new(),
            grid: SegmentIndex::new(self.grid.cell_m(), self.grid.reach_m()),
            recent: Vec::new(),
            len: 0,
        }
    }

    /// Number of segments.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when the map has no segments.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Adds a segment and returns its handle.
    pub fn insert(&mut self, s: MapSegment) -> SegmentId {
        let id = match self.free.pop() {
            Some(slot) => {
                let entry = &mut self.slots[slot as usize];
                entry.0 += 1;
                entry.1 = Some(s);
                SegmentId {
                    slot,
                    generation: entry.0,
                }
            }
            None => {
                self.slots.push((0, Some(s)));
                SegmentId {
                    slot: (self.slots.len() - 1) as u32,
                    generation: 0,
                }
            }
        };
        self.grid.insert(id, s.segment);
        self.recent.push((s.born_scan, id));
        self.len += 1;
        id
    }

    /// Removes a segment; `None` when the handle is stale.
    pub fn remove(&mut self, id: SegmentId) -> Option<MapSegment> {
        let slot = self.slots.get_mut(id.slot as usize)?;
        if slot.0 != id.generation {
            return None;
        }
        let s = slot.1.take()?;
        self.grid.remove(id, &s.segment);
        self.free.push(id.slot);
        self.len -= 1;
        Some(s)
    }

    /// The segment behind a handle, if it is still in the map.
    pub fn get(&self, id: SegmentId) -> Option<&MapSegment> {
        let slot = self.slots.get(id.slot as usize)?;
        if slot.0 == id.generation {
            slot.1.as_ref()
        } else {
            None
        }
    }

    /// Handles of the segments that cross the box `[lo, hi]` (map frame, metres), and possibly
    /// some that only come within the grid's reach of it; sorted.
    pub fn query(&self, lo: Vec2, hi: Vec2) -> Vec<SegmentId> {
        self.grid.in_box(lo, hi)
    }

    /// Handles of the segments within `margin_m` of segment `s` (map frame), sorted.
    pub fn near_segment(&self, s: &Segment, margin_m: f64) -> Vec<SegmentId> {
        self.grid.near_segment(s, margin_m)
    }

    /// All segments, in handle order.
    pub fn iter(&self) -> impl Iterator<Item = (SegmentId, &MapSegment)> {
        self.slots
            .iter()
            .enumerate()
            .filter_map(|(i, (generation, s))| {
                s.as_ref().map(|s| {
                    (
                        SegmentId {
                            slot: i as u32,
                            generation: *generation,
                        },
                        s,
                    )
                })
            })
    }

    /// The segments born at or after scan `since` (`G_{t-1}(tm)` for `since = t − tm`).
    ///
    /// Forgets older births and removed segments as a side effect, so the cost stays
    /// proportional to the recent part of the map.
    pub fn born_since(&mut self, since: u32) -> Vec<Segment> {
        let slots = &self.slots;
        let live = |id: &SegmentId| {
            slots[id.slot as usize].0 == id.generation && slots[id.slot as usize].1.is_some()
        };
        self.recent.retain(|(b, id)| *b >= since && live(id));
        self.recent
            .iter()
            .filter_map(|(_, id)| self.get(*id))
            .map(|s| s.segment)
            .collect()
    }
}

impl SegmentLookup for GlobalMap {
    /// Ties go to the smaller handle.
    fn nearest_segment(
        &self,
        p: Vec2,
        max_distance_m: f64,
    ) -> Option<(Segment, SegmentProjection)> {
        self.grid
            .nearest(p, max_distance_m)
            .map(|(_, s, pr)| (s, pr))
    }

    fn nearest_segment_only(&self, p: Vec2, max_distance_m: f64) -> Option<Segment> {
        self.grid.nearest_segment(p, max_distance_m).map(|(_, s)| s)
    }

    fn nearest_certified(&self, p: Vec2) -> Option<NearestCertificate> {
        Some(self.grid.nearest_certified(p))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(x: f64, born: u32) -> MapSegment {
        MapSegment {
            segment: Segment::new(Vec2::new(x, 0.0), Vec2::new(x + 1.0, 0.0)),
            born_scan: born,
        }
    }

    #[test]
    fn stale_handles_are_detected_after_slot_reuse() {
        let mut map = GlobalMap::default();
        let a = map.insert(ms(0.0, 0));
        map.remove(a);
        let b = map.insert(ms(5.0, 1));
        assert_ne!(a, b);
        assert!(map.get(a).is_none() && map.remove(a).is_none());
        assert_eq!(map.get(b).map(|s| s.born_scan), Some(1));
    }

    #[test]
    fn born_since_returns_only_recent_live_segments() {
        let mut map = GlobalMap::default();
        map.insert(ms(0.0, 0));
        let dead = map.insert(ms(1.0, 3));
        map.insert(ms(2.0, 5));
        map.remove(dead);
        let recent = map.born_since(2);
        assert_eq!(recent.len(), 1);
        assert_eq!(recent[0].start.x, 2.0);
    }
}
