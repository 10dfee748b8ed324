//! One configuration tree mirroring the modules, with units in the keys, and presets.

use serde::{Deserialize, Serialize};

use crate::align::{AlignMethod, AlignParams};
use crate::directions::DirectionParams;
use crate::extract::ExtractParams;
use crate::mapper::{MapperParams, MotionPrior};
use crate::merge::MergeParams;
use crate::polyline::PolylineParams;

/// Every parameter of the pipeline, one section per stage.
///
/// `Config::default()` is the measured default; [`Config::paper`] uses the values and choices
/// the paper states.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Config {
    /// Scan to segments.
    pub extract: ExtractParams,
    /// Segments to generalized polylines (for output).
    pub polyline: PolylineParams,
    /// ICP.
    pub align: AlignParams,
    /// Main directions.
    pub directions: DirectionParams,
    /// Vertex insertion, pairing, simplification.
    pub merge: MergeParams,
    /// The loop around the stages.
    pub mapper: MapperParams,
}

/// Names of the presets, for help texts.
pub const PRESETS: &[&str] = &["default", "paper"];

impl Config {
    /// The paper's method as printed: endpoint ICP from the previous pose, pairing threshold
    /// `T_p = 0.05`, at most 3 children, 180 one-degree bins smoothed over 5, no proximity gate,
    /// no re-joining of split pieces, pairing over the whole map.
    ///
    /// ```
    /// let c = polymap::config::Config::paper();
    /// assert_eq!(c.merge.pairing_threshold, 0.05);
    /// assert_eq!(c.merge.max_children, 3);
    /// ```
    pub fn paper() -> Self {
        let d = Config::default();
        Config {
            align: AlignParams {
                method: AlignMethod::Endpoints,
                rotation_search_deg: 0.0,
                ..d.align
            },
            directions: DirectionParams {
                bins: 180,
                window_bins: 5,
                ..d.directions
            },
            merge: MergeParams {
                pairing_threshold: 0.05,
                max_children: 3,
                max_gap_m: f64::INFINITY,
                rejoin_unpaired_pieces: false,
                ..d.merge
            },
            mapper: MapperParams {
                motion_prior: MotionPrior::Previous,
                merge_margin_m: f64::INFINITY,
                also_start_at_anchor: false,
                weak_direction_velocity: 0.0,
                ..d.mapper
            },
            ..d
        }
    }

    /// A preset by name (see [`PRESETS`]).
    pub fn preset(name: &str) -> Option<Self> {
        match name {
            "default" => Some(Config::default()),
            "paper" => Some(Config::paper()),
            _ => None,
        }
    }
}
