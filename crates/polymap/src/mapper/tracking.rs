//! Where each scan is: the motion prior's guess, ICP from the starts (the guess, the anchor,
//! the constant-velocity guess when odometry disagrees, the coarse rotation search), the window
//! search when ICP's basin may not reach, the recovery after a gap, and the verdict. The
//! strategies themselves (matchers, windows, verdict rules) live in [`crate::align`]; this is
//! the order the mapper asks them in.

use super::*;

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

/// The recovery searches positions within this distance of the anchor (each axis), metres.
const RECOVER_TRANSLATION_M: f64 = 1.0;

/// True when `a` explains the scan better than `b`: more inliers, then a lower residual.
pub(super) fn better(a: &AlignResult, b: &AlignResult) -> bool {
    (a.inliers, -a.residual_rms_m) > (b.inliers, -b.residual_rms_m)
}

impl Mapper {
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

    /// A window over the whole map and the whole circle, for re-localizing a robot lost for a
    /// while (it may have been carried anywhere); `None` for an empty map.
    fn whole_map_window(&self, guess: &Pose2) -> Option<SearchWindow> {
        let (lo, hi) = crate::align::map_bounds(&self.map)?;
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
    pub(super) fn guess(&self, odom_from_robot: Option<Pose2>) -> (Pose2, Pose2) {
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
    pub(super) fn align(
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
