//! Bounded-memory summaries of per-scan streams: min/max bucketing for plotted series, and
//! stride doubling for the trajectory and the snapshots.

use super::SeriesPoint;

/// A streaming min/max decimator: scans are grouped in buckets of `bucket_scans` consecutive
/// scan indices, and each bucket keeps its smallest and largest value. When there are more than
/// `max_buckets` buckets, neighbours merge and the bucket width doubles, so memory stays
/// bounded however long the run.
#[derive(Debug, Clone)]
pub(crate) struct MinMaxSeries {
    bucket_scans: u32,
    max_buckets: usize,
    buckets: Vec<(SeriesPoint, SeriesPoint)>,
}

impl MinMaxSeries {
    /// A decimator that yields at most `max_points` points (at least 2).
    pub(crate) fn new(max_points: usize) -> Self {
        MinMaxSeries {
            bucket_scans: 1,
            max_buckets: (max_points / 2).max(1),
            buckets: Vec::new(),
        }
    }

    /// Adds one point; non-finite values are skipped. Scan indices should not decrease.
    pub(crate) fn push(&mut self, p: SeriesPoint) {
        if !p.value.is_finite() {
            return;
        }
        let id = p.scan_index / self.bucket_scans;
        match self.buckets.last_mut() {
            Some(last) if bucket_id(last, self.bucket_scans) == id => merge_into(last, p, p),
            _ => self.buckets.push((p, p)),
        }
        while self.buckets.len() > self.max_buckets && self.bucket_scans < u32::MAX / 2 {
            self.coarsen();
        }
    }

    /// Doubles the bucket width, merging buckets that now share an id.
    fn coarsen(&mut self) {
        self.bucket_scans *= 2;
        let width = self.bucket_scans;
        let mut merged: Vec<(SeriesPoint, SeriesPoint)> = Vec::with_capacity(self.buckets.len());
        for b in self.buckets.drain(..) {
            match merged.last_mut() {
                Some(last) if bucket_id(last, width) == bucket_id(&b, width) => {
                    merge_into(last, b.0, b.1);
                }
                _ => merged.push(b),
            }
        }
        self.buckets = merged;
    }

    /// The kept points in scan order: each bucket's min and max (once when they coincide).
    pub(crate) fn points(&self) -> Vec<SeriesPoint> {
        let mut out = Vec::with_capacity(2 * self.buckets.len());
        for &(min, max) in &self.buckets {
            let (a, b) = if min.scan_index <= max.scan_index {
                (min, max)
            } else {
                (max, min)
            };
            out.push(a);
            if a != b {
                out.push(b);
            }
        }
        out
    }
}

fn bucket_id(b: &(SeriesPoint, SeriesPoint), width: u32) -> u32 {
    b.0.scan_index.min(b.1.scan_index) / width
}

fn merge_into(b: &mut (SeriesPoint, SeriesPoint), min: SeriesPoint, max: SeriesPoint) {
    if min.value < b.0.value {
        b.0 = min;
    }
    if max.value > b.1.value {
        b.1 = max;
    }
}

/// Decimates a series to at most `max_points` points (at least 2) by min/max bucketing over
/// scan indices, keeping spikes; non-finite values are dropped.
///
/// ```
/// use polymap_export::report::{SeriesPoint, decimate_min_max};
/// let spiky = (0..10_000u32).map(|i| SeriesPoint { scan_index: i, value: if i == 5_000 { 9.0 } else { 1.0 } });
/// let kept = decimate_min_max(spiky, 100);
/// assert!(kept.len() <= 100);
/// assert!(kept.iter().any(|p| p.value == 9.0 && p.scan_index == 5_000));
/// ```
pub fn decimate_min_max(
    points: impl IntoIterator<Item = SeriesPoint>,
    max_points: usize,
) -> Vec<SeriesPoint> {
    let mut series = MinMaxSeries::new(max_points);
    for p in points {
        series.push(p);
    }
    series.points()
}

