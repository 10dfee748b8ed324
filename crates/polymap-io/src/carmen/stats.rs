//! What the reader has seen so far.

use std::collections::BTreeMap;

use polymap::scan::RangeScan;

/// Most distinct skipped message types tracked by name; later ones count under [`OTHER_TYPES`].
const MAX_SKIPPED_TYPE_NAMES: usize = 256;
/// Longest message type name tracked; longer names count under [`OTHER_TYPES`].
const MAX_TYPE_NAME_CHARS: usize = 64;
/// The bucket for skipped message types beyond the limits above.
pub const OTHER_TYPES: &str = "<other>";

/// Counts of what a [`CarmenReader`](super::CarmenReader) has read so far.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CarmenStats {
    /// Lines read (including comments, blank and bad lines).
    pub lines: u64,
    /// Scans returned (`FLASER` and `ROBOTLASER1`).
    pub scans: u64,
    /// `ODOM` messages read.
    pub odometry_messages: u64,
    /// `PARAM` lines read.
    pub params: u64,
    /// Comment (`#`) and blank lines.
    pub comment_lines: u64,
    /// Lines of message types the reader does not use, per type name.
    pub skipped_types: BTreeMap<String, u64>,
    /// Malformed lines skipped (only with `skip_bad_lines`).
    pub bad_lines: u64,
    /// The first few skipped bad lines' errors, `path:line: problem`, for a warning at the end.
    pub bad_line_messages: Vec<String>,
    /// Readings that are no-returns: non-finite, non-positive, or at/above the scan's max range.
    pub no_return_readings: u64,
    /// Readings that are real returns.
    pub valid_readings: u64,
}

impl CarmenStats {
    /// Counts a line of a message type the reader skips.
    pub(crate) fn count_skipped_type(&mut self, name: &str) {
        if let Some(count) = self.skipped_types.get_mut(name) {
            *count += 1;
            return;
        }
        let trackable = self.skipped_types.len() < MAX_SKIPPED_TYPE_NAMES
            && name.chars().count() <= MAX_TYPE_NAME_CHARS;
        let key = if trackable { name } else { OTHER_TYPES };
        *self.skipped_types.entry(key.to_owned()).or_insert(0) += 1;
    }

    /// Counts the valid and no-return readings of a scan.
    pub(crate) fn count_readings(&mut self, scan: &RangeScan) {
        let valid = scan.valid_count() as u64;
        self.valid_readings += valid;
        self.no_return_readings += scan.ranges_m.len() as u64 - valid;
    }

    /// Total lines of all skipped message types.
    ///
    /// ```
    /// use polymap_io::carmen::CarmenStats;
    /// let mut stats = CarmenStats::default();
    /// stats.skipped_types.insert("RLASER".into(), 3);
    /// stats.skipped_types.insert("SYNC".into(), 2);
    /// assert_eq!(stats.skipped_lines(), 5);
    /// ```
    pub fn skipped_lines(&self) -> u64 {
        self.skipped_types.values().sum()
    }
}
