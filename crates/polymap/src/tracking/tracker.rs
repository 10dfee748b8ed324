//! The state tracking carries from scan to scan ([`Tracker`]): the last poses and the speed
//! last observed (the motion prior's guess and anchor), the last `ok` scan (the reach and the
//! restart after lost scans), the recent motion, the loose points, the lost streak, and the
//! run's [`TrackingSummary`]. Each scan's pose comes from [`track_scan`] with that state; a
//! loop correction moves the poses it holds ([`Tracker::apply_correction`]).

use super::estimator::{
    MotionModel, PoseCovariance, covariance_of, fuse, prior_information, speed_spread_m,
    trusted_fit_information, unknown_covariance, weakest_sigma_m,
};
use super::params::{MapperParams, MotionPrior, TrackParams};
use super::recent::{LoosePoints, RecentMotion, StepsSeen, tracked_sure};
use super::speed::{ObservedSpeed, reach_reference, scaled};
use super::strategy::{TrackConfig, TrackInput, TriedPose, track_scan};
use super::summary::{ODOMETRY_CHECK_MIN_TRAVEL_M, TrackingSummary};
use super::verdict::{OdometryWitness, Reason, Tracking, Verdict};
use crate::align::{AlignParams, AlignResult, thin_points};
use crate::geometry::Pose2;
use crate::map::GlobalMap;
use crate::scan::PreparedScan;
use crate::tracking::params::{LOOSE_POINT_SCANS, LOOSE_POINT_SPACING_M, WEAK_DIRECTION_VELOCITY};

/// Where a scan stands in the two numberings of a run: `run` counts this run's scans from 0
/// (the numbering of [`TrackingSummary`]); `map` counts every scan of the map's runs (a
/// segment's `born_scan`, the loop closer's), `run` plus the scans of the runs a saved map
/// holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ScanNumber {
    /// The scan's index in this run, 0-based.
    pub run: u32,
    /// The scan's index in the map, 0-based.
    pub map: u32,
}

/// What tracking made of one scan.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackedScan {
    /// The scan's pose, map frame: ICP's final fit, or with nothing to align to, the motion
    /// prior's guess (the first scan: the map frame's origin, or odometry's pose) or its
    /// anchor.
    pub map_from_robot: Pose2,
    /// The final ICP fit with how well it observed each direction
    /// ([`AlignResult::translation_information`], [`AlignResult::weak_directions`]); `None`
    /// when there was nothing to align to.
    pub align: Option<AlignResult>,
    /// The verdict and how it was reached.
    pub tracking: Tracking,
    /// Whether the scan's segments enter the map ([`Tracking::enters_map`] under
    /// `tracking.merge_doubtful_scans`); a scan that does not neither leaves loose points nor
    /// observes the map.
    pub enters_map: bool,
    /// The scan follows a gap in the log: a time step at least 3 typical ones, in stamps that
    /// keep time (counted in [`TrackingSummary::gaps`]).
    pub after_gap: bool,
    /// The log's odometry, witnessing without being the prior, contradicts the scan's tracked
    /// step (counted in [`TrackingSummary::off_odometry`], whatever the verdict).
    pub off_odometry: bool,
    /// The pose's covariance over (x, y, θ), map frame (m², m·rad, rad²), as tracked (before
    /// any later loop correction): the inverse of the information it rests on, the fit's and
    /// the motion prior's where that was fused or weighed ([`covariance_of`]); a direction
    /// nothing observed, and every direction of a lost scan or one with nothing to align to,
    /// at [`UNKNOWN_VARIANCE`](crate::tracking::UNKNOWN_VARIANCE); zero for the first scan, which
    /// sets the map frame.
    pub covariance: PoseCovariance,
    /// Every ICP run the strategy made, in order ([`TriedPose`]), if [`Tracker::record_tries`].
    pub tries: Vec<TriedPose>,
}

