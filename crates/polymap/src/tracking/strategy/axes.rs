//! The rules along an axis ICP observed weakly or not at all: a pose put on the fallback is
//! searched and checked along the axis, a weak observation far from the speed last observed
//! gives way to ICP from it, and a fast robot that ICP, on weak evidence, says stopped is
//! checked along the axis or called `slowed`.

use super::{
    Attempt, PRIOR_OVER_WEAK_M, STOPPED_BELOW_SHARE_OF_STEP, UNOBSERVED_ACROSS_M,
    UNOBSERVED_SEED_STEP_M, UNOBSERVED_TURN_DEG, best_of,
};
use crate::align::AlignResult;
use crate::geometry::{Pose2, Vec2, normalize_angle_rad};
use crate::tracking::params::MotionPrior;
use crate::tracking::params::UNOBSERVED_REACH_M;
use crate::tracking::verdict::{Reason, verdict};

/// Whether `other` lies within [`UNOBSERVED_ACROSS_M`] of `result` across `axis` (map frame,
/// unit vector) and within [`UNOBSERVED_TURN_DEG`] of its heading: it agrees with `result` in
/// the directions `result` observed, and differs, if at all, along the axis.
pub(super) fn agrees_across(other: &AlignResult, result: &AlignResult, axis: Vec2) -> bool {
    let moved = other.map_from_robot.translation() - result.map_from_robot.translation();
    let turned = other.map_from_robot.theta_rad - result.map_from_robot.theta_rad;
    moved.perp_dot(axis).abs() <= UNOBSERVED_ACROSS_M
        && normalize_angle_rad(turned).abs() <= UNOBSERVED_TURN_DEG.to_radians()
}

