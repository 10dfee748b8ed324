//! Tracking: when to search beyond ICP's basin, how wide, and the verdict on each scan.
//!
//! ICP from the motion prior is exact and cheap when the prior is close, which it is on dense
//! logs. It is not when the robot moved far or turned fast between scans (sparse logs, fast
//! robots), or when ICP's fit is poor. Then the [`CorrelativeMatcher`] searches a window around
//! the prediction on a likelihood raster of the map near it and of the recent scan points that
//! form no segment, and ICP refines its best pose; the better of the two fits wins. The window
//! grows with the predicted motion (a constant-velocity prediction is wrong by about as much as
//! the robot moved), and with every scan that found no match.
//!
//! Each scan gets a [`Verdict`]: `ok`, `weak` (ICP left a direction unobservable, so the pose
//! along it comes from the prior: a bare corridor) or `lost` (too few points fit anywhere).

use serde::{Deserialize, Serialize};

use crate::align::{
    AlignResult, Candidate, CorrelativeMatcher, ScoreRaster, SearchWindow, WindowBest,
    score_sample_n,
};
use crate::check::{Checks, InvalidParam};
use crate::geometry::{Pose2, Vec2, normalize_angle_rad};
use crate::map::GlobalMap;

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
    /// a little, see [`Tracking::inlier_share`]).
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
    /// [`RecentMotion::SCANS`] scans' steps and turns, when larger (0: the prediction alone):
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
    /// far ([`OdometryWitness`]): a scan otherwise `ok` whose step from the previous scan
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
    /// than [`LOOSE_OFF_MAP_M`] from every map segment (point to line on a line of them, point
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

/// How well a scan was tracked.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// A confident match in every direction.
    #[default]
    Ok,
    /// A match, but some direction was unobservable and came from the motion prior.
    Weak,
    /// No confident match: the pose is the best fit found, but the scan does not enter the map.
    Lost,
}

/// Why a scan got its verdict.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Reason {
    /// The first scan, or a scan with nothing to align to: it starts the map.
    #[default]
    Start,
    /// Enough points fit, every direction observed.
    Fit,
    /// Enough points fit, but some direction was unobservable (a bare corridor).
    Degenerate,
    /// Enough points fit, but one direction is observed by few of them (a corridor with little
    /// across it): the pose may have slid along it (`tracking.weak_below_information`).
    WeaklyObserved,
    /// Enough points fit, but a robot that moved fast lately was put near "no motion" along a
    /// direction observed by few of them (`tracking.slowed_below_information`): its step may
    /// have been pulled short.
    Slowed,
    /// Enough points fit, but without the odometry prior the log's odometry, which has agreed
    /// with the scans so far, puts the step more than `tracking.odometry_witness_m` from the
    /// one tracked ([`OdometryWitness`]): the scans or the odometry slipped there.
    OffOdometry,
    /// Enough points fit to keep the scan, too few to trust it.
    PoorFit,
    /// The window search found a distinct pose that explains the scan about as well (on its
    /// raster, or by ICP from its pose).
    Ambiguous,
    /// Most points near a wall are not on it: the pose contradicts the map.
    Contradicted,
    /// Too few points fit, even after the window search.
    TooFewInliers,
    /// The scan has no valid points.
    NoPoints,
    /// A run on a saved map has not placed itself yet: no pose of the map explains the scan
    /// confidently, or the searches of the last scans do not yet agree on one.
    NotFound,
}

/// The tracking outcome of one scan.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Tracking {
    /// The verdict.
    pub verdict: Verdict,
    /// Why.
    pub reason: Reason,
    /// ICP's inliers over the (thinned) scan points: `[0, 1]`, except that a point matched point
    /// to point to a loose blob counts two (x and y), so it may exceed 1 a little.
    pub inlier_share: f64,
    /// Whether the correlative window search ran.
    pub searched: bool,
    /// Whether a searched pose won over ICP from the prediction: the window search's, the
    /// recovery's, or ICP's from a pose along an axis ICP observed weakly or not at all (the
    /// last may win where the window search did not run).
    pub search_won: bool,
    /// Whether ICP from a corner hypothesis ([`crate::tracking::corner_seeds`]) won: the scan
    /// moved beyond the window search.
    #[serde(default)]
    pub corner_won: bool,
    /// Map-frame direction, degrees in `[0, 180)`, along which translation was unobservable,
    /// when one was.
    pub weak_direction_deg: Option<f64>,
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

