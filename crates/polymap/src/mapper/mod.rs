//! The incremental mapper: owns `G_t` and the motion state between scans.
//!
//! For each scan: points → segments (robot frame) → ICP against the map near the scan, started
//! from the motion prior → segments to the map frame → main directions of `G_{t-1}(tm)` →
//! vertex insertion, restrictive pairing, simplification against the map near the scan → `G_t`.
//! The first map `G_1` is the first scan.

use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::align::{
    AlignMethod, AlignParams, AlignResult, GlobalSearch, LoosePoints, Reason, RecentMotion,
    SearchWindow, Tracking, Verdict, WindowMatch, align_endpoints, align_points, fit_score,
    fit_score_above, rotation_search, score_sample, search_window, should_search, thin_points,
    verdict, window_search,
};
use crate::config::Config;
use crate::directions::recent_main_directions;
use crate::extract::{extract_segments, extract_segments_closed};
use crate::geometry::{Pose2, Segment, Vec2, normalize_angle_rad};
use crate::loops::{Correction, LoopCloser, LoopDiagnostics, LoopFailure, SavedNode};
use crate::map::{GlobalMap, MapSegment, Observations};
pub use crate::merge::MergeDiagnostics;
use crate::merge::merge_scan;
pub use crate::motion::{MapperParams, MotionPrior};
use crate::observe::observe_scan;
use crate::polyline::group_polylines;
use crate::scan::RangeScan;

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

/// A start given by the user is searched within this distance (each axis), metres...
const NEAR_START_M: f64 = 1.0;
/// ...and this angle, degrees.
const NEAR_START_DEG: f64 = 30.0;
/// Distinct peaks of a global search refined by ICP: the raster's best is not always ICP's.
const PLACE_PEAKS: usize = 5;
/// A search without a start given places the run when this many searches in a row agree.
const PLACE_AGREEMENT: u32 = 3;
/// The unplaced scans' own map is sampled every this many metres for the global search...
const PLACE_POINT_SPACING_M: f64 = 0.1;
/// ...which searches with its points up to this far from the robot, metres (ICP then verifies
/// each peak with all of them). Farther points need a finer rotation step (the search's cost:
/// about 1 s per scan on Intel's map); with 8 m instead, the second half of Intel placed
/// itself 3 searches in a row at one wrong place.
const PLACE_RANGE_M: f64 = 15.0;

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
    last_odom: Option<Pose2>,
    loops: LoopCloser,
    trajectory: Vec<Pose2>,
    loose: LoosePoints,
    recent: RecentMotion,
    lost_streak: u32,
    verdicts: TrackingSummary,
}

