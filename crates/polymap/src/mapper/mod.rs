//! The incremental mapper ([`Mapper`]): scans pushed one at a time into the global map `G_t`,
//! with the pose, tracking verdict and motion state carried from scan to scan.
//!
//! For each scan: points → segments (robot frame) → ICP against the map near the scan, started
//! from the motion prior → segments to the map frame → main directions of `G_{t-1}(tm)` →
//! vertex insertion, restrictive pairing, simplification against the map near the scan → `G_t`.
//! The first map `G_1` is the first scan.

use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::align::{AlignResult, GlobalSearch, align_points, thin_points};
use crate::config::Config;
use crate::directions::recent_main_directions;
use crate::extract::{extract_segments, extract_segments_closed};
use crate::geometry::{Pose2, Segment, Vec2};
use crate::loops::{Correction, LoopCloser, LoopDiagnostics, LoopFailure, MotionDoubt, SavedNode};
use crate::map::{GlobalMap, MapSegment, Observations};
pub use crate::merge::MergeDiagnostics;
use crate::merge::merge_scan;
use crate::observe::observe_scan;
use crate::polyline::group_polylines;
use crate::scan::RangeScan;
use crate::tracking::{
    LoosePoints, MotionPrior, OdometryWitness, Reason, RecentMotion, TrackConfig, TrackInput,
    Tracking, Verdict, better, track_scan, verdict,
};

/// What one scan did.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct ScanDiagnostics {
    /// Valid points in the scan.
    pub points: usize,
    /// Segments extracted from the scan.
    pub scan_segments: usize,
    /// The ICP outcome; `None` when there was no map to align to.
    pub align: Option<AlignResult>,
    /// Main directions used for merging, degrees in `[0, 180)`.
    pub main_directions_deg: Vec<f64>,
    /// Counts through the merge.
    pub merge: MergeDiagnostics,
    /// Segments in `G_t` after this scan.
    pub map_segments: usize,
    /// Wall-clock time of each stage for this scan, seconds.
    pub stage_s: StageSeconds,
    /// What loop closure did (all zero unless the scan completed a node).
    pub loops: LoopDiagnostics,
    /// The tracking verdict and how it was reached.
    pub tracking: Tracking,
    /// The scan follows a gap in the log: a time step at least 3 typical ones, in stamps that
    /// keep time (counted in [`TrackingSummary::gaps`]).
    #[serde(default)]
    pub after_gap: bool,
    /// The log's odometry contradicts the scan's tracked step (counted in
    /// [`TrackingSummary::off_odometry`], whatever the verdict).
    #[serde(default)]
    pub off_odometry: bool,
}

/// Wall-clock seconds spent in each stage of one [`Mapper::push`].
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct StageSeconds {
    /// Points and segment extraction.
    pub extract: f64,
    /// Motion prior, start selection and ICP.
    pub align: f64,
    /// Main directions of `G_{t-1}(tm)`.
    pub directions: f64,
    /// Vertex insertion, pairing, simplification and the map update.
    pub merge: f64,
    /// Loop closure: node bookkeeping, submap matching, graph optimisation and corrections.
    pub loops: f64,
}

impl std::ops::AddAssign for StageSeconds {
    fn add_assign(&mut self, o: StageSeconds) {
        self.extract += o.extract;
        self.align += o.align;
        self.directions += o.directions;
        self.merge += o.merge;
        self.loops += o.loops;
    }
}

/// The result of [`Mapper::push`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Update {
    /// Index of the scan, 0-based, in processing order.
    pub scan_index: u32,
    /// The estimated robot pose in the map frame.
    pub map_from_robot: Pose2,
    /// What happened.
    pub diagnostics: ScanDiagnostics,
}

/// A scan made ready for mapping by [`Mapper::prepare`]: what the mapper needs of it, computed
/// without the mapper's state, so that it may be done ahead (on another thread).
#[derive(Debug, Clone, PartialEq)]
pub struct PreparedScan {
    /// Valid returns within `extract.max_range_m`, robot frame, metres, in beam order.
    pub points_in_robot: Vec<Vec2>,
    /// Extracted segments, robot frame, metres.
    pub segments_in_robot: Vec<Segment>,
    /// The robot's odometry pose at scan time, odometry frame, if the log carries one.
    pub odom_from_robot: Option<Pose2>,
    /// The scan's stamp, seconds, when known (finite).
    pub stamp_s: Option<f64>,
    /// Wall-clock seconds the preparation took.
    pub extract_s: f64,
}

