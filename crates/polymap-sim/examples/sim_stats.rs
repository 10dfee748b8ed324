//! Simulates every built-in world with its own laser and default parameters otherwise and prints a line of statistics each:
//! size, walls, path length, scans, clearance, share of valid returns, drift, and time taken.
//!
//! `cargo run --release -p polymap-sim --example sim_stats`

use std::time::Instant;

use polymap::geometry::normalize_angle_rad;
use polymap_sim::{World, simulate};

fn main() {
    for world in World::catalogue() {
        let t0 = Instant::now();
        let run = simulate(&world, &world.sim_params(), 1);
        let elapsed_s = t0.elapsed().as_secs_f64();
        let (lo, hi) = world.bounds().unwrap_or_default();
        let size = hi - lo;
        let clearance = run
            .true_poses
            .iter()
            .map(|p| world.clearance_m(p.translation()))
            .fold(f64::MAX, f64::min);
        let beams: usize = run.scans.iter().map(|s| s.ranges_m.len()).sum();
        let valid: usize = run.scans.iter().map(|s| s.valid_count()).sum();
        let min_valid = run.scans.iter().map(|s| s.valid_count()).min().unwrap_or(0);
        let drift = match (
            run.scans.last().and_then(|s| s.odom_from_robot),
            run.true_poses_in_first_frame().last(),
        ) {
            (Some(o), Some(t)) => (
                (o.translation() - t.translation()).length(),
                normalize_angle_rad(o.theta_rad - t.theta_rad).to_degrees(),
            ),
            _ => (0.0, 0.0),
        };
        let (first, last) = (run.true_poses[0], run.true_poses[run.true_poses.len() - 1]);
        println!(
            "{:10} {:5.1}x{:4.1} m  walls {:3} (+{} pillars, {} truth)  path {:5.1} m  scans {:4}  \
             clearance {:.2} m  valid {:.1}% (min {})  seen {}/{} {:.0} m (observed {:.0} m)  \
             end-start {:.2} m  odom drift {:.2} m {:.1}°  {:.3} s",
            world.name,
            size.x,
            size.y,
            world.walls.len(),
            world.pillars.len(),
            run.walls.len(),
            run.path_length_m(),
            run.scans.len(),
            clearance,
            100.0 * valid as f64 / beams as f64,
            min_valid,
            run.walls_seen.len(),
            run.walls.len(),
            run.seen_wall_length_m,
            run.observed_wall_length_m,
            (last.translation() - first.translation()).length(),
            drift.0,
            drift.1,
            elapsed_s
        );
    }
}
