//! Cell coordinates of grids (rasters, spatial indexes).

/// `v.floor() as i64`, exactly (saturating at the ends of `i64`, 0 for NaN), without a call to
/// a software `floor`: the default x86-64 target has no rounding instruction, and the
/// correlative matcher and the segment index take the cell of every point (the library call
/// costs about 6 % of a run over every 5th scan of FR079).
///
/// ```
/// use polymap::geometry::floor_i64;
/// for v in [-2.5, -2.0, -0.5, -0.0, 0.0, 0.5, 2.0, 2.5, 1e30, -1e30, f64::NAN] {
///     assert_eq!(floor_i64(v), v.floor() as i64, "{v}");
/// }
/// ```
#[inline]
pub fn floor_i64(v: f64) -> i64 {
    let t = v as i64;
    if (t as f64) > v {
        t.saturating_sub(1)
    } else {
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn equals_the_library_floor(v in proptest::num::f64::ANY) {
            prop_assert_eq!(floor_i64(v), v.floor() as i64);
        }

        #[test]
        fn equals_the_library_floor_near_cells(k in -1_000_000i64..1_000_000, f in 0.0f64..1.0) {
            let v = k as f64 * 0.1 + f * 1e-9 - 5e-10;
            prop_assert_eq!(floor_i64(v), v.floor() as i64);
        }
    }
}
