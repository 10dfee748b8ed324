//! The spatial index over segments, the one home of every nearest-segment and box query in the
//! workspace:
//!
//! - [`SegmentIndex`]: a uniform grid answering nearest-segment queries within a bounded reach
//!   from one cell, certified nearest queries, the nearest segment at any distance, segments
//!   near a segment and box queries; it follows insertions and removals. The map
//!   (`map::GlobalMap`, also the loop closer's submaps), ICP's tests and the evaluation use it.
//! - [`BoxIndex`]: an R-tree of bounding boxes for sets built once and asked a few box queries
//!   (the merge's candidate pairs, vertex insertion and simplification; the polylines' endpoint
//!   matching).
//!
//! Measured on the same queries (`benches/segment_index.rs`, Intel's map of 298 segments at scan
//! 5000): a nearest segment within 1 m costs the grid 0.08 µs, the R-trees 0.82–0.86 µs; a box
//! query with the exact test after it 0.88 µs (grid without reach) against 0.77 µs (R-tree); but
//! indexing the map takes the R-tree 62 µs, the grid 267 µs without reach and 1.9 ms with the
//! map's 1 m reach. So the grid where a set lives long and is asked for nearest segments, the
//! R-tree where a set is indexed for a handful of box queries.
//!
//! # The grid
//!
//! Each cell lists every segment that comes within `reach_m` of it, so a nearest query within
//! the reach looks at one cell only: one hash lookup and a few exact projections, where an
//! R-tree walks a heap. The grid follows the map through insertions and removals; cells exist
//! only where segments are (and, at most as many again, where a removal emptied them since the
//! last sweep, kept for the insertion that usually follows), so memory grows with the mapped
//! area, not with a bounding box.

use rustc_hash::FxHashMap;
use std::collections::hash_map::Entry as CellEntry;

use crate::geometry::{Segment, SegmentProjection, Vec2, floor_i64};

/// Cell coordinates: `i64`, so that any coordinate a log can hold (up to about 4e18 m at the
/// default cell size) still indexes.
type Cell = (i64, i64);

/// A segment in a cell, with what the nearest query needs precomputed.
#[derive(Debug, Clone, Copy)]
struct Entry<K> {
    key: K,
    segment: Segment,
    /// `end − start`.
    vector: Vec2,
    /// `1 / |end − start|²`, 0 for a degenerate segment.
    inv_len_2: f64,
    /// A lower bound of the squared distance from any point of the cell to the segment, m².
    /// Lists are sorted by it, so a query can stop at the first entry that cannot be nearer.
    floor_2: f64,
}

impl<K> Entry<K> {
    /// The entry of `segment` in a cell whose centre is `centre_distance_m` from it, for cells
    /// of half-diagonal `half_diagonal_m` (metres).
    fn new(key: K, segment: Segment, centre_distance_m: f64, half_diagonal_m: f64) -> Self {
        let vector = segment.vector();
        let len_2 = vector.length_squared();
        // Triangle inequality, shrunk by a relative hair against rounding.
        let floor = ((centre_distance_m - half_diagonal_m) * (1.0 - 1e-9)).max(0.0);
        Entry {
            key,
            segment,
            vector,
            inv_len_2: if len_2 > 0.0 { 1.0 / len_2 } else { 0.0 },
            floor_2: floor * floor,
        }
    }

    /// Squared distance from `p` and the projection parameter, as `Segment::project` computes
    /// them, without a division.
    #[inline]
    fn distance_2(&self, p: Vec2) -> (f64, f64) {
        let w = p - self.segment.start;
        let t = (w.dot(self.vector) * self.inv_len_2).clamp(0.0, 1.0);
        ((w - self.vector * t).length_squared(), t)
    }
}

/// What a search for the nearest segment to a point `at` found: the nearest segment (if any
/// within the grid's reach) and a distance that every other segment is at least as far from
/// `at`. Near `at`, it answers the same query again without a search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NearestCertificate {
    at: Vec2,
    /// Distance from `at` (metres), the segment, `end − start`, `1 / |end − start|²`.
    nearest: Option<(f64, Segment, Vec2, f64)>,
    /// Every segment but the nearest is at least this far from `at`, metres.
    clear_m: f64,
}

