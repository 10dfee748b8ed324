//! The fixed values of tracking: what was measured or reasoned once and is no user's choice.
//! Each says its unit and why it has its value. The user's keys are in [`super::TrackParams`]
//! and [`super::MapperParams`].

// The window search.

/// A large predicted step or turn is no reason to search when ICP's pose fits at least this
/// share of the (thinned) scan points: against 0.8, ACES every 5th scan median relation error
/// 0.110 vs 0.174 m; a search that wins against a pose fitting 90 % was more often a
/// coincidence along a corridor. ICP's share may exceed 1 a little, see
/// [`Tracking::inlier_share`](crate::tracking::Tracking::inlier_share).
pub const SEARCH_SKIP_ABOVE_INLIER_SHARE: f64 = 0.9;

/// The translation window's half-width grows by this many times the predicted step (a
/// constant-velocity guess may be off by as much as the step it predicts).
pub const WINDOW_PER_STEP: f64 = 1.0;

/// With `TrackParams::recent_window`, while ICP's pose fits under
/// `search.search_below_inlier_share` of the points, the window also grows as for a predicted
/// step and turn this many times the largest of the last
/// [`RecentMotion::SCANS`](crate::tracking::RecentMotion::SCANS) scans' steps and turns: a
/// robot that stood for a scan moves on at its former speed, and one that turned lately may
/// turn as much again. Against the prediction alone, every 10th scan: Intel 5.33 → 1.36 m,
/// ACES 15.7 → 13.6 m, FR079 4.51 → 3.98 m; every scan and every 2nd scan unchanged.
pub const WINDOW_PER_RECENT: f64 = 1.0;

/// The rotation window's half-width grows by this many times the predicted turn (as
/// [`WINDOW_PER_STEP`] for the translation)...
pub const WINDOW_PER_TURN: f64 = 1.0;

/// ...and by this many degrees per metre of predicted step: a robot that moved far may have
/// started or stopped turning on the way (about a radian per metre).
pub const WINDOW_DEG_PER_M: f64 = 60.0;

/// Each scan lost in a row widens the translation window by this, metres (the rotation window
/// is then the whole circle): a lost robot kept moving, and the window follows by half the
/// largest tracking window (`search.max_window_m`, 1 m) per scan...
pub const LOST_WINDOW_GROWTH_M: f64 = 0.5;

/// ...up to this, metres (the corner hypotheses' reach, [`CORNER_REACH_M`]; farther, the
/// global re-localization of [`RELOCALIZE_EVERY_LOST`] takes over).
pub const LOST_WINDOW_MAX_M: f64 = 3.0;

/// Every this many scans lost in a row, the search covers the whole map and the whole circle
/// (a global re-localization): it searches every pose of the map, far more than a window,
/// so it runs on one lost scan in this many.
pub const RELOCALIZE_EVERY_LOST: u32 = 10;

/// Cell of the search raster, metres: twice ICP's point spacing (`align.point_spacing_m`,
/// 0.05 m), half the raster's kernel ([`SEARCH_SIGMA_M`]), so that the exact search's peak is
/// within ICP's basin.
pub const SEARCH_CELL_M: f64 = 0.1;

/// Scale of the search raster's kernel, metres: twice the cell ([`SEARCH_CELL_M`]), so that
/// a pose between cells still scores.
pub const SEARCH_SIGMA_M: f64 = 0.2;

/// About this many scan points are scored per candidate pose: a search's time grows with it
/// (every pose of the window scores each point).
pub const SEARCH_POINTS: usize = 100;

/// Only points within this range of the robot are scored (unless fewer than 20 are), metres:
/// far points sharpen the rotation but make the raster, which covers the window widened by
/// this, larger.
pub const SEARCH_MAX_RANGE_M: f64 = 8.0;

/// ICP from the search's pose replaces ICP from the prediction only with more inliers than
/// this share above the latter's (plus two): the search's pose wins on evidence, not on the
/// noise of two nearly equal fits.
pub const SEARCH_WIN_MARGIN: f64 = 0.1;

/// With `TrackParams::along_unobserved`: when neither ICP nor the window search observed the
/// step along an axis, ICP also runs from poses along it, every
/// [`UNOBSERVED_SEED_STEP_M`](crate::tracking::UNOBSERVED_SEED_STEP_M) up to this far on either
/// side of ICP's pose, metres (8 ICP runs per such scan): the sparse logs' steps are about a
/// metre (median 0.67-1.05 m, `datasets/sparse`).
pub const UNOBSERVED_REACH_M: f64 = 1.0;

// The loose points.

/// Scan points of the last this many scans that lie off the map's segments enter the search
/// raster and ICP (pillars, corners, door frames): the same number of scans as the recent
/// motion, [`RecentMotion::SCANS`](crate::tracking::RecentMotion::SCANS), so that they stay
/// close to where the robot is.
pub const LOOSE_POINT_SCANS: usize = 5;

/// Loose points are thinned to this spacing, metres: the search raster's cell,
/// [`SEARCH_CELL_M`].
pub const LOOSE_POINT_SPACING_M: f64 = 0.1;

// The corner hypotheses.

/// Only corner hypotheses within this distance of the prediction count, metres: the map of a
/// building repeats its corners farther away, and the sparse logs' steps are at most 3.3 m.
pub const CORNER_REACH_M: f64 = 3.0;

/// ICP runs from at most this many distinct corner hypotheses, the best-scoring first (each
/// costs an ICP run).
pub const CORNER_SEEDS: usize = 3;

