//! The parameters of tracking: `[tracking]` ([`TrackParams`]: when and how wide the window
//! search runs, the corner hypotheses, the verdict's thresholds, the loose points, the reach
//! of a robot in the time between scans) and `[mapper]` ([`MapperParams`]: the motion prior
//! and where ICP starts). No other module of tracking is imported here, so that the
//! configuration tree composes these without importing the mapper.

use serde::{Deserialize, Serialize};

use crate::check::{Checks, InvalidParam};
use crate::geometry::{Pose2, normalize_angle_rad};

/// Parameters of tracking (section `[tracking]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrackParams {
    /// Search a window around the prediction when the motion is large or ICP fits poorly.
    pub window_search: bool,
    /// Search when the predicted motion between scans is longer than this, metres...
    pub search_above_step_m: f64,
    /// ...or turns more than this, degrees (either only while ICP's pose from the prediction
    /// fits under `search_skip_above_inlier_share` of the points)...
    pub search_above_turn_deg: f64,
    /// ...or when fewer than this share of the (thinned) scan points are ICP inliers.
    pub search_below_inlier_share: f64,
    /// A large predicted step or turn is no reason to search when ICP's pose fits at least this
    /// share of the (thinned) scan points (above 1.1: always a reason; ICP's share may exceed 1
    /// a little, see [`Tracking::inlier_share`](crate::tracking::Tracking::inlier_share)).
    pub search_skip_above_inlier_share: f64,
    /// Half-width of the smallest translation window, metres.
    pub min_window_m: f64,
    /// Half-width of the largest translation window while tracking, metres.
    pub max_window_m: f64,
    /// Half-width of the smallest rotation window, degrees.
    pub min_window_deg: f64,
    /// Half-width of the largest rotation window while tracking without the odometry prior,
    /// degrees (180: the whole circle). A constant-velocity guess may be off by any turn: a
    /// robot that turns 60-85° between scans and then turns back (FR079 every 10th scan) is
    /// 100-150° from its guess.
    pub max_window_deg: f64,
    /// With the odometry prior, half-width of the largest rotation window and how far a corner
    /// hypothesis may turn the scan from the guess, degrees: the odometry guess carries the
    /// turn, a bad odometry turn is off by tens of degrees, not half a turn, and a corridor
    /// fits a scan turned half round nearly as well as the truth.
    pub odometry_max_window_deg: f64,
    /// The translation window's half-width grows by this many times the predicted step.
    pub window_per_step: f64,
    /// While ICP's pose fits under `search_below_inlier_share` of the points, the window also
    /// grows as for a predicted step and turn this many times the largest of the last
    /// [`RecentMotion::SCANS`](crate::tracking::RecentMotion::SCANS) scans' steps and turns, when larger (0: the prediction alone):
    /// a robot that stood for a scan moves on at its former speed, and one that turned lately
    /// may turn as much again.
    pub window_per_recent: f64,
    /// The rotation window's half-width grows by this many times the predicted turn...
    pub window_per_turn: f64,
    /// ...and by this many degrees per metre of predicted step (a robot that moved far may
    /// have started or stopped turning on the way).
    pub window_deg_per_m: f64,
    /// Each scan lost in a row widens the translation window by this, metres (the rotation
    /// window is then the whole circle)...
    pub lost_window_growth_m: f64,
    /// ...up to this, metres.
    pub lost_window_max_m: f64,
    /// Every this many scans lost in a row, the search covers the whole map and the whole
    /// circle (a global re-localization); 0 never.
    pub relocalize_every_lost: u32,
    /// A run on a saved map (`--resume`, `localize`) that has not placed itself after this
    /// many scans stops with an error (each unplaced scan costs a global search).
    pub start_search_scans: u32,
    /// Cell of the search raster, metres.
    pub search_cell_m: f64,
    /// Scale of the search raster's kernel, metres.
    pub search_sigma_m: f64,
    /// About this many scan points are scored per candidate pose.
    pub search_points: usize,
    /// Only points within this range of the robot are scored (unless fewer than 20 are),
    /// metres: the raster covers the window widened by it.
    pub search_max_range_m: f64,
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
    /// map. 0 turns it off.
    pub weak_below_information: f64,
    /// Without the odometry prior: a scan otherwise `ok` whose least observed translation has
    /// less information than this, and that ICP moved along that direction by less than
    /// [`crate::tracking::STOPPED_BELOW_SHARE_OF_STEP`] of the last observed motion along it
    /// (itself at least `search_above_step_m`), is `weak` (`slowed`): a fast robot's step
    /// along a corridor that a few door frames pulled back towards "no motion". 0 turns it
    /// off.
    pub slowed_below_information: f64,
    /// Without the odometry prior, where the log has odometry that agreed with the scans so
    /// far ([`OdometryWitness`](crate::tracking::OdometryWitness)): a scan otherwise `ok` whose step from the previous scan
    /// (robot frame) lies more than this from the odometry's and from its reverse is `weak`
    /// (`off_odometry`), and every such step (whatever the verdict) is counted in the
    /// summary, metres. The reverse too: a log whose odometry reads a reverse as forward
    /// (FR079) still witnesses the step's length and line. 0 turns it off.
    pub odometry_witness_m: f64,
    /// ICP from the search's pose replaces ICP from the prediction only with more inliers
    /// than this share above the latter's (plus two).
    pub search_win_margin: f64,
    /// While tracking (no scan lost just before) with `window_search` on and without the
    /// odometry prior: a scan whose ICP pose was put on its fallback along an axis ICP could not
    /// observe (no evidence of the motion along it) is searched whatever the predicted motion,
    /// in the usual window, and the search's pose wins without `search_win_margin` when ICP
    /// from it observes every direction (translation information at least
    /// `weak_below_information`, the same key as the verdict's), lies within
    /// [`crate::tracking::UNOBSERVED_ACROSS_M`] across the axis and
    /// [`crate::tracking::UNOBSERVED_TURN_DEG`] of ICP's pose, and fits at least as many
    /// points: a corridor's far frames out of ICP's robust reach are the only evidence of a
    /// step along it, and the margin is no test of evidence against none.
    pub search_unobserved: bool,
    /// With `search_unobserved`: when neither ICP nor the window search observed the step
    /// along the axis, ICP also runs from poses along the axis, every
    /// [`crate::tracking::UNOBSERVED_SEED_STEP_M`] up to this far on either side of ICP's pose,
    /// metres (0: off; else at least one step and at most 3 m: up to 24 ICP runs per such
    /// scan), and the pose that passes the same test wins, unless a distinct one
    /// (more than `rival_apart_m` from it) passes too: a robot that starts along a corridor
    /// from a stop, or a scan far apart from the last, moves beyond the window the prediction
    /// gives.
    pub unobserved_reach_m: f64,
    /// With the odometry prior, ICP also starts from the constant-velocity guess when it is
    /// farther than this from the odometry guess, metres...
    pub odometry_check_m: f64,
    /// ...or turned by more than this, degrees.
    pub odometry_check_deg: f64,
    /// Whether scans that are `weak` for a poor fit or an ambiguous search still enter the map
    /// (lost scans never do).
    pub merge_doubtful_scans: bool,
    /// A search is ambiguous when a pose at least `rival_apart_m`...
    pub rival_apart_m: f64,
    /// ...or `rival_apart_deg` degrees from the best...
    pub rival_apart_deg: f64,
    /// ...scores at least this share of the best's score; the scan is then `weak`. Also when
    /// ICP from the search's pose and ICP from the starts reach two such distinct poses, both
    /// observed in every direction, and the one not kept fits at least this share of the
    /// other's inliers.
    pub ambiguous_above: f64,
    /// Scan points of the last this many scans that lie off the map's segments enter the
    /// search raster (pillars, corners, door frames).
    pub loose_point_scans: usize,
    /// Loose points are thinned to this spacing, metres.
    pub loose_point_spacing_m: f64,
    /// ICP also matches scan points that no map segment explains to the loose points farther
    /// than [`LOOSE_OFF_MAP_M`](crate::tracking::LOOSE_OFF_MAP_M) from every map segment (point to line on a line of them, point
    /// to point on a compact blob: see [`crate::align::PointTargets`]): door frames, pillars and
    /// clutter then observe the motion along a corridor whose walls alone cannot.
    pub icp_loose_points: bool,
    /// A robot that stood still (the predicted step and every recent step within
    /// `search_above_step_m`; with the odometry prior, the recent steps) whose pose still fits
    /// under `search_below_inlier_share` of the points after the window search is searched
    /// again around the prediction, as far as it can turn since the last `ok` scan
    /// (`max_turn_deg_s`, `reach_slack_deg`); ICP from that search's pose wins with
    /// `corner_win_ratio` times the inliers (plus two), within `search_above_step_m` of the
    /// anchor and within reach: a turn on the spot.
    pub turn_on_the_spot: bool,
    /// Without the odometry prior, a scan after a gap in stamps that keep time whose pose from
    /// the starts fits under `search_below_inlier_share` of the points is searched as far as
    /// the robot can go and turn in the time since the last `ok` scan (`max_speed_m_s` up to
    /// `max_window_m`, `max_turn_deg_s` up to the widest window).
    pub gap_window: bool,
    /// With the odometry prior, a pose that still fits under `search_below_inlier_share` of
    /// the points is also sought from the odometry's motion since the last `ok` scan with its
    /// direction of travel reversed (odometry that reads the distance but not the direction:
    /// FR079 backing up reads forward); that pose wins with `corner_win_ratio` times the
    /// inliers (plus two), at least `search_below_inlier_share` of the points, and every
    /// direction observed with at least `weak_below_information`.
    pub reversed_odometry: bool,
    /// When the final pose is still `lost` or a `poor_fit`, or (point-to-segment ICP) fits
    /// under `search_below_inlier_share` of the points whatever its verdict (the motion went
    /// beyond the window search), pose hypotheses from the scan's corners matched to the map's corners seed ICP
    /// (see [`crate::tracking::corner_seeds`]); with the odometry prior turned at most
    /// `max_window_deg` from its guess, otherwise any turn.
    pub corner_hypotheses: bool,
    /// Only corner hypotheses within this distance of the prediction count, metres (the map
    /// of a building repeats its corners farther away).
    pub corner_reach_m: f64,
    /// ICP runs from at most this many distinct corner hypotheses, the best-scoring first.
    pub corner_seeds: usize,
    /// ICP from a corner hypothesis replaces ICP from the prediction only with this many times
    /// its inliers (plus two), and with at least `search_below_inlier_share` of the points
    /// inliers: a pose away from the prediction needs more evidence than the window search's
    /// (`search_win_margin`)...
    pub corner_win_ratio: f64,
    /// ...and only when no distinct pose (more than `rival_apart_m` or `rival_apart_deg` away)
    /// from another hypothesis has this share of its inliers.
    pub corner_rival_below: f64,
    /// Only segments at least this long form corners, metres (a scan's segments are short:
    /// clutter and door frames cut its walls).
    pub corner_min_segment_m: f64,
    /// A corner pose wins only within reach of the last `ok` pose in the time since that scan
    /// (when the stamps say it, increasing): at most this speed, m/s...
    pub max_speed_m_s: f64,
    /// ...and this turn rate, degrees per second...
    pub max_turn_deg_s: f64,
    /// ...plus this much, metres (that pose's own error)...
    pub reach_slack_m: f64,
    /// ...and this, degrees.
    pub reach_slack_deg: f64,
}

