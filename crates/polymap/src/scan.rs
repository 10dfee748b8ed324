//! Range scans as they come from a sensor, and their conversion to points.

use serde::{Deserialize, Serialize};

use crate::geometry::{Pose2, Segment, Vec2};

/// A time stamp exactly as the log wrote it, with its value in seconds.
///
/// Output formats write `text` back unchanged, so no precision is lost to a float round trip.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Stamp {
    /// Seconds, as parsed from `text`.
    pub seconds: f64,
    /// The literal text of the log's field.
    pub text: String,
}

impl Stamp {
    /// A stamp from a value in seconds; the text is written with nanosecond precision.
    ///
    /// ```
    /// use polymap::scan::Stamp;
    /// assert_eq!(Stamp::from_seconds(1.5).text, "1.500000000");
    /// ```
    pub fn from_seconds(seconds: f64) -> Self {
        Stamp {
            seconds,
            text: format!("{seconds:.9}"),
        }
    }
}

/// One 2D laser scan: ranges at evenly spaced bearings, plus what the log says about the pose.
///
/// Beam `i` points at bearing `angle_min_rad + i · angle_increment_rad` in the laser frame
/// (x forward, y left). The laser frame sits at `robot_from_laser` in the robot frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RangeScan {
    /// When the scan was taken.
    pub stamp: Stamp,
    /// Measured ranges, metres. Non-finite, non-positive or `>= max_range_m` values are no-returns.
    pub ranges_m: Vec<f64>,
    /// Bearing of the first beam in the laser frame, radians.
    pub angle_min_rad: f64,
    /// Bearing step between consecutive beams, radians.
    pub angle_increment_rad: f64,
    /// Readings at or beyond this range are no-returns, metres.
    pub max_range_m: f64,
    /// Mounting of the laser on the robot.
    pub robot_from_laser: Pose2,
    /// The robot's odometry pose at scan time, in the odometry frame, if the log carries one.
    pub odom_from_robot: Option<Pose2>,
}

impl RangeScan {
    /// True when beam reading `r` is a real return.
    pub fn is_valid_range(&self, r: f64) -> bool {
        r.is_finite() && r > 0.0 && r < self.max_range_m
    }

    /// True when the beams go all the way round (`n · |angle_increment| ≥ 2π` to half a step):
    /// the last beam then neighbours the first, and the scan is one closed curve.
    ///
    /// ```
    /// use polymap::scan::{RangeScan, Stamp};
    /// use polymap::geometry::Pose2;
    /// let mut scan = RangeScan {
    ///     stamp: Stamp::from_seconds(0.0),
    ///     ranges_m: vec![1.0; 360],
    ///     angle_min_rad: -std::f64::consts::PI,
    ///     angle_increment_rad: 1f64.to_radians(),
    ///     max_range_m: 10.0,
    ///     robot_from_laser: Pose2::IDENTITY,
    ///     odom_from_robot: None,
    /// };
    /// assert!(scan.is_full_circle());
    /// scan.ranges_m.truncate(270);
    /// assert!(!scan.is_full_circle());
    /// ```
    pub fn is_full_circle(&self) -> bool {
        let step = self.angle_increment_rad.abs();
        step > 0.0 && (self.ranges_m.len() as f64 + 0.5) * step >= std::f64::consts::TAU
    }

    /// Number of valid returns.
    pub fn valid_count(&self) -> usize {
        self.ranges_m
            .iter()
            .filter(|&&r| self.is_valid_range(r))
            .count()
    }