/// Tracking from scan to scan: the state the motion prior and the strategy need (the last
/// poses, the speed last observed, the last `ok` scan, the recent motion, the loose points,
/// the lost streak) and the run's [`TrackingSummary`]. [`Tracker::track`] gives each scan its
/// pose and verdict and takes it into the state.
#[derive(Debug, Clone)]
pub struct Tracker {
    /// ICP (section `[align]`).
    align: AlignParams,
    /// The window search, the hypotheses and the verdict (section `[tracking]`).
    tracking: TrackParams,
    /// The motion prior and the starts (section `[mapper]`).
    starts: MapperParams,
    last_pose: Option<Pose2>,
    prev_pose: Option<Pose2>,
    /// The last observed motion (`mapper.keep_observed_velocity`).
    observed: ObservedSpeed,
    last_odom: Option<Pose2>,
    /// The last scan tracked `ok`: its index (the map's numbering), pose and stamp.
    last_ok: Option<(u32, Pose2, Option<f64>)>,
    /// The odometry pose of that scan (odometry frame), when it had one.
    last_ok_odom: Option<Pose2>,
    loose: LoosePoints,
    recent: RecentMotion,
    steps_seen: StepsSeen,
    lost_streak: u32,
    summary: TrackingSummary,
    /// Whether [`Tracker::track`] keeps each scan's ICP runs ([`TrackedScan::tries`]).
    record_tries: bool,
}

/// The motion prior's poses for one scan, map frame, and the log's odometry as a witness.
#[derive(Debug, Clone, Copy)]
struct Prior {
    guess: Pose2,
    anchor: Pose2,
    unobserved_to: Pose2,
    witness: Option<OdometryWitness>,
    /// With the odometry prior, the odometry's step from the scan before (its robot frame),
    /// when both carry odometry and that scan was not lost: what the guess moved by.
    odometry_step: Option<Pose2>,
}

impl Tracker {
    /// A tracker with nothing tracked yet, under the `[align]`, `[tracking]` and `[mapper]`
    /// sections of the configuration.
    pub fn new(align: AlignParams, tracking: TrackParams, starts: MapperParams) -> Self {
        Tracker {
            align,
            tracking,
            starts,
            last_pose: None,
            prev_pose: None,
            observed: ObservedSpeed::default(),
            last_odom: None,
            last_ok: None,
            last_ok_odom: None,
            loose: LoosePoints::default(),
            recent: RecentMotion::default(),
            steps_seen: StepsSeen::default(),
            lost_streak: 0,
            summary: TrackingSummary::default(),
            record_tries: false,
        }
    }