impl NearestCertificate {
    /// The answer of a search for the nearest segment within `max_distance_m` of `p`, when the
    /// certificate decides it: `p` has not moved far enough from `at` for another segment to
    /// come as near as the nearest. `None` when a new search is needed.
    ///
    /// The answer is the one the search would give: the gate is applied to the same squared
    /// distance, computed the same way.
    pub fn answer(&self, p: Vec2, max_distance_m: f64) -> Option<Option<Segment>> {
        let moved = (p - self.at).length();
        // A hair for the rounding of the distances compared.
        let hair = 1e-9 * (1.0 + self.clear_m);
        match self.nearest {
            Some((near_m, segment, vector, inv_len_2)) => {
                if near_m + 2.0 * moved + hair >= self.clear_m {
                    return None;
                }
                let w = p - segment.start;
                let t = (w.dot(vector) * inv_len_2).clamp(0.0, 1.0);
                let d_2 = (w - vector * t).length_squared();
                Some((d_2 <= max_distance_m * max_distance_m).then_some(segment))
            }
            // The search squares the distance it is given, so a negative one acts as its size.
            None => (max_distance_m.abs() + moved + hair < self.clear_m).then_some(None),
        }
    }
}

/// Segments keyed by `K`, bucketed in square cells.
///
/// ```
/// use polymap::segment_index::SegmentIndex;
/// use polymap::geometry::{Segment, Vec2};
/// let mut grid = SegmentIndex::new(0.5, 1.0);
/// grid.insert(7u32, Segment::new(Vec2::new(0.0, 0.0), Vec2::new(4.0, 0.0)));
/// let (key, _, p) = grid.nearest(Vec2::new(2.0, 0.3), 1.0).unwrap();
/// assert_eq!(key, 7);
/// assert!((p.distance_2 - 0.09).abs() < 1e-12);
/// assert!(grid.nearest(Vec2::new(2.0, 3.0), 1.0).is_none());
/// ```
#[derive(Debug, Clone)]
pub struct SegmentIndex<K> {
    cell_m: f64,
    reach_m: f64,
    cells: FxHashMap<Cell, Vec<Entry<K>>>,
    /// Cells whose list a removal emptied, kept (with their allocation, but in a copy) for the
    /// insertions that follow (a merge removes a segment and inserts its successor over the
    /// same cells); swept when they outnumber the occupied cells, so the cells listed stay
    /// within twice the occupied ones.
    empty_cells: usize,
}

impl SegmentIndex<usize> {
    /// The segments of a slice, keyed by their position in it, in a grid of `cell_m` cells
    /// answering single-cell queries up to `reach_m` (both metres).
    ///
    /// ```
    /// use polymap::segment_index::SegmentIndex;
    /// use polymap::geometry::{Segment, Vec2};
    /// let segs = [Segment::new(Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0)), Segment::new(Vec2::new(0.0, 2.0), Vec2::new(1.0, 2.0))];
    /// let index = SegmentIndex::from_segments(&segs, 0.5, 1.0);
    /// assert_eq!(index.nearest(Vec2::new(0.5, 1.5), 1.0).map(|n| n.0), Some(1));
    /// assert!(index.nearest(Vec2::new(0.5, 5.0), 1.0).is_none());
    /// assert_eq!(index.nearest_anywhere(Vec2::new(0.5, 5.0)).map(|n| n.0), Some(1));
    /// ```
    pub fn from_segments(segments: &[Segment], cell_m: f64, reach_m: f64) -> SegmentIndex<usize> {
        let mut index = SegmentIndex::new(cell_m, reach_m);
        for (i, s) in segments.iter().enumerate() {
            index.insert(i, *s);
        }
        index
    }
}