/// The log's odometry as a witness of one step, where it is not the motion prior: the pose
/// the step starts from and the odometry's translation since. The mapper offers it only once
/// the odometry has agreed with the scans (see
/// `TrackingSummary::odometry_agrees_with_travel`): a stuck or scaled odometry witnesses
/// nothing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdometryWitness {
    /// The pose the step starts from, map frame: the previous scan's, or after lost scans the
    /// last `ok` one's.
    pub previous: Pose2,
    /// The odometry's translation from that scan to this one, robot frame of that scan,
    /// metres.
    pub step: Vec2,
}

impl OdometryWitness {
    /// Whether the tracked step to `pose` (map frame) lies more than `off_above_m` from the
    /// odometry's, or from its reverse: odometry that reads a reverse as forward (FR079's)
    /// still witnesses the step's length and line, not its sense. Never when `off_above_m`
    /// is 0.
    pub fn contradicts(&self, pose: &Pose2, off_above_m: f64) -> bool {
        let tracked = self.previous.between(pose).translation();
        let off = (tracked - self.step)
            .length()
            .min((tracked + self.step).length());
        off_above_m > 0.0 && off > off_above_m
    }
}

impl Tracking {
    /// Whether the mapper carries tracking on from this scan as from an `ok` one (the speed
    /// observed, the last `ok` pose that bounds the reach, the support its sightings give the
    /// walls, the odometry's travel check): `ok`, or `weak` only as `slowed` or
    /// `off_odometry`. Those verdicts tell the user the step may be wrong; tracking from it is
    /// unchanged, since keeping such scans out of that state reshuffles the sparse runs
    /// (`docs/ARCHITECTURE.md`, "The verdict and what a run says"), and the odometry's travel check,
    /// which decides whether the odometry may witness at all, must see every step it judges.
    pub fn carries_tracking(&self) -> bool {
        self.verdict == Verdict::Ok
            || (self.verdict == Verdict::Weak
                && matches!(self.reason, Reason::Slowed | Reason::OffOdometry))
    }

    /// Whether the scan's segments enter the map: never for a `lost` scan; not for one `weak`
    /// for a poor fit or an ambiguous search unless `merge_doubtful_scans`; not for one placed
    /// by a corner hypothesis unless it is `ok` (a pose away from the prediction enters the
    /// map only when the scan fits there without doubt; the scan still tracks from it) or
    /// only `off_odometry`, a label: keeping those out too takes ACES every 5th scan, phase 2,
    /// from 0.076 to 0.330 m.
    pub fn enters_map(&self, merge_doubtful_scans: bool) -> bool {
        let doubtful = matches!(self.reason, Reason::PoorFit | Reason::Ambiguous);
        let confident = self.verdict == Verdict::Ok || self.reason == Reason::OffOdometry;
        self.verdict != Verdict::Lost
            && (merge_doubtful_scans || !doubtful)
            && (!self.corner_won || confident)
    }
}

/// Whether the window search should run: large motion (predicted, or of any of the last few
/// scans: a robot that moves far per scan may stop or turn at any scan) unless ICP's pose fits
/// at least `search_skip_above_inlier_share` of the points, a poor fit, or lost before.
pub fn should_search(
    prediction: &Pose2,
    anchor: &Pose2,
    recent: &RecentMotion,
    icp: Option<&AlignResult>,
    thinned_points: usize,
    lost_streak: u32,
    params: &TrackParams,
) -> bool {
    if !params.window_search || thinned_points == 0 {
        return false;
    }
    let motion = anchor.between(prediction);
    let step_m = motion.translation().length().max(recent.step_m());
    let turn_deg = normalize_angle_rad(motion.theta_rad)
        .abs()
        .to_degrees()
        .max(recent.turn_deg());
    let share = icp.map_or(0.0, |r| r.inliers as f64 / thinned_points as f64);
    let moved = step_m > params.search_above_step_m || turn_deg > params.search_above_turn_deg;
    lost_streak > 0
        || (moved && share < params.search_skip_above_inlier_share)
        || share < params.search_below_inlier_share
}

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

