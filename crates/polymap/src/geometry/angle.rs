//! Angle helpers. Directions of segments are undirected: they live in `[0, π)`.

use std::f64::consts::{PI, TAU};

/// `a.rem_euclid(m)` for `m > 0`, exactly, without the library's software `fmod` (a call on the
/// default x86-64 target) when `|a| < m`: the remainder of such an `a` is `a` itself.
#[inline]
fn rem_euclid(a: f64, m: f64) -> f64 {
    let r = match a.abs() < m {
        true => a,
        false => a % m,
    };
    if r < 0.0 { r + m } else { r }
}

/// Wraps any angle to `(-π, π]`, in radians.
///
/// ```
/// use polymap::geometry::normalize_angle_rad;
/// assert!((normalize_angle_rad(3.0 * std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-12);
/// assert!((normalize_angle_rad(-0.5) + 0.5).abs() < 1e-12);
/// ```
pub fn normalize_angle_rad(a: f64) -> f64 {
    let r = rem_euclid(a, TAU);
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
    let r = rem_euclid(a, PI);
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
    let d = rem_euclid(a - b, PI);
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

    fn assert_same_remainder(a: f64) {
        for m in [TAU, PI] {
            let (got, want) = (rem_euclid(a, m), a.rem_euclid(m));
            assert!(
                got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                "{a} {m}: {got} {want}"
            );
        }
    }

    #[test]
    fn the_remainder_is_the_library_one_bit_for_bit() {
        let special = [
            0.0,
            -0.0,
            PI,
            -PI,
            TAU,
            -TAU,
            TAU.next_down(),
            -TAU.next_down(),
            PI.next_up(),
            -1e-18,
            1e300,
            -1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        for a in special {
            assert_same_remainder(a);
        }
        for i in -20_000..20_000 {
            assert_same_remainder(f64::from(i) * 0.000_731_9 * f64::from(i % 97));
        }
    }

    proptest::proptest! {
        #[test]
        fn the_remainder_of_any_float_is_the_library_one(a in proptest::num::f64::ANY) {
            assert_same_remainder(a);
        }
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
