//! The incremental mapper ([`Mapper`]): scans pushed one at a time into the global map `G_t`.
//!
//! For each scan: points → segments (robot frame) → track: the pose in the map and the verdict
//! ([`Tracker::track`], which holds every state carried from scan to scan for it) → segments
//! to the map frame → main directions of `G_{t-1}(tm)` → vertex insertion, restrictive
//! pairing, simplification against the map near the scan → `G_t` → what the scan saw of the
//! map → loop closure. The first map `G_1` is the first scan. The mapper owns the map, the
//! trajectory, the loop closer and the placement of a run on a saved map.

use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::align::{AlignResult, GlobalSearch, align_points, thin_points};
use crate::config::Config;
use crate::directions::recent_main_directions;
use crate::extract::{extract_segments, extract_segments_closed};
use crate::geometry::{Pose2, Segment, Vec2};
use crate::loops::{LoopCloser, LoopDiagnostics, LoopFailure, SavedNode};
use crate::map::{GlobalMap, MapSegment, Observations};
pub use crate::merge::MergeDiagnostics;
use crate::merge::merge_scan;
use crate::observe::{Sightings, observe_scan};
use crate::polyline::group_polylines;
use crate::scan::{PreparedScan, RangeScan};
use crate::tracking::{
    PoseCovariance, Reason, ScanNumber, TrackedScan, Tracker, Tracking, TrackingSummary, TriedPose,
    Verdict, better, verdict,
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
    /// The pose's covariance over (x, y, θ), map frame (m², m·rad, rad²), as tracked
    /// ([`TrackedScan::covariance`]).
    #[serde(default)]
    pub pose_covariance: PoseCovariance,
    /// Every ICP run tracking made for the scan ([`TrackedScan::tries`]), where the mapper
    /// records them ([`Mapper::record_tries`]): the pose taken among the candidates it was
    /// preferred to, each where ICP converged (map frame) with its inliers and
    /// correspondences; empty where there was nothing to align to, and for a scan placed on a
    /// saved map.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub tries: Vec<TriedPose>,
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
    /// output: [`Mapper::segments`] and [`Mapper::polylines`] give the saved map. The scans are
    /// also tracked on a fresh map of their own, and [`Mapper::trajectory`] after
    /// [`Mapper::finish`] takes its motion over a few seconds from that map and its place from
    /// the working copy (`mapper/own_motion.rs`).
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

/// The incremental geometric mapper: track, merge, observe, close loops.
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
    /// Where each scan is: the motion prior's state, the strategy, the verdicts.
    tracker: Tracker,
    loops: LoopCloser,
    trajectory: Vec<Pose2>,
    /// A localize run's own tracking of its scans on a fresh map (`mapper.localize_own_motion_s`
    /// above 0): its motion over short spans ([`own_motion`])...
    own: Option<OwnMotion>,
    /// ...and the trajectory [`Mapper::finish`] fused from it and `trajectory`.
    fused: Option<Vec<Pose2>>,
    /// The rays of this run's observing scans, to check the finished map against.
    sightings: Sightings,
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
            tracker: Tracker::new(
                config.align.clone(),
                config.tracking.clone(),
                config.mapper.clone(),
            ),
            loops: LoopCloser::new(
                config.loops.clone(),
                config.align.clone(),
                config.map.grid_cell_m,
            ),
            trajectory: Vec::new(),
            own: None,
            fused: None,
            sightings: Sightings::default(),
            config,
        }
    }

    /// Whether each scan's diagnostics keep every ICP run tracking made for it
    /// ([`ScanDiagnostics::tries`]; off by default: a caller that writes no diagnostics need
    /// not gather them).
    pub fn record_tries(&mut self, on: bool) {
        self.tracker.record_tries(on);
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
            // A localize run's map is the saved one, not checked.
            mapper.sightings = Sightings::off();
            if c.mapper.localize_own_motion_s > 0.0 {
                mapper.own = Some(OwnMotion::new(c));
            }
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
    /// After [`Mapper::finish`], a localize run's poses take their motion over short spans from
    /// the run's own map and their place from the saved map (the module
    /// `mapper/own_motion.rs`); a scan pushed after that turns them back to the poses as
    /// tracked until the next `finish`.
    pub fn trajectory(&self) -> &[Pose2] {
        match &self.fused {
            Some(fused) if fused.len() == self.trajectory.len() => fused,
            _ => &self.trajectory,
        }
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
        self.tracker.close_summary();
        if let Some(c) = self.loops.finish(&mut diagnostics) {
            self.apply_correction(&c);
        }
        let window_s = self.config.mapper.localize_own_motion_s;
        self.fused = self
            .own
            .as_ref()
            .map(|own| own.fused(&self.trajectory, window_s));
        match self.loops.failure() {
            Some(failure) => Err(failure.clone()),
            None => Ok(diagnostics),
        }
    }

    /// Tracking verdict counts so far, with the ranges of lost scans.
    pub fn tracking_summary(&self) -> &TrackingSummary {
        self.tracker.summary()
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
        let at = ScanNumber { run: i, map: t };
        let clock = Instant::now();
        // Track, then merge, observe and close loops. A run on a saved map searches for its
        // place first (`place_scan`).
        let tracked = match self.placement {
            Placement::Placed => self.tracker.track(at, &scan, &self.map),
            _ => self.place_scan(at, &scan),
        };
        let TrackedScan {
            map_from_robot: pose,
            align,
            tracking,
            enters_map: enters,
            after_gap,
            off_odometry,
            covariance,
            tries,
        } = tracked;
        let placed = self.placement == Placement::Placed;
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
            let observed = observe_scan(
                &mut self.map,
                &scan.points_in_robot,
                &pose,
                t,
                confirmed,
                &self.config.observe,
            );
            if observed.observed {
                self.sightings
                    .record(t, &scan.points_in_robot, &self.config.observe);
            }
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
            pose_covariance: covariance,
            tries,
        };
        // A localize run's own tracking takes the scan last (outside the stages' times).
        if let Some(own) = self.own.as_mut() {
            own.push(scan, placed && tracking.verdict != Verdict::Lost);
        }
        Update {
            scan_index: i,
            map_from_robot: pose,
            diagnostics,
        }
    }
}

mod loop_side;
use loop_side::motion_doubt;
mod observed;
mod own_motion;
mod placement;
#[cfg(test)]
mod tests;

use own_motion::OwnMotion;
