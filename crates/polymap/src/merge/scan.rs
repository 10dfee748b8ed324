//! One merge of an aligned scan into the map near it: the stage's entry point.

use serde::{Deserialize, Serialize};

use super::{Child, MergeParams, Piece, insert_vertices, restrictive_pairing, simplify};
use crate::cost::merged_segment_weighted;
use crate::geometry::{Segment, angle_between_directions_rad};
use crate::map::{GlobalMap, MapSegment, Observations, SegmentId};

/// Counts through one merge.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct MergeDiagnostics {
    /// Map segments near the scan that took part (class C1 before vertex insertion).
    pub local_map_segments: usize,
    /// Map pieces after vertex insertion.
    pub map_pieces: usize,
    /// Scan pieces after vertex insertion.
    pub scan_pieces: usize,
    /// Children made by restrictive pairing.
    pub children: usize,
    /// Segments of `A_t` (near the scan) after pairing.
    pub after_pairing: usize,
    /// Merges made by simplification.
    pub merges: usize,
    /// Segments near the scan after simplification.
    pub after_simplification: usize,
}

/// A member of `A_t`: a segment, its birth, its observation record, and (as an index into the
/// local map handles) the map segment it is, untouched, if any.
///
/// Records: a child of a map and a scan segment is its map parent's record, seen at `t`; a
/// piece of a map segment that paired with nothing keeps its segment's record (the scan did
/// not see it); a scan segment is born at `t`.
struct Item {
    segment: Segment,
    born_scan: u32,
    observations: Observations,
    unchanged: Option<usize>,
}

/// A segment that simplification merged inherits the records of the members of `A_t` within
/// this distance of it, metres (simplification merges only segments that close)...
const INHERIT_WITHIN_M: f64 = 0.5;
/// ...and within this angle of its direction, degrees (a wall's record does not take a
/// crossing segment's).
const INHERIT_WITHIN_DEG: f64 = 30.0;

/// What one merge did to the map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MergeResult {
    /// Map segments removed (parents, and segments merged by simplification).
    pub removed: usize,
    /// Segments added (children, merged segments, the scan's unpaired segments).
    pub added: usize,
    /// Counts through the stages of the merge.
    pub diagnostics: MergeDiagnostics,
}

/// Merges scan `t`'s segments (map frame, metres) into the map near them under the main
/// directions `directions_rad` (section 3.1): the map segments within
/// `params.local_margin_m` of a scan segment (`C1`), vertex insertion, restrictive pairing,
/// simplification; the segments near the scan are replaced by the result, every other map
/// segment stays untouched. New segments are born at `t`.
///
/// ```
/// use polymap::geometry::{Segment, Vec2};
/// use polymap::map::{GlobalMap, MapSegment};
/// use polymap::merge::{MergeParams, merge_scan};
/// let mut map = GlobalMap::default();
/// map.insert(MapSegment {
///     segment: Segment::new(Vec2::new(0.0, 0.0), Vec2::new(4.0, 0.0)),
///     born_scan: 0,
/// });
/// // The same wall seen again, 1 cm off and a little longer: one segment remains.
/// let scan = [Segment::new(Vec2::new(0.5, 0.01), Vec2::new(5.0, 0.01))];
/// let result = merge_scan(&MergeParams::default(), &mut map, &scan, &[0.0], 1, true);
/// assert_eq!(map.len(), 1);
/// assert_eq!(result.diagnostics.local_map_segments, 1);
/// ```
pub fn merge_scan(
    params: &MergeParams,
    map: &mut GlobalMap,
    scan: &[Segment],
    directions_rad: &[f64],
    t: u32,
    confirmed: bool,
) -> MergeResult {
    let ids = local_ids(map, scan, params.local_margin_m);
    let c1: Vec<MapSegment> = ids.iter().filter_map(|id| map.get(*id).copied()).collect();
    let records: Vec<Observations> = ids
        .iter()
        .map(|id| map.observations(*id).unwrap_or_default())
        .collect();
    let sighting = (t, confirmed);
    let (items, mut diagnostics) = pair(&c1, &records, scan, directions_rad, sighting, params);
    let simplified = simplify(
        &items.iter().map(|i| i.segment).collect::<Vec<_>>(),
        directions_rad,
        params,
    );
    diagnostics.local_map_segments = ids.len();
    diagnostics.merges = simplified.merges;
    diagnostics.after_simplification = simplified.segments.len();
    let mut untouched = vec![false; ids.len()];
    let mut new_segments = Vec::new();
    for s in &simplified.segments {
        match s.input.map(|i| &items[i]) {
            Some(Item {
                unchanged: Some(local),
                ..
            }) => untouched[*local] = true,
            Some(item) => new_segments.push((
                MapSegment {
                    segment: item.segment,
                    born_scan: item.born_scan,
                },
                item.observations,
            )),
            None => new_segments.push((
                MapSegment {
                    segment: s.segment,
                    born_scan: t,
                },
                inherited(&items, &s.segment, sighting),
            )),
        }
    }
    let mut removed = 0;
    for (id, _) in ids.iter().zip(&untouched).filter(|(_, u)| !**u) {
        map.remove(*id);
        removed += 1;
    }
    let added = new_segments.len();
    for (s, observations) in new_segments {
        map.insert_observed(s, observations);
    }
    MergeResult {
        removed,
        added,
        diagnostics,
    }
}