/// The window around `prediction`: wider for a larger predicted motion, and for every scan lost
/// in a row (then over the whole circle). Its rotation reaches at most `max_window_deg`
/// (`odometry_max_window_deg` when the prediction is odometry's), and always the anchor's
/// heading with `min_window_deg` to spare, however far the prediction turned.
pub fn search_window(
    prediction: &Pose2,
    anchor: &Pose2,
    recent: &RecentMotion,
    lost_streak: u32,
    odometry: bool,
    params: &TrackParams,
) -> SearchWindow {
    let motion = anchor.between(prediction);
    if lost_streak > 0 {
        let half = params.max_window_m + params.lost_window_growth_m * lost_streak as f64;
        return SearchWindow {
            center: *prediction,
            half_xy_m: half.min(params.lost_window_max_m.max(params.max_window_m)),
            half_theta_rad: std::f64::consts::PI,
        };
    }
    let step = motion
        .translation()
        .length()
        .max(params.window_per_recent * recent.step_m());
    let turn_deg = normalize_angle_rad(motion.theta_rad)
        .abs()
        .to_degrees()
        .max(params.window_per_recent * recent.turn_deg());
    let half_xy = (params.min_window_m + params.window_per_step * step).clamp(
        params.min_window_m,
        params.max_window_m.max(params.min_window_m),
    );
    let half_deg = (params.min_window_deg
        + params.window_per_turn * turn_deg
        + params.window_deg_per_m * step)
        .clamp(params.min_window_deg, params.widest_window_deg(odometry))
        // The anchor's heading stays inside the window: a predicted turn beyond the widest
        // window (a turn the last step took, perhaps wrongly) must not exclude no turn.
        .max(normalize_angle_rad(motion.theta_rad).abs().to_degrees() + params.min_window_deg)
        .min(180.0);
    SearchWindow {
        center: *prediction,
        half_xy_m: half_xy,
        half_theta_rad: half_deg.to_radians(),
    }
}

/// A window search's best pose must explain at least this mean raster value per point.
const MIN_SCORE: f64 = 0.05;

/// The outcome of a window search: the best pose, and on demand a rival apart from it (only
/// a scan whose verdict is otherwise `ok`, or still in doubt after the corner hypotheses,
/// asks for it, so the search for a rival runs only when asked).
#[derive(Debug, Clone)]
pub struct WindowMatch {
    /// The best pose of the window.
    pub best: Candidate,
    matcher: CorrelativeMatcher,
    found: WindowBest,
    /// How far apart a rival is (`tracking.rival_apart_m`, `rival_apart_deg` in radians).
    apart: (f64, f64),
}

impl WindowMatch {
    /// Whether a distinct pose (more than `rival_apart_m` or `rival_apart_deg` from the best)
    /// scores at least `ambiguous_above` of the best's score.
    pub fn ambiguous(&self) -> bool {
        self.rival().is_some()
    }

    /// The best distinct pose scoring at least `ambiguous_above` of the best's score.
    pub fn rival(&self) -> Option<Candidate> {
        self.matcher.rival(&self.found, self.apart)
    }
}

/// The scan points (robot frame) a search scores: about `search_points` of them, only those
/// within `search_max_range_m` unless fewer than 20 are. Far points sharpen the rotation but
/// widen the raster (its cost).
pub(super) fn search_sample(points_in_robot: &[Vec2], params: &TrackParams) -> Vec<Vec2> {
    let near: Vec<Vec2> = points_in_robot
        .iter()
        .copied()
        .filter(|p| p.length() <= params.search_max_range_m)
        .collect();
    let points = if near.len() >= 20 {
        &near[..]
    } else {
        points_in_robot
    };
    score_sample_n(points, params.search_points)
}