/// Keeps the items whose scan index is a multiple of a stride, doubling the stride (and
/// dropping the items that are no longer multiples) whenever `cost` of the kept items exceeds
/// `budget`. The newest item is always kept in `last`, whatever the stride.
#[derive(Debug, Clone)]
pub(crate) struct StrideThinning<T> {
    pub(crate) stride: u32,
    pub(crate) kept: Vec<(u32, T)>,
    kept_cost: usize,
}

impl<T> StrideThinning<T> {
    pub(crate) fn new() -> Self {
        StrideThinning {
            stride: 1,
            kept: Vec::new(),
            kept_cost: 0,
        }
    }

    /// True when an item at `scan_index` would be kept.
    pub(crate) fn is_due(&self, scan_index: u32) -> bool {
        scan_index.is_multiple_of(self.stride)
    }

    /// Keeps `item` (call only when [`Self::is_due`]), then thins to fit `budget`, never below
    /// one kept item.
    pub(crate) fn push(
        &mut self,
        scan_index: u32,
        item: T,
        budget: usize,
        cost: impl Fn(&T) -> usize,
    ) {
        self.kept_cost += cost(&item);
        self.kept.push((scan_index, item));
        while self.kept_cost > budget && self.kept.len() > 1 && self.stride < u32::MAX / 2 {
            self.stride *= 2;
            let stride = self.stride;
            self.kept.retain(|(i, _)| i % stride == 0);
            self.kept_cost = self.kept.iter().map(|(_, t)| cost(t)).sum();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pt(scan_index: u32, value: f64) -> SeriesPoint {
        SeriesPoint { scan_index, value }
    }

    #[test]
    fn short_series_are_kept_whole() {
        let points: Vec<SeriesPoint> = (0..50).map(|i| pt(i, f64::from(i % 7))).collect();
        assert_eq!(decimate_min_max(points.clone(), 4000), points);
    }

    #[test]
    fn long_series_keep_extremes_within_the_cap_in_order() {
        let points = (0..13_631u32).map(|i| pt(i, (f64::from(i) * 0.37).sin()));
        let with_spikes = points.map(|p| match p.scan_index {
            777 => pt(777, 50.0),
            9000 => pt(9000, -50.0),
            _ => p,
        });
        let kept = decimate_min_max(with_spikes, 4000);
        assert!(kept.len() <= 4000 && kept.len() > 2000, "{}", kept.len());
        assert!(kept.contains(&pt(777, 50.0)) && kept.contains(&pt(9000, -50.0)));
        assert!(kept.windows(2).all(|w| w[0].scan_index < w[1].scan_index));
        assert_eq!(kept.first().map(|p| p.scan_index), Some(0));
    }

    #[test]
    fn non_finite_values_are_dropped() {
        let kept = decimate_min_max([pt(0, 1.0), pt(1, f64::NAN), pt(2, f64::INFINITY)], 10);
        assert_eq!(kept, vec![pt(0, 1.0)]);
    }

    #[test]
    fn stride_thinning_doubles_and_keeps_multiples() {
        let mut thin = StrideThinning::new();
        for i in 0..1000u32 {
            if thin.is_due(i) {
                thin.push(i, i, 100, |_| 1);
            }
        }
        assert!(
            thin.kept.len() <= 100 && thin.kept.len() > 50,
            "{}",
            thin.kept.len()
        );
        let stride = thin.stride;
        assert!(thin.kept.iter().all(|(i, _)| i % stride == 0));
        assert_eq!(thin.kept.first().map(|k| k.0), Some(0));
    }

    #[test]
    fn stride_thinning_keeps_one_item_over_budget() {
        let mut thin = StrideThinning::new();
        thin.push(0, (), 1, |_| 10);
        thin.push(1, (), 1, |_| 10);
        assert_eq!(thin.kept.len(), 1);
    }
}
