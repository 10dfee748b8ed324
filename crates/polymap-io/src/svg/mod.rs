//! The map as an SVG picture for a person to look at.
//!
//! Coordinates are metres in the map frame. The `viewBox` is in metres with y flipped (map y
//! points up on screen), strokes keep their width at any zoom
//! (`vector-effect="non-scaling-stroke"`), and a scale bar shows a round length (1, 2 or 5 ×
//! 10^k m). Each polyline gets its own colour from a fixed qualitative palette; segments in no
//! polyline are grey. Non-finite coordinates are left out.
//!
//! ```
//! use polymap::geometry::{Segment, Vec2};
//! use polymap::map::MapSegment;
//! use polymap_io::svg::{SvgScene, render_svg};
//! let segments = [MapSegment { segment: Segment::new(Vec2::new(0.0, 0.0), Vec2::new(10.0, 0.0)), born_scan: 0 }];
//! let polylines = [vec![0]];
//! let scene = SvgScene { title: "a <wall>", segments: &segments, polylines: &polylines, ..Default::default() };
//! let svg = render_svg(&scene);
//! assert!(svg.starts_with("<svg "));
//! assert!(svg.contains("a &lt;wall&gt;"));
//! assert!(svg.contains("stroke=\"#4e79a7\""));
//! ```

use std::fmt::Write as _;

use polymap::geometry::{Segment, Vec2};
use polymap::map::MapSegment;

use crate::picture::{
    Bounds, LOOSE_RGB, PALETTE_RGB, hex, length_label, round_length_m, view_bounds,
};

/// Default cap on drawn scan points; more are decimated evenly.
pub const DEFAULT_MAX_SCAN_POINTS: usize = 200_000;
/// Picture width in CSS pixels (the height follows the map's aspect ratio).
const WIDTH_PX: f64 = 1200.0;

/// What to draw. All coordinates are metres in the map frame.
#[derive(Debug, Clone, Copy)]
pub struct SvgScene<'a> {
    /// A title, shown at the top and as the SVG `<title>` (escaped as needed).
    pub title: &'a str,
    /// The map's segments.
    pub segments: &'a [MapSegment],
    /// Polylines as lists of indices into `segments`; out-of-range indices are ignored.
    pub polylines: &'a [Vec<usize>],
    /// The robot's trajectory (positions in order), drawn thin with a start marker; may be empty.
    pub trajectory: &'a [Vec2],
    /// Scan points, drawn as small dots; may be empty.
    pub scan_points: &'a [Vec2],
    /// At most this many scan points are drawn (every k-th point when there are more).
    pub max_scan_points: usize,
}

impl Default for SvgScene<'_> {
    fn default() -> Self {
        SvgScene {
            title: "",
            segments: &[],
            polylines: &[],
            trajectory: &[],
            scan_points: &[],
            max_scan_points: DEFAULT_MAX_SCAN_POINTS,
        }
    }
}

/// Renders `scene` as a standalone SVG document.
pub fn render_svg(scene: &SvgScene<'_>) -> String {
    let view = view_bounds(scene.segments, scene.trajectory, scene.scan_points);
    let size = view.size();
    let mut svg = String::with_capacity(4096 + 24 * scene.segments.len());
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
        escape(scene.title),
        num(view.min.x),
        num(-view.max.y),
        num(size.x),
        num(size.y),
    );
    svg.push_str("<g transform=\"scale(1 -1)\" fill=\"none\" stroke-linecap=\"round\">\n");
    push_scan_points(&mut svg, scene);
    push_segments(&mut svg, scene);
    push_trajectory(&mut svg, scene.trajectory, size.x.max(size.y));
    svg.push_str("</g>\n");
    push_scale_bar(&mut svg, &view);
    push_title(&mut svg, &view, scene.title);
    svg.push_str("</svg>\n");
    svg
}

/// Scan points as one path of zero-length round-capped strokes: dots that keep their size.
fn push_scan_points(svg: &mut String, scene: &SvgScene<'_>) {
    let points = scene.scan_points;
    if points.is_empty() || scene.max_scan_points == 0 {
        return;
    }
    let step = points.len().div_ceil(scene.max_scan_points);
    svg.push_str(
        "<path stroke=\"#9aa0a6\" stroke-width=\"2\" vector-effect=\"non-scaling-stroke\" d=\"",
    );
    for p in points.iter().step_by(step).filter(|p| p.is_finite()) {
        let _ = write!(svg, "M{} {}h0", num(p.x), num(p.y));
    }
    svg.push_str("\"/>\n");
}

/// One path per polyline in its palette colour, then the segments in no polyline.
fn push_segments(svg: &mut String, scene: &SvgScene<'_>) {
    let mut in_polyline = vec![false; scene.segments.len()];
    for (k, polyline) in scene.polylines.iter().enumerate() {
        let members = polyline.iter().filter_map(|&i| {
            let m = scene.segments.get(i)?;
            in_polyline[i] = true;
            Some(m.segment)
        });
        let segments: Vec<Segment> = members.collect();
        push_segment_path(
            svg,
            &segments,
            &hex(PALETTE_RGB[k % PALETTE_RGB.len()]),
            &format!("polyline {k}"),
        );
    }
    let loose: Vec<Segment> = scene
        .segments
        .iter()
        .zip(&in_polyline)
        .filter(|(_, used)| !**used)
        .map(|(m, _)| m.segment)
        .collect();
    push_segment_path(svg, &loose, &hex(LOOSE_RGB), "segments in no polyline");
}

fn push_segment_path(svg: &mut String, segments: &[Segment], colour: &str, label: &str) {
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
        "<path stroke=\"{colour}\" stroke-width=\"2\" vector-effect=\"non-scaling-stroke\" d=\"{d}\">\
         <title>{}</title></path>",
        escape(label)
    );
}

/// The trajectory as a thin line with a filled circle at its start.
fn push_trajectory(svg: &mut String, trajectory: &[Vec2], extent_m: f64) {
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
        "<path stroke=\"#d62728\" stroke-width=\"0.75\" stroke-linejoin=\"round\" \
         vector-effect=\"non-scaling-stroke\" d=\"{d}\"/>\n\
         <circle cx=\"{}\" cy=\"{}\" r=\"{}\" fill=\"#d62728\"><title>start</title></circle>",
        num(start.x),
        num(start.y),
        num(0.006 * extent_m)
    );
}

/// A round-length scale bar in the bottom-left corner, with its label.
fn push_scale_bar(svg: &mut String, view: &Bounds) {
    let size = view.size();
    let length_m = round_length_m(0.2 * size.x);
    let font_m = 0.025 * size.x.max(size.y);
    let x0 = view.min.x + 0.03 * size.x;
    let y = -view.min.y - 0.03 * size.y; // SVG y is -map y
    let _ = writeln!(
        svg,
        "<g class=\"scale-bar\"><path stroke=\"black\" stroke-width=\"2\" fill=\"none\" \
         vector-effect=\"non-scaling-stroke\" d=\"M{} {}v{}h{}v{}\"/>\
         <text x=\"{}\" y=\"{}\" font-family=\"sans-serif\" font-size=\"{}\">{}</text></g>",
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
    let font_m = 0.03 * size.x.max(size.y);
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
