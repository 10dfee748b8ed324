//! Rigid transforms in the plane.

use serde::{Deserialize, Serialize};

use super::{Vec2, normalize_angle_rad};

/// A rigid transform of the plane, SE(2): rotation by `theta_rad`, then translation by `(x_m, y_m)`.
///
/// A pose named `a_from_b` maps points given in frame `b` into frame `a`; the robot's pose in the
/// map is `map_from_robot`.
///
/// ```
/// use polymap::geometry::{Pose2, Vec2};
/// let map_from_robot = Pose2::new(1.0, 2.0, std::f64::consts::FRAC_PI_2);
/// let p_in_map = map_from_robot.transform_point(Vec2::new(1.0, 0.0));
/// assert!((p_in_map - Vec2::new(1.0, 3.0)).length() < 1e-12);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose2 {
    /// Translation along x, metres.
    pub x_m: f64,
    /// Translation along y, metres.
    pub y_m: f64,
    /// Rotation, radians, counter-clockwise, kept in `(-π, π]`.
    pub theta_rad: f64,
}

impl Pose2 {
    /// The identity transform.
    pub const IDENTITY: Pose2 = Pose2 {
        x_m: 0.0,
        y_m: 0.0,
        theta_rad: 0.0,
    };

    /// A pose from translation (metres) and rotation (radians); the angle is normalised.
    pub fn new(x_m: f64, y_m: f64, theta_rad: f64) -> Self {
        Pose2 {
            x_m,
            y_m,
            theta_rad: normalize_angle_rad(theta_rad),
        }
    }

    /// The translation part, metres.
    pub fn translation(&self) -> Vec2 {
        Vec2::new(self.x_m, self.y_m)
    }

    /// Rotates a vector (no translation).
    pub fn rotate(&self, v: Vec2) -> Vec2 {
        let (s, c) = self.theta_rad.sin_cos();
        Vec2::new(c * v.x - s * v.y, s * v.x + c * v.y)
    }

    /// Maps a point from the child frame into the parent frame.
    pub fn transform_point(&self, p: Vec2) -> Vec2 {
        self.rotate(p) + self.translation()
    }

    /// `self ∘ other`: if `self` is `a_from_b` and `other` is `b_from_c`, the result is `a_from_c`.
    ///
    /// ```
    /// use polymap::geometry::Pose2;
    /// let a = Pose2::new(1.0, 0.0, 0.5);
    /// let id = a.compose(&a.inverse());
    /// assert!(id.translation().length() < 1e-12 && id.theta_rad.abs() < 1e-12);
    /// ```
    pub fn compose(&self, other: &Pose2) -> Pose2 {
        let t = self.transform_point(other.translation());
        Pose2::new(t.x, t.y, self.theta_rad + other.theta_rad)
    }

    /// The inverse transform: `b_from_a` for `a_from_b`.
    pub fn inverse(&self) -> Pose2 {
        let inv_rot = Pose2::new(0.0, 0.0, -self.theta_rad);
        let t = inv_rot.rotate(-self.translation());
        Pose2::new(t.x, t.y, -self.theta_rad)
    }

    /// The transform from `self` to `other`: `inverse(self) ∘ other`.
    ///
    /// For two robot poses in the map this is the motion between them, in the first robot's frame.
    pub fn between(&self, other: &Pose2) -> Pose2 {
        self.inverse().compose(other)
    }

    /// The pose a fraction `f` of the way from `self` to `other` (0: `self`, 1: `other`):
    /// position along the straight line, heading along the shorter arc. For poses at two
    /// times of one frame (odometry read before and after a scan's stamp).
    ///
    /// ```
    /// use polymap::geometry::Pose2;
    /// let a = Pose2::new(0.0, 0.0, 3.0);
    /// let b = Pose2::new(2.0, 4.0, -3.0);
    /// let m = a.interpolate(&b, 0.5);
    /// assert_eq!((m.x_m, m.y_m), (1.0, 2.0));
    /// // Through ±π, not through 0.
    /// assert!((m.theta_rad.abs() - std::f64::consts::PI).abs() < 1e-12);
    /// ```
    pub fn interpolate(&self, other: &Pose2, f: f64) -> Pose2 {
        let d = other.theta_rad - self.theta_rad;
        let d = d - std::f64::consts::TAU * (d / std::f64::consts::TAU).round();
        Pose2::new(
            self.x_m + f * (other.x_m - self.x_m),
            self.y_m + f * (other.y_m - self.y_m),
            self.theta_rad + f * d,
        )
    }

    /// `other` less `self` over (x metres, y metres, θ radians) in the frame both are given
    /// in, the heading along the shorter arc: the difference an information matrix over a
    /// pose weighs.
    ///
    /// ```
    /// use polymap::geometry::Pose2;
    /// let d = Pose2::new(1.0, 2.0, 3.0).offset_to(&Pose2::new(1.5, 1.0, -3.0));
    /// assert_eq!((d.x, d.y), (0.5, -1.0));
    /// assert!((d.z - (std::f64::consts::TAU - 6.0)).abs() < 1e-12);
    /// ```
    pub fn offset_to(&self, other: &Pose2) -> glam::DVec3 {
        glam::DVec3::new(
            other.x_m - self.x_m,
            other.y_m - self.y_m,
            normalize_angle_rad(other.theta_rad - self.theta_rad),
        )
    }

    /// True when every field is finite.
    pub fn is_finite(&self) -> bool {
        self.x_m.is_finite() && self.y_m.is_finite() && self.theta_rad.is_finite()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compose_then_inverse_is_identity() {
        let a = Pose2::new(3.0, -1.0, 2.5);
        let b = Pose2::new(-0.5, 4.0, -1.0);
        let ab = a.compose(&b);
        let back = a.inverse().compose(&ab);
        assert!((back.translation() - b.translation()).length() < 1e-12);
        assert!((back.theta_rad - b.theta_rad).abs() < 1e-12);
    }

    #[test]
    fn between_gives_relative_motion_in_first_frame() {
        let p1 = Pose2::new(1.0, 1.0, std::f64::consts::FRAC_PI_2);
        let p2 = Pose2::new(1.0, 2.0, std::f64::consts::FRAC_PI_2);
        let d = p1.between(&p2);
        assert!((d.x_m - 1.0).abs() < 1e-12 && d.y_m.abs() < 1e-12 && d.theta_rad.abs() < 1e-12);
    }
}
