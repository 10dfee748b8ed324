//! The subsections of `[tracking]`: `[tracking.search]` ([`WindowSearchParams`]),
//! `[tracking.verdict]` ([`VerdictParams`]), `[tracking.reach]` ([`ReachParams`]) and
//! `[tracking.odometry]` ([`OdometryCheckParams`]).

use serde::{Deserialize, Serialize};

use crate::check::{Checks, InvalidParam};

/// When the window search runs and how wide its window is (section `[tracking.search]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WindowSearchParams {
    /// Search a window around the prediction when the motion is large or ICP fits poorly
    /// (`false` in the paper preset).
    pub enabled: bool,
    /// Search when the predicted motion between scans, or any recent one, is longer than
    /// this, metres...
    pub search_above_step_m: f64,
    /// ...or turns more than this, degrees (either only while ICP's pose from the prediction
    /// fits under [`SEARCH_SKIP_ABOVE_INLIER_SHARE`](crate::tracking::SEARCH_SKIP_ABOVE_INLIER_SHARE)
    /// of the points)...
    pub search_above_turn_deg: f64,
    /// ...or when fewer than this share of the (thinned) scan points are ICP inliers. The
    /// same share is the "poor fit" that the rules after the search (a turn on the spot, the
    /// window after a gap, the reversed odometry, the corner hypotheses) act on.
    pub search_below_inlier_share: f64,
    /// Half-width of the smallest translation window, metres.
    pub min_window_m: f64,
    /// Half-width of the largest translation window while tracking, metres.
    pub max_window_m: f64,
    /// Half-width of the smallest rotation window, degrees.
    pub min_window_deg: f64,
    /// Half-width of the largest rotation window while tracking without the odometry prior,
    /// degrees (180: the whole circle). A constant-velocity guess may be off by any turn: a
    /// robot that turns 60-85° between scans and then turns back (FR079 every 10th scan) is
    /// 100-150° from its guess. With the odometry prior:
    /// `tracking.odometry.odometry_max_window_deg`.
    pub max_window_deg: f64,
}

impl Default for WindowSearchParams {
    fn default() -> Self {
        WindowSearchParams {
            enabled: true,
            search_above_step_m: 0.2,
            search_above_turn_deg: 12.0,
            search_below_inlier_share: 0.5,
            min_window_m: 0.3,
            max_window_m: 1.0,
            min_window_deg: 15.0,
            max_window_deg: 180.0,
        }
    }
}

impl WindowSearchParams {
    /// Checks every key's range; the error names the first key out of range.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        Checks::new()
            .within("search_above_step_m", self.search_above_step_m, 0.0, 1e3)
            .within(
                "search_above_turn_deg",
                self.search_above_turn_deg,
                0.0,
                360.0,
            )
            .share("search_below_inlier_share", self.search_below_inlier_share)
            .within("min_window_m", self.min_window_m, 0.0, 10.0)
            .within("max_window_m", self.max_window_m, self.min_window_m, 10.0)
            .within("min_window_deg", self.min_window_deg, 0.0, 180.0)
            .within(
                "max_window_deg",
                self.max_window_deg,
                self.min_window_deg,
                180.0,
            )
            .done()
    }
}

/// The verdict's thresholds (section `[tracking.verdict]`): when a scan is `lost`, `weak`
/// (and why) or `ok`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct VerdictParams {
    /// A scan is `lost` when fewer than this share of its (thinned) points are ICP inliers...
    pub lost_below_inlier_share: f64,
    /// ...and `weak` when fewer than this share are.
    pub weak_below_inlier_share: f64,
    /// A scan is `lost` when fewer than this share of its ICP correspondences (points within
    /// the final gate of a wall) are inliers: the points land near walls but not on them, so
    /// the pose contradicts the map (a wrong match, a kidnapped robot); points far from any
    /// wall (a new room) do not count against it...
    pub lost_below_inlier_ratio: f64,
    /// ...and `weak` when fewer than this share are.
    pub weak_below_inlier_ratio: f64,
    /// A scan whose least observed translation has less information than this (fully weighted
    /// correspondences per m², the rotation marginalized; see
    /// [`crate::align::TranslationInformation`]) is `weak` (`weakly_observed`): along that
    /// direction (a corridor with little across it) the fit may slide on small errors of the
    /// map. 0 turns it off. The rules along weakly observed axes take the same bound for
    /// "observed in every direction".
    pub weak_below_information: f64,
    /// Without the odometry prior: a scan otherwise `ok` whose least observed translation has
    /// less information than this, and that ICP moved along that direction by less than
    /// [`crate::tracking::STOPPED_BELOW_SHARE_OF_STEP`] of the last observed motion along it
    /// (itself at least `tracking.search.search_above_step_m`), is `weak` (`slowed`): a fast
    /// robot's step along a corridor that a few door frames pulled back towards "no motion".
    /// 0 turns it off.
    pub slowed_below_information: f64,
    /// A search is ambiguous when a pose at least `rival_apart_m` or `rival_apart_deg` from
    /// the best scores at least this share of the best's score; the scan is then `weak`.
    /// Also when ICP from the search's pose and ICP from the starts reach two such distinct
    /// poses, both observed in every direction, and the one not kept fits at least this share
    /// of the other's inliers; and a scan placed on a saved map is refused as ambiguous alike.
    pub ambiguous_above: f64,
    /// Two poses are distinct (a search's rival, a placement's, a corner hypothesis's) when
    /// more than this apart, metres...
    pub rival_apart_m: f64,
    /// ...or turned by more than this, degrees.
    pub rival_apart_deg: f64,
}

