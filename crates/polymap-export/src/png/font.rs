//! A stroke font for the scale bar's label (digits, '.', 'k', 'm' and space): each glyph is a
//! few polylines on a 4 × 8 grid, stroked with round caps by tiny-skia, so the label stays
//! legible at any size (tiny-skia draws no text, and a label is all the picture needs).

use tiny_skia::{LineCap, LineJoin, Paint, PathBuilder, Pixmap, Stroke, Transform};

/// Glyph width in grid units (the grid is 4 wide, 8 tall from the cap line to the baseline).
const GLYPH_UNITS: f32 = 4.0;
/// Advance from one glyph to the next, grid units.
const ADVANCE_UNITS: f32 = 6.0;
/// Height from the cap line to the baseline, grid units.
pub(crate) const HEIGHT_UNITS: f32 = 8.0;

/// The strokes of a glyph: polylines of `(x, y)` grid points, y down from the cap line.
fn glyph(c: char) -> Option<&'static [&'static [(f32, f32)]]> {
    Some(match c {
        '0' => &[&[
            (1.0, 0.0),
            (3.0, 0.0),
            (4.0, 1.5),
            (4.0, 6.5),
            (3.0, 8.0),
            (1.0, 8.0),
            (0.0, 6.5),
            (0.0, 1.5),
            (1.0, 0.0),
        ]],
        '1' => &[
            &[(0.8, 1.8), (2.2, 0.0), (2.2, 8.0)],
            &[(0.8, 8.0), (3.6, 8.0)],
        ],
        '2' => &[&[
            (0.0, 1.5),
            (1.0, 0.0),
            (3.0, 0.0),
            (4.0, 1.5),
            (4.0, 3.0),
            (0.0, 8.0),
            (4.0, 8.0),
        ]],
        '3' => &[&[
            (0.0, 0.0),
            (4.0, 0.0),
            (1.8, 3.4),
            (3.0, 3.4),
            (4.0, 4.6),
            (4.0, 6.8),
            (3.0, 8.0),
            (1.0, 8.0),
            (0.0, 7.0),
        ]],
        '4' => &[&[(3.0, 8.0), (3.0, 0.0), (0.0, 5.8), (4.0, 5.8)]],
        '5' => &[&[
            (4.0, 0.0),
            (0.3, 0.0),
            (0.0, 3.6),
            (3.0, 3.4),
            (4.0, 4.6),
            (4.0, 6.8),
            (3.0, 8.0),
            (0.0, 8.0),
        ]],
        '6' => &[&[
            (3.6, 0.0),
            (1.2, 0.0),
            (0.0, 2.0),
            (0.0, 6.8),
            (1.0, 8.0),
            (3.0, 8.0),
            (4.0, 6.8),
            (4.0, 4.6),
            (3.0, 3.6),
            (0.0, 3.6),
        ]],
        '7' => &[&[(0.0, 0.0), (4.0, 0.0), (1.4, 8.0)]],
        '8' => &[&[
            (1.0, 3.6),
            (0.0, 2.6),
            (0.0, 1.0),
            (1.0, 0.0),
            (3.0, 0.0),
            (4.0, 1.0),
            (4.0, 2.6),
            (3.0, 3.6),
            (1.0, 3.6),
            (0.0, 4.6),
            (0.0, 7.0),
            (1.0, 8.0),
            (3.0, 8.0),
            (4.0, 7.0),
            (4.0, 4.6),
            (3.0, 3.6),
        ]],
        '9' => &[&[
            (4.0, 4.4),
            (1.0, 4.4),
            (0.0, 3.4),
            (0.0, 1.0),
            (1.0, 0.0),
            (3.0, 0.0),
            (4.0, 1.2),
            (4.0, 6.0),
            (2.8, 8.0),
            (0.4, 8.0),
        ]],
        '.' => &[&[(2.0, 7.7), (2.0, 8.0)]],
        'k' => &[
            &[(0.0, 0.0), (0.0, 8.0)],
            &[(4.0, 3.6), (0.0, 6.2)],
            &[(1.6, 5.2), (4.0, 8.0)],
        ],
        'm' => &[
            &[(0.0, 3.6), (0.0, 8.0)],
            &[(0.0, 4.6), (0.8, 3.6), (1.2, 3.6), (2.0, 4.6), (2.0, 8.0)],
            &[(2.0, 4.6), (2.8, 3.6), (3.2, 3.6), (4.0, 4.6), (4.0, 8.0)],
        ],
        ' ' => &[],
        _ => return None,
    })
}

