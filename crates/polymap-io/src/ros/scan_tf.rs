//! tf for a laser topic: where each scan's frame is mounted on the robot, and the robot's
//! odometry from `odom → base`, read from the recording's `/tf` and `/tf_static` by the same
//! pass that reads the scans.

use std::collections::BTreeMap;
use std::path::Path;

use polymap::geometry::Pose2;
use serde::Serialize;

use super::error::{MessageProblem, RosError};
use super::messages::TfMessage;
use super::source::{Connection, Place};
use super::tf::{TfBuffer, TfLimits, frame_name};

/// The topic of dynamic transforms.
pub const TF_TOPIC: &str = "/tf";
/// The topic of static transforms.
pub const TF_STATIC_TOPIC: &str = "/tf_static";
/// The odometry frame whose transform to the robot's frame gives odometry.
pub const ODOM_FRAME: &str = "odom";
/// The robot's frame by default.
pub const BASE_LINK: &str = "base_link";
/// The robot's frame where tf has no [`BASE_LINK`].
pub const BASE_FOOTPRINT: &str = "base_footprint";

/// A laser frame leaning more than this from the robot's plane is warned about, radians (5°):
/// its scans are projected as if level.
pub const MAX_LEVEL_TILT_RAD: f64 = 5.0 * std::f64::consts::PI / 180.0;

/// How many errors of each kind are kept for the warnings.
const MAX_ERRORS: usize = 10;
/// How many scan frames without tf are told apart (a topic has one frame in practice).
const MAX_MISSING_FRAMES: usize = 8;

/// Whether a connection carries tf: `Some(true)` for `/tf_static`, `Some(false)` for `/tf`
/// (with or without the leading `/`), of type `tf2_msgs/TFMessage` or `tf/tfMessage`.
pub(crate) fn tf_topic(c: &Connection) -> Option<bool> {
    if !c.is_tf() {
        return None;
    }
    match frame_name(&c.topic) {
        "tf" => Some(false),
        "tf_static" => Some(true),
        _ => None,
    }
}

/// Scans of one frame that tf could not place on the robot.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct FrameMiss {
    /// Scans of the frame taken as at the robot's origin.
    pub scans: u64,
    /// Why, for the first of them.
    pub first_problem: String,
}

/// What tf gave the scans, and what it could not.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct TfStats {
    /// `TFMessage`s read on `/tf`.
    pub messages: u64,
    /// `TFMessage`s read on `/tf_static`.
    pub static_messages: u64,
    /// Transforms taken into the buffer.
    pub transforms: u64,
    /// Transforms refused by the buffer (a bad quaternion, a loop of frames, …).
    pub refused_transforms: u64,
    /// The first few refusals.
    pub refused_errors: Vec<String>,
    /// tf messages that did not decode, skipped (each is named in the errors).
    pub bad_messages: u64,
    /// The first few of their errors, naming the file, the topic and the message.
    pub bad_message_errors: Vec<String>,
    /// Frames in the buffer at the end.
    pub frames: usize,
    /// The robot's frame the scans were placed in (`None` until one is found).
    pub base_frame: Option<String>,
    /// Scans whose `robot_from_laser` came from tf.
    pub scans_mounted: u64,
    /// Scans tf could not place, by their frame (normalized): they were taken as at the
    /// robot's origin, as in a recording without tf.
    pub scans_without_mount: BTreeMap<String, FrameMiss>,
    /// The laser frame leaning most from the robot's plane beyond [`MAX_LEVEL_TILT_RAD`], and by
    /// how much, radians.
    pub tilted: Option<(String, f64)>,
    /// Whether the scans' odometry comes from tf (`odom → base`): no odometry topic was
    /// chosen, and odometry was asked for (`prior`) or witnesses the steps.
    pub odometry: Option<TfOdometry>,
    /// Scans given odometry from tf.
    pub scans_with_odometry: u64,
    /// Scans tf gave no odometry (with the odometry as the prior, each is counted; as a
    /// witness, scans across a gap of more than 1 s are too).
    pub scans_without_odometry: u64,
    /// Why, for the first of them.
    pub odometry_first_problem: Option<String>,
}

