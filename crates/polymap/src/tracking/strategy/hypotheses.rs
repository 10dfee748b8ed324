//! Poses away from the prediction: corner hypotheses, the window search's rival, and the bounds
//! they must keep to win (the robot's reach in the stamps' time, the turn from odometry's
//! guess, a clear margin of inliers).

use super::{Attempt, best_of};
use crate::align::{AlignMethod, AlignResult, Candidate};
use crate::geometry::{Pose2, Vec2, normalize_angle_rad};
use crate::tracking::corner_seeds;
use crate::tracking::params::{
    CORNER_RIVAL_BELOW, CORNER_RIVAL_TURN_DEG, CORNER_WIN_RATIO, OWN_STEP_REFINED,
    OWN_STEP_SCREEN_EVERY, SEARCH_WIN_MARGIN,
};
use crate::tracking::params::{MotionPrior, TrackParams};
use crate::tracking::verdict::{Tracking, Verdict, verdict};

/// How far a winning corner pose may turn the scan from the guess: with the odometry prior, as
/// far as the window search may while tracking (`tracking.odometry.odometry_max_window_deg`): its guess carries
/// the turn, and a bad odometry turn is off by tens of degrees, not half a turn; a corridor's
/// corners fit a scan turned half round nearly as well as the truth (Intel with odometry,
/// every 5th scan, with 4 loop candidates per node: a pose 178° off the odometry guess took
/// over a lost scan as `ok`, 61 of 114 points inliers against 37). Without odometry the whole
/// circle: after a wrong turn the constant-velocity guess may be off by more than the window
/// (ACES every 2nd scan, phase 1: a corner pose more than 90° from the guess brought the run
/// from 0.911 to 0.424 m).
pub(super) fn corner_turn_rad(odometry: bool, tracking: &TrackParams) -> f64 {
    match odometry {
        false => std::f64::consts::PI,
        true => tracking.widest_window_deg(true).to_radians(),
    }
}