impl Attempt<'_> {
    /// The map-frame axis (unit vector) along which ICP put `result` on its fallback
    /// (`TrackInput::unobserved_to`) for want of information, where
    /// [`Attempt::checks_along_axes`]. `None` when every translation was observed, or only the
    /// rotation was not.
    pub(super) fn unobserved(&self, result: &AlignResult) -> Option<Vec2> {
        let on = self.checks_along_axes() && result.weak_directions > 0;
        let axis = result.weak_direction_deg.filter(|_| on)?.to_radians();
        Some(Vec2::new(axis.cos(), axis.sin()))
    }

    /// Whether a pose may be checked along an axis ICP observed weakly or not at all
    /// (`tracking.search_unobserved`): while tracking (nothing lost just before), with the
    /// window search on, and without the odometry prior, whose guess is evidence of the motion.
    pub(super) fn checks_along_axes(&self) -> bool {
        let tracking = self.config.tracking;
        tracking.search_unobserved
            && tracking.search.enabled
            && self.input.lost_streak == 0
            && self.config.starts.motion_prior != MotionPrior::Odometry
    }

    /// Where ICP observed the step along an axis only weakly and put it away from the
    /// fallback of the unobserved (the last observed motion), ICP from the fallback's place
    /// along the axis, at the pose's heading; its pose when it fits at least as many points and
    /// agrees across the axis and in rotation: a weak observation that fits no better does not
    /// overrule the robot's speed.
    pub(super) fn prior_over_weak(&self, result: &AlignResult) -> Option<AlignResult> {
        let (input, tracking) = (self.input, self.config.tracking);
        let info = result.translation_information;
        // The fallback differs from "no motion" only with the constant-velocity prior and
        // `mapper.keep_observed_velocity`, once a motion was observed.
        let on = input.lost_streak == 0
            && input.unobserved_to != input.anchor
            && result.weak_directions == 0
            && info.weakest < tracking.verdict.weak_below_information;
        if !on {
            return None;
        }
        let axis = info.weakest_axis();
        let start = result.map_from_robot;
        let along = (input.unobserved_to.translation() - start.translation()).dot(axis);
        if along.abs() <= PRIOR_OVER_WEAK_M {
            return None;
        }
        // The fallback along the axis only: its heading carries the last observed step's
        // turn, stale where that step turned (a corner before a corridor), and the walls
        // observe the heading.
        let moved = axis * along;
        let prior = self.run_near(Pose2::new(
            start.x_m + moved.x,
            start.y_m + moved.y,
            start.theta_rad,
        ));
        (prior.inliers >= result.inliers && agrees_across(&prior, result, axis)).then_some(prior)
    }

    /// Whether ICP's pose `searched` is evidence of the step along `axis` that ICP's pose
    /// `result` could not observe: it observes every direction, agrees with `result` in the
    /// directions `result` did observe (across the axis, and the rotation), and fits as many
    /// points (by ratio where the speed's spread excludes it: [`Attempt::against_speed`]).
    pub(super) fn evidence_along(
        &self,
        searched: &AlignResult,
        result: &AlignResult,
        axis: Vec2,
    ) -> bool {
        let tracking = self.config.tracking;
        searched.weak_directions == 0
            && searched.translation_information.weakest >= tracking.verdict.weak_below_information
            && agrees_across(searched, result, axis)
            && searched.inliers >= result.inliers
            && (!self.against_speed(searched, result) || self.wins_by_ratio(searched, result))
    }

    /// ICP from poses along `axis` (every [`UNOBSERVED_SEED_STEP_M`] up to
    /// `UNOBSERVED_REACH_M` either side of `result`): the best that is evidence of
    /// the step ([`Attempt::evidence_along`]), unless a distinct one is evidence too; `None`
    /// without `tracking.along_unobserved`.
    pub(super) fn along_unobserved(&self, result: &AlignResult, axis: Vec2) -> Option<AlignResult> {
        let tracking = self.config.tracking;
        if !tracking.along_unobserved {
            return None;
        }
        let steps = (UNOBSERVED_REACH_M / UNOBSERVED_SEED_STEP_M).floor() as i32;
        let origin = result.map_from_robot;
        let passed: Vec<AlignResult> = (-steps..=steps)
            .filter(|&k| k != 0)
            .map(|k| {
                let d = axis * (k as f64 * UNOBSERVED_SEED_STEP_M);
                self.run_near(Pose2::new(
                    origin.x_m + d.x,
                    origin.y_m + d.y,
                    origin.theta_rad,
                ))
            })
            .filter(|r| self.evidence_along(r, result, axis))
            .collect();
        let best = best_of(passed.iter().copied())?;
        let rival = passed
            .iter()
            .any(|r| tracking.apart(&best.map_from_robot, &r.map_from_robot));
        (!rival).then_some(best)
    }

    /// The map-frame axis (unit vector) along which ICP observed `result` only weakly (its
    /// verdict would be `weakly_observed`: otherwise a good fit) and put it less than
    /// [`STOPPED_BELOW_SHARE_OF_STEP`] of the longest recent step from the anchor (ahead, in
    /// the sense of the speed last observed where that is at least `search_above_step_m`
    /// along the axis: a step back counts as none), while the robot moved at least
    /// `tracking.search.search_above_step_m` per scan lately: a fast robot that ICP, on weak
    /// evidence, says stopped, slowed down or backing (also where the fallback was not tried
    /// because the pose lies near it); only where [`Attempt::checks_along_axes`].
    pub(super) fn stopped_on_weak_evidence(&self, result: &AlignResult) -> Option<Vec2> {
        let (input, tracking) = (self.input, self.config.tracking);
        let info = result.translation_information;
        let recent = input.recent.step_m();
        let on = self.checks_along_axes()
            && recent >= tracking.search.search_above_step_m
            // A fit whose only doubt is that one direction: a poor fit is doubtful in every
            // direction, and "agrees across" says nothing about it.
            && verdict(Some(result), self.points.len(), false, tracking).reason
                == Reason::WeaklyObserved;
        let axis = info.weakest_axis();
        // Ahead in the sense of the speed last observed, where it says one: a step back
        // against it is no less a stop.
        let (ahead, _) = self.moved_along(result, axis);
        (on && ahead < STOPPED_BELOW_SHARE_OF_STEP * recent).then_some(axis)
    }

    /// The direction (map frame, degrees) along which `result` fell short of the last observed
    /// motion on weak evidence (`tracking.verdict.slowed_below_information`): without the odometry
    /// prior, its least observed translation has less information than that, the last
    /// observed motion ([`TrackInput::unobserved_to`]) went at least `search_above_step_m`
    /// along it, and `result` moved less than [`STOPPED_BELOW_SHARE_OF_STEP`] of that along
    /// it from the anchor.
    pub(super) fn slowed(&self, result: &AlignResult) -> Option<f64> {
        let tracking = self.config.tracking;
        let info = result.translation_information;
        let on = tracking.verdict.slowed_below_information > 0.0
            && self.config.starts.motion_prior != MotionPrior::Odometry
            && info.weakest < tracking.verdict.slowed_below_information;
        let axis = info.weakest_axis();
        let short = match self.moved_along(result, axis) {
            (ahead, Some(expected)) => ahead < STOPPED_BELOW_SHARE_OF_STEP * expected,
            (_, None) => false,
        };
        (on && short).then_some(info.weakest_deg)
    }

    /// How far `result` lies from the anchor along `axis` (map frame, unit vector), metres:
    /// signed, ahead positive, in the sense of the speed last observed (the fallback,
    /// `TrackInput::unobserved_to`) where that moves at least `tracking.search.search_above_step_m`
    /// along the axis, with that speed's length along it; otherwise unsigned, and `None`.
    pub(super) fn moved_along(&self, result: &AlignResult, axis: Vec2) -> (f64, Option<f64>) {
        let input = self.input;
        let from = input.anchor.translation();
        let moved = (result.map_from_robot.translation() - from).dot(axis);
        let expected = (input.unobserved_to.translation() - from).dot(axis);
        // `expected` ≠ 0: the sign of −0.0 would turn `moved` round where the step may be 0.
        match expected != 0.0 && expected.abs() >= self.config.tracking.search.search_above_step_m {
            true => (moved * expected.signum(), Some(expected.abs())),
            false => (moved.abs(), None),
        }
    }

    /// A robot put short of its usual step on weak evidence, checked against its own steps.
    /// Where ICP observed the step along an axis only weakly (under
    /// `tracking.verdict.slowed_below_information`; the fit's only doubt, not a poor fit), that
    /// axis runs along the robot's heading ([`OWN_STEP_ALONG_HEADING`]), the robot moved at
    /// least `search_above_step_m` lately, and its sure steps turned alike have a usual length
    /// ([`StepsSeen::usual_length`], spread within [`OWN_STEP_SPREAD_SHARE`] of it: a log
    /// thinned by travel, a robot at a steady speed) that `result`'s step falls short of by
    /// more than twice the spread: ICP from poses along the axis (every
    /// [`UNOBSERVED_SEED_STEP_M`] up to `UNOBSERVED_REACH_M` either side, and at the usual
    /// length). Of those that agree across the axis, observe every direction and fit within
    /// [`OWN_STEP_INLIER_MARGIN`] inliers (or 2 %) of the best, not beyond the usual length by
    /// more than twice the spread, the one nearest it, where nearer than `result` by more than
    /// the spread: the fit bounds the step, the robot's own steps choose within the bound. A
    /// step longer than usual stays (a gap in a log's travel).
    ///
    /// [`StepsSeen::usual_length`]: crate::tracking::StepsSeen::usual_length
    pub(super) fn own_step_along(&self, result: &AlignResult) -> Option<AlignResult> {
        let input = self.input;
        let info = result.translation_information;
        let tracking = self.config.tracking;
        // A robot that moved lately, whose fit's only doubt is that axis (a poor fit doubts
        // every direction, and "agrees across" says nothing of it).
        let only_doubt = || {
            let reason = verdict(Some(result), self.points.len(), false, tracking).reason;
            matches!(
                reason,
                Reason::Fit | Reason::WeaklyObserved | Reason::Degenerate
            )
        };
        let on = self.checks_along_axes()
            && info.weakest < tracking.verdict.slowed_below_information
            && input.recent.step_m() >= tracking.search.search_above_step_m
            && only_doubt();
        if !on {
            return None;
        }
        // The weak axis must run along the robot's heading: a pose moved across it is no
        // longer or shorter a step.
        let axis = info.weakest_axis();
        let heading = Vec2::new(input.anchor.theta_rad.cos(), input.anchor.theta_rad.sin());
        let ahead = axis.dot(heading);
        if ahead.abs() < OWN_STEP_ALONG_HEADING {
            return None;
        }
        let step = input.anchor.between(&result.map_from_robot);
        let (usual, spread) = input.steps_seen.usual_length(step.theta_rad)?;
        let spread = spread.max(OWN_STEP_MIN_SPREAD_M);
        // A robot that drives forward at a steady step.
        if usual < tracking.search.search_above_step_m || spread > OWN_STEP_SPREAD_SHARE * usual {
            return None;
        }
        let signed = |r: &AlignResult| {
            let s = input.anchor.between(&r.map_from_robot);
            let l = s.translation().length();
            if s.x_m < 0.0 { -l } else { l }
        };
        let off = |r: &AlignResult| (signed(r) - usual).abs();
        // Only a step short of the usual one (a robot put stopped, slowed or backing on weak
        // evidence): a long step may be a gap in the log's travel.
        // Compared so that a step that is not a number goes no further.
        let short = signed(result) < usual - 2.0 * spread;
        if !short {
            return None;
        }
        let origin = result.map_from_robot;
        let steps = (UNOBSERVED_REACH_M / UNOBSERVED_SEED_STEP_M).floor() as i32;
        let mut seeds: Vec<f64> = (-steps..=steps)
            .filter(|&k| k != 0)
            .map(|k| k as f64 * UNOBSERVED_SEED_STEP_M)
            .collect();
        // The place on the axis where the step has the usual length.
        seeds.push((usual - signed(result)) / ahead);
        let mut tried: Vec<AlignResult> = seeds
            .into_iter()
            .map(|d| {
                let m = axis * d;
                self.run_near(Pose2::new(
                    origin.x_m + m.x,
                    origin.y_m + m.y,
                    origin.theta_rad,
                ))
            })
            .filter(|r| agrees_across(r, result, axis))
            .collect();
        tried.push(*result);
        let best = tried.iter().map(|r| r.inliers).max()?;
        let floor = best.saturating_sub(OWN_STEP_INLIER_MARGIN.max(best / 50));
        let chosen = tried
            .iter()
            .filter(|r| r.inliers >= floor && r.weak_directions == 0)
            .filter(|r| signed(r) <= usual + 2.0 * spread)
            .min_by(|a, b| off(a).total_cmp(&off(b)))?;
        (off(chosen) + spread < off(result)).then_some(*chosen)
    }
}

/// The weak axis runs along the robot's heading where the cosine between them is at least
/// this (within about 25°).
pub const OWN_STEP_ALONG_HEADING: f64 = 0.9;

/// The robot's usual step tells nothing where its sure steps spread (half their interquartile
/// range) over more than this share of it: a robot that speeds up and slows down. A log
/// thinned by travel (the sparse logs, one scan a metre) spreads a few per cent.
pub const OWN_STEP_SPREAD_SHARE: f64 = 0.25;

/// The spread of the usual step is taken as at least this, metres: the steps of a log thinned
/// by travel may agree more closely than a step is tracked.
pub const OWN_STEP_MIN_SPREAD_M: f64 = 0.05;

/// Poses along the axis within this many inliers of the best (or 2 % of them, the larger) fit
/// as well: along a corridor ICP stops at fixed points a few decimetres apart whose inliers
/// differ by a few (ACES sparse, scan 316: 122-124 from 0.1 m back to 0.9 m ahead).
pub const OWN_STEP_INLIER_MARGIN: usize = 2;
