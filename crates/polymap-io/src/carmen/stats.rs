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
    /// Scans stamped earlier than the scan before them.
    pub stamps_backwards: Oddity,
    /// Scans stamped exactly as the scan before them.
    pub stamps_repeated: Oddity,
    /// `ROBOTLASER1` scans whose field of view contradicts their beam count and resolution (the
    /// beams follow the resolution).
    pub fov_mismatches: Oddity,
    /// Scans whose odometry pose jumped more than
    /// [`ReaderOptions::max_odometry_jump_m`](super::ReaderOptions) from the scan before: their
    /// odometry is dropped (the mapper then has no odometry guess for them).
    pub odometry_jumps: Oddity,
    /// Scans whose odometry was the last `ODOM` message's, written more than
    /// [`ReaderOptions::stale_odometry_s`](super::ReaderOptions) before them: their odometry
    /// is interpolated at their stamp from the `ODOM` messages around it (`largest`: the
    /// oldest, seconds).
    pub stale_odometry: Oddity,
    /// Scans whose odometry was as stale but kept as logged: no later `ODOM` message
    /// bracketed their stamp (the log ended, the next message is stamped earlier, more than
    /// [`MAX_HELD_SCANS`](super::MAX_HELD_SCANS) scans waited, an error came first) or the
    /// odometry jumped over the gap (`largest`: the oldest, seconds).
    pub stale_odometry_kept: Oddity,
    /// Warnings a reader of another format reports in these terms (a ROS recording whose
    /// witness odometry was dropped); empty for CARMEN.
    pub other_warnings: Vec<String>,
}

/// How often something odd but readable occurred, and where first.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Oddity {
    /// How many times.
    pub count: u64,
    /// The 1-based line of the first time (0 when never).
    pub first_line: u64,
    /// The largest size seen, in the oddity's unit (metres for odometry jumps, seconds for stale
    /// odometry, else 0).
    pub largest: f64,
}

impl Oddity {
    /// Counts one occurrence on `line`, of size `size`.
    pub(crate) fn count(&mut self, line: u64, size: f64) {
        if self.count == 0 {
            self.first_line = line;
        }
        self.count += 1;
        self.largest = self.largest.max(size);
    }
}

impl CarmenStats {
    /// Counts a line of a message type the reader skips.
    pub(crate) fn count_skipped_type(&mut self, name: &str) {
        if let Some(count) = self
            .skipped_types
            .get_mut(crate::printable::printable(name).as_ref())
        {
            *count += 1;
            return;
        }
        let trackable = self.skipped_types.len() < MAX_SKIPPED_TYPE_NAMES
            && name.chars().count() <= MAX_TYPE_NAME_CHARS;
        // Names are kept printable: they end up in messages and summary.json.
        let key = if trackable {
            crate::printable::printable(name).into_owned()
        } else {
            OTHER_TYPES.to_owned()
        };
        *self.skipped_types.entry(key).or_insert(0) += 1;
    }

    /// Counts the valid and no-return readings of a scan.
    pub(crate) fn count_readings(&mut self, scan: &RangeScan) {
        let valid = scan.valid_count() as u64;
        self.valid_readings += valid;
        self.no_return_readings += scan.ranges_m.len() as u64 - valid;
    }

    /// One warning per kind of oddity seen, naming the count and the first line, e.g.
    /// `"631 scans are stamped earlier than the scan before them (first: line 1042)"`.
    pub fn warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        let mut say = |o: &Oddity, what: &str| {
            if o.count > 0 {
                out.push(format!("{} {what} (first: line {})", o.count, o.first_line));
            }
        };
        say(
            &self.stamps_backwards,
            "scan(s) stamped earlier than the scan before them; trajectory.tum keeps the log's stamps",
        );
        say(
            &self.stamps_repeated,
            "scan(s) stamped the same as the scan before them; trajectory.tum keeps the log's stamps",
        );
        say(
            &self.fov_mismatches,
            "ROBOTLASER1 scan(s) whose field of view does not match beam count × resolution; the beams follow the resolution",
        );
        if self.odometry_jumps.count > 0 {
            say(
                &self.odometry_jumps,
                &format!(
                    "scan(s) whose odometry jumped (largest {:.1} m) from the scan before; their odometry is not used",
                    self.odometry_jumps.largest
                ),
            );
        }
        if self.stale_odometry.count > 0 {
            say(
                &self.stale_odometry,
                &format!(
                    "scan(s) whose odometry was up to {:.1} s older than the scan (odometry messages missing); their odometry is interpolated at their stamp from the ODOM messages around it",
                    self.stale_odometry.largest
                ),
            );
        }
        if self.stale_odometry_kept.count > 0 {
            say(
                &self.stale_odometry_kept,
                &format!(
                    "scan(s) whose odometry was up to {:.1} s older than the scan (odometry messages missing) and no later ODOM message says better; their odometry is as logged",
                    self.stale_odometry_kept.largest
                ),
            );
        }
        out.extend(self.other_warnings.iter().cloned());
        out
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
