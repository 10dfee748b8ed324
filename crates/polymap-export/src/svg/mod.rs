//! The map as an SVG picture for a person to look at.
//!
//! Coordinates are metres in the map frame. The `viewBox` is in metres with y flipped (map y
//! points up on screen). Stroke widths and font sizes are in metres too, computed from the
//! picture's nominal width ([`WIDTH_PX`] CSS pixels) so a line is 2 px wide at that size. No
//! `vector-effect` is used: librsvg (GNOME's viewers, `rsvg-convert`) ignores it, and the
//! picture must look the same there as in browsers and Inkscape. A scale bar shows a round
//! length (1, 2 or 5 × 10^k m). Each polyline gets its own colour from a fixed qualitative
//! palette; segments in no polyline are grey. Non-finite coordinates are left out.
//!
//! ```
//! use polymap::geometry::{Segment, Vec2};
//! use polymap::map::MapSegment;
//! use polymap_export::svg::render_svg;
//! use polymap_io::snapshot::{MapSnapshot, Polyline};
//! let snapshot = MapSnapshot {
//!     title: "a <wall>".into(),
//!     segments: vec![MapSegment { segment: Segment::new(Vec2::new(0.0, 0.0), Vec2::new(10.0, 0.0)), born_scan: 0 }],
//!     polylines: vec![Polyline { segments: vec![0] }],
//!     ..MapSnapshot::default()
//! };
//! let svg = render_svg(&snapshot, &Default::default());
//! assert!(svg.starts_with("<svg "));
//! assert!(svg.contains("a &lt;wall&gt;"));
//! assert!(svg.contains("stroke=\"#4e79a7\""));
//! ```

use std::fmt::Write as _;

use std::path::Path;

use polymap::geometry::{Segment, Vec2};
use polymap_io::snapshot::MapSnapshot;

use crate::ExportError;
use crate::picture::{
    Bounds, LOOSE_RGB, PALETTE_RGB, hex, length_label, round_length_m, view_bounds,
};

/// Default cap on drawn scan points; more are decimated evenly.
pub const DEFAULT_MAX_SCAN_POINTS: usize = 200_000;
/// Picture width in CSS pixels (the height follows the map's aspect ratio); stroke widths are
/// chosen for this size.
pub const WIDTH_PX: f64 = 1200.0;

/// How to draw.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SvgStyle {
    /// At most this many scan points are drawn (every k-th point when there are more).
    pub max_scan_points: usize,
}

impl Default for SvgStyle {
    fn default() -> Self {
        SvgStyle {
            max_scan_points: DEFAULT_MAX_SCAN_POINTS,
        }
    }
}

/// Renders `snapshot` as a standalone SVG document: the map, the trajectory, the scan points,
/// a scale bar and the title.
pub fn render_svg(snapshot: &MapSnapshot, style: &SvgStyle) -> String {
    let positions = snapshot.positions();
    let view = view_bounds(&snapshot.segments, &positions, &snapshot.points);
    let size = view.size();
    // Metres per CSS pixel at the nominal width: every width below is in pixels times this.
    let m_per_px = size.x / WIDTH_PX;
    let mut svg = String::with_capacity(4096 + 24 * snapshot.segments.len());
    let _ = write!(
        svg,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{:.0}\" height=\"{:.0}\" \
         viewBox=\"{} {} {} {}\">\n<title>{}</title>\n\
         <rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"white\"/>\n",
        WIDTH_PX,
        WIDTH_PX * size.y / size.x,
        num(view.min.x),
        num(-view.max.y),
        num(size.x),
        num(size.y),
        escape(&snapshot.title),
        num(view.min.x),
        num(-view.max.y),
        num(size.x),
        num(size.y),
    );
    svg.push_str("<g transform=\"scale(1 -1)\" fill=\"none\" stroke-linecap=\"round\">\n");
    push_scan_points(&mut svg, &snapshot.points, style.max_scan_points, m_per_px);
    push_segments(&mut svg, snapshot, m_per_px);
    push_trajectory(&mut svg, &positions, size.x.max(size.y), m_per_px);
    svg.push_str("</g>\n");
    push_scale_bar(&mut svg, &view, m_per_px);
    push_title(&mut svg, &view, &snapshot.title);
    svg.push_str("</svg>\n");
    svg
}

/// Renders `snapshot` and writes it to `path` atomically.
pub fn write_svg(path: &Path, snapshot: &MapSnapshot, style: &SvgStyle) -> Result<(), ExportError> {
    polymap_io::atomic::write_bytes_atomic(path, render_svg(snapshot, style).as_bytes())
        .map_err(|e| ExportError::io(path, e))
}

/// Scan points as one path of zero-length round-capped strokes: dots that keep their size.
fn push_scan_points(svg: &mut String, points: &[Vec2], max_points: usize, m_per_px: f64) {
    if points.is_empty() || max_points == 0 {
        return;
    }
    let step = points.len().div_ceil(max_points);
    let _ = write!(
        svg,
        "<path stroke=\"#9aa0a6\" stroke-width=\"{}\" d=\"",
        width(2.0 * m_per_px)
    );
    for p in points.iter().step_by(step).filter(|p| p.is_finite()) {
        let _ = write!(svg, "M{} {}h0", num(p.x), num(p.y));
    }
    svg.push_str("\"/>\n");
}

