//! The merged segment `ms(L1, L2, ad)` and the cost `C(L1, L2, ad)` of section 2.3.
//!
//! The line `ld` has direction `ad` and sits between `L1` and `L2` so that `d1·l1 = d2·l2`, where
//! `li` is the length of `Li` and `di` the distance of its midpoint from `ld`. With `n` the unit
//! normal of `ad` and `mi` the midpoints, that puts `ld` at normal offset
//! `c = (l1·(n·m1) + l2·(n·m2)) / (l1 + l2)`. The merged segment runs between the extreme
//! projections of the four endpoints onto `ld`.

use crate::geometry::{Segment, Vec2};

/// A candidate merge: the merged segment along a main direction and what it costs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Merge {
    /// `ms(L1, L2, ad)`, in the frame of the inputs.
    pub segment: Segment,
    /// `C(L1, L2, ad)`, dimensionless in the paper; here in metres scaled by `K`.
    pub cost: f64,
}

/// The line `ld` of direction `ad_rad` placed between two segments (d1·l1 = d2·l2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DirectedLine {
    /// Unit direction of the line.
    pub direction: Vec2,
    /// Unit normal (direction rotated by +90°).
    pub normal: Vec2,
    /// Signed offset along `normal`: the line is `{p : normal·p = offset_m}`.
    pub offset_m: f64,
}

impl DirectedLine {
    /// `ld` between `l1` and `l2`; `None` when both segments have zero length.
    pub fn between(l1: &Segment, l2: &Segment, ad_rad: f64) -> Option<DirectedLine> {
        Self::between_lengths(l1, l1.length(), l2, l2.length(), unit(ad_rad))
    }

    /// [`DirectedLine::between`] with the segments' lengths and the unit direction given.
    fn between_lengths(
        l1: &Segment,
        len1: f64,
        l2: &Segment,
        len2: f64,
        direction: Vec2,
    ) -> Option<DirectedLine> {
        let normal = direction.perp();
        if len1 + len2 <= 0.0 {
            return None;
        }
        let offset_m =
            (len1 * normal.dot(l1.midpoint()) + len2 * normal.dot(l2.midpoint())) / (len1 + len2);
        Some(DirectedLine {
            direction,
            normal,
            offset_m,
        })
    }

    /// Distance of a point from the line, metres.
    pub fn distance_m(&self, p: Vec2) -> f64 {
        (self.normal.dot(p) - self.offset_m).abs()
    }

    /// The point of the line at coordinate `s` along `direction`.
    pub fn point_at(&self, s: f64) -> Vec2 {
        self.direction * s + self.normal * self.offset_m
    }
}

/// `ms(L1, L2, ad)`: the convex hull of the projections of both segments onto `ld`.
///
/// ```
/// use polymap::cost::merged_segment;
/// use polymap::geometry::{Segment, Vec2};
/// let l1 = Segment::new(Vec2::new(0.0, 0.0), Vec2::new(2.0, 0.0));
/// let l2 = Segment::new(Vec2::new(1.0, 0.2), Vec2::new(3.0, 0.2));
/// let ms = merged_segment(&l1, &l2, 0.0).unwrap();
/// assert!((ms.start - Vec2::new(0.0, 0.1)).length() < 1e-12);
/// assert!((ms.end - Vec2::new(3.0, 0.1)).length() < 1e-12);
/// ```
pub fn merged_segment(l1: &Segment, l2: &Segment, ad_rad: f64) -> Option<Segment> {
    merged_segment_weighted(l1, 1.0, l2, 1.0, ad_rad)
}

/// [`merged_segment`] with the line placed by weighted lengths: `w1·l1` and `w2·l2` instead of
/// `l1` and `l2` (a map segment many scans saw moves less towards one new sighting).
pub fn merged_segment_weighted(
    l1: &Segment,
    w1: f64,
    l2: &Segment,
    w2: f64,
    ad_rad: f64,
) -> Option<Segment> {
    let ld =
        DirectedLine::between_lengths(l1, w1 * l1.length(), l2, w2 * l2.length(), unit(ad_rad))?;
    Some(hull_on_line(&ld, l1, l2))
}

