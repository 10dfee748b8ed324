//! The relations metric of Kümmerle et al. (2009), "On measuring the accuracy of SLAM algorithms".
//!
//! For each ground-truth relation `(t1, t2, robot1_from_robot2)`, the estimated relative pose is
//! `inv(P(t1)) · P(t2)`, with `P(t)` the estimated `map_from_robot` at stamp `t`. The
//! translational error is the length of the difference of the two relative translations (metres);
//! the rotational error is `|wrap(yaw_est − yaw_true)|` (computed in radians, reported in degrees).

use std::fmt;

use polymap::geometry::{Pose2, normalize_angle_rad};
use serde::Serialize;

use crate::relations::Relation;
use crate::stamp_index::{RELATION_STAMP_TOLERANCE_S, StampIndex};
use crate::stats::ErrorStats;

/// Settings of the relations metric.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RelationParams {
    /// Largest difference between a relation's stamp and a trajectory stamp for them to match,
    /// seconds. Default [`RELATION_STAMP_TOLERANCE_S`] (5 µs: the same scan's stamp).
    pub stamp_tolerance_s: f64,
}

impl Default for RelationParams {
    fn default() -> Self {
        RelationParams {
            stamp_tolerance_s: RELATION_STAMP_TOLERANCE_S,
        }
    }
}

/// The error of the estimate on one relation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RelationError {
    /// Index of the relation in the evaluated slice.
    pub relation: usize,
    /// Estimated pose of the robot at `t2` in the robot frame at `t1`.
    pub estimated_robot1_from_robot2: Pose2,
    /// Length of the difference of estimated and true relative translations, metres.
    pub translation_error_m: f64,
    /// `|wrap(yaw_est − yaw_true)|`, radians, in `[0, π]`.
    pub rotation_error_rad: f64,
    /// `|t2 − t1|` of the relation, seconds.
    pub time_apart_s: f64,
}

/// Per-relation errors, and which relations found no pose at `t1` or `t2`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RelationErrors {
    /// Number of relations evaluated.
    pub relations: usize,
    /// One entry per matched relation, in the relations' order.
    pub errors: Vec<RelationError>,
    /// Indices of the relations whose `t1` or `t2` matched no (finite) trajectory pose.
    pub unmatched: Vec<usize>,
}

/// Summary of the relations metric, as the papers report it.
///
/// All spreads are population standard deviations (see [`ErrorStats`]). `None` when no relation
/// was matched.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RelationMetrics {
    /// Number of relations evaluated.
    pub relations: usize,
    /// Relations whose two stamps both matched a trajectory pose.
    pub matched: usize,
    /// Relations with at least one stamp unmatched (`relations − matched`).
    pub unmatched: usize,
    /// Translational error, metres.
    pub translation_m: Option<ErrorStats>,
    /// Rotational error, degrees.
    pub rotation_deg: Option<ErrorStats>,
    /// Squared translational error, m².
    pub translation_2_m2: Option<ErrorStats>,
    /// Squared rotational error, deg².
    pub rotation_2_deg2: Option<ErrorStats>,
    /// The same errors split by how far apart in time the two poses of a relation are (an
    /// addition to the papers' figures): see [`TIME_APART_CLASSES_S`].
    pub by_time_apart: Vec<TimeApartClass>,
}

/// Upper bounds of the classes of [`RelationMetrics::by_time_apart`], seconds. Poses at most
/// 10 s apart measure local tracking; poses more than 100 s apart mostly measure whether the
/// map stayed consistent when the robot came back (loops), which drift accumulated on the way
/// decides.
pub const TIME_APART_CLASSES_S: [f64; 3] = [10.0, 100.0, f64::INFINITY];

/// The errors of the relations whose poses are between `from_s` (exclusive; 0 inclusive) and
/// `to_s` (inclusive) apart.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TimeApartClass {
    /// Lower bound, seconds.
    pub from_s: f64,
    /// Upper bound, seconds; `None` for no bound.
    pub to_s: Option<f64>,
    /// Translational error, metres.
    pub translation_m: Option<ErrorStats>,
    /// Rotational error, degrees.
    pub rotation_deg: Option<ErrorStats>,
    /// The class's share of the overall mean translational error (its errors' sum over all
    /// errors' sum), in [0, 1].
    pub share_of_translation: f64,
}

