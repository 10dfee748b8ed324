//! A 3 × 5 pixel font for the scale bar's label (digits, '.', 'k', 'm' and space): tiny-skia
//! draws no text, and a label is all the picture needs.

use tiny_skia::{Paint, Pixmap, Rect, Transform};

/// Glyph rows from the top, 3 bits each (bit 2 = left column).
fn glyph(c: char) -> Option<[u8; 5]> {
    Some(match c {
        '0' => [0b111, 0b101, 0b101, 0b101, 0b111],
        '1' => [0b010, 0b110, 0b010, 0b010, 0b111],
        '2' => [0b111, 0b001, 0b111, 0b100, 0b111],
        '3' => [0b111, 0b001, 0b111, 0b001, 0b111],
        '4' => [0b101, 0b101, 0b111, 0b001, 0b001],
        '5' => [0b111, 0b100, 0b111, 0b001, 0b111],
        '6' => [0b111, 0b100, 0b111, 0b101, 0b111],
        '7' => [0b111, 0b001, 0b010, 0b010, 0b010],
        '8' => [0b111, 0b101, 0b111, 0b101, 0b111],
        '9' => [0b111, 0b101, 0b111, 0b001, 0b111],
        '.' => [0b000, 0b000, 0b000, 0b000, 0b010],
        'k' => [0b100, 0b101, 0b110, 0b101, 0b101],
        'm' => [0b000, 0b000, 0b111, 0b111, 0b101],
        ' ' => [0; 5],
        _ => return None,
    })
}

/// Draws `text` with its top-left corner at `(x_px, y_px)`, each font pixel `scale_px` wide.
/// Characters without a glyph are skipped. Returns the width drawn, pixels.
pub(crate) fn draw_text(
    pixmap: &mut Pixmap,
    text: &str,
    x_px: f32,
    y_px: f32,
    scale_px: f32,
    paint: &Paint,
) -> f32 {
    let mut x = x_px;
    for rows in text.chars().filter_map(glyph) {
        for (r, bits) in rows.iter().enumerate() {
            for c in 0..3u8 {
                if bits & (0b100 >> c) == 0 {
                    continue;
                }
                let (px, py) = (x + f32::from(c) * scale_px, y_px + r as f32 * scale_px);
                if let Some(rect) = Rect::from_xywh(px, py, scale_px, scale_px) {
                    pixmap.fill_rect(rect, paint, Transform::identity(), None);
                }
            }
        }
        x += 4.0 * scale_px;
    }
    x - x_px
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn digits_draw_dark_pixels_where_the_glyph_says() {
        let mut pixmap = Pixmap::new(40, 10).expect("small pixmap");
        let mut paint = Paint::default();
        paint.set_color_rgba8(0, 0, 0, 255);
        let width = draw_text(&mut pixmap, "1 m", 0.0, 0.0, 2.0, &paint);
        assert_eq!(width, 24.0);
        let alpha = |x, y| pixmap.pixel(x, y).map_or(0, |p| p.alpha());
        assert_eq!(alpha(2, 0), 255, "top of the '1'");
        assert_eq!(alpha(0, 0), 0, "left of the '1'");
        assert_eq!(alpha(16, 9), 255, "bottom-left of the 'm'");
        assert!(glyph('x').is_none());
    }
}
