//! `polymap simulate`: a simulated world written as a CARMEN log with its ground truth.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow};
use polymap::geometry::Pose2;
use polymap::map::MapSegment;
use polymap_io::carmen::write_flaser_log;
use polymap_io::map_json::{FRAME_FIRST_SCAN, MapJson, write_map_json};
use polymap_io::ros::mcap_file::McapCompression;
use polymap_io::ros::ros1::BagCompression;
use polymap_io::ros::{RecordOptions, float32_scan, write_bag_with, write_mcap_with};
use polymap_io::tum::{StampedPose, write_tum};
use polymap_sim::{LaserParams, SimRun, World, simulate, world_by_name};
use serde_json::json;

use crate::args::SimulateArgs;
use crate::outputs::write_file;

/// Files written for a simulated run.
pub struct SimFiles {
    pub log: PathBuf,
    pub truth: PathBuf,
    pub walls: PathBuf,
    /// With [`SimOutput::ros`]: the MCAP file and the ROS 1 bag.
    pub ros: Option<(PathBuf, PathBuf)>,
}

/// Where the laser sits on the robot in a world simulated with `--ros` whose own laser sits at
/// the robot's origin: 0.25 m ahead of it, facing forward, so that the recordings' tf
/// (`base_link → laser` on `/tf_static`) matters. The truth stays the robot's (`base_link`)
/// trajectory.
pub const ROS_LASER_MOUNT: Pose2 = Pose2 {
    x_m: 0.25,
    y_m: 0.0,
    theta_rad: 0.0,
};

/// What `polymap simulate` writes besides the CARMEN log.
#[derive(Debug, Clone, Copy)]
pub struct SimOutput {
    /// Also write NAME.mcap and NAME.bag, with the laser mounted at [`ROS_LASER_MOUNT`] (in
    /// every file: the CARMEN log says it with `PARAM robot_frontlaser_offset`, the recordings
    /// with tf). The scans are then rounded to `float32` (as a ROS message holds them) in every
    /// file, so that all three read back to the same scans.
    pub ros: bool,
    /// The laser's field of view, degrees (one beam per degree); `None`: the world's own laser.
    pub fov_deg: Option<u16>,
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
    let output = SimOutput {
        ros: a.ros,
        fov_deg: a.fov_deg,
    };
    let files = simulate_with(name, &a.output, a.seed, output)?;
    say!(
        "wrote {}, {} and {}",
        files.log.display(),
        files.truth.display(),
        files.walls.display()
    );
    if let Some((mcap, bag)) = &files.ros {
        say!("wrote {} and {}", mcap.display(), bag.display());
    }
    Ok(())
}

/// Simulates world `name` (180° laser) into `dir`: `NAME.clf`, `NAME.truth.tum` (true poses in the first
/// scan's frame), `NAME.walls.json` (true walls, same frame) and `NAME.sim.json`.
pub fn simulate_to(name: &str, dir: &Path, seed: u64) -> Result<SimFiles> {
    let output = SimOutput {
        ros: false,
        fov_deg: None,
    };
    simulate_with(name, dir, seed, output)
}

/// [`simulate_to`] with, if asked, a laser of `output.fov_deg` degrees and, with `output.ros`, the world
/// also as `NAME.mcap` (zstd chunks) and `NAME.bag` (lz4 chunks), the laser mounted at
/// [`ROS_LASER_MOUNT`].
pub fn simulate_with(name: &str, dir: &Path, seed: u64, output: SimOutput) -> Result<SimFiles> {
    let names: Vec<String> = World::catalogue().into_iter().map(|w| w.name).collect();
    let world = world_by_name(name)
        .ok_or_else(|| anyhow!("unknown world {name:?}; known: {}", names.join(", ")))?;
    let mut params = world.sim_params();
    if let Some(fov_deg) = output.fov_deg {
        // The world's laser (range, noise, mounting) with the field of view asked for.
        let geometry = LaserParams::one_beam_per_degree(fov_deg);
        params.laser.num_beams = geometry.num_beams;
        params.laser.fov_rad = geometry.fov_rad;
        params.laser.angle_min_rad = geometry.angle_min_rad;
    }
    if output.ros && params.laser.robot_from_laser == Pose2::IDENTITY {
        params.laser.robot_from_laser = ROS_LASER_MOUNT;
    }
    let mut run = simulate(&world, &params, seed);
    if output.ros {
        run.scans = run.scans.iter().map(float32_scan).collect();
    }
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create", dir.display()))?;
    let files = SimFiles {
        log: dir.join(format!("{name}.clf")),
        truth: dir.join(format!("{name}.truth.tum")),
        walls: dir.join(format!("{name}.walls.json")),
        ros: output.ros.then(|| {
            (
                dir.join(format!("{name}.mcap")),
                dir.join(format!("{name}.bag")),
            )
        }),
    };
    write_flaser_log(&files.log, &run.scans)?;
    if let Some((mcap, bag)) = &files.ros {
        // The scans, /odom, and tf: base_link → laser (static), odom → base_link.
        let with_tf = RecordOptions {
            odometry_topic: true,
            tf: true,
        };
        write_mcap_with(mcap, &run.scans, McapCompression::Zstd, with_tf)?;
        write_bag_with(bag, &run.scans, BagCompression::Lz4, with_tf)?;
    }
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