/// What odometry from tf is used for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TfOdometry {
    /// Tracking starts from it (`--odometry`).
    Prior,
    /// It witnesses the tracked steps.
    Witness,
}

impl TfStats {
    /// One sentence per thing the user should know, for the run's warnings.
    pub fn warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.bad_messages > 0 {
            out.push(format!(
                "{} tf message(s) did not decode and were skipped; first: {}",
                self.bad_messages,
                self.bad_message_errors.first().map_or("", String::as_str)
            ));
        }
        if self.refused_transforms > 0 {
            out.push(format!(
                "{} tf transform(s) were refused; first: {}",
                self.refused_transforms,
                self.refused_errors.first().map_or("", String::as_str)
            ));
        }
        let base = self.base_frame.as_deref().unwrap_or(BASE_LINK);
        for (frame, miss) in &self.scans_without_mount {
            out.push(format!(
                "{} scan(s) in frame {frame:?} have no tf to the robot's frame {base:?} (first: \
                 {}): they are taken as at the robot's origin (--base-frame names the robot's \
                 frame)",
                miss.scans, miss.first_problem
            ));
        }
        if let Some((frame, tilt)) = &self.tilted {
            out.push(format!(
                "the laser frame {frame:?} leans {:.1}° from the plane of {base:?} in tf: its \
                 scans are read as if level",
                tilt.to_degrees()
            ));
        }
        if self.odometry == Some(TfOdometry::Prior) && self.scans_without_odometry > 0 {
            out.push(format!(
                "{} scan(s) got no odometry from tf ({ODOM_FRAME} → {base}), first: {}",
                self.scans_without_odometry,
                self.odometry_first_problem.as_deref().unwrap_or("")
            ));
        }
        out
    }
}

/// The tf buffer of a recording and what it gave the scans.
pub(crate) struct TfTrack {
    buffer: TfBuffer,
    /// `--base-frame`, normalized.
    requested_base: Option<String>,
    stats: TfStats,
    /// Messages read per tf topic (1-based indexes in errors): `/tf`, `/tf_static`.
    index: [u64; 2],
}

impl TfTrack {
    pub(crate) fn new(base_frame: Option<&str>, odometry: Option<TfOdometry>) -> Self {
        TfTrack {
            buffer: TfBuffer::new(TfLimits::default()),
            requested_base: base_frame.map(|b| frame_name(b).to_owned()),
            stats: TfStats {
                odometry,
                ..TfStats::default()
            },
            index: [0, 0],
        }
    }

    /// Decodes one tf message and inserts its transforms; a message that does not decode is
    /// skipped and counted, naming the file, topic and message.
    pub(crate) fn read(
        &mut self,
        path: &Path,
        connection: &Connection,
        data: &[u8],
        place: Place,
        is_static: bool,
    ) {
        let slot = usize::from(is_static);
        self.index[slot] += 1;
        let decoded = match connection.encoding.flavor() {
            Some(f) => TfMessage::decode(data, f),
            None => Err(MessageProblem::Encoding(format!(
                "{:?}",
                connection.encoding
            ))),
        };
        let msg = match decoded {
            Ok(msg) => msg,
            Err(problem) => {
                self.stats.bad_messages += 1;
                if self.stats.bad_message_errors.len() < MAX_ERRORS {
                    let e = RosError::Message {
                        path: path.to_path_buf(),
                        topic: connection.topic.clone(),
                        index: self.index[slot],
                        at: place.to_string(),
                        problem,
                    };
                    self.stats.bad_message_errors.push(e.to_string());
                }
                return;
            }
        };
        match is_static {
            true => self.stats.static_messages += 1,
            false => self.stats.messages += 1,
        }
        for e in self.buffer.insert_message(&msg, is_static) {
            self.stats.refused_transforms += 1;
            if self.stats.refused_errors.len() < MAX_ERRORS {
                self.stats.refused_errors.push(format!(
                    "{}: topic {}, message {}: {e}",
                    path.display(),
                    connection.topic,
                    self.index[slot]
                ));
            }
        }
        self.stats.transforms = self.buffer.counts().inserted;
    }

