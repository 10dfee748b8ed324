//! Where each scan is, as far as the mapper is concerned: the motion prior's guess and
//! anchor, and the state [`crate::align::track_scan`] needs (the constant-velocity prediction,
//! the recent motion, the lost streak, the loose points). The strategy itself (the ICP
//! starts, the recovery, the window search, the verdict) lives in [`crate::align`].

use super::*;

impl Mapper {
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

    /// The pose of the scan and the verdict on it, from [`crate::align::track_scan`] with the
    /// mapper's state; the pose is `None` when there is nothing to align to.
    pub(super) fn align(
        &self,
        scan: &PreparedScan,
        guess: Pose2,
        anchor: Pose2,
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