impl Default for TrackParams {
    fn default() -> Self {
        TrackParams {
            window_search: true,
            search_above_step_m: 0.2,
            search_above_turn_deg: 12.0,
            search_below_inlier_share: 0.5,
            search_skip_above_inlier_share: 0.9,
            min_window_m: 0.3,
            max_window_m: 1.0,
            min_window_deg: 15.0,
            max_window_deg: 180.0,
            odometry_max_window_deg: 90.0,
            window_per_step: 1.0,
            window_per_recent: 1.0,
            window_per_turn: 1.0,
            window_deg_per_m: 60.0,
            lost_window_growth_m: 0.5,
            lost_window_max_m: 3.0,
            relocalize_every_lost: 10,
            start_search_scans: 50,
            search_cell_m: 0.1,
            search_sigma_m: 0.2,
            search_points: 100,
            search_max_range_m: 8.0,
            lost_below_inlier_share: 0.15,
            weak_below_inlier_share: 0.4,
            lost_below_inlier_ratio: 0.5,
            weak_below_inlier_ratio: 0.6,
            weak_below_information: 5.0,
            slowed_below_information: 15.0,
            odometry_witness_m: 0.3,
            search_win_margin: 0.1,
            search_unobserved: true,
            unobserved_reach_m: 1.0,
            merge_doubtful_scans: true,
            odometry_check_m: 0.3,
            odometry_check_deg: 15.0,
            rival_apart_m: 0.5,
            rival_apart_deg: 10.0,
            ambiguous_above: 0.95,
            loose_point_scans: 5,
            loose_point_spacing_m: 0.1,
            icp_loose_points: true,
            turn_on_the_spot: true,
            gap_window: true,
            reversed_odometry: true,
            corner_hypotheses: true,
            corner_reach_m: 3.0,
            corner_seeds: 3,
            corner_win_ratio: 1.5,
            corner_rival_below: 0.85,
            corner_min_segment_m: 0.3,
            max_speed_m_s: 2.0,
            max_turn_deg_s: 120.0,
            reach_slack_m: 0.3,
            reach_slack_deg: 20.0,
        }
    }
}

