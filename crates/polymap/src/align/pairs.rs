//! Pose hypotheses from pairs of segments (an addition to the paper): two non-parallel
//! segments of one set that meet, or nearly meet, form a corner; a corner of the fixed set
//! matched to a corner of the moving set with the same angle fixes a rigid pose (the rotation
//! that turns one pair's directions into the other's, the translation that puts one corner
//! point on the other). Segments are undirected, so every match gives two poses, half a turn
//! apart.
//!
//! Walls meet at corners, doorways and T-junctions, and two maps of one building share most
//! of them: the true pose is among the hypotheses as soon as one corner is seen in both. The
//! hypotheses are only candidates; [`crate::align::global_match`] verifies them by a score.

use std::f64::consts::PI;

use crate::geometry::{Pose2, Segment, Vec2, undirected_angle_rad};

/// Two non-parallel segments that meet within a reach: where their lines cross, their
/// directions, and the signed angle from the first line to the second.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Corner {
    /// Where the two lines cross, metres, in the segments' frame.
    pub point: Vec2,
    /// Undirected direction of the first segment, radians in `[0, π)`.
    pub first_rad: f64,
    /// Undirected direction of the second segment, radians in `[0, π)`.
    pub second_rad: f64,
    /// The angle from the first line to the second, radians in `(0, π)`.
    pub angle_rad: f64,
    /// The shorter segment's length, metres: how well the corner's directions are known.
    pub weight_m: f64,
}

/// The corners among `segments`: pairs of segments at least `min_segment_m` long, at least
/// `min_angle_rad` from parallel, whose lines cross within `reach_m` of both segments. Only the
/// `max_segments` longest segments take part. Each pair gives one corner, in the order of the
/// (length-sorted) segments.
///
/// ```
/// use polymap::align::corners;
/// use polymap::geometry::{Segment, Vec2};
/// let l = [
///     Segment::new(Vec2::new(0.0, 0.0), Vec2::new(3.0, 0.0)),
///     Segment::new(Vec2::new(0.1, 0.2), Vec2::new(0.1, 2.0)),
///     Segment::new(Vec2::new(5.0, 5.0), Vec2::new(5.0, 7.0)), // too far from the others
/// ];
/// let found = corners(&l, 0.5, 100, 0.5, 1.0);
/// assert_eq!(found.len(), 1);
/// assert!(found[0].point.distance(Vec2::new(0.1, 0.0)) < 1e-12);
/// ```
pub fn corners(
    segments: &[Segment],
    min_segment_m: f64,
    max_segments: usize,
    min_angle_rad: f64,
    reach_m: f64,
) -> Vec<Corner> {
    let mut long: Vec<&Segment> = segments
        .iter()
        .filter(|s| s.is_finite() && s.length() >= min_segment_m)
        .collect();
    long.sort_by(|a, b| b.length().total_cmp(&a.length()));
    long.truncate(max_segments);
    let mut found = Vec::new();
    for (i, a) in long.iter().enumerate() {
        for b in &long[i + 1..] {
            if let Some(c) = corner(a, b, min_angle_rad, reach_m) {
                found.push(c);
            }
        }
    }
    found
}

/// The corner of `a` and `b`, if they are far enough from parallel and their lines cross
/// within `reach_m` of both.
fn corner(a: &Segment, b: &Segment, min_angle_rad: f64, reach_m: f64) -> Option<Corner> {
    let (u, v) = (a.vector(), b.vector());
    let cross = u.perp_dot(v);
    let sin = cross / (u.length() * v.length());
    if sin.abs() < min_angle_rad.sin() {
        return None;
    }
    // a.start + s·u = b.start + r·v
    let s = (b.start - a.start).perp_dot(v) / cross;
    let point = a.start + u * s;
    if a.distance_to_point(point) > reach_m || b.distance_to_point(point) > reach_m {
        return None;
    }
    let (first_rad, second_rad) = (a.direction_rad(), b.direction_rad());
    Some(Corner {
        point,
        first_rad,
        second_rad,
        angle_rad: undirected_angle_rad(second_rad - first_rad),
        weight_m: a.length().min(b.length()),
    })
}

