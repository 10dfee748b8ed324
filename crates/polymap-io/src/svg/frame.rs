//! The picture's extent in metres, and the scale bar's round length.

use polymap::geometry::Vec2;

/// An axis-aligned box in the map frame, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Bounds {
    pub(crate) min: Vec2,
    pub(crate) max: Vec2,
}

impl Bounds {
    /// The smallest box around the finite points of `points`; `None` if there are none.
    pub(crate) fn around(points: impl IntoIterator<Item = Vec2>) -> Option<Bounds> {
        let mut bounds: Option<Bounds> = None;
        for p in points.into_iter().filter(|p| p.is_finite()) {
            bounds = Some(match bounds {
                None => Bounds { min: p, max: p },
                Some(b) => Bounds {
                    min: b.min.min(p),
                    max: b.max.max(p),
                },
            });
        }
        bounds
    }

    /// The box grown by `margin_m` on every side, and to at least `min_size_m` across.
    pub(crate) fn padded(&self, margin_m: f64, min_size_m: f64) -> Bounds {
        let centre = (self.min + self.max) * 0.5;
        let half = ((self.max - self.min) * 0.5).max(Vec2::splat(min_size_m * 0.5));
        let pad = Vec2::splat(margin_m);
        Bounds {
            min: centre - half - pad,
            max: centre + half + pad,
        }
    }

    /// Width and height, metres.
    pub(crate) fn size(&self) -> Vec2 {
        self.max - self.min
    }
}

/// The largest "round" length (1, 2 or 5 × 10^k metres) not longer than `at_most_m`
/// (7.3 → 5, 0.34 → 0.2); 1 for a non-positive or non-finite input.
pub(crate) fn round_length_m(at_most_m: f64) -> f64 {
    if at_most_m.is_nan() || at_most_m <= 0.0 || at_most_m.is_infinite() {
        return 1.0;
    }
    let decade = 10f64.powf(at_most_m.log10().floor());
    let mantissa = at_most_m / decade;
    let step = if mantissa >= 5.0 {
        5.0
    } else if mantissa >= 2.0 {
        2.0
    } else {
        1.0
    };
    step * decade
}

/// A length label: `5 m`, `200 m`, `0.5 m`, `2 km`, `20 cm`.
pub(crate) fn length_label(length_m: f64) -> String {
    if length_m >= 1000.0 {
        format!("{} km", trim_number(length_m / 1000.0))
    } else if (0.01..1.0).contains(&length_m) {
        format!("{} cm", trim_number(length_m * 100.0))
    } else {
        format!("{} m", trim_number(length_m))
    }
}

/// A number without trailing zeros, to at most 6 decimals.
fn trim_number(v: f64) -> String {
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    s.to_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_lengths_are_1_2_5_times_a_power_of_ten() {
        for (at_most, expected) in [
            (7.3, 5.0),
            (5.0, 5.0),
            (4.99, 2.0),
            (1.0, 1.0),
            (0.34, 0.2),
            (1234.0, 1000.0),
            (19.9, 10.0),
        ] {
            assert_eq!(round_length_m(at_most), expected, "{at_most}");
        }
        assert_eq!(round_length_m(0.0), 1.0);
        assert_eq!(round_length_m(f64::NAN), 1.0);
    }

    #[test]
    fn labels_use_readable_units() {
        assert_eq!(length_label(5.0), "5 m");
        assert_eq!(length_label(200.0), "200 m");
        assert_eq!(length_label(0.5), "50 cm");
        assert_eq!(length_label(2000.0), "2 km");
        assert_eq!(length_label(0.001), "0.001 m");
    }

    #[test]
    fn bounds_skip_non_finite_points_and_pad() {
        let b = Bounds::around([
            Vec2::new(1.0, 2.0),
            Vec2::new(f64::NAN, 0.0),
            Vec2::new(3.0, -1.0),
        ])
        .unwrap();
        assert_eq!(
            b,
            Bounds {
                min: Vec2::new(1.0, -1.0),
                max: Vec2::new(3.0, 2.0)
            }
        );
        let p = b.padded(0.5, 4.0);
        assert_eq!(p.size(), Vec2::new(5.0, 5.0));
        assert!(Bounds::around([Vec2::new(f64::INFINITY, 0.0)]).is_none());
    }
}
