//! Merging a second map into the map (an addition): the second map's segments, already in the
//! map's frame, go through [`merge_scan`] as if they were scans again.
//!
//! They are fed in pieces, one per birth scan of the second map, in birth order, each born
//! at `born_offset` plus its own birth. Each piece's main directions are those of the map
//! segments within `directions_reach_m` of it and of the piece itself: the local directions
//! that the mapper takes from recently born segments, which a merge of whole maps has no
//! "recent" part to give.

use serde::{Deserialize, Serialize};

use super::{MergeParams, merge_scan};
use crate::check::{Checks, InvalidParam};
use crate::directions::{DirectionParams, main_directions};
use crate::geometry::{Segment, Vec2};
use crate::map::{GlobalMap, MapSegment};

/// Parameters of merging a map into a map.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MapMergeParams {
    /// A piece's main directions come from the map segments within this distance of its
    /// bounding box (and the piece), metres.
    pub directions_reach_m: f64,
}

impl Default for MapMergeParams {
    fn default() -> Self {
        MapMergeParams {
            directions_reach_m: 5.0,
        }
    }
}

impl MapMergeParams {
    /// Checks every key's range; the error names the first key out of range.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        Checks::new()
            .within("directions_reach_m", self.directions_reach_m, 0.0, 1e3)
            .done()
    }
}

/// Counts of one merge of a map into a map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct MapMergeResult {
    /// Pieces merged (distinct birth scans of the second map).
    pub pieces: usize,
    /// Map segments removed over all pieces.
    pub removed: usize,
    /// Segments added over all pieces.
    pub added: usize,
}

/// Merges `other` (segments in `map`'s frame) into `map`, piece by piece in birth order (see
/// the module's documentation); a piece born at scan `b` is merged as scan `born_offset + b`.
///
/// ```
/// use polymap::directions::DirectionParams;
/// use polymap::geometry::{Segment, Vec2};
/// use polymap::map::{GlobalMap, MapSegment};
/// use polymap::merge::{MapMergeParams, MergeParams, merge_map};
/// let wall = |x0: f64, x1: f64, y: f64, born_scan| MapSegment {
///     segment: Segment::new(Vec2::new(x0, y), Vec2::new(x1, y)), born_scan };
/// let mut map = GlobalMap::default();
/// map.insert(wall(0.0, 4.0, 0.0, 0));
/// // The second map saw the same wall 1 cm off and longer.
/// let other = [wall(1.0, 6.0, 0.01, 0)];
/// let r = merge_map(&MergeParams::default(), &DirectionParams::default(),
///                   &MapMergeParams::default(), &mut map, &other, 100);
/// assert_eq!((map.len(), r.pieces), (1, 1));
/// ```
pub fn merge_map(
    merge: &MergeParams,
    directions: &DirectionParams,
    params: &MapMergeParams,
    map: &mut GlobalMap,
    other: &[MapSegment],
    born_offset: u32,
) -> MapMergeResult {
    let mut order: Vec<&MapSegment> = other.iter().filter(|s| s.segment.is_finite()).collect();
    order.sort_by_key(|s| s.born_scan);
    let mut result = MapMergeResult::default();
    for piece in order.chunk_by(|a, b| a.born_scan == b.born_scan) {
        let segments: Vec<Segment> = piece.iter().map(|s| s.segment).collect();
        let local = local_directions(map, &segments, directions, params.directions_reach_m);
        let t = born_offset.saturating_add(piece[0].born_scan);
        let r = merge_scan(merge, map, &segments, &local, t, true);
        result.pieces += 1;
        result.removed += r.removed;
        result.added += r.added;
    }
    result
}

/// The main directions of `piece` and the map segments within `reach_m` of its bounding box.
fn local_directions(
    map: &GlobalMap,
    piece: &[Segment],
    params: &DirectionParams,
    reach_m: f64,
) -> Vec<f64> {
    let (lo, hi) = piece.iter().fold(
        (Vec2::splat(f64::INFINITY), Vec2::splat(f64::NEG_INFINITY)),
        |(lo, hi), s| {
            let (a, b) = s.bounds();
            (lo.min(a), hi.max(b))
        },
    );
    let reach = Vec2::splat(reach_m);
    let mut near: Vec<Segment> = map
        .query(lo - reach, hi + reach)
        .into_iter()
        .filter_map(|id| map.get(id).map(|s| s.segment))
        .collect();
    near.extend_from_slice(piece);
    main_directions(near.iter(), params).directions_rad
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wall(x0: f64, y0: f64, x1: f64, y1: f64, born_scan: u32) -> MapSegment {
        MapSegment {
            segment: Segment::new(Vec2::new(x0, y0), Vec2::new(x1, y1)),
            born_scan,
        }
    }

    fn run(a: &[MapSegment], b: &[MapSegment]) -> (GlobalMap, MapMergeResult) {
        let mut map = GlobalMap::default();
        for s in a {
            map.insert(*s);
        }
        let r = merge_map(
            &MergeParams::default(),
            &DirectionParams::default(),
            &MapMergeParams::default(),
            &mut map,
            b,
            1000,
        );
        (map, r)
    }

    #[test]
    fn a_map_merged_with_itself_keeps_its_walls() {
        let room = [
            wall(0.0, 0.0, 6.0, 0.0, 0),
            wall(6.0, 0.0, 6.0, 4.0, 1),
            wall(6.0, 4.0, 0.0, 4.0, 2),
            wall(0.0, 4.0, 0.0, 0.0, 3),
        ];
        let (map, r) = run(&room, &room);
        assert_eq!(map.len(), 4, "{r:?}");
        assert_eq!(r.pieces, 4);
    }

    #[test]
    fn new_walls_are_added_and_born_after_the_offset() {
        let a = [wall(0.0, 0.0, 6.0, 0.0, 0), wall(6.0, 0.0, 6.0, 4.0, 0)];
        let b = [wall(20.0, 0.0, 26.0, 0.0, 7), wall(26.0, 0.0, 26.0, 4.0, 7)];
        let (map, r) = run(&a, &b);
        assert_eq!((map.len(), r.added, r.removed), (4, 2, 0));
        let born: Vec<u32> = map.iter().map(|(_, s)| s.born_scan).collect();
        assert_eq!(born.iter().filter(|b| **b == 1007).count(), 2);
    }
}
