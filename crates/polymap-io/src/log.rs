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
use std::path::{Path, PathBuf};

use polymap::scan::RangeScan;

use crate::carmen::{CarmenError, CarmenStats, ReaderOptions};
use crate::ros::{RosError, RosFormat, RosScanOptions, RosScanReader, TfStats, sniff};
use crate::source::{self, ScanSource};

/// The kinds of log polymap reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogKind {
    /// A CARMEN text log (`.clf`), the fallback for anything that is not a ROS recording.
    Carmen,
    /// A ROS recording in one of the container formats.
    Ros(RosFormat),
    /// Scans arriving as they are taken ([`LogSource::live`]), never told from a path.
    Live,
}

impl LogKind {
    /// Tells the kind of `path` by its content (a folder with `metadata.yaml` is a rosbag2
    /// folder; bag, MCAP and SQLite files by their magic bytes; anything else, and standard
    /// input `-`, is CARMEN, which [`source::open_log`] reads plain or compressed).
    pub fn of(path: &Path) -> Result<Self, LogError> {
        if path.as_os_str() == "-" {
            return Ok(LogKind::Carmen);
        }
        refuse_device(path)?;
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
            LogKind::Live => "live topic",
        }
    }
}

/// Refuses a device or a socket named as the log (`/dev/zero` never ends): a log is a file, a
/// folder, or a stream through a pipe (`-`, or a FIFO such as a shell's `<(…)`).
fn refuse_device(path: &Path) -> Result<(), LogError> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let Ok(t) = std::fs::metadata(path).map(|m| m.file_type()) else {
            return Ok(()); // opening it names the problem
        };
        if !(t.is_char_device() || t.is_block_device() || t.is_socket()) {
            return Ok(());
        }
        let what = crate::input_file::kind_of(&t);
        Err(LogError::Carmen(CarmenError::Io {
            path: path.to_path_buf(),
            source: std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!("{what}, not a log file: to map a stream, pipe it to standard input (`-`)"),
            ),
        }))
    }
    #[cfg(not(unix))]
    {
        let _ = path;
        Ok(())
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
    /// ROS without `odometry`: attach the odometry anyway where it is found without another
    /// pass over the file, as a witness of the steps, best effort
    /// ([`RosScanOptions::witness_odometry`]).
    pub witness_odometry: bool,
    /// ROS: the robot's frame in tf ([`RosScanOptions::base_frame`]; default `base_link`, else
    /// `base_footprint`).
    pub base_frame: Option<String>,
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
    /// ROS without odometry: why the file's odometry witnesses no step, or none from some
    /// scan on ([`crate::ros::RosStats::odometry_dropped`]).
    pub odometry_dropped: Option<String>,
    /// ROS without odometry: witnessing odometry messages that did not decode, skipped.
    pub odometry_bad_messages: u64,
    /// What the reader read past, for the user (a recording cut off, and where it ends).
    pub warnings: Vec<String>,
    /// ROS: what tf gave the scans; `None` for a recording without tf, and for CARMEN.
    pub tf: Option<TfStats>,
}

enum Inner {
    Carmen(Box<source::LogSource>),
    Ros(Box<RosScanReader>),
    Live(Box<dyn LiveScans>),
}

/// Scans that arrive as they are taken (a ROS 2 topic), mapped like any log.
pub trait LiveScans: Send {
    /// The next scan, waiting for it; `None` once the source has ended and every scan that
    /// arrived was handed over.
    fn next_scan(&mut self) -> Option<RangeScan>;

    /// What has arrived so far, in the same terms as a file's counts (messages received,
    /// scans handed over, bad messages skipped, scans dropped in `warnings`).
    fn stats(&self) -> LogStats;
}

/// A log of any kind, read scan by scan in file order; a [`ScanSource`] for the pipeline.
pub struct LogSource {
    kind: LogKind,
    inner: Inner,
    path: PathBuf,
    size: Option<u64>,
}

impl LogSource {
    /// Opens a log, telling its kind by content (`-` is standard input, read as CARMEN).
    pub fn open(path: &Path, options: &LogOptions) -> Result<Self, LogError> {
        let kind = LogKind::of(path)?;
        let inner = match kind {
            // `LogKind::of` never tells a path to be live.
            LogKind::Carmen | LogKind::Live => {
                let carmen = ReaderOptions {
                    skip_bad_lines: options.skip_bad_input,
                    ..options.carmen.clone()
                };
                Inner::Carmen(Box::new(source::open_log(path, carmen)?))
            }
            LogKind::Ros(format) => {
                let ros = RosScanOptions {
                    topic: options.topic.clone(),
                    odometry: options.odometry,
                    odom_topic: options.odom_topic.clone(),
                    witness_odometry: options.witness_odometry,
                    skip_bad: options.skip_bad_input,
                    base_frame: options.base_frame.clone(),
                    ..RosScanOptions::default()
                };
                Inner::Ros(Box::new(RosScanReader::open(path, format, &ros)?))
            }
        };
        let size = match &inner {
            Inner::Carmen(c) => c.size_bytes(),
            Inner::Ros(_) => std::fs::metadata(path)
                .ok()
                .filter(|m| m.is_file())
                .map(|m| m.len()),
            Inner::Live(_) => None,
        };
        Ok(LogSource {
            kind,
            inner,
            path: path.to_path_buf(),
            size,
        })
    }