impl Default for VerdictParams {
    fn default() -> Self {
        VerdictParams {
            lost_below_inlier_share: 0.15,
            weak_below_inlier_share: 0.4,
            lost_below_inlier_ratio: 0.5,
            weak_below_inlier_ratio: 0.6,
            weak_below_information: 5.0,
            slowed_below_information: 15.0,
            ambiguous_above: 0.95,
            rival_apart_m: 0.5,
            rival_apart_deg: 10.0,
        }
    }
}

impl VerdictParams {
    /// Checks every key's range; the error names the first key out of range.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        Checks::new()
            .share("lost_below_inlier_share", self.lost_below_inlier_share)
            .share("weak_below_inlier_share", self.weak_below_inlier_share)
            .share("lost_below_inlier_ratio", self.lost_below_inlier_ratio)
            .share("weak_below_inlier_ratio", self.weak_below_inlier_ratio)
            .within(
                "weak_below_information",
                self.weak_below_information,
                0.0,
                1e6,
            )
            .within(
                "slowed_below_information",
                self.slowed_below_information,
                0.0,
                1e6,
            )
            .share("ambiguous_above", self.ambiguous_above)
            .within("rival_apart_m", self.rival_apart_m, 0.0, 100.0)
            .within("rival_apart_deg", self.rival_apart_deg, 0.0, 180.0)
            .done()
    }
}

/// The robot's speed limits (section `[tracking.reach]`): how far it can go and turn in the
/// time between two scans. A pose away from the prediction (a corner hypothesis, a turn on
/// the spot) wins only within that reach of the last `ok` pose, and the window after a gap
/// reaches as far.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ReachParams {
    /// The robot's top speed, m/s...
    pub max_speed_m_s: f64,
    /// ...and turn rate, degrees per second.
    pub max_turn_deg_s: f64,
}

impl Default for ReachParams {
    fn default() -> Self {
        ReachParams {
            max_speed_m_s: 2.0,
            max_turn_deg_s: 120.0,
        }
    }
}

impl ReachParams {
    /// Checks every key's range; the error names the first key out of range.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        Checks::new()
            .above("max_speed_m_s", self.max_speed_m_s, 0.0, 1e3)
            .above("max_turn_deg_s", self.max_turn_deg_s, 0.0, 1e5)
            .done()
    }
}

/// The checks of and by the log's odometry (section `[tracking.odometry]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OdometryCheckParams {
    /// Without the odometry prior, where the log has odometry that agreed with the scans so
    /// far ([`OdometryWitness`](crate::tracking::OdometryWitness)): a scan otherwise `ok`
    /// whose step from the previous scan (robot frame) lies more than this from the
    /// odometry's and from its reverse is `weak` (`off_odometry`), and every such step
    /// (whatever the verdict) is counted in the summary, metres. The reverse too: a log whose
    /// odometry reads a reverse as forward (FR079) still witnesses the step's length and
    /// line. 0 turns it off.
    pub odometry_witness_m: f64,
    /// With the odometry prior, ICP also starts from the constant-velocity guess when it is
    /// farther than this from the odometry guess, metres...
    pub odometry_check_m: f64,
    /// ...or turned by more than this, degrees.
    pub odometry_check_deg: f64,
    /// With the odometry prior, half-width of the largest rotation window and how far a corner
    /// hypothesis or a search's rival may turn the scan from the guess, degrees (at least
    /// `tracking.search.min_window_deg`): the odometry guess carries the turn, a bad odometry
    /// turn is off by tens of degrees, not half a turn, and a corridor fits a scan turned half
    /// round nearly as well as the truth.
    pub odometry_max_window_deg: f64,
}

impl Default for OdometryCheckParams {
    fn default() -> Self {
        OdometryCheckParams {
            odometry_witness_m: 0.3,
            odometry_check_m: 0.3,
            odometry_check_deg: 15.0,
            odometry_max_window_deg: 90.0,
        }
    }
}

impl OdometryCheckParams {
    /// Checks every key's range (the widest window at least `min_window_deg`, the search's
    /// smallest); the error names the first key out of range.
    pub fn validate(&self, min_window_deg: f64) -> Result<(), InvalidParam> {
        Checks::new()
            .within("odometry_witness_m", self.odometry_witness_m, 0.0, 10.0)
            .within("odometry_check_m", self.odometry_check_m, 0.0, 1e3)
            .within("odometry_check_deg", self.odometry_check_deg, 0.0, 180.0)
            .within(
                "odometry_max_window_deg",
                self.odometry_max_window_deg,
                min_window_deg,
                180.0,
            )
            .done()
    }
}
