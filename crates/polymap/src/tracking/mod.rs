//! Tracking: where each scan is. [`Tracker`] holds everything carried from scan to scan (the
//! last poses and the speed last observed, which give the motion prior's guess and anchor; the
//! last `ok` scan; the recent motion; the loose points; the lost streak; the run's
//! [`TrackingSummary`]) and gives each scan its pose and verdict ([`Tracker::track`]) through
//! the per-scan strategy ([`track_scan`]): ICP from the starts, the recovery after a gap, the
//! window search, the rules along weakly observed axes, corner hypotheses and the search's
//! rival, and the [`verdict`]. Scan matching itself (ICP, the likelihood raster, the
//! correlative matcher, corner poses) is [`crate::align`]; the mapper ([`crate::mapper`])
//! merges, observes and closes loops with what tracking gives.
//!
//! Parts: `tracker.rs` (the state), `speed.rs` (the speed last observed, gaps in the log),
//! `strategy/` (one scan: `starts.rs`, `search.rs`, `axes.rs`, `hypotheses.rs`), `window.rs`
//! (when and how wide to search), `verdict.rs`, `summary.rs`, `params.rs` (`[tracking]` and
//! `[mapper]`), `recent.rs`, `corner_seeds.rs`.

mod corner_seeds;
mod params;
mod recent;
mod speed;
mod strategy;
mod summary;
mod tracker;
mod verdict;
mod window;

pub use corner_seeds::corner_seeds;
pub use params::{MapperParams, MotionPrior, TrackParams};
pub use recent::{LOOSE_OFF_MAP_M, LoosePoints, RecentMotion};
pub use strategy::{
    PINNED_BELOW_INFORMATION, PRIOR_OVER_WEAK_M, RECOVER_TRANSLATION_M,
    STOPPED_BELOW_SHARE_OF_STEP, TrackConfig, TrackInput, UNOBSERVED_ACROSS_M,
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
