//! Walls that cross: a second check of the map as a whole, beside how often the scans saw
//! through it ([`super::seen_through_share`]).
//!
//! Two walls of a building do not cross. Where two map segments cross at a shallow angle
//! ([`CROSSED_MIN_DEG`] to [`CROSSED_MAX_DEG`]), each going on at least [`CROSSED_DEPTH_M`]
//! past the crossing on both sides, the map draws one wall twice, turned apart: from poses
//! turned against each other, or a curved wall drawn as straight chords, each merge pulling
//! a chord onto another main direction (ARCHITECTURE §4, known gaps). Such a map has few of
//! its walls seen through, since a ray from either version of the wall reaches the other
//! only near the crossing. Steep crossings are left out: furniture, railings and door leaves
//! stand across walls (FR079's dense map crosses 72 times, all at 41–90°, where tracking held).
//!
//! How much wall a crossing draws twice is the stretch of each of the two segments within
//! [`DOUBLED_WITHIN_M`] of the other segment: at most `DOUBLED_WITHIN_M / sin(angle)` each way
//! from the crossing, cut where either segment ends. So the flatter the crossing the more it
//! counts, and two long walls whose ends overshoot each other at a bend count only their
//! overshoot's neighbourhood, not their whole length. A segment's stretches from several
//! crossings count once where they overlap, so the share is at most 1.

use serde::{Deserialize, Serialize};

use crate::geometry::{Segment, Vec2};
use crate::map::{GlobalMap, MapParams, MapSegment};

/// Crossings at a smaller angle, degrees, are near-duplicates of one wall (a merge's few
/// centimetres), not a wall drawn twice.
pub const CROSSED_MIN_DEG: f64 = 5.0;

/// Crossings at a larger angle, degrees, are left out (see the module docs): on the
/// benchmark logs' dense maps FR079's 72 crossings lie at 41–90°; Intel's 4 shallow ones
/// at 11–23°.
pub const CROSSED_MAX_DEG: f64 = 30.0;

/// Both segments go on at least this far past the crossing on both sides, metres: two walls
/// meeting at a corner or a tip overshooting a wall by a few centimetres do not cross.
pub const CROSSED_DEPTH_M: f64 = 0.5;

/// Two lines this near each other draw one wall, metres: a wall's thickness and a scan's
/// spread about it.
pub const DOUBLED_WITHIN_M: f64 = 0.3;

/// Scans of the walls crossed that lie at most this many scans apart are named as one range.
const RANGE_GAP_SCANS: u32 = 10;

/// The walls of a map that cross each other ([`crossed_walls`]).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct CrossedWalls {
    /// The share of the map's length drawn twice about the crossings (see the module docs),
    /// `[0, 1]`.
    pub share: f64,
    /// How many pairs of segments cross.
    pub crossings: usize,
    /// The scans that last merged into the crossed segments (their `born_scan`, which every
    /// merge renews; the map's numbering), as inclusive ranges, in order: where to look.
    pub scans: Vec<[u32; 2]>,
}

/// The walls of `map` that cross another (see the module docs); `None` for a map without
/// length. Segments with a non-finite coordinate are left out.
pub fn crossed_walls(map: &GlobalMap) -> Option<CrossedWalls> {
    let mut total_m = 0.0;
    let mut doubled_m = 0.0;
    let mut born = Vec::new();
    let mut crossings = 0;
    let mut others = Vec::new();
    for (id, s) in map.iter() {
        if !s.segment.is_finite() {
            continue;
        }
        total_m += s.segment.length();
        others.clear();
        map.for_crossing_candidates(s.segment.start, s.segment.end, |other, _| {
            others.push(other);
        });
        others.sort_unstable();
        others.dedup();
        // This segment's stretches (metres from its start) drawn twice, one per crossing.
        let mut stretches: Vec<(f64, f64)> = Vec::new();
        for &other in &others {
            let Some(o) = map
                .get(other)
                .filter(|o| other != id && o.segment.is_finite())
            else {
                continue;
            };
            if let Some(stretch) = doubled_stretch(&s.segment, &o.segment) {
                stretches.push(stretch);
                // Each pair is met from both of its segments.
                crossings += usize::from(id < other);
            }
        }
        if !stretches.is_empty() {
            doubled_m += union_m(&mut stretches);
            born.push(s.born_scan);
        }
    }
    if total_m <= 0.0 {
        return None;
    }
    born.sort_unstable();
    Some(CrossedWalls {
        share: (doubled_m / total_m).min(1.0),
        crossings,
        scans: ranges(&born),
    })
}

