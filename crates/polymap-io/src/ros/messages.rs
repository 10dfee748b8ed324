//! The message types polymap reads, decoded by hand: `sensor_msgs/LaserScan`,
//! `nav_msgs/Odometry` and `tf2_msgs/TFMessage` (also ROS 1's older `tf/tfMessage`), in ROS 1
//! serialization or CDR.

use polymap::geometry::Pose2;
use polymap::scan::{RangeScan, Stamp};

use super::error::MessageProblem;
use super::wire::{Decoder, Encoder, Flavor};
use crate::carmen::beyond_a_turn;

/// A ROS time stamp: seconds and nanoseconds since the epoch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub struct RosTime {
    /// Whole seconds (ROS 1: unsigned 32-bit; ROS 2: signed 32-bit).
    pub sec: i64,
    /// Nanoseconds, `0..1_000_000_000`.
    pub nanosec: u32,
}

impl RosTime {
    /// Nanoseconds since the epoch.
    pub fn nanos(&self) -> i128 {
        i128::from(self.sec) * 1_000_000_000 + i128::from(self.nanosec)
    }

    /// The stamp as text, with 6 decimals when it is a whole number of microseconds and 9
    /// otherwise; the value in seconds is parsed back from that text.
    ///
    /// ```
    /// use polymap_io::ros::RosTime;
    /// let t = RosTime { sec: 1_000_000_000, nanosec: 100_000_000 };
    /// assert_eq!(t.to_stamp().text, "1000000000.100000");
    /// let t = RosTime { sec: 5, nanosec: 7 };
    /// assert_eq!(t.to_stamp().text, "5.000000007");
    /// let t = RosTime { sec: -1, nanosec: 500_000_000 };
    /// assert_eq!(t.to_stamp().text, "-0.500000");
    /// ```
    pub fn to_stamp(&self) -> Stamp {
        let n = self.nanos();
        let sign = if n < 0 { "-" } else { "" };
        let (whole, frac) = (n.abs() / 1_000_000_000, n.abs() % 1_000_000_000);
        let text = if frac % 1000 == 0 {
            format!("{sign}{whole}.{:06}", frac / 1000)
        } else {
            format!("{sign}{whole}.{frac:09}")
        };
        Stamp {
            seconds: text.parse().unwrap_or(n as f64 * 1e-9),
            text,
        }
    }

    /// The time of `seconds` (the inverse of [`to_stamp`](Self::to_stamp) for stamps written
    /// with at most 9 decimals); `None` when out of the 32-bit range of ROS times.
    pub fn from_stamp(stamp: &Stamp) -> Option<RosTime> {
        let (whole, frac) = stamp.text.split_once('.').unwrap_or((&stamp.text, ""));
        let negative = whole.starts_with('-');
        let whole: i64 = whole.trim_start_matches('-').parse().ok()?;
        let digits: String = frac.chars().chain(std::iter::repeat('0')).take(9).collect();
        let frac: i64 = digits.parse().ok()?;
        let n = whole * 1_000_000_000 + frac;
        let n = if negative { -n } else { n };
        let t = RosTime {
            sec: n.div_euclid(1_000_000_000),
            nanosec: n.rem_euclid(1_000_000_000) as u32,
        };
        (i64::from(i32::MIN)..=i64::from(u32::MAX))
            .contains(&t.sec)
            .then_some(t)
    }

    fn decode(d: &mut Decoder<'_>, flavor: Flavor) -> Result<Self, MessageProblem> {
        let sec = d.u32("header.stamp.sec")?;
        let sec = match flavor {
            Flavor::Ros1 => i64::from(sec),
            _ => i64::from(sec as i32),
        };
        let nanosec = d.u32("header.stamp.nanosec")?;
        if nanosec >= 1_000_000_000 {
            return Err(MessageProblem::BadValue {
                field: "header.stamp.nanosec",
                value: f64::from(nanosec),
            });
        }
        Ok(RosTime { sec, nanosec })
    }

    fn encode(&self, e: &mut Encoder) {
        e.u32(self.sec as u32);
        e.u32(self.nanosec);
    }
}

