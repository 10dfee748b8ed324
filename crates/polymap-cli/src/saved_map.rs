//! A saved map a run starts from (`--resume DIR`, `localize --map DIR`): read and checked,
//! and the mapper that continues or localizes in it.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use polymap::config::Config;
use polymap::geometry::Pose2;
use polymap::loops::SavedNode;
use polymap::mapper::{MapRole, Mapper, PriorMap};
use polymap_io::loop_nodes::{LOOP_NODES_FILE, read_loop_nodes};
use polymap_io::map_json::{MapJson, read_map_json};
use polymap_pipeline::manifest::FolderLock;

use crate::quote::quoted;

/// Above this bounding box, square metres, of a saved map, `--resume` and `localize` without
/// `--initial-pose` warn that the search for the log's start will be slow. Each scan until
/// the start is found costs a search over the whole box, about 65 µs per m²: measured on the
/// simulated office's map tiled 2 × 2 (3,400 m²) and 3 × 3 (8,000 m²), where no start is ever
/// certain, 12 s and 26 s for the 50 scans searched. The benchmark logs' maps are smaller:
/// Intel 1,100 m², ACES 3,000 m², FR079 650 m².
const SLOW_SEARCH_AREA_M2: f64 = 5_000.0;
/// Above this bounding box, square metres, the search is refused: at about 65 µs per m² a scan
/// it would take minutes (a map of 100,000 m² took minutes); the log needs `--initial-pose`.
const MAX_SEARCH_AREA_M2: f64 = 100_000.0;
/// Seconds per square metre of the map's box that one search for the start takes.
const SEARCH_S_PER_M2: f64 = 65e-6;

/// A saved map a run starts from: `--resume DIR` or `localize --map DIR`.
pub struct SavedMap {
    pub(crate) dir: PathBuf,
    pub(crate) map: MapJson,
    /// The saved run's loop-closure nodes (empty when it saved none).
    pub(crate) nodes: Vec<SavedNode>,
    pub(crate) role: MapRole,
    /// The folder's lock for reading, held from the check of its files for the whole run: no
    /// run writes the map while it is read and used.
    _lock: Option<FolderLock>,
}

impl SavedMap {
    /// Reads the saved map in `dir` (its `map.json` and, when there, its loop nodes), holding
    /// the folder's lock for reading for as long as the value lives.
    pub fn read(dir: &Path, role: MapRole) -> Result<SavedMap> {
        let lock = crate::outputs::check_run_folder(dir, &["map.json", LOOP_NODES_FILE])?;
        let map = read_map_json(dir.join("map.json")).with_context(|| {
            format!(
                "cannot read the saved map in {}",
                quoted(&dir.display().to_string())
            )
        })?;
        anyhow::ensure!(
            !map.segments.is_empty(),
            "{}: the saved map has no segments: nothing to place the log in",
            quoted(&dir.join("map.json").display().to_string())
        );
        // Without its loop nodes (a map from an older polymap, or merged) the map is still
        // continued; loops then close only among the new scans.
        let nodes_path = dir.join(LOOP_NODES_FILE);
        let nodes = match nodes_path.is_file() {
            true => read_loop_nodes(&nodes_path)?,
            false => {
                eprintln!(
                    "polymap: note: no {LOOP_NODES_FILE} in {}: loops will close among the new \
                     scans only",
                    quoted(&dir.display().to_string())
                );
                Vec::new()
            }
        };
        Ok(SavedMap {
            dir: dir.to_path_buf(),
            map,
            nodes,
            role,
            _lock: lock,
        })
    }

    /// Warns about a map whose search for the log's start (without `--initial-pose`) will be
    /// slow, and refuses one where it would take minutes: the search covers the map's whole
    /// bounding box, its cost grows with that area.
    pub(crate) fn check_searchable(&self, start_search_scans: u32) -> Result<()> {
        let ends = self.map.segments.iter().flat_map(|s| [s.start, s.end]);
        let (lo, hi) = ends.fold(([f64::MAX; 2], [f64::MIN; 2]), |(lo, hi), p| {
            (
                [lo[0].min(p[0]), lo[1].min(p[1])],
                [hi[0].max(p[0]), hi[1].max(p[1])],
            )
        });
        let (w, h) = ((hi[0] - lo[0]).max(0.0), (hi[1] - lo[1]).max(0.0));
        let area_m2 = w * h;
        let dir = quoted(&self.dir.display().to_string());
        anyhow::ensure!(
            area_m2 <= MAX_SEARCH_AREA_M2,
            "{dir}: the map covers {w:.0} m × {h:.0} m, more than the {MAX_SEARCH_AREA_M2} m² a \
             search for the log's start may cover (each scan until it is found would take about \
             {:.0} s): give --initial-pose x,y,yaw (metres, metres, radians) where the log starts",
            area_m2 * SEARCH_S_PER_M2
        );
        if area_m2 > SLOW_SEARCH_AREA_M2 {
            eprintln!(
                "polymap: warning: {dir}: the map covers {w:.0} m × {h:.0} m: the search for the \
                 log's start takes about {:.1} s per scan until it is found (up to {} scans); \
                 --initial-pose x,y,yaw (metres, metres, radians) skips it",
                area_m2 * SEARCH_S_PER_M2,
                start_search_scans
            );
        }
        Ok(())
    }

    /// What the saved map is to the run, for messages.
    pub(crate) fn role_name(&self) -> &'static str {
        match self.role {
            MapRole::Localize => "map to localize in (--map)",
            MapRole::Build => "map to resume (--resume)",
        }
    }

    pub(crate) fn mapper(&self, config: &Config, start: Option<Pose2>) -> Mapper {
        let prior = PriorMap {
            segments: self.map.map_segments(),
            scans: self.map.scans_mapped(),
            nodes: self.nodes.clone(),
            observations: self.map.observations(),
        };
        Mapper::on_map(config.clone(), prior, self.role, start)
    }
}
