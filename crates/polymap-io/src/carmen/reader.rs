//! The streaming reader: one line at a time, one reused buffer, never the whole file.

use std::collections::VecDeque;
use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};

use polymap::geometry::Pose2;
use polymap::scan::RangeScan;

use super::error::{CarmenError, LineProblem};
use super::fields::token_count;
use super::messages::{
    FlaserContext, OdometryReading, ParamEffect, parse_flaser, parse_odom, parse_param,
    parse_robotlaser,
};
use super::stats::CarmenStats;

/// Most scans held for the `ODOM` message after a scan with stale odometry
/// ([`ReaderOptions::stale_odometry_s`]); when that many wait, they go on as logged (a log
/// whose odometry stopped for good is not held in memory).
pub const MAX_HELD_SCANS: usize = 64;

/// With `skip_bad_lines`, a line too long is skipped up to its end, if that comes within this
/// many times [`ReaderOptions::max_line_bytes`]; beyond, the input is not a text log (a device
/// such as `/dev/zero` on standard input never ends its first line).
const SKIPPED_LINE_FACTOR: usize = 16;

/// How a [`CarmenReader`] treats its input.
#[derive(Debug, Clone, PartialEq)]
pub struct ReaderOptions {
    /// Skip malformed lines (counting them in [`CarmenStats::bad_lines`]) instead of failing.
    /// Default `false`.
    pub skip_bad_lines: bool,
    /// `FLASER` readings at or above this range are no-returns, metres, unless the log sets
    /// `PARAM robot_front_laser_max` (CARMEN's own parameter, FR079: 80.99), which then applies
    /// to the scans after it. Default 50.
    ///
    /// `FLASER` carries no maximum range. CARMEN assumes 80 m, but the logs write their
    /// no-return code slightly above it (Intel 81.83, FR079 81.91) or at a cap of their own
    /// (ACES 50.00, 11,139 times, with real returns up to 49.91 just below). 50 m makes all
    /// three codes no-returns and drops no real return in any of the three logs (the longest are
    /// 26.37 m in Intel, 36.62 m in FR079, 49.91 m in ACES). `ROBOTLASER1` uses its own
    /// `maximum_range` field instead.
    pub flaser_max_range_m: f64,
    /// Largest reading count accepted on one line. Default 100,000.
    pub max_beams: usize,
    /// Longest line accepted, bytes (the newline excluded). Default 4 MiB.
    pub max_line_bytes: usize,
    /// How many skipped bad lines keep their message in [`CarmenStats::bad_line_messages`].
    /// Default 10.
    pub max_bad_line_messages: usize,
    /// A scan whose odometry pose is farther than this from the previous scan's is counted in
    /// [`CarmenStats::odometry_jumps`] and loses its odometry, metres. Default 10 (a robot at
    /// 2 m/s between scans 5 s apart; the three benchmark logs move at most 0.3 m per scan).
    pub max_odometry_jump_m: f64,
    /// A scan whose odometry pose is the last `ODOM` message's, written more than this before
    /// the scan's stamp, carries stale odometry (the odometry messages stopped, as over a gap
    /// in the log): it takes the odometry interpolated at its stamp between that message and
    /// the next one, when the next one is stamped at or after the scan, and is counted in
    /// [`CarmenStats::stale_odometry`], seconds. Default 1 (ACES's scan after its 3 s gap
    /// carried the odometry of 2.9 s before, which read 45° of the robot's 99° turn; the
    /// benchmark logs' odometry messages come every 0.1–0.2 s).
    pub stale_odometry_s: f64,
}

impl Default for ReaderOptions {
    fn default() -> Self {
        ReaderOptions {
            skip_bad_lines: false,
            flaser_max_range_m: 50.0,
            max_beams: 100_000,
            max_line_bytes: 4 << 20,
            max_bad_line_messages: 10,
            max_odometry_jump_m: 10.0,
            stale_odometry_s: 1.0,
        }
    }
}

/// One message the reader returns.
#[derive(Debug, Clone, PartialEq)]
pub enum CarmenRecord {
    /// A laser scan (`FLASER` or `ROBOTLASER1`).
    Scan(RangeScan),
    /// An odometry message (`ODOM`).
    Odometry(OdometryReading),
}

