//! Tracking: where each scan is. [`Tracker`] holds everything carried from scan to scan (the
//! last poses and the speed last observed, which give the motion prior's guess and anchor; the
//! last `ok` scan; the recent motion; the loose points; the lost streak; the run's
//! [`TrackingSummary`]) and gives each scan its pose and verdict ([`Tracker::track`]) through
//! the per-scan strategy ([`track_scan`]): ICP from the starts, the whole-circle recovery, the
//! window search, the rules along weakly observed axes, corner hypotheses and the search's
//! rival, and the [`verdict`]. Scan matching itself (ICP, the likelihood raster, the
//! correlative matcher, corner poses) is [`crate::align`]; the mapper ([`crate::mapper`])
//! merges, observes and closes loops with what tracking gives.
//!
//! Parts: `tracker.rs` (the state), `speed.rs` (the speed last observed, gaps in the log),
//! `strategy/` (one scan: `starts.rs`, `search.rs`, `axes.rs`, `hypotheses.rs`), `window.rs`
//! (when and how wide to search), `verdict.rs`, `summary.rs`, `params/` (`[tracking]` and
//! `[mapper]`, the fixed values), `recent.rs`, `corner_seeds.rs`.

mod corner_seeds;
mod estimator;
mod params;
mod recent;
mod short_of_odometry;
mod speed;
mod strategy;
mod summary;
mod tracker;
mod verdict;
mod window;

pub use corner_seeds::corner_seeds;
pub use estimator::{PoseCovariance, UNKNOWN_VARIANCE, covariance_of, unknown_covariance};
pub use params::{
    CORNER_MIN_SEGMENT_M, CORNER_REACH_M, CORNER_RIVAL_BELOW, CORNER_RIVAL_TURN_DEG, CORNER_SEEDS,
    CORNER_WIN_RATIO, LOOSE_POINT_SCANS, LOOSE_POINT_SPACING_M, LOST_WINDOW_GROWTH_M,
    LOST_WINDOW_MAX_M, MapperParams, MotionPrior, OdometryCheckParams, REACH_SLACK_DEG,
    REACH_SLACK_M, RELOCALIZE_EVERY_LOST, ReachParams, SEARCH_CELL_M, SEARCH_MAX_RANGE_M,
    SEARCH_POINTS, SEARCH_SIGMA_M, SEARCH_SKIP_ABOVE_INLIER_SHARE, SEARCH_WIN_MARGIN,
    START_SCORE_MARGIN, TrackParams, UNOBSERVED_REACH_M, VerdictParams, WEAK_DIRECTION_VELOCITY,
    WINDOW_DEG_PER_M, WINDOW_PER_RECENT, WINDOW_PER_STEP, WINDOW_PER_TURN, WindowSearchParams,
};
pub use recent::{
    LOOSE_OFF_MAP_M, LoosePoints, OWN_STEP_LENGTH_M, OWN_STEP_TURN_DEG, OWN_STEP_VALUES,
    RecentMotion, STEPS_SEEN, StepsSeen,
};
pub use short_of_odometry::{
    MAX_SHORT_STRETCHES, SHORT_BELOW, SHORT_MIN_STEP_M, SHORT_WINDOW_M, SHORT_WINDOW_STEPS,
    ShortStretch,
};
pub use strategy::{
    PINNED_BELOW_INFORMATION, PRIOR_OVER_WEAK_M, RECOVER_TRANSLATION_M,
    STOPPED_BELOW_SHARE_OF_STEP, TrackConfig, TrackInput, TriedPose, UNOBSERVED_ACROSS_M,
    UNOBSERVED_SEED_STEP_M, UNOBSERVED_TURN_DEG, better, track_scan,
};
pub use summary::{
    MAX_GAP_SCANS, MAX_WEAK_TRAVEL_PARTS, ODOMETRY_CHECK_MIN_TRAVEL_M, ODOMETRY_WITNESS_WITHIN,
    TrackingSummary, WEAK_STRETCH_M, WEAK_TRAVEL_MIN_M, WEAK_TRAVEL_PART_M, WEAK_TRAVEL_SHARE,
    WeakStretch, WeakTravelPart,
};
pub use tracker::{ScanNumber, TrackedScan, Tracker};
pub use verdict::{OdometryWitness, Reason, Tracking, Verdict, verdict};
pub use window::{WindowMatch, search_window, should_search, whole_map_window, window_search};
