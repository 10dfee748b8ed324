//! Finding a trajectory's pose by its time stamp.
//!
//! Logs need not be sorted by time (Intel's scan stamps step backwards 631 times in file order),
//! so the index sorts the stamps once and answers each query by binary search.

/// The default largest difference, in seconds, between a queried stamp and a trajectory stamp
/// for them to count as the same instant, for a trajectory against a true one: 1 ms.
pub const DEFAULT_STAMP_TOLERANCE_S: f64 = 1e-3;

/// The largest difference, in seconds, between a relation's stamp and a trajectory stamp for
/// them to name the same scan: 5 µs. A relations file names scans by their stamps in the log,
/// written to the microsecond, as a trajectory of the same log writes them; a looser tolerance
/// takes a neighbouring scan where a log's stamps bunch and the relation's own scan is not in
/// the trajectory (a run of every k-th scan): Intel's last scans are stamped 1 ms apart while
/// the robot drives on, and at 1 ms a run of every 5th scan was scored 10.9 m off on a
/// relation to a scan it never mapped.
pub const RELATION_STAMP_TOLERANCE_S: f64 = 5e-6;

/// A sorted index over time stamps (seconds) that finds the entry matching a query stamp.
///
/// Among entries within the tolerance, the one nearest in time wins; among equally near entries
/// (e.g. several poses sharing one stamp) the first one in the original order wins.
/// Non-finite stamps are never matched.
///
/// ```
/// use polymap_eval::stamp_index::StampIndex;
/// let stamps = [3.0, 1.0, 2.0, 1.0];
/// let index = StampIndex::new(stamps.iter().copied(), 1e-3);
/// assert_eq!(index.find(1.0), Some(1));
/// assert_eq!(index.find(2.0004), Some(2));
/// assert_eq!(index.find(2.5), None);
/// ```
#[derive(Debug, Clone)]
pub struct StampIndex {
    /// `(stamp_s, position in the original order)`, sorted by stamp, then position.
    sorted: Vec<(f64, usize)>,
    tolerance_s: f64,
}

impl StampIndex {
    /// Builds the index over `stamps_s` (seconds, any order); `tolerance_s` is the largest
    /// accepted difference between a query and a match, in seconds.
    pub fn new(stamps_s: impl IntoIterator<Item = f64>, tolerance_s: f64) -> StampIndex {
        let mut sorted: Vec<(f64, usize)> = stamps_s
            .into_iter()
            .enumerate()
            .filter(|(_, t)| t.is_finite())
            .map(|(i, t)| (t, i))
            .collect();
        sorted.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        StampIndex {
            sorted,
            tolerance_s: tolerance_s.abs(),
        }
    }

    /// Position (in the original order) of the entry matching `stamp_s`, if any lies within the
    /// tolerance.
    pub fn find(&self, stamp_s: f64) -> Option<usize> {
        if !stamp_s.is_finite() {
            return None;
        }
        let lo = self
            .sorted
            .partition_point(|&(t, _)| t < stamp_s - self.tolerance_s);
        let mut best: Option<(f64, usize)> = None;
        for &(t, i) in self.sorted[lo..]
            .iter()
            .take_while(|(t, _)| *t <= stamp_s + self.tolerance_s)
        {
            let d = (t - stamp_s).abs();
            let better = match best {
                None => true,
                Some((bd, bi)) => d < bd || (d == bd && i < bi),
            };
            if better {
                best = Some((d, i));
            }
        }
        best.map(|(_, i)| i)
    }

    /// Positions in the original order of all entries, sorted by stamp (ties: original order).
    ///
    /// Non-finite stamps are left out.
    pub fn sorted_positions(&self) -> impl Iterator<Item = usize> + '_ {
        self.sorted.iter().map(|&(_, i)| i)
    }

    /// Number of indexed (finite) stamps.
    pub fn len(&self) -> usize {
        self.sorted.len()
    }

    /// True when no finite stamp was indexed.
    pub fn is_empty(&self) -> bool {
        self.sorted.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_within_tolerance_wins() {
        let index = StampIndex::new([10.0, 10.0008, 9.9995], 1e-3);
        assert_eq!(index.find(10.0007), Some(1));
        assert_eq!(index.find(9.9996), Some(2));
    }

    #[test]
    fn duplicate_stamps_give_first_in_file_order() {
        let index = StampIndex::new([5.0, 4.0, 5.0, 5.0], 1e-3);
        assert_eq!(index.find(5.0), Some(0));
    }

    #[test]
    fn non_finite_stamps_are_ignored() {
        let index = StampIndex::new([f64::NAN, 1.0, f64::INFINITY], 1e-3);
        assert_eq!(index.len(), 1);
        assert_eq!(index.find(f64::NAN), None);
        assert_eq!(index.find(1.0), Some(1));
    }

    #[test]
    fn large_epoch_stamps_keep_microseconds() {
        // Intel's stamps are ~1e9 s; f64 still resolves them to ~1e-7 s.
        let index = StampIndex::new([976052905.167303, 976052905.167304], 1e-7);
        assert_eq!(index.find(976052905.167304), Some(1));
    }
}
