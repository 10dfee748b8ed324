//! The parameters of tracking: `[tracking]` ([`TrackParams`]: how many scans may look for
//! their place on a saved map, and the subsections `[tracking.search]` (when and how wide
//! the window search runs), `[tracking.verdict]` (the verdict's thresholds), `[tracking.reach]`
//! (the robot's speed limits) and `[tracking.odometry]` (the checks of and by the log's
//! odometry)) and `[mapper]` ([`MapperParams`]: the motion prior and where ICP starts). The
//! values that are no user's choice are the constants of `fixed.rs`; the on/off switches of
//! single rules are fields that are no keys, for tests to show a rule's effect. No other
//! module of tracking is imported here, so that the configuration tree composes these without
//! importing the mapper.

mod fixed;
mod mapper;
mod sections;

use serde::{Deserialize, Serialize};

use crate::check::{Checks, InvalidParam};
use crate::geometry::{Pose2, normalize_angle_rad};

pub use fixed::*;
pub use mapper::{MapperParams, MotionPrior};
pub use sections::{OdometryCheckParams, ReachParams, VerdictParams, WindowSearchParams};

/// Parameters of tracking (section `[tracking]` and its subsections).
///
/// The fields marked *not a key* turn single rules on and off: they are always on in a run
/// (no configuration file sets them), and tests turn them off to show what the rule does.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrackParams {
    /// A run on a saved map (`--resume`, `localize`) that has not placed itself after this
    /// many scans stops with an error (each unplaced scan costs a global search).
    pub start_search_scans: u32,
    /// When and how wide the window search runs (`[tracking.search]`).
    pub search: WindowSearchParams,
    /// The verdict's thresholds (`[tracking.verdict]`).
    pub verdict: VerdictParams,
    /// The robot's speed limits (`[tracking.reach]`).
    pub reach: ReachParams,
    /// The checks of and by the log's odometry (`[tracking.odometry]`).
    pub odometry: OdometryCheckParams,
    /// Not a key (tests turn it off). While ICP's pose fits under
    /// `search.search_below_inlier_share` of the points, the window also grows to
    /// [`WINDOW_PER_RECENT`] times the recent motion (off: the prediction alone).
    #[serde(skip, default = "on")]
    pub recent_window: bool,
    /// Not a key (tests turn it off). While tracking (no scan lost just before) with the
    /// window search on and without the odometry prior: a scan whose ICP pose was put on its
    /// fallback along an axis ICP could not observe (no evidence of the motion along it) is
    /// searched whatever the predicted motion, in the usual window, and the search's pose wins
    /// without [`SEARCH_WIN_MARGIN`] when ICP from it observes every direction (translation
    /// information at least `verdict.weak_below_information`), lies within
    /// [`crate::tracking::UNOBSERVED_ACROSS_M`] across the axis and
    /// [`crate::tracking::UNOBSERVED_TURN_DEG`] of ICP's pose, and fits at least as many
    /// points: a corridor's far frames out of ICP's robust reach are the only evidence of a
    /// step along it, and the margin is no test of evidence against none.
    #[serde(skip, default = "on")]
    pub search_unobserved: bool,
    /// Not a key (tests turn it off). With `search_unobserved`: when neither ICP nor the
    /// window search observed the step along the axis, ICP also runs from poses along the
    /// axis, up to [`UNOBSERVED_REACH_M`] on either side of ICP's pose, and the pose that
    /// passes the same test wins, unless a distinct one (`verdict.rival_apart_m`) passes too:
    /// a robot that starts along a corridor from a stop, or a scan far apart from the last,
    /// moves beyond the window the prediction gives.
    #[serde(skip, default = "on")]
    pub along_unobserved: bool,
    /// Not a key (tests turn it off). Whether scans that are `weak` for a poor fit or an
    /// ambiguous search still enter the map (lost scans never do).
    #[serde(skip, default = "on")]
    pub merge_doubtful_scans: bool,
    /// Not a key (tests turn it off). ICP also matches scan points that no map segment
    /// explains to the loose points farther than
    /// [`LOOSE_OFF_MAP_M`](crate::tracking::LOOSE_OFF_MAP_M) from every map segment (point to
    /// line on a line of them, point to point on a compact blob: see
    /// [`crate::align::PointTargets`]): door frames, pillars and clutter then observe the
    /// motion along a corridor whose walls alone cannot.
    #[serde(skip, default = "on")]
    pub icp_loose_points: bool,
    /// Not a key (tests turn it off). A robot that stood still (the predicted step and every
    /// recent step within `search.search_above_step_m`; with the odometry prior, the recent
    /// steps) whose pose still fits under `search.search_below_inlier_share` of the points
    /// after the window search is searched again around the prediction, as far as it can turn
    /// since the last `ok` scan ([`TrackParams::reach`]); ICP from that search's pose wins
    /// with [`CORNER_WIN_RATIO`] times the inliers (plus two), within
    /// `search.search_above_step_m` of the anchor and within reach: a turn on the spot.
    #[serde(skip, default = "on")]
    pub turn_on_the_spot: bool,
    /// Not a key (tests turn it off). Without the odometry prior, a scan after a gap in stamps
    /// that keep time whose pose from the starts fits under `search.search_below_inlier_share`
    /// of the points is searched as far as the robot can go and turn in the time since the
    /// last `ok` scan ([`TrackParams::reach`] up to `search.max_window_m` and the widest
    /// rotation window).
    #[serde(skip, default = "on")]
    pub gap_window: bool,
    /// Not a key (tests turn it off). With the odometry prior, a pose that still fits under
    /// `search.search_below_inlier_share` of the points is also sought from the odometry's
    /// motion since the last `ok` scan with its direction of travel reversed (odometry that
    /// reads the distance but not the direction: FR079 backing up reads forward); that pose
    /// wins with [`CORNER_WIN_RATIO`] times the inliers (plus two), at least
    /// `search.search_below_inlier_share` of the points, and every direction observed with at
    /// least `verdict.weak_below_information`.
    #[serde(skip, default = "on")]
    pub reversed_odometry: bool,
    /// Not a key (tests turn it off). When the final pose is still `lost` or a `poor_fit`, or
    /// (point-to-segment ICP) fits under `search.search_below_inlier_share` of the points
    /// whatever its verdict (the motion went beyond the window search), pose hypotheses from
    /// the scan's corners matched to the map's corners seed ICP (see
    /// [`crate::tracking::corner_seeds`]); with the odometry prior turned at most
    /// `odometry.odometry_max_window_deg` from its guess, otherwise any turn.
    #[serde(skip, default = "on")]
    pub corner_hypotheses: bool,
}

