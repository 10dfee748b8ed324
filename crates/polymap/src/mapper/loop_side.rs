//! The mapper's side of [`crate::loops`]: a loop correction applied to the map, the trajectory
//! and the tracker, and the doubt on a scan's motion the pose graph gets.

use super::Mapper;
use crate::geometry::Vec2;
use crate::loops::{Correction, MotionDoubt};
use crate::tracking::{Reason, Tracking, Verdict};

impl Mapper {
    /// Moves every map segment, scan pose and the motion state by the correction of the node
    /// it was born in (segments merged later than their node's end move with the node of
    /// their last merge).
    pub(super) fn apply_correction(&mut self, c: &Correction) {
        let Some(last) = c.new_from_old.last().copied() else {
            return;
        };
        // Node 0 starts at the map's scan `loop_base` (0 for a new map): segments born before
        // it (an earlier run's) never move.
        let base = self.loop_base;
        let first_new = self.loops.first_new_node();
        let start = self.loops.node_start(c.first_node.max(first_new));
        let first_scan = (base as u64 + start as u64).min(u32::MAX as u64) as u32;
        let delta = |t: u32| {
            let n = self.loops.node_of(t.saturating_sub(base));
            n.checked_sub(c.first_node)
                .and_then(|i| c.new_from_old.get(i).copied())
                .unwrap_or(last)
        };
        // Segments that move less than this stay (re-indexing is the costly part).
        const STAY_M: f64 = 5e-4;
        let moved: Vec<_> = self
            .map
            .iter()
            .filter(|(_, s)| s.born_scan >= first_scan)
            .filter_map(|(id, s)| {
                let d = delta(s.born_scan);
                let segment = s.segment.transformed(&d);
                let far = segment.start.distance_squared(s.segment.start) > STAY_M * STAY_M
                    || segment.end.distance_squared(s.segment.end) > STAY_M * STAY_M;
                far.then_some((id, segment))
            })
            .collect();
        self.map.move_segments(&moved);
        let run_first = self.first_scan;
        for (i, pose) in self
            .trajectory
            .iter_mut()
            .enumerate()
            .skip(first_scan.saturating_sub(run_first) as usize)
        {
            *pose = delta(run_first.saturating_add(i as u32)).compose(pose);
        }
        // The tracker's last poses move too, so the next step does not count the correction as
        // motion; a pose older than the first node the correction moves stays (`delta` would
        // give it the newest node's correction).
        let t = (run_first + self.scans).saturating_sub(1);
        self.tracker.apply_correction(t, first_scan, delta);
    }
}

/// The doubt on a scan's motion for the pose graph: along the direction ICP could not observe
/// when the scan is `weak` for it (`degenerate`: the motion along it came from the prior),
/// else none. (Doubting `weakly_observed` scans too, or poor, ambiguous and lost fits in every
/// direction, let wrong loop edges bend Intel: `docs/decisions/2026-11-21-loop-closure.md`.)
pub(super) fn motion_doubt(tracking: &Tracking) -> MotionDoubt {
    match (
        tracking.verdict,
        tracking.reason,
        tracking.weak_direction_deg,
    ) {
        (Verdict::Weak, Reason::Degenerate, Some(deg)) => {
            let (s, c) = deg.to_radians().sin_cos();
            MotionDoubt::Along(Vec2::new(c, s))
        }
        _ => MotionDoubt::None,
    }
}