    /// Tracks scan `at` in `map` (map frame): the motion prior's guess, ICP from its starts,
    /// the window search, the hypotheses and the verdict ([`track_scan`]); then takes the scan
    /// into the state (its pose, speed, loose points, the summary).
    pub fn track(&mut self, at: ScanNumber, scan: &PreparedScan, map: &GlobalMap) -> TrackedScan {
        let prior = self.prior(scan);
        // With odometry, the pose the strategy finds is weighed with the odometry's step
        // (`Attempt::weighed`); a pose already weighed is not fused again below.
        let (align, tracking, tries) = self.align(scan, map, &prior);
        let weighed = align.is_some_and(|a| a.weighed_prior);
        // A scan with nothing to align (no valid points) is no evidence of motion: the anchor,
        // like a scan with too few correspondences; the very first scan starts the map frame.
        // A lost scan keeps its (poor) fit, the best guess there is, but stays out of the map.
        let fallback = match map.is_empty() {
            true => prior.guess,
            false => prior.anchor,
        };
        let mut pose = align.map_or(fallback, |a| a.map_from_robot);
        // The fit is fused with the motion prior it has not weighed yet: the odometry's step
        // the fit contradicted, or without odometry the constant-velocity prediction where the
        // stamps time it.
        let fusable = tracking.verdict != Verdict::Lost && !map.is_empty() && !weighed;
        let motion = match self.starts.motion_prior {
            MotionPrior::Odometry => prior
                .odometry_step
                .map(|step| (prior.guess, MotionModel::Odometry { step })),
            MotionPrior::ConstantVelocity
                if self.starts.keep_observed_velocity && self.observed.motion().is_some() =>
            {
                self.observed.step_dt_s(scan.stamp_s).map(|dt_s| {
                    let age_s = self.observed.unobserved_s();
                    (
                        prior.unobserved_to,
                        MotionModel::ConstantVelocity { dt_s, age_s },
                    )
                })
            }
            _ => None,
        };
        // The pose rests on the prior too where ICP weighed the odometry's step, or where the
        // prior is fused below and does not contradict the fit.
        let mut with_prior = weighed;
        if let (Some(a), Some((to, model)), true) = (align, motion, fusable) {
            let fused = fuse(pose, &a.translation_information, to, model);
            (pose, with_prior) = (fused.pose, fused.with_prior);
        }
        // Its information: the fit's as far as the verdict trusts it, with the prior's.
        let weak_below = self.tracking.verdict.weak_below_information;
        let information = align.map(|a| {
            let fit =
                trusted_fit_information(&a.translation_information, a.residual_rms_m, weak_below);
            match (with_prior, motion) {
                (true, Some((_, model))) => fit + prior_information(model),
                _ => fit,
            }
        });
        let covariance = match (map.is_empty(), tracking.verdict, information) {
            (true, _, _) => [[0.0; 3]; 3],
            (false, Verdict::Lost, _) | (false, _, None) => unknown_covariance(),
            (false, _, Some(information)) => covariance_of(&information),
        };
        let tracked = self.take(at, scan, &prior, (pose, align, tracking), covariance, true);
        TrackedScan { tries, ..tracked }
    }

    /// Takes scan `at` into the state with a pose found elsewhere (map frame): the search that
    /// places a run on a saved map. Only a `placed` scan moves the motion state (the last
    /// poses, the speed, the last `ok` scan; the summary's gap, odometry and weak-stretch
    /// counts); the verdict counts, the lost streak and the loose points take every scan.
    pub fn take_pose(
        &mut self,
        at: ScanNumber,
        scan: &PreparedScan,
        pose: Pose2,
        align: Option<AlignResult>,
        tracking: Tracking,
        placed: bool,
    ) -> TrackedScan {
        let prior = self.prior(scan);
        let covariance = match (align, tracking.verdict) {
            (Some(a), v) if placed && v != Verdict::Lost => {
                covariance_of(&trusted_fit_information(
                    &a.translation_information,
                    a.residual_rms_m,
                    self.tracking.verdict.weak_below_information,
                ))
            }
            _ => unknown_covariance(),
        };
        self.take(
            at,
            scan,
            &prior,
            (pose, align, tracking),
            covariance,
            placed,
        )
    }

    /// The tracking summary of the run so far.
    pub fn summary(&self) -> &TrackingSummary {
        &self.summary
    }

    /// Ends the run's summary at its last scan taken so far (the stretch of travel going on
    /// is judged); more scans may follow.
    pub fn close_summary(&mut self) {
        self.summary.close_part();
    }

    /// Counts the lost scans `first..=last` (this run's numbering; one lost range) as weak
    /// instead: scans placed after the fact.
    pub(crate) fn relabel_lost_as_weak(&mut self, first: u32, last: u32) {
        self.summary.relabel_lost_as_weak(first, last);
    }

    /// Moves the poses the tracker holds by a loop correction: `delta(t)` is the correction
    /// (`new_from_old`, map frame) of the map's scan `t`, `last` the map's index of the last
    /// scan taken; the last `ok` pose moves only when it is of scan `first_moved` or later (a
    /// pose older than what the correction moves stays). The speed state is relative and stays.
    pub fn apply_correction(&mut self, last: u32, first_moved: u32, delta: impl Fn(u32) -> Pose2) {
        self.last_pose = self.last_pose.map(|p| delta(last).compose(&p));
        self.prev_pose = self
            .prev_pose
            .map(|p| delta(last.saturating_sub(1)).compose(&p));
        self.last_ok = self.last_ok.map(|(i, p, stamp)| match i >= first_moved {
            true => (i, delta(i).compose(&p), stamp),
            false => (i, p, stamp),
        });
    }