/// A `std_msgs/Header`: ROS 1 has a sequence number first, ROS 2 does not.
fn decode_header(d: &mut Decoder<'_>, flavor: Flavor) -> Result<(RosTime, String), MessageProblem> {
    if flavor == Flavor::Ros1 {
        d.u32("header.seq")?;
    }
    let stamp = RosTime::decode(d, flavor)?;
    let frame_id = d.string("header.frame_id")?;
    Ok((stamp, frame_id))
}

fn encode_header(e: &mut Encoder, flavor: Flavor, seq: u32, stamp: &RosTime, frame_id: &str) {
    if flavor == Flavor::Ros1 {
        e.u32(seq);
    }
    stamp.encode(e);
    e.string(frame_id);
}

/// A `sensor_msgs/LaserScan` (ROS 1) or `sensor_msgs/msg/LaserScan` (ROS 2); intensities are
/// only counted.
#[derive(Debug, Clone, PartialEq)]
pub struct LaserScanMsg {
    /// `header.stamp`.
    pub stamp: RosTime,
    /// `header.frame_id`.
    pub frame_id: String,
    /// Bearing of the first beam, radians.
    pub angle_min: f32,
    /// Bearing of the last beam, radians.
    pub angle_max: f32,
    /// Bearing step, radians (negative for a clockwise scanner).
    pub angle_increment: f32,
    /// Time between beams, seconds.
    pub time_increment: f32,
    /// Time between scans, seconds.
    pub scan_time: f32,
    /// Shortest valid range, metres.
    pub range_min: f32,
    /// Longest valid range, metres.
    pub range_max: f32,
    /// Ranges, metres.
    pub ranges: Vec<f32>,
    /// Number of intensities in the message (their values are not kept).
    pub intensity_count: usize,
}

impl LaserScanMsg {
    /// Decodes a message; checks its counts against its length and its geometry.
    pub fn decode(data: &[u8], flavor: Flavor) -> Result<Self, MessageProblem> {
        let mut d = match flavor {
            Flavor::Ros1 => Decoder::ros1(data),
            _ => Decoder::cdr(data)?,
        };
        let flavor = d.flavor();
        let (stamp, frame_id) = decode_header(&mut d, flavor)?;
        let mut f = [0f32; 7];
        for (v, name) in f.iter_mut().zip(SCAN_FLOATS) {
            *v = d.f32(name)?;
        }
        let ranges = d.f32_seq("ranges")?;
        let intensity_count = d.count("intensities", 4)?;
        for _ in 0..intensity_count {
            d.f32("intensities")?;
        }
        d.finish()?;
        let msg = LaserScanMsg {
            stamp,
            frame_id,
            angle_min: f[0],
            angle_max: f[1],
            angle_increment: f[2],
            time_increment: f[3],
            scan_time: f[4],
            range_min: f[5],
            range_max: f[6],
            ranges,
            intensity_count,
        };
        msg.check_geometry()?;
        Ok(msg)
    }

    /// Checks what the mapper relies on: a finite, non-zero bearing step, finite bearings and
    /// a positive `range_max` (as [`decode`](Self::decode) does for every message it reads).
    pub fn check_geometry(&self) -> Result<(), MessageProblem> {
        let bad = |field, value: f32| {
            Err(MessageProblem::BadValue {
                field,
                value: f64::from(value),
            })
        };
        if !self.angle_min.is_finite() {
            return bad("angle_min", self.angle_min);
        }
        if !self.angle_increment.is_finite()
            || (self.angle_increment == 0.0 && self.ranges.len() > 1)
        {
            return bad("angle_increment", self.angle_increment);
        }
        if let Some(reason) = beyond_a_turn(f64::from(self.angle_increment), self.ranges.len()) {
            return Err(MessageProblem::BadGeometry {
                field: "angle_increment",
                reason,
            });
        }
        if self.range_min.is_nan() {
            return bad("range_min", self.range_min);
        }
        if self.range_max.is_nan() || self.range_max <= 0.0 {
            return bad("range_max", self.range_max);
        }
        Ok(())
    }