impl TimeApartClass {
    fn classes(errors: &[RelationError]) -> Vec<TimeApartClass> {
        let total: f64 = errors.iter().map(|e| e.translation_error_m).sum();
        let mut from_s = 0.0;
        TIME_APART_CLASSES_S
            .iter()
            .map(|&to_s| {
                let in_class: Vec<&RelationError> = errors
                    .iter()
                    .filter(|e| {
                        (e.time_apart_s > from_s || from_s == 0.0) && e.time_apart_s <= to_s
                    })
                    .collect();
                let trans: Vec<f64> = in_class.iter().map(|e| e.translation_error_m).collect();
                let rot: Vec<f64> = in_class
                    .iter()
                    .map(|e| e.rotation_error_rad.to_degrees())
                    .collect();
                let class = TimeApartClass {
                    from_s,
                    to_s: to_s.is_finite().then_some(to_s),
                    translation_m: ErrorStats::from_values(&trans),
                    rotation_deg: ErrorStats::from_values(&rot),
                    share_of_translation: if total > 0.0 {
                        trans.iter().sum::<f64>() / total
                    } else {
                        0.0
                    },
                };
                from_s = to_s;
                class
            })
            .collect()
    }

    /// "≤ 10 s", "10–100 s", "> 100 s".
    pub fn label(&self) -> String {
        match (self.from_s, self.to_s) {
            (0.0, Some(t)) => format!("≤ {t:.0} s"),
            (f, Some(t)) => format!("{f:.0}–{t:.0} s"),
            (f, None) => format!("> {f:.0} s"),
        }
    }
}

/// The error of one estimated relative pose against the true one.
///
/// ```
/// use polymap::geometry::Pose2;
/// use polymap_eval::relation_error::pose_difference;
/// let e = pose_difference(&Pose2::new(1.0, 0.0, 3.1), &Pose2::new(1.0, 0.3, -3.1));
/// assert!((e.translation_m - 0.3).abs() < 1e-12);
/// assert!((e.rotation_rad - (2.0 * std::f64::consts::PI - 6.2)).abs() < 1e-9);
/// ```
pub fn pose_difference(estimated: &Pose2, truth: &Pose2) -> PoseDifference {
    PoseDifference {
        translation_m: (estimated.translation() - truth.translation()).length(),
        rotation_rad: normalize_angle_rad(estimated.theta_rad - truth.theta_rad).abs(),
    }
}

/// Difference of two poses as the relations metric measures it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PoseDifference {
    /// Length of the difference of the translations, metres.
    pub translation_m: f64,
    /// Absolute wrapped difference of the angles, radians, in `[0, π]`.
    pub rotation_rad: f64,
}

/// Errors of `trajectory` on every relation.
///
/// `trajectory` holds `(stamp_s, map_from_robot)` pairs in any order; see
/// [`StampIndex`] for how stamps are matched (nearest within the tolerance, first on ties).
/// Poses with a non-finite field count as missing.
pub fn relation_errors(
    relations: &[Relation],
    trajectory: &[(f64, Pose2)],
    params: &RelationParams,
) -> RelationErrors {
    let index = StampIndex::new(trajectory.iter().map(|(t, _)| *t), params.stamp_tolerance_s);
    let pose_at = |t: f64| {
        index
            .find(t)
            .map(|i| trajectory[i].1)
            .filter(Pose2::is_finite)
    };
    let mut errors = Vec::with_capacity(relations.len());
    let mut unmatched = Vec::new();
    for (k, rel) in relations.iter().enumerate() {
        let (Some(p1), Some(p2)) = (pose_at(rel.t1_s), pose_at(rel.t2_s)) else {
            unmatched.push(k);
            continue;
        };
        let estimated = p1.between(&p2);
        let d = pose_difference(&estimated, &rel.robot1_from_robot2);
        errors.push(RelationError {
            relation: k,
            estimated_robot1_from_robot2: estimated,
            translation_error_m: d.translation_m,
            rotation_error_rad: d.rotation_rad,
            time_apart_s: (rel.t2_s - rel.t1_s).abs(),
        });
    }
    RelationErrors {
        relations: relations.len(),
        errors,
        unmatched,
    }
}

/// The relations metric of `trajectory` (`(stamp_s, map_from_robot)` pairs, any order).
///
/// ```
/// use polymap::geometry::Pose2;
/// use polymap_eval::relations::Relation;
/// use polymap_eval::relation_error::{evaluate_relations, RelationParams};
/// let trajectory = [(1.0, Pose2::new(0.0, 0.0, 0.0)), (2.0, Pose2::new(1.1, 0.0, 0.0))];
/// let truth = Relation { t1_s: 1.0, t2_s: 2.0, robot1_from_robot2: Pose2::new(1.0, 0.0, 0.0), line: 1 };
/// let missing = Relation { t1_s: 1.0, t2_s: 7.0, ..truth };
/// let m = evaluate_relations(&[truth, missing], &trajectory, &RelationParams::default());
/// assert_eq!((m.relations, m.matched, m.unmatched), (2, 1, 1));
/// assert!((m.translation_m.unwrap().mean - 0.1).abs() < 1e-12);
/// ```
pub fn evaluate_relations(
    relations: &[Relation],
    trajectory: &[(f64, Pose2)],
    params: &RelationParams,
) -> RelationMetrics {
    RelationMetrics::from_errors(&relation_errors(relations, trajectory, params))
}

