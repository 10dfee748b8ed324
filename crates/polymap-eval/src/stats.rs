//! Summary statistics of a list of non-negative errors.

use serde::Serialize;

/// Summary of a list of error values, all in the unit of the values (named by the owning field).
///
/// The standard deviation is the **population** standard deviation, `sqrt(Σ(x − mean)² / n)`,
/// as `sqrt(E[x²] − E[x]²)` in the papers' evaluation tools; with a single value it is `0`.
/// The median of an even count is the mean of the two middle values.
///
/// ```
/// use polymap_eval::stats::ErrorStats;
/// let s = ErrorStats::from_values(&[1.0, 2.0, 3.0, 4.0]).unwrap();
/// assert_eq!(s.count, 4);
/// assert_eq!(s.mean, 2.5);
/// assert_eq!(s.median, 2.5);
/// assert_eq!(s.max, 4.0);
/// assert!((s.std - 1.25f64.sqrt()).abs() < 1e-12);
/// assert!((s.rms - 7.5f64.sqrt()).abs() < 1e-12);
/// assert!(ErrorStats::from_values(&[]).is_none());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ErrorStats {
    /// Number of values summarised.
    pub count: usize,
    /// Arithmetic mean.
    pub mean: f64,
    /// Population standard deviation (divides by `count`, not `count − 1`).
    pub std: f64,
    /// Root mean square, `sqrt(Σx² / n)`.
    pub rms: f64,
    /// Median.
    pub median: f64,
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
}

impl ErrorStats {
    /// Summarises `values`; `None` when the list is empty.
    ///
    /// Values are expected finite; a NaN propagates into mean, std and rms.
    pub fn from_values(values: &[f64]) -> Option<ErrorStats> {
        if values.is_empty() {
            return None;
        }
        let n = values.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        let var = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n;
        let mean_2 = values.iter().map(|v| v * v).sum::<f64>() / n;
        let mut sorted = values.to_vec();
        sorted.sort_by(f64::total_cmp);
        Some(ErrorStats {
            count: values.len(),
            mean,
            std: var.sqrt(),
            rms: mean_2.sqrt(),
            median: median_of_sorted(&sorted),
            min: sorted[0],
            max: sorted[sorted.len() - 1],
        })
    }

    /// The same statistics of the squared values (`x²` for every `x`).
    ///
    /// ```
    /// use polymap_eval::stats::ErrorStats;
    /// let s = ErrorStats::of_squares(&[1.0, 3.0]).unwrap();
    /// assert_eq!(s.mean, 5.0);
    /// assert_eq!(s.std, 4.0);
    /// ```
    pub fn of_squares(values: &[f64]) -> Option<ErrorStats> {
        let squares: Vec<f64> = values.iter().map(|v| v * v).collect();
        ErrorStats::from_values(&squares)
    }
}

/// Median of a non-empty sorted slice.
fn median_of_sorted(sorted: &[f64]) -> f64 {
    debug_assert!(!sorted.is_empty());
    let mid = sorted.len() / 2;
    if sorted.len() % 2 == 1 {
        sorted[mid]
    } else {
        0.5 * (sorted[mid - 1] + sorted[mid])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn single_value_has_zero_spread() {
        let s = ErrorStats::from_values(&[0.7]).unwrap();
        assert_eq!(
            (s.mean, s.std, s.median, s.min, s.max),
            (0.7, 0.0, 0.7, 0.7, 0.7)
        );
    }

    #[test]
    fn median_of_odd_count_ignores_order() {
        let s = ErrorStats::from_values(&[5.0, 1.0, 3.0]).unwrap();
        assert_eq!(s.median, 3.0);
        assert_eq!(s.min, 1.0);
    }
}
