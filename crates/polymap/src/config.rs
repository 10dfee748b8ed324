//! One configuration tree mirroring the modules, with units in the keys, and presets.

use serde::{Deserialize, Serialize};

use crate::align::{AlignMethod, AlignParams};
use crate::check::InvalidParam;
use crate::directions::DirectionParams;
use crate::extract::ExtractParams;
use crate::loops::LoopParams;
use crate::map::MapParams;
use crate::merge::MergeParams;
use crate::observe::ObserveParams;
use crate::polyline::PolylineParams;
use crate::tracking::{MapperParams, MotionPrior, TrackParams, WindowSearchParams};

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
    /// Vertex insertion, pairing, simplification, and which map segments take part.
    pub merge: MergeParams,
    /// The map store and its index.
    pub map: MapParams,
    /// The loop around the stages: the motion prior and where ICP starts.
    pub mapper: MapperParams,
    /// Loop closure (an addition).
    pub loops: LoopParams,
    /// What scans observe of the map, and pruning what they contradict (an addition).
    pub observe: ObserveParams,
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
                local_margin_m: f64::INFINITY,
                support_cap: 1.0,
                ..d.merge
            },
            mapper: MapperParams {
                motion_prior: MotionPrior::Previous,
                also_start_at_anchor: false,
                keep_observed_velocity: false,
                recover_below_inlier_share: 0.0,
                ..d.mapper
            },
            loops: LoopParams {
                enabled: false,
                ..d.loops
            },
            tracking: TrackParams {
                search: WindowSearchParams {
                    enabled: false,
                    ..d.tracking.search
                },
                ..d.tracking
            },
            ..d
        }
    }

    /// Checks that every value is in a range the pipeline can work with: each section checks
    /// itself; the error names the first key out of range as `section.key`, with its rule.
    ///
    /// ```
    /// let mut c = polymap::config::Config::default();
    /// assert!(c.validate().is_ok());
    /// c.directions.bins = 0;
    /// assert_eq!(c.validate().unwrap_err().key, "directions.bins");
    /// ```
    pub fn validate(&self) -> Result<(), InvalidParam> {
        let sections: [(&str, Result<(), InvalidParam>); 10] = [
            ("extract", self.extract.validate()),
            ("polyline", self.polyline.validate()),
            ("align", self.align.validate()),
            ("tracking", self.tracking.validate()),
            ("directions", self.directions.validate()),
            ("merge", self.merge.validate()),
            ("map", self.map.validate()),
            ("mapper", self.mapper.validate()),
            ("loops", self.loops.validate()),
            ("observe", self.observe.validate()),
        ];
        for (section, checked) in sections {
            checked.map_err(|e| e.in_section(section))?;
        }
        Ok(())
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_presets_are_valid() {
        for name in PRESETS {
            let c = Config::preset(name).unwrap();
            assert_eq!(c.validate(), Ok(()), "{name}");
        }
    }

    /// The numeric keys under `tree` (subsections included), each as its path of names.
    fn numeric_keys(tree: &serde_json::Value, path: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
        for (key, value) in tree.as_object().unwrap() {
            path.push(key.clone());
            if value.is_object() {
                numeric_keys(value, path, out);
            } else if value.is_f64() || value.is_u64() {
                out.push(path.clone());
            }
            path.pop();
        }
    }

    /// Every numeric key of every section and subsection has a range: some value of it is
    /// refused, and the error names that key (a key nobody checks would pass).
    #[test]
    fn every_key_is_checked() {
        let tree = serde_json::to_value(Config::default()).unwrap();
        let mut keys = Vec::new();
        numeric_keys(&tree, &mut Vec::new(), &mut keys);
        for path in &keys {
            let pointer = format!("/{}", path.join("/"));
            let tries: Vec<serde_json::Value> = if tree.pointer(&pointer).unwrap().is_f64() {
                vec![(-1.0).into()]
            } else {
                vec![0.into(), 1_000_000_000_000u64.into(), u32::MAX.into()]
            };
            let name = path.join(".");
            let refused = tries.into_iter().any(|v| {
                let mut t = tree.clone();
                *t.pointer_mut(&pointer).unwrap() = v;
                let c: Config = match serde_json::from_value(t) {
                    Ok(c) => c,
                    Err(_) => return false,
                };
                c.validate().is_err_and(|e| e.key == name)
            });
            assert!(refused, "{name} accepts every value tried");
        }
        assert!(keys.len() >= 60, "only {} numeric keys found", keys.len());
        assert!(
            keys.iter().any(|p| p.len() == 3),
            "no key of a subsection found"
        );
    }

    /// Zero ICP iterations are refused: they make mapping take minutes.
    #[test]
    fn zero_icp_iterations_are_refused() {
        let mut c = Config::default();
        c.align.max_iterations = 0;
        let e = c.validate().unwrap_err();
        assert_eq!(e.key, "align.max_iterations");
        assert!(e.to_string().contains("must be within [1, 10000]"), "{e}");
    }
}
