//! The simulation run: path, laser and odometry put together into scans with ground truth.

use polymap::geometry::{Pose2, Segment};
use polymap::scan::{RangeScan, Stamp};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::laser::read_laser;
use crate::odometry::odometry;
use crate::params::SimParams;
use crate::path::trajectory;
use crate::raycast::RayCaster;
use crate::truth::{WallTally, poses_in_first_frame};
use crate::world::World;

/// ChaCha stream for the laser's noise.
const LASER_STREAM: u64 = 1;
/// ChaCha stream for the odometry's noise.
const ODOMETRY_STREAM: u64 = 2;
/// ChaCha stream for the odometry's faults.
const ODOMETRY_FAULT_STREAM: u64 = 3;

/// A simulated log with its ground truth.
///
/// Ground truth is in the **world frame**; a mapper starts from the first scan's pose, so
/// compare against [`SimRun::true_poses_in_first_frame`] and
/// [`SimRun::walls_in_first_frame`]. With default odometry the odometry frame is that same
/// first-pose frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SimRun {
    /// Name of the simulated world.
    pub world_name: String,
    /// The seed the run was made with.
    pub seed: u64,
    /// The parameters actually used (after [`SimParams::sanitized`]).
    pub params: SimParams,
    /// The scans, in time order, odometry filled in when enabled.
    pub scans: Vec<RangeScan>,
    /// The robot's true pose at each scan, `map_from_robot` with the world as map.
    pub true_poses: Vec<Pose2>,
    /// Ground-truth walls ([`World::truth_walls`]): walls, then pillars as polygons. Metres,
    /// world frame.
    pub walls: Vec<Segment>,
    /// Returned beams that hit each of `walls`.
    pub wall_hits: Vec<u32>,
    /// Indices into `walls` of those hit by at least `params.min_hits_seen` returned beams.
    pub walls_seen: Vec<usize>,
    /// Total length of the walls in `walls_seen`, metres.
    pub seen_wall_length_m: f64,
    /// Length of wall actually observed: the 0.1 m stretches of `walls` hit at least once,
    /// metres.
    pub observed_wall_length_m: f64,
}

impl SimRun {
    /// The transform from the world frame to the first robot pose's frame.
    pub fn first_from_world(&self) -> Pose2 {
        self.true_poses
            .first()
            .map_or(Pose2::IDENTITY, Pose2::inverse)
    }

    /// True poses in the first pose's frame (the first is the identity).
    pub fn true_poses_in_first_frame(&self) -> Vec<Pose2> {
        poses_in_first_frame(&self.true_poses)
    }

    /// Ground-truth walls in the first pose's frame.
    pub fn walls_in_first_frame(&self) -> Vec<Segment> {
        let first_from_world = self.first_from_world();
        self.walls
            .iter()
            .map(|w| w.transformed(&first_from_world))
            .collect()
    }

    /// The odometry pose of every scan that carries one (`odom_from_robot`).
    pub fn odometry_poses(&self) -> Vec<Pose2> {
        self.scans
            .iter()
            .filter_map(|s| s.odom_from_robot)
            .collect()
    }

    /// The walls in `walls_seen`, world frame.
    pub fn seen_walls(&self) -> Vec<Segment> {
        self.walls_seen
            .iter()
            .filter_map(|&i| self.walls.get(i).copied())
            .collect()
    }

    /// Length of the true path, metres.
    pub fn path_length_m(&self) -> f64 {
        self.true_poses
            .windows(2)
            .map(|w| (w[1].translation() - w[0].translation()).length())
            .sum()
    }
}

/// Time stamp of scan `k`: `start + k / rate`, written with six decimals; `seconds` is read
/// back from the text so the two agree exactly.
fn stamp(params: &SimParams, k: usize) -> Stamp {
    let seconds = params.start_time_s + k as f64 / params.rate_hz;
    let text = format!("{seconds:.6}");
    let seconds = text.parse().unwrap_or(seconds);
    Stamp { seconds, text }
}

/// A seeded generator for one noise source.
fn rng(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(stream);
    rng
}

