//! Where ICP starts for one scan and what it fits from there: the motion prior's guess, the
//! anchor, the constant-velocity guess where odometry disagrees with it, the last `ok` pose
//! after a lost scan, the best coarse rotation; the best start by soft inlier score or ICP
//! from each; odometry's motion reversed; the whole-circle recovery; ICP again without the
//! points by a face's end that alone pin a direction.

use super::{
    Attempt, PINNED_BELOW_INFORMATION, RECOVER_TRANSLATION_M, TrackConfig, TrackInput, TriedPose,
    best_of, better,
};
use crate::align::{
    AlignMethod, AlignParams, AlignResult, PointTargets, PosePrior, SearchWindow, SegmentLookup,
    align_endpoints, align_points_and_loose, align_points_past_ends, bounds, fit_score,
    fit_score_above, rotation_search, score_sample,
};
use crate::geometry::{Pose2, Segment, Vec2};
use crate::tracking::estimator::{odometry_contradicts, odometry_prior, speed_contradicts};
use crate::tracking::params::MotionPrior;
use crate::tracking::params::START_SCORE_MARGIN;
use crate::tracking::recent::LOOSE_OFF_MAP_M;
use crate::tracking::window::window_search;

/// The recent scans' points the map's segments leave unexplained, for ICP
/// (`tracking.icp_loose_points`; point-to-segment ICP only); `None` when there are none.
pub(super) fn loose_targets(input: &TrackInput, config: &TrackConfig) -> Option<PointTargets> {
    if !config.tracking.icp_loose_points || config.align.method != AlignMethod::PointToSegment {
        return None;
    }
    let unexplained: Vec<Vec2> = input
        .loose
        .all()
        .into_iter()
        .filter(|p| input.map.nearest_id(*p, LOOSE_OFF_MAP_M).is_none())
        .collect();
    (!unexplained.is_empty()).then(|| PointTargets::new(&unexplained))
}

