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
