//! What the last scans leave for the next: their largest steps and turns ([`RecentMotion`],
//! which sizes the window search) and their points that no map segment explains
//! ([`LoosePoints`], which the search raster and ICP match).

use crate::geometry::{Pose2, Vec2, normalize_angle_rad};

/// The largest step and turn over the last few scans.
#[derive(Debug, Clone, Default)]
pub struct RecentMotion {
    steps: std::collections::VecDeque<(f64, f64)>,
}

impl RecentMotion {
    /// How many scans are remembered.
    pub const SCANS: usize = 5;

    /// Records the motion from one scan's pose to the next's.
    pub fn push(&mut self, from: &Pose2, to: &Pose2) {
        let d = from.between(to);
        self.steps.push_back((
            d.translation().length(),
            normalize_angle_rad(d.theta_rad).abs(),
        ));
        while self.steps.len() > Self::SCANS {
            self.steps.pop_front();
        }
    }

    /// The longest recent step, metres (0 before any).
    pub fn step_m(&self) -> f64 {
        self.steps.iter().map(|s| s.0).fold(0.0, f64::max)
    }

    /// The largest recent turn, degrees (0 before any).
    pub fn turn_deg(&self) -> f64 {
        self.steps
            .iter()
            .map(|s| s.1)
            .fold(0.0, f64::max)
            .to_degrees()
    }
}

/// With `tracking.icp_loose_points`, a loose point at least this far from every map segment is
/// one the map leaves unexplained, metres (closer, it is a sample of a mapped wall, which
/// ICP matches to the segment).
pub const LOOSE_OFF_MAP_M: f64 = 0.15;

/// Keeps the loose points of the last scans: points of a tracked scan (robot frame, placed by
/// `map_from_robot`) farther than `off_m` from the map, thinned.
#[derive(Debug, Clone, Default)]
pub struct LoosePoints {
    scans: std::collections::VecDeque<Vec<Vec2>>,
}

impl LoosePoints {
    /// Adds one scan's points (map frame, already filtered to those off the map), keeping the
    /// last `keep_scans` scans.
    pub fn push(&mut self, points_in_map: Vec<Vec2>, keep_scans: usize) {
        self.scans.push_back(points_in_map);
        while self.scans.len() > keep_scans {
            self.scans.pop_front();
        }
    }

    /// Every kept point, map frame.
    pub fn all(&self) -> Vec<Vec2> {
        self.scans.iter().flatten().copied().collect()
    }

    /// Moves every kept point by `new_from_old` (a loop correction).
    pub fn transform(&mut self, new_from_old: &Pose2) {
        for p in self.scans.iter_mut().flatten() {
            *p = new_from_old.transform_point(*p);
        }
    }
}
