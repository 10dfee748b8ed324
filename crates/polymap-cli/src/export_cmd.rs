//! `polymap export`: other formats from a finished run.

use std::path::PathBuf;

use anyhow::{Context, Result};
use polymap_export::report::ReportData;
use polymap_io::map_json::read_map_json;
use polymap_io::tum::read_tum;

use crate::args::ExportArgs;
use crate::exports::{ExportInput, Format, export};

pub fn run(a: &ExportArgs) -> Result<()> {
    let map = read_map_json(a.run.join("map.json"))?;
    let trajectory = read_tum(a.run.join("trajectory.tum"))?;
    let log = match &a.log {
        Some(l) => Some(l.clone()),
        None if a.format.contains(&Format::Pgm) => Some(logged_path(&a.run)?),
        None => None,
    };
    let history = match a.format.contains(&Format::Html) {
        true => Some(read_history(&a.run)?),
        false => None,
    };
    let segments = map.map_segments();
    let input = ExportInput {
        dir: &a.run,
        segments: &segments,
        polylines: &map.polylines,
        trajectory: &trajectory,
        scan_points: &[],
        log: log.as_deref(),
        skip_bad_lines: a.skip_bad_lines,
        history: history.as_ref(),
        resolution_m: a.resolution,
    };
    for path in export(&a.format, &input)? {
        say!("wrote {}", path.display());
    }
    Ok(())
}

/// The log named in the run's summary.json.
fn logged_path(run: &std::path::Path) -> Result<PathBuf> {
    let path = run.join("summary.json");
    let text = std::fs::read_to_string(&path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let summary: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("{}: not JSON", path.display()))?;
    let log = summary["log"]
        .as_str()
        .with_context(|| format!("{}: no \"log\"; pass --log", path.display()))?;
    Ok(PathBuf::from(log))
}

/// The replay history the run saved.
pub fn read_history(run: &std::path::Path) -> Result<ReportData> {
    let path = run.join("history.json");
    let text = std::fs::read_to_string(&path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    serde_json::from_str(&text)
        .with_context(|| format!("{}: not a polymap history", path.display()))
}
