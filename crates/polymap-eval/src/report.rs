//! Benchmark table rows (one line per log, markdown) and the published reference figures on
//! the same logs and metric, so a table can print them beside ours.
//!
//! Columns: log | scans | segments | relation error (m ± std, deg ± std) | points within 10 cm |
//! scans/s. Translations are printed with 4 decimals (m), rotations with 3 (deg).

use serde::Serialize;

use crate::stats::ErrorStats;

mod published;

pub use published::{LOG_SCANS, PUBLISHED_FIGURES};

/// A mean and its (population) standard deviation, in the unit of the owning field.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MeanStd {
    /// Mean.
    pub mean: f64,
    /// Standard deviation.
    pub std: f64,
}

impl From<&ErrorStats> for MeanStd {
    fn from(s: &ErrorStats) -> Self {
        MeanStd {
            mean: s.mean,
            std: s.std,
        }
    }
}

/// One benchmark result, as the benchmark script prints it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BenchmarkRow {
    /// Log name, e.g. `intel`.
    pub log: String,
    /// Scans processed.
    pub scans: usize,
    /// Segments in the final map.
    pub segments: usize,
    /// Relations metric, translational error, metres; `None` without relations.
    pub relation_translation_m: Option<MeanStd>,
    /// Relations metric, rotational error, degrees; `None` without relations.
    pub relation_rotation_deg: Option<MeanStd>,
    /// Share of scan points within 10 cm of the map, in `[0, 1]`; `None` if not measured.
    pub points_within_10cm_share: Option<f64>,
    /// Processing speed, scans per second of wall-clock time.
    pub scans_per_s: f64,
}

/// The table's header: column names and the markdown separator line.
///
/// ```
/// let h = polymap_eval::report::markdown_header();
/// assert!(h.starts_with("| log |"));
/// assert_eq!(h.lines().count(), 2);
/// ```
pub fn markdown_header() -> String {
    "| log | scans | segments | relation error | points within 10 cm | scans/s |\n\
     | --- | ---: | ---: | --- | ---: | ---: |"
        .to_string()
}

impl BenchmarkRow {
    /// The row as one markdown table line (no trailing newline).
    ///
    /// ```
    /// use polymap_eval::report::{BenchmarkRow, MeanStd};
    /// let row = BenchmarkRow {
    ///     log: "intel".into(), scans: 13631, segments: 420,
    ///     relation_translation_m: Some(MeanStd { mean: 0.031, std: 0.026 }),
    ///     relation_rotation_deg: Some(MeanStd { mean: 1.3, std: 4.7 }),
    ///     points_within_10cm_share: Some(0.9512), scans_per_s: 812.34,
    /// };
    /// assert_eq!(
    ///     row.to_markdown(),
    ///     "| intel | 13631 | 420 | 0.0310 ± 0.0260 m, 1.300 ± 4.700° | 95.1 % | 812.3 |"
    /// );
    /// ```
    pub fn to_markdown(&self) -> String {
        let within = self
            .points_within_10cm_share
            .map_or("-".to_string(), |s| format!("{:.1} %", 100.0 * s));
        format!(
            "| {} | {} | {} | {} | {} | {:.1} |",
            self.log,
            self.scans,
            self.segments,
            relation_cell(self.relation_translation_m, self.relation_rotation_deg),
            within,
            self.scans_per_s
        )
    }
}

/// `a ± b m, c ± d°`, with dashes for what is missing.
fn relation_cell(translation_m: Option<MeanStd>, rotation_deg: Option<MeanStd>) -> String {
    let t = translation_m.map_or("-".to_string(), |t| {
        format!("{:.4} ± {:.4} m", t.mean, t.std)
    });
    match rotation_deg {
        Some(r) => format!("{t}, {:.3} ± {:.3}°", r.mean, r.std),
        None => t,
    }
}

/// A published result of the relations metric on one of the benchmark logs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PublishedFigure {
    /// Log name: `intel`, `aces` or `fr079`.
    pub log: &'static str,
    /// The method, e.g. `graph mapping`.
    pub method: &'static str,
    /// Where the figure comes from.
    pub source: &'static str,
    /// Translational error, metres.
    pub translation_m: MeanStd,
    /// Rotational error, degrees, when published.
    pub rotation_deg: Option<MeanStd>,
    /// Wall-clock time for the whole log, seconds, when published (on the authors' machine).
    pub wall_clock_s: Option<f64>,
}

/// The published figures for one log (case-insensitive name), in table order.
///
/// ```
/// use polymap_eval::report::published_for;
/// let intel: Vec<_> = published_for("Intel").collect();
/// assert_eq!(intel.len(), 4);
/// assert_eq!(intel[2].translation_m.mean, 0.031);
/// ```
pub fn published_for(log: &str) -> impl Iterator<Item = &'static PublishedFigure> + '_ {
    PUBLISHED_FIGURES
        .iter()
        .filter(move |f| f.log.eq_ignore_ascii_case(log))
}

impl PublishedFigure {
    /// The figure as a row of the benchmark table: log column `log: method (source)`, scans
    /// and segments `-`, scans/s from the published wall-clock time when there is one.
    ///
    /// ```
    /// use polymap_eval::report::published_for;
    /// let carto = published_for("aces").last().unwrap();
    /// assert_eq!(
    ///     carto.to_markdown(),
    ///     "| aces: Cartographer (Hess et al. 2016) | - | - | 0.0375 ± 0.0426 m, 0.373 ± 0.469° | - | 179.9 |"
    /// );
    /// ```
    pub fn to_markdown(&self) -> String {
        let scans = LOG_SCANS
            .iter()
            .find(|(log, _)| *log == self.log)
            .map(|(_, n)| *n as f64);
        let speed = match (scans, self.wall_clock_s) {
            (Some(n), Some(s)) if s > 0.0 => format!("{:.1}", n / s),
            _ => "-".to_string(),
        };
        format!(
            "| {}: {} ({}) | - | - | {} | - | {} |",
            self.log,
            self.method,
            self.source,
            relation_cell(Some(self.translation_m), self.rotation_deg),
            speed
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn twelve_figures_four_per_log() {
        assert_eq!(PUBLISHED_FIGURES.len(), 12);
        for (log, _) in LOG_SCANS {
            assert_eq!(published_for(log).count(), 4, "{log}");
        }
    }

    #[test]
    fn rows_without_relations_use_dashes() {
        let row = BenchmarkRow {
            log: "sim".into(),
            scans: 10,
            segments: 3,
            relation_translation_m: None,
            relation_rotation_deg: None,
            points_within_10cm_share: None,
            scans_per_s: 5.0,
        };
        assert_eq!(row.to_markdown(), "| sim | 10 | 3 | - | - | 5.0 |");
    }

    #[test]
    fn translation_only_figures_print_without_degrees() {
        let sm = published_for("fr079").next().unwrap();
        assert_eq!(
            sm.to_markdown(),
            "| fr079: scan matching (Kümmerle et al. 2009) | - | - | 0.2580 ± 0.4270 m | - | - |"
        );
    }

    #[test]
    fn header_and_rows_have_the_same_column_count() {
        let cols = |s: &str| s.matches('|').count();
        let h = markdown_header();
        let first = published_for("intel").next().unwrap().to_markdown();
        assert!(h.lines().all(|l| cols(l) == cols(&first)));
    }
}
