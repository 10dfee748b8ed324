//! The ROS 2 messages the node reads and writes, as serde types whose CDR encoding (the field
//! order and types of the `.msg` definitions of ROS 2 Humble, Jazzy and Kilted, which agree on
//! all of these) is what every ROS 2 middleware puts on the wire.
//!
//! Only what the node needs is here; a field is named as in its `.msg` file. Fixed-size arrays
//! (`float64[36]` covariances) go through [`Covariance`], as serde's own arrays stop at 32.

use serde::de::{self, SeqAccess, Visitor};
use serde::ser::SerializeTuple;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// `builtin_interfaces/msg/Time`: seconds and nanoseconds since the epoch (or the clock's
/// start under simulated time).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Time {
    /// Whole seconds.
    pub sec: i32,
    /// Nanoseconds within the second, below 1e9.
    pub nanosec: u32,
}

/// `builtin_interfaces/msg/Duration`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Duration {
    /// Whole seconds.
    pub sec: i32,
    /// Nanoseconds within the second, below 1e9.
    pub nanosec: u32,
}

/// `std_msgs/msg/Header`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// When the data was taken.
    pub stamp: Time,
    /// The frame the data is expressed in.
    pub frame_id: String,
}

/// `sensor_msgs/msg/LaserScan` (angles in radians, counter-clockwise from the frame's x
/// axis; ranges in metres).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct LaserScan {
    /// Stamp of the first beam and the laser's frame.
    pub header: Header,
    /// Bearing of the first beam, radians.
    pub angle_min: f32,
    /// Bearing of the last beam, radians.
    pub angle_max: f32,
    /// Bearing step, radians.
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
    /// Intensities (device units), possibly empty.
    pub intensities: Vec<f32>,
}

/// `geometry_msgs/msg/Point` (also `Vector3`'s layout), metres.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Point {
    /// x, metres.
    pub x: f64,
    /// y, metres.
    pub y: f64,
    /// z, metres.
    pub z: f64,
}

/// `geometry_msgs/msg/Vector3`.
pub type Vector3 = Point;

/// `geometry_msgs/msg/Quaternion`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Default for Quaternion {
    fn default() -> Self {
        Quaternion::from_yaw(0.0)
    }
}

impl Quaternion {
    /// The rotation by `yaw_rad` about z.
    pub fn from_yaw(yaw_rad: f64) -> Self {
        let (s, c) = (yaw_rad / 2.0).sin_cos();
        Quaternion {
            x: 0.0,
            y: 0.0,
            z: s,
            w: c,
        }
    }

    /// The rotation about z that this quaternion's rotation turns the x axis by (its yaw,
    /// radians), whatever its roll and pitch.
    pub fn yaw(&self) -> f64 {
        let siny = 2.0 * (self.w * self.z + self.x * self.y);
        let cosy = 1.0 - 2.0 * (self.y * self.y + self.z * self.z);
        siny.atan2(cosy)
    }
}

/// `geometry_msgs/msg/Pose`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Position, metres.
    pub position: Point,
    /// Orientation.
    pub orientation: Quaternion,
}

/// A `float64[36]`: a 6×6 covariance, row-major over (x, y, z, roll, pitch, yaw), metres and
/// radians squared.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Covariance(pub [f64; 36]);

impl Default for Covariance {
    fn default() -> Self {
        Covariance([0.0; 36])
    }
}

impl Serialize for Covariance {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut t = s.serialize_tuple(36)?;
        for v in &self.0 {
            t.serialize_element(v)?;
        }
        t.end()
    }
}

impl<'de> Deserialize<'de> for Covariance {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Covariance;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("36 float64")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Covariance, A::Error> {
                let mut c = [0.0; 36];
                for (i, v) in c.iter_mut().enumerate() {
                    *v = seq
                        .next_element()?
                        .ok_or_else(|| de::Error::invalid_length(i, &self))?;
                }
                Ok(Covariance(c))
            }
        }
        d.deserialize_tuple(36, V)
    }
}

/// `geometry_msgs/msg/PoseWithCovariance`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    /// The pose.
    pub pose: Pose,
    /// Its covariance (x, y, z, roll, pitch, yaw).
    pub covariance: Covariance,
}

/// `geometry_msgs/msg/PoseWithCovarianceStamped`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovarianceStamped {
    /// Stamp and the frame the pose is in.
    pub header: Header,
    /// The pose.
    pub pose: PoseWithCovariance,
}

/// `geometry_msgs/msg/Twist`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Twist {
    /// Linear velocity, m/s.
    pub linear: Vector3,
    /// Angular velocity, rad/s.
    pub angular: Vector3,
}

/// `geometry_msgs/msg/TwistWithCovariance`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct TwistWithCovariance {
    /// The twist.
    pub twist: Twist,
    /// Its covariance.
    pub covariance: Covariance,
}

