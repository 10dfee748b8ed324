//! Mapping simulated worlds for the tracking checks: every K-th scan, with or
//! without the odometry prior, with or without faulty odometry; the verdicts, the poses as
//! tracked, the final poses, and how well the true geometry constrains each scan.
//!
//! Shared by the tests in `tracking.rs` and by `examples/tracking_table.rs`.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use polymap::config::Config;
use polymap::geometry::{Pose2, Segment, Vec2};
use polymap::mapper::Mapper;
use polymap::tracking::{MotionPrior, Tracking, TrackingSummary, Verdict};
use polymap_eval::trajectory::{AteAlignment, PosePair, absolute_trajectory_error};
use polymap_sim::odometry::OdometryFaults;
use polymap_sim::{SimRun, simulate, world_by_name};

/// The worlds the tracking checks run on: the three built for it, and two of the others.
pub const WORLDS: [&str; 5] = ["corridor", "ring", "hall360", "hallway45", "office"];

/// A simulated run of a built-in world with its own laser, seed 1; `faulty` adds
/// [`OdometryFaults::bad`] to the default odometry.
pub fn simulate_world(name: &str, faulty: bool) -> SimRun {
    let world = world_by_name(name).expect("a built-in world");
    let mut params = world.sim_params();
    if faulty {
        params.odometry.faults = OdometryFaults::bad();
    }
    simulate(&world, &params, 1)
}

/// The default configuration, or the one `polymap map --odometry` makes of it (the same two
/// settings as `config_file::effective_config`, which lives in the binary).
pub fn config(odometry: bool) -> Config {
    let mut config = Config::default();
    if odometry {
        config.mapper.motion_prior = MotionPrior::Odometry;
        config.mapper.icp_from_best_start_only = false;
    }
    config
}

/// One mapping run over the kept scans.
pub struct Mapped {
    /// Index in the log of each kept scan.
    pub kept: Vec<usize>,
    /// True poses of the kept scans, first-scan frame of the log.
    pub truth: Vec<Pose2>,
    /// Each kept scan's pose as tracked (the update's pose), map frame.
    pub tracked: Vec<Pose2>,
    /// Each kept scan's final pose (after loop closure), map frame.
    pub final_poses: Vec<Pose2>,
    /// Each kept scan's tracking outcome.
    pub tracking: Vec<Tracking>,
    /// Whether loop closure moved the map while the scan was mapped.
    pub corrected: Vec<bool>,
    /// The mapper's counts.
    pub summary: TrackingSummary,
    /// How often the scans saw through the map for each time they saw it
    /// ([`Mapper::seen_through_share`]).
    pub seen_through: Option<f64>,
    /// The share of the map drawn twice about walls that cross
    /// ([`Mapper::crossed_walls`]).
    pub crossed: Option<f64>,
    /// How often the run's scans, cast again at their final poses, saw through the finished
    /// map's walls ([`Mapper::walls_seen_through`]).
    pub walls_seen_through: Option<f64>,
    /// Wall-clock seconds of mapping.
    pub seconds: f64,
}

impl Mapped {
    /// Scans mapped per second.
    pub fn scans_per_s(&self) -> f64 {
        self.kept.len() as f64 / self.seconds.max(1e-9)
    }

    /// ATE RMSE of the final poses after SE(2) alignment, metres, over the kept scans in
    /// `range` (indices into `kept`).
    pub fn ate_m(&self, range: std::ops::Range<usize>) -> f64 {
        let pairs: Vec<PosePair> = range
            .map(|i| PosePair {
                stamp_s: i as f64,
                estimate: self.final_poses[i],
                truth: self.truth[i],
            })
            .collect();
        absolute_trajectory_error(&pairs, AteAlignment::LeastSquares)
            .map_or(f64::INFINITY, |a| a.position_m.rms)
    }

    /// ATE over every kept scan.
    pub fn ate_all_m(&self) -> f64 {
        self.ate_m(0..self.kept.len())
    }

    /// For each kept scan after the first, how far its tracked motion from the previous kept
    /// scan is from the true one (translation, in the previous scan's frame), metres.
    pub fn step_errors_m(&self) -> Vec<f64> {
        (1..self.kept.len())
            .map(|i| {
                let est = self.tracked[i - 1].between(&self.tracked[i]);
                let tru = self.truth[i - 1].between(&self.truth[i]);
                (est.translation() - tru.translation()).length()
            })
            .collect()
    }
}

/// ATE RMSE of the run's odometry alone (dead reckoning) after SE(2) alignment, metres.
pub fn odometry_ate_m(run: &SimRun) -> f64 {
    let pairs: Vec<PosePair> = run
        .odometry_poses()
        .into_iter()
        .zip(run.true_poses_in_first_frame())
        .enumerate()
        .map(|(i, (estimate, truth))| PosePair {
            stamp_s: i as f64,
            estimate,
            truth,
        })
        .collect();
    absolute_trajectory_error(&pairs, AteAlignment::LeastSquares)
        .map_or(f64::INFINITY, |a| a.position_m.rms)
}

/// Kept scans (indices into `kept`, after the first) whose tracked motion is more than
/// `jump_m` off the true one, leaving out those during which loop closure moved the map
/// (their tracked poses are in two frames).
pub fn jumps(mapped: &Mapped, jump_m: f64) -> Vec<usize> {
    mapped
        .step_errors_m()
        .iter()
        .enumerate()
        .map(|(i, &e)| (i + 1, e))
        // A correction reported with scan i - 1 moves the map after that scan's pose was
        // taken: the step to scan i spans it.
        .filter(|&(i, e)| e > jump_m && !mapped.corrected[i] && !mapped.corrected[i - 1])
        .map(|(i, _)| i)
        .collect()
}

