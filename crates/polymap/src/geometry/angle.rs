//! Angle helpers. Directions of segments are undirected: they live in `[0, π)`.

use std::f64::consts::{PI, TAU};

/// Wraps any angle to `(-π, π]`, in radians.
///
/// ```
/// use polymap::geometry::normalize_angle_rad;
/// assert!((normalize_angle_rad(3.0 * std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-12);
/// assert!((normalize_angle_rad(-0.5) + 0.5).abs() < 1e-12);
/// ```
pub fn normalize_angle_rad(a: f64) -> f64 {
    let r = a.rem_euclid(TAU);
    if r > PI { r - TAU } else { r }
}

/// Maps a direction angle to the undirected range `[0, π)`, in radians.
///
/// ```
/// use polymap::geometry::undirected_angle_rad;
/// let a = undirected_angle_rad(-std::f64::consts::FRAC_PI_4);
/// assert!((a - 3.0 * std::f64::consts::FRAC_PI_4).abs() < 1e-12);
/// ```
pub fn undirected_angle_rad(a: f64) -> f64 {
    let r = a.rem_euclid(PI);
    // rem_euclid can return exactly PI for tiny negative inputs through rounding.
    if r >= PI { 0.0 } else { r }
}

/// The angle between two undirected directions, in `[0, π/2]` radians.
///
/// ```
/// use polymap::geometry::angle_between_directions_rad;
/// let d = angle_between_directions_rad(0.1, std::f64::consts::PI - 0.1);
/// assert!((d - 0.2).abs() < 1e-12);
/// ```
pub fn angle_between_directions_rad(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(PI);
    d.min(PI - d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn undirected_angles_fold_into_half_turn() {
        assert!((undirected_angle_rad(PI + 0.3) - 0.3).abs() < 1e-12);
        assert_eq!(undirected_angle_rad(0.0), 0.0);
        assert!(undirected_angle_rad(-1e-18) < PI);
    }

    #[test]
    fn angle_between_is_symmetric_and_bounded() {
        for &(a, b) in &[(0.0, 1.0), (3.0, 0.1), (1.5, 1.6), (0.0, PI / 2.0)] {
            let d = angle_between_directions_rad(a, b);
            assert!((d - angle_between_directions_rad(b, a)).abs() < 1e-12);
            assert!((0.0..=PI / 2.0 + 1e-12).contains(&d));
        }
    }
}