/// A streaming reader of CARMEN logs: one line in memory at a time.
///
/// Use [`next_scan`](Self::next_scan) for scans only, [`next_record`](Self::next_record) for
/// scans and odometry, or iterate (the iterator yields scans; after an error it continues with
/// the next line, so stop at the first `Err` unless you mean to go on).
#[derive(Debug)]
pub struct CarmenReader<R> {
    input: R,
    path: PathBuf,
    options: ReaderOptions,
    line: Vec<u8>,
    line_number: u64,
    robot_from_laser: Pose2,
    flaser_max_range_m: f64,
    failed: bool,
    stats: CarmenStats,
    /// The previous scan's stamp (seconds) and odometry pose as logged.
    previous: Option<(f64, Option<Pose2>)>,
    /// The last `ODOM` message's stamp (seconds) and pose.
    last_odometry: Option<(f64, Pose2)>,
    /// Scans held until the next `ODOM` message (the first of them carries stale odometry,
    /// [`ReaderOptions::stale_odometry_s`]; the rest keep the file order), each with its line
    /// and whether its odometry is stale.
    held: Vec<(RangeScan, u64, bool)>,
    /// Records ready to return, in file order, before any further line is read.
    ready: VecDeque<CarmenRecord>,
    /// An error met while scans were held: returned after them (file order).
    pending_error: Option<CarmenError>,
}

impl CarmenReader<BufReader<File>> {
    /// Opens a log file for reading.
    pub fn open(path: impl AsRef<Path>, options: ReaderOptions) -> Result<Self, CarmenError> {
        let path = path.as_ref();
        let file = File::open(path).map_err(|source| CarmenError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Ok(Self::from_reader(
            BufReader::with_capacity(1 << 16, file),
            path,
            options,
        ))
    }
}

impl<R: BufRead> CarmenReader<R> {
    /// Reads a log from any buffered input; `path` names it in error messages.
    pub fn from_reader(input: R, path: impl Into<PathBuf>, options: ReaderOptions) -> Self {
        let flaser_max_range_m = options.flaser_max_range_m;
        CarmenReader {
            input,
            path: path.into(),
            options,
            line: Vec::with_capacity(4096),
            line_number: 0,
            robot_from_laser: Pose2::IDENTITY,
            flaser_max_range_m,
            failed: false,
            stats: CarmenStats::default(),
            previous: None,
            last_odometry: None,
            held: Vec::new(),
            ready: VecDeque::new(),
            pending_error: None,
        }
    }

    /// What has been read so far.
    pub fn stats(&self) -> &CarmenStats {
        &self.stats
    }

    /// The file name used in errors.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The next scan in file order, `Ok(None)` at the end of the log.
    pub fn next_scan(&mut self) -> Result<Option<RangeScan>, CarmenError> {
        loop {
            match self.next_record()? {
                None => return Ok(None),
                Some(CarmenRecord::Scan(scan)) => return Ok(Some(scan)),
                Some(CarmenRecord::Odometry(_)) => {}
            }
        }
    }

    /// The next scan or odometry message in file order, `Ok(None)` at the end of the log.
    ///
    /// An error comes after the records before it in the file (scans held for later
    /// odometry, [`ReaderOptions::stale_odometry_s`], are returned first, as logged). After an
    /// I/O error the reader is finished and returns `Ok(None)`.
    pub fn next_record(&mut self) -> Result<Option<CarmenRecord>, CarmenError> {
        if let Some(record) = self.ready.pop_front() {
            return Ok(Some(record));
        }
        if let Some(error) = self.pending_error.take() {
            return Err(error);
        }
        match self.read_record() {
            Err(error) if !self.held.is_empty() => {
                self.pending_error = Some(error);
                Ok(self.release_held())
            }
            other => other,
        }
    }

    /// [`CarmenReader::next_record`] but for an error met while scans are held.
    fn read_record(&mut self) -> Result<Option<CarmenRecord>, CarmenError> {
        loop {
            if let Some(record) = self.ready.pop_front() {
                return Ok(Some(record));
            }
            if self.failed {
                return Ok(self.release_held());
            }
            let read = self.read_line();
            self.failed = read.is_err();
            let outcome = match read? {
                None => return Ok(self.release_held()),
                Some(Err(problem)) => Err(problem),
                Some(Ok(())) => {
                    let line = std::mem::take(&mut self.line);
                    let outcome = self.handle_line(&line);
                    self.line = line;
                    outcome
                }
            };
            match outcome {
                Ok(Some(record)) => return Ok(Some(record)),
                Ok(None) => {}
                Err(problem) => self.bad_line(problem)?,
            }
        }
    }

