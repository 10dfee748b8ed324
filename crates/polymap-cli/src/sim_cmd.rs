//! `polymap simulate`: a simulated world written as a CARMEN log with its ground truth.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow};
use polymap::map::MapSegment;
use polymap_io::carmen::write_flaser_log;
use polymap_io::map_json::{FRAME_FIRST_SCAN, MapJson, write_map_json};
use polymap_io::tum::{StampedPose, write_tum};
use polymap_sim::{SimRun, World, simulate, world_by_name};
use serde_json::json;

use crate::args::SimulateArgs;
use crate::outputs::write_file;

/// Files written for a simulated run.
pub struct SimFiles {
    pub log: PathBuf,
    pub truth: PathBuf,
    pub walls: PathBuf,
}

pub fn run(a: &SimulateArgs) -> Result<()> {
    if a.list {
        for w in World::catalogue() {
            say!("{:<10} {}", w.name, w.description);
        }
        return Ok(());
    }
    let name = a
        .world
        .as_deref()
        .ok_or_else(|| anyhow!("name a world (see --list)"))?;
    let files = simulate_to(name, &a.output, a.seed)?;
    say!(
        "wrote {}, {} and {}",
        files.log.display(),
        files.truth.display(),
        files.walls.display()
    );
    Ok(())
}

/// Simulates world `name` into `dir`: `NAME.clf`, `NAME.truth.tum` (true poses in the first
/// scan's frame), `NAME.walls.json` (true walls, same frame) and `NAME.sim.json`.
pub fn simulate_to(name: &str, dir: &Path, seed: u64) -> Result<SimFiles> {
    let names: Vec<String> = World::catalogue().into_iter().map(|w| w.name).collect();
    let world = world_by_name(name)
        .ok_or_else(|| anyhow!("unknown world {name:?}; known: {}", names.join(", ")))?;
    let run = simulate(&world, &world.sim_params(), seed);
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create", dir.display()))?;
    let files = SimFiles {
        log: dir.join(format!("{name}.clf")),
        truth: dir.join(format!("{name}.truth.tum")),
        walls: dir.join(format!("{name}.walls.json")),
    };
    write_flaser_log(&files.log, &run.scans)?;
    write_tum(&files.truth, &truth_trajectory(&run))?;
    let walls: Vec<MapSegment> = run
        .walls_in_first_frame()
        .into_iter()
        .map(|segment| MapSegment {
            segment,
            born_scan: 0,
        })
        .collect();
    write_map_json(&files.walls, &MapJson::new(FRAME_FIRST_SCAN, &walls, &[]))?;
    let meta = json!({
        "world": run.world_name,
        "description": world.description,
        "seed": run.seed,
        "scans": run.scans.len(),
        "path_length_m": run.path_length_m(),
        "walls": run.walls.len(),
        "walls_seen": run.walls_seen,
        "seen_wall_length_m": run.seen_wall_length_m,
        "observed_wall_length_m": run.observed_wall_length_m,
        "params": run.params,
    });
    write_file(
        &dir.join(format!("{name}.sim.json")),
        serde_json::to_string_pretty(&meta)?.as_bytes(),
    )?;
    Ok(files)
}

fn truth_trajectory(run: &SimRun) -> Vec<StampedPose> {
    run.scans
        .iter()
        .zip(run.true_poses_in_first_frame())
        .map(|(s, p)| StampedPose {
            stamp: s.stamp.clone(),
            map_from_robot: p,
        })
        .collect()
}