/// The start whose soft inlier count over a sample of the points is highest. The first start
/// is kept unless another beats it by `margin` (soft points): along a corridor the count is
/// nearly flat, and the first start is "no motion".
pub(super) fn best_scoring(
    starts: &[Pose2],
    points: &[Vec2],
    map: &impl SegmentLookup,
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

/// Map segments near the scan's points placed at `pose` (within `align.initial_gate_m`), for
/// endpoint ICP; `None` when the scan has no points.
pub(super) fn segments_near(
    input: &TrackInput,
    pose: &Pose2,
    params: &AlignParams,
) -> Option<Vec<Segment>> {
    let (lo, hi) = bounds(
        input
            .points_in_robot
            .iter()
            .map(|p| pose.transform_point(*p)),
    )?;
    let margin = Vec2::splat(params.initial_gate_m);
    Some(
        input
            .map
            .query(lo - margin, hi + margin)
            .iter()
            .filter_map(|id| input.map.get(*id))
            .map(|s| s.segment)
            .collect(),
    )
}

impl Attempt<'_> {
    /// ICP from the motion prior's starts; `None` when there is nothing to align to.
    pub(super) fn icp_from_starts(&self) -> Option<AlignResult> {
        let (input, params, policy) = (self.input, self.config.align, self.config.starts);
        if input.map.is_empty() || input.points_in_robot.is_empty() {
            return None;
        }
        let near = match params.method {
            AlignMethod::PointToSegment => Vec::new(),
            AlignMethod::Endpoints => segments_near(input, &input.guess, params)?,
        };
        let mut starts = self.starts();
        if policy.icp_from_best_start_only && starts.len() > 1 {
            let margin = START_SCORE_MARGIN;
            starts = vec![best_scoring(
                &starts,
                self.points,
                input.map,
                params,
                margin,
            )];
        }
        // With the odometry prior, the scans' own motion (the constant-velocity start, where
        // odometry disagrees with it) overrules the odometry's starts only with a fit
        // ([`Attempt::overrules_odometry`]).
        let cv = self.odometry_disagrees();
        let (own, others): (Vec<Pose2>, Vec<Pose2>) =
            starts.into_iter().partition(|s| Some(*s) == cv);
        let from_odometry = best_of(others.into_iter().map(|s| self.run(&near, s)));
        let from_cv = best_of(own.into_iter().map(|s| self.run(&near, s)));
        let mut result = match (from_odometry, from_cv) {
            (Some(o), Some(c)) if !self.overrules_odometry(&c, &o) => o,
            (o, c) => c.or(o)?,
        };
        // Where that fits poorly and odometry disagrees with the scans' own motion, the
        // odometry's turn may be the fault (a stalled wheel reads its partner's distance over
        // the wheel base as a turn): also from the best coarse rotation around the
        // constant-velocity guess, not only around the odometry's.
        if let Some(cv) = self
            .odometry_disagrees()
            .filter(|_| self.fits_poorly(&result))
        {
            let turned = rotation_search(self.points, input.map, cv, params);
            if turned != cv {
                let from_turned = self.run_near(turned);
                if self.prefers(&from_turned, &result) {
                    result = from_turned;
                }
            }
        }
        // Where that still fits poorly, odometry may have read the distance but not the
        // direction of travel (FR079 backing up, every 10th scan: forward 0.79, 1.06 and
        // 1.06 m where the robot backed 0.57, 0.79 and 1.07 m, the turns right): also from
        // the odometry's motion reversed, which must win clearly (a corridor fits a pose a
        // step back nearly as well).
        if let Some(start) = self
            .reversed_odometry()
            .filter(|_| self.fits_poorly(&result))
        {
            let reversed = self.run_near(start);
            if self.wins_clearly(&reversed, &result) {
                result = reversed;
            }
        }
        Some(result)
    }

    /// Where ICP may start, before [`MapperParams::icp_from_best_start_only`] picks one: the
    /// guess; the anchor when they differ (a constant-velocity guess is wrong when a turn
    /// starts, stops or reverses); the constant-velocity guess where odometry disagrees with
    /// it; after a lost scan the last `ok` pose ([`TrackInput::restart`]: with odometry, moved
    /// by it since then); the best coarse rotation around the guess when the robot turned
    /// faster than ICP's basin.
    pub(super) fn starts(&self) -> Vec<Pose2> {
        let (input, params, policy) = (self.input, self.config.align, self.config.starts);
        let (guess, anchor) = (input.guess, input.anchor);
        let mut starts = vec![guess];
        if policy.also_start_at_anchor && anchor != guess {
            starts.insert(0, anchor);
        }
        // Odometry is checked against the scans' own motion: where the odometry increment and
        // the constant-velocity one disagree (a slip, a bad turn), ICP also runs from the
        // latter, and the better fit wins.
        if let Some(cv) = self.odometry_disagrees() {
            starts.push(cv);
        }
        // After a gap in the log the guess spans the gap's time; the robot may have moved
        // only about one step's worth in it (a robot that waited or slowed).
        if let Some(one_step) = input.after_gap.filter(|p| !starts.contains(p)) {
            starts.push(one_step);
        }
        // After a lost scan, whose pose is a poor fit, also from the last `ok` pose, with
        // odometry moved by it since then (with point-to-segment ICP: `--preset paper` stays
        // as it was, as in `within_reach`).
        if params.method == AlignMethod::PointToSegment
            && input.lost_streak > 0
            && !starts.contains(&input.restart)
        {
            starts.push(input.restart);
        }
        let searched = rotation_search(self.points, input.map, guess, params);
        if searched != guess {
            starts.push(searched);
        }
        starts
    }

    /// ICP from the best pose (and its rival, if any) of a window search over the whole circle
    /// within [`RECOVER_TRANSLATION_M`] of the anchor; the result with the most inliers.
    /// `None` when there is no map near.
    pub(super) fn recover(&self) -> Option<AlignResult> {
        let window = SearchWindow {
            center: self.input.anchor,
            half_xy_m: RECOVER_TRANSLATION_M,
            half_theta_rad: std::f64::consts::PI,
        };
        let loose = self.input.loose.all();
        let map = self.input.map;
        let found = window_search(
            map,
            &loose,
            self.points,
            &window,
            None,
            self.config.tracking,
        )?;
        best_of(
            std::iter::once(found.best)
                .chain(found.rival()) // a second start
                .map(|c| self.run_near(c.map_from_robot)),
        )
    }

    /// One ICP run from `start` with the configured correspondences; `near` are the map
    /// segments near the scan for endpoint ICP (unused by point-to-segment ICP).
    pub(super) fn run(&self, near: &[Segment], start: Pose2) -> AlignResult {
        self.run_with(near, start, None)
    }

    /// The pose `result` found, weighed with the odometry's step ([`odometry_prior`]): ICP
    /// from it minimizing the fit plus the prior. `None` without the odometry's step
    /// ([`TrackInput::odometry_step`]), or where the pose so found still lies beyond the
    /// odometry's spread ([`odometry_contradicts`]): the fit insists on a motion the odometry
    /// cannot explain (a slipping or stalled wheel, or a candidate that stood against the
    /// odometry and won), and keeps its own pose.
    pub(super) fn weighed(&self, result: &AlignResult) -> Option<AlignResult> {
        let input = self.input;
        let step = input.odometry_step?;
        let prior = odometry_prior(input.guess, &step);
        // Along a direction the fit cannot observe, ICP puts the pose on its anchor: with
        // odometry, its guess, the prior's own pose.
        debug_assert_eq!(input.unobserved_to, prior.pose);
        let start = result.map_from_robot;
        let near = match self.config.align.method {
            AlignMethod::PointToSegment => Vec::new(),
            AlignMethod::Endpoints => segments_near(input, &start, self.config.align)?,
        };
        let held = self.run_with(&near, start, Some(&prior));
        (!odometry_contradicts(&input.guess, &held.map_from_robot, &step)).then_some(held)
    }

    fn run_with(&self, near: &[Segment], start: Pose2, prior: Option<&PosePrior>) -> AlignResult {
        let (input, params) = (self.input, self.config.align);
        let anchor = input.unobserved_to;
        let result = match params.method {
            AlignMethod::PointToSegment => self.align_on(self.points, start, prior),
            AlignMethod::Endpoints => align_endpoints(
                input.segments_in_robot,
                input.map,
                near,
                start,
                anchor,
                prior,
                params,
            ),
        };
        self.tried(&result);
        result
    }

    /// Point-to-segment ICP of `points` (robot frame; the scan's thinned points or some of
    /// them) from `start` (map frame), matching the loose points too, weighing `prior`, with
    /// the fallback of the unobserved; not recorded as a try.
    pub(super) fn align_on(
        &self,
        points: &[Vec2],
        start: Pose2,
        prior: Option<&PosePrior>,
    ) -> AlignResult {
        let input = self.input;
        let (map, anchor) = (input.map, input.unobserved_to);
        align_points_and_loose(
            points,
            map,
            self.targets,
            start,
            anchor,
            prior,
            self.config.align,
        )
    }

    /// Records an ICP run ([`TriedPose`]) where the attempt keeps them.
    pub(super) fn tried(&self, result: &AlignResult) {
        if let Some(tries) = self.tries {
            tries.borrow_mut().push(TriedPose::of(result));
        }
    }

    /// One ICP run from a pose far from the guess: [`Attempt::run`] with the map segments near
    /// `start` for endpoint ICP.
    pub(super) fn run_near(&self, start: Pose2) -> AlignResult {
        let near = match self.config.align.method {
            AlignMethod::PointToSegment => Vec::new(),
            AlignMethod::Endpoints => {
                segments_near(self.input, &start, self.config.align).unwrap_or_default()
            }
        };
        self.run(&near, start)
    }

    /// The constant-velocity prediction, with the odometry prior, when it differs from the
    /// odometry guess by more than `tracking.odometry.odometry_check_m` or `odometry_check_deg`.
    pub(super) fn odometry_disagrees(&self) -> Option<Pose2> {
        if self.config.starts.motion_prior != MotionPrior::Odometry {
            return None;
        }
        let cv = self.input.constant_velocity?;
        let d = self.input.guess.between(&cv);
        let t = self.config.tracking;
        (d.translation().length() > t.odometry.odometry_check_m
            || d.theta_rad.abs().to_degrees() > t.odometry.odometry_check_deg)
            .then_some(cv)
    }

    /// With the odometry prior (`tracking.reversed_odometry`), the last `ok` pose
    /// ([`TrackInput::last_ok`]) moved by the odometry's motion since then (to
    /// [`TrackInput::restart`]) with its translation reversed and its turn kept; `None` for a
    /// motion under `tracking.search.search_above_step_m` (ICP's basin covers it reversed).
    pub(super) fn reversed_odometry(&self) -> Option<Pose2> {
        let (input, tracking) = (self.input, self.config.tracking);
        let odometry = self.config.starts.motion_prior == MotionPrior::Odometry;
        if !(odometry && tracking.reversed_odometry) {
            return None;
        }
        let d = input.last_ok.between(&input.restart);
        (d.translation().length() >= tracking.search.search_above_step_m).then(|| {
            input
                .last_ok
                .compose(&Pose2::new(-d.x_m, -d.y_m, d.theta_rad))
        })
    }

    /// Whether ICP from the scans' own motion (`from_cv`) overrules ICP from the odometry's
    /// starts (`from_odometry`): it fits better ([`better`]) and at least
    /// `tracking.search.search_below_inlier_share` of the points. Where both fit poorly, a few more
    /// inliers are no evidence against odometry (ACES with odometry every 10th scan: turns
    /// odometry read right, 41° and −87°, taken 23° and 95° off from the constant-velocity
    /// start at 50 % and 44 % of the points; the maps 7.7 and 17.3 m off the dense run).
    pub(super) fn overrules_odometry(
        &self,
        from_cv: &AlignResult,
        from_odometry: &AlignResult,
    ) -> bool {
        self.prefers(from_cv, from_odometry) && !self.fits_poorly(from_cv)
    }

    /// Whether `pose` lies where the robot could be only if the odometry failed
    /// ([`odometry_contradicts`]); false without the odometry's step.
    pub(super) fn beyond_odometry_spread(&self, pose: &Pose2) -> bool {
        self.input
            .odometry_step
            .is_some_and(|step| odometry_contradicts(&self.input.guess, pose, &step))
    }

    /// Whether `pose` lies where the robot could be only if its speed changed beyond a robot's
    /// acceleration ([`speed_contradicts`] about the constant-velocity prediction); false
    /// without the speed's spread (`TrackInput::speed_spread_m`).
    fn beyond_speed_spread(&self, pose: &Pose2) -> bool {
        let input = self.input;
        input
            .speed_spread_m
            .is_some_and(|spread| speed_contradicts(&input.unobserved_to, pose, spread))
    }

    /// Whether the speed's spread excludes `other` ([`Attempt::beyond_speed_spread`]) and
    /// allows `current`, a distinct place: `other` then must win by ratio
    /// ([`Attempt::wins_by_ratio`]), as against the odometry. Without it a rival, a searched
    /// pose or one along a weakly observed axis that fits as well took the scan where a robot
    /// cannot be (the simulated ring with a 360° laser every 3rd scan, seed 3: in a bare
    /// hallway a pose 0.84 m behind the prediction of a robot going 0.15 m a scan, ambiguous,
    /// fitting a box as well; 0.44 m ATE with no warning, 0.05 m with this).
    pub(super) fn against_speed(&self, other: &AlignResult, current: &AlignResult) -> bool {
        let (a, b) = (&other.map_from_robot, &current.map_from_robot);
        self.beyond_speed_spread(a)
            && !self.beyond_speed_spread(b)
            && self.config.tracking.apart(a, b)
    }

    /// Whether the odometry contradicts `other` ([`Attempt::beyond_odometry_spread`]) and allows
    /// `current`, a distinct place (`tracking.verdict.rival_apart_m`, `rival_apart_deg`): two
    /// poses a few centimetres apart, one of them just past the spread of a turn on the spot,
    /// are one place. `other` then must win by ratio ([`Attempt::wins_by_ratio`]), as a pose
    /// away from the prediction does: a failed wheel is rarer than a scan that fits a pose a
    /// quarter turn away nearly as well (Intel with odometry, every 10th scan, a nuisance
    /// variant, phase 6, scan 850: the constant-velocity start's ICP, 90° and 1.1 m from the
    /// odometry's guess, took the scan with 79 inliers against the odometry's 78, and the map
    /// went 10.8 m off).
    fn against_odometry(&self, other: &AlignResult, current: &AlignResult) -> bool {
        let (a, b) = (&other.map_from_robot, &current.map_from_robot);
        self.beyond_odometry_spread(a)
            && !self.beyond_odometry_spread(b)
            && self.config.tracking.apart(a, b)
    }

    /// Whether `other` explains the scan better than `current`, the odometry's spread weighed
    /// in: by ratio against the odometry ([`Attempt::against_odometry`]), otherwise the
    /// [`better`] fit.
    fn prefers(&self, other: &AlignResult, current: &AlignResult) -> bool {
        match self.against_odometry(other, current) {
            true => self.wins_by_ratio(other, current),
            false => better(other, current),
        }
    }

    /// Where ICP observed a direction by about one point only (weakest information under
    /// [`PINNED_BELOW_INFORMATION`], every direction above the solver's threshold), ICP again
    /// from its pose without the points that beams running along a segment put by its end
    /// ([`align_points_past_ends`]); its pose when that leaves the direction unobservable (put
    /// on the fallback, `TrackInput::unobserved_to`): the one point was such a point, which
    /// moves with the robot and would hold it still (the simulated ring: a side beam by the end
    /// of a box's face held a robot for 150 scans while it drove 7.5 m on). Point-to-segment ICP
    /// only.
    pub(super) fn unpinned(&self, result: &AlignResult) -> Option<AlignResult> {
        let (input, params) = (self.input, self.config.align);
        let info = result.translation_information.weakest;
        let pinned = params.method == AlignMethod::PointToSegment
            && result.weak_directions == 0
            && info > 0.0
            && info < PINNED_BELOW_INFORMATION;
        if !pinned {
            return None;
        }
        let free = align_points_past_ends(
            self.points,
            input.map,
            self.targets,
            result.map_from_robot,
            input.unobserved_to,
            None,
            params,
        );
        self.tried(&free);
        (free.weak_directions > 0 && free.weak_directions < 3).then_some(free)
    }
}