    /// Encodes the message (intensities: none).
    pub fn encode(&self, flavor: Flavor, seq: u32) -> Vec<u8> {
        let mut e = Encoder::new(flavor);
        encode_header(&mut e, flavor, seq, &self.stamp, &self.frame_id);
        for v in [
            self.angle_min,
            self.angle_max,
            self.angle_increment,
            self.time_increment,
            self.scan_time,
            self.range_min,
            self.range_max,
        ] {
            e.f32(v);
        }
        e.f32_seq(&self.ranges);
        e.u32(0);
        e.finish()
    }

    /// The scan for the mapper: stamp from `header.stamp`; readings that are NaN, ±inf, below
    /// `range_min` or above `range_max` become `+inf` (no-return); the laser frame is the robot
    /// frame and there is no odometry yet (the scan reader sets both from tf or odometry).
    pub fn to_range_scan(&self) -> RangeScan {
        let (lo, hi) = (self.range_min, self.range_max);
        let ranges_m = self
            .ranges
            .iter()
            .map(|&r| {
                if r.is_finite() && r >= lo && r <= hi {
                    f64::from(r)
                } else {
                    f64::INFINITY
                }
            })
            .collect();
        RangeScan {
            stamp: self.stamp.to_stamp(),
            ranges_m,
            angle_min_rad: f64::from(self.angle_min),
            angle_increment_rad: f64::from(self.angle_increment),
            // `RangeScan` treats readings at its maximum as no-returns; ROS keeps `range_max`.
            max_range_m: f64::from(self.range_max).next_up(),
            robot_from_laser: Pose2::IDENTITY,
            odom_from_robot: None,
        }
    }

    /// The message for a scan (the inverse of [`to_range_scan`](Self::to_range_scan) up to
    /// `float32` precision): no-returns and readings at or beyond `max_range_m` become `+inf`.
    pub fn from_range_scan(scan: &RangeScan, stamp: RosTime, frame_id: &str) -> Self {
        let n = scan.ranges_m.len();
        let ranges = scan
            .ranges_m
            .iter()
            .map(|&r| {
                if scan.is_valid_range(r) {
                    r as f32
                } else {
                    f32::INFINITY
                }
            })
            .collect();
        let last = scan.angle_min_rad + n.saturating_sub(1) as f64 * scan.angle_increment_rad;
        LaserScanMsg {
            stamp,
            frame_id: frame_id.to_owned(),
            angle_min: scan.angle_min_rad as f32,
            angle_max: last as f32,
            angle_increment: scan.angle_increment_rad as f32,
            time_increment: 0.0,
            scan_time: 0.0,
            range_min: 0.0,
            range_max: scan.max_range_m as f32,
            ranges,
            intensity_count: 0,
        }
    }
}

const SCAN_FLOATS: [&str; 7] = [
    "angle_min",
    "angle_max",
    "angle_increment",
    "time_increment",
    "scan_time",
    "range_min",
    "range_max",
];

/// The pose part of a `nav_msgs/Odometry`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdometryMsg {
    /// `header.stamp`.
    pub stamp: RosTime,
    /// `pose.pose.position` x and y, metres (odometry frame).
    pub position_m: [f64; 2],
    /// `pose.pose.orientation` as `[x, y, z, w]`.
    pub orientation: [f64; 4],
}

impl OdometryMsg {
    /// Decodes a message (twist and covariances are checked for length, not kept).
    pub fn decode(data: &[u8], flavor: Flavor) -> Result<Self, MessageProblem> {
        let mut d = match flavor {
            Flavor::Ros1 => Decoder::ros1(data),
            _ => Decoder::cdr(data)?,
        };
        let flavor = d.flavor();
        let (stamp, _) = decode_header(&mut d, flavor)?;
        d.string("child_frame_id")?;
        let x = d.f64("pose.position.x")?;
        let y = d.f64("pose.position.y")?;
        d.f64("pose.position.z")?;
        let mut q = [0.0; 4];
        for v in &mut q {
            *v = d.f64("pose.orientation")?;
        }
        d.skip_f64(36, "pose.covariance")?;
        d.skip_f64(6 + 36, "twist")?;
        d.finish()?;
        if !(x.is_finite() && y.is_finite() && q.iter().all(|v| v.is_finite())) {
            return Err(MessageProblem::BadValue {
                field: "pose",
                value: f64::NAN,
            });
        }
        Ok(OdometryMsg {
            stamp,
            position_m: [x, y],
            orientation: q,
        })
    }

