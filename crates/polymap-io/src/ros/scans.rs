//! A laser topic as a stream of [`RangeScan`]s, with the laser's mounting from tf and odometry
//! interpolated to each scan.

use std::collections::{BTreeMap, VecDeque};
use std::path::{Path, PathBuf};

use polymap::geometry::Pose2;
use polymap::scan::RangeScan;

use super::error::{MessageProblem, RosError};
use super::mcap_indexed::summary_topics;
use super::messages::{LaserScanMsg, OdometryMsg};
pub use super::scan_tf::{FrameMiss, TfStats};
use super::scan_tf::{TF_STATIC_TOPIC, TF_TOPIC, TfOdometry, TfTrack, tf_topic};
use super::source::{Connection, MessageSource, ReadLimits};
use super::survey::{TopicSummary, survey};
use super::{RosFormat, open_source, open_source_for_topics};

/// Witnessing odometry ([`RosScanOptions::witness_odometry`]) is interpolated only between
/// messages at most this far apart, nanoseconds: across a longer gap a scan gets none (the
/// CARMEN reader's stale-odometry bound, 1 s).
const WITNESS_MAX_BRACKET_NS: i128 = 1_000_000_000;

/// How many skipped-message errors are kept for the warning.
const MAX_BAD_MESSAGES: usize = 10;

/// A scan is held back until messages recorded this long after it (receive time, nanoseconds)
/// have been read, so that the tf published for its stamp, which a recording may hold after
/// the scan, is in the buffer when the scan is placed.
const TF_HOLD_NS: i128 = 2_000_000_000;
/// Scans held back at most (whatever their receive times say).
const MAX_HELD_SCANS: usize = 400;
/// Readings held back at most, over the held scans (8 bytes each).
const MAX_HELD_READINGS: usize = 4_000_000;

/// What to read from a ROS recording.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RosScanOptions {
    /// The `LaserScan` topic; `None`: the only one in the file.
    pub topic: Option<String>,
    /// Attach odometry to each scan (interpolated by time).
    pub odometry: bool,
    /// The `Odometry` topic; `None`: the only one in the file.
    pub odom_topic: Option<String>,
    /// Without `odometry`: attach the odometry anyway, as a witness of the steps (the mapper
    /// checks its scans against it without tracking from it), from `odom_topic` or, when the
    /// file is surveyed for the laser topic anyway, its only `Odometry` topic. Best effort:
    /// scans outside the odometry's time span get none, and odometry that cannot be read is
    /// dropped ([`RosStats::odometry_dropped`]) instead of failing the run.
    pub witness_odometry: bool,
    /// Skip (and count) undecodable messages and corrupt chunks instead of failing.
    pub skip_bad: bool,
    /// Size limits.
    pub limits: ReadLimits,
    /// The robot's frame in tf: each scan's `robot_from_laser` is the transform from it to the
    /// scan's `header.frame_id`, and odometry from tf is `odom → ` it. `None`: `base_link`, or
    /// `base_footprint` where tf has no `base_link` (the first of them tf names, kept for the
    /// run). Without tf in the recording the laser is at the robot's origin.
    pub base_frame: Option<String>,
}

/// What a [`RosScanReader`] has read so far.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RosStats {
    /// Messages read on every topic.
    pub messages: u64,
    /// Scans returned.
    pub scans: u64,
    /// Odometry messages read.
    pub odometry_messages: u64,
    /// Messages of other topics, per topic.
    pub other_topics: BTreeMap<String, u64>,
    /// Undecodable messages and corrupt chunks skipped (only with `skip_bad`).
    pub bad_messages: u64,
    /// The first few of their errors.
    pub bad_message_errors: Vec<String>,
    /// Readings that are no-returns.
    pub no_return_readings: u64,
    /// Readings that are real returns.
    pub valid_readings: u64,
    /// Scans outside the odometry's time span, given the nearest odometry pose.
    pub scans_outside_odometry: u64,
    /// With [`RosScanOptions::witness_odometry`]: why the file's odometry witnesses no step,
    /// or none from some scan on (several odometry topics, one that does not open or
    /// decode); `None` while it witnesses, or where the file has none.
    pub odometry_dropped: Option<String>,
    /// With [`RosScanOptions::witness_odometry`] and `skip_bad`: odometry messages that did
    /// not decode, skipped (not counted in `bad_messages`: the run asked for no odometry).
    pub odometry_bad_messages: u64,
    /// What the container reader read past (a file cut off, and where it ends).
    pub warnings: Vec<String>,
    /// What tf gave the scans; `None` for a recording without `/tf` or `/tf_static`.
    pub tf: Option<TfStats>,
}

