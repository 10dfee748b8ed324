//! Tracking: where each scan is. The motion prior's guess, ICP from the starts it gives, the
//! window search, the corner hypotheses and the rules between them, and the verdict on each
//! scan; scan matching itself (ICP, the raster, the correlative matcher) is [`crate::align`].

mod corner_seeds;
mod motion;
mod strategy;
mod track;

pub use corner_seeds::corner_seeds;
pub use motion::{MapperParams, MotionPrior};
pub use strategy::{
    PRIOR_OVER_WEAK_M, RECOVER_TRANSLATION_M, STOPPED_BELOW_SHARE_OF_STEP, TrackConfig, TrackInput,
    UNOBSERVED_ACROSS_M, UNOBSERVED_SEED_STEP_M, UNOBSERVED_TURN_DEG, better, track_scan,
    whole_map_window,
};
pub use track::{
    LOOSE_OFF_MAP_M, LoosePoints, OdometryWitness, Reason, RecentMotion, TrackParams, Tracking,
    Verdict, WindowMatch, search_window, should_search, verdict, window_search,
};