/// One path per polyline in its palette colour, then the segments in no polyline.
fn push_segments(svg: &mut String, snapshot: &MapSnapshot, m_per_px: f64) {
    let mut in_polyline = vec![false; snapshot.segments.len()];
    for (k, polyline) in snapshot.polylines.iter().enumerate() {
        let members = polyline.segments.iter().filter_map(|&i| {
            let m = snapshot.segments.get(i)?;
            in_polyline[i] = true;
            Some(m.segment)
        });
        let segments: Vec<Segment> = members.collect();
        push_segment_path(
            svg,
            &segments,
            &hex(PALETTE_RGB[k % PALETTE_RGB.len()]),
            &format!("polyline {k}"),
            m_per_px,
        );
    }
    let loose: Vec<Segment> = snapshot
        .segments
        .iter()
        .zip(&in_polyline)
        .filter(|(_, used)| !**used)
        .map(|(m, _)| m.segment)
        .collect();
    push_segment_path(
        svg,
        &loose,
        &hex(LOOSE_RGB),
        "segments in no polyline",
        m_per_px,
    );
}

fn push_segment_path(
    svg: &mut String,
    segments: &[Segment],
    colour: &str,
    label: &str,
    m_per_px: f64,
) {
    let finite = segments
        .iter()
        .filter(|s| s.start.is_finite() && s.end.is_finite());
    let mut d = String::new();
    for s in finite {
        let _ = write!(
            d,
            "M{} {}L{} {}",
            num(s.start.x),
            num(s.start.y),
            num(s.end.x),
            num(s.end.y)
        );
    }
    if d.is_empty() {
        return;
    }
    let _ = writeln!(
        svg,
        "<path stroke=\"{colour}\" stroke-width=\"{}\" d=\"{d}\">\
         <title>{}</title></path>",
        width(2.0 * m_per_px),
        escape(label)
    );
}

/// The trajectory as a thin line with a filled circle at its start.
fn push_trajectory(svg: &mut String, trajectory: &[Vec2], extent_m: f64, m_per_px: f64) {
    let mut points = trajectory.iter().filter(|p| p.is_finite());
    let Some(start) = points.next() else {
        return;
    };
    let mut d = format!("M{} {}", num(start.x), num(start.y));
    for p in points {
        let _ = write!(d, "L{} {}", num(p.x), num(p.y));
    }
    let _ = writeln!(
        svg,
        "<path stroke=\"#d62728\" stroke-width=\"{}\" stroke-linejoin=\"round\" d=\"{d}\"/>\n\
         <circle cx=\"{}\" cy=\"{}\" r=\"{}\" fill=\"#d62728\"><title>start</title></circle>",
        width(0.75 * m_per_px),
        num(start.x),
        num(start.y),
        num(0.006 * extent_m)
    );
}

/// A round-length scale bar in the bottom-left corner, with its label.
fn push_scale_bar(svg: &mut String, view: &Bounds, m_per_px: f64) {
    let size = view.size();
    let length_m = round_length_m(0.2 * size.x);
    let font_m = 0.025 * size.x.max(size.y);
    let x0 = view.min.x + 0.03 * size.x;
    let y = -view.min.y - 0.03 * size.y; // SVG y is -map y
    let _ = writeln!(
        svg,
        "<g class=\"scale-bar\"><path stroke=\"black\" stroke-width=\"{}\" fill=\"none\" \
         d=\"M{} {}v{}h{}v{}\"/>\
         <text x=\"{}\" y=\"{}\" font-family=\"sans-serif\" font-size=\"{}\">{}</text></g>",
        width(2.0 * m_per_px),
        num(x0),
        num(y - 0.3 * font_m),
        num(0.3 * font_m),
        num(length_m),
        num(-0.3 * font_m),
        num(x0),
        num(y - 0.6 * font_m),
        num(font_m),
        escape(&length_label(length_m)),
    );
}

fn push_title(svg: &mut String, view: &Bounds, title: &str) {
    if title.is_empty() {
        return;
    }
    let size = view.size();
    // Sans-serif glyphs average about 0.55 em: the title stays within 94 % of the width.
    let chars = title.chars().count().max(1) as f64;
    let font_m = (0.03 * size.x.max(size.y)).min(0.94 * size.x / (0.55 * chars));
    let _ = writeln!(
        svg,
        "<text x=\"{}\" y=\"{}\" font-family=\"sans-serif\" font-size=\"{}\">{}</text>",
        num(view.min.x + 0.03 * size.x),
        num(-view.max.y + 1.3 * font_m),
        num(font_m),
        escape(title)
    );
}

/// A coordinate in metres with millimetre resolution, without trailing zeros.
fn num(v: f64) -> String {
    let s = format!("{v:.3}");
    let s = if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        &s
    };
    if s == "-0" {
        "0".to_owned()
    } else {
        s.to_owned()
    }
}

/// A stroke width in metres: like [`num`], but never rounded down to zero (a map a few
/// millimetres across still gets visible lines).
fn width(w_m: f64) -> String {
    if w_m >= 0.001 {
        num(w_m)
    } else {
        format!("{:.3e}", w_m.max(1e-9))
    }
}

/// Escapes text for XML character data and attribute values; drops characters XML forbids.
fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            '\t' | '\n' | '\r' => out.push(c),
            c if (c as u32) < 0x20 || c == '\u{FFFE}' || c == '\u{FFFF}' => {}
            c => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests;
