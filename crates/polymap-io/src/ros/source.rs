//! What every ROS container reader yields: connections (topic, type, encoding) and raw messages
//! in the container's own order.

use super::error::RosError;
use super::wire::Flavor;

/// How the messages of a connection are serialized.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Encoding {
    /// ROS 1 serialization.
    Ros1,
    /// CDR (ROS 2); the byte order comes from each message's header.
    Cdr,
    /// Anything else (named as the file names it).
    Other(String),
}

impl Encoding {
    /// From the name a container gives it (`ros1`, `cdr`, …).
    pub fn from_name(name: &str) -> Self {
        match name {
            "ros1" => Encoding::Ros1,
            "cdr" => Encoding::Cdr,
            other => Encoding::Other(other.to_owned()),
        }
    }

    /// The flavor to decode with; `None` when polymap cannot decode it.
    pub fn flavor(&self) -> Option<Flavor> {
        match self {
            Encoding::Ros1 => Some(Flavor::Ros1),
            // The decoder reads the byte order from the encapsulation header.
            Encoding::Cdr => Some(Flavor::CdrLittle),
            Encoding::Other(_) => None,
        }
    }
}

/// A topic as the container declares it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Connection {
    /// Topic name, e.g. `/scan`.
    pub topic: String,
    /// Message type as written (`sensor_msgs/LaserScan` or `sensor_msgs/msg/LaserScan`).
    pub type_name: String,
    /// Serialization of its messages.
    pub encoding: Encoding,
}

impl Connection {
    /// The type without ROS 2's `/msg/` part: `sensor_msgs/LaserScan` for both generations.
    pub fn plain_type(&self) -> String {
        self.type_name.replacen("/msg/", "/", 1)
    }

    /// True for `sensor_msgs/LaserScan`.
    pub fn is_laser_scan(&self) -> bool {
        self.plain_type() == LASER_SCAN
    }

    /// True for `nav_msgs/Odometry`.
    pub fn is_odometry(&self) -> bool {
        self.plain_type() == ODOMETRY
    }

    /// True for the types polymap decodes (laser scans, odometry, tf): the readers keep the
    /// bytes of these messages only.
    pub fn is_decoded(&self) -> bool {
        self.is_laser_scan() || self.is_odometry() || self.is_tf()
    }

    /// True for `tf2_msgs/TFMessage` (ROS 1 and 2) and ROS 1's older `tf/tfMessage`.
    pub fn is_tf(&self) -> bool {
        let t = self.plain_type();
        t == TF_MESSAGE || t == TF_MESSAGE_ROS1_OLD
    }
}

/// The laser scan type, without `/msg/`.
pub const LASER_SCAN: &str = "sensor_msgs/LaserScan";
/// The odometry type, without `/msg/`.
pub const ODOMETRY: &str = "nav_msgs/Odometry";
/// The tf type, without `/msg/`.
pub const TF_MESSAGE: &str = "tf2_msgs/TFMessage";
/// ROS 1's tf type before tf2 (the same layout).
pub const TF_MESSAGE_ROS1_OLD: &str = "tf/tfMessage";

/// One message, borrowed from the reader's buffer until the next call.
#[derive(Debug)]
pub struct RawMessage<'a> {
    /// Index into the reader's connections.
    pub connection: usize,
    /// The serialized message.
    pub data: &'a [u8],
    /// Where it is: its record's byte offset (its chunk's, if chunked), or its database row.
    pub place: Place,
    /// The container's receive time, nanoseconds since the epoch.
    pub log_time_ns: i128,
}

/// Where a message is in its file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Place {
    /// Byte offset of its record, or of the chunk holding it.
    Byte(u64),
    /// Row id in a database.
    Row(i64),
}

impl std::fmt::Display for Place {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Place::Byte(b) => write!(f, "byte {b}"),
            Place::Row(r) => write!(f, "row {r}"),
        }
    }
}

/// Limits that keep a damaged or hostile file from sizing memory.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReadLimits {
    /// Largest record (or decompressed chunk) accepted, bytes. Default 256 MiB.
    pub max_record_bytes: u64,
}

impl Default for ReadLimits {
    fn default() -> Self {
        ReadLimits {
            max_record_bytes: 256 << 20,
        }
    }
}

/// A reader of one ROS container format, message by message.
pub trait MessageSource: Send {
    /// Moves to the next message in the container's order; `Ok(false)` at the end.
    fn advance(&mut self) -> Result<bool, RosError>;
    /// The message [`advance`](Self::advance) moved to (call only after it returned `true`).
    fn current(&self) -> RawMessage<'_>;
    /// The connections declared so far (all of them, for formats that declare them up front).
    fn connections(&self) -> &[Connection];
    /// Bytes of the file consumed so far (for progress).
    fn position(&self) -> u64;
    /// Damaged parts skipped (only when asked to skip bad input): count and first messages.
    fn skipped(&self) -> (u64, &[String]);
    /// What the reader found odd but read past, for the user (a file cut off, and where).
    fn warnings(&self) -> &[String] {
        &[]
    }
}