impl TrackParams {
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
            .within(
                "search_skip_above_inlier_share",
                self.search_skip_above_inlier_share,
                0.0,
                10.0,
            )
            .within("min_window_m", self.min_window_m, 0.0, 10.0)
            .within("max_window_m", self.max_window_m, self.min_window_m, 10.0)
            .within("min_window_deg", self.min_window_deg, 0.0, 180.0)
            .within(
                "max_window_deg",
                self.max_window_deg,
                self.min_window_deg,
                180.0,
            )
            .within(
                "odometry_max_window_deg",
                self.odometry_max_window_deg,
                self.min_window_deg,
                180.0,
            )
            .within("window_per_step", self.window_per_step, 0.0, 100.0)
            .within("window_per_recent", self.window_per_recent, 0.0, 10.0)
            .within("window_per_turn", self.window_per_turn, 0.0, 100.0)
            .within("window_deg_per_m", self.window_deg_per_m, 0.0, 1000.0)
            .within("lost_window_growth_m", self.lost_window_growth_m, 0.0, 10.0)
            .within("lost_window_max_m", self.lost_window_max_m, 0.0, 50.0)
            .within(
                "relocalize_every_lost",
                self.relocalize_every_lost,
                0,
                1_000_000,
            )
            .within("start_search_scans", self.start_search_scans, 1, 1_000_000)
            .within("search_cell_m", self.search_cell_m, 0.01, 1.0)
            .within("search_sigma_m", self.search_sigma_m, 0.01, 5.0)
            .within("search_points", self.search_points, 1, 10_000)
            .within("search_max_range_m", self.search_max_range_m, 1.0, 1e3)
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
            .within("odometry_witness_m", self.odometry_witness_m, 0.0, 10.0)
            .within("search_win_margin", self.search_win_margin, 0.0, 10.0)
            .within("unobserved_reach_m", self.unobserved_reach_m, 0.0, 3.0)
            .rule(
                "unobserved_reach_m",
                self.unobserved_reach_m == 0.0
                    || self.unobserved_reach_m >= crate::tracking::UNOBSERVED_SEED_STEP_M,
                self.unobserved_reach_m,
                format_args!(
                    "0 (off) or at least {} m",
                    crate::tracking::UNOBSERVED_SEED_STEP_M
                ),
            )
            .within("odometry_check_m", self.odometry_check_m, 0.0, 1e3)
            .within("odometry_check_deg", self.odometry_check_deg, 0.0, 180.0)
            .within("rival_apart_m", self.rival_apart_m, 0.0, 100.0)
            .within("rival_apart_deg", self.rival_apart_deg, 0.0, 180.0)
            .share("ambiguous_above", self.ambiguous_above)
            .within("loose_point_scans", self.loose_point_scans, 0, 1000)
            .within(
                "loose_point_spacing_m",
                self.loose_point_spacing_m,
                0.01,
                10.0,
            )
            .within("corner_reach_m", self.corner_reach_m, 0.0, 1e3)
            .within("corner_seeds", self.corner_seeds, 1, 100)
            .within("corner_win_ratio", self.corner_win_ratio, 1.0, 100.0)
            .share("corner_rival_below", self.corner_rival_below)
            .above(
                "corner_min_segment_m",
                self.corner_min_segment_m,
                0.0,
                100.0,
            )
            .above("max_speed_m_s", self.max_speed_m_s, 0.0, 1e3)
            .above("max_turn_deg_s", self.max_turn_deg_s, 0.0, 1e5)
            .within("reach_slack_m", self.reach_slack_m, 0.0, 1e3)
            .within("reach_slack_deg", self.reach_slack_deg, 0.0, 360.0)
            .done()
    }
}

