//! What every picture of a map shares (the SVG and the PNG): the drawn extent in metres, the
//! scale bar's round length and label, and the polyline palette.

use polymap::geometry::Vec2;
use polymap::map::MapSegment;

/// Polyline colours (the Tableau 10 qualitative palette) as RGB, used in turn.
pub const PALETTE_RGB: [[u8; 3]; 10] = [
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
pub const LOOSE_RGB: [u8; 3] = [0x55, 0x55, 0x55];

/// An axis-aligned box in the map frame, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    /// Lower-left corner.
    pub min: Vec2,
    /// Upper-right corner.
    pub max: Vec2,
}

impl Bounds {
    /// The smallest box around the finite points; `None` if there are none.
    pub fn around(points: impl IntoIterator<Item = Vec2>) -> Option<Bounds> {
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
    pub fn padded(&self, margin_m: f64, min_size_m: f64) -> Bounds {
        let centre = (self.min + self.max) * 0.5;
        let half = ((self.max - self.min) * 0.5).max(Vec2::splat(min_size_m * 0.5));
        let pad = Vec2::splat(margin_m);
        Bounds {
            min: centre - half - pad,
            max: centre + half + pad,
        }
    }

    /// Width and height, metres.
    pub fn size(&self) -> Vec2 {
        self.max - self.min
    }
}

/// The largest "round" length (1, 2 or 5 × 10^k metres) not longer than `at_most_m`;
/// 1 for a non-positive or non-finite input.
pub fn round_length_m(at_most_m: f64) -> f64 {
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
pub fn length_label(length_m: f64) -> String {
    let s = format!("{length_m:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    format!("{s} m")
}

/// The drawn area of a map picture: every segment endpoint, trajectory position and scan point,
/// plus a margin (5 % of the extent and 0.5 m), at least 2 m across; a 2 m box around the
/// origin when there is nothing to draw.
pub fn view_bounds(segments: &[MapSegment], trajectory: &[Vec2], scan_points: &[Vec2]) -> Bounds {
    let endpoints = segments
        .iter()
        .flat_map(|m| [m.segment.start, m.segment.end]);
    let all = endpoints
        .chain(trajectory.iter().copied())
        .chain(scan_points.iter().copied());
    let bounds = Bounds::around(all).unwrap_or(Bounds {
        min: Vec2::splat(-1.0),
        max: Vec2::splat(1.0),
    });
    let extent = bounds.size().max_element();
    bounds.padded(0.05 * extent + 0.5, 2.0)
}

/// A palette colour as an SVG/CSS hex string (`#rrggbb`).
pub fn hex(rgb: [u8; 3]) -> String {
    format!("#{:02x}{:02x}{:02x}", rgb[0], rgb[1], rgb[2])
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