    /// The motion prior's poses for `scan` and the log's odometry as a witness of its step.
    fn prior(&self, scan: &PreparedScan) -> Prior {
        let (guess, anchor, unobserved_to) = self.guess(scan.odom_from_robot, scan.stamp_s);
        let witness = self.odometry_witness(scan.odom_from_robot);
        let odometry_step = self
            .odometry_step(scan.odom_from_robot)
            .filter(|_| self.starts.motion_prior == MotionPrior::Odometry && self.lost_streak == 0);
        Prior {
            guess,
            anchor,
            unobserved_to,
            witness,
            odometry_step,
        }
    }

    /// Takes a scan with its pose (map frame), fit and verdict into the state; the motion
    /// state only when `placed`.
    fn take(
        &mut self,
        at: ScanNumber,
        scan: &PreparedScan,
        prior: &Prior,
        (pose, align, tracking): (Pose2, Option<AlignResult>, Tracking),
        covariance: PoseCovariance,
        placed: bool,
    ) -> TrackedScan {
        let (i, t) = (at.run, at.map);
        let lost = tracking.verdict == Verdict::Lost;
        let mut after_gap = false;
        let mut off_odometry = false;
        if placed {
            // Observed: tracked `ok` (or only `slowed`, see `Tracking::carries_tracking`) with
            // every direction observed; a motion between two observed scans is evidence of the
            // robot's speed, and one the robot was seen to make (the own-step hypotheses).
            let observed =
                tracking.carries_tracking() && align.is_some_and(|a| a.weak_directions == 0);
            if let Some(last) = self.last_pose {
                self.recent.push(&last, &pose);
            }
            let step = self.last_pose.map(|last| last.between(&pose));
            let after_ok = self
                .last_ok
                .is_some_and(|(k, _, _)| k.saturating_add(1) == t);
            let seen = step.filter(|_| observed && after_ok && !tracking.corner_won);
            let below = self.tracking.verdict.slowed_below_information;
            let sure = tracked_sure(&tracking, align.as_ref(), below);
            self.steps_seen.record(seen.as_ref(), sure);
            let dt_s = self.observed.step_dt_s(scan.stamp_s);
            let set_speed =
                self.observed
                    .record(step, observed && !tracking.corner_won, scan.stamp_s);
            // How well a step that set the speed told its translation.
            let observed_sigma_m = align
                .filter(|_| set_speed)
                .map(|a| weakest_sigma_m(&a.translation_information, a.residual_rms_m));
            self.observed.weigh(observed_sigma_m, dt_s);
            after_gap = self.observed.last_gap_scale() > 1.0;
            if after_gap {
                self.summary.count_gap(i);
            }
            let off = self.tracking.odometry.odometry_witness_m;
            off_odometry = !lost && prior.witness.is_some_and(|w| w.contradicts(&pose, off));
            if off_odometry {
                self.summary.count_off_odometry(i);
            }
            // The step's length as tracked and as the log's odometry read it, metres.
            let tracked_m = step.map(|s| s.translation().length());
            let odometry_m = self
                .last_odom
                .zip(scan.odom_from_robot)
                .map(|(a, b)| a.between(&b).translation().length());
            // The log's odometry against the scans, between consecutive `ok` scans.
            let ok = tracking.carries_tracking();
            if let (true, Some(tracked_m), Some(odometry_m)) =
                (ok && after_ok, tracked_m, odometry_m)
            {
                self.summary.count_travel(odometry_m, tracked_m);
            }
            // Without the odometry prior, the log's odometry against the tracked steps over
            // metres: a stall on `ok` steps.
            if self.starts.motion_prior != MotionPrior::Odometry {
                let follows = !lost && self.lost_streak == 0;
                let steps = odometry_m.zip(tracked_m).filter(|_| follows);
                self.summary.count_witnessed_step(i, steps);
            }
            let weak = tracking.verdict == Verdict::Weak;
            // The step the speed last observed predicts (the fallback along an unobserved
            // direction; over a gap in the log, for the gap's time, at most `GAP_SCALE_MAX`
            // steps): a stretch tracked short is long in it.
            let expected_m = self.last_pose.map_or(0.0, |last| {
                last.between(&prior.unobserved_to).translation().length()
            });
            self.summary
                .count_weak_step(i, weak, tracked_m.unwrap_or(0.0), odometry_m, expected_m);
            if let (false, Some(tracked_m)) = (lost, tracked_m) {
                let weakly_observed = weak
                    && matches!(
                        tracking.reason,
                        Reason::WeaklyObserved | Reason::Degenerate | Reason::Slowed
                    );
                self.summary.count_step(i, tracked_m, weakly_observed);
            }
            self.prev_pose = self.last_pose.replace(pose);
            self.last_odom = scan.odom_from_robot;
            if tracking.carries_tracking() {
                self.last_ok = Some((t, pose, scan.stamp_s));
                self.last_ok_odom = scan.odom_from_robot;
            }
        }
        self.summary.count(i, tracking.verdict, tracking.reason);
        self.lost_streak = if lost { self.lost_streak + 1 } else { 0 };
        // A scan trusted too little to merge neither explains later searches (loose points)
        // nor observes the map (see-through counts prune walls).
        let enters_map = tracking.enters_map(self.tracking.merge_doubtful_scans);
        if enters_map {
            let spacing = LOOSE_POINT_SPACING_M;
            let loose = thin_points(&scan.points_in_robot, spacing)
                .into_iter()
                .map(|p| pose.transform_point(p))
                .collect();
            self.loose.push(loose, LOOSE_POINT_SCANS);
        }
        TrackedScan {
            map_from_robot: pose,
            align,
            tracking,
            enters_map,
            after_gap,
            off_odometry,
            covariance,
            tries: Vec::new(),
        }
    }