impl<K: Copy + Ord> SegmentIndex<K> {
    /// A grid of `cell_m` cells answering single-cell queries up to `reach_m` (both metres).
    pub fn new(cell_m: f64, reach_m: f64) -> Self {
        let cell_m = if cell_m.is_finite() && cell_m > 0.0 {
            cell_m
        } else {
            0.5
        };
        SegmentIndex {
            cell_m,
            reach_m: reach_m.max(0.0),
            cells: FxHashMap::default(),
            empty_cells: 0,
        }
    }

    /// True when no segment is indexed.
    pub fn is_empty(&self) -> bool {
        self.cells.len() == self.empty_cells
    }

    /// The cell size, metres.
    pub fn cell_m(&self) -> f64 {
        self.cell_m
    }

    /// The largest query distance answered from a single cell, metres.
    pub fn reach_m(&self) -> f64 {
        self.reach_m
    }

    fn cell_of(&self, p: Vec2) -> Cell {
        cell_of(self.cell_m, p)
    }

    /// Calls `f` with the cells a segment is listed in and their centre's distance from it:
    /// those whose centre lies within reach plus half a cell diagonal of it (and a relative
    /// hair, so that rounding cannot leave out a cell the segment passes through when the
    /// reach is 0).
    fn cells_of(cell_m: f64, reach_m: f64, s: &Segment, f: impl FnMut(Cell, f64)) {
        let limit = (reach_m + half_diagonal_m(cell_m)) * (1.0 + 1e-9);
        cells_around(cell_m, s, reach_m + cell_m, limit, f)
    }

    fn half_diagonal_m(&self) -> f64 {
        half_diagonal_m(self.cell_m)
    }

    /// Adds a segment under `key`. A segment with a non-finite endpoint is not indexed (no
    /// query finds it).
    pub fn insert(&mut self, key: K, segment: Segment) {
        if !segment.is_finite() {
            return;
        }
        let half_diagonal = self.half_diagonal_m();
        let (cells, empty_cells) = (&mut self.cells, &mut self.empty_cells);
        Self::cells_of(self.cell_m, self.reach_m, &segment, |c, centre_distance| {
            let entry = Entry::new(key, segment, centre_distance, half_diagonal);
            let list = match cells.entry(c) {
                CellEntry::Occupied(kept) => {
                    let list = kept.into_mut();
                    if list.is_empty() {
                        *empty_cells -= 1;
                    }
                    list
                }
                CellEntry::Vacant(new) => new.insert(Vec::new()),
            };
            let at = list.partition_point(|e| e.floor_2 <= entry.floor_2);
            list.insert(at, entry);
        });
    }

    /// Removes the segment stored under `key` (pass the same segment as inserted).
    pub fn remove(&mut self, key: K, segment: &Segment) {
        if !segment.is_finite() {
            return;
        }
        let (cells, empty_cells) = (&mut self.cells, &mut self.empty_cells);
        Self::cells_of(self.cell_m, self.reach_m, segment, |c, _| {
            if let Some(list) = cells.get_mut(&c)
                && let Some(i) = list.iter().position(|e| e.key == key)
            {
                list.remove(i); // keeps the order by distance floor
                if list.is_empty() {
                    *empty_cells += 1;
                }
            }
        });
        if 2 * self.empty_cells > self.cells.len() {
            self.cells.retain(|_, list| !list.is_empty());
            self.empty_cells = 0;
        }
    }

    /// The nearest segment within `max_distance_m` of `p`, with the projection of `p` onto it;
    /// ties go to the smaller key.
    pub fn nearest(&self, p: Vec2, max_distance_m: f64) -> Option<(K, Segment, SegmentProjection)> {
        self.nearest_entry(p, max_distance_m)
            .map(|e| (e.key, e.segment, e.segment.project(p)))
    }

    /// [`SegmentIndex::nearest`] without the projection: the key and the segment.
    pub fn nearest_segment(&self, p: Vec2, max_distance_m: f64) -> Option<(K, Segment)> {
        self.nearest_entry(p, max_distance_m)
            .map(|e| (e.key, e.segment))
    }