/// ICP from a corner hypothesis (or the search of a turn on the spot) replaces ICP from the
/// prediction only with this many times its inliers (plus two), and with at least
/// `search.search_below_inlier_share` of the points inliers: a pose away from the prediction
/// needs more evidence than the window search's ([`SEARCH_WIN_MARGIN`])...
pub const CORNER_WIN_RATIO: f64 = 1.5;

/// ...and only when no distinct pose (more than `verdict.rival_apart_m` or
/// `verdict.rival_apart_deg` away) from another hypothesis has this share of its inliers:
/// below the verdict's `ambiguous_above` (0.95), since a corner pose is taken on less
/// evidence of the motion than the window search's.
pub const CORNER_RIVAL_BELOW: f64 = 0.85;

/// ...counting only a rival turned at most this much farther from the motion prior's guess
/// than the corner pose, degrees: a pose as plausible a turn. A corridor fits the scan turned
/// half round nearly as well as the truth, and a robot that stood and drove off 1.9 m turning
/// 14° was held `lost` at 11 inliers where the truth fitted 111, vetoed by its mirror image
/// turned 166° at 106 (ACES every 10th scan, phase 0, scan 477).
pub const CORNER_RIVAL_TURN_DEG: f64 = 45.0;

/// The hypotheses of steps like the robot's own are screened by ICP on every this many of the
/// scan's thinned points (a third of the cost of each run on every point)...
pub const OWN_STEP_SCREEN_EVERY: usize = 3;

/// ...and ICP on every point runs from this many of the screened poses, the best distinct
/// ones (apart by `verdict.rival_apart_m` or `rival_apart_deg`): the best and its rival, the
/// only pose that may veto it. The sparse logs keep 32 of 60 runs within 0.25 m (Intel's
/// default run 2.437 → 0.787 m), and map faster (Orebro 432 → 486 scans/s).
pub const OWN_STEP_REFINED: usize = 2;

/// Only segments at least this long form corners, metres (a scan's segments are short: clutter
/// and door frames cut its walls); the window's smallest half-width, `search.min_window_m`.
pub const CORNER_MIN_SEGMENT_M: f64 = 0.3;

// The robot's reach.

/// The reach of a robot in a time ([`TrackParams::reach`](super::TrackParams::reach)) adds
/// this much for the error of the pose it starts from, metres: the window's smallest
/// half-width, `search.min_window_m`...
pub const REACH_SLACK_M: f64 = 0.3;

/// ...and this, degrees: a little more than the smallest rotation window
/// (`search.min_window_deg`, 15°), as for the translation.
pub const REACH_SLACK_DEG: f64 = 20.0;

// The motion prior fused with the fit ([`crate::tracking::Tracker`], `estimator.rs`).

/// The variance a fit's information is counted in, m²: the information of ICP's final
/// correspondences (weighted points per m², [`TranslationInformation::pose`]) over this is
/// information in 1/m². A point's residual is about a centimetre, but neighbouring points of a
/// wall share their map segment's error (the scan is thinned to 5 cm): 0.0008 m² (2.8 cm per
/// point) puts the fit level with the prior at ten scans a second where it holds the pose by
/// about eight points. Measured at 0.0004, 0.0008 and 0.0015 m² on the dense benchmark logs and
/// the simulated worlds over seeds (record of the fusion): 0.0015 mends bare corridors most but
/// moves FR079 0.0382 → 0.0432 m and the well observed worlds by 2–10 mm; 0.0004 mends little.
///
/// [`TranslationInformation::pose`]: crate::align::TranslationInformation::pose
pub const FIT_VARIANCE_M2: f64 = 0.0008;

/// How far the robot may be from the constant-velocity prediction whatever the time, metres:
/// the error of the step the prediction repeats (its two poses, a few millimetres each).
pub const PRIOR_FLOOR_M: f64 = 0.005;

/// A robot's largest acceleration, m/s²: in `dt` seconds it leaves the constant-velocity
/// prediction by up to half this times `dt²` (5 mm at ten scans a second, 0.5 m at one scan a
/// second, where the prior tells the fit next to nothing), and by this times `dt` times the
/// time since its speed was last observed (a speed observed a second ago may be 1 m/s off).
/// Without that age the prior held ACES's weak scans to a stale speed: 0.0445 → 0.0528 m.
pub const PRIOR_ACCEL_M_S2: f64 = 1.0;

/// The odometry prior's error over one step, metres: a floor (the odometry's resolution and
/// the stamps' jitter)...
pub const ODOMETRY_FLOOR_M: f64 = 0.005;

/// ...and this share of the distance driven (slip, wheel radius; 1 cm at ten scans a second
/// of a robot at 0.5 m/s), generous for a log's odometry that the fit judges by.
pub const ODOMETRY_PER_M: f64 = 0.1;

/// The odometry's heading error over one step, degrees: a floor...
pub const ODOMETRY_TURN_FLOOR_DEG: f64 = 0.5;

/// ...this share of the turn read (wheel base; a turn read 30 % large is three of these)...
pub const ODOMETRY_TURN_SHARE: f64 = 0.1;

/// ...and this much per metre driven, degrees (unequal wheels).
pub const ODOMETRY_TURN_PER_M_DEG: f64 = 2.0;

// Where ICP starts (`[mapper]`).

/// Share of the last scan-to-scan motion kept along directions ICP cannot observe, with the
/// constant-velocity prior, before any motion was observed or with
/// `MapperParams::keep_observed_velocity` off: none (the previous pose, as the paper).
pub const WEAK_DIRECTION_VELOCITY: f64 = 0.0;

/// Soft inlier points by which another start must beat the first (the anchor, "no motion",
/// when it is a start) to be chosen: one point, so that a tie keeps the first.
pub const START_SCORE_MARGIN: f64 = 1.0;
