//! The global map `G_t`: segments with their birth scan, a spatial index, the queue of
//! recent births that the main directions are computed from, and what later scans observed of
//! each segment ([`Observations`], kept beside the segments, see [`crate::observe`]).

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

/// What the scans observed of one map segment (see [`crate::observe`]): when it was last seen
/// and how often laser rays passed through where it stands.
///
/// Counts are in *observing scans* (scans that [`crate::observe::observe_scan`] looked with),
/// not rays: a scan counts once per segment, as seeing it when one of its rays ends on it, else
/// as seeing through it when its rays cross it. A segment a merge makes at scan `t` starts as
/// seen at `t` ([`Observations::born`]).
///
/// ```
/// use polymap::map::Observations;
/// let mut o = Observations::born(3);
/// o.saw_through();
/// o.saw_through();
/// assert_eq!((o.seen, o.seen_through, o.through_since_seen), (1, 2, 2));
/// o.saw(9);
/// assert_eq!((o.last_seen_scan, o.seen, o.through_since_seen), (9, 2, 0));
/// // A scan tracked `weak` sees it: seen, but no support; the same scan again counts once.
/// o.saw_by(12, false);
/// o.saw_by(12, false);
/// assert_eq!((o.seen, o.support()), (3, 2));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Observations {
    /// 0-based index of the last scan that saw the segment (a ray ended on it, or its merge
    /// made it).
    pub last_seen_scan: u32,
    /// Scans that saw the segment, its making included.
    pub seen: u32,
    /// Scans whose rays passed through the segment (and none ended on it).
    pub seen_through: u32,
    /// Of `seen_through`, the scans after `last_seen_scan`: the evidence against the segment
    /// that no sighting has answered since.
    pub through_since_seen: u32,
    /// Of `seen`, the scans tracked `ok` (a confident fit, every direction observed): the
    /// sightings trusted to place the segment (its support in a merge,
    /// [`crate::merge::MergeParams::support_cap`]). `None` in a record read from a map written
    /// before it was kept: there every sighting counts ([`Observations::support`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub confirmed: Option<u32>,
}

impl Observations {
    /// The record of a segment made (so seen) by the merge of scan `t`, a scan tracked `ok`.
    pub fn born(t: u32) -> Self {
        Self::born_by(t, true)
    }

    /// The record of a segment made (so seen) by the merge of scan `t`; `confirmed`: the scan
    /// was tracked `ok`.
    pub fn born_by(t: u32, confirmed: bool) -> Self {
        Observations {
            last_seen_scan: t,
            seen: 1,
            seen_through: 0,
            through_since_seen: 0,
            confirmed: Some(u32::from(confirmed)),
        }
    }

    /// Scan `t`, tracked `ok`, saw the segment ([`Observations::saw_by`]).
    pub fn saw(&mut self, t: u32) {
        self.saw_by(t, true);
    }

    /// Scan `t` saw the segment (a scan counts once: the merge that made the segment at `t`
    /// and the rays of the same scan are one sighting); `confirmed`: the scan was tracked `ok`.
    pub fn saw_by(&mut self, t: u32, confirmed: bool) {
        if self.seen == 0 || self.last_seen_scan != t {
            let support = self.support().saturating_add(u32::from(confirmed));
            self.seen = self.seen.saturating_add(1);
            self.confirmed = Some(support.min(self.seen));
        }
        self.last_seen_scan = self.last_seen_scan.max(t);
        self.through_since_seen = 0;
    }

    /// The sightings that place the segment: `confirmed`, or every sighting (`seen`) in a
    /// record from before `confirmed` was kept.
    pub fn support(&self) -> u32 {
        self.confirmed.unwrap_or(self.seen)
    }

    /// A scan saw through the segment.
    pub fn saw_through(&mut self) {
        self.seen_through = self.seen_through.saturating_add(1);
        self.through_since_seen = self.through_since_seen.saturating_add(1);
    }