    fn nearest_entry<'a>(&'a self, p: Vec2, max_distance_m: f64) -> Option<&'a Entry<K>> {
        let max_2 = max_distance_m * max_distance_m;
        let mut best: Option<(f64, &'a Entry<K>)> = None;
        // Within `p`'s own cell the floors bound the distance from `p`: entries come by
        // increasing floor, so the walk ends at the first one that can be neither within reach
        // nor nearer than the best. In other cells they bound nothing.
        let mut consider = |list: &'a Vec<Entry<K>>, own_cell: bool| {
            for e in list {
                if own_cell && (e.floor_2 > max_2 || best.is_some_and(|(bd, _)| e.floor_2 > bd)) {
                    break;
                }
                let (d_2, _) = e.distance_2(p);
                if d_2 <= max_2 && best.is_none_or(|(bd, be)| (d_2, e.key) < (bd, be.key)) {
                    best = Some((d_2, e));
                }
            }
        };
        if max_distance_m <= self.reach_m {
            if let Some(list) = self.cells.get(&self.cell_of(p)) {
                consider(list, true);
            }
        } else {
            let r = Vec2::splat(max_distance_m - self.reach_m);
            self.for_cells(p - r, p + r, |list| consider(list, false));
        }
        best.map(|(_, e)| e)
    }

    /// The nearest segment to `p` at any distance, with the projection of `p` onto it; ties go
    /// to the smaller key. `None` when the index is empty or `p` is not finite.
    ///
    /// Searches within twice the last distance until something is found or the search box
    /// holds as many cells as are listed (then one exact walk over all of them).
    pub fn nearest_anywhere(&self, p: Vec2) -> Option<(K, Segment, SegmentProjection)> {
        if !p.is_finite() {
            return None;
        }
        let mut max_distance_m = self.reach_m.max(self.cell_m);
        loop {
            // Cells a side of the box a query beyond the reach walks.
            let side = 2.0 * (max_distance_m - self.reach_m).max(0.0) / self.cell_m + 1.0;
            if side * side > self.cells.len() as f64 {
                return self.nearest(p, f64::INFINITY);
            }
            if let Some(hit) = self.nearest(p, max_distance_m) {
                return Some(hit);
            }
            max_distance_m *= 2.0;
        }
    }

    /// True when some segment lies within `max_distance_m` of `p` (inclusive).
    pub fn any_within(&self, p: Vec2, max_distance_m: f64) -> bool {
        self.nearest_entry(p, max_distance_m).is_some()
    }

    /// The nearest segment within the grid's reach of `p`, with a certificate that answers
    /// later queries near `p` without a search (see [`NearestCertificate::answer`]).
    pub fn nearest_certified(&self, p: Vec2) -> NearestCertificate {
        let reach_2 = self.reach_m * self.reach_m;
        let mut best: Option<(f64, &Entry<K>)> = None;
        let mut second_2 = reach_2;
        if let Some(list) = self.cells.get(&self.cell_of(p)) {
            for e in list {
                // Entries come by increasing floor: past the runner-up nothing changes.
                if e.floor_2 > second_2 {
                    break;
                }
                let (d_2, _) = e.distance_2(p);
                match best {
                    Some((bd, _)) if d_2 >= bd => second_2 = second_2.min(d_2),
                    _ => {
                        if let Some((bd, _)) = best {
                            second_2 = second_2.min(bd);
                        }
                        best = Some((d_2, e));
                    }
                }
            }
        }
        // Segments not listed in `p`'s cell are further than the reach from `p`.
        NearestCertificate {
            at: p,
            nearest: best.map(|(d_2, e)| (d_2.sqrt(), e.segment, e.vector, e.inv_len_2)),
            clear_m: second_2.sqrt(),
        }
    }

    /// Keys of the segments that come within `margin_m` of segment `s`, sorted, no repeats.
    pub fn near_segment(&self, s: &Segment, margin_m: f64) -> Vec<K> {
        // A segment is listed in many cells: gather, drop repeats, then measure each once.
        let mut candidates: Vec<(K, Segment)> = Vec::new();
        if margin_m <= self.reach_m {
            // Every segment within the margin of `s` is within reach of the cell holding its
            // closest point on `s`, and so listed there: the cells `s` passes through suffice.
            for c in self.cells_touched_by(s) {
                if let Some(list) = self.cells.get(&c) {
                    candidates.extend(list.iter().map(|e| (e.key, e.segment)));
                }
            }
        } else {
            let (lo, hi) = s.bounds();
            let m = Vec2::splat(margin_m);
            self.for_cells(lo - m, hi + m, |list| {
                candidates.extend(list.iter().map(|e| (e.key, e.segment)))
            });
        }
        candidates.sort_unstable_by_key(|c| c.0);
        candidates.dedup_by(|a, b| a.0 == b.0);
        candidates
            .into_iter()
            .filter(|(_, t)| t.distance_to_segment_within(s, margin_m).is_some())
            .map(|(k, _)| k)
            .collect()
    }

    /// The cells a segment passes through (and possibly a few neighbours): those of its
    /// bounding box whose centre lies within half a cell diagonal of it.
    fn cells_touched_by(&self, s: &Segment) -> Vec<Cell> {
        let mut out = Vec::new();
        let limit = self.half_diagonal_m() * (1.0 + 1e-9);
        cells_around(self.cell_m, s, 0.0, limit, |c, _| out.push(c));
        out
    }

    /// Calls `f` with every segment that may cross segment `a`–`b` (metres): those listed in
    /// the cells the segment passes through whose distance floor there is zero (a superset of
    /// the segments passing through the cell; a segment may come more than once). Walks the
    /// cells in order (Amanatides–Woo), so the cost grows with the length, not the box.
    pub fn for_crossing_candidates(&self, a: Vec2, b: Vec2, mut f: impl FnMut(K, &Segment)) {
        // Floors are shrunk by a relative hair: a segment through a cell's corner may get a
        // floor a rounding error above zero.
        const FLOOR_2: f64 = 1e-12;
        self.walk_cells(a, b, |c| {
            if let Some(list) = self.cells.get(&c) {
                for e in list.iter().take_while(|e| e.floor_2 <= FLOOR_2) {
                    f(e.key, &e.segment);
                }
            }
        });
    }

    /// Calls `visit` with each cell segment `a`–`b` passes through, in order from `a`
    /// (Amanatides–Woo); where it steps through a corner, also with both cells beside it.
    fn walk_cells(&self, a: Vec2, b: Vec2, mut visit: impl FnMut(Cell)) {
        let (mut c, last) = (self.cell_of(a), self.cell_of(b));
        let d = b - a;
        let step = (d.x.signum() as i64, d.y.signum() as i64);
        let boundary = |p: f64, i: i64, s: i64| (i + i64::from(s > 0)) as f64 * self.cell_m - p;
        let n = (last.0 - c.0).abs() + (last.1 - c.1).abs();
        visit(c);
        for _ in 0..n.min(1 << 20) {
            let tx = match d.x != 0.0 {
                true => boundary(a.x, c.0, step.0) / d.x,
                false => f64::INFINITY,
            };
            let ty = match d.y != 0.0 {
                true => boundary(a.y, c.1, step.1) / d.y,
                false => f64::INFINITY,
            };
            if (tx - ty).abs() <= 1e-12 && c.0 != last.0 && c.1 != last.1 {
                visit((c.0 + step.0, c.1));
                visit((c.0, c.1 + step.1));
            }
            if (tx < ty && c.0 != last.0) || c.1 == last.1 {
                c.0 += step.0;
            } else {
                c.1 += step.1;
            }
            visit(c);
        }
    }

    /// Keys of the segments that cross the box `[lo, hi]` (metres, the index's frame; and
    /// possibly some that only come within reach of it), sorted, no repeats.
    pub fn in_box(&self, lo: Vec2, hi: Vec2) -> Vec<K> {
        let mut keys = Vec::new();
        self.for_cells(lo, hi, |list| keys.extend(list.iter().map(|e| e.key)));
        keys.sort_unstable();
        keys.dedup();
        keys
    }

    /// Calls `f` with the key of every entry in the cells of the box `[lo, hi]` (metres, the
    /// index's frame): the keys [`SegmentIndex::in_box`] returns, each as often as it is
    /// listed there (a caller that can mark keys it saw dedups without sorting them all).
    pub fn for_keys_in_box(&self, lo: Vec2, hi: Vec2, mut f: impl FnMut(K)) {
        self.for_cells(lo, hi, |list| list.iter().for_each(|e| f(e.key)));
    }

    fn for_cells<'a>(&'a self, lo: Vec2, hi: Vec2, mut f: impl FnMut(&'a Vec<Entry<K>>)) {
        let (c0, c1) = (self.cell_of(lo), self.cell_of(hi));
        let cells = (c1.0.saturating_sub(c0.0).saturating_add(1))
            .saturating_mul(c1.1.saturating_sub(c0.1).saturating_add(1));
        if cells > self.cells.len() as i64 || cells < 0 {
            // A box of more cells than are listed: walk the listed cells instead.
            for (c, list) in &self.cells {
                if (c0.0..=c1.0).contains(&c.0) && (c0.1..=c1.1).contains(&c.1) {
                    f(list);
                }
            }
            return;
        }
        for i in c0.0..=c1.0 {
            for j in c0.1..=c1.1 {
                if let Some(list) = self.cells.get(&(i, j)) {
                    f(list);
                }
            }
        }
    }
}