/// A mapping run of a built-in world: which world, every how many scans, faulty odometry or
/// not, with the odometry prior or not.
pub type RunKey = (&'static str, usize, bool, bool);

/// Runs already mapped, shared by the tests (they run in parallel and ask for the same runs).
static MAPPED: Mutex<Option<HashMap<RunKey, Arc<Mapped>>>> = Mutex::new(None);

/// Maps every `every`-th scan (from the first) of world `name` (`faulty` odometry or not)
/// with the odometry prior or without, once per test binary.
pub fn mapped(name: &'static str, every: usize, faulty: bool, odometry: bool) -> Arc<Mapped> {
    let key = (name, every, faulty, odometry);
    let cached = |m: &Mutex<Option<HashMap<RunKey, Arc<Mapped>>>>| {
        let guard = m.lock().unwrap_or_else(|e| e.into_inner());
        guard.as_ref().and_then(|h| h.get(&key).cloned())
    };
    if let Some(m) = cached(&MAPPED) {
        return m;
    }
    let run = simulate_world(name, faulty);
    let m = Arc::new(map_every(&run, every, 0, config(odometry)));
    let mut guard = MAPPED.lock().unwrap_or_else(|e| e.into_inner());
    guard
        .get_or_insert_with(HashMap::new)
        .insert(key, m.clone());
    m
}

/// Kept scans `i` (indices into `kept`) that end a silent drift: the tracked motion from the
/// earliest kept scan within `span_m` of true travel before `i` is more than `drift_m` off
/// the true one, yet every scan after that one up to `i` is `ok` and no loop correction
/// happened. Catches errors that creep in by less than a jump per scan.
pub fn silent_drifts(mapped: &Mapped, span_m: f64, drift_m: f64) -> Vec<usize> {
    let travelled: Vec<f64> = std::iter::once(0.0)
        .chain(mapped.truth.windows(2).scan(0.0, |acc, w| {
            *acc += (w[1].translation() - w[0].translation()).length();
            Some(*acc)
        }))
        .collect();
    let quiet = |i: usize| mapped.tracking[i].verdict == Verdict::Ok && !mapped.corrected[i];
    (1..mapped.kept.len())
        .filter(|&i| {
            let j = (0..i)
                .find(|&j| travelled[i] - travelled[j] <= span_m)
                .unwrap_or(i - 1);
            let est = mapped.tracked[j].between(&mapped.tracked[i]);
            let tru = mapped.truth[j].between(&mapped.truth[i]);
            (est.translation() - tru.translation()).length() > drift_m && (j + 1..=i).all(quiet)
        })
        .collect()
}

/// Maps every `every`-th scan of `run` from `offset`.
pub fn map_every(run: &SimRun, every: usize, offset: usize, config: Config) -> Mapped {
    let truth_all = run.true_poses_in_first_frame();
    let kept: Vec<usize> = (offset..run.scans.len()).step_by(every.max(1)).collect();
    let mut mapper = Mapper::new(config);
    let clock = Instant::now();
    let updates: Vec<_> = kept.iter().map(|&k| mapper.push(&run.scans[k])).collect();
    mapper.finish().expect("loop closure does not fail");
    let seconds = clock.elapsed().as_secs_f64();
    Mapped {
        truth: kept.iter().map(|&k| truth_all[k]).collect(),
        tracked: updates.iter().map(|u| u.map_from_robot).collect(),
        final_poses: mapper.trajectory().to_vec(),
        tracking: updates.iter().map(|u| u.diagnostics.tracking).collect(),
        corrected: updates
            .iter()
            .map(|u| u.diagnostics.loops.optimized_nodes > 0)
            .collect(),
        summary: mapper.tracking_summary().clone(),
        seen_through: mapper.seen_through_share(),
        crossed: mapper.crossed_walls().map(|c| c.share),
        walls_seen_through: mapper.walls_seen_through().map(|w| w.share),
        seconds,
        kept,
    }
}

/// Points of a scan closer than this to a true wall count as hitting it, metres.
const ON_WALL_M: f64 = 0.05;

/// How well the true walls pin down each scan's position: the smaller eigenvalue of
/// `Σ n nᵀ` over the scan's returns, `n` the normal of the true wall each hits. About the
/// number of returns constraining the worst direction: 0 for two parallel walls.
pub fn position_information(run: &SimRun) -> Vec<f64> {
    let mut points = Vec::new();
    run.scans
        .iter()
        .zip(&run.true_poses)
        .map(|(scan, world_from_robot)| {
            points.clear();
            scan.points_in_robot(&mut points);
            let normals = points
                .iter()
                .filter_map(|&p| wall_normal(&run.walls, world_from_robot.transform_point(p)));
            smaller_eigenvalue(normals)
        })
        .collect()
}

/// Unit normal of the true wall nearest to `p`, if within [`ON_WALL_M`].
fn wall_normal(walls: &[Segment], p: Vec2) -> Option<Vec2> {
    let (d, w) = walls
        .iter()
        .map(|w| (w.distance_to_point(p), w))
        .min_by(|a, b| a.0.total_cmp(&b.0))?;
    (d < ON_WALL_M).then(|| (w.end - w.start).normalize_or_zero().perp())
}

/// Smaller eigenvalue of `Σ n nᵀ`.
fn smaller_eigenvalue(normals: impl Iterator<Item = Vec2>) -> f64 {
    let (mut a, mut b, mut c) = (0.0, 0.0, 0.0);
    for n in normals {
        a += n.x * n.x;
        b += n.x * n.y;
        c += n.y * n.y;
    }
    let mean = (a + c) / 2.0;
    mean - (((a - c) / 2.0).powi(2) + b * b).sqrt()
}