/// Verdict counts over a run, and the runs of consecutive lost scans.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct TrackingSummary {
    /// Scans tracked confidently.
    pub ok: u32,
    /// Scans with a direction taken from the motion prior.
    pub weak: u32,
    /// Scans with no confident match (they did not enter the map).
    pub lost: u32,
    /// Inclusive ranges `[first, last]` of consecutive lost scans (scan indices, 0-based).
    pub lost_ranges: Vec<[u32; 2]>,
}

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

    fn count(&mut self, t: u32, verdict: Verdict) {
        match verdict {
            Verdict::Ok => self.ok += 1,
            Verdict::Weak => self.weak += 1,
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
            last_odom: None,
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
        );
        prepared.extract_s = clock.elapsed().as_secs_f64();
        prepared
    }

    /// [`Mapper::prepare`] for a scan already converted to points: `points_in_robot` are its
    /// valid returns in beam order (robot frame, metres, as [`RangeScan::points_in_robot`]
    /// gives them), `angle_increment_rad` its beam step, `closed` whether the scan goes all the
    /// way round ([`RangeScan::is_full_circle`]: its last point neighbours its first). For
    /// callers that keep the points for something else too, so the ranges are converted once.
    pub fn prepare_points(
        config: &Config,
        mut points_in_robot: Vec<Vec2>,
        angle_increment_rad: f64,
        closed: bool,
        odom_from_robot: Option<Pose2>,
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
            extract_s: clock.elapsed().as_secs_f64(),
        }
    }

    /// Integrates one prepared scan; afterwards [`Mapper::map`] is `G_t`.
    pub fn push_prepared(&mut self, scan: PreparedScan) -> Update {
        let i = self.scans;
        let t = self.first_scan.saturating_add(i);
        let clock = Instant::now();
        let (guess, anchor) = self.guess(scan.odom_from_robot);
        let placing = self.placement != Placement::Placed;
        let (align, tracking) = match placing {
            true => self.place(&scan),
            false => self.align(&scan, guess, anchor),
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
        if placed {
            if let Some(last) = self.last_pose {
                self.recent.push(&last, &pose);
            }
            self.prev_pose = self.last_pose.replace(pose);
            self.last_odom = scan.odom_from_robot;
        }
        self.verdicts.count(i, tracking.verdict);
        self.lost_streak = if lost { self.lost_streak + 1 } else { 0 };
        if !lost {
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
        let doubtful = matches!(tracking.reason, Reason::PoorFit | Reason::Ambiguous)
            && !self.config.tracking.merge_doubtful_scans;
        let scan_in_map: Vec<Segment> = if lost || doubtful {
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
        )
        .diagnostics;
        if !lost {
            observe_scan(
                &mut self.map,
                &scan.points_in_robot,
                &pose,
                t,
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
                &scan.points_in_robot,
                &scan.segments_in_robot,
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
        };
        Update {
            scan_index: i,
            map_from_robot: pose,
            diagnostics,
        }
    }

    /// Once placed at `pose`, the scans before (tracked on their own map) are placed too: their
    /// poses move into the map's frame and their verdicts turn from lost to weak (placed after
    /// the fact; their segments stay out of the map). Not when the placement itself is lost
    /// (a start the user gave that the scans do not confirm).
    fn place_earlier_scans(&mut self, pose: &Pose2, lost: bool) {
        self.search = None;
        self.agreement = None;
        let Some(local) = self.local.take() else {
            return;
        };
        let Some((last, earlier)) = local.trajectory().split_last() else {
            return;
        };
        if lost || earlier.is_empty() {
            return;
        }
        let map_from_local = pose.compose(&last.inverse());
        let first = self.trajectory.len() - earlier.len();
        for (k, p) in earlier.iter().enumerate() {
            self.trajectory[first + k] = map_from_local.compose(p);
        }
        self.verdicts
            .relabel_lost_as_weak(first as u32, (first + earlier.len() - 1) as u32);
    }

    /// Places a scan of a run on a saved map: ICP from the best few peaks of a global search
    /// (or of a search near the user's start), the best fit kept. The verdict is lost unless
    /// the fit is confident in every direction and no distinct pose explains the scan about as
    /// well ([`crate::align::TrackParams::ambiguous_above`] of its inliers).
    fn place(&mut self, scan: &PreparedScan) -> (Option<AlignResult>, Tracking) {
        let params = self.config.tracking.clone();
        // The scans not yet placed are tracked among themselves, on a map of their own: it is
        // seen from more places than one scan, which tells apart places one scan cannot (two
        // alike rooms, a symmetric ring), and once placed it places them all.
        let mut local_config = self.config.clone();
        local_config.loops.enabled = false;
        let local = self
            .local
            .get_or_insert_with(|| Box::new(Mapper::new(local_config)));
        let local_pose = local.push_prepared(scan.clone()).map_from_robot;
        let robot_from_local = local_pose.inverse();
        let mut points: Vec<Vec2> = local
            .map()
            .iter()
            .flat_map(|(_, s)| points_along(&s.segment, PLACE_POINT_SPACING_M))
            .map(|p| robot_from_local.transform_point(p))
            .collect();
        if points.is_empty() {
            points = thin_points(&scan.points_in_robot, self.config.align.point_spacing_m);
        }
        let hint = match self.placement {
            Placement::Near(start) => Some((start, NEAR_START_M, NEAR_START_DEG.to_radians())),
            _ => None,
        };
        if self.search.is_none() {
            self.search = GlobalSearch::new(&self.map, &params).map(Box::new);
        }
        let range_m = PLACE_RANGE_M;
        let peaks = match &self.search {
            Some(search) => search.peaks(&points, hint, PLACE_PEAKS, range_m, &params),
            None => Vec::new(),
        };
        let align = &self.config.align;
        let results: Vec<AlignResult> = peaks
            .iter()
            .map(|c| {
                align_points(
                    &points,
                    &self.map,
                    c.map_from_robot,
                    c.map_from_robot,
                    align,
                )
            })
            .collect();
        let Some(best) = results
            .iter()
            .copied()
            .reduce(|best, r| if better(&r, &best) { r } else { best })
        else {
            let reason = match points.is_empty() {
                true => Reason::NoPoints,
                false => Reason::NotFound,
            };
            let tracking = Tracking {
                verdict: Verdict::Lost,
                reason,
                searched: true,
                ..Tracking::default()
            };
            return (None, tracking);
        };
        let apart = |r: &AlignResult| apart_by(&best.map_from_robot, &r.map_from_robot, &params);
        let rival = results.iter().filter(|r| apart(r)).map(|r| r.inliers).max();
        let mut tracking = verdict(Some(&best), points.len(), false, &params);
        tracking.searched = true;
        tracking.search_won = true;
        if rival.is_some_and(|n| n as f64 >= params.ambiguous_above * best.inliers as f64) {
            tracking.verdict = Verdict::Lost;
            tracking.reason = Reason::Ambiguous;
        } else if tracking.verdict != Verdict::Ok {
            tracking.verdict = Verdict::Lost;
            tracking.reason = Reason::NotFound;
        }
        // One scan may fit a wrong place better than its own (a scan close to a wall sees
        // little: on Intel one fitted 80 % of its points 9 m and 90° off, 65 % at its true
        // place): a search without a start given must place the scans' own map the same way
        // `PLACE_AGREEMENT` times in a row.
        if self.placement == Placement::Search {
            let agreed = match tracking.verdict {
                Verdict::Ok => {
                    let map_from_local = best.map_from_robot.compose(&robot_from_local);
                    let n = match self.agreement {
                        Some((m, n)) if !apart_by(&m, &map_from_local, &params) => n + 1,
                        _ => 1,
                    };
                    self.agreement = Some((map_from_local, n));
                    n
                }
                _ => {
                    self.agreement = None;
                    0
                }
            };
            if tracking.verdict == Verdict::Ok && agreed < PLACE_AGREEMENT {
                tracking.verdict = Verdict::Lost;
                tracking.reason = Reason::NotFound;
            }
        }
        (Some(best), tracking)
    }

    /// ICP from the best pose (and its rival, if any) of a window search over the whole circle
    /// within [`RECOVER_TRANSLATION_M`] of the anchor; the result with the most inliers.
    /// `None` when there is no map near.
    fn recover(
        &self,
        points: &[Vec2],
        anchor: Pose2,
        run: &impl Fn(Pose2) -> AlignResult,
    ) -> Option<AlignResult> {
        let window = SearchWindow {
            center: anchor,
            half_xy_m: RECOVER_TRANSLATION_M,
            half_theta_rad: std::f64::consts::PI,
        };
        let loose = self.loose.all();
        let found = window_search(
            &self.map,
            &loose,
            points,
            &window,
            None,
            &self.config.tracking,
        )?;
        std::iter::once(found.best)
            .chain(found.rival)
            .map(|c| run(c.map_from_robot))
            .reduce(|best, r| if better(&r, &best) { r } else { best })
    }

    /// Moves every map segment, scan pose and the motion state by the correction of the node
    /// it was born in (segments merged later than their node's end move with the node of
    /// their last merge).
    fn apply_correction(&mut self, c: &Correction) {
        let Some(last) = c.new_from_old.last().copied() else {
            return;
        };
        let ns = self.config.loops.node_scans;
        // Node 0 starts at the map's scan `loop_base` (0 for a new map): segments born before
        // it (an earlier run's) never move.
        let base = self.loop_base;
        let first_new = self.loops.first_new_node();
        let nodes_in = c.first_node.saturating_sub(first_new) as u64;
        let first_scan = (base as u64 + nodes_in * ns as u64).min(u32::MAX as u64) as u32;
        let delta = |t: u32| {
            let n = first_new + (t.saturating_sub(base) / ns) as usize;
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
    }

    /// A window over the whole map and the whole circle, for re-localizing a robot lost for a
    /// while (it may have been carried anywhere); `None` for an empty map.
    fn whole_map_window(&self, guess: &Pose2) -> Option<SearchWindow> {
        let (lo, hi) = bounds(
            self.map
                .iter()
                .flat_map(|(_, s)| [s.segment.start, s.segment.end]),
        )?;
        let center = (lo + hi) * 0.5;
        Some(SearchWindow {
            center: Pose2::new(center.x, center.y, guess.theta_rad),
            half_xy_m: ((hi - lo) * 0.5).max_element(),
            half_theta_rad: std::f64::consts::PI,
        })
    }

    /// The constant-velocity guess, with the odometry prior, when it differs from the odometry
    /// `guess` by more than `tracking.odometry_check_m` or `tracking.odometry_check_deg`.
    fn odometry_disagrees(&self, guess: &Pose2) -> Option<Pose2> {
        if self.config.mapper.motion_prior != MotionPrior::Odometry {
            return None;
        }
        let (prev, last) = (self.prev_pose?, self.last_pose?);
        let cv = last.compose(&prev.between(&last));
        let d = guess.between(&cv);
        let t = &self.config.tracking;
        (d.translation().length() > t.odometry_check_m
            || d.theta_rad.abs().to_degrees() > t.odometry_check_deg)
            .then_some(cv)
    }

    /// The first guess for the new scan's pose, and the anchor that directions ICP cannot
    /// observe fall back to.
    ///
    /// The constant-velocity guess seeds ICP; along directions ICP cannot observe, the pose
    /// keeps `weak_direction_velocity` of the last motion (0: the previous pose, 1: the full
    /// constant-velocity guess), so a spurious velocity in a featureless corridor fades instead
    /// of running on. The odometry guess is evidence of motion and is its own anchor.
    fn guess(&self, odom_from_robot: Option<Pose2>) -> (Pose2, Pose2) {
        let prior = self.config.mapper.motion_prior;
        let Some(last) = self.last_pose else {
            // The map frame: the first scan's pose, or odometry's frame when odometry is used.
            let first = match (prior, odom_from_robot) {
                (MotionPrior::Odometry, Some(odom)) => odom,
                _ => Pose2::IDENTITY,
            };
            return (first, first);
        };
        match prior {
            MotionPrior::Previous => (last, last),
            MotionPrior::ConstantVelocity => {
                let Some(prev) = self.prev_pose else {
                    return (last, last);
                };
                let v = prev.between(&last);
                let f = self.config.mapper.weak_direction_velocity.clamp(0.0, 1.0);
                let damped = Pose2::new(v.x_m * f, v.y_m * f, v.theta_rad * f);
                (last.compose(&v), last.compose(&damped))
            }
            MotionPrior::Odometry => {
                let g = match (self.last_odom, odom_from_robot) {
                    (Some(a), Some(b)) => last.compose(&a.between(&b)),
                    _ => last,
                };
                (g, g)
            }
        }
    }

    /// ICP of the scan against the map near the guess, and a window search when ICP's basin
    /// may not reach (see [`crate::align::should_search`]), with the verdict; `None` when there
    /// is nothing to align to.
    fn align(
        &self,
        scan: &PreparedScan,
        guess: Pose2,
        anchor: Pose2,
    ) -> (Option<AlignResult>, Tracking) {
        let params = &self.config.align;
        let points = thin_points(&scan.points_in_robot, params.point_spacing_m);
        let first = self.map.is_empty();
        let tracked = self.icp(scan, &points, guess, anchor);
        let mut tracking = verdict(
            tracked.0.as_ref(),
            points.len(),
            first,
            &self.config.tracking,
        );
        tracking.searched = tracked.1.is_some();
        tracking.search_won = tracked.2;
        if tracking.verdict == Verdict::Ok && tracked.1.is_some_and(|m| m.ambiguous()) {
            tracking.verdict = Verdict::Weak;
            tracking.reason = Reason::Ambiguous;
        }
        (tracked.0, tracking)
    }

    /// [`Mapper::align`]'s fit: ICP from the starts, the recovery, the window search; with
    /// whether the search ran and whether it won.
    fn icp(
        &self,
        scan: &PreparedScan,
        points: &[Vec2],
        guess: Pose2,
        anchor: Pose2,
    ) -> (Option<AlignResult>, Option<WindowMatch>, bool) {
        let Some(result) = self.icp_from_starts(scan, points, guess, anchor) else {
            return (None, None, false);
        };
        let tracking = &self.config.tracking;
        if !should_search(
            &guess,
            &anchor,
            &self.recent,
            Some(&result),
            points.len(),
            self.lost_streak,
            tracking,
        ) {
            return (Some(result), None, false);
        }
        let every = tracking.relocalize_every_lost;
        let global = every > 0 && self.lost_streak > 0 && self.lost_streak.is_multiple_of(every);
        let window = match global.then(|| self.whole_map_window(&guess)).flatten() {
            Some(w) => w,
            None => search_window(&guess, &anchor, self.lost_streak, tracking),
        };
        let loose = self.loose.all();
        let seed = Some(result.map_from_robot);
        let Some(found) = window_search(&self.map, &loose, points, &window, seed, tracking) else {
            return (Some(result), None, false);
        };
        if found.best.map_from_robot == result.map_from_robot {
            return (Some(result), Some(found), false); // nothing in the window beat ICP's pose
        }
        let searched = self.run_icp(scan, points, found.best.map_from_robot, anchor);
        // The search's pose must fit clearly better: along a corridor, or with odometry's good
        // guess, a pose that fits a few more points by coincidence is no evidence.
        let margin = self.config.tracking.search_win_margin;
        if searched.inliers as f64 > result.inliers as f64 * (1.0 + margin) + 2.0 {
            (Some(searched), Some(found), true)
        } else {
            (Some(result), Some(found), false)
        }
    }

    /// One ICP run from `start` with the configured correspondences.
    fn run_icp(
        &self,
        scan: &PreparedScan,
        points: &[Vec2],
        start: Pose2,
        anchor: Pose2,
    ) -> AlignResult {
        let params = &self.config.align;
        match params.method {
            AlignMethod::PointToSegment => align_points(points, &self.map, start, anchor, params),
            AlignMethod::Endpoints => {
                let near = self.near_endpoints_map(scan, start);
                align_endpoints(
                    &scan.segments_in_robot,
                    &self.map,
                    &near,
                    start,
                    anchor,
                    params,
                )
            }
        }
    }

    /// Map segments near the scan placed at `guess`, for endpoint ICP.
    fn near_endpoints_map(&self, scan: &PreparedScan, guess: Pose2) -> Vec<Segment> {
        let Some((lo, hi)) = bounds(
            scan.points_in_robot
                .iter()
                .map(|p| guess.transform_point(*p)),
        ) else {
            return Vec::new();
        };
        let margin = Vec2::splat(self.config.align.initial_gate_m);
        self.map
            .query(lo - margin, hi + margin)
            .iter()
            .filter_map(|id| self.map.get(*id))
            .map(|s| s.segment)
            .collect()
    }

    /// ICP from the motion prior's starts (and the recovery after a gap); `None` when there is
    /// nothing to align to.
    fn icp_from_starts(
        &self,
        scan: &PreparedScan,
        points: &[Vec2],
        guess: Pose2,
        anchor: Pose2,
    ) -> Option<AlignResult> {
        if self.map.is_empty() || scan.points_in_robot.is_empty() {
            return None;
        }
        let params = &self.config.align;
        let segs_in_robot = &scan.segments_in_robot;
        let near: Vec<Segment> = match params.method {
            AlignMethod::PointToSegment => Vec::new(),
            AlignMethod::Endpoints => {
                let (lo, hi) = bounds(
                    scan.points_in_robot
                        .iter()
                        .map(|p| guess.transform_point(*p)),
                )?;
                let margin = Vec2::splat(params.initial_gate_m);
                self.map
                    .query(lo - margin, hi + margin)
                    .iter()
                    .filter_map(|id| self.map.get(*id))
                    .map(|s| s.segment)
                    .collect()
            }
        };
        let run = |start: Pose2| match params.method {
            AlignMethod::PointToSegment => align_points(points, &self.map, start, anchor, params),
            AlignMethod::Endpoints => {
                align_endpoints(segs_in_robot, &self.map, &near, start, anchor, params)
            }
        };
        // Starts: the guess; the anchor when they differ (a constant-velocity guess is wrong
        // when a turn starts, stops or reverses); the best coarse rotation when the robot turned
        // faster than ICP's basin. Which one ICP runs from: see `icp_from_best_start_only`.
        let mut starts = vec![guess];
        if self.config.mapper.also_start_at_anchor && anchor != guess {
            starts.insert(0, anchor);
        }
        // Odometry is checked against the scans' own motion: where the odometry increment and
        // the constant-velocity one disagree (a slip, a bad turn), ICP also runs from the
        // latter, and the better fit wins.
        if let Some(cv) = self.odometry_disagrees(&guess) {
            starts.push(cv);
        }
        let searched = rotation_search(points, &self.map, guess, params);
        if searched != guess {
            starts.push(searched);
        }
        if self.config.mapper.icp_from_best_start_only && starts.len() > 1 {
            let margin = self.config.mapper.start_score_margin;
            starts = vec![best_scoring(&starts, points, &self.map, params, margin)];
        }
        let result = starts
            .into_iter()
            .map(run)
            .reduce(|best, r| if better(&r, &best) { r } else { best })?;
        // With odometry the guess already carries the turn; a poor fit after a gap then
        // means stale odometry, which the next increment makes good (a recovery would turn
        // the pose and the increment would turn it again).
        let share = self.config.mapper.recover_below_inlier_share;
        if (result.inliers as f64) >= share * points.len() as f64
            || self.config.mapper.motion_prior == MotionPrior::Odometry
        {
            return Some(result);
        }
        let Some(recovered) = self.recover(points, anchor, &run) else {
            return Some(result);
        };
        // Kept only when it fits well where the guess fitted badly: a turned scan that is
        // merely less bad is likelier a coincidence of the search.
        let fits_well = recovered.inliers as f64 >= 2.0 * share * points.len() as f64;
        Some(if fits_well && recovered.inliers >= 2 * result.inliers {
            recovered
        } else {
            result
        })
    }
}

/// The start whose soft inlier count over a sample of the points is highest. The first start
/// is kept unless another beats it by `margin` (soft points): along a corridor the count is
/// nearly flat, and the first start is "no motion".
fn best_scoring(
    starts: &[Pose2],
    points: &[Vec2],
    map: &impl crate::align::SegmentLookup,
    params: &AlignParams,
    margin: f64,
) -> Pose2 {
    let sample = score_sample(points, params);
    let first = fit_score(&sample, map, &starts[0], params);
    let mut best = (first + margin, starts[0]);
    for p in &starts[1..] {
        if let Some(s) = fit_score_above(&sample, map, p, params, best.0) {
            best = (s, *p);
        }
    }
    best.1
}

/// Whether two poses are distinct places: `tracking.rival_apart_m` or `rival_apart_deg` apart.
fn apart_by(a: &Pose2, b: &Pose2, params: &crate::align::TrackParams) -> bool {
    let d = a.between(b);
    d.translation().length() > params.rival_apart_m
        || normalize_angle_rad(d.theta_rad).abs() > params.rival_apart_deg.to_radians()
}

/// Points along a segment, `spacing_m` apart (metres), both ends included.
fn points_along(segment: &Segment, spacing_m: f64) -> impl Iterator<Item = Vec2> + '_ {
    let n = (segment.length() / spacing_m).ceil().clamp(1.0, 1e6) as usize;
    (0..=n).map(move |k| segment.start + (segment.end - segment.start) * (k as f64 / n as f64))
}

/// The recovery searches positions within this distance of the anchor (each axis), metres.
const RECOVER_TRANSLATION_M: f64 = 1.0;

/// True when `a` explains the scan better than `b`: more inliers, then a lower residual.
fn better(a: &AlignResult, b: &AlignResult) -> bool {
    (a.inliers, -a.residual_rms_m) > (b.inliers, -b.residual_rms_m)
}

/// The bounding box of some points; `None` for none.
pub(crate) fn bounds(points: impl Iterator<Item = Vec2>) -> Option<(Vec2, Vec2)> {
    points.fold(None, |acc, p| match acc {
        None => Some((p, p)),
        Some((lo, hi)) => Some((lo.min(p), hi.max(p))),
    })
}

mod observed;
#[cfg(test)]
mod tests;
