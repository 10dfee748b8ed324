//! The merged map's files: `map.json`, `merge.json`, `map.svg`, trajectories.

use std::path::Path;

use anyhow::{Context, Result};
use polymap::config::Config;
use polymap::map::{GlobalMap, MapSegment};
use polymap::merge::{MapMergeParams, MapMergeResult, merge_map};
use polymap_export::svg::{SvgStyle, write_svg};
use polymap_io::atomic::write_bytes_atomic;
use polymap_io::map_json::write_map_json;
use polymap_io::snapshot::{MapSnapshot, Polyline};

use super::input::Input;

/// B's segments (already in A's frame) merged into A, born after A's scans.
pub(super) fn merge(
    a: &Input,
    b_in_a: &[MapSegment],
    mut map: GlobalMap,
    config: &Config,
) -> (Vec<MapSegment>, MapMergeResult) {
    let counts = merge_map(
        &config.merge,
        &config.directions,
        &MapMergeParams::default(),
        &mut map,
        b_in_a,
        a.scans,
    );
    (map.iter().map(|(_, s)| *s).collect(), counts)
}

/// `map.json`, `merge.json`, `map.svg`, each atomically, the small contract files first.
pub(super) fn write_outputs(
    dir: &Path,
    a: &Input,
    b_scans: u32,
    merged: &[MapSegment],
    polylines: &[Vec<usize>],
    report: &serde_json::Value,
) -> Result<()> {
    let snapshot = MapSnapshot {
        frame: a.frame.clone(),
        title: format!(
            "merged map — {} segments, {} polylines",
            merged.len(),
            polylines.len()
        ),
        segments: merged.to_vec(),
        polylines: polylines
            .iter()
            .map(|p| Polyline {
                segments: p.clone(),
            })
            .collect(),
        // B's scans are numbered after A's.
        scans_before: a.scans.saturating_add(b_scans),
        ..MapSnapshot::default()
    };
    write_map_json(dir.join("map.json"), &snapshot.map_json())?;
    write_json(&dir.join("merge.json"), report)?;
    write_svg(&dir.join("map.svg"), &snapshot, &SvgStyle::default())?;
    Ok(())
}

pub(super) fn write_json(path: &Path, value: &serde_json::Value) -> Result<()> {
    let mut text = serde_json::to_string_pretty(value)?;
    text.push('\n');
    write_bytes_atomic(path, text.as_bytes())
        .with_context(|| format!("{}: cannot write", path.display()))
}

/// Removes a merged map an earlier merge left in the folder (`map.json`, `map.svg`, the laid
/// trajectories), so none stays beside a refusal.
pub(super) fn remove_stale(dir: &Path) -> Result<()> {
    for name in ["map.json", "map.svg"] {
        remove_stale_file(&dir.join(name))?;
    }
    remove_stale_trajectories(dir, &[])
}

/// Removes the laid trajectories (`trajectory_*.tum`) of an earlier merge not named in `keep`.
pub(super) fn remove_stale_trajectories(dir: &Path, keep: &[String]) -> Result<()> {
    let entries =
        std::fs::read_dir(dir).with_context(|| format!("{}: cannot list", dir.display()))?;
    for entry in entries {
        let entry = entry.with_context(|| format!("{}: cannot list", dir.display()))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        if name.starts_with("trajectory_") && name.ends_with(".tum") && !keep.contains(&name) {
            remove_stale_file(&entry.path())?;
        }
    }
    Ok(())
}

/// Removes one file of an earlier merge, if there.
pub(super) fn remove_stale_file(path: &Path) -> Result<()> {
    if path.is_file() {
        std::fs::remove_file(path).with_context(|| format!("{}: cannot remove", path.display()))?;
        eprintln!("polymap: removed {} of an earlier merge", path.display());
    }
    Ok(())
}