fn hull_on_line(ld: &DirectedLine, l1: &Segment, l2: &Segment) -> Segment {
    let s = [l1.start, l1.end, l2.start, l2.end].map(|p| ld.direction.dot(p));
    let lo = s.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = s.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    Segment::new(ld.point_at(lo), ld.point_at(hi))
}

/// `C(L1, L2, ad)` exactly as printed in section 2.3, together with `ms(L1, L2, ad)`.
///
/// `k` is the paper's constant `K` balancing angular against metric units. Returns `None` when
/// the cost is undefined: both segments of zero length, or both perpendicular to `ad` (the sum of
/// the projected lengths, the denominator of the length ratio `lr`, vanishes).
///
/// ```
/// use polymap::cost::cost;
/// use polymap::geometry::{Segment, Vec2};
/// // Two parallel 2 m segments 0.2 m apart, fully overlapping, along ad = 0:
/// // d(P, ld) = 0.1 for all four endpoints, lr = 2 / 4 = 0.5, all angles 0, so with K = 1
/// // C = 0.5 · 2 · ((2+1)·0.2/2 − 2·0.2/2) / (1 + 1) = 0.05.
/// let l1 = Segment::new(Vec2::new(0.0, 0.0), Vec2::new(2.0, 0.0));
/// let l2 = Segment::new(Vec2::new(0.0, 0.2), Vec2::new(2.0, 0.2));
/// let m = cost(&l1, &l2, 0.0, 1.0).unwrap();
/// assert!((m.cost - 0.05).abs() < 1e-12);
/// ```
pub fn cost(l1: &Segment, l2: &Segment, ad_rad: f64, k: f64) -> Option<Merge> {
    cost_along(l1, l2, unit(ad_rad), k)
}

/// The unit vector of a direction, as every cost computation makes it.
pub(crate) fn unit(ad_rad: f64) -> Vec2 {
    Vec2::new(ad_rad.cos(), ad_rad.sin())
}

/// [`cost`] along a main direction given as its unit vector ([`unit`]), so callers costing many
/// pairs compute it once.
pub(crate) fn cost_along(l1: &Segment, l2: &Segment, direction: Vec2, k: f64) -> Option<Merge> {
    cost_at_most(l1, l2, direction, k, f64::INFINITY)
}