/// A map saved by an earlier run, for a run to start from ([`Mapper::on_map`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PriorMap {
    /// The map's segments, metres, in the map's frame.
    pub segments: Vec<MapSegment>,
    /// Scans mapped into it so far, over all its runs: the new run's scans are numbered on
    /// from here (their segments' `born_scan`), and nothing born before moves.
    pub scans: u32,
    /// Its loop-closure nodes ([`Mapper::loop_nodes`] of the run that made it), for loops
    /// between the old and the new parts; empty when not saved.
    pub nodes: Vec<SavedNode>,
    /// Each segment's observation record (`observations[i]` for `segments[i]`), when saved;
    /// without it the segments start as seen at their birth.
    pub observations: Option<Vec<Observations>>,
}

/// What a run does with its map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MapRole {
    /// Scans are merged into the map (mapping, or continuing a saved map).
    #[default]
    Build,
    /// The map stays as it is: scans are only localized in it. Internally the run tracks as
    /// [`MapRole::Build`] does, on a working copy of the map that its scans grow (and loops
    /// close in): measured, tracking on the saved walls alone was lost or weak where clutter
    /// hid them and followed wrong recoveries (relation error on the second half of Intel 0.151
    /// m against the working copy's 0.035 m; ACES 0.54 m against 0.21 m). The copy is never
    /// output: [`Mapper::segments`] and [`Mapper::polylines`] give the saved map.
    Localize,
}

/// How a run on a saved map places its first scan.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Placement {
    /// Placed: tracking goes on from the last pose (a new map starts placed at its origin).
    Placed,
    /// Not yet: a global search over the whole map and circle, scan after scan.
    Search,
    /// Not yet: a search near a pose the user gave.
    Near(Pose2),
}

/// The incremental geometric mapper.
#[derive(Debug, Clone)]
pub struct Mapper {
    config: Config,
    map: GlobalMap,
    /// Scans pushed in this run.
    scans: u32,
    /// Scans of the runs this map continues: this run's scan `i` is the map's scan
    /// `first_scan + i` (segments' `born_scan`).
    first_scan: u32,
    role: MapRole,
    /// The saved map of a localize run, as it was given (what the run outputs), with its
    /// observation records when it had them.
    saved: Option<(Vec<MapSegment>, Vec<Observations>)>,
    placement: Placement,
    /// The map's scan the loop closer's first node starts at (where this run placed itself).
    loop_base: u32,
    /// While a run on a saved map is not placed: its scans tracked on a map of their own...
    local: Option<Box<Mapper>>,
    /// ...and where the last searches put that map (`map_from_local`), with how many in a row
    /// agreed.
    agreement: Option<(Pose2, u32)>,
    /// ...and the saved map prepared for the global search.
    search: Option<Box<GlobalSearch>>,
    last_pose: Option<Pose2>,
    prev_pose: Option<Pose2>,
    /// The last observed motion (`mapper.keep_observed_velocity`).
    observed: ObservedSpeed,
    last_odom: Option<Pose2>,
    /// The last scan tracked `ok`: its index (the map's numbering), pose and stamp.
    last_ok: Option<(u32, Pose2, Option<f64>)>,
    /// The odometry pose of that scan (odometry frame), when it had one.
    last_ok_odom: Option<Pose2>,
    loops: LoopCloser,
    trajectory: Vec<Pose2>,
    loose: LoosePoints,
    recent: RecentMotion,
    lost_streak: u32,
    verdicts: TrackingSummary,
}