    /// The first guess for the new scan's pose, the anchor ("no motion": the previous pose),
    /// and the pose that directions ICP cannot observe fall back to, all map frame.
    ///
    /// The constant-velocity guess seeds ICP. With `keep_observed_velocity` (once a motion was
    /// observed), the fallback is the previous pose moved by the last observed motion; a motion
    /// taken from the prior never feeds back, so it cannot run on by itself. Otherwise the fallback keeps
    /// [`WEAK_DIRECTION_VELOCITY`] of the last motion (0: the previous pose). The odometry guess
    /// is evidence of motion and is its own anchor and fallback.
    ///
    /// Without odometry, a scan after a gap in a log whose stamps keep time
    /// ([`ObservedSpeed::gap_scale`]) is predicted over the gap's time: the motion per scan
    /// times the gap, not one scan's worth; the fallback of unobservable directions (the last
    /// observed motion, or the damped one) spans it too. After a loop correction that moved
    /// the last two poses by different node corrections, that difference is scaled with the
    /// step (the same holds for one scan's worth).
    pub(crate) fn guess(
        &self,
        odom_from_robot: Option<Pose2>,
        stamp_s: Option<f64>,
    ) -> (Pose2, Pose2, Pose2) {
        let prior = self.starts.motion_prior;
        let Some(last) = self.last_pose else {
            // The map frame: the first scan's pose, or odometry's frame when odometry is used.
            let first = match (prior, odom_from_robot) {
                (MotionPrior::Odometry, Some(odom)) => odom,
                _ => Pose2::IDENTITY,
            };
            return (first, first, first);
        };
        match prior {
            MotionPrior::Previous => (last, last, last),
            MotionPrior::ConstantVelocity => {
                let Some(v) = self.constant_velocity_step(stamp_s) else {
                    return (last, last, last);
                };
                let predicted = last.compose(&v);
                match self.observed.motion() {
                    Some(m) if self.starts.keep_observed_velocity => {
                        let over_gap = scaled(&m, self.observed.gap_scale(stamp_s));
                        (predicted, last, last.compose(&over_gap))
                    }
                    _ => {
                        let f = WEAK_DIRECTION_VELOCITY.clamp(0.0, 1.0);
                        let damped =
                            last.compose(&Pose2::new(v.x_m * f, v.y_m * f, v.theta_rad * f));
                        (predicted, damped, damped)
                    }
                }
            }
            MotionPrior::Odometry => {
                let g = match self.odometry_step(odom_from_robot) {
                    Some(step) => last.compose(&step),
                    None => last,
                };
                (g, g, g)
            }
        }
    }