/// The cell holding `p`, for cells of `cell_m` metres.
fn cell_of(cell_m: f64, p: Vec2) -> Cell {
    (floor_i64(p.x / cell_m), floor_i64(p.y / cell_m))
}

/// Half the diagonal of a cell of `cell_m` metres.
fn half_diagonal_m(cell_m: f64) -> f64 {
    cell_m * std::f64::consts::FRAC_1_SQRT_2
}

/// Calls `f` with each cell (of `cell_m` metres) of the segment's bounding box grown by
/// `grow_m` whose centre lies within `limit_m` of the segment, and with that distance (metres).
///
/// Only the strip along the segment is visited: per column of cells, the rows where the
/// part of the segment within `limit_m` of the column lies (widened by half a cell against
/// rounding). The cost grows with the segment's length, not its bounding box: a long
/// diagonal once walked every cell of its box (minutes for one wall of a hostile map).
fn cells_around(cell_m: f64, s: &Segment, grow_m: f64, limit_m: f64, mut f: impl FnMut(Cell, f64)) {
    let (lo, hi) = s.bounds();
    let g = Vec2::splat(grow_m);
    let (c0, c1) = (cell_of(cell_m, lo - g), cell_of(cell_m, hi + g));
    let d = s.vector();
    let margin = limit_m.max(0.0) + 0.5 * cell_m;
    for i in c0.0..=c1.0 {
        let xc = (i as f64 + 0.5) * cell_m;
        // The segment's points within `margin` of the column's centre line, by x.
        let (y0, y1) = if d.x != 0.0 {
            let t0 = ((xc - margin - s.start.x) / d.x).clamp(0.0, 1.0);
            let t1 = ((xc + margin - s.start.x) / d.x).clamp(0.0, 1.0);
            let (ya, yb) = (s.start.y + d.y * t0, s.start.y + d.y * t1);
            (ya.min(yb), ya.max(yb))
        } else {
            (lo.y, hi.y)
        };
        let j0 = floor_i64((y0 - margin) / cell_m).max(c0.1);
        let j1 = floor_i64((y1 + margin) / cell_m).min(c1.1);
        for j in j0..=j1 {
            let centre = Vec2::new(xc, (j as f64 + 0.5) * cell_m);
            let d_2 = s.distance_2_to_point(centre);
            if d_2 <= limit_m * limit_m {
                f((i, j), d_2.sqrt());
            }
        }
    }
}

mod boxes;
pub use boxes::BoxIndex;

#[cfg(test)]
mod tests;
