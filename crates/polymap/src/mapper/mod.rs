//! The incremental mapper: owns `G_t` and the motion state between scans.
//!
//! For each scan: points → segments (robot frame) → ICP against the map near the scan, started
//! from the motion prior → segments to the map frame → main directions of `G_{t-1}(tm)` →
//! vertex insertion, restrictive pairing, simplification against the map near the scan → `G_t`.
//! The first map `G_1` is the first scan.

use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::align::{
    AlignMethod, AlignParams, AlignResult, LoosePoints, Reason, RecentMotion, SearchWindow,
    Tracking, Verdict, WindowMatch, align_endpoints, align_points, fit_score, fit_score_above,
    rotation_search, score_sample, search_window, should_search, thin_points, verdict,
    window_search,
};
use crate::config::Config;
use crate::directions::recent_main_directions;
use crate::extract::{extract_segments, extract_segments_closed};
use crate::geometry::{Pose2, Segment, Vec2};
use crate::loops::{Correction, LoopCloser, LoopDiagnostics, LoopFailure};
use crate::map::{GlobalMap, MapSegment};
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

/// The incremental geometric mapper.
#[derive(Debug, Clone)]
pub struct Mapper {
    config: Config,
    map: GlobalMap,
    scans: u32,
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

    /// The configuration in use.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The current global map `G_t`.
    pub fn map(&self) -> &GlobalMap {
        &self.map
    }

    /// The map's segments in a stable order (by handle).
    pub fn segments(&self) -> Vec<MapSegment> {
        self.map.iter().map(|(_, s)| *s).collect()
    }

    /// The map's generalized polylines: indices into [`Mapper::segments`].
    pub fn polylines(&self) -> Vec<Vec<usize>> {
        let segs: Vec<Segment> = self.map.iter().map(|(_, s)| s.segment).collect();
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
        let t = self.scans;
        let clock = Instant::now();
        let (guess, anchor) = self.guess(scan.odom_from_robot);
        let (align, tracking) = self.align(&scan, guess, anchor);
        // A scan with nothing to align (no valid points) is no evidence of motion: the anchor,
        // like a scan with too few correspondences; the very first scan starts the map frame.
        // A lost scan keeps its (poor) fit, the best guess there is, but stays out of the map.
        let fallback = if self.map.is_empty() { guess } else { anchor };
        let pose = align.map_or(fallback, |a| a.map_from_robot);
        if let Some(last) = self.last_pose {
            self.recent.push(&last, &pose);
        }
        self.prev_pose = self.last_pose.replace(pose);
        self.last_odom = scan.odom_from_robot;
        self.verdicts.count(t, tracking.verdict);
        let lost = tracking.verdict == Verdict::Lost;
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
        if self.config.loops.enabled {
            let correction = self.loops.add_scan(
                t,
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
            scan_index: t,
            map_from_robot: pose,
            diagnostics,
        }
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
        let first_scan = (c.first_node as u64 * ns as u64).min(u32::MAX as u64) as u32;
        let delta = |t: u32| {
            let n = (t / ns) as usize;
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
        for (t, pose) in self
            .trajectory
            .iter_mut()
            .enumerate()
            .skip(first_scan as usize)
        {
            *pose = delta(t as u32).compose(pose);
        }
        let t = self.scans.saturating_sub(1);
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
    map: &GlobalMap,
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
