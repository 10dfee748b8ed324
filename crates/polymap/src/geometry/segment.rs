//! Line segments.

use serde::{Deserialize, Serialize};

use super::{Pose2, Vec2, undirected_angle_rad};

/// A line segment between two points, metres, in whatever frame its owner names.
///
/// ```
/// use polymap::geometry::{Segment, Vec2};
/// let s = Segment::new(Vec2::new(0.0, 0.0), Vec2::new(2.0, 0.0));
/// assert_eq!(s.length(), 2.0);
/// assert_eq!(s.distance_to_point(Vec2::new(1.0, 0.5)), 0.5);
/// assert_eq!(s.distance_to_point(Vec2::new(3.0, 0.0)), 1.0);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Segment {
    /// First endpoint.
    pub start: Vec2,
    /// Second endpoint.
    pub end: Vec2,
}

/// Where a point falls on a segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmentProjection {
    /// The closest point of the segment.
    pub point: Vec2,
    /// Its parameter along the segment, `0` at `start` and `1` at `end`.
    pub t: f64,
    /// Squared distance from the query point to `point`, m².
    pub distance_2: f64,
}

impl Segment {
    /// A segment from two endpoints.
    pub fn new(start: Vec2, end: Vec2) -> Self {
        Segment { start, end }
    }

    /// `end - start`.
    pub fn vector(&self) -> Vec2 {
        self.end - self.start
    }

    /// Distance along the unit ray `origin + t·dir` to this segment, if the ray crosses it at
    /// `t > 0`, metres; a ray parallel to the segment (grazing along it) does not hit it. The
    /// one ray–segment test of the project (the simulator's ray caster and the tests' scans).
    ///
    /// ```
    /// use polymap::geometry::{Segment, Vec2};
    /// let wall = Segment::new(Vec2::new(3.0, -1.0), Vec2::new(3.0, 1.0));
    /// assert_eq!(wall.ray_hit_m(Vec2::ZERO, Vec2::X), Some(3.0));
    /// assert_eq!(wall.ray_hit_m(Vec2::ZERO, -Vec2::X), None);
    /// ```
    #[inline]
    pub fn ray_hit_m(&self, origin: Vec2, dir: Vec2) -> Option<f64> {
        let e = self.vector();
        let denom = dir.perp_dot(e);
        if denom == 0.0 || !denom.is_finite() {
            return None;
        }
        let ao = self.start - origin;
        let t = ao.perp_dot(e) / denom;
        let s = ao.perp_dot(dir) / denom;
        (t > 0.0 && (0.0..=1.0).contains(&s)).then_some(t)
    }

    /// Length, metres.
    pub fn length(&self) -> f64 {
        self.vector().length()
    }

    /// Squared length, m².
    pub fn length_2(&self) -> f64 {
        self.vector().length_squared()
    }

    /// Midpoint.
    pub fn midpoint(&self) -> Vec2 {
        (self.start + self.end) * 0.5
    }

    /// Undirected direction in `[0, π)` radians, measured from the x axis of the segment's frame.
    pub fn direction_rad(&self) -> f64 {
        let v = self.vector();
        undirected_angle_rad(v.y.atan2(v.x))
    }