/// Verdict counts over a run, and the runs of consecutive lost scans.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TrackingSummary {
    /// Scans tracked confidently.
    pub ok: u32,
    /// Scans with a direction taken from the motion prior, a direction observed by few
    /// points, a poor fit or a rival pose.
    pub weak: u32,
    /// Of the `weak` scans, those weak only because a direction was observed by few points
    /// (`weakly_observed`): common along any corridor, also where tracking is accurate, so the
    /// run's warning does not count them.
    #[serde(default)]
    pub weakly_observed: u32,
    /// Scans with no confident match (they did not enter the map).
    pub lost: u32,
    /// Inclusive ranges `[first, last]` of consecutive lost scans (scan indices, 0-based).
    pub lost_ranges: Vec<[u32; 2]>,
    /// Scans that follow a gap in the log: a time step at least 3 typical ones, in stamps
    /// that keep time (scans are missing there; without odometry the motion across it is
    /// predicted over its time). Stamps that bunch or go back say nothing, and count none.
    #[serde(default)]
    pub gaps: u32,
    /// The first [`MAX_GAP_SCANS`] of them (scan indices, 0-based).
    #[serde(default)]
    pub gap_scans: Vec<u32>,
    /// Where the log has odometry: how far it says the robot went between consecutive scans
    /// both tracked `ok`, metres (summed step lengths)...
    #[serde(default)]
    pub odometry_travel_m: f64,
    /// ...and how far the tracked poses went between the same scans, metres. Odometry that
    /// reads under half or over twice the scans' travel is stuck, scaled or not this robot's
    /// (the benchmark logs: within 2 %).
    #[serde(default)]
    pub tracked_travel_m: f64,
    /// Without the odometry prior, while the log's odometry agrees with the scans
    /// ([`TrackingSummary::odometry_agrees_with_travel`]): the scans not lost whose tracked
    /// step lies more than `tracking.odometry_witness_m` from the odometry's and from its
    /// reverse ([`OdometryWitness`]), whatever their verdict (an `ok` one becomes `weak`,
    /// `off_odometry`); one slip of the odometry counts twice, the step to it and from it.
    /// Where sparse scans leave a corridor tracked short (`weakly_observed` scans, which do
    /// not raise the weak warning) these are the sign: the benchmark logs' runs of every 10th
    /// scan have 0.9–9.9 %, their dense runs none. A dense run shortening a corridor by a few
    /// millimetres per scan stays under the threshold at every step.
    #[serde(default)]
    pub off_odometry: u32,
    /// The first [`MAX_GAP_SCANS`] of them (scan indices, 0-based).
    #[serde(default)]
    pub off_odometry_scans: Vec<u32>,
    /// Runs of consecutive `weak` scans over which the robot went at least
    /// [`WEAK_STRETCH_M`], tracked or by the log's odometry (the larger): there the motion
    /// came from the motion prior or from few points for metres on end, and a corridor may
    /// come out short. Scattered weak scans, common along corridors also where tracking is
    /// accurate, make no such stretch.
    #[serde(default)]
    pub weak_stretches: Vec<WeakStretch>,
    /// The run of weak scans going on, with its tracked and odometry travel (metres).
    #[serde(skip)]
    open_weak: Option<(WeakStretch, f64, f64)>,
}

/// A run of consecutive `weak` scans ([`TrackingSummary::weak_stretches`]).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct WeakStretch {
    /// The first scan of the run (scan index, 0-based).
    pub first: u32,
    /// The last scan of the run (inclusive).
    pub last: u32,
    /// How far the robot went over the run, from the scan before it to its last scan: the
    /// tracked poses' travel or the log's odometry's, the larger, metres.
    pub travel_m: f64,
}

/// A run of consecutive weak scans over at least this travel is a weak stretch
/// ([`TrackingSummary::weak_stretches`]), metres. The benchmark logs' dense runs have none
/// (the longest: ACES 4.1 m, Intel 1.7 m, FR079 none), nor do their runs of every 3rd and 5th
/// scan (ACES 5.3-8.8 m, the others under 5 m), where tracking is accurate; the simulated
/// corridor, whose middle no feature observes along it, has two of 25 and 28 m (ATE 1.17 m),
/// and 14 of the 30 runs of every 10th scan have them, all broken (every ACES phase, FR079
/// phases 4, 6 and 8, Intel phase 9).
pub const WEAK_STRETCH_M: f64 = 10.0;

/// At most this many gap scans are listed in [`TrackingSummary::gap_scans`] (all are counted),
/// and as many in [`TrackingSummary::off_odometry_scans`].
pub const MAX_GAP_SCANS: usize = 100;

/// Tracked travel below which the log's odometry is not judged against the scans, metres: a
/// few scans of a robot that hardly moved say nothing of its odometry.
pub const ODOMETRY_CHECK_MIN_TRAVEL_M: f64 = 5.0;

/// The log's odometry witnesses the steps ([`OdometryWitness`]) while its travel between
/// consecutive `ok` scans is within this factor of the scans' either way (the benchmark logs:
/// within 2 %; a wheel 10 % too small still witnesses).
pub const ODOMETRY_WITNESS_WITHIN: f64 = 1.25;

impl TrackingSummary {
    /// Counts the lost scans `first..=last` (one lost range) as weak instead.
    fn relabel_lost_as_weak(&mut self, first: u32, last: u32) {
        let n = last - first + 1;
        if let Some(i) = self.lost_ranges.iter().position(|r| *r == [first, last]) {
            self.lost_ranges.remove(i);
            self.lost -= n;
            self.weak += n;
        }
    }