/// A scan read, waiting for the tf recorded after it.
struct Held {
    scan: RangeScan,
    frame_id: String,
    stamp_ns: i128,
    log_time_ns: i128,
}

/// Streams the scans of one `LaserScan` topic in file order.
///
/// Without [`RosScanOptions::topic`] (or, with odometry, without
/// [`RosScanOptions::odom_topic`]) the file is surveyed first to find the only topic of the
/// type (several are an error that lists them): from an MCAP file's summary statistics when it
/// has them, otherwise by one pass counting messages per topic.
///
/// Odometry is read by a second reader over the same file, moving forward in step with the
/// scans: memory stays bounded and each scan's pose is interpolated between the odometry
/// messages around its `header.stamp` (x and y linearly, yaw along the shorter arc).
///
/// tf (`/tf` and `/tf_static`, [`super::tf`]) is read by the same pass as the scans. Since a
/// recording may hold the transforms for a scan's stamp after the scan, each scan is held back
/// until the messages recorded 2 s after it are read (at most 400 scans or 4 million readings):
/// its `robot_from_laser` is then the transform from the robot's frame
/// ([`RosScanOptions::base_frame`]) to its `header.frame_id`, and, where no odometry topic is
/// read, its odometry is `odom →` the robot's frame.
pub struct RosScanReader {
    source: Box<dyn MessageSource>,
    path: PathBuf,
    topic: String,
    index: u64,
    odom: Option<OdomTrack>,
    /// Whether `odom` only witnesses ([`RosScanOptions::witness_odometry`]).
    witness: bool,
    stats: RosStats,
    skip_bad: bool,
    tf: TfTrack,
    held: VecDeque<Held>,
    held_readings: usize,
    /// The latest receive time read, nanoseconds.
    latest_log_time_ns: i128,
    ended: bool,
}

impl RosScanReader {
    /// Opens `path` (of format `format`) for the scans of the chosen topic.
    pub fn open(
        path: &Path,
        format: RosFormat,
        options: &RosScanOptions,
    ) -> Result<Self, RosError> {
        let open = || open_source(path, format, options.limits, options.skip_bad);
        let open_for = |topics: &[String]| {
            open_source_for_topics(path, format, options.limits, options.skip_bad, topics)
        };
        let needs_survey =
            options.topic.is_none() || (options.odometry && options.odom_topic.is_none());
        let topics = match (needs_survey, format) {
            (false, _) => Vec::new(),
            // An MCAP summary counts the messages per channel: no pass over the data.
            (true, RosFormat::Mcap) => match summary_topics(path, options.limits)? {
                Some(topics) => topics,
                None => survey(open()?.as_mut())?,
            },
            (true, _) => survey(open()?.as_mut())?,
        };
        let topic = match &options.topic {
            Some(t) => t.clone(),
            None => only_topic(
                path,
                &topics,
                "sensor_msgs/LaserScan",
                Connection::is_laser_scan,
                "--topic",
            )?,
        };
        let mut witness_dropped = None;
        let has = |is: fn(&Connection) -> bool| {
            topics.iter().any(|t| is(&t.connection) && t.messages > 0)
        };
        let has_tf = has(|c| tf_topic(c) == Some(false));
        // --odometry without an odometry topic: tf's odom → base, where the recording has /tf.
        let odometry_from_tf = options.odometry
            && options.odom_topic.is_none()
            && !has(Connection::is_odometry)
            && has_tf;
        let odom = if options.odometry && !odometry_from_tf {
            let odom_topic = match &options.odom_topic {
                Some(t) => t.clone(),
                None => only_topic(
                    path,
                    &topics,
                    "nav_msgs/Odometry",
                    Connection::is_odometry,
                    "--odom-topic",
                )?,
            };
            let source = open_for(std::slice::from_ref(&odom_topic))?;
            Some(OdomTrack::new(source, path, odom_topic, options.skip_bad))
        } else if options.witness_odometry && !options.odometry {
            // Only where the topic is named or the survey (run for the laser topic anyway, so
            // `topics` is empty without it) found odometry; several odometry topics, or one
            // that does not open, are said why, not an error.
            let has_odometry = topics
                .iter()
                .any(|t| t.connection.is_odometry() && t.messages > 0);
            let odom_topic = match (&options.odom_topic, has_odometry) {
                (Some(t), _) => Ok(Some(t.clone())),
                (None, true) => only_topic(
                    path,
                    &topics,
                    "nav_msgs/Odometry",
                    Connection::is_odometry,
                    "--odom-topic",
                )
                .map(Some),
                (None, false) => Ok(None),
            };
            let track = odom_topic.and_then(|topic| {
                topic
                    .map(|t| {
                        open_for(std::slice::from_ref(&t))
                            .map(|source| OdomTrack::new(source, path, t, options.skip_bad))
                    })
                    .transpose()
            });
            track.unwrap_or_else(|e| {
                witness_dropped = Some(e.to_string());
                None
            })
        } else {
            None
        };
        // Without an odometry topic read, tf's odom → base gives the odometry.
        let tf_odometry = match (&odom, options.odometry, options.witness_odometry) {
            (Some(_), _, _) => None,
            (None, true, _) => Some(TfOdometry::Prior),
            (None, false, true) => Some(TfOdometry::Witness),
            (None, false, false) => None,
        };
        let read_topics = [topic.clone(), TF_TOPIC.into(), TF_STATIC_TOPIC.into()];
        Ok(RosScanReader {
            source: open_for(&read_topics)?,
            path: path.to_path_buf(),
            topic,
            index: 0,
            odom,
            witness: !options.odometry && options.witness_odometry,
            stats: RosStats {
                odometry_dropped: witness_dropped,
                ..RosStats::default()
            },
            skip_bad: options.skip_bad,
            tf: TfTrack::new(options.base_frame.as_deref(), tf_odometry),
            held: VecDeque::new(),
            held_readings: 0,
            latest_log_time_ns: i128::MIN,
            ended: false,
        })
    }

