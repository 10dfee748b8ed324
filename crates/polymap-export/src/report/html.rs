//! Renders a run's [`MapSnapshot`] (the final map) and its [`ReportData`] (the replay) as one
//! self-contained HTML page: `page.html` with `page.css`,
//! `page.js` and the data (compact JSON, coordinates rounded to millimetres) inlined.

use std::path::Path;

use polymap_io::snapshot::MapSnapshot;
use serde::Serialize;

use super::{MapConsistency, ReportData, SeriesPoint};
use crate::ExportError;

const PAGE: &str = include_str!("page.html");
const CSS: &str = include_str!("page.css");
const SCRIPT: &str = include_str!("page.js");

/// The data as the page's script reads it: flat arrays of rounded numbers.
#[derive(Serialize)]
struct Payload<'a> {
    title: &'a str,
    total_scans: u32,
    /// `[x0, y0, x1, y1, …]` per final segment, metres.
    final_segments: Vec<f64>,
    /// Polyline index of each final segment, −1 for none.
    polyline_of: Vec<i64>,
    /// Scan index of each trajectory pose.
    trajectory_scan: Vec<u32>,
    /// `[x, y, θ, …]` per trajectory pose: metres, radians.
    trajectory_pose: Vec<f64>,
    snapshots: Vec<SnapshotPayload>,
    series: [SeriesPayload<'a>; 4],
    lost_ranges: &'a [[u32; 2]],
    gap_scans: &'a [u32],
    gaps: u32,
    off_odometry_scans: &'a [u32],
    off_odometry: u32,
    map_consistency: Option<MapConsistency>,
    weak_stretches: &'a [[u32; 2]],
}

#[derive(Serialize)]
struct SnapshotPayload {
    scan: u32,
    pose: [f64; 3],
    segments: Vec<f64>,
    histogram_m: Vec<f64>,
    directions_deg: Vec<f64>,
}

#[derive(Serialize)]
struct SeriesPayload<'a> {
    name: &'a str,
    unit: &'a str,
    scan: Vec<u32>,
    value: Vec<f64>,
}

/// Rounds to `decimals` places so the JSON stays short; non-finite values become `null`.
fn round(v: f64, decimals: i32) -> f64 {
    let k = 10f64.powi(decimals);
    (v * k).round() / k
}

fn flat_segments<'a>(segments: impl Iterator<Item = &'a polymap::geometry::Segment>) -> Vec<f64> {
    segments
        .flat_map(|s| [s.start.x, s.start.y, s.end.x, s.end.y])
        .map(|v| round(v, 3))
        .collect()
}

fn series<'a>(
    name: &'a str,
    unit: &'a str,
    points: &[SeriesPoint],
    decimals: i32,
) -> SeriesPayload<'a> {
    SeriesPayload {
        name,
        unit,
        scan: points.iter().map(|p| p.scan_index).collect(),
        value: points.iter().map(|p| round(p.value, decimals)).collect(),
    }
}

fn polyline_of(map: &MapSnapshot) -> Vec<i64> {
    let mut of = vec![-1i64; map.segments.len()];
    for (k, polyline) in map.polylines.iter().enumerate().rev() {
        for &i in &polyline.segments {
            if let Some(slot) = of.get_mut(i) {
                *slot = i64::try_from(k).unwrap_or(i64::MAX);
            }
        }
    }
    of
}

fn payload<'a>(map: &MapSnapshot, data: &'a ReportData) -> Payload<'a> {
    let snapshots = data.snapshots.iter().map(|s| SnapshotPayload {
        scan: s.scan_index,
        pose: pose(&s.map_from_robot),
        segments: flat_segments(s.content.segments.iter()),
        histogram_m: s.content.histogram_m.iter().map(|v| round(*v, 3)).collect(),
        directions_deg: s
            .content
            .main_directions_deg
            .iter()
            .map(|v| round(*v, 2))
            .collect(),
    });
    let d = &data.series;
    Payload {
        title: &data.title,
        total_scans: data.total_scans,
        final_segments: flat_segments(map.segments.iter().map(|m| &m.segment)),
        polyline_of: polyline_of(map),
        trajectory_scan: data.trajectory.iter().map(|p| p.scan_index).collect(),
        trajectory_pose: data
            .trajectory
            .iter()
            .flat_map(|p| pose(&p.map_from_robot))
            .collect(),
        snapshots: snapshots.collect(),
        series: [
            series("ICP residual (RMS)", "m", &d.icp_residual_m, 5),
            series("map segments", "", &d.map_segments, 0),
            series("scan segments", "", &d.scan_segments, 0),
            series("ICP iterations", "", &d.icp_iterations, 0),
        ],
        lost_ranges: &data.lost_ranges,
        gap_scans: &data.gap_scans,
        gaps: data.gaps,
        off_odometry_scans: &data.off_odometry_scans,
        off_odometry: data.off_odometry,
        map_consistency: data.map_consistency.clone(),
        weak_stretches: &data.weak_stretches,
    }
}

fn pose(p: &polymap::geometry::Pose2) -> [f64; 3] {
    [round(p.x_m, 3), round(p.y_m, 3), round(p.theta_rad, 4)]
}

