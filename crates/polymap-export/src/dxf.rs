//! The map as a DXF drawing that CAD programs open (AutoCAD R12 ASCII, `AC1009`).
//!
//! One drawing unit is one metre, map frame (R12 has no `$INSUNITS` header; it arrived with
//! R2000, whose files need handles and an object section — R12 is the version every DXF reader
//! accepts). Each map segment is a `LINE` on layer `MAP`, coloured per polyline (AutoCAD colour
//! index, cycling through ten colours; grey for segments in no polyline). The trajectory is one
//! open 2D `POLYLINE` on layer `TRAJECTORY`. A `LAYER` table defines `0`, `MAP` and
//! `TRAJECTORY`. Coordinates are written with micrometre precision; non-finite ones are left out.
//!
//! ```
//! use polymap::geometry::{Segment, Vec2};
//! use polymap::map::MapSegment;
//! use polymap_export::dxf::write_dxf_to;
//! use polymap_io::snapshot::MapSnapshot;
//! let segments = vec![MapSegment { segment: Segment::new(Vec2::ZERO, Vec2::new(3.0, 0.0)), born_scan: 0 }];
//! let snapshot = MapSnapshot::from_parts(segments, vec![vec![0]], &[], Vec::new());
//! let mut out = Vec::new();
//! write_dxf_to(&mut out, &snapshot).unwrap();
//! let text = String::from_utf8(out).unwrap();
//! assert!(text.contains("LINE\n8\nMAP\n") && text.ends_with("0\nEOF\n"));
//! ```

use std::io::{self, Write};
use std::path::Path;

use polymap::geometry::Vec2;
use polymap::map::MapSegment;

use polymap_io::snapshot::MapSnapshot;

use crate::ExportError;
use crate::picture::Bounds;

/// Layer of the map segments.
pub const MAP_LAYER: &str = "MAP";
/// Layer of the trajectory.
pub const TRAJECTORY_LAYER: &str = "TRAJECTORY";
/// AutoCAD colour indices given to polylines in turn.
const POLYLINE_ACI: [u8; 10] = [5, 30, 1, 4, 3, 2, 6, 221, 34, 9];
/// AutoCAD colour index of segments in no polyline (grey).
const LOOSE_ACI: u8 = 8;

/// Writes the drawing of `snapshot` (segments, polylines for the colours, trajectory) to
/// `path` atomically.
pub fn write_dxf(path: &Path, snapshot: &MapSnapshot) -> Result<(), ExportError> {
    polymap_io::atomic::write_atomic(path, |out| write_dxf_to(&mut &mut *out, snapshot))
        .map_err(|e| ExportError::io(path, e))
}

/// Writes the drawing to any writer.
pub fn write_dxf_to(out: &mut impl Write, snapshot: &MapSnapshot) -> io::Result<()> {
    let trajectory = snapshot.positions();
    write_header(out, snapshot, &trajectory)?;
    write_tables(out)?;
    section(out, "ENTITIES")?;
    let colours = segment_colours(snapshot);
    for (m, colour) in snapshot.segments.iter().zip(colours) {
        write_line(out, m, colour)?;
    }
    write_trajectory(out, &trajectory)?;
    pairs(out, &[("0", "ENDSEC"), ("0", "EOF")])
}

/// The colour of each segment: its first polyline's, or grey.
fn segment_colours(snapshot: &MapSnapshot) -> Vec<u8> {
    let mut colours = vec![LOOSE_ACI; snapshot.segments.len()];
    for (k, polyline) in snapshot.polylines.iter().enumerate().rev() {
        for &i in &polyline.segments {
            if let Some(c) = colours.get_mut(i) {
                *c = POLYLINE_ACI[k % POLYLINE_ACI.len()];
            }
        }
    }
    colours
}

fn write_header(
    out: &mut impl Write,
    snapshot: &MapSnapshot,
    trajectory: &[Vec2],
) -> io::Result<()> {
    let endpoints = snapshot
        .segments
        .iter()
        .flat_map(|m| [m.segment.start, m.segment.end]);
    let all = endpoints.chain(trajectory.iter().copied());
    let b = Bounds::around(all).unwrap_or(Bounds {
        min: Vec2::ZERO,
        max: Vec2::ONE,
    });
    section(out, "HEADER")?;
    pairs(out, &[("9", "$ACADVER"), ("1", "AC1009")])?;
    pairs(out, &[("9", "$EXTMIN")])?;
    point(out, 10, b.min)?;
    pairs(out, &[("9", "$EXTMAX")])?;
    point(out, 10, b.max)?;
    pairs(out, &[("0", "ENDSEC")])
}