    /// The closest point of the segment to `p`, with its parameter and squared distance.
    pub fn project(&self, p: Vec2) -> SegmentProjection {
        let v = self.vector();
        let len_2 = v.length_squared();
        let t = if len_2 > 0.0 {
            ((p - self.start).dot(v) / len_2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let point = self.start + v * t;
        SegmentProjection {
            point,
            t,
            distance_2: (p - point).length_squared(),
        }
    }

    /// Squared distance from a point, m².
    pub fn distance_2_to_point(&self, p: Vec2) -> f64 {
        self.project(p).distance_2
    }

    /// Distance from a point, metres.
    pub fn distance_to_point(&self, p: Vec2) -> f64 {
        self.distance_2_to_point(p).sqrt()
    }

    /// Smallest distance between two segments, metres (zero when they cross).
    ///
    /// ```
    /// use polymap::geometry::{Segment, Vec2};
    /// let a = Segment::new(Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0));
    /// let b = Segment::new(Vec2::new(2.0, 1.0), Vec2::new(2.0, 3.0));
    /// assert!((a.distance_to_segment(&b) - 2f64.sqrt()).abs() < 1e-12);
    /// let c = Segment::new(Vec2::new(0.5, -1.0), Vec2::new(0.5, 1.0));
    /// assert_eq!(a.distance_to_segment(&c), 0.0);
    /// ```
    pub fn distance_to_segment(&self, other: &Segment) -> f64 {
        self.distance_to_segment_within(other, f64::INFINITY)
            .unwrap_or(f64::INFINITY)
    }

    /// The distance to `other` when it is at most `limit_m`, metres; `None` otherwise. Cheaper
    /// than [`Segment::distance_to_segment`] for far pairs: their bounding boxes are compared
    /// first.
    ///
    /// ```
    /// use polymap::geometry::{Segment, Vec2};
    /// let a = Segment::new(Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0));
    /// let b = Segment::new(Vec2::new(0.0, 0.3), Vec2::new(1.0, 0.3));
    /// assert!((a.distance_to_segment_within(&b, 0.5).unwrap() - 0.3).abs() < 1e-12);
    /// assert_eq!(a.distance_to_segment_within(&b, 0.2), None);
    /// ```
    pub fn distance_to_segment_within(&self, other: &Segment, limit_m: f64) -> Option<f64> {
        let (alo, ahi) = self.bounds();
        let (blo, bhi) = other.bounds();
        let gap = (blo - ahi).max(alo - bhi).max(Vec2::ZERO);
        if gap.length_squared() > limit_m * limit_m {
            return None;
        }
        let d = self.exact_distance_to_segment(other);
        (d <= limit_m).then_some(d)
    }

    fn exact_distance_to_segment(&self, other: &Segment) -> f64 {
        if self.intersects(other) {
            return 0.0;
        }
        let d_2 = self
            .distance_2_to_point(other.start)
            .min(self.distance_2_to_point(other.end))
            .min(other.distance_2_to_point(self.start))
            .min(other.distance_2_to_point(self.end));
        d_2.sqrt()
    }

    /// True when the two closed segments share a point (proper crossings and touching ends).
    pub fn intersects(&self, other: &Segment) -> bool {
        let d1 = self.vector();
        let d2 = other.vector();
        let o1 = d1.perp_dot(other.start - self.start);
        let o2 = d1.perp_dot(other.end - self.start);
        let o3 = d2.perp_dot(self.start - other.start);
        let o4 = d2.perp_dot(self.end - other.start);
        // Strict sign changes on both: a proper crossing. Touching and collinear cases give a
        // zero orientation and are caught by the endpoint distances of the caller.
        (o1 * o2 < 0.0) && (o3 * o4 < 0.0)
    }

    /// The segment mapped through a pose (`a_from_b` applied to a segment in frame `b`).
    pub fn transformed(&self, a_from_b: &Pose2) -> Segment {
        Segment::new(
            a_from_b.transform_point(self.start),
            a_from_b.transform_point(self.end),
        )
    }

    /// The axis-aligned bounding box as `(min, max)` corners.
    pub fn bounds(&self) -> (Vec2, Vec2) {
        (self.start.min(self.end), self.start.max(self.end))
    }

    /// True when both endpoints are finite.
    pub fn is_finite(&self) -> bool {
        self.start.is_finite() && self.end.is_finite()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projection_clamps_to_endpoints() {
        let s = Segment::new(Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0));
        let p = s.project(Vec2::new(-2.0, 1.0));
        assert_eq!(p.t, 0.0);
        assert_eq!(p.point, Vec2::ZERO);
        assert_eq!(p.distance_2, 5.0);
    }

    #[test]
    fn degenerate_segment_projects_to_its_point() {
        let s = Segment::new(Vec2::new(1.0, 1.0), Vec2::new(1.0, 1.0));
        assert_eq!(s.distance_to_point(Vec2::new(1.0, 2.0)), 1.0);
    }

    #[test]
    fn direction_is_undirected() {
        let a = Segment::new(Vec2::new(0.0, 0.0), Vec2::new(1.0, 1.0));
        let b = Segment::new(Vec2::new(1.0, 1.0), Vec2::new(0.0, 0.0));
        assert!((a.direction_rad() - b.direction_rad()).abs() < 1e-12);
        assert!((a.direction_rad() - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
    }

    #[test]
    fn parallel_segments_distance() {
        let a = Segment::new(Vec2::new(0.0, 0.0), Vec2::new(4.0, 0.0));
        let b = Segment::new(Vec2::new(1.0, 0.3), Vec2::new(2.0, 0.3));
        assert!((a.distance_to_segment(&b) - 0.3).abs() < 1e-12);
    }
}