    /// Encodes the message with frames `odom` and `base_link`, zero covariances and twist.
    pub fn encode(&self, flavor: Flavor, seq: u32) -> Vec<u8> {
        let mut e = Encoder::new(flavor);
        encode_header(&mut e, flavor, seq, &self.stamp, "odom");
        e.string("base_link");
        e.f64(self.position_m[0]);
        e.f64(self.position_m[1]);
        e.f64(0.0);
        for v in self.orientation {
            e.f64(v);
        }
        for _ in 0..36 + 6 + 36 {
            e.f64(0.0);
        }
        e.finish()
    }

    /// The planar pose: x, y and the yaw of the quaternion.
    pub fn pose(&self) -> Pose2 {
        let [qx, qy, qz, qw] = self.orientation;
        let yaw = (2.0 * (qw * qz + qx * qy)).atan2(1.0 - 2.0 * (qy * qy + qz * qz));
        Pose2::new(self.position_m[0], self.position_m[1], yaw)
    }

    /// The message of a planar pose (quaternion about z).
    pub fn from_pose(stamp: RosTime, pose: &Pose2) -> Self {
        let (s, c) = (pose.theta_rad / 2.0).sin_cos();
        OdometryMsg {
            stamp,
            position_m: [pose.x_m, pose.y_m],
            orientation: [0.0, 0.0, s, c],
        }
    }
}

/// One `geometry_msgs/TransformStamped`: where frame `child_frame` is in frame `parent_frame`
/// at `stamp`, i.e. the transform `parent_from_child` (it maps points given in the child frame
/// into the parent frame).
#[derive(Debug, Clone, PartialEq)]
pub struct TransformStampedMsg {
    /// `header.stamp`.
    pub stamp: RosTime,
    /// `header.frame_id`: the parent frame, as written (a leading `/` kept).
    pub parent_frame: String,
    /// `child_frame_id`, as written.
    pub child_frame: String,
    /// `transform.translation` x, y, z: the child frame's origin in the parent frame, metres.
    pub translation_m: [f64; 3],
    /// `transform.rotation` as `[x, y, z, w]` (a unit quaternion when well formed; the values
    /// are kept as written and checked by [`TfBuffer`](super::tf::TfBuffer)).
    pub rotation: [f64; 4],
}

/// The least bytes one `TransformStamped` takes in either serialization: stamp (8), two strings
/// (4-byte length each, and CDR's NUL), seven `float64` (56). A count of transforms is checked
/// against it before anything is decoded.
const MIN_TRANSFORM_BYTES: usize = 8 + 4 + 4 + 56;

impl TransformStampedMsg {
    /// The transform of a planar pose: `parent_from_child = pose` (rotation about z).
    pub fn from_pose(stamp: RosTime, parent_frame: &str, child_frame: &str, pose: &Pose2) -> Self {
        let (s, c) = (pose.theta_rad / 2.0).sin_cos();
        TransformStampedMsg {
            stamp,
            parent_frame: parent_frame.to_owned(),
            child_frame: child_frame.to_owned(),
            translation_m: [pose.x_m, pose.y_m, 0.0],
            rotation: [0.0, 0.0, s, c],
        }
    }

    fn decode(d: &mut Decoder<'_>, flavor: Flavor) -> Result<Self, MessageProblem> {
        let (stamp, parent_frame) = decode_header(d, flavor)?;
        let child_frame = d.string("child_frame_id")?;
        let mut translation_m = [0.0; 3];
        for v in &mut translation_m {
            *v = d.f64("transform.translation")?;
        }
        let mut rotation = [0.0; 4];
        for v in &mut rotation {
            *v = d.f64("transform.rotation")?;
        }
        Ok(TransformStampedMsg {
            stamp,
            parent_frame,
            child_frame,
            translation_m,
            rotation,
        })
    }

