//! Where each scan is, as far as the mapper is concerned: the motion prior's guess and
//! anchor, and the state [`crate::align::track_scan`] needs (the constant-velocity prediction,
//! the recent motion, the lost streak, the loose points). The strategy itself (the ICP
//! starts, the recovery, the window search, the verdict) lives in [`crate::align`].

use super::*;

impl Mapper {
    /// The first guess for the new scan's pose, the anchor ("no motion": the previous pose),
    /// and the pose that directions ICP cannot observe fall back to, all map frame.
    ///
    /// The constant-velocity guess seeds ICP. With `keep_observed_velocity` (once a motion was
    /// observed), the fallback is the previous pose moved by the last observed motion; a motion
    /// taken from the prior never feeds back, so it cannot run on by itself. Otherwise the fallback keeps
    /// `weak_direction_velocity` of the last motion (0: the previous pose). The odometry guess
    /// is evidence of motion and is its own anchor and fallback.
    pub(super) fn guess(&self, odom_from_robot: Option<Pose2>) -> (Pose2, Pose2, Pose2) {
        let prior = self.config.mapper.motion_prior;
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
                let Some(prev) = self.prev_pose else {
                    return (last, last, last);
                };
                let v = prev.between(&last);
                let predicted = last.compose(&v);
                match self.observed.motion() {
                    Some(m) if self.config.mapper.keep_observed_velocity => {
                        (predicted, last, last.compose(&m))
                    }
                    _ => {
                        let f = self.config.mapper.weak_direction_velocity.clamp(0.0, 1.0);
                        let damped =
                            last.compose(&Pose2::new(v.x_m * f, v.y_m * f, v.theta_rad * f));
                        (predicted, damped, damped)
                    }
                }
            }
            MotionPrior::Odometry => {
                let g = match (self.last_odom, odom_from_robot) {
                    (Some(a), Some(b)) => last.compose(&a.between(&b)),
                    _ => last,
                };
                (g, g, g)
            }
        }
    }

    /// The pose of the scan and the verdict on it, from [`crate::align::track_scan`] with the
    /// mapper's state; the pose is `None` when there is nothing to align to.
    pub(super) fn align(
        &self,
        scan: &PreparedScan,
        guess: Pose2,
        anchor: Pose2,
        unobserved_to: Pose2,
    ) -> (Option<AlignResult>, Tracking) {
        let (reference, dt_s) = reach_reference(self.last_ok, scan.stamp_s, guess);
        let constant_velocity = match (self.prev_pose, self.last_pose) {
            (Some(prev), Some(last)) => Some(last.compose(&prev.between(&last))),
            _ => None,
        };
        let input = TrackInput {
            points_in_robot: &scan.points_in_robot,
            segments_in_robot: &scan.segments_in_robot,
            map: &self.map,
            loose: &self.loose,
            guess,
            anchor,
            unobserved_to,
            reference,
            dt_s,
            constant_velocity,
            recent: &self.recent,
            lost_streak: self.lost_streak,
        };
        let config = TrackConfig {
            align: &self.config.align,
            tracking: &self.config.tracking,
            starts: &self.config.mapper,
        };
        track_scan(&input, &config)
    }
}

/// How many recent time steps give the typical one.
const TYPICAL_DT_STEPS: usize = 15;

/// The last motion observed between two scans (`mapper.keep_observed_velocity`): the step from
/// a scan tracked `ok` with every direction observed to the next such scan, robot frame of the
/// first; not from a step whose stamps say it spans a gap or a burst (under half or over twice
/// the median of the recent time steps), nor from a corner pose (a correction of the earlier
/// error, not a motion). A motion taken from the prior never updates it, so it cannot run on.
#[derive(Debug, Clone, Default)]
pub(super) struct ObservedSpeed {
    motion: Option<Pose2>,
    last_observed: bool,
    last_stamp_s: Option<f64>,
    /// The recent positive time steps, seconds: a ring of [`TYPICAL_DT_STEPS`], the first
    /// `filled` valid, the next written at `next`.
    dts: [f64; TYPICAL_DT_STEPS],
    filled: usize,
    next: usize,
}

impl ObservedSpeed {
    /// The last observed motion, robot frame of the scan it started from.
    pub(super) fn motion(&self) -> Option<Pose2> {
        self.motion
    }