    /// Counts scan `t` as following a gap in the log.
    fn count_gap(&mut self, t: u32) {
        self.gaps += 1;
        if self.gap_scans.len() < MAX_GAP_SCANS {
            self.gap_scans.push(t);
        }
    }

    /// Adds the step between two consecutive scans tracked `ok`: `odometry_m` as the log's
    /// odometry reads it, `tracked_m` as tracked.
    fn count_travel(&mut self, odometry_m: f64, tracked_m: f64) {
        if odometry_m.is_finite() && tracked_m.is_finite() {
            self.odometry_travel_m += odometry_m;
            self.tracked_travel_m += tracked_m;
        }
    }

    /// Whether the log's odometry travelled under half or over twice what the scans did, over
    /// at least `min_travel_m` of tracked travel: odometry that is stuck, scaled or not the
    /// robot's (see [`TrackingSummary::tracked_travel_m`]).
    pub fn odometry_disagrees_with_travel(&self, min_travel_m: f64) -> bool {
        self.odometry_within(min_travel_m, 2.0) == Some(false)
    }

    /// Whether the log's odometry travelled within [`ODOMETRY_WITNESS_WITHIN`] of what the
    /// scans did (see [`TrackingSummary::odometry_travel_m`]), over at least `min_travel_m` of
    /// tracked travel: odometry fit to witness the steps.
    pub fn odometry_agrees_with_travel(&self, min_travel_m: f64) -> bool {
        self.odometry_within(min_travel_m, ODOMETRY_WITNESS_WITHIN) == Some(true)
    }

    /// Over at least `min_travel_m` of tracked travel, whether the odometry's travel lies
    /// within `factor` of the scans' either way; `None` below it.
    fn odometry_within(&self, min_travel_m: f64, factor: f64) -> Option<bool> {
        let (odo, scans) = (self.odometry_travel_m, self.tracked_travel_m);
        (scans >= min_travel_m).then(|| odo >= scans / factor && odo <= scans * factor)
    }

    /// Takes the step to scan `t` into the run of weak scans: `weak` extends it (by
    /// `tracked_m`, and `odometry_m` where the log has odometry, metres), anything else ends
    /// it; a run that reaches [`WEAK_STRETCH_M`] is listed, and updated while it goes on.
    fn count_weak_step(&mut self, t: u32, weak: bool, tracked_m: f64, odometry_m: Option<f64>) {
        if !weak {
            self.open_weak = None;
            return;
        }
        let finite = |m: f64| if m.is_finite() { m } else { 0.0 };
        let (mut run, mut tracked, mut odometry) = self.open_weak.take().unwrap_or((
            WeakStretch {
                first: t,
                last: t,
                travel_m: 0.0,
            },
            0.0,
            0.0,
        ));
        tracked += finite(tracked_m);
        odometry += odometry_m.map_or(0.0, finite);
        run.last = t;
        run.travel_m = tracked.max(odometry);
        if run.travel_m >= WEAK_STRETCH_M {
            match self.weak_stretches.last_mut() {
                Some(listed) if listed.first == run.first => *listed = run,
                _ => self.weak_stretches.push(run),
            }
        }
        self.open_weak = Some((run, tracked, odometry));
    }

    /// Counts scan `t` as tracked off the log's odometry.
    fn count_off_odometry(&mut self, t: u32) {
        self.off_odometry += 1;
        if self.off_odometry_scans.len() < MAX_GAP_SCANS {
            self.off_odometry_scans.push(t);
        }
    }

    fn count(&mut self, t: u32, verdict: Verdict, reason: Reason) {
        match verdict {
            Verdict::Ok => self.ok += 1,
            Verdict::Weak => {
                self.weak += 1;
                self.weakly_observed += u32::from(reason == Reason::WeaklyObserved);
            }
            Verdict::Lost => {
                self.lost += 1;
                match self.lost_ranges.last_mut() {
                    Some(r) if r[1] + 1 == t => r[1] = t,
                    _ => self.lost_ranges.push([t, t]),
                }
            }
        }
    }
}