impl Attempt<'_> {
    /// ICP from the best distinct corner hypotheses ([`corner_seeds`]) near the guess that
    /// score above `current`'s pose; the best of them when it has `CORNER_WIN_RATIO`
    /// times `current`'s inliers (plus two), at least `tracking.search.search_below_inlier_share` of
    /// the points are inliers, and no distinct pose from another hypothesis, turned at most
    /// `CORNER_RIVAL_TURN_DEG` farther from the guess, has `CORNER_RIVAL_BELOW` of its inliers.
    pub(super) fn icp_from_corners(&self, current: &AlignResult) -> Option<AlignResult> {
        let input = self.input;
        let tracking = self.config.tracking;
        let seeds = corner_seeds(
            input.map,
            &input.loose.all(),
            self.points,
            input.segments_in_robot,
            &input.guess,
            Some(&current.map_from_robot),
            tracking,
        );
        let all: Vec<AlignResult> = seeds
            .iter()
            .map(|c| self.run_near(c.map_from_robot))
            .collect();
        // Only a pose within the turn bound may win; any pose may veto it as a rival.
        let Some(best) = best_of(all.iter().copied().filter(|r| {
            self.within_turn_bound(&r.map_from_robot) && self.within_reach(&r.map_from_robot)
        })) else {
            return self.icp_from_own_steps(current);
        };
        // A pose away from the prediction needs more evidence than one near it: half again
        // the inliers, a fit that would need no search, and no distinct pose nearly as good
        // and as plausible a turn from the guess (a building of alike rooms fits a scan turned
        // by a right angle almost as well; a corridor, turned half round).
        let turn = |p: &Pose2| normalize_angle_rad(p.theta_rad - input.guess.theta_rad).abs();
        let as_plausible = |r: &AlignResult| {
            turn(&r.map_from_robot)
                <= turn(&best.map_from_robot) + CORNER_RIVAL_TURN_DEG.to_radians()
        };
        match self.wins_by_ratio(&best, current) && !self.rivalled(&best, &all, as_plausible) {
            true => Some(best),
            false => self.icp_from_own_steps(current),
        }
    }

    /// Where no corner pose won, ICP from the previous pose moved by steps like the robot's
    /// own ([`StepsSeen::hypotheses`](crate::tracking::StepsSeen::hypotheses)), screened
    /// ([`Attempt::screened`]): ICP on every point from the best two the screen found; the
    /// better when it wins by ratio over `current` within reach, and the other, if distinct,
    /// has not `CORNER_RIVAL_BELOW` of its inliers, as for a corner pose. Not with the odometry
    /// prior, whose guess already holds the step. Orebro (sparse), scan 61: after steps of about 1 m
    /// the robot drove 3.05 m turning 13°, 2 m beyond the window; no corner was in view, ICP
    /// from the starts fitted 32 % of the points and the scan was lost, and the seven scans of
    /// the spin that followed with it. A step of 3 m and 15° from the robot's own reaches it,
    /// at 73 %.
    pub(super) fn icp_from_own_steps(&self, current: &AlignResult) -> Option<AlignResult> {
        if self.config.starts.motion_prior == MotionPrior::Odometry {
            return None;
        }
        let all: Vec<AlignResult> = self
            .screened(&self.own_step_starts())
            .iter()
            .map(|&start| self.run_near(start))
            .collect();
        let best = best_of(
            all.iter()
                .copied()
                .filter(|r| self.within_reach(&r.map_from_robot)),
        )?;
        (self.wins_by_ratio(&best, current) && !self.rivalled(&best, &all, |_| true))
            .then_some(best)
    }

    /// The starts of the own-step hypotheses (map frame): the previous pose moved by each
    /// step of [`StepsSeen::hypotheses`](crate::tracking::StepsSeen::hypotheses).
    pub(super) fn own_step_starts(&self) -> Vec<Pose2> {
        let input = self.input;
        let steps = input.steps_seen.hypotheses();
        steps
            .iter()
            .map(|step| input.anchor.compose(step))
            .collect()
    }

    /// Where ICP on every point should run among `starts` (map frame): the poses ICP on every
    /// [`OWN_STEP_SCREEN_EVERY`]th point finds from them (a start itself where the screen had
    /// too few correspondences to move it), the best [`OWN_STEP_REFINED`] distinct ones (apart
    /// as a rival is); ICP from a screened pose starts near where it ends. The screening runs
    /// are not recorded as tries (their inliers count a third of the points). Not screened
    /// with endpoint ICP (`--preset paper`): every start.
    pub(super) fn screened(&self, starts: &[Pose2]) -> Vec<Pose2> {
        if self.config.align.method != AlignMethod::PointToSegment {
            return starts.to_vec();
        }
        let few: Vec<Vec2> = self
            .points
            .iter()
            .step_by(OWN_STEP_SCREEN_EVERY)
            .copied()
            .collect();
        let least = self.config.align.min_correspondences;
        let screened: Vec<AlignResult> = starts
            .iter()
            .map(|&start| {
                let r = self.align_on(&few, start, None);
                // Too few correspondences: ICP put the pose on the fallback, not near a fit.
                match r.correspondences >= least {
                    true => r,
                    false => AlignResult {
                        map_from_robot: start,
                        ..r
                    },
                }
            })
            .collect();
        // The best, then the best apart from every one kept.
        let tracking = self.config.tracking;
        let mut chosen: Vec<Pose2> = Vec::with_capacity(OWN_STEP_REFINED);
        while chosen.len() < OWN_STEP_REFINED {
            let apart =
                |r: &AlignResult| chosen.iter().all(|c| tracking.apart(c, &r.map_from_robot));
            let Some(next) = best_of(screened.iter().copied().filter(apart)) else {
                break;
            };
            chosen.push(next.map_from_robot);
        }
        chosen
    }

    /// Whether a pose among `all` that `counts` lies apart from `best` (more than
    /// `tracking.verdict.rival_apart_m` or `rival_apart_deg`) with `CORNER_RIVAL_BELOW` of its
    /// inliers: a hypothesis nearly as good elsewhere vetoes the best.
    fn rivalled(
        &self,
        best: &AlignResult,
        all: &[AlignResult],
        counts: impl Fn(&AlignResult) -> bool,
    ) -> bool {
        all.iter().any(|r| {
            self.config
                .tracking
                .apart(&best.map_from_robot, &r.map_from_robot)
                && r.inliers as f64 >= CORNER_RIVAL_BELOW * best.inliers as f64
                && counts(r)
        })
    }

    /// Whether `pose` turns at most [`corner_turn_rad`] from the guess (any turn without
    /// odometry), or from the scans' own motion where odometry disagrees with it (a stalled
    /// wheel reads a turn the robot did not make): a pose far from the guess (a corner pose,
    /// ICP from the search's rival) may win only within it.
    pub(super) fn within_turn_bound(&self, pose: &Pose2) -> bool {
        let odometry = self.config.starts.motion_prior == MotionPrior::Odometry;
        let max_turn = corner_turn_rad(odometry, self.config.tracking);
        let from = |p: &Pose2| normalize_angle_rad(pose.theta_rad - p.theta_rad).abs();
        let turned = match self.odometry_disagrees() {
            Some(cv) => from(&self.input.guess).min(from(&cv)),
            None => from(&self.input.guess),
        };
        turned <= max_turn
    }

    /// Whether `pose` is within reach of the last `ok` pose in the time since that scan
    /// (`tracking.reach.max_speed_m_s`, `max_turn_deg_s`, plus `REACH_SLACK_M`, `REACH_SLACK_DEG`);
    /// true when the stamps do not say (unknown, or not increasing), and with endpoint ICP
    /// (`--preset paper` stays as it was).
    pub(super) fn within_reach(&self, pose: &Pose2) -> bool {
        let (input, tracking) = (self.input, self.config.tracking);
        let point_to_segment = self.config.align.method == AlignMethod::PointToSegment;
        let Some(dt) = input.dt_s.filter(|_| point_to_segment) else {
            return true;
        };
        let d = input.reference.between(pose);
        let (reach_m, reach_deg) = tracking.reach(dt);
        d.translation().length() <= reach_m
            && normalize_angle_rad(d.theta_rad).abs().to_degrees() <= reach_deg
    }

    /// ICP from the window search's `rival` pose, with its verdict, when that fit observes
    /// every direction, is not `lost`, and beats `current` as a search's pose must
    /// ([`Attempt::search_pose_wins`]).
    pub(super) fn rival_fits_better(
        &self,
        rival: &Candidate,
        current: &AlignResult,
    ) -> Option<(AlignResult, Tracking)> {
        let fit = self.run_near(rival.map_from_robot);
        let judged = verdict(
            Some(&fit),
            self.points.len(),
            self.input.map.is_empty(),
            self.config.tracking,
        );
        // Every direction observed (by few points, maybe: FR079's true pose of the case above
        // was `weakly_observed`, the mirror image `ok`), and no verdict of `lost`.
        let sound = fit.weak_directions == 0 && judged.verdict != Verdict::Lost;
        // With odometry, no further from its guess than a corner pose may turn: in a corridor
        // the scan turned half round fits nearly as well (Intel every 5th scan on faulty
        // odometry, phase 2, scan 2099: a lost pose on the right heading, 35 inliers, taken
        // over by the rival turned 180°, 46; 0.06 → 1.54 m).
        let turn = self.within_turn_bound(&fit.map_from_robot);
        (sound && turn && self.search_pose_wins(&fit, current)).then_some((fit, judged))
    }

    /// Whether `other`, ICP from a search's pose, beats `current`: more inliers by
    /// `SEARCH_WIN_MARGIN` (plus two), or by ratio where the speed's spread excludes it and
    /// allows `current` ([`Attempt::against_speed`]); within reach ([`Attempt::within_reach`]).
    pub(super) fn search_pose_wins(&self, other: &AlignResult, current: &AlignResult) -> bool {
        let wins = match self.against_speed(other, current) {
            true => self.wins_by_ratio(other, current),
            false => {
                other.inliers as f64 > current.inliers as f64 * (1.0 + SEARCH_WIN_MARGIN) + 2.0
            }
        };
        wins && self.within_reach(&other.map_from_robot)
    }

    /// Whether `other`, a pose away from the prediction, has `CORNER_WIN_RATIO`
    /// times `current`'s inliers (plus two) and at least `tracking.search.search_below_inlier_share`
    /// of the points (the corner poses' rule).
    pub(super) fn wins_by_ratio(&self, other: &AlignResult, current: &AlignResult) -> bool {
        let tracking = self.config.tracking;
        let n = self.points.len() as f64;
        other.inliers as f64 >= CORNER_WIN_RATIO * current.inliers as f64 + 2.0
            && other.inliers as f64 >= tracking.search.search_below_inlier_share * n
    }

    /// Whether `other`, a pose away from the prediction, beats `current` clearly: it wins by
    /// ratio ([`Attempt::wins_by_ratio`]) and observes every direction with at least
    /// `tracking.verdict.weak_below_information`.
    pub(super) fn wins_clearly(&self, other: &AlignResult, current: &AlignResult) -> bool {
        self.wins_by_ratio(other, current)
            && other.weak_directions == 0
            && other.translation_information.weakest
                >= self.config.tracking.verdict.weak_below_information
    }
}