    /// Reads the next line into `self.line` (newline stripped). `Ok(None)` at the end of input;
    /// `Ok(Some(Err(_)))` for a line that is too long (its remainder is consumed).
    fn read_line(&mut self) -> Result<Option<Result<(), LineProblem>>, CarmenError> {
        self.line.clear();
        let limit = self.options.max_line_bytes;
        let read = (&mut self.input)
            .take(u64::try_from(limit).unwrap_or(u64::MAX).saturating_add(1))
            .read_until(b'\n', &mut self.line)
            .map_err(|e| self.io_error(e))?;
        if read == 0 {
            return Ok(None);
        }
        self.line_number += 1;
        self.stats.lines += 1;
        if self.line.last() == Some(&b'\n') {
            self.line.pop();
        } else if self.line.len() > limit {
            // Not skipping, the run ends on this line: its rest (endless from a device such
            // as /dev/zero) is not read.
            if self.options.skip_bad_lines {
                self.discard_rest_of_line(limit.saturating_mul(SKIPPED_LINE_FACTOR))?;
            }
            return Ok(Some(Err(LineProblem::TooLong { limit_bytes: limit })));
        }
        Ok(Some(Ok(())))
    }

    /// Consumes input up to and including the next newline, without storing it; more than
    /// `max_bytes` without a newline is not a text log, and an error.
    fn discard_rest_of_line(&mut self, max_bytes: usize) -> Result<(), CarmenError> {
        let mut discarded = 0usize;
        loop {
            if discarded > max_bytes {
                return Err(self.io_error(std::io::Error::new(
                    std::io::ErrorKind::InvalidData,
                    format!(
                        "line {} goes on for more than {max_bytes} bytes without an end: not a \
                         text log",
                        self.line_number
                    ),
                )));
            }
            let buf = self.input.fill_buf().map_err(|source| CarmenError::Io {
                path: self.path.clone(),
                source,
            })?;
            if buf.is_empty() {
                return Ok(());
            }
            match buf.iter().position(|&b| b == b'\n') {
                Some(i) => {
                    self.input.consume(i + 1);
                    return Ok(());
                }
                None => {
                    let len = buf.len();
                    self.input.consume(len);
                    discarded = discarded.saturating_add(len);
                }
            }
        }
    }

    /// Interprets one line; `Ok(None)` for lines that yield no record.
    fn handle_line(&mut self, bytes: &[u8]) -> Result<Option<CarmenRecord>, LineProblem> {
        let line = std::str::from_utf8(bytes).map_err(|_| LineProblem::NotUtf8)?;
        let line = line.trim_start_matches(|c: char| c.is_ascii_whitespace());
        if line.is_empty() || line.starts_with('#') {
            self.stats.comment_lines += 1;
            return Ok(None);
        }
        let (name, rest) = line
            .split_once(|c: char| c.is_ascii_whitespace())
            .unwrap_or((line, ""));
        match name {
            "FLASER" => self.scan(parse_flaser(
                rest,
                token_count(rest),
                &self.flaser_context(),
            )?),
            "ROBOTLASER1" => {
                let (scan, fov_mismatch) =
                    parse_robotlaser(rest, token_count(rest), self.options.max_beams)?;
                if fov_mismatch {
                    self.stats.fov_mismatches.count(self.line_number, 0.0);
                }
                self.scan(scan)
            }
            "ODOM" => {
                let odometry = parse_odom(rest, token_count(rest))?;
                self.stats.odometry_messages += 1;
                let (t, pose) = (odometry.stamp.seconds, odometry.odom_from_robot);
                self.resolve_held(t, pose);
                self.last_odometry = Some((t, pose));
                self.ready.push_back(CarmenRecord::Odometry(odometry));
                Ok(None)
            }
            "PARAM" => {
                match parse_param(rest)? {
                    ParamEffect::FrontLaserOffset(x_m) => {
                        self.robot_from_laser = Pose2::new(x_m, 0.0, 0.0);
                    }
                    ParamEffect::FrontLaserMaxRange(r_m) => self.flaser_max_range_m = r_m,
                    ParamEffect::Other => {}
                }
                self.stats.params += 1;
                Ok(None)
            }
            other => {
                self.stats.count_skipped_type(other);
                Ok(None)
            }
        }
    }

    fn flaser_context(&self) -> FlaserContext {
        FlaserContext {
            max_beams: self.options.max_beams,
            max_range_m: self.flaser_max_range_m,
            robot_from_laser: self.robot_from_laser,
        }
    }

