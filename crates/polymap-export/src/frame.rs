//! The extent of a picture in metres, the scale bar's round length, and the polyline palette.

use polymap::geometry::Vec2;

/// Polyline colours (the Tableau 10 qualitative palette) as RGB, used in turn.
pub(crate) const PALETTE_RGB: [[u8; 3]; 10] = [
    [0x4e, 0x79, 0xa7],
    [0xf2, 0x8e, 0x2b],
    [0xe1, 0x57, 0x59],
    [0x76, 0xb7, 0xb2],
    [0x59, 0xa1, 0x4f],
    [0xed, 0xc9, 0x48],
    [0xb0, 0x7a, 0xa1],
    [0xff, 0x9d, 0xa7],
    [0x9c, 0x75, 0x5f],
    [0xba, 0xb0, 0xac],
];

/// Colour of segments in no polyline, RGB.
pub(crate) const LOOSE_RGB: [u8; 3] = [0x55, 0x55, 0x55];

/// An axis-aligned box in the map frame, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Bounds {
    pub(crate) min: Vec2,
    pub(crate) max: Vec2,
}

impl Bounds {
    /// The smallest box around the finite points; `None` if there are none.
    pub(crate) fn around(points: impl IntoIterator<Item = Vec2>) -> Option<Bounds> {
        points
            .into_iter()
            .filter(|p| p.is_finite())
            .fold(None, |b: Option<Bounds>, p| {
                Some(match b {
                    None => Bounds { min: p, max: p },
                    Some(b) => Bounds {
                        min: b.min.min(p),
                        max: b.max.max(p),
                    },
                })
            })
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

/// The largest "round" length (1, 2 or 5 × 10^k metres) not longer than `at_most_m`;
/// 1 for a non-positive or non-finite input.
pub(crate) fn round_length_m(at_most_m: f64) -> f64 {
    if !at_most_m.is_finite() || at_most_m <= 0.0 {
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

/// A short label for a round length: "5 m", "0.2 m", "100 m".
pub(crate) fn length_label(length_m: f64) -> String {
    let s = format!("{length_m:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    format!("{s} m")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_lengths() {
        assert_eq!(round_length_m(7.3), 5.0);
        assert!((round_length_m(0.34) - 0.2).abs() < 1e-12);
        assert_eq!(round_length_m(1.0), 1.0);
        assert_eq!(round_length_m(f64::NAN), 1.0);
        assert_eq!(length_label(0.2), "0.2 m");
        assert_eq!(length_label(100.0), "100 m");
    }

    #[test]
    fn bounds_skip_non_finite_points() {
        let b = Bounds::around([Vec2::new(1.0, 2.0), Vec2::NAN, Vec2::new(-1.0, 5.0)]);
        let b = b.expect("two finite points");
        assert_eq!(b.min, Vec2::new(-1.0, 2.0));
        assert_eq!(b.max, Vec2::new(1.0, 5.0));
        assert!(Bounds::around([Vec2::NAN]).is_none());
    }
}