impl Mapper {
    /// A mapper with an empty map.
    pub fn new(config: Config) -> Self {
        let reach_m = config.align.initial_gate_m.max(config.align.final_gate_m);
        Mapper {
            map: GlobalMap::new(config.map.grid_cell_m, reach_m),
            scans: 0,
            first_scan: 0,
            role: MapRole::Build,
            saved: None,
            placement: Placement::Placed,
            loop_base: 0,
            local: None,
            agreement: None,
            search: None,
            last_pose: None,
            prev_pose: None,
            observed: ObservedSpeed::default(),
            last_odom: None,
            last_ok: None,
            last_ok_odom: None,
            loops: LoopCloser::new(
                config.loops.clone(),
                config.align.clone(),
                config.map.grid_cell_m,
            ),
            trajectory: Vec::new(),
            loose: LoosePoints::default(),
            recent: RecentMotion::default(),
            lost_streak: 0,
            verdicts: TrackingSummary::default(),
            config,
        }
    }

    /// A mapper that starts from a saved map: with [`MapRole::Build`] it goes on mapping (the
    /// map grows, loops close among the new scans, old segments merge with new ones but never
    /// move otherwise); with [`MapRole::Localize`] the map it gives stays as it was and scans
    /// are only placed in it. The first scan is placed by a global search over the whole map (or near
    /// `start`, map frame, when given); until one is placed confidently every scan is lost
    /// ([`Reason::NotFound`] or [`Reason::Ambiguous`]) and the search runs again on the next.
    /// An empty prior map is a new map.
    pub fn on_map(config: Config, prior: PriorMap, role: MapRole, start: Option<Pose2>) -> Self {
        let mut mapper = Mapper::new(config);
        let c = &mapper.config;
        mapper.loops = LoopCloser::continuing(
            c.loops.clone(),
            c.align.clone(),
            c.map.grid_cell_m,
            prior.nodes,
        );
        let observations = prior
            .observations
            .filter(|o| o.len() == prior.segments.len());
        if role == MapRole::Localize {
            let given = observations.clone().unwrap_or_default();
            mapper.saved = Some((prior.segments.clone(), given));
        }
        match observations {
            Some(observations) => {
                for (s, o) in prior.segments.into_iter().zip(observations) {
                    mapper.map.insert_observed(s, o);
                }
            }
            None => {
                for s in prior.segments {
                    mapper.map.insert(s);
                }
            }
        }
        mapper.first_scan = prior.scans;
        mapper.loop_base = prior.scans;
        mapper.role = role;
        if !mapper.map.is_empty() {
            mapper.placement = match start {
                Some(pose) => Placement::Near(pose),
                None => Placement::Search,
            };
        }
        mapper
    }

    /// The loop-closure nodes to save with the map, for a run that continues it (see
    /// [`PriorMap::nodes`]): a saved map's and this run's, at their corrected poses. Call after
    /// [`Mapper::finish`].
    pub fn loop_nodes(&self) -> Vec<SavedNode> {
        self.loops.saved_nodes()
    }

    /// Whether the run has placed itself in its map (always, for a new map).
    pub fn placed(&self) -> bool {
        self.placement == Placement::Placed
    }

    /// What the run does with its map.
    pub fn role(&self) -> MapRole {
        self.role
    }

    /// The map's index of this run's first scan: scans of the runs before (0 for a new map).
    pub fn first_scan(&self) -> u32 {
        self.first_scan
    }

    /// The configuration in use.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The current global map `G_t` (in a localize run, the working copy: see
    /// [`MapRole::Localize`]).
    pub fn map(&self) -> &GlobalMap {
        &self.map
    }

    /// The map's segments in a stable order (by handle); in a localize run, the saved map's
    /// segments as given.
    pub fn segments(&self) -> Vec<MapSegment> {
        match &self.saved {
            Some((saved, _)) => saved.clone(),
            None => self.map.iter().map(|(_, s)| *s).collect(),
        }
    }

    /// The map's generalized polylines: indices into [`Mapper::segments`].
    pub fn polylines(&self) -> Vec<Vec<usize>> {
        let segs: Vec<Segment> = self.segments().iter().map(|s| s.segment).collect();
        group_polylines(&segs, self.config.polyline.max_gap_m)
    }

    /// The pose of every scan pushed so far (map frame), with every loop closure's correction
    /// applied: the best estimate, which may differ from the poses [`Mapper::push`] returned.
    pub fn trajectory(&self) -> &[Pose2] {
        &self.trajectory
    }