    fn encode(&self, e: &mut Encoder, flavor: Flavor, seq: u32) {
        encode_header(e, flavor, seq, &self.stamp, &self.parent_frame);
        e.string(&self.child_frame);
        for v in self.translation_m.iter().chain(&self.rotation) {
            e.f64(*v);
        }
    }
}

/// A `tf2_msgs/TFMessage` (ROS 1 and ROS 2; ROS 1's `tf/tfMessage` has the same layout): the
/// transforms published together on `/tf` or `/tf_static`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TfMessage {
    /// The `transforms` array, in message order.
    pub transforms: Vec<TransformStampedMsg>,
}

impl TfMessage {
    /// Decodes a message. The count of transforms is checked against the bytes left (at least
    /// 72 bytes each) before any is decoded; strings are checked against the message's length.
    ///
    /// ```
    /// use polymap::geometry::Pose2;
    /// use polymap_io::ros::{Flavor, RosTime, TfMessage, TransformStampedMsg};
    /// let t = TransformStampedMsg::from_pose(
    ///     RosTime { sec: 3, nanosec: 0 }, "base_link", "laser", &Pose2::new(0.25, 0.0, 0.0));
    /// let msg = TfMessage { transforms: vec![t] };
    /// for flavor in [Flavor::Ros1, Flavor::CdrLittle, Flavor::CdrBig] {
    ///     assert_eq!(TfMessage::decode(&msg.encode(flavor, 7), flavor).unwrap(), msg);
    /// }
    /// ```
    pub fn decode(data: &[u8], flavor: Flavor) -> Result<Self, MessageProblem> {
        let mut d = match flavor {
            Flavor::Ros1 => Decoder::ros1(data),
            _ => Decoder::cdr(data)?,
        };
        let flavor = d.flavor();
        let n = d.count_min("transforms", MIN_TRANSFORM_BYTES)?;
        let mut transforms = Vec::with_capacity(n);
        for _ in 0..n {
            transforms.push(TransformStampedMsg::decode(&mut d, flavor)?);
        }
        d.finish()?;
        Ok(TfMessage { transforms })
    }

