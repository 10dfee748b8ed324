//! Tracking: where each scan is. The motion prior's guess, ICP from the starts it gives, the
//! window search, the corner hypotheses and the rules between them, and the verdict on each
//! scan; scan matching itself (ICP, the raster, the correlative matcher) is [`crate::align`].

mod corner_seeds;
mod params;
mod recent;
mod strategy;
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
pub use verdict::{OdometryWitness, Reason, Tracking, Verdict, verdict};
pub use window::{WindowMatch, search_window, should_search, whole_map_window, window_search};
