//! The window search for one scan: when it runs, its window (the prediction, the recent
//! motion, odometry's disagreement, a gap's time), whether its pose wins over ICP's from the
//! starts, and the wider search of a robot that may have turned on the spot.

use super::{Aligned, Attempt, fits_nearly_as_well};
use crate::align::{AlignResult, SearchWindow};
use crate::geometry::{Pose2, Vec2, normalize_angle_rad};
use crate::tracking::params::MotionPrior;
use crate::tracking::params::{CORNER_WIN_RATIO, RELOCALIZE_EVERY_LOST};
use crate::tracking::recent::RecentMotion;
use crate::tracking::window::{search_window, should_search, whole_map_window, window_search};

impl Attempt<'_> {
    /// ICP from the starts, the recovery, the window search (see [`Attempt::icp`]).
    pub(super) fn icp_and_search(&self) -> Aligned {
        let input = self.input;
        let Some(from_starts) = self.icp_from_starts() else {
            return Aligned::icp(None);
        };
        // A recovered pose turned as far as the motion may have turned replaces ICP's from the
        // starts; one turned farther is held until the window search has run, and must beat
        // its pose (`settle`).
        let (result, held) = match self.recovered(&from_starts) {
            Some(r) if self.within_turn_window(&r, &from_starts) => (r, None),
            held => (from_starts, held),
        };
        let tracking = self.config.tracking;
        let (guess, anchor, lost_streak) = (input.guess, input.anchor, input.lost_streak);
        let unobserved = self.unobserved(&result);
        if unobserved.is_none()
            && !should_search(
                &guess,
                &anchor,
                input.recent,
                Some(&result),
                self.points.len(),
                lost_streak,
                tracking,
            )
        {
            return self.settle(held, Aligned::icp(Some(result)));
        }
        let every = RELOCALIZE_EVERY_LOST;
        let global = every > 0 && lost_streak > 0 && lost_streak.is_multiple_of(every);
        let aligned = match global
            .then(|| whole_map_window(input.map, &guess))
            .flatten()
        {
            Some(w) => self.search_in(&w, result, unobserved),
            None => {
                let window = self.window(&result);
                let aligned = self.search_in(&window, result, unobserved);
                self.turned_on_the_spot(aligned, &window)
            }
        };
        self.settle(held, aligned)
    }

    /// A `held` recovered pose against the pose `aligned` kept. Where both found the same pose
    /// (not apart by `tracking.verdict.rival_apart_m` or `rival_apart_deg`), the recovered one
    /// stands, the window search confirming it; where it fits `CORNER_WIN_RATIO` times the
    /// points (plus two), it stands as ICP's from the starts would, the window's outcome (its
    /// rival) being about a pose it beat.
    fn settle(&self, held: Option<AlignResult>, aligned: Aligned) -> Aligned {
        let tracking = self.config.tracking;
        match (held, aligned.result) {
            (Some(held), Some(kept))
                if !tracking.apart(&kept.map_from_robot, &held.map_from_robot) =>
            {
                Aligned {
                    result: Some(held),
                    search_won: false,
                    second_fit: false,
                    ..aligned
                }
            }
            (Some(held), Some(kept))
                if held.inliers as f64 > kept.inliers as f64 * CORNER_WIN_RATIO + 2.0 =>
            {
                Aligned::icp(Some(held))
            }
            _ => aligned,
        }
    }

    /// The recovery (`mapper.recover_below_inlier_share`; not with the odometry prior: the
    /// guess already carries the turn, and a poor fit after a gap means stale odometry, which
    /// the next increment makes good): where ICP from the starts fits under that share of the
    /// points, ICP from a window search over the whole circle within [`RECOVER_TRANSLATION_M`]
    /// of the anchor ([`Attempt::recover`]), when it fits well (twice that share) and doubles
    /// the inliers; a turned scan that is merely less bad is likelier a coincidence of the
    /// search.
    fn recovered(&self, from_starts: &AlignResult) -> Option<AlignResult> {
        let policy = self.config.starts;
        let share = policy.recover_below_inlier_share;
        let n = self.points.len() as f64;
        if (from_starts.inliers as f64) >= share * n || policy.motion_prior == MotionPrior::Odometry
        {
            return None;
        }
        self.recover()
            .filter(|r| r.inliers as f64 >= 2.0 * share * n && r.inliers >= 2 * from_starts.inliers)
    }

    /// Whether `recovered` is turned from the motion prior's guess by no more than the window
    /// search's rotation window ([`Attempt::window`] for ICP's result `from_starts`): as far
    /// as the motion may have turned. The whole circle around the anchor also holds a
    /// building's twins, which may fit better than the true pose where the scan after a sharp
    /// turn sees much that is not yet mapped: in the simulated 45° hallway at one scan per
    /// metre, a 45° turn fitted 7 % of the points from the starts, the whole circle's best
    /// pose, turned 135° from the guess, 86 %, and the true turn, in the window, 64 %. A
    /// recovered pose turned farther must beat the window search's by `CORNER_WIN_RATIO`, as
    /// a corner pose must. Its translation does not decide: at every 10th FR079 scan the true
    /// pose lies over a metre from the constant-velocity guess (a robot that stops or backs),
    /// where the recovery, fitting 27–39 % more points than the window search's pose, finds it.
    fn within_turn_window(&self, recovered: &AlignResult, from_starts: &AlignResult) -> bool {
        let window = self.window(from_starts);
        let turn = window.center.between(&recovered.map_from_robot).theta_rad;
        turn.abs() <= window.half_theta_rad
    }

    /// Whether ICP's `result` fits under `tracking.search.search_below_inlier_share` of the points.
    pub(super) fn fits_poorly(&self, result: &AlignResult) -> bool {
        let share = result.inliers as f64 / self.points.len().max(1) as f64;
        share < self.config.tracking.search.search_below_inlier_share
    }

    /// The window around the prediction ([`search_window`]); while ICP's `result` fits poorly
    /// ([`Attempt::fits_poorly`]), also as wide as the recent motion
    /// (`tracking.recent_window`, `WINDOW_PER_RECENT`): the robot may have moved on at its recent speed after a
    /// stop, or turned as it did lately; and with the odometry prior, as far as the
    /// constant-velocity guess where odometry disagrees with it; after a gap in the log
    /// ([`TrackInput::after_gap`]), as far as the robot can go and turn in the gap's time. The
    /// recent motion is every step tracked, corrections after a poor fit included: at worst a
    /// few scans get the widest window.
    pub(super) fn window(&self, result: &AlignResult) -> SearchWindow {
        let (input, tracking) = (self.input, self.config.tracking);
        let poor = self.fits_poorly(result);
        let none = RecentMotion::default();
        let recent = match poor {
            true => input.recent,
            false => &none,
        };
        // Where odometry disagrees with the scans' own motion and fits poorly (a slip, a
        // stalled wheel's turn), the window reaches from the odometry's pose towards the
        // constant-velocity one (its heading always, its position up to `max_window_m`).
        let anchor = match poor {
            true => self.odometry_disagrees().unwrap_or(input.anchor),
            false => input.anchor,
        };
        let odometry = self.config.starts.motion_prior == MotionPrior::Odometry;
        let mut window = search_window(
            &input.guess,
            &anchor,
            recent,
            input.lost_streak,
            odometry,
            tracking,
        );
        // After a gap in the log (scans missing; `tracking.gap_window`), as far as the robot
        // can go and turn in the gap's time (`within_reach`'s bounds, the translation up to
        // `max_window_m`): over a gap the last motion, even scaled to the gap's time, says
        // little (a robot that turned on the spot before a 3 s gap moved 0.6 m in it).
        let after_gap = input.after_gap.filter(|_| tracking.gap_window && poor);
        if let (Some(one_step), Some(dt)) = (after_gap, input.dt_s) {
            let (reach_m, _) = tracking.reach(dt);
            let reach_m = reach_m.min(
                tracking
                    .search
                    .max_window_m
                    .max(tracking.search.min_window_m),
            );
            window.half_xy_m = window.half_xy_m.max(reach_m);
            window.half_theta_rad = window.half_theta_rad.max(self.turn_reach_rad(dt));
            window = spanning(&window, &one_step);
        }
        window
    }

    /// The turn the robot can make in `dt` seconds ([`TrackParams::reach`]), up to the widest
    /// window, radians.
    pub(super) fn turn_reach_rad(&self, dt: f64) -> f64 {
        let odometry = self.config.starts.motion_prior == MotionPrior::Odometry;
        let (_, reach_deg) = self.config.tracking.reach(dt);
        reach_deg
            .min(self.config.tracking.widest_window_deg(odometry))
            .min(180.0)
            .to_radians()
    }

    /// A robot that stood still (predicted and recent steps under `search_above_step_m`; with
    /// the odometry prior the anchor is odometry's guess, so the recent steps decide) and
    /// still fits poorly after the window search may have turned on the spot, which neither
    /// the prediction nor the recent motion foresees (`tracking.turn_on_the_spot`): searched
    /// again around the prediction with the rotation window as wide as the robot can turn
    /// since the last `ok` scan (`within_reach`'s bound), seeded with the pose kept. ICP from
    /// that search's pose wins as a corner pose does, by `CORNER_WIN_RATIO` times the
    /// inliers (plus two), and only on the spot (within `search_above_step_m` of the anchor)
    /// and within reach: a scan that fits poorly at its true pose (people in view) finds some
    /// turned pose that fits a little better, often off the spot (FR079 every 3rd scan: a pose
    /// turned 85° and 0.38 m away fitting 54 % against 34 %). A robot on the move keeps its
    /// window: along a corridor, a pose turned half round fits as well.
    pub(super) fn turned_on_the_spot(&self, aligned: Aligned, window: &SearchWindow) -> Aligned {
        let (input, tracking) = (self.input, self.config.tracking);
        let on = tracking.turn_on_the_spot;
        let Some(kept) = aligned.result.filter(|r| on && self.fits_poorly(r)) else {
            return aligned;
        };
        let still = input.anchor.between(&input.guess).translation().length()
            <= tracking.search.search_above_step_m
            && input.recent.step_m() <= tracking.search.search_above_step_m;
        let Some(reach_rad) = input
            .dt_s
            .filter(|_| still)
            .map(|dt| self.turn_reach_rad(dt))
        else {
            return aligned;
        };
        if reach_rad <= window.half_theta_rad {
            return aligned;
        }
        let wide = SearchWindow {
            half_theta_rad: reach_rad,
            ..*window
        };
        let loose = input.loose.all();
        let seed = Some(kept.map_from_robot);
        let Some(found) = window_search(input.map, &loose, self.points, &wide, seed, tracking)
        else {
            return aligned;
        };
        if found.best.map_from_robot == kept.map_from_robot {
            return aligned;
        }
        let turned = self.run_near(found.best.map_from_robot);
        let on_the_spot = input
            .anchor
            .between(&turned.map_from_robot)
            .translation()
            .length()
            <= tracking.search.search_above_step_m;
        let wins = turned.inliers as f64 > kept.inliers as f64 * CORNER_WIN_RATIO + 2.0
            && on_the_spot
            && self.within_reach(&turned.map_from_robot);
        if !wins {
            return aligned;
        }
        Aligned {
            second_fit: fits_nearly_as_well(&kept, &turned, tracking),
            result: Some(turned),
            found: Some(found),
            search_won: true,
            on_the_spot: true,
        }
    }

    /// The window search in `window` and ICP from its best pose against ICP's `result` from
    /// the starts: the search's pose wins by `SEARCH_WIN_MARGIN`, or by evidence
    /// along the `unobserved` axis.
    pub(super) fn search_in(
        &self,
        window: &SearchWindow,
        result: AlignResult,
        unobserved: Option<Vec2>,
    ) -> Aligned {
        let (input, tracking) = (self.input, self.config.tracking);
        let loose = input.loose.all();
        let seed = Some(result.map_from_robot);
        let Some(found) = window_search(input.map, &loose, self.points, window, seed, tracking)
        else {
            return Aligned::icp(Some(result));
        };
        if found.best.map_from_robot == result.map_from_robot {
            // Nothing in the window beat ICP's pose.
            return Aligned {
                found: Some(found),
                ..Aligned::icp(Some(result))
            };
        }
        let searched = self.run_near(found.best.map_from_robot);
        // The search's pose must fit clearly better: along a corridor, or with odometry's good
        // guess, a pose that fits a few more points by coincidence is no evidence.
        // Where ICP had no evidence along an axis, evidence wins over none: ICP from the
        // search's pose must observe every direction, agree with ICP's pose in the directions
        // ICP did observe (across the axis, and the rotation), and fit as many points.
        let evidence = unobserved.is_some_and(|axis| self.evidence_along(&searched, &result, axis));
        // Nor may it lie beyond the robot's reach since the last `ok` scan: after a lost scan
        // the window is the whole circle.
        let search_won = match evidence && !self.against_speed(&searched, &result) {
            true => self.within_reach(&searched.map_from_robot),
            false => self.search_pose_wins(&searched, &result),
        };
        let (kept, other) = match search_won {
            true => (searched, result),
            false => (result, searched),
        };
        let second_fit = fits_nearly_as_well(&other, &kept, tracking);
        Aligned {
            result: Some(kept),
            found: Some(found),
            search_won,
            second_fit,
            on_the_spot: false,
        }
    }
}

/// `window` (around the guess over a gap's time) widened to reach as far around `one_step`,
/// the pose of one time step's motion: centred between the two, each within the window's
/// reach of it (over a gap the robot moved anywhere from about one step to the gap's many).
fn spanning(window: &SearchWindow, one_step: &Pose2) -> SearchWindow {
    let guess = window.center;
    let half_way = guess.translation().lerp(one_step.translation(), 0.5);
    let turn = normalize_angle_rad(one_step.theta_rad - guess.theta_rad);
    SearchWindow {
        center: Pose2::new(half_way.x, half_way.y, guess.theta_rad + 0.5 * turn),
        half_xy_m: window.half_xy_m + 0.5 * guess.translation().distance(one_step.translation()),
        half_theta_rad: (window.half_theta_rad + 0.5 * turn.abs()).min(std::f64::consts::PI),
    }
}