/// The poses `fixed_from_moving` that put corner `moving` on corner `fixed`, if their angles
/// agree within `tolerance_rad` (in either order of the moving corner's segments): for each
/// way the segments can correspond, the rotation (the weighted mean of the two segments'
/// turns) and that rotation plus half a turn.
pub fn corner_poses(fixed: &Corner, moving: &Corner, tolerance_rad: f64) -> Vec<Pose2> {
    let mut poses = Vec::new();
    let orders = [
        (moving.first_rad, moving.second_rad, moving.angle_rad),
        (moving.second_rad, moving.first_rad, PI - moving.angle_rad),
    ];
    for (m1, m2, angle) in orders {
        if (fixed.angle_rad - angle).abs() > tolerance_rad {
            continue;
        }
        let turn1 = undirected_angle_rad(fixed.first_rad - m1);
        let turn2 = undirected_angle_rad(fixed.second_rad - m2);
        // Both turns are one rotation modulo π: average them on the near side of turn1.
        let turn2 = turn1 + (turn2 - turn1 + PI / 2.0).rem_euclid(PI) - PI / 2.0;
        let theta = 0.5 * (turn1 + turn2);
        for theta in [theta, theta + PI] {
            let rotated = Pose2::new(0.0, 0.0, theta).rotate(moving.point);
            let t = fixed.point - rotated;
            poses.push(Pose2::new(
                t.x,
                t.y,
                crate::geometry::normalize_angle_rad(theta),
            ));
        }
    }
    poses
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seg(x0: f64, y0: f64, x1: f64, y1: f64) -> Segment {
        Segment::new(Vec2::new(x0, y0), Vec2::new(x1, y1))
    }

    #[test]
    fn parallel_or_distant_segments_make_no_corner() {
        let parallel = [seg(0.0, 0.0, 3.0, 0.0), seg(0.0, 0.5, 3.0, 0.6)];
        assert!(corners(&parallel, 0.1, 10, 0.5, 1.0).is_empty());
        let apart = [seg(0.0, 0.0, 3.0, 0.0), seg(5.0, 2.0, 5.0, 4.0)];
        assert!(corners(&apart, 0.1, 10, 0.5, 1.0).is_empty());
        let short = [seg(0.0, 0.0, 3.0, 0.0), seg(0.0, 0.0, 0.0, 0.2)];
        assert!(corners(&short, 0.5, 10, 0.5, 1.0).is_empty());
    }

    #[test]
    fn a_turned_and_shifted_corner_gives_the_pose_among_its_hypotheses() {
        let truth = Pose2::new(2.0, -1.0, 2.2);
        let l = [seg(0.0, 0.0, 3.0, 0.0), seg(0.0, 0.0, 1.0, 2.0)];
        let moved: Vec<Segment> = l.iter().map(|s| s.transformed(&truth.inverse())).collect();
        let fixed = corners(&l, 0.1, 10, 0.5, 1.0);
        let moving = corners(&moved, 0.1, 10, 0.5, 1.0);
        assert_eq!((fixed.len(), moving.len()), (1, 1));
        let poses = corner_poses(&fixed[0], &moving[0], 0.01);
        assert!(!poses.is_empty() && poses.len() <= 4);
        let best = poses
            .iter()
            .map(|p| {
                let d = truth.between(p);
                d.translation().length() + d.theta_rad.abs()
            })
            .fold(f64::INFINITY, f64::min);
        assert!(best < 1e-9, "{poses:?}");
    }

    #[test]
    fn corners_of_different_angles_do_not_match() {
        let a = corners(
            &[seg(0.0, 0.0, 3.0, 0.0), seg(0.0, 0.0, 0.0, 2.0)],
            0.1,
            10,
            0.5,
            1.0,
        );
        let b = corners(
            &[seg(0.0, 0.0, 3.0, 0.0), seg(0.0, 0.0, 2.0, 2.0)],
            0.1,
            10,
            0.5,
            1.0,
        );
        assert!(corner_poses(&a[0], &b[0], 3f64.to_radians()).is_empty());
    }
}