/// [`crossed_walls`] of a map given as its segments (map frame, metres; a saved `map.json`,
/// another tool's map), under the default grid: the same figures as the run's own check of
/// the same segments. Its `scans` are empty (segments alone carry no scan).
pub fn crossed_walls_of(segments: &[Segment]) -> Option<CrossedWalls> {
    let mut map = GlobalMap::new(MapParams::default().grid_cell_m, 1.0);
    for &segment in segments {
        map.insert(MapSegment {
            segment,
            born_scan: 0,
        });
    }
    crossed_walls(&map).map(|c| CrossedWalls {
        scans: Vec::new(),
        ..c
    })
}

/// Where `a` and `b` cross at an angle within [`CROSSED_MIN_DEG`]..=[`CROSSED_MAX_DEG`], at
/// least [`CROSSED_DEPTH_M`] from every end of both: the stretch of `a` (metres from its
/// start, `(from, to)`) within [`DOUBLED_WITHIN_M`] of `b`'s line and alongside `b` (where
/// `a`'s points project onto `b` between its ends).
fn doubled_stretch(a: &Segment, b: &Segment) -> Option<(f64, f64)> {
    let (da, db) = (a.vector(), b.vector());
    let (la, lb) = (da.length(), db.length());
    if la < 2.0 * CROSSED_DEPTH_M || lb < 2.0 * CROSSED_DEPTH_M {
        return None;
    }
    let cross = da.perp_dot(db);
    let sin = (cross / (la * lb)).abs();
    let (lo, hi) = (
        CROSSED_MIN_DEG.to_radians().sin(),
        CROSSED_MAX_DEG.to_radians().sin(),
    );
    if !(lo..=hi).contains(&sin) {
        return None;
    }
    // Where the lines meet, as distances along each segment from its start, metres.
    let w: Vec2 = b.start - a.start;
    let along_a = w.perp_dot(db) / cross * la;
    let along_b = w.perp_dot(da) / cross * lb;
    let deep =
        |along: f64, length: f64| along >= CROSSED_DEPTH_M && along <= length - CROSSED_DEPTH_M;
    if !(deep(along_a, la) && deep(along_b, lb)) {
        return None;
    }
    // A point of `a` at `along_a + u` lies `|u| sin` from `b`'s line and projects onto `b` at
    // `along_b + u cos` (`cos` signed: the two directions' cosine).
    let half = DOUBLED_WITHIN_M / sin;
    let cos = da.dot(db) / (la * lb);
    let (b_lo, b_hi) = {
        let (x, y) = (-along_b / cos, (lb - along_b) / cos);
        (x.min(y), x.max(y))
    };
    let from = (along_a - half).max(0.0).max(along_a + b_lo);
    let to = (along_a + half).min(la).min(along_a + b_hi);
    (to > from).then_some((from, to))
}

/// The length the `stretches` (`(from, to)`, metres) cover together, overlaps once.
fn union_m(stretches: &mut [(f64, f64)]) -> f64 {
    stretches.sort_by(|x, y| x.0.total_cmp(&y.0));
    let mut total = 0.0;
    let mut open: Option<(f64, f64)> = None;
    for &(from, to) in stretches.iter() {
        open = match open {
            Some((a, b)) if from <= b => Some((a, b.max(to))),
            Some((a, b)) => {
                total += b - a;
                Some((from, to))
            }
            None => Some((from, to)),
        };
    }
    total + open.map_or(0.0, |(a, b)| b - a)
}

