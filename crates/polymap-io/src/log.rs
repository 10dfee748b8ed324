//! One entry point for every log polymap reads: the kind is told by content, and scans come
//! out the same way whatever the format.
//!
//! ```no_run
//! use polymap_io::log::{LogOptions, LogSource};
//! let mut log = LogSource::open("run.bag".as_ref(), &LogOptions::default()).unwrap();
//! while let Some(scan) = log.next_scan().unwrap() {
//!     println!("{} {} beams", scan.stamp.text, scan.ranges_m.len());
//! }
//! ```

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufReader, Read};
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use polymap::scan::RangeScan;

use crate::carmen::{CarmenError, CarmenReader, ReaderOptions};
use crate::ros::{RosError, RosFormat, RosScanOptions, RosScanReader, sniff};

/// The kinds of log polymap reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogKind {
    /// A CARMEN text log (`.clf`), the fallback for anything that is not a ROS recording.
    Carmen,
    /// A ROS recording in one of the container formats.
    Ros(RosFormat),
}

impl LogKind {
    /// Tells the kind of `path` by its content (a folder with `metadata.yaml` is a rosbag2
    /// folder; bag, MCAP and SQLite files by their magic bytes; anything else is CARMEN).
    pub fn of(path: &Path) -> Result<Self, LogError> {
        Ok(match sniff(path)? {
            Some(f) => LogKind::Ros(f),
            None if path.is_dir() => {
                return Err(LogError::Ros(RosError::Unsupported {
                    path: path.to_path_buf(),
                    what: "a folder without metadata.yaml is not a rosbag2 bag".into(),
                }));
            }
            None => LogKind::Carmen,
        })
    }

    /// A short name: `CARMEN log`, `ROS 1 bag`, `MCAP file`, `rosbag2 sqlite3 file`,
    /// `rosbag2 folder`.
    pub fn name(&self) -> &'static str {
        match self {
            LogKind::Carmen => "CARMEN log",
            LogKind::Ros(RosFormat::Bag1) => "ROS 1 bag",
            LogKind::Ros(RosFormat::Mcap) => "MCAP file",
            LogKind::Ros(RosFormat::Sqlite) => "rosbag2 sqlite3 file",
            LogKind::Ros(RosFormat::Folder) => "rosbag2 folder",
        }
    }
}

/// How to read a log.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LogOptions {
    /// Skip (and count) bad input — malformed lines, undecodable messages, corrupt chunks —
    /// instead of failing at the first.
    pub skip_bad_input: bool,
    /// ROS: the `LaserScan` topic (default: the only one).
    pub topic: Option<String>,
    /// ROS: attach odometry (`nav_msgs/Odometry`) to each scan, interpolated by time.
    /// CARMEN scans carry their odometry pose anyway.
    pub odometry: bool,
    /// ROS: the `Odometry` topic (default: the only one).
    pub odom_topic: Option<String>,
    /// CARMEN reader settings (its `skip_bad_lines` is taken from `skip_bad_input`).
    pub carmen: ReaderOptions,
}