    /// Takes the step to the scan just tracked (`None` for the first), whether that scan was
    /// observed (`ok`, every direction, not a corner pose), and its stamp (seconds).
    pub(super) fn record(&mut self, step: Option<Pose2>, observed: bool, stamp_s: Option<f64>) {
        let dt = match (self.last_stamp_s, stamp_s) {
            (Some(a), Some(b)) if b > a => Some(b - a),
            _ => None,
        };
        let typical = self.typical_dt_s();
        let usual = match (dt, typical) {
            (Some(dt), Some(m)) => (0.5 * m..=2.0 * m).contains(&dt),
            _ => true,
        };
        if let Some(step) = step.filter(|_| observed && self.last_observed && usual) {
            self.motion = Some(step);
        }
        if let Some(dt) = dt {
            self.dts[self.next] = dt;
            self.next = (self.next + 1) % TYPICAL_DT_STEPS;
            self.filled = (self.filled + 1).min(TYPICAL_DT_STEPS);
        }
        self.last_observed = observed;
        self.last_stamp_s = stamp_s;
    }

    /// The median of the recent time steps, once there are a third of the ring.
    fn typical_dt_s(&self) -> Option<f64> {
        if self.filled < TYPICAL_DT_STEPS / 3 {
            return None;
        }
        let mut sorted = self.dts;
        let sorted = &mut sorted[..self.filled];
        sorted.sort_unstable_by(f64::total_cmp);
        Some(sorted[sorted.len() / 2])
    }
}

/// The pose a scan's motion is bounded from, and the seconds since it: the last `ok` pose is
/// where the robot was for sure, and the time since then bounds how far it can be now, when
/// the stamps say it (both known, increasing); otherwise `fallback` and no bound.
fn reach_reference(
    last_ok: Option<(u32, Pose2, Option<f64>)>,
    stamp_s: Option<f64>,
    fallback: Pose2,
) -> (Pose2, Option<f64>) {
    match (last_ok, stamp_s) {
        (Some((_, pose, Some(a))), Some(b)) if b > a => (pose, Some(b - a)),
        _ => (fallback, None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_observed_speed_comes_only_from_observed_steps_at_the_usual_rate() {
        let step = Pose2::new(0.1, 0.0, 0.0);
        let mut speed = ObservedSpeed::default();
        // The first observed scan has no step; the second gives one.
        speed.record(None, true, Some(0.0));
        assert_eq!(speed.motion(), None);
        for k in 1..=10 {
            speed.record(Some(step), true, Some(0.1 * k as f64));
        }
        assert_eq!(speed.motion(), Some(step));
        // An unobserved scan's step (taken from the prior) never updates it, nor does the
        // next one, which starts from the unobserved scan.
        let filled = Pose2::new(0.3, 0.0, 0.0);
        speed.record(Some(filled), false, Some(1.1));
        speed.record(Some(filled), true, Some(1.2));
        assert_eq!(speed.motion(), Some(step));
        // A step across a gap (1 s where 0.1 s is usual) or a burst (1 ms) is no speed.
        speed.record(Some(filled), true, Some(2.2));
        speed.record(Some(filled), true, Some(2.201));
        assert_eq!(speed.motion(), Some(step));
        // Back at the usual rate it is.
        let faster = Pose2::new(0.15, 0.0, 0.0);
        speed.record(Some(faster), true, Some(2.3));
        assert_eq!(speed.motion(), Some(faster));
        // Without stamps every observed step counts.
        let mut unstamped = ObservedSpeed::default();
        unstamped.record(None, true, None);
        unstamped.record(Some(faster), true, None);
        assert_eq!(unstamped.motion(), Some(faster));
    }

    #[test]
    fn the_reach_is_bounded_only_when_the_stamps_increase() {
        let ok = Pose2::new(1.0, 2.0, 0.3);
        let fallback = Pose2::IDENTITY;
        let at = |stamp: Option<f64>| Some((7, ok, stamp));
        assert_eq!(
            reach_reference(at(Some(10.0)), Some(10.25), fallback),
            (ok, Some(0.25))
        );
        // Bunched, reordered or missing stamps say nothing about the time.
        for (last, now) in [
            (Some(10.0), Some(10.0)),
            (Some(10.0), Some(9.0)),
            (None, Some(1.0)),
            (Some(1.0), None),
        ] {
            assert_eq!(reach_reference(at(last), now, fallback), (fallback, None));
        }
        assert_eq!(reach_reference(None, Some(1.0), fallback), (fallback, None));
    }
}
