//! One configuration tree mirroring the modules, with units in the keys, and presets.

use serde::{Deserialize, Serialize};

use crate::align::{AlignMethod, AlignParams, TrackParams};
use crate::directions::DirectionParams;
use crate::extract::ExtractParams;
use crate::loops::LoopParams;
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
    /// Tracking: the window search and the verdict per scan (an addition).
    pub tracking: TrackParams,
    /// Main directions.
    pub directions: DirectionParams,
    /// Vertex insertion, pairing, simplification.
    pub merge: MergeParams,
    /// The loop around the stages.
    pub mapper: MapperParams,
    /// Loop closure (an addition).
    pub loops: LoopParams,
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
                recover_below_inlier_share: 0.0,
                ..d.mapper
            },
            loops: LoopParams {
                enabled: false,
                ..d.loops
            },
            tracking: TrackParams {
                window_search: false,
                ..d.tracking
            },
            ..d
        }
    }

    /// Checks that every value is in a range the pipeline can work with; the message names
    /// the first key that is not.
    ///
    /// ```
    /// let mut c = polymap::config::Config::default();
    /// assert!(c.validate().is_ok());
    /// c.directions.bins = 0;
    /// assert!(c.validate().unwrap_err().contains("directions.bins"));
    /// ```
    pub fn validate(&self) -> Result<(), String> {
        let (e, a, d, m, p) = (
            &self.extract,
            &self.align,
            &self.directions,
            &self.merge,
            &self.mapper,
        );
        let checks: [(&str, bool); 18] = [
            (
                "extract.tolerance_m",
                e.tolerance_m.is_finite() && e.tolerance_m > 0.0,
            ),
            (
                "extract.max_range_m",
                e.max_range_m.is_finite() && e.max_range_m > 0.0 && e.max_range_m <= 1e4,
            ),
            ("extract.min_points", e.min_points >= 2),
            (
                "align.initial_gate_m",
                a.initial_gate_m.is_finite() && a.initial_gate_m > 0.0 && a.initial_gate_m <= 100.0,
            ),
            (
                "align.final_gate_m",
                a.final_gate_m > 0.0 && a.final_gate_m <= a.initial_gate_m,
            ),
            (
                "align.gate_decay",
                a.gate_decay > 0.0 && a.gate_decay <= 1.0,
            ),
            ("align.max_iterations", a.max_iterations <= 10_000),
            (
                "align.rotation_search_deg",
                (0.0..=180.0).contains(&a.rotation_search_deg),
            ),
            (
                "align.rotation_search_step_deg",
                a.rotation_search_step_deg >= 0.1 && a.rotation_search_step_deg <= 90.0,
            ),
            (
                "align.rotation_search_sigma_m",
                a.rotation_search_sigma_m.is_finite() && a.rotation_search_sigma_m > 0.0,
            ),
            ("directions.bins", (1..=3600).contains(&d.bins)),
            (
                "directions.window_bins",
                d.window_bins >= 1 && d.window_bins <= d.bins,
            ),
            ("merge.k", m.k.is_finite() && m.k >= 0.0),
            ("merge.max_gap_m", m.max_gap_m >= 0.0),
            (
                "merge.pairing_threshold",
                m.pairing_threshold.is_finite() && m.simplify_threshold.is_finite(),
            ),
            (
                "mapper.grid_cell_m",
                p.grid_cell_m.is_finite() && (0.05..=100.0).contains(&p.grid_cell_m),
            ),
            ("mapper.merge_margin_m", p.merge_margin_m >= 0.0),
            (
                "mapper.recover_below_inlier_share",
                (0.0..=1.0).contains(&p.recover_below_inlier_share),
            ),
        ];
        match checks.iter().find(|(_, ok)| !ok) {
            Some((key, _)) => Err(format!("{key} is out of range")),
            None => match self.loops.invalid_key().or(self.tracking.invalid_key()) {
                Some(key) => Err(format!("{key} is out of range")),
                None => Ok(()),
            },
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