/// The default of the switches that are no keys: on.
fn on() -> bool {
    true
}

impl Default for TrackParams {
    fn default() -> Self {
        TrackParams {
            start_search_scans: 50,
            search: WindowSearchParams::default(),
            verdict: VerdictParams::default(),
            reach: ReachParams::default(),
            odometry: OdometryCheckParams::default(),
            recent_window: true,
            search_unobserved: true,
            along_unobserved: true,
            merge_doubtful_scans: true,
            icp_loose_points: true,
            turn_on_the_spot: true,
            gap_window: true,
            reversed_odometry: true,
            corner_hypotheses: true,
        }
    }
}

impl TrackParams {
    /// Checks every key's range; the error names the first key out of range, with its
    /// subsection (`search.min_window_m`).
    pub fn validate(&self) -> Result<(), InvalidParam> {
        Checks::new()
            .within("start_search_scans", self.start_search_scans, 1, 1_000_000)
            .done()?;
        self.search.validate().map_err(|e| e.in_section("search"))?;
        self.verdict
            .validate()
            .map_err(|e| e.in_section("verdict"))?;
        self.reach.validate().map_err(|e| e.in_section("reach"))?;
        self.odometry
            .validate(self.search.min_window_deg)
            .map_err(|e| e.in_section("odometry"))
    }

    /// How far the robot can go and turn in `dt_s` seconds: `reach.max_speed_m_s` and
    /// `reach.max_turn_deg_s` times it, plus [`REACH_SLACK_M`] and [`REACH_SLACK_DEG`]
    /// (metres, degrees).
    pub fn reach(&self, dt_s: f64) -> (f64, f64) {
        (
            self.reach.max_speed_m_s * dt_s + REACH_SLACK_M,
            self.reach.max_turn_deg_s * dt_s + REACH_SLACK_DEG,
        )
    }

    /// Half-width of the widest rotation window while tracking, degrees:
    /// `search.max_window_deg`, or `odometry.odometry_max_window_deg` with the odometry prior;
    /// never under `search.min_window_deg`.
    pub fn widest_window_deg(&self, odometry: bool) -> f64 {
        let cut = match odometry {
            true => self.odometry.odometry_max_window_deg,
            false => self.search.max_window_deg,
        };
        cut.max(self.search.min_window_deg)
    }

    /// Whether two poses are distinct places: more than `verdict.rival_apart_m` or
    /// `verdict.rival_apart_deg` apart (the rival of a search, of a placement, of a corner
    /// hypothesis).
    pub fn apart(&self, a: &Pose2, b: &Pose2) -> bool {
        let d = a.between(b);
        d.translation().length() > self.verdict.rival_apart_m
            || normalize_angle_rad(d.theta_rad).abs() > self.verdict.rival_apart_deg.to_radians()
    }
}

/// [`UNOBSERVED_REACH_M`] is at least one step of the poses along the axis.
const _: () = assert!(UNOBSERVED_REACH_M >= crate::tracking::UNOBSERVED_SEED_STEP_M);

#[cfg(test)]
mod tests {
    use super::*;

    /// The leaves of a serialized tree (its keys, subsections counted by their keys).
    fn leaves(value: &serde_json::Value) -> usize {
        match value {
            serde_json::Value::Object(map) => map.values().map(leaves).sum(),
            _ => 1,
        }
    }

    /// `[tracking]` keeps what a user may need to change: at most 30 keys, subsections
    /// included.
    #[test]
    fn the_tracking_section_has_at_most_30_keys() {
        let tree = serde_json::to_value(TrackParams::default()).unwrap();
        let keys = leaves(&tree);
        assert!(keys <= 30, "[tracking] has {keys} keys");
    }

    /// The switches that are no keys are on after reading a configuration, and a file that
    /// names one is refused with its name.
    #[test]
    fn the_rule_switches_are_on_and_no_keys() {
        let read: TrackParams =
            serde_json::from_str(r#"{"search": {"max_window_m": 2.0}}"#).unwrap();
        let expected = TrackParams {
            search: WindowSearchParams {
                max_window_m: 2.0,
                ..WindowSearchParams::default()
            },
            ..TrackParams::default()
        };
        assert_eq!(read, expected);
        let e = serde_json::from_str::<TrackParams>(r#"{"corner_hypotheses": false}"#)
            .expect_err("refused");
        assert!(
            e.to_string().contains("unknown field `corner_hypotheses`"),
            "{e}"
        );
    }

    #[test]
    fn the_widest_odometry_window_is_at_least_the_smallest_window() {
        let mut p = TrackParams::default();
        p.odometry.odometry_max_window_deg = 10.0;
        let e = p.validate().expect_err("refused");
        assert_eq!(e.key, "odometry.odometry_max_window_deg");
    }
}