    /// Encodes the message; ROS 1 headers get sequence number `seq`.
    pub fn encode(&self, flavor: Flavor, seq: u32) -> Vec<u8> {
        let mut e = Encoder::new(flavor);
        e.u32(u32::try_from(self.transforms.len()).unwrap_or(u32::MAX));
        for t in &self.transforms {
            t.encode(&mut e, flavor, seq);
        }
        e.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scan of `n` beams `step` radians apart, as a message.
    fn scan(n: usize, step: f32) -> LaserScanMsg {
        LaserScanMsg {
            stamp: RosTime { sec: 1, nanosec: 0 },
            frame_id: "laser".into(),
            angle_min: 0.0,
            angle_max: step * (n - 1) as f32,
            angle_increment: step,
            time_increment: 0.0,
            scan_time: 0.0,
            range_min: 0.0,
            range_max: 10.0,
            ranges: vec![1.0; n],
            intensity_count: 0,
        }
    }

    fn tf_message() -> TfMessage {
        let t = |sec, parent: &str, child: &str, x: f64, yaw: f64| {
            TransformStampedMsg::from_pose(
                RosTime { sec, nanosec: 250 },
                parent,
                child,
                &Pose2::new(x, -0.5, yaw),
            )
        };
        TfMessage {
            transforms: vec![
                t(1_700_000_000, "odom", "base_link", 3.5, 2.0),
                t(1_700_000_000, "/base_link", "laser_front", 0.25, -0.1),
            ],
        }
    }

    #[test]
    fn tf_messages_round_trip_in_both_serializations() {
        let msg = tf_message();
        for flavor in [Flavor::Ros1, Flavor::CdrLittle, Flavor::CdrBig] {
            let bytes = msg.encode(flavor, 42);
            assert_eq!(
                TfMessage::decode(&bytes, flavor).unwrap(),
                msg,
                "{flavor:?}"
            );
        }
        // ROS 1: a count, then per transform seq, stamp, two strings without NUL, 7 doubles.
        let ros1 = msg.encode(Flavor::Ros1, 42);
        let strings = "odom".len() + "base_link".len() + "/base_link".len() + "laser_front".len();
        assert_eq!(ros1.len(), 4 + 2 * (12 + 8 + 56) + strings);
        assert_eq!(&ros1[..8], &[2, 0, 0, 0, 42, 0, 0, 0]);
        let empty = TfMessage::default();
        assert_eq!(
            TfMessage::decode(&empty.encode(Flavor::CdrLittle, 0), Flavor::CdrLittle).unwrap(),
            empty
        );
    }

    /// The `tf2_msgs/msg/TFMessage` of the rosbag2 conformance recordings (written by ROS 2):
    /// `test_frame` → `child_frame`, translation (1, 2, 3), identity rotation.
    #[test]
    fn a_tf_message_written_by_ros_2_decodes() {
        let hex = "0001000001000000FC6E446800D0EE2E0B000000746573745F6672616D6500000C0000006368\
                   696C645F6672616D650000000000000000000000F03F000000000000004000000000000008400000\
                   00000000000000000000000000000000000000000000000000000000F03F";
        let bytes: Vec<u8> = (0..hex.len())
            .step_by(2)
            .map(|i| u8::from_str_radix(&hex[i..i + 2], 16).unwrap())
            .collect();
        let msg = TfMessage::decode(&bytes, Flavor::CdrLittle).unwrap();
        assert_eq!(msg.transforms.len(), 1);
        let t = &msg.transforms[0];
        assert_eq!(
            (t.parent_frame.as_str(), t.child_frame.as_str()),
            ("test_frame", "child_frame")
        );
        assert_eq!(t.translation_m, [1.0, 2.0, 3.0]);
        assert_eq!(t.rotation, [0.0, 0.0, 0.0, 1.0]);
        assert_eq!(t.stamp.sec, 1_749_315_324);
        // Encoding it again gives the same bytes.
        assert_eq!(msg.encode(Flavor::CdrLittle, 0), bytes);
    }

    /// A cut, a count beyond the message, bytes left over, and flipped bits are errors (or a
    /// message of other values), never a panic nor an allocation by the count.
    #[test]
    fn malformed_tf_messages_are_errors() {
        for flavor in [Flavor::Ros1, Flavor::CdrLittle, Flavor::CdrBig] {
            let bytes = tf_message().encode(flavor, 1);
            for cut in 0..bytes.len() {
                assert!(
                    TfMessage::decode(&bytes[..cut], flavor).is_err(),
                    "{flavor:?} {cut}"
                );
            }
            let mut long = bytes.clone();
            long.extend_from_slice(&[0; 8]);
            assert!(matches!(
                TfMessage::decode(&long, flavor),
                Err(MessageProblem::TrailingBytes { .. })
            ));
            let mut huge = bytes.clone();
            let at = if flavor == Flavor::Ros1 { 0 } else { 4 };
            huge[at..at + 4].copy_from_slice(&[0xff; 4]);
            assert!(matches!(
                TfMessage::decode(&huge, flavor),
                Err(MessageProblem::CountTooLarge {
                    field: "transforms",
                    count: u32::MAX,
                    ..
                })
            ));
            let mut state = 0x2545_f491_4f6c_dd1du64;
            for _ in 0..2_000 {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let mut flipped = bytes.clone();
                let i = (state % flipped.len() as u64) as usize;
                flipped[i] ^= 1 << (state >> 60 & 7);
                let _ = TfMessage::decode(&flipped, flavor);
            }
        }
    }

    /// Beams spanning 361 rad gave an empty map with exit 0; the CARMEN reader refuses the
    /// same geometry, and so does this one, clockwise or not.
    #[test]
    fn beams_spanning_more_than_a_turn_are_refused() {
        for step in [1.0f32, -1.0] {
            let data = scan(362, step).encode(Flavor::CdrLittle, 0);
            let e = LaserScanMsg::decode(&data, Flavor::CdrLittle).unwrap_err();
            assert!(
                e.to_string().contains("362 beams at")
                    && e.to_string().contains("more than a full turn"),
                "{e}"
            );
        }
        let turn = scan(360, std::f32::consts::TAU / 360.0).encode(Flavor::CdrLittle, 0);
        assert!(LaserScanMsg::decode(&turn, Flavor::CdrLittle).is_ok());
    }
}