/// `nav_msgs/msg/Odometry`: the pose of `child_frame_id` in `header.frame_id`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Odometry {
    /// Stamp and the odometry frame.
    pub header: Header,
    /// The robot's (base) frame.
    pub child_frame_id: String,
    /// The base's pose in the odometry frame.
    pub pose: PoseWithCovariance,
    /// The base's velocity, in the child frame.
    pub twist: TwistWithCovariance,
}

/// `geometry_msgs/msg/Transform`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Transform {
    /// Translation, metres.
    pub translation: Vector3,
    /// Rotation.
    pub rotation: Quaternion,
}

/// `geometry_msgs/msg/TransformStamped`: where `child_frame_id` is in `header.frame_id`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Stamp and the parent frame.
    pub header: Header,
    /// The child frame.
    pub child_frame_id: String,
    /// Parent from child.
    pub transform: Transform,
}

/// `tf2_msgs/msg/TFMessage`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TfMessage {
    /// The transforms.
    pub transforms: Vec<TransformStamped>,
}

/// `nav_msgs/msg/MapMetaData`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct MapMetaData {
    /// When the map was loaded (made).
    pub map_load_time: Time,
    /// Cell size, metres.
    pub resolution: f32,
    /// Cells along x.
    pub width: u32,
    /// Cells along y.
    pub height: u32,
    /// The map frame's pose of cell (0, 0)'s corner.
    pub origin: Pose,
}

/// `nav_msgs/msg/OccupancyGrid`: row-major from the origin cell, row 0 at the lowest y;
/// 0 free, 100 occupied, -1 unknown.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct OccupancyGrid {
    /// Stamp and the map frame.
    pub header: Header,
    /// Size and placement.
    pub info: MapMetaData,
    /// Cell values.
    pub data: Vec<i8>,
}

/// `std_msgs/msg/ColorRGBA`, each in [0, 1].
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct ColorRgba {
    /// Red.
    pub r: f32,
    /// Green.
    pub g: f32,
    /// Blue.
    pub b: f32,
    /// Opacity.
    pub a: f32,
}

/// `sensor_msgs/msg/CompressedImage` (only as a part of [`Marker`]).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CompressedImage {
    /// Stamp and frame.
    pub header: Header,
    /// `jpeg`, `png`, ...
    pub format: String,
    /// The encoded image.
    pub data: Vec<u8>,
}

/// `visualization_msgs/msg/UVCoordinate`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct UvCoordinate {
    /// u in [0, 1].
    pub u: f32,
    /// v in [0, 1].
    pub v: f32,
}

/// `visualization_msgs/msg/MeshFile`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MeshFile {
    /// Name (for its extension).
    pub filename: String,
    /// The file's bytes.
    pub data: Vec<u8>,
}

/// `visualization_msgs/msg/Marker` as of ROS 2 Humble (with the texture and mesh fields).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Marker {
    /// Stamp and the frame the points are in.
    pub header: Header,
    /// Namespace of the id.
    pub ns: String,
    /// Id within the namespace.
    pub id: i32,
    /// [`Marker::LINE_STRIP`], ...
    #[serde(rename = "type")]
    pub kind: i32,
    /// [`Marker::ADD`] or [`Marker::DELETEALL`], ...
    pub action: i32,
    /// The pose of the points' frame in the header's frame.
    pub pose: Pose,
    /// For line strips, `scale.x` is the line width, metres.
    pub scale: Vector3,
    /// Colour of the whole marker.
    pub color: ColorRgba,
    /// How long the marker lives (0: until replaced).
    pub lifetime: Duration,
    /// Whether the marker follows its frame.
    pub frame_locked: bool,
    /// The points, metres.
    pub points: Vec<Point>,
    /// Per-point colours (empty: `color`).
    pub colors: Vec<ColorRgba>,
    /// Texture URI.
    pub texture_resource: String,
    /// Embedded texture.
    pub texture: CompressedImage,
    /// Texture coordinates.
    pub uv_coordinates: Vec<UvCoordinate>,
    /// Text of a text marker.
    pub text: String,
    /// Mesh URI.
    pub mesh_resource: String,
    /// Embedded mesh.
    pub mesh_file: MeshFile,
    /// Whether a mesh uses its own materials.
    pub mesh_use_embedded_materials: bool,
}

impl Marker {
    /// A connected line through `points`.
    pub const LINE_STRIP: i32 = 4;
    /// Add or replace the marker.
    pub const ADD: i32 = 0;
    /// Delete every marker of the namespace.
    pub const DELETEALL: i32 = 3;
}

/// `visualization_msgs/msg/MarkerArray`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MarkerArray {
    /// The markers.
    pub markers: Vec<Marker>,
}

/// `diagnostic_msgs/msg/KeyValue`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct KeyValue {
    /// Key.
    pub key: String,
    /// Value.
    pub value: String,
}