    /// Whether the recording has tf: a tf message read, or a tf topic declared.
    fn carries_tf(&self) -> bool {
        self.tf.any_read()
            || self
                .source
                .connections()
                .iter()
                .any(|c| tf_topic(c).is_some())
    }

    /// The laser topic read.
    pub fn topic(&self) -> &str {
        &self.topic
    }

    /// What has been read so far.
    pub fn stats(&self) -> RosStats {
        let mut stats = self.stats.clone();
        let (skipped, errors) = self.source.skipped();
        stats
            .warnings
            .extend(self.source.warnings().iter().cloned());
        stats.bad_messages += skipped;
        for e in errors
            .iter()
            .take(MAX_BAD_MESSAGES.saturating_sub(stats.bad_message_errors.len()))
        {
            stats.bad_message_errors.push(e.clone());
        }
        stats.tf = self.carries_tf().then(|| self.tf.stats());
        if let Some(odom) = &self.odom {
            stats.odometry_messages = odom.read;
            // Odometry only witnessing: its bad messages are its own (a run that asked for no
            // odometry has no bad input there).
            match self.witness {
                true => stats.odometry_bad_messages = odom.bad,
                false => stats.bad_messages += odom.bad,
            }
        }
        stats
    }

    /// Bytes of the file read so far.
    pub fn position(&self) -> u64 {
        self.source.position()
    }

    /// The next scan, `Ok(None)` at the end.
    pub fn next_scan(&mut self) -> Result<Option<RangeScan>, RosError> {
        loop {
            if self.front_ready()
                && let Some(held) = self.held.pop_front()
            {
                self.held_readings -= held.scan.ranges_m.len();
                return self.place(held).map(Some);
            }
            if self.ended {
                if self.stats.scans == 0 && self.stats.bad_messages == 0 {
                    return Err(self.no_scans());
                }
                return Ok(None);
            }
            if !self.source.advance()? {
                self.ended = true;
                continue;
            }
            self.read_message()?;
        }
    }

    /// Whether the first held scan can be placed: the messages recorded long enough after it
    /// are read, too many scans are held, or the file is read.
    fn front_ready(&self) -> bool {
        let Some(front) = self.held.front() else {
            return false;
        };
        self.ended
            || self.held.len() > MAX_HELD_SCANS
            || self.held_readings > MAX_HELD_READINGS
            || self.latest_log_time_ns.saturating_sub(front.log_time_ns) >= TF_HOLD_NS
    }