    /// The odometry's step from the last scan to one whose odometry pose is `odom_from_robot`
    /// (robot frame of the last scan), when both are known.
    fn odometry_step(&self, odom_from_robot: Option<Pose2>) -> Option<Pose2> {
        let (a, b) = (self.last_odom?, odom_from_robot?);
        Some(a.between(&b))
    }

    /// Without the odometry prior, how far the robot may be from the constant-velocity prior's
    /// pose at a scan stamped `stamp_s`, metres: [`speed_spread_m`] over the step's time, plus
    /// what the prediction's span differs from that time by
    /// ([`ObservedSpeed::span_mismatch_m`]); where the stamps time the step, a timed step that
    /// set the speed told it, and the scan before was not lost (the prediction then builds on
    /// a poor fit, as the odometry's step is not used then either).
    fn speed_spread_m(&self, stamp_s: Option<f64>) -> Option<f64> {
        let on = self.starts.motion_prior == MotionPrior::ConstantVelocity
            && self.starts.keep_observed_velocity
            && self.lost_streak == 0;
        let sigma_m_s = self.observed.speed_sigma_m_s().filter(|_| on)?;
        let dt_s = self.observed.step_dt_s(stamp_s)?;
        let mismatch_m = self.observed.span_mismatch_m(stamp_s)?;
        Some(speed_spread_m(dt_s, sigma_m_s) + mismatch_m)
    }

    /// The constant-velocity step from the last pose to a scan stamped `stamp_s` (robot frame
    /// of the last scan; over a gap's time, [`ObservedSpeed::predicted_step`]), once there are
    /// two poses.
    fn constant_velocity_step(&self, stamp_s: Option<f64>) -> Option<Pose2> {
        let (prev, last) = (self.prev_pose?, self.last_pose?);
        Some(self.observed.predicted_step(&prev.between(&last), stamp_s))
    }

    /// After a gap in the log (a scan stamped `stamp_s` whose
    /// [`ObservedSpeed::gap_scale`] spans several time steps), the last pose moved by one
    /// time step's motion ([`ObservedSpeed::one_step`]; the last pose before two poses), map
    /// frame; `None` when the scan follows no gap.
    fn one_step_over_gap(&self, stamp_s: Option<f64>) -> Option<Pose2> {
        let last = self.last_pose?;
        if self.observed.gap_scale(stamp_s) <= 1.0 {
            return None;
        }
        Some(match self.prev_pose {
            Some(prev) => last.compose(&self.observed.one_step(&prev.between(&last))),
            None => last,
        })
    }

    /// The log's odometry as a witness of the step to a scan whose odometry pose is
    /// `odom_from_robot` (`tracking.odometry.odometry_witness_m`): from the previous scan, or after lost
    /// scans from the last `ok` one; without the odometry prior, while its travel agrees with
    /// the scans' ([`TrackingSummary::odometry_agrees_with_travel`], judged at every scan).
    fn odometry_witness(&self, odom_from_robot: Option<Pose2>) -> Option<OdometryWitness> {
        let on = self.starts.motion_prior != MotionPrior::Odometry
            && self.tracking.odometry.odometry_witness_m > 0.0
            && self
                .summary
                .odometry_agrees_with_travel(ODOMETRY_CHECK_MIN_TRAVEL_M);
        // After a lost scan, from the last `ok` pose: a lost scan's pose is its poor fit (or
        // the anchor), and a step from it says nothing of the scan after it.
        let (previous, from) = match self.lost_streak {
            0 => (self.last_pose?, self.last_odom?),
            _ => (self.last_ok.map(|(_, pose, _)| pose)?, self.last_ok_odom?),
        };
        let to = odom_from_robot?;
        on.then(|| OdometryWitness {
            previous,
            step: from.between(&to).translation(),
        })
    }