/// The search raster over the box `lo`..`hi` (map frame, metres): the map's segments there and
/// the loose points (map frame) they leave unexplained; `None` when neither has any.
pub(super) fn search_raster(
    map: &GlobalMap,
    loose_points_in_map: &[Vec2],
    lo: Vec2,
    hi: Vec2,
    params: &TrackParams,
) -> Option<ScoreRaster> {
    let mut raster = ScoreRaster::new(lo, hi, params.search_cell_m, params.search_sigma_m);
    let mut any = false;
    for id in map.query(lo, hi) {
        if let Some(s) = map.get(id) {
            raster.add_segment(&s.segment);
            any = true;
        }
    }
    // Only points the segments leave unexplained: pillars, corners, door frames. Clutter the
    // map already covers would only flatten the score.
    let unexplained: Vec<Vec2> = loose_points_in_map
        .iter()
        .copied()
        .filter(|p| p.x >= lo.x && p.y >= lo.y && p.x <= hi.x && p.y <= hi.y)
        .filter(|p| raster.at(*p) < 0.5)
        .collect();
    for p in &unexplained {
        raster.add_point(*p);
        any = true;
    }
    any.then_some(raster)
}

/// The best pose of `window` for the scan's points (robot frame) on a raster of the map and
/// of the loose points near it that the map does not explain (map frame), and its rival on
/// demand ([`WindowMatch::rival`]); `None` when nothing scores. A `seed` pose (ICP's answer)
/// is the score to beat: the search then only opens blocks that could beat it, and returns
/// the seed when none does.
pub fn window_search(
    map: &GlobalMap,
    loose_points_in_map: &[Vec2],
    points_in_robot: &[Vec2],
    window: &SearchWindow,
    seed: Option<Pose2>,
    params: &TrackParams,
) -> Option<WindowMatch> {
    let sample = search_sample(points_in_robot, params);
    let reach_m = sample.iter().map(|p| p.length()).fold(0.0, f64::max);
    let margin = Vec2::splat(window.half_xy_m + reach_m + params.search_sigma_m);
    let (lo, hi) = (
        window.center.translation() - margin,
        window.center.translation() + margin,
    );
    let raster = search_raster(map, loose_points_in_map, lo, hi, params)?;
    let seeded = seed.map(|pose| Candidate {
        map_from_robot: pose,
        score: sample
            .iter()
            .map(|p| raster.at(pose.transform_point(*p)))
            .sum::<f64>()
            / sample.len().max(1) as f64,
    });
    let floor = seeded.map_or(MIN_SCORE, |c| c.score.max(MIN_SCORE));
    let matcher = CorrelativeMatcher::for_window(raster, window.half_xy_m);
    let found = matcher.window_best(&sample, window, floor, seeded, params.ambiguous_above)?;
    Some(WindowMatch {
        best: found.best,
        matcher,
        found,
        apart: (params.rival_apart_m, params.rival_apart_deg.to_radians()),
    })
}