impl TrackParams {
    /// How far the robot can go and turn in `dt_s` seconds: `max_speed_m_s` and
    /// `max_turn_deg_s` times it, plus `reach_slack_m` and `reach_slack_deg` (metres,
    /// degrees).
    pub fn reach(&self, dt_s: f64) -> (f64, f64) {
        (
            self.max_speed_m_s * dt_s + self.reach_slack_m,
            self.max_turn_deg_s * dt_s + self.reach_slack_deg,
        )
    }

    /// Half-width of the widest rotation window while tracking, degrees: `max_window_deg`, or
    /// `odometry_max_window_deg` with the odometry prior; never under `min_window_deg`.
    pub fn widest_window_deg(&self, odometry: bool) -> f64 {
        let cut = match odometry {
            true => self.odometry_max_window_deg,
            false => self.max_window_deg,
        };
        cut.max(self.min_window_deg)
    }

    /// Whether two poses are distinct places: more than `rival_apart_m` or `rival_apart_deg`
    /// apart (the rival of a search, of a placement, of a corner hypothesis).
    pub fn apart(&self, a: &Pose2, b: &Pose2) -> bool {
        let d = a.between(b);
        d.translation().length() > self.rival_apart_m
            || normalize_angle_rad(d.theta_rad).abs() > self.rival_apart_deg.to_radians()
    }
}