    /// The record of a segment made of parts with records `parts`, none seen now: the latest
    /// sighting and the largest counts (the parts overlap in time, so a sum would count the
    /// same scans twice), and the contradictions all parts share (the fewest); `None` for no
    /// parts.
    pub fn combined(parts: impl IntoIterator<Item = Observations>) -> Option<Self> {
        parts.into_iter().reduce(|a, b| Observations {
            last_seen_scan: a.last_seen_scan.max(b.last_seen_scan),
            seen: a.seen.max(b.seen),
            seen_through: a.seen_through.max(b.seen_through),
            through_since_seen: a.through_since_seen.min(b.through_since_seen),
            confirmed: match (a.confirmed, b.confirmed) {
                (None, None) => None,
                _ => Some(a.support().max(b.support())),
            },
        })
    }

    /// The record of a segment that the merge of scan `t` made from segments with records
    /// `sources` and the scan's own sighting: [`Observations::combined`], seen at `t`
    /// (`confirmed`: the scan was tracked `ok`).
    pub fn merged(
        t: u32,
        confirmed: bool,
        sources: impl IntoIterator<Item = Observations>,
    ) -> Self {
        let mut o = Observations::combined(sources).unwrap_or_default();
        o.saw_by(t, confirmed);
        o
    }
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
    /// The observation record of each slot's segment (parallel to `slots`).
    observed: Vec<Observations>,
    /// The pose of the last scan that observed the map (see [`crate::observe`]).
    observed_from: Option<crate::geometry::Pose2>,
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
            observed: Vec::new(),
            observed_from: None,
            free: Vec::new(),
            grid: SegmentIndex::new(cell_m, reach_m),
            recent: Vec::new(),
            len: 0,
        }
    }

    /// An empty map indexed like this one (same cell and reach).
    pub fn empty_like(&self) -> Self {
        GlobalMap::new(self.grid.cell_m(), self.grid.reach_m())
    }

    /// Number of segments.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when the map has no segments.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Adds a segment, seen at its birth scan ([`Observations::born`]), and returns its handle.
    pub fn insert(&mut self, s: MapSegment) -> SegmentId {
        self.insert_observed(s, Observations::born(s.born_scan))
    }

    /// Adds a segment with its observation record and returns its handle.
    pub fn insert_observed(&mut self, s: MapSegment, observations: Observations) -> SegmentId {
        let id = match self.free.pop() {
            Some(slot) => {
                let entry = &mut self.slots[slot as usize];
                entry.0 += 1;
                entry.1 = Some(s);
                self.observed[slot as usize] = observations;
                SegmentId {
                    slot,
                    generation: entry.0,
                }
            }
            None => {
                self.slots.push((0, Some(s)));
                self.observed.push(observations);
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

    /// The observation record of a segment, if it is still in the map.
    pub fn observations(&self, id: SegmentId) -> Option<Observations> {
        self.get(id)?;
        self.observed.get(id.slot as usize).copied()
    }

    /// The observation record of a segment to update, if it is still in the map.
    pub fn observations_mut(&mut self, id: SegmentId) -> Option<&mut Observations> {
        self.get(id)?;
        self.observed.get_mut(id.slot as usize)
    }

    /// The pose (map frame) of the last scan that observed the map, see [`crate::observe`].
    pub fn observed_from(&self) -> Option<crate::geometry::Pose2> {
        self.observed_from
    }

    /// Records the pose (map frame) of a scan that observed the map.
    pub fn set_observed_from(&mut self, map_from_robot: crate::geometry::Pose2) {
        self.observed_from = Some(map_from_robot);
    }

    /// Moves segments to new places, keeping their birth and observation records: all are
    /// removed first, then inserted in the order given (so handles are reused as a removal
    /// and re-insertion in that order would reuse them). Stale handles are skipped.
    pub fn move_segments(&mut self, moves: &[(SegmentId, Segment)]) {
        let taken: Vec<_> = moves
            .iter()
            .map(|(id, to)| {
                let record = self.observations(*id);
                self.remove(*id).zip(record).map(|(s, o)| (s, o, *to))
            })
            .collect();
        for (s, o, to) in taken.into_iter().flatten() {
            self.insert_observed(
                MapSegment {
                    segment: to,
                    born_scan: s.born_scan,
                },
                o,
            );
        }
    }

    /// Handles of the segments that cross the box `[lo, hi]` (map frame, metres), and possibly
    /// some that only come within the grid's reach of it; sorted.
    pub fn query(&self, lo: Vec2, hi: Vec2) -> Vec<SegmentId> {
        // A segment is listed in every grid cell within reach of it (tens of cells): marking
        // its slot once seen leaves only the distinct handles to sort (the search raster's box
        // spans hundreds of cells; sorting every listing would cost about 4 % of a sparse run).
        let mut seen = vec![0u64; self.slots.len().div_ceil(64)];
        let mut ids = Vec::new();
        self.grid.for_keys_in_box(lo, hi, |id: SegmentId| {
            let slot = id.slot as usize;
            // The grid holds exactly the live handles, one per slot.
            debug_assert!(slot < self.slots.len());
            if let Some(word) = seen.get_mut(slot / 64) {
                let bit = 1u64 << (slot % 64);
                if *word & bit == 0 {
                    *word |= bit;
                    ids.push(id);
                }
            }
        });
        ids.sort_unstable();
        ids
    }

    /// The handle of the segment nearest `p` within `max_distance_m` (map frame, metres);
    /// ties go to the smaller handle.
    pub fn nearest_id(&self, p: Vec2, max_distance_m: f64) -> Option<SegmentId> {
        self.grid.nearest(p, max_distance_m).map(|(id, _, _)| id)
    }

    /// Calls `f` with every segment (handle and segment, map frame) that may cross segment
    /// `a`–`b`: a superset of those that do, some possibly more than once; see
    /// [`SegmentIndex::for_crossing_candidates`].
    pub fn for_crossing_candidates(&self, a: Vec2, b: Vec2, f: impl FnMut(SegmentId, &Segment)) {
        self.grid.for_crossing_candidates(a, b, f)
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

    /// The query's own dedup (a slot marked once seen) gives exactly the grid's sorted,
    /// deduplicated box query, through removals and slot reuse.
    #[test]
    fn query_is_the_grids_box_query_once_each_and_sorted() {
        let mut map = GlobalMap::default();
        let mut ids = Vec::new();
        for i in 0..40 {
            let (x, y) = ((i % 8) as f64 * 1.3, (i / 8) as f64 * 0.9);
            let segment = Segment::new(Vec2::new(x, y), Vec2::new(x + 2.5, y + 0.7));
            ids.push(map.insert(MapSegment {
                segment,
                born_scan: i,
            }));
        }
        for id in ids.iter().step_by(3) {
            map.remove(*id);
        }
        for i in 0..5 {
            map.insert(ms(i as f64 * 2.0, 50));
        }
        for (lo, hi) in [
            (Vec2::new(-1.0, -1.0), Vec2::new(20.0, 10.0)),
            (Vec2::new(2.0, 1.0), Vec2::new(4.0, 2.0)),
            (Vec2::new(30.0, 30.0), Vec2::new(31.0, 31.0)),
        ] {
            let found = map.query(lo, hi);
            assert_eq!(found, map.grid.in_box(lo, hi));
            assert!(found.windows(2).all(|w| w[0] < w[1]));
            assert!(found.iter().all(|id| map.get(*id).is_some()));
        }
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

    #[test]
    fn records_follow_their_segments_through_moves_and_slot_reuse() {
        let mut map = GlobalMap::default();
        let a = map.insert(ms(0.0, 2));
        let b = map.insert(ms(3.0, 4));
        map.observations_mut(a).unwrap().saw_through();
        map.move_segments(&[(a, Segment::new(Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0)))]);
        assert!(map.observations(a).is_none());
        let moved: Vec<_> = map
            .iter()
            .map(|(id, s)| (s.born_scan, map.observations(id)))
            .collect();
        let mut want = Observations::born(2);
        want.saw_through();
        assert!(moved.contains(&(2, Some(want))));
        assert_eq!(map.observations(b), Some(Observations::born(4)));
        map.remove(b);
        let c = map.insert(ms(9.0, 7));
        assert_eq!(map.observations(c), Some(Observations::born(7)));
    }
}