/// Sorted scan numbers as inclusive ranges, numbers at most [`RANGE_GAP_SCANS`] apart joined.
pub(super) fn ranges(sorted: &[u32]) -> Vec<[u32; 2]> {
    let mut out: Vec<[u32; 2]> = Vec::new();
    for &scan in sorted {
        match out.last_mut() {
            Some(last) if scan <= last[1].saturating_add(RANGE_GAP_SCANS) => last[1] = scan,
            _ => out.push([scan, scan]),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::MapSegment;

    fn map_of(segments: &[(Segment, u32)]) -> GlobalMap {
        let mut map = GlobalMap::new(1.0, 0.5);
        for &(segment, born_scan) in segments {
            map.insert(MapSegment { segment, born_scan });
        }
        map
    }

    fn seg(a: (f64, f64), b: (f64, f64)) -> Segment {
        Segment::new(Vec2::new(a.0, a.1), Vec2::new(b.0, b.1))
    }

    /// A wall drawn twice, 15° apart, crossing in the middle: both are crossed, and the
    /// scans that mapped them are named.
    #[test]
    fn a_wall_drawn_twice_turned_apart_crosses() {
        let turned = 15f64.to_radians();
        let (c, s) = (2.0 * turned.cos(), 2.0 * turned.sin());
        let map = map_of(&[
            (seg((-2.0, 0.0), (2.0, 0.0)), 3),
            (seg((-c, -s), (c, s)), 40),
            (seg((0.0, 5.0), (4.0, 5.0)), 60),
        ]);
        let found = crossed_walls(&map).unwrap();
        assert_eq!(found.crossings, 1);
        // Each 4 m wall within 0.3 m of the other over 0.6 / sin 15° = 2.32 m.
        let stretch = 2.0 * DOUBLED_WITHIN_M / turned.sin();
        assert!(
            (found.share - 2.0 * stretch / 12.0).abs() < 1e-9,
            "{found:?}"
        );
        assert_eq!(found.scans, vec![[3, 3], [40, 40]]);
        // Two long walls overshooting each other by 0.6 m at a 15° bend: only the overshoot's
        // neighbourhood counts.
        let (c, s) = (12.0 * turned.cos(), 12.0 * turned.sin());
        let bend = map_of(&[
            (seg((-11.4, 0.0), (0.6, 0.0)), 0),
            (seg((-0.6 * turned.cos(), -0.6 * turned.sin()), (c, s)), 1),
        ]);
        let found = crossed_walls(&bend).unwrap();
        assert_eq!(found.crossings, 1);
        // Each from its end 0.6 m past the crossing to where the other's end projects.
        let each = 0.6 + 0.6 / turned.cos();
        assert!((found.share - 2.0 * each / 24.6).abs() < 1e-9, "{found:?}");
    }

    /// A fan of walls crossing at one point, 10° apart: each wall's stretches from its two
    /// crossings overlap and count once; the share stays within the map's length.
    #[test]
    fn stretches_drawn_more_than_twice_count_once() {
        // A wall through the origin at `deg`, `half_m` each way.
        let wall = |deg: f64, half_m: f64| {
            let (s, c) = deg.to_radians().sin_cos();
            (seg((-half_m * c, -half_m * s), (half_m * c, half_m * s)), 0)
        };
        let fan =
            |half_m: f64| map_of(&[wall(0.0, half_m), wall(10.0, half_m), wall(20.0, half_m)]);
        // Three 1.2 m walls: each drawn twice over its whole length by two crossings, once.
        let fan_short = fan(0.6);
        let found = crossed_walls(&fan_short).unwrap();
        assert_eq!(found.crossings, 3);
        assert!((found.share - 1.0).abs() < 1e-9, "{found:?}");
        let found = crossed_walls(&fan(3.0)).unwrap();
        assert_eq!(found.crossings, 3);
        // Each wall: 0.3 / sin 10° = 1.73 m each way from the crossing with its 10° neighbour,
        // the stretch of its 20° crossing inside that (the middle wall's two alike), once.
        let each = 2.0 * DOUBLED_WITHIN_M / 10f64.to_radians().sin();
        assert!((found.share - 3.0 * each / 18.0).abs() < 1e-9, "{found:?}");
        assert!(found.share <= 1.0);
    }

    /// Corners and a T-junction at a shallow angle, a door leaf across a wall (steep),
    /// near-duplicates of one wall (under 5°) and a tip just past a wall are no crossings.
    #[test]
    fn corners_junctions_steep_crossings_and_near_duplicates_do_not_cross() {
        let (s15, c15) = 15f64.to_radians().sin_cos();
        let map = map_of(&[
            // A corner and a T-junction, at 15°.
            (seg((0.0, 0.0), (4.0, 0.0)), 0),
            (seg((0.0, 0.0), (-4.0 * c15, 4.0 * s15)), 0),
            (seg((2.0, 0.0), (2.0 + 3.0 * c15, 3.0 * s15)), 0),
            // A door leaf standing across a wall at 60°.
            (seg((6.0, -1.0), (7.2, 1.08)), 1),
            (seg((5.0, 0.0), (9.0, 0.0)), 1),
            // A near-duplicate 3° off the wall.
            (seg((5.0, 0.1), (9.0, -0.1)), 2),
            // A wall whose tip ends 0.2 m past another at 20°.
            (seg((0.0, 8.0), (4.0, 8.0)), 3),
            (
                seg(
                    (2.0 - 3.0 * 0.94, 8.0 - 3.0 * 0.342),
                    (2.0 + 0.2 * 0.94, 8.0 + 0.2 * 0.342),
                ),
                3,
            ),
        ]);
        let found = crossed_walls(&map).unwrap();
        assert_eq!(found.crossings, 0, "{found:?}");
        assert_eq!(found.share, 0.0);
        assert!(found.scans.is_empty());
        assert!(crossed_walls(&GlobalMap::new(1.0, 0.5)).is_none());
    }

    #[test]
    fn scans_close_together_are_one_range() {
        assert_eq!(
            ranges(&[1, 5, 11, 30, 31, 200]),
            vec![[1, 11], [30, 31], [200, 200]]
        );
        assert!(ranges(&[]).is_empty());
    }
}