/// Where ICP starts for a new scan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MotionPrior {
    /// The previous scan's pose (the paper).
    Previous,
    /// The previous pose moved by the last scan-to-scan motion.
    ConstantVelocity,
    /// The previous pose moved by the odometry increment between the scans (falls back to the
    /// previous pose when a scan has no odometry).
    Odometry,
}

/// Where ICP starts for each scan (section `[mapper]`): the motion prior, the extra starts and
/// how one is chosen, and the recovery after a gap.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MapperParams {
    /// The first guess for ICP.
    pub motion_prior: MotionPrior,
    /// When the motion prior's guess differs from the anchor (the previous pose), also run ICP
    /// from the anchor and keep the better fit (more inliers, then lower residual).
    pub also_start_at_anchor: bool,
    /// Share of the last scan-to-scan motion kept along directions ICP cannot observe, with the
    /// constant-velocity prior (0: assume no motion there; 1: assume the same motion again).
    pub weak_direction_velocity: f64,
    /// With the constant-velocity prior, directions ICP cannot observe fall back to the
    /// previous pose moved by the last motion that was observed (a step between two scans that
    /// were both tracked `ok` with every direction observed) instead of
    /// `weak_direction_velocity` of the last motion: a robot keeps its speed along a bare
    /// corridor, and a motion that was itself taken from the prior never feeds back.
    pub keep_observed_velocity: bool,
    /// With several ICP starts, score them by the soft inlier count of a sample of points and
    /// run ICP from the best one only (faster); otherwise run ICP from each and keep the best.
    pub icp_from_best_start_only: bool,
    /// Soft inlier points by which another start must beat the first (the anchor, "no
    /// motion", when it is a start) to be chosen.
    pub start_score_margin: f64,
    /// When ICP's inliers are fewer than this share of the scan's (thinned) points (the scan
    /// fits nowhere near the guess: the robot turned during a gap in the log), poses over the
    /// whole circle and within 1 m of the anchor are scored, ICP runs from the best three, and
    /// the best result is kept if it has at least twice the inliers and twice this share (0
    /// turns this off). Not with the odometry prior, whose guess carries the turn.
    pub recover_below_inlier_share: f64,
}

impl Default for MapperParams {
    fn default() -> Self {
        MapperParams {
            motion_prior: MotionPrior::ConstantVelocity,
            also_start_at_anchor: true,
            weak_direction_velocity: 0.0,
            keep_observed_velocity: true,
            icp_from_best_start_only: true,
            start_score_margin: 1.0,
            recover_below_inlier_share: 0.15,
        }
    }
}

impl MapperParams {
    /// Checks every key's range; the error names the first key out of range.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        Checks::new()
            .share("weak_direction_velocity", self.weak_direction_velocity)
            .within("start_score_margin", self.start_score_margin, 0.0, 1e6)
            .share(
                "recover_below_inlier_share",
                self.recover_below_inlier_share,
            )
            .done()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reach_along_an_unobserved_axis_is_off_or_at_least_one_step_and_bounded() {
        let with = |unobserved_reach_m| TrackParams {
            unobserved_reach_m,
            ..TrackParams::default()
        };
        for ok in [0.0, 0.25, 1.0, 3.0] {
            assert!(with(ok).validate().is_ok(), "{ok}");
        }
        for bad in [0.1, -1.0, 3.5, f64::NAN] {
            let e = with(bad).validate().expect_err("refused");
            assert_eq!(e.key, "unobserved_reach_m", "{bad}");
        }
    }
}
