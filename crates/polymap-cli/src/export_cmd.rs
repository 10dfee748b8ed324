//! `polymap export`: other formats from a finished run.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use polymap_export::formats::{ExportInput, Format, export};
use polymap_export::report::ReportData;
use polymap_io::log::{LogOptions, LogSource};
use polymap_io::map_json::read_map_json;
use polymap_io::snapshot::{MapSnapshot, ScanPoints};
use polymap_io::tum::read_tum;
use polymap_pipeline::manifest::{FolderLock, manifest_of, read_manifest, write_manifest};
use polymap_pipeline::pipeline::reread_scan_points;

use polymap_io::input_file::read_regular_to_string;

use crate::args::ExportArgs;

/// The most a run's `summary.json` may weigh (a run writes a few kB).
const MAX_SUMMARY_BYTES: u64 = 16 << 20;
/// The most a run's `history.json` may weigh (its budget keeps a long run near 3 MB).
const MAX_HISTORY_BYTES: u64 = 256 << 20;
use crate::quote::quoted;

pub fn run(a: &ExportArgs) -> Result<()> {
    let read = ["map.json", "trajectory.tum", "summary.json", "history.json"];
    // Held from the check until the exports are written: no run may write the folder
    // meanwhile.
    let _lock = FolderLock::exclusive(&a.run)?;
    crate::outputs::check_locked_run_folder(&a.run, &read)?;
    let map = read_map_json(a.run.join("map.json"))?;
    let trajectory = read_tum(a.run.join("trajectory.tum"))?;
    let snapshot = MapSnapshot::from_files(&map, trajectory);
    let rays = match a.format.contains(&Format::Pgm) {
        true => Some(rays(a, &snapshot)?),
        false => None,
    };
    let history = match a.format.contains(&Format::Html) {
        true => Some(read_history(&a.run)?),
        false => None,
    };
    let input = ExportInput {
        dir: &a.run,
        snapshot: &snapshot,
        rays: rays.as_ref(),
        history: history.as_ref(),
        resolution_m: a.resolution,
    };
    let written = export(&a.format, &input)?;
    add_to_manifest(&a.run, &written)?;
    for path in written {
        say!("wrote {}", path.display());
    }
    Ok(())
}

/// Lists the exports `written` in the run's manifest beside its files (a folder without a
/// manifest stays without one: its files were never checked to be one run's). The other
/// entries stay as they are: export checked only the files it reads, so a file it neither
/// read nor wrote, changed since the run, must still show as not the one listed.
fn add_to_manifest(run: &Path, written: &[PathBuf]) -> Result<()> {
    let Some(mut manifest) = read_manifest(run)? else {
        return Ok(());
    };
    let names: Vec<String> = written
        .iter()
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .collect();
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    manifest
        .files
        .extend(manifest_of(run, &manifest.run, &names)?.files);
    write_manifest(run, &manifest)?;
    Ok(())
}

/// The laser rays of the mapped log, read again through the pipeline's conversion; scan `i`
/// goes with pose `i` (a log's stamps may repeat or go backwards, so they are only checked).
fn rays(a: &ExportArgs, snapshot: &MapSnapshot) -> Result<ScanPoints> {
    let log = match &a.log {
        Some(l) => l.clone(),
        None => logged_path(&a.run)?,
    };
    let options = LogOptions {
        skip_bad_input: a.skip_bad_lines,
        ..LogOptions::default()
    };
    let mut source = LogSource::open(&log, &options)?;
    if !source.is_regular_file() {
        bail!(
            "{}: not a file that can be read again (standard input, a pipe or a device): \
             pass the log with --log FILE, or map with --export pgm",
            quoted(&log.display().to_string())
        );
    }
    let poses = snapshot.trajectory.len();
    let (points, stamps) = reread_scan_points(&mut source, poses)
        .with_context(|| format!("re-reading {} for the occupancy grid", log.display()))?;
    if stamps.len() < poses {
        bail!(
            "{}: the trajectory has {poses} poses but the log only {} scans: not this log's trajectory",
            log.display(),
            stamps.len()
        );
    }
    if source.next_scan().is_ok_and(|s| s.is_some()) {
        eprintln!("polymap: note: the trajectory covers the first {poses} scans of the log");
    }
    let mismatch = snapshot
        .trajectory
        .iter()
        .zip(&stamps)
        .position(|(p, s)| p.stamp.seconds != s.seconds);
    if let Some(i) = mismatch {
        bail!(
            "{}: trajectory pose {} has stamp {} but scan {} of the log has {}: not this log's trajectory",
            log.display(),
            i + 1,
            quoted(&snapshot.trajectory[i].stamp.text),
            i + 1,
            quoted(&stamps[i].text)
        );
    }
    Ok(points)
}

/// The log named in the run's summary.json; a run that read standard input has none.
fn logged_path(run: &Path) -> Result<PathBuf> {
    let path = run.join("summary.json");
    let text = read_regular_to_string(&path, MAX_SUMMARY_BYTES)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let summary: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("{}: not JSON", path.display()))?;
    let log = summary["log"]
        .as_str()
        .with_context(|| format!("{}: no \"log\"; pass --log", path.display()))?;
    if log == "-" {
        bail!(
            "{}: the run read its log from standard input, which cannot be read again: \
             pass the log with --log FILE (or map with --export pgm)",
            run.display()
        );
    }
    Ok(PathBuf::from(log))
}

/// The replay history the run saved.
pub fn read_history(run: &Path) -> Result<ReportData> {
    let path = run.join("history.json");
    let text = read_regular_to_string(&path, MAX_HISTORY_BYTES)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    serde_json::from_str(&text)
        .with_context(|| format!("{}: not a polymap history", path.display()))
}