/// Draws `text` with its top-left corner (cap line) at `(x_px, y_px)`, one grid unit
/// `unit_px` pixels; strokes are about one unit wide. Characters without a glyph are skipped.
/// Returns the width drawn, pixels.
pub(crate) fn draw_text(
    pixmap: &mut Pixmap,
    text: &str,
    x_px: f32,
    y_px: f32,
    unit_px: f32,
    paint: &Paint,
) -> f32 {
    let stroke = Stroke {
        width: (0.9 * unit_px).max(1.0),
        line_cap: LineCap::Round,
        line_join: LineJoin::Round,
        ..Stroke::default()
    };
    let mut x = x_px;
    let mut pb = PathBuilder::new();
    for strokes in text.chars().filter_map(glyph) {
        for line in strokes {
            let mut points = line
                .iter()
                .map(|&(gx, gy)| (x + gx * unit_px, y_px + gy * unit_px));
            if let Some((x0, y0)) = points.next() {
                pb.move_to(x0, y0);
                // A one-point stroke (the full stop) needs a length for its round cap.
                pb.line_to(x0, y0 + 0.01);
                for (px, py) in points {
                    pb.line_to(px, py);
                }
            }
        }
        x += ADVANCE_UNITS * unit_px;
    }
    if let Some(path) = pb.finish() {
        pixmap.stroke_path(&path, paint, &stroke, Transform::identity(), None);
    }
    x - x_px - (ADVANCE_UNITS - GLYPH_UNITS) * unit_px
}

#[cfg(test)]
mod tests {
    use super::*;

    fn render(text: &str, unit_px: f32) -> Pixmap {
        let mut pixmap = Pixmap::new(200, 40).expect("small pixmap");
        let mut paint = Paint::default();
        paint.set_color_rgba8(0, 0, 0, 255);
        paint.anti_alias = true;
        draw_text(&mut pixmap, text, 4.0, 4.0, unit_px, &paint);
        pixmap
    }

    /// Runs of ink along row `y` between columns `x0..x1`.
    fn ink_runs(pixmap: &Pixmap, y: u32, x0: u32, x1: u32) -> usize {
        let inked = |x| pixmap.pixel(x, y).is_some_and(|p| p.alpha() > 128);
        (x0..x1)
            .filter(|&x| inked(x) && (x == x0 || !inked(x - 1)))
            .count()
    }

    /// The old 3 × 5 bitmap font drew "m" as a solid block: the stroked one has three stems
    /// with white between them.
    #[test]
    fn the_m_has_three_stems_and_gaps() {
        let unit = 3.0;
        let pixmap = render("m", unit);
        // Through the lower half of the 'm' (grid y = 6.5).
        let y = (4.0 + 6.5 * unit) as u32;
        assert_eq!(ink_runs(&pixmap, y, 0, 30), 3);
    }

    #[test]
    fn digits_are_told_apart() {
        let unit = 3.0;
        let mid = (4.0 + 3.6 * unit) as u32;
        // An '8' is closed in the middle, a '0' is open there.
        assert_eq!(ink_runs(&render("8", unit), mid, 0, 30), 1);
        assert_eq!(ink_runs(&render("0", unit), mid, 0, 30), 2);
        for c in "0123456789.km ".chars() {
            assert!(glyph(c).is_some(), "{c:?}");
        }
        assert!(glyph('x').is_none());
    }

    #[test]
    fn the_width_drawn_counts_glyph_advances() {
        let mut pixmap = Pixmap::new(100, 40).expect("small pixmap");
        let paint = Paint::default();
        let w = draw_text(&mut pixmap, "1 m", 0.0, 0.0, 2.0, &paint);
        assert_eq!(w, (2.0 * ADVANCE_UNITS + GLYPH_UNITS) * 2.0);
    }
}