    /// Reads the current message: tf into the buffer, a scan of the topic into the held ones.
    fn read_message(&mut self) -> Result<(), RosError> {
        self.stats.messages += 1;
        let m = self.source.current();
        let c = &self.source.connections()[m.connection];
        self.latest_log_time_ns = self.latest_log_time_ns.max(m.log_time_ns);
        if let Some(is_static) = tf_topic(c) {
            self.tf.read(&self.path, c, m.data, m.place, is_static);
            return Ok(());
        }
        if c.topic != self.topic {
            *self.stats.other_topics.entry(c.topic.clone()).or_insert(0) += 1;
            return Ok(());
        }
        self.index += 1;
        if !c.is_laser_scan() {
            return Err(RosError::Topics {
                path: self.path.clone(),
                problem: format!(
                    "topic {} is of type {}, not sensor_msgs/LaserScan",
                    self.topic, c.type_name
                ),
            });
        }
        let decoded = match c.encoding.flavor() {
            Some(f) => LaserScanMsg::decode(m.data, f),
            None => Err(MessageProblem::Encoding(format!("{:?}", c.encoding))),
        };
        let (place, log_time_ns) = (m.place, m.log_time_ns);
        match decoded {
            Ok(msg) => {
                let scan = msg.to_range_scan();
                self.held_readings += scan.ranges_m.len();
                self.held.push_back(Held {
                    scan,
                    frame_id: msg.frame_id,
                    stamp_ns: msg.stamp.nanos(),
                    log_time_ns,
                });
                Ok(())
            }
            Err(problem) => {
                let e = RosError::Message {
                    path: self.path.clone(),
                    topic: self.topic.clone(),
                    index: self.index,
                    at: place.to_string(),
                    problem,
                };
                self.bad(e)
            }
        }
    }

    /// A held scan with its mounting and odometry.
    fn place(&mut self, held: Held) -> Result<RangeScan, RosError> {
        let Held {
            mut scan,
            frame_id,
            stamp_ns,
            ..
        } = held;
        let carries_tf = self.carries_tf();
        let (robot_frame, robot_from_laser) = self.tf.mount(&frame_id, stamp_ns, carries_tf);
        scan.robot_from_laser = robot_from_laser;
        let odometry = self.odom.as_mut().map(|odom| odom.at(stamp_ns));
        match odometry {
            None if carries_tf => {
                scan.odom_from_robot =
                    self.tf
                        .odometry(&robot_frame, stamp_ns, WITNESS_MAX_BRACKET_NS);
            }
            None => {}
            // Witnessing: none outside the odometry's span, nor across a gap in it (the
            // interpolation over a gap would read a straight line the robot did not take).
            Some(Ok((pose, outside, bracket_ns))) if self.witness => {
                scan.odom_from_robot =
                    Some(pose).filter(|_| !outside && bracket_ns <= WITNESS_MAX_BRACKET_NS);
            }
            Some(Ok((pose, outside, _))) => {
                scan.odom_from_robot = Some(pose);
                self.stats.scans_outside_odometry += u64::from(outside);
            }
            Some(Err(e)) if self.witness => {
                if let Some(odom) = self.odom.take() {
                    self.stats.odometry_messages = odom.read;
                    self.stats.odometry_bad_messages = odom.bad;
                }
                self.stats.odometry_dropped = Some(e.to_string());
            }
            Some(Err(e)) => return Err(e),
        }
        let valid = scan.valid_count() as u64;
        self.stats.valid_readings += valid;
        self.stats.no_return_readings += scan.ranges_m.len() as u64 - valid;
        self.stats.scans += 1;
        Ok(scan)
    }

    fn bad(&mut self, e: RosError) -> Result<(), RosError> {
        if !self.skip_bad {
            return Err(e);
        }
        self.stats.bad_messages += 1;
        if self.stats.bad_message_errors.len() < MAX_BAD_MESSAGES {
            self.stats.bad_message_errors.push(e.to_string());
        }
        Ok(())
    }

    fn no_scans(&self) -> RosError {
        let lasers: Vec<String> = self
            .source
            .connections()
            .iter()
            .filter(|c| c.is_laser_scan())
            .map(|c| c.topic.clone())
            .collect();
        RosError::Topics {
            path: self.path.clone(),
            problem: format!(
                "no messages on topic {}; LaserScan topics in the file: {}",
                self.topic,
                if lasers.is_empty() {
                    "none".into()
                } else {
                    lasers.join(", ")
                }
            ),
        }
    }
}