/// Simulates the world's tour: the robot follows [`World::waypoints`] and logs a scan at
/// every step. Deterministic for a seed; laser and odometry draw from separate streams, so
/// changing one's parameters leaves the other's noise unchanged. Invalid parameters are
/// replaced by defaults ([`SimParams::sanitized`]); check them first with
/// [`SimParams::validate`].
///
/// ```
/// use polymap_sim::{SimParams, World, simulate};
/// let params = SimParams { max_scans: Some(20), ..SimParams::default() };
/// let run = simulate(&World::hallway45(), &params, 7);
/// assert_eq!(run.scans.len(), 20);
/// assert_eq!(run.scans[1].stamp.text, "1000000000.100000");
/// assert!(run.scans.iter().all(|s| s.valid_count() > 150));
/// assert_eq!(run, simulate(&World::hallway45(), &params, 7));
/// ```
pub fn simulate(world: &World, params: &SimParams, seed: u64) -> SimRun {
    let params = params.sanitized();
    let mut true_poses = trajectory(&world.waypoints, &params.path, params.rate_hz);
    true_poses.truncate(params.max_scans.unwrap_or(usize::MAX));
    let odom = odometry(
        &true_poses,
        &params.odometry,
        &mut rng(seed, ODOMETRY_STREAM),
        &mut rng(seed, ODOMETRY_FAULT_STREAM),
    );
    let caster = RayCaster::new(world);
    let before = Before::new(world, true_poses.len());
    let mut laser_rng = rng(seed, LASER_STREAM);
    let mut tally = WallTally::new(world);
    let laser = &params.laser;
    let scans = true_poses
        .iter()
        .zip(&odom)
        .enumerate()
        .map(|(k, (map_from_robot, odom_from_robot))| {
            let caster = before.caster(k).unwrap_or(&caster);
            let reading = read_laser(caster, map_from_robot, laser, &mut laser_rng);
            reading
                .hits
                .iter()
                .flatten()
                .filter(|h| before.is_truth(k, h))
                .for_each(|h| tally.record(world, h));
            RangeScan {
                stamp: stamp(&params, k),
                ranges_m: reading.ranges_m,
                angle_min_rad: laser.angle_min_rad,
                angle_increment_rad: laser.angle_increment_rad(),
                max_range_m: laser.max_range_m,
                robot_from_laser: laser.robot_from_laser,
                odom_from_robot: params.odometry.enabled.then_some(*odom_from_robot),
            }
        })
        .collect();
    finish(world, params, seed, scans, true_poses, tally)
}

/// The world before its change ([`World::moved`]): its ray caster and which of its walls are
/// also walls of the world as the tour ends (the ground truth).
struct Before {
    caster: Option<RayCaster>,
    /// Scans `0..until` see the world before the change.
    until: usize,
    /// Walls `0..kept` are the same in both worlds (pillars are never moved).
    kept: usize,
}

impl Before {
    fn new(world: &World, scans: usize) -> Before {
        let Some((m, before)) = world.moved.as_ref().zip(world.before_change()) else {
            return Before {
                caster: None,
                until: 0,
                kept: world.walls.len(),
            };
        };
        Before {
            caster: Some(RayCaster::new(&before)),
            until: (m.at_share.clamp(0.0, 1.0) * scans as f64).round() as usize,
            kept: world.walls.len().saturating_sub(m.replaces_last),
        }
    }

    /// The caster for scan `k`, when it sees the world before the change.
    fn caster(&self, k: usize) -> Option<&RayCaster> {
        self.caster.as_ref().filter(|_| k < self.until)
    }

    /// Whether scan `k`'s hit is on a wall of the final world (a hit on a wall that was moved
    /// away is not).
    fn is_truth(&self, k: usize, hit: &crate::raycast::RayHit) -> bool {
        k >= self.until
            || !matches!(hit.obstacle, crate::raycast::Obstacle::Wall(i) if i >= self.kept)
    }
}

/// Assembles the run from its parts.
fn finish(
    world: &World,
    params: SimParams,
    seed: u64,
    scans: Vec<RangeScan>,
    true_poses: Vec<Pose2>,
    tally: WallTally,
) -> SimRun {
    let walls_seen = tally.seen(params.min_hits_seen);
    let walls = tally.walls().to_vec();
    let seen_wall_length_m = walls_seen.iter().map(|&i| walls[i].length()).sum();
    SimRun {
        world_name: world.name.clone(),
        seed,
        scans,
        true_poses,
        wall_hits: tally.hits().to_vec(),
        seen_wall_length_m,
        observed_wall_length_m: tally.observed_length_m(),
        walls,
        walls_seen,
        params,
    }
}
