//! Vertex insertion (section 3.1, Fig. 5): endpoints of one map split the nearby segments of the
//! other, so that features present in only one of them can find partners in pairing.

use super::MergeParams;
use super::candidates::{BRUTE_FORCE_PAIRS, boxes_within};
use crate::geometry::{Segment, SegmentProjection, Vec2};
use crate::segment_index::BoxIndex;

/// A segment after vertex insertion, with the index of the input segment it is part of.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Piece {
    /// The piece (the whole input segment when it was not split).
    pub segment: Segment,
    /// Index of the input segment it came from.
    pub source: usize,
}

/// Splits map segments at the projections of scan endpoints and scan segments at the
/// projections of map endpoints.
///
/// For every endpoint `E` of one side, the closest point `p(E)` of the other side is found; when
/// `|E − p(E)| <= insert_max_distance_m` and `p(E)` is at least `insert_min_piece_m` from the
/// endpoints of its segment (and from other cuts), the segment is split there into two collinear
/// pieces. Returns the pieces of `map` and of `scan`, each in input order.
///
/// ```
/// use polymap::merge::{insert_vertices, MergeParams};
/// use polymap::geometry::{Segment, Vec2};
/// // Fig. 5: a triangle in the map above a straight scan segment.
/// let map = [Segment::new(Vec2::new(1.0, 0.0), Vec2::new(1.5, 0.3)), Segment::new(Vec2::new(1.5, 0.3), Vec2::new(2.0, 0.0))];
/// let scan = [Segment::new(Vec2::new(0.0, 0.0), Vec2::new(3.0, 0.0))];
/// let (map_pieces, scan_pieces) = insert_vertices(&map, &scan, &MergeParams::default());
/// assert_eq!(map_pieces.len(), 2);
/// assert_eq!(scan_pieces.len(), 4); // cut at x = 1.0, 1.5 and 2.0
/// ```
pub fn insert_vertices(
    map: &[Segment],
    scan: &[Segment],
    params: &MergeParams,
) -> (Vec<Piece>, Vec<Piece>) {
    let scan_cuts = cuts_from(map, scan, params);
    let map_cuts = cuts_from(scan, map, params);
    (
        split_all(map, map_cuts, params),
        split_all(scan, scan_cuts, params),
    )
}

/// For each segment of `targets`, the parameters `t` where endpoints of `sources` project.
fn cuts_from(sources: &[Segment], targets: &[Segment], params: &MergeParams) -> Vec<Vec<f64>> {
    cuts_with_walk_limit(sources, targets, params, BRUTE_FORCE_PAIRS)
}

/// [`cuts_from`], walking all targets for up to `walk_limit` endpoint–target pairs.
fn cuts_with_walk_limit(
    sources: &[Segment],
    targets: &[Segment],
    params: &MergeParams,
    walk_limit: usize,
) -> Vec<Vec<f64>> {
    let mut cuts = vec![Vec::new(); targets.len()];
    if targets.is_empty() {
        return cuts;
    }
    let r = params.insert_max_distance_m;
    let closest = |a: &(usize, SegmentProjection), b: &(usize, SegmentProjection)| {
        a.1.distance_2
            .total_cmp(&b.1.distance_2)
            .then(a.0.cmp(&b.0))
    };
    // Any candidate set holding every target within `r` gives the same nearest one: all
    // targets while that is cheap, those whose box meets the endpoint's in a `BoxIndex` after.
    let index =
        (2 * sources.len() * targets.len() > walk_limit).then(|| BoxIndex::from_segments(targets));
    let boxes: Vec<(Vec2, Vec2)> = targets.iter().map(Segment::bounds).collect();
    // Both ways pre-select by boxes grown by `r` and a hair: the projection's rounding may put
    // a target whose box is just beyond `r` within it, and the exact test below decides.
    let grow = r * (1.0 + 1e-9) + 1e-12;
    for e in sources.iter().flat_map(|s| [s.start, s.end]) {
        let nearest = match &index {
            Some(index) => index
                .intersecting_iter(e - Vec2::splat(grow), e + Vec2::splat(grow))
                .map(|j| (j, targets[j].project(e)))
                .min_by(closest),
            None => boxes
                .iter()
                .enumerate()
                .filter(|(_, b)| boxes_within((e, e), **b, grow))
                .map(|(j, _)| (j, targets[j].project(e)))
                .min_by(closest),
        };
        if let Some((j, proj)) = nearest.filter(|(_, p)| p.distance_2 <= r * r) {
            cuts[j].push(proj.t);
        }
    }
    cuts
}

fn split_all(segments: &[Segment], cuts: Vec<Vec<f64>>, params: &MergeParams) -> Vec<Piece> {
    let mut out = Vec::with_capacity(segments.len());
    for (source, (s, mut ts)) in segments.iter().zip(cuts).enumerate() {
        ts.sort_by(f64::total_cmp);
        let len = s.length();
        let min_t = if len > 0.0 {
            params.insert_min_piece_m / len
        } else {
            f64::INFINITY
        };
        let mut last = 0.0;
        for t in ts {
            if t - last >= min_t && 1.0 - t >= min_t {
                out.push(Piece {
                    segment: Segment::new(lerp(s, last), lerp(s, t)),
                    source,
                });
                last = t;
            }
        }
        out.push(Piece {
            segment: Segment::new(lerp(s, last), s.end),
            source,
        });
    }
    out
}

fn lerp(s: &Segment, t: f64) -> Vec2 {
    if t <= 0.0 {
        s.start
    } else {
        s.start + s.vector() * t
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn segment() -> impl Strategy<Value = Segment> {
        (0.0f64..8.0, 0.0f64..8.0, -2.0f64..2.0, -2.0f64..2.0)
            .prop_map(|(x, y, dx, dy)| Segment::new(Vec2::new(x, y), Vec2::new(x + dx, y + dy)))
    }

    /// A target that the projection's rounding puts just within the insertion distance: the
    /// walk's box test must keep it, as the R-tree's looser envelope does.
    #[test]
    fn walk_and_tree_agree_at_the_insertion_distance() {
        let target = Segment::new(
            Vec2::new(8.086380767959202, -9.5358840208391),
            Vec2::new(5.214068203938593, 9.198177437191713),
        );
        let e = Vec2::new(4.7312066729623865, 9.327964732037218);
        let sources = [Segment::new(e, e + Vec2::new(0.0, 5.0))];
        let p = MergeParams::default();
        let by_tree = cuts_with_walk_limit(&sources, &[target], &p, 0);
        assert_eq!(by_tree, vec![vec![1.0]]);
        assert_eq!(
            cuts_with_walk_limit(&sources, &[target], &p, usize::MAX),
            by_tree
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// The walk over all targets and the R-tree find the same cuts.
        #[test]
        fn walk_and_tree_find_the_same_cuts(
            sources in proptest::collection::vec(segment(), 0..30),
            targets in proptest::collection::vec(segment(), 0..30),
        ) {
            let p = MergeParams::default();
            prop_assert_eq!(
                cuts_with_walk_limit(&sources, &targets, &p, 0),
                cuts_with_walk_limit(&sources, &targets, &p, usize::MAX)
            );
        }
    }
}