fn write_tables(out: &mut impl Write) -> io::Result<()> {
    section(out, "TABLES")?;
    pairs(out, &[("0", "TABLE"), ("2", "LTYPE"), ("70", "1")])?;
    pairs(
        out,
        &[
            ("0", "LTYPE"),
            ("2", "CONTINUOUS"),
            ("70", "0"),
            ("3", "Solid line"),
            ("72", "65"),
            ("73", "0"),
            ("40", "0.0"),
            ("0", "ENDTAB"),
        ],
    )?;
    pairs(out, &[("0", "TABLE"), ("2", "LAYER"), ("70", "3")])?;
    for (name, colour) in [("0", "7"), (MAP_LAYER, "7"), (TRAJECTORY_LAYER, "1")] {
        let layer = [("0", "LAYER"), ("2", name), ("70", "0"), ("62", colour)];
        pairs(out, &layer)?;
        pairs(out, &[("6", "CONTINUOUS")])?;
    }
    pairs(out, &[("0", "ENDTAB"), ("0", "ENDSEC")])
}

fn write_line(out: &mut impl Write, m: &MapSegment, colour: u8) -> io::Result<()> {
    let s = &m.segment;
    if !(s.start.is_finite() && s.end.is_finite()) {
        return Ok(());
    }
    pairs(out, &[("0", "LINE"), ("8", MAP_LAYER)])?;
    writeln!(out, "62\n{colour}")?;
    point(out, 10, s.start)?;
    point(out, 11, s.end)
}

fn write_trajectory(out: &mut impl Write, trajectory: &[Vec2]) -> io::Result<()> {
    let finite: Vec<Vec2> = trajectory
        .iter()
        .copied()
        .filter(|p| p.is_finite())
        .collect();
    if finite.len() < 2 {
        return Ok(());
    }
    pairs(
        out,
        &[("0", "POLYLINE"), ("8", TRAJECTORY_LAYER), ("66", "1")],
    )?;
    point(out, 10, Vec2::ZERO)?;
    pairs(out, &[("70", "0")])?;
    for p in finite {
        pairs(out, &[("0", "VERTEX"), ("8", TRAJECTORY_LAYER)])?;
        point(out, 10, p)?;
    }
    pairs(out, &[("0", "SEQEND"), ("8", TRAJECTORY_LAYER)])
}

fn section(out: &mut impl Write, name: &str) -> io::Result<()> {
    pairs(out, &[("0", "SECTION"), ("2", name)])
}

/// Group code / value pairs, one per line each.
fn pairs(out: &mut impl Write, items: &[(&str, &str)]) -> io::Result<()> {
    for (code, value) in items {
        writeln!(out, "{code}\n{value}")?;
    }
    Ok(())
}

/// A point as group codes `code`, `code + 10`, `code + 20` (x, y, z = 0).
fn point(out: &mut impl Write, code: u16, p: Vec2) -> io::Result<()> {
    writeln!(
        out,
        "{code}\n{:.6}\n{}\n{:.6}\n{}\n0.0",
        p.x,
        code + 10,
        p.y,
        code + 20
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use polymap::geometry::Segment;

    fn seg(x0: f64, y0: f64, x1: f64, y1: f64) -> MapSegment {
        MapSegment {
            segment: Segment::new(Vec2::new(x0, y0), Vec2::new(x1, y1)),
            born_scan: 0,
        }
    }

    #[test]
    fn lines_take_their_polyline_colour_and_skip_non_finite() {
        let segments = [
            seg(0.0, 0.0, 1.0, 0.0),
            seg(f64::NAN, 0.0, 1.0, 1.0),
            seg(5.0, 5.0, 6.0, 6.0),
        ];
        let scene = MapSnapshot::from_parts(
            segments.to_vec(),
            vec![vec![0, 1, 99]],
            &[Vec2::ZERO, Vec2::NAN],
            Vec::new(),
        );
        let mut out = Vec::new();
        write_dxf_to(&mut out, &scene).expect("in memory");
        let text = String::from_utf8(out).expect("ASCII");
        assert_eq!(text.matches("0\nLINE\n").count(), 2);
        assert!(
            text.contains(
                "LINE\n8\nMAP\n62\n5\n10\n0.000000\n20\n0.000000\n30\n0.0\n11\n1.000000\n"
            )
        );
        assert!(text.contains("LINE\n8\nMAP\n62\n8\n"));
        assert!(!text.contains("POLYLINE"), "one finite pose is no polyline");
        assert!(!text.contains("NaN"));
    }

    #[test]
    fn group_codes_and_values_alternate() {
        let segments = [seg(0.0, 0.0, 1.0, 0.0)];
        let trajectory = [Vec2::ZERO, Vec2::new(1.0, 1.0)];
        let scene = MapSnapshot::from_parts(segments.to_vec(), Vec::new(), &trajectory, Vec::new());
        let mut out = Vec::new();
        write_dxf_to(&mut out, &scene).expect("in memory");
        let text = String::from_utf8(out).expect("ASCII");
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len() % 2, 0);
        for code in lines.iter().step_by(2) {
            assert!(code.parse::<u16>().is_ok(), "{code:?} is not a group code");
        }
    }
}