/// The record of a segment that simplification merged at scan `t`, from the members of `A_t`
/// near it and roughly parallel: seen at `t` when one of them was (a child or a scan segment), else only their
/// records combined (merging old pieces the scan did not see is no sighting).
fn inherited(items: &[Item], merged: &Segment, (t, confirmed): (u32, bool)) -> Observations {
    let direction = merged.direction_rad();
    let (lo, hi) = merged.bounds();
    let grow = crate::geometry::Vec2::splat(INHERIT_WITHIN_M);
    let (lo, hi) = (lo - grow, hi + grow);
    let near: Vec<Observations> = items
        .iter()
        .filter(|i| {
            // The boxes first: most members are far from the merged segment.
            let (a, b) = i.segment.bounds();
            a.cmple(hi).all() && b.cmpge(lo).all()
        })
        .filter(|i| {
            let turn = angle_between_directions_rad(i.segment.direction_rad(), direction);
            turn <= INHERIT_WITHIN_DEG.to_radians()
                && i.segment
                    .distance_to_segment_within(merged, INHERIT_WITHIN_M)
                    .is_some()
        })
        .map(|i| i.observations)
        .collect();
    let seen_now = near.iter().any(|o| o.last_seen_scan == t && o.seen > 0);
    match Observations::combined(near.iter().copied()) {
        Some(o) if !seen_now => o,
        _ => Observations::merged(t, confirmed, near),
    }
}