impl RelationMetrics {
    /// Summarises per-relation errors.
    pub fn from_errors(errors: &RelationErrors) -> RelationMetrics {
        let trans_m: Vec<f64> = errors
            .errors
            .iter()
            .map(|e| e.translation_error_m)
            .collect();
        let rot_deg: Vec<f64> = errors
            .errors
            .iter()
            .map(|e| e.rotation_error_rad.to_degrees())
            .collect();
        RelationMetrics {
            relations: errors.relations,
            matched: errors.errors.len(),
            unmatched: errors.unmatched.len(),
            translation_m: ErrorStats::from_values(&trans_m),
            rotation_deg: ErrorStats::from_values(&rot_deg),
            translation_2_m2: ErrorStats::of_squares(&trans_m),
            rotation_2_deg2: ErrorStats::of_squares(&rot_deg),
            by_time_apart: TimeApartClass::classes(&errors.errors),
        }
    }

    /// The metrics as pretty-printed JSON.
    pub fn to_json(&self) -> String {
        // Serialising plain numbers and options into a String cannot fail; NaN becomes `null`.
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// A human-readable, aligned markdown table (one row per quantity, then the counts).
    ///
    /// ```
    /// use polymap::geometry::Pose2;
    /// use polymap_eval::relations::Relation;
    /// use polymap_eval::relation_error::{evaluate_relations, RelationParams};
    /// let trajectory = [(1.0, Pose2::IDENTITY), (2.0, Pose2::new(1.0, 0.0, 0.0))];
    /// let r = Relation { t1_s: 1.0, t2_s: 2.0, robot1_from_robot2: Pose2::new(1.0, 0.0, 0.0), line: 1 };
    /// let table = evaluate_relations(&[r], &trajectory, &RelationParams::default()).to_table();
    /// assert!(table.contains("| translation (m)"));
    /// assert!(table.contains("matched 1 of 1"));
    /// ```
    pub fn to_table(&self) -> String {
        self.to_string()
    }
}

impl fmt::Display for RelationMetrics {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "| {:<18} | {:>10} | {:>10} | {:>10} | {:>10} |",
            "quantity", "mean", "std", "median", "max"
        )?;
        writeln!(
            f,
            "| {:-<18} | {:->10} | {:->10} | {:->10} | {:->10} |",
            "", "", "", "", ""
        )?;
        let rows = [
            ("translation (m)", &self.translation_m),
            ("rotation (deg)", &self.rotation_deg),
            ("translation² (m²)", &self.translation_2_m2),
            ("rotation² (deg²)", &self.rotation_2_deg2),
        ];
        for (name, stats) in rows {
            write_stats_row(f, name, stats)?;
        }
        writeln!(
            f,
            "relations: matched {} of {} ({} unmatched); std = population",
            self.matched, self.relations, self.unmatched
        )?;
        writeln!(f)?;
        writeln!(
            f,
            "| {:<14} | {:>9} | {:>18} | {:>16} | {:>14} |",
            "poses apart", "relations", "translation (m)", "rotation (deg)", "share of error"
        )?;
        writeln!(
            f,
            "| {:-<14} | {:->9} | {:->18} | {:->16} | {:->14} |",
            "", "", "", "", ""
        )?;
        for c in &self.by_time_apart {
            let mean =
                |s: &Option<ErrorStats>| s.map_or("-".to_string(), |s| format!("{:.4}", s.mean));
            writeln!(
                f,
                "| {:<14} | {:>9} | {:>18} | {:>16} | {:>13.0}% |",
                c.label(),
                c.translation_m.map_or(0, |s| s.count),
                mean(&c.translation_m),
                mean(&c.rotation_deg),
                100.0 * c.share_of_translation
            )?;
        }
        write!(
            f,
            "(means; relations between poses far apart in time measure whether the map stayed \
             consistent when the robot came back)"
        )
    }
}

/// One aligned table row; dashes when there is nothing to summarise.
fn write_stats_row(
    f: &mut fmt::Formatter<'_>,
    name: &str,
    stats: &Option<ErrorStats>,
) -> fmt::Result {
    match stats {
        Some(s) => {
            writeln!(
                f,
                "| {:<18} | {:>10.4} | {:>10.4} | {:>10.4} | {:>10.4} |",
                name, s.mean, s.std, s.median, s.max
            )
        }
        None => writeln!(
            f,
            "| {:<18} | {:>10} | {:>10} | {:>10} | {:>10} |",
            name, "-", "-", "-", "-"
        ),
    }
}

#[cfg(test)]
mod tests;