/// An error of any log reader.
#[derive(Debug, thiserror::Error)]
pub enum LogError {
    /// From the CARMEN reader.
    #[error(transparent)]
    Carmen(#[from] CarmenError),
    /// From a ROS reader.
    #[error(transparent)]
    Ros(#[from] RosError),
}

/// What a log reader has seen so far, in the same terms for every format.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LogStats {
    /// Records read: lines (CARMEN) or messages (ROS).
    pub records: u64,
    /// `lines` or `messages`.
    pub record_unit: &'static str,
    /// What a scan is in this format, for messages (`FLASER or ROBOTLASER1 lines`,
    /// `LaserScan messages on /scan`).
    pub scan_source: String,
    /// Scans returned.
    pub scans: u64,
    /// Odometry messages read.
    pub odometry_messages: u64,
    /// Records the reader does not use: per message type (CARMEN) or per topic (ROS).
    pub skipped: BTreeMap<String, u64>,
    /// Bad lines, messages or chunks skipped (only with `skip_bad_input`).
    pub bad_records: u64,
    /// The first few of their errors.
    pub bad_record_errors: Vec<String>,
    /// Readings that are no-returns.
    pub no_return_readings: u64,
    /// Readings that are real returns.
    pub valid_readings: u64,
    /// ROS with odometry: scans outside the odometry's time span (given the nearest pose).
    pub scans_outside_odometry: u64,
}

enum Inner {
    Carmen(Box<CarmenReader<BufReader<CountingReader<File>>>>),
    Ros(Box<RosScanReader>),
}

/// A log of any kind, read scan by scan in file order.
pub struct LogSource {
    kind: LogKind,
    inner: Inner,
    bytes_read_shared: Arc<AtomicU64>,
    size: u64,
}

impl LogSource {
    /// Opens a log, telling its kind by content.
    pub fn open(path: &Path, options: &LogOptions) -> Result<Self, LogError> {
        let kind = LogKind::of(path)?;
        let size = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
        let bytes_read_shared = Arc::new(AtomicU64::new(0));
        let inner = match kind {
            LogKind::Carmen => {
                let file = File::open(path).map_err(|source| CarmenError::Io {
                    path: path.to_path_buf(),
                    source,
                })?;
                let input = BufReader::with_capacity(
                    1 << 16,
                    CountingReader {
                        inner: file,
                        count: Arc::clone(&bytes_read_shared),
                    },
                );
                let carmen = ReaderOptions {
                    skip_bad_lines: options.skip_bad_input,
                    ..options.carmen.clone()
                };
                Inner::Carmen(Box::new(CarmenReader::from_reader(input, path, carmen)))
            }
            LogKind::Ros(format) => {
                let ros = RosScanOptions {
                    topic: options.topic.clone(),
                    odometry: options.odometry,
                    odom_topic: options.odom_topic.clone(),
                    skip_bad: options.skip_bad_input,
                    ..RosScanOptions::default()
                };
                Inner::Ros(Box::new(RosScanReader::open(path, format, &ros)?))
            }
        };
        Ok(LogSource {
            kind,
            inner,
            bytes_read_shared,
            size,
        })
    }

    /// The kind of log.
    pub fn kind(&self) -> LogKind {
        self.kind
    }

    /// The file's size in bytes (0 for a folder or a stream).
    pub fn size(&self) -> u64 {
        self.size
    }

    /// A counter of the bytes read so far, updated as scans are read (for a progress bar
    /// on another thread).
    pub fn bytes_read(&self) -> Arc<AtomicU64> {
        Arc::clone(&self.bytes_read_shared)
    }

    /// The next scan in file order, `Ok(None)` at the end.
    pub fn next_scan(&mut self) -> Result<Option<RangeScan>, LogError> {
        match &mut self.inner {
            Inner::Carmen(r) => Ok(r.next_scan()?),
            Inner::Ros(r) => {
                let scan = r.next_scan()?;
                self.bytes_read_shared
                    .store(r.position(), Ordering::Relaxed);
                Ok(scan)
            }
        }
    }

    /// What has been read so far.
    pub fn stats(&self) -> LogStats {
        match &self.inner {
            Inner::Carmen(r) => {
                let s = r.stats();
                LogStats {
                    records: s.lines,
                    record_unit: "lines",
                    scan_source: "FLASER or ROBOTLASER1 lines".into(),
                    scans: s.scans,
                    odometry_messages: s.odometry_messages,
                    skipped: s.skipped_types.clone(),
                    bad_records: s.bad_lines,
                    bad_record_errors: s.bad_line_messages.clone(),
                    no_return_readings: s.no_return_readings,
                    valid_readings: s.valid_readings,
                    scans_outside_odometry: 0,
                }
            }
            Inner::Ros(r) => {
                let s = r.stats();
                LogStats {
                    records: s.messages,
                    record_unit: "messages",
                    scan_source: format!("LaserScan messages on {}", r.topic()),
                    scans: s.scans,
                    odometry_messages: s.odometry_messages,
                    skipped: s.other_topics,
                    bad_records: s.bad_messages,
                    bad_record_errors: s.bad_message_errors,
                    no_return_readings: s.no_return_readings,
                    valid_readings: s.valid_readings,
                    scans_outside_odometry: s.scans_outside_odometry,
                }
            }
        }
    }
}

/// Counts the bytes read through it.
struct CountingReader<R> {
    inner: R,
    count: Arc<AtomicU64>,
}

impl<R: Read> Read for CountingReader<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.count.fetch_add(n as u64, Ordering::Relaxed);
        Ok(n)
    }
}