/// Vertex insertion and restrictive pairing of the local map `c1` (with its observation
/// `records`) with the scan: `A_t` (the children, then the segments that were no parent) and
/// the counts so far.
fn pair(
    c1: &[MapSegment],
    records: &[Observations],
    scan: &[Segment],
    directions_rad: &[f64],
    (t, confirmed): (u32, bool),
    p: &MergeParams,
) -> (Vec<Item>, MergeDiagnostics) {
    let c1_segs: Vec<Segment> = c1.iter().map(|s| s.segment).collect();
    let (map_pieces, scan_pieces) = insert_vertices(&c1_segs, scan, p);
    let pairing = restrictive_pairing(
        &segments(&map_pieces),
        &segments(&scan_pieces),
        directions_rad,
        p,
    );
    let mut items: Vec<Item> = pairing
        .children
        .iter()
        .map(|c| Item {
            segment: supported_child(
                c,
                &map_pieces,
                &scan_pieces,
                records,
                directions_rad,
                p.support_cap,
            ),
            born_scan: t,
            observations: Observations::merged(
                t,
                confirmed,
                map_pieces
                    .get(c.map_parent)
                    .and_then(|p| records.get(p.source))
                    .copied(),
            ),
            unchanged: None,
        })
        .collect();
    let rejoin = p.rejoin_unpaired_pieces;
    keep_non_parents(
        &mut items,
        &map_pieces,
        &pairing.map_is_parent,
        rejoin,
        |i| (c1_segs[i], c1[i].born_scan, records[i], Some(i)),
    );
    keep_non_parents(
        &mut items,
        &scan_pieces,
        &pairing.scan_is_parent,
        rejoin,
        |i| (scan[i], t, Observations::born_by(t, confirmed), None),
    );
    let diagnostics = MergeDiagnostics {
        map_pieces: map_pieces.len(),
        scan_pieces: scan_pieces.len(),
        children: pairing.children.len(),
        after_pairing: items.len(),
        ..MergeDiagnostics::default()
    };
    (items, diagnostics)
}

/// The child `c` placed by support ([`MergeParams::support_cap`]): on the line of its main
/// direction between its map parent (support: the scans tracked `ok` that saw it,
/// [`Observations::support`], at most the cap) and its scan parent (support 1), by length ×
/// support; its extent the hull of both parents' projections.
fn supported_child(
    c: &Child,
    map_pieces: &[Piece],
    scan_pieces: &[Piece],
    records: &[Observations],
    directions_rad: &[f64],
    cap: f64,
) -> Segment {
    let map = &map_pieces[c.map_parent];
    let support = records
        .get(map.source)
        .map_or(1.0, |o| f64::from(o.support().max(1)).min(cap));
    if support <= 1.0 {
        return c.segment;
    }
    merged_segment_weighted(
        &map.segment,
        support,
        &scan_pieces[c.scan_parent].segment,
        1.0,
        directions_rad[c.direction],
    )
    .unwrap_or(c.segment)
}

/// Handles of the map segments within `margin_m` of a scan segment, sorted, no repeats.
fn local_ids(map: &GlobalMap, scan: &[Segment], margin_m: f64) -> Vec<SegmentId> {
    if !margin_m.is_finite() {
        return map.iter().map(|(id, _)| id).collect();
    }
    let mut ids: Vec<SegmentId> = scan
        .iter()
        .flat_map(|s| map.near_segment(s, margin_m))
        .collect();
    ids.sort_unstable();
    ids.dedup();
    ids
}

fn segments(pieces: &[Piece]) -> Vec<Segment> {
    pieces.iter().map(|p| p.segment).collect()
}

/// Adds the pieces that did not become parents to `A_t`. With `rejoin`, a split segment none of
/// whose pieces became a parent goes back as the whole original (from `original(source)`: the
/// segment, its birth, its observation record, and its local index if it is a map segment).
fn keep_non_parents(
    items: &mut Vec<Item>,
    pieces: &[Piece],
    is_parent: &[bool],
    rejoin: bool,
    original: impl Fn(usize) -> (Segment, u32, Observations, Option<usize>),
) {
    let mut i = 0;
    while i < pieces.len() {
        let source = pieces[i].source;
        let end = i + pieces[i..]
            .iter()
            .take_while(|p| p.source == source)
            .count();
        let any_parent = is_parent[i..end].iter().any(|p| *p);
        let (whole, born_scan, observations, id) = original(source);
        if !any_parent && (rejoin || end - i == 1) {
            items.push(Item {
                segment: whole,
                born_scan,
                observations,
                unchanged: id,
            });
        } else {
            for (piece, _) in pieces[i..end]
                .iter()
                .zip(&is_parent[i..end])
                .filter(|(_, p)| !**p)
            {
                items.push(Item {
                    segment: piece.segment,
                    born_scan,
                    observations,
                    unchanged: None,
                });
            }
        }
        i = end;
    }
}
