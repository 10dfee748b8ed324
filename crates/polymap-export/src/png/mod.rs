//! The map as a PNG picture (tiny-skia): segments coloured per polyline, the trajectory,
//! optional scan points and a scale bar on white — the same content as the SVG, for quick
//! looks and READMEs.
//!
//! The picture is [`PngStyle::width_px`] wide with the height from the map's aspect ratio;
//! neither side exceeds [`MAX_SIDE_PX`] (the scale shrinks to fit). Map y points up.
//!
//! ```
//! use polymap::geometry::{Segment, Vec2};
//! use polymap::map::MapSegment;
//! use polymap_export::png::{PngStyle, render_png};
//! use polymap_io::snapshot::MapSnapshot;
//! let segments = vec![MapSegment { segment: Segment::new(Vec2::ZERO, Vec2::new(10.0, 0.0)), born_scan: 0 }];
//! let snapshot = MapSnapshot::from_parts(segments, Vec::new(), &[], Vec::new());
//! let bytes = render_png(&snapshot, &PngStyle { width_px: 400, ..Default::default() }).unwrap();
//! assert!(bytes.starts_with(b"\x89PNG"));
//! ```

mod font;

use std::path::Path;

use polymap::geometry::Vec2;
use polymap::map::MapSegment;
use polymap_io::snapshot::{MapSnapshot, Polyline};
use tiny_skia::{Color, LineCap, LineJoin, Paint, PathBuilder, Pixmap, Rect, Stroke, Transform};

use crate::ExportError;
use crate::picture::{Bounds, LOOSE_RGB, PALETTE_RGB, length_label, round_length_m, view_bounds};

/// Default picture width, pixels.
pub const DEFAULT_WIDTH_PX: u32 = 1600;
/// Largest width or height of a picture, pixels.
pub const MAX_SIDE_PX: u32 = 8192;
/// Default cap on drawn scan points; more are decimated evenly.
pub const DEFAULT_MAX_SCAN_POINTS: usize = 200_000;
/// Colour of the trajectory, RGB.
const TRAJECTORY_RGB: [u8; 3] = [0xd6, 0x27, 0x28];

/// How to draw.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PngStyle {
    /// At most this many scan points are drawn (every k-th point when there are more).
    pub max_scan_points: usize,
    /// Picture width, pixels (clamped to `16..=MAX_SIDE_PX`).
    pub width_px: u32,
}

impl Default for PngStyle {
    fn default() -> Self {
        PngStyle {
            max_scan_points: DEFAULT_MAX_SCAN_POINTS,
            width_px: DEFAULT_WIDTH_PX,
        }
    }
}

/// What to draw, borrowed from a snapshot. All coordinates are metres in the map frame.
struct Scene<'a> {
    segments: &'a [MapSegment],
    polylines: &'a [Polyline],
    trajectory: Vec<Vec2>,
    scan_points: &'a [Vec2],
    max_scan_points: usize,
    width_px: u32,
}

impl<'a> Scene<'a> {
    fn new(snapshot: &'a MapSnapshot, style: &PngStyle) -> Self {
        Scene {
            segments: &snapshot.segments,
            polylines: &snapshot.polylines,
            trajectory: snapshot.positions(),
            scan_points: &snapshot.points,
            max_scan_points: style.max_scan_points,
            width_px: style.width_px,
        }
    }
}

/// Maps metres in the map frame to pixels (y down).
#[derive(Debug, Clone, Copy)]
struct View {
    bounds: Bounds,
    px_per_m: f64,
}

impl View {
    fn to_px(self, p: Vec2) -> (f32, f32) {
        let x = (p.x - self.bounds.min.x) * self.px_per_m;
        let y = (self.bounds.max.y - p.y) * self.px_per_m;
        (x as f32, y as f32)
    }
}

/// Renders the snapshot (segments, polylines, trajectory, points) to PNG bytes.
pub fn render_png(snapshot: &MapSnapshot, style: &PngStyle) -> Result<Vec<u8>, ExportError> {
    let scene = Scene::new(snapshot, style);
    encode(
        &render_pixmap(&scene, Path::new("map.png"))?,
        Path::new("map.png"),
    )
}

/// Renders the snapshot and writes it to `path` atomically.
pub fn write_png(path: &Path, snapshot: &MapSnapshot, style: &PngStyle) -> Result<(), ExportError> {
    let scene = Scene::new(snapshot, style);
    let bytes = encode(&render_pixmap(&scene, path)?, path)?;
    polymap_io::atomic::write_bytes_atomic(path, &bytes).map_err(|e| ExportError::io(path, e))
}

fn encode(pixmap: &Pixmap, path: &Path) -> Result<Vec<u8>, ExportError> {
    pixmap.encode_png().map_err(|e| ExportError::Png {
        path: path.to_owned(),
        message: e.to_string(),
    })
}

/// The picture as pixels; `path` names the picture in errors.
fn render_pixmap(scene: &Scene<'_>, path: &Path) -> Result<Pixmap, ExportError> {
    let (view, width, height) = layout(scene);
    if !(view.bounds.size().is_finite() && view.px_per_m.is_finite() && view.px_per_m > 0.0) {
        return Err(ExportError::Png {
            path: path.to_owned(),
            message: "the map's extent is not finite (coordinates too large to draw)".to_owned(),
        });
    }
    let mut pixmap = Pixmap::new(width, height).ok_or_else(|| ExportError::Png {
        path: path.to_owned(),
        message: format!("cannot allocate a {width} x {height} picture"),
    })?;
    pixmap.fill(Color::WHITE);
    draw_scan_points(&mut pixmap, view, scene);
    draw_segments(&mut pixmap, view, scene);
    draw_trajectory(&mut pixmap, view, &scene.trajectory);
    draw_scale_bar(&mut pixmap, view, width);
    Ok(pixmap)
}