    /// Writes the valid returns into `out` as points in the robot frame, in beam order.
    ///
    /// `out` is cleared first; reusing one buffer avoids an allocation per scan.
    ///
    /// ```
    /// use polymap::scan::{RangeScan, Stamp};
    /// use polymap::geometry::Pose2;
    /// let scan = RangeScan {
    ///     stamp: Stamp::from_seconds(0.0),
    ///     ranges_m: vec![1.0, f64::NAN, 2.0],
    ///     angle_min_rad: -std::f64::consts::FRAC_PI_2,
    ///     angle_increment_rad: std::f64::consts::FRAC_PI_2,
    ///     max_range_m: 10.0,
    ///     robot_from_laser: Pose2::IDENTITY,
    ///     odom_from_robot: None,
    /// };
    /// let mut pts = Vec::new();
    /// scan.points_in_robot(&mut pts);
    /// assert_eq!(pts.len(), 2);
    /// assert!((pts[0].y + 1.0).abs() < 1e-12 && (pts[1].y - 2.0).abs() < 1e-12);
    /// ```
    pub fn points_in_robot(&self, out: &mut Vec<Vec2>) {
        out.clear();
        out.reserve(self.ranges_m.len());
        let (s0, c0) = self.angle_min_rad.sin_cos();
        let (sd, cd) = self.angle_increment_rad.sin_cos();
        // Rotate the beam direction incrementally; renormalise from time to time so the error
        // stays far below a range's resolution even for thousands of beams.
        let (mut s, mut c) = (s0, c0);
        for (i, &r) in self.ranges_m.iter().enumerate() {
            if self.is_valid_range(r) {
                out.push(
                    self.robot_from_laser
                        .transform_point(Vec2::new(c * r, s * r)),
                );
            }
            let (s1, c1) = (s * cd + c * sd, c * cd - s * sd);
            if i % 64 == 63 {
                let (sx, cx) =
                    (self.angle_min_rad + (i + 1) as f64 * self.angle_increment_rad).sin_cos();
                s = sx;
                c = cx;
            } else {
                s = s1;
                c = c1;
            }
        }
    }
}

/// A scan made ready for mapping by [`crate::mapper::Mapper::prepare`]: what tracking and the
/// map need of it, computed without the mapper's state, so that it may be done ahead (on
/// another thread).
#[derive(Debug, Clone, PartialEq)]
pub struct PreparedScan {
    /// Valid returns within `extract.max_range_m`, robot frame, metres, in beam order.
    pub points_in_robot: Vec<Vec2>,
    /// Extracted segments, robot frame, metres.
    pub segments_in_robot: Vec<Segment>,
    /// The robot's odometry pose at scan time, odometry frame, if the log carries one.
    pub odom_from_robot: Option<Pose2>,
    /// The scan's stamp, seconds, when known (finite).
    pub stamp_s: Option<f64>,
    /// Wall-clock seconds the preparation took.
    pub extract_s: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scan(ranges_m: Vec<f64>, n: usize) -> RangeScan {
        RangeScan {
            stamp: Stamp::from_seconds(1.0),
            ranges_m,
            angle_min_rad: -std::f64::consts::FRAC_PI_2,
            angle_increment_rad: std::f64::consts::PI / n as f64,
            max_range_m: 80.0,
            robot_from_laser: Pose2::IDENTITY,
            odom_from_robot: None,
        }
    }

    #[test]
    fn no_returns_are_dropped() {
        let s = scan(vec![0.0, -1.0, f64::INFINITY, f64::NAN, 80.0, 81.0, 5.0], 6);
        assert_eq!(s.valid_count(), 1);
    }

    #[test]
    fn incremental_bearings_match_direct_ones() {
        let n = 1000;
        let s = scan(vec![10.0; n], n);
        let mut pts = Vec::new();
        s.points_in_robot(&mut pts);
        for (i, p) in pts.iter().enumerate() {
            let a = s.angle_min_rad + i as f64 * s.angle_increment_rad;
            let q = Vec2::new(a.cos(), a.sin()) * 10.0;
            assert!((*p - q).length() < 1e-9, "beam {i}");
        }
    }

    #[test]
    fn laser_offset_is_applied() {
        let mut s = scan(vec![1.0], 1);
        s.angle_min_rad = 0.0;
        s.robot_from_laser = Pose2::new(0.5, 0.0, 0.0);
        let mut pts = Vec::new();
        s.points_in_robot(&mut pts);
        assert!((pts[0] - Vec2::new(1.5, 0.0)).length() < 1e-12);
    }
}
