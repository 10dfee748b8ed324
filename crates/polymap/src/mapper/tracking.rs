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
    /// observed), the fallback is the previous pose moved by the last observed motion, and the
    /// guess too when the last scan's own motion was not all observed; a motion taken from the
    /// prior never feeds back, so it cannot run on by itself. Otherwise the fallback keeps
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
                match self.observed_motion {
                    // The last scan's own motion was not all observed: the last observed
                    // motion is the better prediction, and the fallback of the unobserved.
                    Some(m) if self.config.mapper.keep_observed_velocity => {
                        let predicted = if self.last_observed { v } else { m };
                        (last.compose(&predicted), last, last.compose(&m))
                    }
                    _ => {
                        let f = self.config.mapper.weak_direction_velocity.clamp(0.0, 1.0);
                        let damped = Pose2::new(v.x_m * f, v.y_m * f, v.theta_rad * f);
                        (last.compose(&v), last, last.compose(&damped))
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