/// JSON that is safe inside a `<script>` element: `<`, `>` and `&` only occur inside JSON
/// strings, where their `\u` escapes mean the same, so `</script>` and `<!--` cannot appear.
fn script_safe_json(map: &MapSnapshot, data: &ReportData) -> Result<String, serde_json::Error> {
    let json = serde_json::to_string(&payload(map, data))?;
    Ok(json
        .replace('<', "\\u003c")
        .replace('>', "\\u003e")
        .replace('&', "\\u0026"))
}

/// Escapes text for HTML character data.
fn escape_html(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The report as one self-contained HTML document: the final map and its polylines from
/// `map` (its trajectory is not used: the page's comes with the replay), the replay from
/// `history`.
pub fn render_report_html(map: &MapSnapshot, history: &ReportData) -> Result<String, ExportError> {
    let data = history;
    let json = script_safe_json(map, data).map_err(|source| ExportError::Json {
        path: Default::default(),
        source,
    })?;
    let title = escape_html(&data.title);
    Ok(fill(
        PAGE,
        &[
            ("TITLE", &title),
            ("CSS", CSS),
            ("SCRIPT", SCRIPT),
            ("DATA", &json),
        ],
    ))
}

/// Replaces each `{{NAME}}` of `template` in one pass, so substituted text is never rescanned.
fn fill(template: &str, values: &[(&str, &str)]) -> String {
    let extra: usize = values.iter().map(|(_, v)| v.len()).sum();
    let mut out = String::with_capacity(template.len() + extra);
    let mut rest = template;
    while let Some(start) = rest.find("{{") {
        out.push_str(&rest[..start]);
        let after = &rest[start + 2..];
        let value = after.find("}}").and_then(|end| {
            let name = &after[..end];
            let value = values.iter().find(|(n, _)| *n == name)?.1;
            Some((value, end))
        });
        match value {
            Some((value, end)) => {
                out.push_str(value);
                rest = &after[end + 2..];
            }
            None => {
                out.push_str("{{");
                rest = after;
            }
        }
    }
    out.push_str(rest);
    out
}

/// Writes the report to `path` (conventionally `DIR/report.html`).
pub fn write_report_html(
    path: &Path,
    map: &MapSnapshot,
    history: &ReportData,
) -> Result<(), ExportError> {
    let html = render_report_html(map, history).map_err(|e| match e {
        ExportError::Json { source, .. } => ExportError::Json {
            path: path.to_owned(),
            source,
        },
        other => other,
    })?;
    polymap_io::atomic::write_bytes_atomic(path, html.as_bytes())
        .map_err(|e| ExportError::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn script_end_tags_in_the_title_cannot_close_the_data_element() {
        let data = ReportData {
            title: "</script><script>alert(1)</script> & <!--".to_owned(),
            ..Default::default()
        };
        let html = render_report_html(&MapSnapshot::default(), &data).expect("renders");
        assert_eq!(
            html.matches("</script>").count(),
            html.matches("<script").count()
        );
        assert!(html.contains("&lt;/script&gt;"));
        let start = html.find("id=\"report-data\"").expect("data element");
        let json_start = start + html[start..].find('>').expect("tag end") + 1;
        let json_end = json_start + html[json_start..].find("</script>").expect("end tag");
        let value: serde_json::Value =
            serde_json::from_str(&html[json_start..json_end]).expect("valid JSON");
        assert_eq!(value["title"], serde_json::json!(data.title));
    }

    /// The final map and its polylines come from the snapshot: every segment drawn, each
    /// coloured by the first polyline holding it, out-of-range indices ignored.
    #[test]
    fn the_final_map_comes_from_the_snapshot() {
        use polymap::geometry::{Segment, Vec2};
        use polymap::map::MapSegment;
        let piece = |x: f64| MapSegment {
            segment: Segment::new(Vec2::new(x, 0.0), Vec2::new(x + 0.5, 0.25)),
            born_scan: 0,
        };
        let map = MapSnapshot::from_parts(
            vec![piece(0.0), piece(1.0), piece(2.0)],
            vec![vec![2, 0], vec![9]],
            &[],
            Vec::new(),
        );
        let history = ReportData::default();
        let payload = payload(&map, &history);
        assert_eq!(payload.polyline_of, vec![0, -1, 0]);
        assert_eq!(payload.final_segments.len(), 12);
        assert_eq!(&payload.final_segments[4..8], &[1.0, 0.0, 1.5, 0.25]);
    }

    #[test]
    fn the_page_needs_no_network() {
        let html =
            render_report_html(&MapSnapshot::default(), &ReportData::default()).expect("renders");
        for banned in ["http://", "https://", "src=", "href=", "@import", "fetch("] {
            assert!(!html.contains(banned), "page contains {banned}");
        }
        assert!(!html.contains("{{"), "unfilled placeholder");
    }

    #[test]
    fn placeholders_are_filled_once() {
        let got = fill("a{{X}}b{{Y}}c{{Z}}", &[("X", "{{Y}}"), ("Y", "1")]);
        assert_eq!(got, "a{{Y}}b1c{{Z}}");
    }

    #[test]
    fn coordinates_are_rounded_and_non_finite_values_become_null() {
        assert_eq!(round(1.234_56, 3), 1.235);
        let json = serde_json::to_string(&[round(f64::NAN, 3)]).expect("serialises");
        assert_eq!(json, "[null]");
    }
}