    /// The pose of the scan in `map` and the verdict on it, from [`track_scan`] with the
    /// tracker's state and the motion prior's poses (and the log's odometry as a witness of
    /// the step); the pose is `None` when there is nothing to align to.
    fn align(
        &self,
        scan: &PreparedScan,
        map: &GlobalMap,
        prior: &Prior,
    ) -> (Option<AlignResult>, Tracking, Vec<TriedPose>) {
        let Prior {
            guess,
            anchor,
            unobserved_to,
            witness,
            odometry_step,
        } = *prior;
        let (reference, dt_s) = reach_reference(self.last_ok, scan.stamp_s, guess);
        // With odometry, ICP restarts after a lost scan from the last `ok` pose moved by the
        // odometry since then.
        let odometry = self.starts.motion_prior == MotionPrior::Odometry;
        let last_ok = self.last_ok.map(|(_, pose, _)| pose);
        let restart = match odometry {
            true => moved_by_odometry(last_ok, self.last_ok_odom, scan.odom_from_robot),
            false => None,
        }
        .unwrap_or(reference);
        // As in `guess` (the odometry check compares odometry, which spans a gap, with it).
        let constant_velocity = self
            .last_pose
            .zip(self.constant_velocity_step(scan.stamp_s))
            .map(|(last, v)| last.compose(&v));
        let input = TrackInput {
            points_in_robot: &scan.points_in_robot,
            segments_in_robot: &scan.segments_in_robot,
            map,
            loose: &self.loose,
            guess,
            anchor,
            unobserved_to,
            reference,
            last_ok: last_ok.unwrap_or(guess),
            restart,
            dt_s,
            after_gap: self.one_step_over_gap(scan.stamp_s).filter(|_| !odometry),
            constant_velocity,
            recent: &self.recent,
            steps_seen: &self.steps_seen,
            lost_streak: self.lost_streak,
            odometry_witness: witness,
            odometry_step,
            speed_spread_m: self.speed_spread_m(scan.stamp_s),
        };
        let config = TrackConfig {
            align: &self.align,
            tracking: &self.tracking,
            starts: &self.starts,
        };
        track_scan(&input, &config, self.record_tries)
    }

    /// Keeps each scan's ICP runs in [`TrackedScan::tries`] from now on (off by default).
    pub fn record_tries(&mut self, on: bool) {
        self.record_tries = on;
    }
}

/// The last `ok` pose `ok` (map frame) moved by the odometry from that scan's odometry pose
/// `then` to this scan's `now` (odometry frame); `None` when any is unknown.
fn moved_by_odometry(ok: Option<Pose2>, then: Option<Pose2>, now: Option<Pose2>) -> Option<Pose2> {
    Some(ok?.compose(&then?.between(&now?)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn after_a_lost_scan_odometry_moves_the_last_ok_pose() {
        let ok = Pose2::new(1.0, 2.0, std::f64::consts::FRAC_PI_2);
        let then = Pose2::new(10.0, 0.0, 0.0);
        // Odometry says 0.5 m ahead since that scan: ahead of the robot, which faces +y.
        let now = Pose2::new(10.5, 0.0, 0.0);
        let moved = moved_by_odometry(Some(ok), Some(then), Some(now)).unwrap();
        assert!((moved.x_m - 1.0).abs() < 1e-12 && (moved.y_m - 2.5).abs() < 1e-12);
        assert_eq!(moved_by_odometry(Some(ok), None, Some(now)), None);
        assert_eq!(moved_by_odometry(None, Some(then), Some(now)), None);
    }
}
