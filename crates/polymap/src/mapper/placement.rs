//! Placing a run on a saved map: the unplaced scans tracked on a map of their own, a global
//! search over the saved map, ICP of its peaks, and agreement of successive searches (see
//! [`Mapper::on_map`]).

use super::*;
use crate::align::points_along;
use crate::tracking::{SEARCH_CELL_M, SEARCH_SIGMA_M};

/// A start given by the user is searched within this distance (each axis), metres...
const NEAR_START_M: f64 = 1.0;
/// ...and this angle, degrees.
const NEAR_START_DEG: f64 = 30.0;
/// Distinct peaks of a global search refined by ICP: the raster's best is not always ICP's.
const PLACE_PEAKS: usize = 5;
/// A search without a start given places the run when this many searches in a row agree.
const PLACE_AGREEMENT: u32 = 3;
/// The unplaced scans' own map is sampled every this many metres for the global search...
const PLACE_POINT_SPACING_M: f64 = 0.1;
/// ...which searches with its points up to this far from the robot, metres (ICP then verifies
/// each peak with all of them). Farther points need a finer rotation step (the search's cost:
/// about 1 s per scan on Intel's map); with 8 m instead, the second half of Intel placed
/// itself 3 searches in a row at one wrong place.
const PLACE_RANGE_M: f64 = 15.0;

impl Mapper {
    /// Once placed at `pose`, the scans before (tracked on their own map) are placed too: their
    /// poses move into the map's frame and their verdicts turn from lost to weak (placed after
    /// the fact; their segments stay out of the map). Not when the placement itself is lost
    /// (a start the user gave that the scans do not confirm).
    pub(super) fn place_earlier_scans(&mut self, pose: &Pose2, lost: bool) {
        self.search = None;
        self.agreement = None;
        let Some(local) = self.local.take() else {
            return;
        };
        let Some((last, earlier)) = local.trajectory().split_last() else {
            return;
        };
        if lost || earlier.is_empty() {
            return;
        }
        let map_from_local = pose.compose(&last.inverse());
        let first = self.trajectory.len() - earlier.len();
        for (k, p) in earlier.iter().enumerate() {
            self.trajectory[first + k] = map_from_local.compose(p);
        }
        self.tracker
            .relabel_lost_as_weak(first as u32, (first + earlier.len() - 1) as u32);
    }

    /// A scan of a run not yet placed on its saved map: placed by [`Mapper::place`], and taken
    /// into the tracker with the pose found. A run is placed by its first confident match, or
    /// where the user said it starts; until then nothing of it is tracked from, merged or
    /// closed into loops, and a scan without a fit stays at the user's start or at the
    /// tracker's first guess.
    pub(super) fn place_scan(&mut self, at: ScanNumber, scan: &PreparedScan) -> TrackedScan {
        let (align, tracking) = self.place(scan);
        let fallback = match self.placement {
            Placement::Near(start) => start,
            _ => self.tracker.guess(scan.odom_from_robot, scan.stamp_s).0,
        };
        let pose = align.map_or(fallback, |a| a.map_from_robot);
        let lost = tracking.verdict == Verdict::Lost;
        let placed = !lost || matches!(self.placement, Placement::Near(_));
        if placed {
            self.placement = Placement::Placed;
            self.loop_base = at.map;
            self.place_earlier_scans(&pose, lost);
        }
        self.tracker
            .take_pose(at, scan, pose, align, tracking, placed)
    }