    /// Takes in every outcome of loop closure still pending (see [`crate::loops`]); call it
    /// after the last scan, before reading [`Mapper::trajectory`] and the map for good. Pushing
    /// more scans afterwards is fine.
    ///
    /// # Errors
    ///
    /// When loop closure failed during the run (a panic on its thread: a bug), with the node
    /// it failed on; the map and trajectory are then those of mapping without loop closure
    /// from there on.
    pub fn finish(&mut self) -> Result<LoopDiagnostics, LoopFailure> {
        let mut diagnostics = LoopDiagnostics::default();
        if let Some(c) = self.loops.finish(&mut diagnostics) {
            self.apply_correction(&c);
        }
        match self.loops.failure() {
            Some(failure) => Err(failure.clone()),
            None => Ok(diagnostics),
        }
    }

    /// Tracking verdict counts so far, with the ranges of lost scans.
    pub fn tracking_summary(&self) -> &TrackingSummary {
        &self.verdicts
    }

    /// Loop edges accepted so far.
    pub fn loop_closures(&self) -> usize {
        self.loops.loop_edges()
    }

    /// Number of scans pushed so far.
    pub fn scans(&self) -> u32 {
        self.scans
    }

    /// Integrates one scan; afterwards [`Mapper::map`] is `G_t`. The same as
    /// [`Mapper::prepare`] followed by [`Mapper::push_prepared`].
    pub fn push(&mut self, scan: &RangeScan) -> Update {
        let prepared = Self::prepare(&self.config, scan);
        self.push_prepared(prepared)
    }

    /// The stateless first stage of a push: the scan's valid points and its segments (robot
    /// frame) under `config` (the mapper's own, for the result to be the same as [`Mapper::push`]).
    pub fn prepare(config: &Config, scan: &RangeScan) -> PreparedScan {
        let clock = Instant::now();
        let mut points = Vec::new();
        scan.points_in_robot(&mut points);
        let mut prepared = Self::prepare_points(
            config,
            points,
            scan.angle_increment_rad,
            scan.is_full_circle(),
            scan.odom_from_robot,
            scan.stamp.seconds,
        );
        prepared.extract_s = clock.elapsed().as_secs_f64();
        prepared
    }

    /// [`Mapper::prepare`] for a scan already converted to points: `points_in_robot` are its
    /// valid returns in beam order (robot frame, metres, as [`RangeScan::points_in_robot`]
    /// gives them), `angle_increment_rad` its beam step, `closed` whether the scan goes all the
    /// way round ([`RangeScan::is_full_circle`]: its last point neighbours its first),
    /// `stamp_s` its stamp in seconds (kept when finite). For callers that keep the points for
    /// something else too, so the ranges are converted once.
    pub fn prepare_points(
        config: &Config,
        mut points_in_robot: Vec<Vec2>,
        angle_increment_rad: f64,
        closed: bool,
        odom_from_robot: Option<Pose2>,
        stamp_s: f64,
    ) -> PreparedScan {
        let clock = Instant::now();
        let max_range_2 = config.extract.max_range_m.powi(2);
        points_in_robot.retain(|p| p.length_squared() <= max_range_2);
        // A 360° scan is one closed curve: extraction must not cut it at the seam.
        let extract = match closed {
            true => extract_segments_closed,
            false => extract_segments,
        };
        let segments = extract(&points_in_robot, angle_increment_rad, &config.extract)
            .iter()
            .map(|e| e.segment)
            .collect();
        PreparedScan {
            points_in_robot,
            segments_in_robot: segments,
            odom_from_robot,
            stamp_s: Some(stamp_s).filter(|s| s.is_finite()),
            extract_s: clock.elapsed().as_secs_f64(),
        }
    }