/// [`cost_along`] when the cost can be at most `max_cost`; `None` as soon as a lower bound
/// shows it cannot. Merges at most `max_cost` come out exactly as [`cost_along`] makes them.
///
/// The bound, for `k ≥ 0`: `lr ≥ 1/2` (the merged segment is at least as long as the larger
/// projected length), each term is at least `d/(1 + k)` (its first fraction's denominator is
/// at most `1 + k`), and the last factor at least `1/(1 + k)`, so `C ≥ (d1 + d2) / (2(1 + k)²)`.
pub(crate) fn cost_at_most(
    l1: &Segment,
    l2: &Segment,
    direction: Vec2,
    k: f64,
    max_cost: f64,
) -> Option<Merge> {
    let (v1, v2) = (l1.vector(), l2.vector());
    let (len1, len2) = (v1.length(), v2.length());
    let ld = DirectedLine::between_lengths(l1, len1, l2, len2, direction)?;
    let d1 = ld.distance_m(l1.start) + ld.distance_m(l1.end);
    let d2 = ld.distance_m(l2.start) + ld.distance_m(l2.end);
    // The margin keeps rounding of the bound from rejecting a merge right at `max_cost`.
    if k >= 0.0 && 0.5 * (d1 + d2) / ((1.0 + k) * (1.0 + k)) > max_cost * (1.0 + 1e-9) + 1e-12 {
        return None;
    }
    let ms = hull_on_line(&ld, l1, l2);
    // Cosines of the undirected angles in [0°, 90°]: |u·w| of unit vectors; a zero-length
    // segment makes no angle (cosine 1), as its direction would be 0 anyway.
    let cos_between = |a: Vec2, la: f64, b: Vec2, lb: f64| {
        if la > 0.0 && lb > 0.0 {
            (a.dot(b) / (la * lb)).abs().min(1.0)
        } else {
            1.0
        }
    };
    let cos_a1 = cos_between(v1, len1, ld.direction, 1.0);
    let cos_a2 = cos_between(v2, len2, ld.direction, 1.0);
    let cos_a12 = cos_between(v1, len1, v2, len2);
    let projected_m = len1 * cos_a1 + len2 * cos_a2;
    if projected_m <= f64::EPSILON * (len1 + len2) {
        return None;
    }
    let lr = ms.length() / projected_m;
    let term =
        |len: f64, d: f64, cos_a: f64| (len + 1.0) * d / (1.0 + k * cos_a) - len * d / (1.0 + k);
    let c = lr * (term(len1, d1, cos_a1) + term(len2, d2, cos_a2)) / (1.0 + k * cos_a12);
    Some(Merge {
        segment: ms,
        cost: c,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_3;

    fn seg(ax: f64, ay: f64, bx: f64, by: f64) -> Segment {
        Segment::new(Vec2::new(ax, ay), Vec2::new(bx, by))
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9 * (1.0 + b.abs())
    }

    #[test]
    fn weights_move_the_merged_line_towards_the_heavier_segment() {
        let (l1, l2) = (seg(0.0, 0.0, 2.0, 0.0), seg(1.0, 0.2, 3.0, 0.2));
        // Equal weights are the paper's placement (y = 0.1); three times the first, y = 0.05.
        let even = merged_segment_weighted(&l1, 2.0, &l2, 2.0, 0.0).unwrap();
        assert!((even.start - Vec2::new(0.0, 0.1)).length() < 1e-12);
        let heavy = merged_segment_weighted(&l1, 3.0, &l2, 1.0, 0.0).unwrap();
        assert!((heavy.start - Vec2::new(0.0, 0.05)).length() < 1e-12);
        assert!((heavy.end - Vec2::new(3.0, 0.05)).length() < 1e-12);
    }

    #[test]
    fn ld_balances_length_times_distance() {
        // l1 = 3 at y = 0, l2 = 1 at y = 0.4: c = (3·0 + 1·0.4)/4 = 0.1, so d1 = 0.1, d2 = 0.3.
        let l1 = seg(0.0, 0.0, 3.0, 0.0);
        let l2 = seg(0.0, 0.4, 1.0, 0.4);
        let ld = DirectedLine::between(&l1, &l2, 0.0).unwrap();
        assert!(close(ld.offset_m, 0.1));
        assert!(close(
            ld.distance_m(l1.midpoint()) * 3.0,
            ld.distance_m(l2.midpoint()) * 1.0
        ));
    }

    /// Parallel, unequal lengths, partly overlapping: computed by hand.
    #[test]
    fn cost_parallel_by_hand() {
        // l1: (0,0)-(3,0), l2: (2,0.4)-(3,0.4), ad = 0, K = 2.
        // c = (3·0 + 1·0.4)/4 = 0.1; d(P1)+d(P2) = 0.2, d(P3)+d(P4) = 0.6.
        // ms spans x in [0, 3]: |ms| = 3, projections 3 + 1 = 4, lr = 0.75.
        // term1 = (4·0.2)/3 − 3·0.2/3 = 0.2/3; term2 = (2·0.6)/3 − 1·0.6/3 = 0.2.
        // C = 0.75 · (0.2/3 + 0.2) / 3 = 0.0666…
        let m = cost(&seg(0.0, 0.0, 3.0, 0.0), &seg(2.0, 0.4, 3.0, 0.4), 0.0, 2.0).unwrap();
        assert!(close(m.cost, 0.75 * (0.2 / 3.0 + 0.2) / 3.0), "{}", m.cost);
        assert!(close(m.segment.length(), 3.0));
        assert!(close(m.segment.start.y, 0.1));
    }

    /// One segment at 60° to ad, the other along ad: computed by hand.
    #[test]
    fn cost_angled_by_hand() {
        // l1: (0,0)-(1,0) along ad = 0; l2 from (0,0) to (0.5, √3/2): length 1 at 60°.
        // Midpoints: m1 = (0.5, 0), m2 = (0.25, √3/4). c = (0 + √3/4)/2 = √3/8.
        // d(P1)+d(P2) = 2·√3/8 = √3/4. d(P3) = √3/8, d(P4) = √3/2 − √3/8 = 3√3/8: sum √3/2.
        // ms: x in [0, 1] → 1; projections 1·1 + 1·cos60 = 1.5; lr = 2/3.
        // K = 1: term1 = 2·(√3/4)/2 − (√3/4)/2 = √3/8.
        //        term2 = 2·(√3/2)/(1 + 0.5) − (√3/2)/2 = 2√3/3 − √3/4 = 5√3/12.
        // C = (2/3)·(√3/8 + 5√3/12) / (1 + 0.5) = (4/9)·(13√3/24).
        let s3 = 3f64.sqrt();
        let l2 = seg(0.0, 0.0, 0.5, s3 / 2.0);
        let m = cost(&seg(0.0, 0.0, 1.0, 0.0), &l2, 0.0, 1.0).unwrap();
        assert!(close(m.cost, 4.0 / 9.0 * 13.0 * s3 / 24.0), "{}", m.cost);
    }

    /// Disjoint collinear segments along ad cost nothing (the known trap), and disjoint
    /// parallel ones cost more the further apart their projections are (through lr).
    #[test]
    fn cost_disjoint_by_hand() {
        let m = cost(&seg(0.0, 0.0, 1.0, 0.0), &seg(5.0, 0.0, 6.0, 0.0), 0.0, 1.0).unwrap();
        assert_eq!(m.cost, 0.0);
        assert!(close(m.segment.length(), 6.0));
        // Offset by 0.1: c = 0.05, d sums 0.1 and 0.1, lr = 6/2 = 3, K = 1:
        // term = 2·0.1/2 − 0.1/2 = 0.05 each; C = 3·0.1/2 = 0.15.
        let far = cost(&seg(0.0, 0.0, 1.0, 0.0), &seg(5.0, 0.1, 6.0, 0.1), 0.0, 1.0).unwrap();
        assert!(close(far.cost, 0.15), "{}", far.cost);
        let near = cost(&seg(0.0, 0.0, 1.0, 0.0), &seg(1.0, 0.1, 2.0, 0.1), 0.0, 1.0).unwrap();
        assert!(near.cost < far.cost);
    }

    #[test]
    fn cost_prefers_the_matching_main_direction() {
        let l1 = seg(0.0, 0.0, FRAC_PI_3.cos() * 2.0, FRAC_PI_3.sin() * 2.0);
        let l2 = seg(
            0.05,
            0.0,
            0.05 + FRAC_PI_3.cos() * 2.0,
            FRAC_PI_3.sin() * 2.0,
        );
        let along = cost(&l1, &l2, FRAC_PI_3, 1.0).unwrap().cost;
        let across = cost(&l1, &l2, 0.0, 1.0).unwrap().cost;
        assert!(along < across / 10.0, "{along} vs {across}");
    }

    #[test]
    fn cost_is_symmetric() {
        let a = seg(0.0, 0.0, 2.0, 0.1);
        let b = seg(0.5, 0.3, 1.7, 0.25);
        let ab = cost(&a, &b, 0.05, 3.0).unwrap();
        let ba = cost(&b, &a, 0.05, 3.0).unwrap();
        assert!(close(ab.cost, ba.cost));
    }

    #[test]
    fn undefined_costs_are_none() {
        assert!(cost(&seg(0.0, 0.0, 0.0, 0.0), &seg(1.0, 1.0, 1.0, 1.0), 0.0, 1.0).is_none());
        assert!(cost(&seg(0.0, 0.0, 0.0, 1.0), &seg(1.0, 0.0, 1.0, 1.0), 0.0, 1.0).is_none());
    }

    proptest::proptest! {
        /// The bound behind `cost_at_most` is a true lower bound: pruning never drops a merge
        /// at most the limit, and what it keeps is bit for bit `cost_along`'s.
        #[test]
        fn pruned_cost_agrees_with_the_full_cost(
            a in proptest::array::uniform4(-3.0f64..3.0),
            // l2 near l1, so that many costs fall around the limit.
            b in proptest::array::uniform4(-0.4f64..0.4),
            ad in 0.0f64..std::f64::consts::PI,
            k in 0.0f64..5.0,
            max_cost in 0.0f64..0.5,
        ) {
            let l1 = seg(a[0], a[1], a[2], a[3]);
            let l2 = seg(a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3]);
            let full = cost_along(&l1, &l2, unit(ad), k).filter(|m| m.cost <= max_cost);
            let pruned = cost_at_most(&l1, &l2, unit(ad), k, max_cost)
                .filter(|m| m.cost <= max_cost);
            proptest::prop_assert_eq!(full, pruned);
        }
    }
}