    fn scan(&mut self, mut scan: RangeScan) -> Result<Option<CarmenRecord>, LineProblem> {
        self.stats.scans += 1;
        self.stats.count_readings(&scan);
        let line = self.line_number;
        let logged_odometry = scan.odom_from_robot;
        if let Some((stamp_s, previous_odometry)) = self.previous {
            let t = scan.stamp.seconds;
            if t < stamp_s {
                self.stats.stamps_backwards.count(line, stamp_s - t);
            } else if t == stamp_s {
                self.stats.stamps_repeated.count(line, 0.0);
            }
            if let (Some(a), Some(b)) = (previous_odometry, scan.odom_from_robot) {
                let jump_m = (b.translation() - a.translation()).length();
                // A non-finite jump (poses far out) counts too.
                if jump_m.is_nan() || jump_m > self.options.max_odometry_jump_m {
                    self.stats.odometry_jumps.count(line, jump_m);
                    scan.odom_from_robot = None;
                }
            }
        }
        self.previous = Some((scan.stamp.seconds, logged_odometry));
        // Odometry the robot had stopped reporting: held until the next `ODOM` message says
        // where the robot was at the scan's stamp. Scans after it wait too (file order).
        let stale = match (self.last_odometry, scan.odom_from_robot) {
            (Some((t, pose)), Some(odometry)) => {
                odometry == pose && scan.stamp.seconds - t > self.options.stale_odometry_s
            }
            _ => false,
        };
        if stale || !self.held.is_empty() {
            self.held.push((scan, line, stale));
            // Odometry that never resumes must not hold the log in memory: the scans go on
            // as logged.
            if self.held.len() >= MAX_HELD_SCANS {
                return Ok(self.release_held());
            }
            return Ok(None);
        }
        Ok(Some(CarmenRecord::Scan(scan)))
    }

    /// The held scans, now that an `ODOM` message stamped `t` (seconds) reads `pose`: a stale
    /// one whose stamp lies between the last message's and `t` takes the odometry
    /// interpolated at its stamp (counted); all go to the ready records in file order.
    fn resolve_held(&mut self, t: f64, pose: Pose2) {
        for (mut scan, line, stale) in std::mem::take(&mut self.held) {
            if let (true, Some((t0, pose0))) = (stale, self.last_odometry) {
                let ts = scan.stamp.seconds;
                // Not across a jump of the odometry (a reset over the gap): the jump check
                // of the scans after it says so.
                let jump_m = (pose.translation() - pose0.translation()).length();
                let between = (t0 < ts && ts <= t && jump_m <= self.options.max_odometry_jump_m)
                    .then(|| pose0.interpolate(&pose, (ts - t0) / (t - t0)))
                    .filter(Pose2::is_finite);
                match between {
                    Some(odometry) => {
                        scan.odom_from_robot = Some(odometry);
                        self.stats.stale_odometry.count(line, ts - t0);
                    }
                    None => self.stats.stale_odometry_kept.count(line, ts - t0),
                }
            }
            self.ready.push_back(CarmenRecord::Scan(scan));
        }
    }

    /// How many records wait to be returned (held or ready), for tests.
    #[cfg(test)]
    pub(super) fn waiting(&self) -> usize {
        self.held.len() + self.ready.len()
    }

    /// At the end of the input, before an error, or when [`MAX_HELD_SCANS`] wait: the first
    /// held scan, as logged (no later odometry says better); the others follow on the next
    /// calls.
    fn release_held(&mut self) -> Option<CarmenRecord> {
        for (scan, line, stale) in std::mem::take(&mut self.held) {
            if stale {
                let (t0, _) = self.last_odometry.unwrap_or_default();
                self.stats
                    .stale_odometry_kept
                    .count(line, scan.stamp.seconds - t0);
            }
            self.ready.push_back(CarmenRecord::Scan(scan));
        }
        self.ready.pop_front()
    }

    /// Fails on a malformed line, or counts and remembers it when skipping bad lines.
    fn bad_line(&mut self, problem: LineProblem) -> Result<(), CarmenError> {
        let error = CarmenError::Malformed {
            path: self.path.clone(),
            line: self.line_number,
            problem,
        };
        if !self.options.skip_bad_lines {
            return Err(error);
        }
        self.stats.bad_lines += 1;
        if self.stats.bad_line_messages.len() < self.options.max_bad_line_messages {
            self.stats.bad_line_messages.push(error.to_string());
        }
        Ok(())
    }

    fn io_error(&self, source: std::io::Error) -> CarmenError {
        CarmenError::Io {
            path: self.path.clone(),
            source,
        }
    }
}

impl<R: BufRead> Iterator for CarmenReader<R> {
    type Item = Result<RangeScan, CarmenError>;

    fn next(&mut self) -> Option<Self::Item> {
        self.next_scan().transpose()
    }
}
