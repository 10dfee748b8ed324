//! One map to merge: read from a `polymap map` folder, or the merged map of earlier inputs.

use std::path::{Path, PathBuf};

use anyhow::{Result, bail};
use polymap::config::Config;
use polymap::geometry::Vec2;
use polymap::loops::SavedNode;
use polymap::map::{GlobalMap, MapSegment};
use polymap_io::loop_nodes::{LOOP_NODES_FILE, read_loop_nodes};
use polymap_io::map_json::read_map_json;
use polymap_io::tum::{StampedPose, read_tum};

use crate::quote::quoted;

/// One input map: its folder, `map.json` and how many scans made it.
pub(super) struct Input {
    /// Its folder (for a merged map, the first input's).
    pub dir: PathBuf,
    /// How `merge.json` names it: the folder as given, or the inputs merged.
    pub path_text: String,
    /// How messages name it (quoted).
    pub label: String,
    /// The frame's description (`map.json` `frame`).
    pub frame: String,
    pub segments: Vec<MapSegment>,
    /// The robot's positions from `trajectory.tum` (empty without it), map frame.
    pub path: Vec<Vec2>,
    /// The robot's poses from `trajectory.tum` (empty without it), one per scan, map frame.
    pub trajectory: Vec<StampedPose>,
    /// The loop nodes of `loop_nodes.json`, when the folder has it.
    pub nodes: Option<Vec<SavedNode>>,
    pub scans: u32,
    /// The folder's lock for reading, held until the merge is written.
    pub _lock: Option<polymap_pipeline::manifest::FolderLock>,
}

/// Reads `DIR/map.json` and counts the scans that made it (its `scans`, or one past the
/// latest birth in a version 1 file).
pub(super) fn read_input(dir: &Path) -> Result<Input> {
    if !dir.is_dir() {
        bail!("{}: not a folder (a polymap map output)", shown(dir));
    }
    let lock =
        crate::outputs::check_run_folder(dir, &["map.json", "trajectory.tum", LOOP_NODES_FILE])?;
    let map = read_map_json(dir.join("map.json"))?;
    let segments = map.map_segments();
    if segments.is_empty() {
        bail!("{}: the map has no segments", shown(&dir.join("map.json")));
    }
    let born = segments.iter().map(|s| s.born_scan).max().unwrap_or(0);
    let scans = map.scans_mapped().max(born.saturating_add(1));
    let tum = dir.join("trajectory.tum");
    let trajectory = match tum.is_file() {
        true => read_tum(&tum)?,
        false => Vec::new(),
    };
    let path: Vec<Vec2> = trajectory
        .iter()
        .map(|p| p.map_from_robot.translation())
        .collect();
    let nodes_file = dir.join(LOOP_NODES_FILE);
    let nodes = match nodes_file.is_file() {
        true => Some(read_loop_nodes(&nodes_file)?),
        false => None,
    };
    Ok(Input {
        dir: dir.to_path_buf(),
        path_text: dir.display().to_string(),
        label: shown(dir),
        frame: map.frame,
        segments,
        scans,
        path,
        trajectory,
        nodes,
        _lock: lock,
    })
}

/// Segments in a map store indexed as the mapper's.
pub(super) fn global_map(segments: &[MapSegment], config: &Config) -> GlobalMap {
    let reach = config.align.initial_gate_m.max(config.align.final_gate_m);
    let mut map = GlobalMap::new(config.map.grid_cell_m, reach);
    for s in segments {
        map.insert(*s);
    }
    map
}

/// A path for messages, quoted.
pub(super) fn shown(p: &Path) -> String {
    quoted(&p.display().to_string())
}