/// The verdict on a scan from its final alignment.
pub fn verdict(
    result: Option<&AlignResult>,
    thinned_points: usize,
    first: bool,
    params: &TrackParams,
) -> Tracking {
    let Some(r) = result else {
        let reason = if first || thinned_points > 0 {
            Reason::Start
        } else {
            Reason::NoPoints
        };
        let verdict = if reason == Reason::Start {
            Verdict::Ok
        } else {
            Verdict::Lost
        };
        return Tracking {
            verdict,
            reason,
            ..Tracking::default()
        };
    };
    let share = r.inliers as f64 / thinned_points.max(1) as f64;
    let ratio = r.inliers as f64 / r.correspondences.max(1) as f64;
    let (verdict, reason) = if share < params.lost_below_inlier_share {
        (Verdict::Lost, Reason::TooFewInliers)
    } else if ratio < params.lost_below_inlier_ratio {
        (Verdict::Lost, Reason::Contradicted)
    } else if share < params.weak_below_inlier_share || ratio < params.weak_below_inlier_ratio {
        (Verdict::Weak, Reason::PoorFit)
    } else if r.weak_directions > 0 {
        (Verdict::Weak, Reason::Degenerate)
    } else if r.translation_information.weakest < params.weak_below_information {
        (Verdict::Weak, Reason::WeaklyObserved)
    } else {
        (Verdict::Ok, Reason::Fit)
    };
    let weak_direction_deg = match reason {
        Reason::WeaklyObserved => Some(r.translation_information.weakest_deg),
        _ => r.weak_direction_deg,
    };
    Tracking {
        verdict,
        reason,
        inlier_share: share,
        searched: false,
        search_won: false,
        corner_won: false,
        weak_direction_deg,
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::align::TranslationInformation;

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

    #[test]
    fn lost_doubtful_and_unsure_corner_scans_stay_out_of_the_map() {
        let at = |verdict, reason, corner_won| Tracking {
            verdict,
            reason,
            corner_won,
            ..Tracking::default()
        };
        let ok = at(Verdict::Ok, Reason::Fit, false);
        assert!(ok.enters_map(false) && ok.enters_map(true));
        let lost = at(Verdict::Lost, Reason::Contradicted, false);
        assert!(!lost.enters_map(true));
        let poor = at(Verdict::Weak, Reason::PoorFit, false);
        assert!(poor.enters_map(true) && !poor.enters_map(false));
        let slid = at(Verdict::Weak, Reason::WeaklyObserved, false);
        assert!(slid.enters_map(false));
        let corner_ok = at(Verdict::Ok, Reason::Fit, true);
        assert!(corner_ok.enters_map(true));
        for reason in [Reason::Ambiguous, Reason::WeaklyObserved, Reason::PoorFit] {
            assert!(!at(Verdict::Weak, reason, true).enters_map(true));
        }
        // `off_odometry` is a label: a corner pose enters the map and tracking carries on
        // from it as from an `ok` one.
        let witnessed = at(Verdict::Weak, Reason::OffOdometry, true);
        assert!(witnessed.enters_map(false) && witnessed.carries_tracking());
        assert!(!slid.carries_tracking() && !poor.carries_tracking() && ok.carries_tracking());
    }

    #[test]
    fn the_odometry_witnesses_the_steps_line_not_its_sense() {
        let previous = Pose2::new(1.0, 2.0, std::f64::consts::FRAC_PI_2);
        // The odometry read 1 m ahead (robot frame): map frame +y from `previous`.
        let witness = OdometryWitness {
            previous,
            step: Vec2::new(1.0, 0.0),
        };
        let at = |x: f64, y: f64| Pose2::new(x, y, 0.0);
        assert!(!witness.contradicts(&at(1.0, 3.0), 0.3));
        assert!(!witness.contradicts(&at(1.2, 3.1), 0.3));
        // Backwards 1 m: the odometry's line, in reverse (odometry that reads a reverse as
        // forward).
        assert!(!witness.contradicts(&at(1.0, 1.0), 0.3));
        // A stall, half the step, a step sideways.
        assert!(witness.contradicts(&at(1.0, 2.0), 0.3));
        assert!(witness.contradicts(&at(1.0, 2.5), 0.3));
        assert!(witness.contradicts(&at(2.0, 2.0), 0.3));
        // 0 turns it off.
        assert!(!witness.contradicts(&at(1.0, 2.0), 0.0));
    }

    #[test]
    fn the_window_grows_with_the_motion_and_when_lost() {
        let p = TrackParams::default();
        let anchor = Pose2::IDENTITY;
        let still = search_window(&anchor, &anchor, &RecentMotion::default(), 0, false, &p);
        assert_eq!(still.half_xy_m, p.min_window_m);
        assert!((still.half_theta_rad.to_degrees() - p.min_window_deg).abs() < 1e-9);
        let fast = Pose2::new(0.5, 0.0, 30f64.to_radians());
        let w = search_window(&fast, &anchor, &RecentMotion::default(), 0, false, &p);
        assert!((w.half_xy_m - 0.8).abs() < 1e-9);
        assert!((w.half_theta_rad.to_degrees() - 75.0).abs() < 1e-9);
        // Without odometry a large predicted turn widens the window up to the whole circle
        // (15° + the turn + 60°/m of the 0.2 m step). With odometry the window stops at 90°,
        // but a predicted turn beyond it (the last step's, perhaps a wrong flip) still leaves
        // the anchor's heading inside, with the smallest margin, and at most the whole circle.
        for (turn_deg, cv_deg, odometry_deg) in [
            (60.0, 87.0, 87.0),
            (80.0, 107.0, 95.0),
            (100.0, 127.0, 115.0),
            (172.0, 180.0, 180.0),
        ] {
            let spun = Pose2::new(0.2, 0.0, f64::to_radians(turn_deg));
            for (odometry, half_deg) in [(false, cv_deg), (true, odometry_deg)] {
                let w = search_window(&spun, &anchor, &RecentMotion::default(), 0, odometry, &p);
                assert!(
                    (w.half_theta_rad.to_degrees() - half_deg).abs() < 1e-9,
                    "{turn_deg}° {odometry}: {}",
                    w.half_theta_rad.to_degrees()
                );
            }
        }
        let lost = search_window(&fast, &anchor, &RecentMotion::default(), 3, false, &p);
        assert!((lost.half_xy_m - 2.5).abs() < 1e-9);
        assert_eq!(lost.half_theta_rad, std::f64::consts::PI);
        // A robot that stood still for a scan after moving fast: the window of its recent
        // motion (0.5 m, 30°), and of the prediction alone without `window_per_recent`.
        let mut moved = RecentMotion::default();
        moved.push(&anchor, &fast);
        moved.push(&fast, &fast);
        let after_stop = search_window(&anchor, &anchor, &moved, 0, false, &p);
        assert_eq!(after_stop.center, anchor);
        assert_eq!(
            (after_stop.half_xy_m, after_stop.half_theta_rad),
            (w.half_xy_m, w.half_theta_rad)
        );
        let alone = TrackParams {
            window_per_recent: 0.0,
            ..p.clone()
        };
        assert_eq!(
            search_window(&anchor, &anchor, &moved, 0, false, &alone),
            still
        );
        let mut recent = RecentMotion::default();
        assert!(should_search(&fast, &anchor, &recent, None, 10, 0, &p));
        assert!(!should_search(&anchor, &anchor, &recent, None, 0, 0, &p));
        // A good fit with no motion predicted still searches when the robot moved far lately.
        let good = AlignResult {
            map_from_robot: anchor,
            iterations: 3,
            correspondences: 10,
            inliers: 8,
            residual_rms_m: 0.01,
            converged: true,
            weak_directions: 0,
            weak_direction_deg: None,
            translation_information: TranslationInformation {
                weakest: 50.0,
                strongest: 100.0,
                weakest_deg: 0.0,
            },
        };
        assert!(!should_search(
            &anchor,
            &anchor,
            &recent,
            Some(&good),
            10,
            0,
            &p
        ));
        recent.push(&anchor, &fast);
        assert!(should_search(
            &anchor,
            &anchor,
            &recent,
            Some(&good),
            10,
            0,
            &p
        ));
        // ...but not when ICP's pose fits nearly every point (`search_skip_above_inlier_share`),
        // unless that is off.
        let sure = AlignResult {
            inliers: 10,
            ..good
        };
        assert!(!should_search(
            &fast,
            &anchor,
            &recent,
            Some(&sure),
            10,
            0,
            &p
        ));
        let always = TrackParams {
            search_skip_above_inlier_share: 10.0,
            ..p
        };
        assert!(should_search(
            &fast,
            &anchor,
            &recent,
            Some(&sure),
            10,
            0,
            &always
        ));
    }

    #[test]
    fn verdicts_follow_the_share_and_the_weak_directions() {
        let p = TrackParams::default();
        let mut r = AlignResult {
            map_from_robot: Pose2::IDENTITY,
            iterations: 3,
            correspondences: 100,
            inliers: 90,
            residual_rms_m: 0.01,
            converged: true,
            weak_directions: 0,
            weak_direction_deg: None,
            translation_information: TranslationInformation {
                weakest: 50.0,
                strongest: 100.0,
                weakest_deg: 0.0,
            },
        };
        assert_eq!(verdict(Some(&r), 100, false, &p).verdict, Verdict::Ok);
        r.weak_directions = 1;
        assert_eq!(verdict(Some(&r), 100, false, &p).verdict, Verdict::Weak);
        r.weak_directions = 0;
        r.inliers = 30;
        r.correspondences = 40;
        assert_eq!(verdict(Some(&r), 100, false, &p).reason, Reason::PoorFit);
        r.correspondences = 100;
        r.inliers = 10;
        assert_eq!(verdict(Some(&r), 100, false, &p).verdict, Verdict::Lost);
        r.inliers = 45;
        assert_eq!(
            verdict(Some(&r), 100, false, &p).reason,
            Reason::Contradicted
        );
        r.correspondences = 50;
        assert_eq!(verdict(Some(&r), 100, false, &p).verdict, Verdict::Ok);
        assert_eq!(verdict(None, 0, false, &p).verdict, Verdict::Lost);
        assert_eq!(verdict(None, 10, true, &p).verdict, Verdict::Ok);
    }
}