    /// Integrates one prepared scan; afterwards [`Mapper::map`] is `G_t`.
    pub fn push_prepared(&mut self, scan: PreparedScan) -> Update {
        let i = self.scans;
        let t = self.first_scan.saturating_add(i);
        let clock = Instant::now();
        let (guess, anchor, unobserved_to) = self.guess(scan.odom_from_robot, scan.stamp_s);
        let placing = self.placement != Placement::Placed;
        let witness = self.odometry_witness(scan.odom_from_robot);
        let (align, tracking) = match placing {
            true => self.place(&scan),
            false => self.align(&scan, guess, anchor, unobserved_to, witness),
        };
        // A scan with nothing to align (no valid points) is no evidence of motion: the anchor,
        // like a scan with too few correspondences; the very first scan starts the map frame.
        // A lost scan keeps its (poor) fit, the best guess there is, but stays out of the map.
        let fallback = match self.placement {
            Placement::Near(start) => start,
            _ if self.map.is_empty() || placing => guess,
            _ => anchor,
        };
        let pose = align.map_or(fallback, |a| a.map_from_robot);
        let lost = tracking.verdict == Verdict::Lost;
        // A run on a saved map is placed by its first confident match, or where the user said
        // it starts; until then nothing of it is tracked from, merged or closed into loops.
        if placing && (!lost || matches!(self.placement, Placement::Near(_))) {
            self.placement = Placement::Placed;
            self.loop_base = t;
            self.place_earlier_scans(&pose, lost);
        }
        let placed = self.placement == Placement::Placed;
        let mut after_gap = false;
        let mut off_odometry = false;
        if placed {
            // Observed: tracked `ok` (or only `slowed`, see `Tracking::carries_tracking`) with
            // every direction observed; a motion between two observed scans is evidence of the
            // robot's speed.
            let observed =
                tracking.carries_tracking() && align.is_some_and(|a| a.weak_directions == 0);
            if let Some(last) = self.last_pose {
                self.recent.push(&last, &pose);
            }
            let step = self.last_pose.map(|last| last.between(&pose));
            self.observed
                .record(step, observed && !tracking.corner_won, scan.stamp_s);
            after_gap = self.observed.last_gap_scale() > 1.0;
            if after_gap {
                self.verdicts.count_gap(i);
            }
            let off = self.config.tracking.odometry_witness_m;
            off_odometry = !lost && witness.is_some_and(|w| w.contradicts(&pose, off));
            if off_odometry {
                self.verdicts.count_off_odometry(i);
            }
            // The step's length as tracked and as the log's odometry read it, metres.
            let tracked_m = self
                .last_pose
                .map(|last| last.between(&pose).translation().length());
            let odometry_m = self
                .last_odom
                .zip(scan.odom_from_robot)
                .map(|(a, b)| a.between(&b).translation().length());
            // The log's odometry against the scans, between consecutive `ok` scans.
            let ok = tracking.carries_tracking();
            let last_was_ok = self
                .last_ok
                .is_some_and(|(k, _, _)| k.saturating_add(1) == t);
            if let (true, Some(tracked_m), Some(odometry_m)) =
                (ok && last_was_ok, tracked_m, odometry_m)
            {
                self.verdicts.count_travel(odometry_m, tracked_m);
            }
            let weak = tracking.verdict == Verdict::Weak;
            self.verdicts
                .count_weak_step(i, weak, tracked_m.unwrap_or(0.0), odometry_m);
            self.prev_pose = self.last_pose.replace(pose);
            self.last_odom = scan.odom_from_robot;
            if tracking.carries_tracking() {
                self.last_ok = Some((t, pose, scan.stamp_s));
                self.last_ok_odom = scan.odom_from_robot;
            }
        }
        self.verdicts.count(i, tracking.verdict, tracking.reason);
        self.lost_streak = if lost { self.lost_streak + 1 } else { 0 };
        // A scan trusted too little to merge neither explains later searches (loose points)
        // nor observes the map (see-through counts prune walls).
        let enters = tracking.enters_map(self.config.tracking.merge_doubtful_scans);
        if enters {
            let spacing = self.config.tracking.loose_point_spacing_m;
            let loose = thin_points(&scan.points_in_robot, spacing)
                .into_iter()
                .map(|p| pose.transform_point(p))
                .collect();
            self.loose
                .push(loose, self.config.tracking.loose_point_scans);
        }
        let aligned = Instant::now();
        // Segments of a lost scan stay out of the map until tracking finds it again; those of
        // a scan that fits poorly or as well elsewhere would be where the scan is likeliest,
        // which is not where it is sure to be: one wrong scan in the map misleads the next.
        // Only a scan tracked `ok` (or only `slowed`) adds to the support that holds a wall in
        // place: a `weak` scan's pose may have slid along a wall it sees, and its sightings
        // would anchor what it placed there.
        let confirmed = tracking.carries_tracking();
        let scan_in_map: Vec<Segment> = if !enters {
            Vec::new()
        } else {
            scan.segments_in_robot
                .iter()
                .map(|s| s.transformed(&pose))
                .collect()
        };
        // A fixed map has nothing to merge into: no directions either.
        let directions =
            recent_main_directions(&mut self.map, t, &self.config.directions).directions_rad;
        let directed = Instant::now();
        let merge = merge_scan(
            &self.config.merge,
            &mut self.map,
            &scan_in_map,
            &directions,
            t,
            confirmed,
        )
        .diagnostics;
        if enters {
            observe_scan(
                &mut self.map,
                &scan.points_in_robot,
                &pose,
                t,
                confirmed,
                &self.config.observe,
            );
        }
        let merged = Instant::now();
        self.scans += 1;
        self.trajectory.push(pose);
        let mut loops = LoopDiagnostics::default();
        if self.config.loops.enabled && placed {
            let correction = self.loops.add_scan(
                t - self.loop_base,
                pose,
                (&scan.points_in_robot, &scan.segments_in_robot),
                motion_doubt(&tracking),
                &mut loops,
            );
            if let Some(c) = correction {
                self.apply_correction(&c);
            }
        }
        let closed = Instant::now();
        let diagnostics = ScanDiagnostics {
            points: scan.points_in_robot.len(),
            scan_segments: scan.segments_in_robot.len(),
            align,
            main_directions_deg: directions.iter().map(|d| d.to_degrees()).collect(),
            merge,
            map_segments: self.map.len(),
            stage_s: StageSeconds {
                extract: scan.extract_s,
                align: (aligned - clock).as_secs_f64(),
                directions: (directed - aligned).as_secs_f64(),
                merge: (merged - directed).as_secs_f64(),
                loops: (closed - merged).as_secs_f64(),
            },
            loops,
            tracking,
            after_gap,
            off_odometry,
        };
        Update {
            scan_index: i,
            map_from_robot: pose,
            diagnostics,
        }
    }