    /// A live source, named `name` in messages (a topic, say `/scan`).
    pub fn live(name: &str, scans: Box<dyn LiveScans>) -> Self {
        LogSource {
            kind: LogKind::Live,
            inner: Inner::Live(scans),
            path: PathBuf::from(name),
            size: None,
        }
    }

    /// The kind of log.
    pub fn kind(&self) -> LogKind {
        self.kind
    }

    /// The name used in messages (`<stdin>` for standard input).
    pub fn path(&self) -> &Path {
        match &self.inner {
            Inner::Carmen(c) => c.path(),
            Inner::Ros(_) | Inner::Live(_) => &self.path,
        }
    }

    /// The file's size in bytes; `None` for a stream or a folder.
    pub fn size_bytes(&self) -> Option<u64> {
        self.size
    }

    /// True for a log that can be read again (a regular file or a rosbag2 folder).
    pub fn is_regular_file(&self) -> bool {
        match &self.inner {
            Inner::Carmen(c) => c.is_regular_file(),
            Inner::Ros(_) => true,
            Inner::Live(_) => false,
        }
    }

    /// The next scan in file order, `Ok(None)` at the end.
    pub fn next_scan(&mut self) -> Result<Option<RangeScan>, LogError> {
        match &mut self.inner {
            Inner::Carmen(r) => Ok(ScanSource::next_scan(r.as_mut())?),
            Inner::Ros(r) => Ok(r.next_scan()?),
            Inner::Live(l) => Ok(l.next_scan()),
        }
    }

    /// What has been read so far, in the same terms for every format.
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
                    odometry_dropped: None,
                    odometry_bad_messages: 0,
                    warnings: Vec::new(),
                    tf: None,
                }
            }
            Inner::Live(l) => l.stats(),
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
                    odometry_dropped: s.odometry_dropped,
                    odometry_bad_messages: s.odometry_bad_messages,
                    warnings: s.warnings,
                    tf: s.tf,
                }
            }
        }
    }

    /// The counts in the CARMEN reader's terms, for reporting code written for it: a ROS
    /// recording's messages count as lines, its other topics as skipped types, its bad
    /// messages and chunks as bad lines.
    pub fn carmen_stats(&self) -> CarmenStats {
        match &self.inner {
            Inner::Carmen(r) => r.stats().clone(),
            Inner::Ros(_) | Inner::Live(_) => {
                let s = self.stats();
                CarmenStats {
                    lines: s.records,
                    scans: s.scans,
                    odometry_messages: s.odometry_messages,
                    skipped_types: s.skipped,
                    bad_lines: s.bad_records,
                    bad_line_messages: s.bad_record_errors,
                    no_return_readings: s.no_return_readings,
                    valid_readings: s.valid_readings,
                    other_warnings: s
                        .warnings
                        .into_iter()
                        .chain(s.odometry_dropped.map(|e| {
                            format!("no odometry witnesses the steps (from then on): {e}")
                        }))
                        .chain((s.odometry_bad_messages > 0).then(|| {
                            format!(
                                "{} odometry message(s) did not decode and were skipped; the \
                                 odometry witnesses the steps without them",
                                s.odometry_bad_messages
                            )
                        }))
                        .chain(s.tf.iter().flat_map(TfStats::warnings))
                        .chain((s.scans_outside_odometry > 0).then(|| {
                            format!(
                                "{} scan(s) stamped outside the odometry's time span took the \
                                 nearest odometry pose (the robot moved there as far as \
                                 --odometry knows: not at all)",
                                s.scans_outside_odometry
                            )
                        }))
                        .collect(),
                    ..CarmenStats::default()
                }
            }
        }
    }
}

impl ScanSource for LogSource {
    type Error = LogError;

    fn next_scan(&mut self) -> Result<Option<RangeScan>, LogError> {
        LogSource::next_scan(self)
    }

    fn bytes_read(&self) -> u64 {
        match &self.inner {
            Inner::Carmen(c) => c.bytes_read(),
            Inner::Ros(r) => r.position(),
            Inner::Live(_) => 0,
        }
    }
}
