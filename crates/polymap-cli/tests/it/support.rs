//! Shared helpers: running the binary, simulating and mapping in process.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use polymap::config::Config;
use polymap::geometry::Pose2;
use polymap::mapper::{Mapper, Update};
use polymap_sim::{SimRun, simulate, world_by_name};

/// Runs the `polymap` binary with arguments.
pub fn polymap(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_polymap"))
        .args(args)
        .output()
        .expect("the polymap binary runs")
}

/// `polymap map LOG -o OUT -q EXTRA…`.
pub fn map_quietly(log: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "map",
        log.to_str().expect("a UTF-8 temp path"),
        "-o",
        out.to_str().expect("a UTF-8 temp path"),
        "-q",
    ];
    args.extend_from_slice(extra);
    polymap(&args)
}

/// Standard error and output as text, for failure messages.
pub fn text(o: &Output) -> String {
    format!(
        "status {:?}\nstdout:\n{}\nstderr:\n{}",
        o.status,
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// A simulated run of a named world with its default parameters (`World::sim_params`) and
/// seed 1.
pub fn sim(name: &str) -> SimRun {
    let world = world_by_name(name).expect("a built-in world");
    simulate(&world, &world.sim_params(), 1)
}

/// Maps every scan of a run; returns the mapper and each scan's update.
pub fn map_run(run: &SimRun, config: Config) -> (Mapper, Vec<Update>) {
    let mut mapper = Mapper::new(config);
    let updates = run.scans.iter().map(|s| mapper.push(s)).collect();
    mapper.finish().expect("loop closure does not fail");
    (mapper, updates)
}

/// The mapper's final poses (after loop closure) paired with the true poses in the first
/// scan's frame (the map frame).
pub fn pose_pairs(run: &SimRun, mapper: &Mapper) -> Vec<(Pose2, Pose2)> {
    mapper
        .trajectory()
        .iter()
        .copied()
        .zip(run.true_poses_in_first_frame())
        .collect()
}

/// The shared datasets folder, if present.
pub fn datasets() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/datasets");
    dir.is_dir().then_some(dir)
}