    /// Places a scan of a run on a saved map: ICP from the best few peaks of a global search
    /// (or of a search near the user's start), the best fit kept. The verdict is lost unless
    /// the fit is confident in every direction and no distinct pose explains the scan about as
    /// well ([`crate::tracking::TrackParams::ambiguous_above`] of its inliers).
    pub(super) fn place(&mut self, scan: &PreparedScan) -> (Option<AlignResult>, Tracking) {
        let params = self.config.tracking.clone();
        // The scans not yet placed are tracked among themselves, on a map of their own: it is
        // seen from more places than one scan, which tells apart places one scan cannot (two
        // alike rooms, a symmetric ring), and once placed it places them all.
        let mut local_config = self.config.clone();
        local_config.loops.enabled = false;
        let local = self
            .local
            .get_or_insert_with(|| Box::new(Mapper::new(local_config).without_sightings()));
        let local_pose = local.push_prepared(scan.clone()).map_from_robot;
        let robot_from_local = local_pose.inverse();
        let own: Vec<Segment> = local.map().iter().map(|(_, s)| s.segment).collect();
        let mut points: Vec<Vec2> = points_along(&own, PLACE_POINT_SPACING_M)
            .into_iter()
            .map(|p| robot_from_local.transform_point(p))
            .collect();
        if points.is_empty() {
            points = thin_points(&scan.points_in_robot, self.config.align.point_spacing_m);
        }
        let hint = match self.placement {
            Placement::Near(start) => Some((start, NEAR_START_M, NEAR_START_DEG.to_radians())),
            _ => None,
        };
        if self.search.is_none() {
            let (cell_m, sigma_m) = (SEARCH_CELL_M, SEARCH_SIGMA_M);
            self.search = GlobalSearch::new(&self.map, cell_m, sigma_m).map(Box::new);
        }
        let range_m = PLACE_RANGE_M;
        let apart = (
            params.verdict.rival_apart_m,
            params.verdict.rival_apart_deg.to_radians(),
        );
        let peaks = match &self.search {
            Some(search) => search.peaks(&points, hint, PLACE_PEAKS, range_m, apart),
            None => Vec::new(),
        };
        let align = &self.config.align;
        let results: Vec<AlignResult> = peaks
            .iter()
            .map(|c| {
                align_points(
                    &points,
                    &self.map,
                    c.map_from_robot,
                    c.map_from_robot,
                    align,
                )
            })
            .collect();
        let Some(best) = results
            .iter()
            .copied()
            .reduce(|best, r| if better(&r, &best) { r } else { best })
        else {
            let reason = match points.is_empty() {
                true => Reason::NoPoints,
                false => Reason::NotFound,
            };
            let tracking = Tracking {
                verdict: Verdict::Lost,
                reason,
                searched: true,
                ..Tracking::default()
            };
            return (None, tracking);
        };
        let apart = |r: &AlignResult| params.apart(&best.map_from_robot, &r.map_from_robot);
        let rival = results.iter().filter(|r| apart(r)).map(|r| r.inliers).max();
        let mut tracking = verdict(Some(&best), points.len(), false, &params);
        tracking.searched = true;
        tracking.search_won = true;
        if rival.is_some_and(|n| n as f64 >= params.verdict.ambiguous_above * best.inliers as f64) {
            tracking.verdict = Verdict::Lost;
            tracking.reason = Reason::Ambiguous;
        } else if tracking.verdict != Verdict::Ok {
            tracking.verdict = Verdict::Lost;
            tracking.reason = Reason::NotFound;
        }
        // One scan may fit a wrong place better than its own (a scan close to a wall sees
        // little: on Intel one fitted 80 % of its points 9 m and 90° off, 65 % at its true
        // place): a search without a start given must place the scans' own map the same way
        // `PLACE_AGREEMENT` times in a row.
        if self.placement == Placement::Search {
            let agreed = match tracking.verdict {
                Verdict::Ok => {
                    let map_from_local = best.map_from_robot.compose(&robot_from_local);
                    let n = match self.agreement {
                        Some((m, n)) if !params.apart(&m, &map_from_local) => n + 1,
                        _ => 1,
                    };
                    self.agreement = Some((map_from_local, n));
                    n
                }
                _ => {
                    self.agreement = None;
                    0
                }
            };
            if tracking.verdict == Verdict::Ok && agreed < PLACE_AGREEMENT {
                tracking.verdict = Verdict::Lost;
                tracking.reason = Reason::NotFound;
            }
        }
        (Some(best), tracking)
    }
}