/// The drawn area (everything plus a margin, at least 2 m across) and the picture's size.
fn layout(scene: &Scene<'_>) -> (View, u32, u32) {
    let bounds = view_bounds(scene.segments, &scene.trajectory, scene.scan_points);
    let size = bounds.size();
    let max_side = f64::from(MAX_SIDE_PX);
    let width = f64::from(scene.width_px.clamp(16, MAX_SIDE_PX));
    let px_per_m = (width / size.x).min(max_side / size.y);
    let w = (size.x * px_per_m).round().clamp(1.0, max_side) as u32;
    let h = (size.y * px_per_m).round().clamp(1.0, max_side) as u32;
    (View { bounds, px_per_m }, w, h)
}

fn paint(rgb: [u8; 3], alpha: u8) -> Paint<'static> {
    let mut paint = Paint::default();
    paint.set_color_rgba8(rgb[0], rgb[1], rgb[2], alpha);
    paint.anti_alias = true;
    paint
}

fn stroke(width_px: f32) -> Stroke {
    Stroke {
        width: width_px,
        line_cap: LineCap::Round,
        line_join: LineJoin::Round,
        ..Stroke::default()
    }
}

fn draw_scan_points(pixmap: &mut Pixmap, view: View, scene: &Scene<'_>) {
    let points = scene.scan_points;
    if points.is_empty() || scene.max_scan_points == 0 {
        return;
    }
    let step = points.len().div_ceil(scene.max_scan_points);
    let grey = paint([0x9a, 0xa0, 0xa6], 255);
    for p in points.iter().step_by(step).filter(|p| p.is_finite()) {
        let (x, y) = view.to_px(*p);
        if let Some(rect) = Rect::from_xywh(x - 1.0, y - 1.0, 2.0, 2.0) {
            pixmap.fill_rect(rect, &grey, Transform::identity(), None);
        }
    }
}

/// One stroked path per polyline in its palette colour, then the segments in no polyline.
fn draw_segments(pixmap: &mut Pixmap, view: View, scene: &Scene<'_>) {
    let mut in_polyline = vec![false; scene.segments.len()];
    for (k, polyline) in scene.polylines.iter().enumerate() {
        let mut pb = PathBuilder::new();
        for &i in &polyline.segments {
            if let Some(m) = scene.segments.get(i) {
                in_polyline[i] = true;
                push_segment(&mut pb, view, m);
            }
        }
        stroke_path(pixmap, pb, PALETTE_RGB[k % PALETTE_RGB.len()], 2.5);
    }
    let mut pb = PathBuilder::new();
    for (m, _) in scene
        .segments
        .iter()
        .zip(&in_polyline)
        .filter(|(_, u)| !**u)
    {
        push_segment(&mut pb, view, m);
    }
    stroke_path(pixmap, pb, LOOSE_RGB, 2.5);
}

fn push_segment(pb: &mut PathBuilder, view: View, m: &MapSegment) {
    let s = m.segment;
    if s.start.is_finite() && s.end.is_finite() {
        let (a, b) = (view.to_px(s.start), view.to_px(s.end));
        pb.move_to(a.0, a.1);
        pb.line_to(b.0, b.1);
    }
}

fn stroke_path(pixmap: &mut Pixmap, pb: PathBuilder, rgb: [u8; 3], width_px: f32) {
    if let Some(path) = pb.finish() {
        let s = stroke(width_px);
        pixmap.stroke_path(&path, &paint(rgb, 255), &s, Transform::identity(), None);
    }
}

fn draw_trajectory(pixmap: &mut Pixmap, view: View, trajectory: &[Vec2]) {
    let mut points = trajectory
        .iter()
        .filter(|p| p.is_finite())
        .map(|p| view.to_px(*p));
    let Some(start) = points.next() else {
        return;
    };
    let mut pb = PathBuilder::new();
    pb.move_to(start.0, start.1);
    for (x, y) in points {
        pb.line_to(x, y);
    }
    stroke_path(pixmap, pb, TRAJECTORY_RGB, 1.2);
    if let Some(dot) = PathBuilder::from_circle(start.0, start.1, 5.0) {
        let red = paint(TRAJECTORY_RGB, 255);
        pixmap.fill_path(
            &dot,
            &red,
            tiny_skia::FillRule::Winding,
            Transform::identity(),
            None,
        );
    }
}

/// A round-length bar in the bottom-left corner with its label above it.
fn draw_scale_bar(pixmap: &mut Pixmap, view: View, width: u32) {
    let size = view.bounds.size();
    let length_m = round_length_m(0.2 * size.x);
    let bar_px = (length_m * view.px_per_m) as f32;
    // One grid unit of the stroke font: the label is 8 units tall (12–32 px).
    let unit_px = (f64::from(width) / 800.0).clamp(1.5, 4.0) as f32;
    let x0 = (0.03 * f64::from(width)) as f32;
    let y = pixmap.height() as f32 - x0;
    let tick = 2.0 * unit_px;
    let mut pb = PathBuilder::new();
    pb.move_to(x0, y - tick);
    pb.line_to(x0, y);
    pb.line_to(x0 + bar_px, y);
    pb.line_to(x0 + bar_px, y - tick);
    stroke_path(pixmap, pb, [0, 0, 0], 2.0);
    let black = paint([0, 0, 0], 255);
    let label = length_label(length_m);
    let top = y - tick - (font::HEIGHT_UNITS + 2.0) * unit_px;
    font::draw_text(pixmap, &label, x0, top, unit_px, &black);
}

#[cfg(test)]
mod tests;
