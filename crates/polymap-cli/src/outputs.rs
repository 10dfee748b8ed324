//! Writing a run's outputs: map.json, trajectory.tum, map.svg, summary.json.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use polymap::geometry::Vec2;
use polymap::map::MapSegment;
use polymap_io::map_json::{MapJson, write_map_json};
use polymap_io::svg::{SvgScene, render_svg};
use polymap_io::tum::{StampedPose, write_tum};

/// Everything a finished run writes.
pub struct RunOutputs<'a> {
    pub frame: &'a str,
    pub title: &'a str,
    pub segments: &'a [MapSegment],
    pub polylines: &'a [Vec<usize>],
    pub trajectory: &'a [StampedPose],
    pub scan_points: &'a [Vec2],
    pub summary: &'a serde_json::Value,
}

/// Writes the contract files into `dir`.
pub fn write_outputs(dir: &Path, out: &RunOutputs<'_>) -> Result<()> {
    write_map_json(
        dir.join("map.json"),
        &MapJson::new(out.frame, out.segments, out.polylines),
    )?;
    write_tum(dir.join("trajectory.tum"), out.trajectory)?;
    let positions: Vec<Vec2> = out
        .trajectory
        .iter()
        .map(|p| p.map_from_robot.translation())
        .collect();
    let svg = render_svg(&SvgScene {
        title: out.title,
        segments: out.segments,
        polylines: out.polylines,
        trajectory: &positions,
        scan_points: out.scan_points,
        ..SvgScene::default()
    });
    write_file(&dir.join("map.svg"), svg.as_bytes())?;
    let summary =
        serde_json::to_string_pretty(out.summary).context("cannot serialise the summary")?;
    write_file(&dir.join("summary.json"), summary.as_bytes())
}

/// Writes a file, naming it in the error.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    std::fs::write(path, bytes).with_context(|| format!("{}: cannot write", path.display()))
}

/// Writes one JSON object per scan: `{"scan": i, "stamp": "...", "pose": {...}, ...diagnostics}`.
pub struct DiagnosticsWriter {
    path: PathBuf,
    out: BufWriter<File>,
}

impl DiagnosticsWriter {
    pub fn create(path: &Path) -> Result<Self> {
        let file =
            File::create(path).with_context(|| format!("{}: cannot create", path.display()))?;
        Ok(DiagnosticsWriter {
            path: path.to_path_buf(),
            out: BufWriter::new(file),
        })
    }

    pub fn write(&mut self, stamp: &str, update: &polymap::mapper::Update) -> Result<()> {
        let line = serde_json::json!({
            "scan": update.scan_index,
            "stamp": stamp,
            "pose": update.map_from_robot,
            "diagnostics": update.diagnostics,
        });
        writeln!(self.out, "{line}")
            .with_context(|| format!("{}: cannot write", self.path.display()))
    }

    pub fn finish(mut self) -> Result<()> {
        self.out
            .flush()
            .with_context(|| format!("{}: cannot write", self.path.display()))
    }
}