/// `diagnostic_msgs/msg/DiagnosticStatus`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct DiagnosticStatus {
    /// [`DiagnosticStatus::OK`], `WARN`, `ERROR` or `STALE` (a `byte`).
    pub level: u8,
    /// What is reported on (`polymap: tracking`).
    pub name: String,
    /// A sentence for people.
    pub message: String,
    /// The hardware, if any.
    pub hardware_id: String,
    /// Figures.
    pub values: Vec<KeyValue>,
}

impl DiagnosticStatus {
    /// All is well.
    pub const OK: u8 = 0;
    /// Something is doubtful.
    pub const WARN: u8 = 1;
    /// Something is wrong.
    pub const ERROR: u8 = 2;
}

/// `diagnostic_msgs/msg/DiagnosticArray`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct DiagnosticArray {
    /// Stamp.
    pub header: Header,
    /// The statuses.
    pub status: Vec<DiagnosticStatus>,
}

/// A message type's ROS 2 package and name (`sensor_msgs`, `LaserScan`), for the topic's DDS
/// type name (`sensor_msgs::msg::dds_::LaserScan_`).
pub trait RosMessage {
    /// The package.
    const PACKAGE: &'static str;
    /// The type's name in it.
    const NAME: &'static str;
}

macro_rules! ros_message {
    ($($t:ty => $package:literal / $name:literal),* $(,)?) => {
        $(impl RosMessage for $t {
            const PACKAGE: &'static str = $package;
            const NAME: &'static str = $name;
        })*
    };
}

ros_message! {
    LaserScan => "sensor_msgs" / "LaserScan",
    Odometry => "nav_msgs" / "Odometry",
    TfMessage => "tf2_msgs" / "TFMessage",
    OccupancyGrid => "nav_msgs" / "OccupancyGrid",
    PoseWithCovarianceStamped => "geometry_msgs" / "PoseWithCovarianceStamped",
    MarkerArray => "visualization_msgs" / "MarkerArray",
    DiagnosticArray => "diagnostic_msgs" / "DiagnosticArray",
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_yaw_goes_through_a_quaternion_and_back() {
        for yaw in [-3.0, -1.0, 0.0, 0.5, 3.1] {
            assert!((Quaternion::from_yaw(yaw).yaw() - yaw).abs() < 1e-12);
        }
    }

    /// A message in CDR as a DDS sample carries it: the little-endian encapsulation header,
    /// then the body.
    fn sample<T: Serialize>(m: &T) -> Vec<u8> {
        let mut out = vec![0, 1, 0, 0];
        out.extend(cdr_encoding::to_vec::<_, byteorder::LittleEndian>(m).unwrap());
        out
    }

    #[test]
    fn a_laser_scan_reads_back_through_the_recordings_decoder() {
        let m = LaserScan {
            header: Header {
                stamp: Time {
                    sec: 17,
                    nanosec: 250,
                },
                frame_id: "laser".into(),
            },
            angle_min: -1.5,
            angle_max: 1.5,
            angle_increment: 1.0,
            range_min: 0.1,
            range_max: 30.0,
            ranges: vec![1.0, 2.0, 3.0, 4.0],
            intensities: vec![7.0; 4],
            ..LaserScan::default()
        };
        let d =
            polymap_io::ros::LaserScanMsg::decode(&sample(&m), polymap_io::ros::Flavor::CdrLittle)
                .unwrap();
        assert_eq!((d.stamp.sec, d.stamp.nanosec), (17, 250));
        assert_eq!(d.frame_id, "laser");
        assert_eq!((d.angle_min, d.range_max), (-1.5, 30.0));
        assert_eq!(d.ranges, m.ranges);
        assert_eq!(d.intensity_count, 4);
    }

    #[test]
    fn an_odometry_reads_back_through_the_recordings_decoder() {
        let mut m = Odometry {
            header: Header {
                stamp: Time { sec: 3, nanosec: 9 },
                frame_id: "odom".into(),
            },
            child_frame_id: "base_link".into(),
            ..Odometry::default()
        };
        m.pose.pose.position.x = 1.25;
        m.pose.pose.position.y = -2.0;
        m.pose.pose.orientation = Quaternion::from_yaw(0.5);
        m.twist.covariance.0[35] = 1.0;
        let d =
            polymap_io::ros::OdometryMsg::decode(&sample(&m), polymap_io::ros::Flavor::CdrLittle)
                .unwrap();
        assert_eq!(d.position_m, [1.25, -2.0]);
        assert!((d.pose().theta_rad - 0.5).abs() < 1e-12);
    }

    #[test]
    fn a_covariance_is_36_numbers_without_a_length() {
        let mut c = Covariance::default();
        c.0[35] = 2.5;
        let bytes = cdr_encoding::to_vec::<_, byteorder::LittleEndian>(&c).unwrap();
        assert_eq!(bytes.len(), 36 * 8);
        let (back, _) =
            cdr_encoding::from_bytes::<Covariance, byteorder::LittleEndian>(&bytes).unwrap();
        assert_eq!(back, c);
    }
}