    /// Moves every map segment, scan pose and the motion state by the correction of the node
    /// it was born in (segments merged later than their node's end move with the node of
    /// their last merge).
    fn apply_correction(&mut self, c: &Correction) {
        let Some(last) = c.new_from_old.last().copied() else {
            return;
        };
        // Node 0 starts at the map's scan `loop_base` (0 for a new map): segments born before
        // it (an earlier run's) never move.
        let base = self.loop_base;
        let first_new = self.loops.first_new_node();
        let start = self.loops.node_start(c.first_node.max(first_new));
        let first_scan = (base as u64 + start as u64).min(u32::MAX as u64) as u32;
        let delta = |t: u32| {
            let n = self.loops.node_of(t.saturating_sub(base));
            n.checked_sub(c.first_node)
                .and_then(|i| c.new_from_old.get(i).copied())
                .unwrap_or(last)
        };
        // Segments that move less than this stay (re-indexing is the costly part).
        const STAY_M: f64 = 5e-4;
        let moved: Vec<_> = self
            .map
            .iter()
            .filter(|(_, s)| s.born_scan >= first_scan)
            .filter_map(|(id, s)| {
                let d = delta(s.born_scan);
                let segment = s.segment.transformed(&d);
                let far = segment.start.distance_squared(s.segment.start) > STAY_M * STAY_M
                    || segment.end.distance_squared(s.segment.end) > STAY_M * STAY_M;
                far.then_some((id, segment))
            })
            .collect();
        self.map.move_segments(&moved);
        let run_first = self.first_scan;
        for (i, pose) in self
            .trajectory
            .iter_mut()
            .enumerate()
            .skip(first_scan.saturating_sub(run_first) as usize)
        {
            *pose = delta(run_first.saturating_add(i as u32)).compose(pose);
        }
        let t = (run_first + self.scans).saturating_sub(1);
        self.last_pose = self.last_pose.map(|p| delta(t).compose(&p));
        self.prev_pose = self
            .prev_pose
            .map(|p| delta(t.saturating_sub(1)).compose(&p));
        // A pose older than the first node the correction moves stays (`delta` would give it
        // the newest node's correction).
        self.last_ok = self.last_ok.map(|(i, p, stamp)| match i >= first_scan {
            true => (i, delta(i).compose(&p), stamp),
            false => (i, p, stamp),
        });
    }
}

mod observed;
mod placement;
#[cfg(test)]
mod tests;
mod tracking;
use tracking::ObservedSpeed;

/// The doubt on a scan's motion for the pose graph: along the direction ICP could not observe
/// when the scan is `weak` for it (`degenerate`: the motion along it came from the prior),
/// else none. (Doubting `weakly_observed` scans too, or poor, ambiguous and lost fits in every
/// direction, let wrong loop edges bend Intel: `docs/decisions/2026-11-21-loop-closure.md`.)
fn motion_doubt(tracking: &Tracking) -> MotionDoubt {
    match (
        tracking.verdict,
        tracking.reason,
        tracking.weak_direction_deg,
    ) {
        (Verdict::Weak, Reason::Degenerate, Some(deg)) => {
            let (s, c) = deg.to_radians().sin_cos();
            MotionDoubt::Along(Vec2::new(c, s))
        }
        _ => MotionDoubt::None,
    }
}