/// The one topic of a type with messages, or an error listing what there is.
fn only_topic(
    path: &Path,
    topics: &[TopicSummary],
    type_name: &str,
    is: fn(&Connection) -> bool,
    flag: &str,
) -> Result<String, RosError> {
    let of_type: Vec<&TopicSummary> = topics
        .iter()
        .filter(|t| is(&t.connection) && t.messages > 0)
        .collect();
    let listing = |ts: &[&TopicSummary]| {
        ts.iter()
            .map(|t| format!("{} ({} messages)", t.connection.topic, t.messages))
            .collect::<Vec<_>>()
            .join(", ")
    };
    match of_type.as_slice() {
        [one] => Ok(one.connection.topic.clone()),
        [] => {
            let all_listing = topics
                .iter()
                .map(|t| {
                    format!(
                        "{} [{}] ({} messages)",
                        t.connection.topic, t.connection.type_name, t.messages
                    )
                })
                .collect::<Vec<_>>()
                .join(", ");
            Err(RosError::Topics {
                path: path.to_path_buf(),
                problem: format!(
                    "no {type_name} topic with messages; topics: {}",
                    if all_listing.is_empty() {
                        "none".into()
                    } else {
                        all_listing
                    }
                ),
            })
        }
        many => Err(RosError::Topics {
            path: path.to_path_buf(),
            problem: format!(
                "{} {type_name} topics; choose one with {flag}: {}",
                many.len(),
                listing(many)
            ),
        }),
    }
}

/// Odometry poses of one topic, read forward in step with the scans.
struct OdomTrack {
    source: Box<dyn MessageSource>,
    path: PathBuf,
    topic: String,
    index: u64,
    /// Messages read.
    read: u64,
    /// Undecodable messages skipped.
    bad: u64,
    skip_bad: bool,
    prev: Option<(i128, Pose2)>,
    next: Option<(i128, Pose2)>,
    done: bool,
}

impl OdomTrack {
    fn new(source: Box<dyn MessageSource>, path: &Path, topic: String, skip_bad: bool) -> Self {
        OdomTrack {
            source,
            path: path.to_path_buf(),
            topic,
            index: 0,
            read: 0,
            bad: 0,
            skip_bad,
            prev: None,
            next: None,
            done: false,
        }
    }

    /// The pose at `t_ns`, whether `t_ns` was outside the odometry's span (then the nearest
    /// pose is given), and how far apart the messages it was interpolated between are,
    /// nanoseconds (0 for a message at `t_ns`, or outside).
    fn at(&mut self, t_ns: i128) -> Result<(Pose2, bool, i128), RosError> {
        while !self.done && self.next.is_none_or(|(tn, _)| tn < t_ns) {
            match self.read_next()? {
                Some(sample) => {
                    if let Some(old) = self.next.replace(sample) {
                        self.prev = Some(old);
                    }
                }
                None => self.done = true,
            }
        }
        match (self.prev, self.next) {
            (_, Some((tn, pn))) if tn == t_ns => Ok((pn, false, 0)),
            (Some((tp, pp)), Some((tn, pn))) if tp <= t_ns && t_ns < tn => {
                let f = ((t_ns - tp) as f64) / ((tn - tp) as f64);
                Ok((pp.interpolate(&pn, f), false, tn - tp))
            }
            (_, Some((_, pn))) => Ok((pn, true, 0)),
            (Some((_, pp)), None) => Ok((pp, true, 0)),
            (None, None) => Err(RosError::Topics {
                path: self.path.clone(),
                problem: format!("no odometry messages on topic {}", self.topic),
            }),
        }
    }

    fn read_next(&mut self) -> Result<Option<(i128, Pose2)>, RosError> {
        while self.source.advance()? {
            let m = self.source.current();
            let c = &self.source.connections()[m.connection];
            if c.topic != self.topic {
                continue;
            }
            self.index += 1;
            if !c.is_odometry() {
                return Err(RosError::Topics {
                    path: self.path.clone(),
                    problem: format!(
                        "topic {} is of type {}, not nav_msgs/Odometry",
                        self.topic, c.type_name
                    ),
                });
            }
            let decoded = match c.encoding.flavor() {
                Some(f) => OdometryMsg::decode(m.data, f),
                None => Err(MessageProblem::Encoding(format!("{:?}", c.encoding))),
            };
            match decoded {
                Ok(msg) => {
                    self.read += 1;
                    return Ok(Some((msg.stamp.nanos(), msg.pose())));
                }
                Err(problem) if !self.skip_bad => {
                    return Err(RosError::Message {
                        path: self.path.clone(),
                        topic: self.topic.clone(),
                        index: self.index,
                        at: m.place.to_string(),
                        problem,
                    });
                }
                Err(_) => self.bad += 1,
            }
        }
        Ok(None)
    }
}
