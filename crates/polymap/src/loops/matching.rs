//! Matching a completed node's submap against an older node's: ICP from the pose the graph
//! predicts, else a grid search on a score raster and ICP from its distinct peaks, and the
//! tests a match must pass to become a loop edge.

use crate::align::{AlignResult, align_points, score_sample};
use crate::geometry::Pose2;
use crate::map::{GlobalMap, MapSegment};

use super::LoopDiagnostics;
use super::field::{PoseGrid, distinct_peaks, scored_grid};
use super::nodes::{Candidate, NodeGraph};
use crate::align::ScoreRaster;

impl NodeGraph {
    /// The pose of the node in candidate `c`'s frame from their submaps, with whether the grid
    /// grown with the travel found it, or `None` when the match is weak or ambiguous.
    pub(super) fn match_nodes(
        &self,
        k: usize,
        c: &Candidate,
        diagnostics: &mut LoopDiagnostics,
    ) -> Option<(Pose2, bool)> {
        let p = &self.params;
        if c.target.is_empty() {
            return None;
        }
        let predicted = c.predicted;
        let reach_m = self.align.initial_gate_m.max(self.align.final_gate_m);
        let mut index = GlobalMap::new(self.grid_cell_m, reach_m);
        for s in &c.target {
            index.insert(MapSegment {
                segment: *s,
                born_scan: 0,
            });
        }
        let points = &self.submaps[k].points;
        let good = |r: &AlignResult| {
            r.weak_directions == 0
                && r.correspondences as f64 >= p.min_matched_share * points.len() as f64
                && r.inliers as f64 >= p.min_inlier_share * r.correspondences as f64
        };
        let direct = align_points(points, &index, predicted, predicted, &self.align);
        // The prediction is right (the common case on a return with little drift): one ICP.
        if good(&direct)
            && predicted
                .between(&direct.map_from_robot)
                .translation()
                .length()
                < DIRECT_MATCH_MAX_MOVE_M
        {
            return Some((direct.map_from_robot, false));
        }
        // Otherwise: the best starts of a grid around the prediction, each refined by ICP; the
        // grid as wide as the travel between the nodes asks (`search_translation_per_travel`)
        // only where the fixed one found nothing, so that a wider grid's alike places cannot
        // displace a match the fixed grid finds.
        let sample = score_sample(points, &self.align);
        let sigma = self.align.rotation_search_sigma_m;
        let raster = ScoreRaster::of(&c.target, &[], SCORE_CELL_M, sigma);
        diagnostics.searches += 1;
        let steps_r = (p.search_rotation_deg / p.search_rotation_step_deg).floor() as i32;
        let steps = |half_m: f64| (half_m / p.search_step_m).floor() as i32;
        let search = |half_m: f64| -> Option<Pose2> {
            let scored = scored_grid(
                &raster,
                &sample,
                &PoseGrid {
                    center: predicted,
                    steps_xy: steps(half_m),
                    step_m: p.search_step_m,
                    rotations: -steps_r..steps_r + 1,
                    step_rad: p.search_rotation_step_deg.to_radians(),
                },
            );
            let top = scored.first().map_or(0.0, |s| s.0);
            // Too few points near the submap anywhere in the search for half of them to match.
            if top < MIN_TOP_SCORE_SHARE * p.min_matched_share * sample.len() as f64 {
                return None;
            }
            // ICP from the best starts of distinct peaks (each more than a search step and the
            // score's reach, or two rotation steps, from those before and from the prediction)
            // that score at least `RIVAL_SCORE_SHARE` of the best (a peak far below it cannot
            // come near its inliers): a rival place is tried too, not only the best place's
            // neighbourhood.
            let starts = distinct_peaks(
                &scored,
                &[predicted],
                p.search_step_m + self.align.rotation_search_sigma_m,
                (2.0 * p.search_rotation_step_deg).to_radians(),
                SEARCH_PEAKS,
                RIVAL_SCORE_SHARE * top,
            );
            let mut results: Vec<AlignResult> = vec![direct];
            results.extend(
                starts
                    .iter()
                    .map(|start| align_points(points, &index, *start, *start, &self.align)),
            );
            let best = *results.iter().max_by(|a, b| {
                (a.inliers, -a.residual_rms_m)
                    .partial_cmp(&(b.inliers, -b.residual_rms_m))
                    .unwrap_or(std::cmp::Ordering::Equal)
            })?;
            if !good(&best) {
                return None;
            }
            let rival = results
                .iter()
                .filter(|r| {
                    !close(
                        &r.map_from_robot,
                        &best.map_from_robot,
                        RIVAL_MIN_OFFSET_M,
                        RIVAL_MIN_OFFSET_DEG,
                    )
                })
                .map(|r| r.inliers)
                .max()
                .unwrap_or(0);
            (rival as f64 <= p.max_ambiguity * best.inliers as f64).then_some(best.map_from_robot)
        };
        let fixed = search(p.search_translation_m);
        match fixed.is_none() && steps(c.search_half_m) > steps(p.search_translation_m) {
            true => search(c.search_half_m).map(|pose| (pose, true)),
            false => fixed.map(|pose| (pose, false)),
        }
    }
}

/// ICP runs from the best starts of at most this many distinct peaks of the grid search (the
/// best and its rivals).
const SEARCH_PEAKS: usize = 3;

/// The grid search gives up when its best soft score is below this share of
/// `min_matched_share` of the sample (a point within ICP's final gate scores at least 0.3).
const MIN_TOP_SCORE_SHARE: f64 = 0.3;

/// Peaks of the grid search scoring below this share of the best are not tried.
const RIVAL_SCORE_SHARE: f64 = 0.75;

/// ICP from the predicted pose is taken at once when it moved the node less than this, metres
/// (a return with little drift, the common case); otherwise the grid search runs.
const DIRECT_MATCH_MAX_MOVE_M: f64 = 0.3;

/// A result further than this from the best (metres or degrees) is a rival place: if it
/// reaches `max_ambiguity` of the best's inliers the match is ambiguous.
const RIVAL_MIN_OFFSET_M: f64 = 0.5;
/// See [`RIVAL_MIN_OFFSET_M`].
const RIVAL_MIN_OFFSET_DEG: f64 = 5.0;

/// Cell size of the score field of the grid search, metres.
const SCORE_CELL_M: f64 = 0.1;

/// True when two poses are within `m` metres and `deg` degrees.
fn close(a: &Pose2, b: &Pose2, m: f64, deg: f64) -> bool {
    let d = a.between(b);
    d.translation().length() <= m && d.theta_rad.abs() <= deg.to_radians()
}