    /// The robot's frame: `--base-frame`, else the first of `base_link` and `base_footprint`
    /// that tf names, kept once found.
    fn base(&mut self) -> Option<String> {
        if let Some(b) = &self.requested_base {
            self.stats.base_frame = Some(b.clone());
            return Some(b.clone());
        }
        if self.stats.base_frame.is_none() {
            self.stats.base_frame = [BASE_LINK, BASE_FOOTPRINT]
                .into_iter()
                .find(|f| self.buffer.has_frame(f))
                .map(str::to_owned);
        }
        self.stats.base_frame.clone()
    }

    /// Where a scan of `frame_id` stamped `time_ns` sits on the robot: the robot's frame and
    /// `robot_from_laser`. Without tf for it, the scan's own frame and the identity (counted).
    /// `carries_tf`: whether the recording has tf at all (without, and without
    /// `--base-frame`, nothing is counted: the laser is at the robot's origin, as ever).
    pub(crate) fn mount(
        &mut self,
        frame_id: &str,
        time_ns: i128,
        carries_tf: bool,
    ) -> (String, Pose2) {
        let frame = frame_name(frame_id).to_owned();
        if !carries_tf {
            if self.requested_base.is_some() {
                self.miss(&frame, "the recording has no /tf or /tf_static".into());
            }
            return (frame, Pose2::IDENTITY);
        }
        let Some(base) = self.base() else {
            let problem = format!("tf names neither {BASE_LINK} nor {BASE_FOOTPRINT}");
            self.miss(&frame, problem);
            return (frame, Pose2::IDENTITY);
        };
        if base == frame {
            self.stats.scans_mounted += 1;
            return (frame, Pose2::IDENTITY);
        }
        match self.buffer.lookup(&base, &frame, time_ns) {
            Ok(l) => {
                self.stats.scans_mounted += 1;
                if l.tilt_rad > MAX_LEVEL_TILT_RAD
                    && self
                        .stats
                        .tilted
                        .as_ref()
                        .is_none_or(|(_, t)| l.tilt_rad > *t)
                {
                    self.stats.tilted = Some((frame, l.tilt_rad));
                }
                (base, l.pose)
            }
            Err(e) => {
                self.miss(&frame, e.to_string());
                (frame, Pose2::IDENTITY)
            }
        }
    }

    fn miss(&mut self, frame: &str, problem: String) {
        let known = self.stats.scans_without_mount.contains_key(frame);
        if !known && self.stats.scans_without_mount.len() >= MAX_MISSING_FRAMES {
            return;
        }
        let entry = self
            .stats
            .scans_without_mount
            .entry(frame.to_owned())
            .or_insert_with(|| FrameMiss {
                scans: 0,
                first_problem: problem,
            });
        entry.scans += 1;
    }

    /// `odom_from_robot` from tf at `time_ns`, for the robot's frame `robot_frame`. As a
    /// witness, none across a gap wider than `max_witness_gap_ns` between two transforms.
    pub(crate) fn odometry(
        &mut self,
        robot_frame: &str,
        time_ns: i128,
        max_witness_gap_ns: i128,
    ) -> Option<Pose2> {
        let use_ = self.stats.odometry?;
        let found = self
            .buffer
            .lookup(ODOM_FRAME, robot_frame, time_ns)
            .map_err(|e| e.to_string())
            .and_then(|l| match use_ {
                TfOdometry::Witness if l.widest_gap_ns > max_witness_gap_ns => Err(format!(
                    "tf {ODOM_FRAME} → {robot_frame} has a gap of {:.3} s there",
                    l.widest_gap_ns as f64 * 1e-9
                )),
                _ => Ok(l.pose),
            });
        match found {
            Ok(pose) => {
                self.stats.scans_with_odometry += 1;
                Some(pose)
            }
            Err(e) => {
                self.stats.scans_without_odometry += 1;
                self.stats.odometry_first_problem.get_or_insert(e);
                None
            }
        }
    }

    /// Whether any tf message was read.
    pub(crate) fn any_read(&self) -> bool {
        self.stats.messages + self.stats.static_messages + self.stats.bad_messages > 0
    }

    pub(crate) fn stats(&self) -> TfStats {
        let mut stats = self.stats.clone();
        stats.frames = self.buffer.frames().count();
        stats
    }
}
