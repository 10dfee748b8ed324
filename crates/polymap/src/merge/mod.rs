//! Merging map and scan (sections 2.1 and 3.1): vertex insertion, restrictive pairing and
//! simplification, all under the cost `C(L1, L2, ad)` and the current main directions.
//!
//! Addition to the paper: a proximity gate. The cost of two collinear segments is zero at any
//! distance (the collinearity term vanishes and the length ratio only multiplies it), so walls on
//! one line across a doorway would merge. A pair is only considered when the segments come
//! within `max_gap_m` of each other (set it to infinity for the paper's behaviour).

mod bands;
mod candidates;
mod insertion;
mod maps;
mod pairing;
mod scan;
mod simplify;

use serde::{Deserialize, Serialize};

use crate::check::{Checks, InvalidParam};
use crate::cost::{Merge, cost_at_most, unit};
use crate::geometry::{Segment, Vec2};
pub use candidates::{pairs_within, pairs_within_brute, pairs_within_self};
pub use insertion::{Piece, insert_vertices};
pub use maps::{MapMergeParams, MapMergeResult, merge_map};
pub use pairing::{Child, Pairing, restrictive_pairing};
pub use scan::{MergeDiagnostics, MergeResult, merge_scan};
pub use simplify::{Simplified, SimplifiedSegment, simplify, simplify_brute};

/// Parameters of merging.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MergeParams {
    /// `K` of the cost function: balances angular against metric terms (metres here).
    pub k: f64,
    /// `T_p`: a map/scan pair makes a child when its cost is below this.
    pub pairing_threshold: f64,
    /// `T_s`: simplification merges the cheapest pair while its cost is at most this.
    pub simplify_threshold: f64,
    /// Most children one segment may have in pairing (the paper: 3).
    pub max_children: usize,
    /// Proximity gate (an addition): pairs further apart than this never merge, metres.
    /// Infinity gives the paper's behaviour.
    pub max_gap_m: f64,
    /// Vertex insertion: an endpoint splits the other map's nearest segment when it lies within
    /// this distance of it, metres.
    pub insert_max_distance_m: f64,
    /// Vertex insertion: a projection closer than this to an existing endpoint counts as that
    /// endpoint (no split), metres.
    pub insert_min_piece_m: f64,
    /// An addition: pieces of a segment split by vertex insertion that took part in no pairing
    /// are joined back into the original segment, so insertion never fragments a segment that
    /// gained nothing from it.
    pub rejoin_unpaired_pieces: bool,
    /// Locality (an addition): only map segments within this distance (segment to segment) of
    /// a scan segment take part in merging, metres (infinity: the whole map, as in the paper).
    pub local_margin_m: f64,
    /// Support (an addition): a child of pairing lies on the line between its map and scan
    /// parents placed by length × support instead of length alone, where a map parent's
    /// support is the number of scans tracked `ok` that saw it
    /// ([`crate::map::Observations::support`]), at most this, and a scan segment's is 1;
    /// dimensionless, at least 1 (1: the paper's, length alone). Without it every merge moves a
    /// wall a third to a half of the way to the latest scan, so the map follows each scan's
    /// small error and dense runs drift more than sparse ones. `weak` scans do not add
    /// support: along a wall they may have slid, and what they placed must stay movable.
    /// Default 10 (`--preset paper`: 1); measured in `docs/decisions/2026-11-26-support.md`.
    pub support_cap: f64,
}

impl Default for MergeParams {
    fn default() -> Self {
        MergeParams {
            k: 1.0,
            pairing_threshold: 0.05,
            simplify_threshold: 0.05,
            max_children: 3,
            max_gap_m: 0.5,
            insert_max_distance_m: 0.5,
            insert_min_piece_m: 0.1,
            rejoin_unpaired_pieces: true,
            local_margin_m: 1.0,
            support_cap: 10.0,
        }
    }
}

impl MergeParams {
    /// Checks every key's range; the error names the first key out of range.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        let inf = f64::INFINITY;
        Checks::new()
            .within("k", self.k, 0.0, 1e6)
            .within("pairing_threshold", self.pairing_threshold, 0.0, 1e6)
            .within("simplify_threshold", self.simplify_threshold, 0.0, 1e6)
            .within("max_children", self.max_children, 1, 1000)
            .within("max_gap_m", self.max_gap_m, 0.0, inf)
            .within(
                "insert_max_distance_m",
                self.insert_max_distance_m,
                0.0,
                100.0,
            )
            .within("insert_min_piece_m", self.insert_min_piece_m, 0.0, 100.0)
            .within("local_margin_m", self.local_margin_m, 0.0, inf)
            .within("support_cap", self.support_cap, 1.0, 1e6)
            .done()
    }
}

/// The cheapest merge of two segments over the given main directions, if any is defined.
///
/// Ties go to the earlier direction, so results do not depend on floating-point accidents of
/// order. Returns the index of the chosen direction with the merge.
pub fn best_merge(
    l1: &Segment,
    l2: &Segment,
    directions_rad: &[f64],
    k: f64,
) -> Option<(usize, Merge)> {
    best_merge_at_most(l1, l2, &units(directions_rad), k, f64::INFINITY)
}

/// The unit vectors of main directions, for [`best_merge_at_most`].
pub(crate) fn units(directions_rad: &[f64]) -> Vec<Vec2> {
    directions_rad.iter().map(|&ad| unit(ad)).collect()
}

/// [`best_merge`] with the main directions as unit vectors ([`units`]), when its cost is at
/// most `max_cost` (directions that cannot reach it are not costed in full); `None` otherwise.
pub(crate) fn best_merge_at_most(
    l1: &Segment,
    l2: &Segment,
    directions: &[Vec2],
    k: f64,
    max_cost: f64,
) -> Option<(usize, Merge)> {
    let mut best: Option<(usize, Merge)> = None;
    for (i, &ad) in directions.iter().enumerate() {
        if let Some(m) = cost_at_most(l1, l2, ad, k, max_cost)
            .filter(|m| m.cost.is_finite() && m.cost <= max_cost)
            && best.is_none_or(|(_, b)| m.cost < b.cost)
        {
            best = Some((i, m));
        }
    }
    best
}

#[cfg(test)]
mod tests;
