//! Message definitions written into the files polymap writes (bags and MCAP schemas).

/// The ROS 1 MD5 sum and full definition of a type (`sensor_msgs/LaserScan`,
/// `nav_msgs/Odometry` or `tf2_msgs/TFMessage`; any other type gets `*` and an empty
/// definition).
pub(crate) fn definition(type_name: &str) -> (&'static str, &'static str) {
    match type_name {
        "sensor_msgs/LaserScan" => ("90c7ef2dc6895d81024acba2ac42f369", ROS1_LASER_SCAN),
        "nav_msgs/Odometry" => ("cd5e73d190d741a2f92e81eda573aca7", ROS1_ODOMETRY),
        "tf2_msgs/TFMessage" => ("94810edda583a504dfda3829e70d7eec", ROS1_TF_MESSAGE),
        _ => ("*", ""),
    }
}

/// The ROS 2 (`ros2msg`) definition of a type (`sensor_msgs/msg/LaserScan`,
/// `nav_msgs/msg/Odometry` or `tf2_msgs/msg/TFMessage`; empty for any other).
pub(crate) fn ros2_definition(type_name: &str) -> &'static str {
    match type_name {
        "sensor_msgs/msg/LaserScan" => ROS2_LASER_SCAN,
        "nav_msgs/msg/Odometry" => ROS2_ODOMETRY,
        "tf2_msgs/msg/TFMessage" => ROS2_TF_MESSAGE,
        _ => "",
    }
}

const ROS1_TF_MESSAGE: &str = r#"geometry_msgs/TransformStamped[] transforms

================================================================================
MSG: geometry_msgs/TransformStamped
Header header
string child_frame_id
geometry_msgs/Transform transform

================================================================================
MSG: std_msgs/Header
uint32 seq
time stamp
string frame_id

================================================================================
MSG: geometry_msgs/Transform
geometry_msgs/Vector3 translation
geometry_msgs/Quaternion rotation

================================================================================
MSG: geometry_msgs/Vector3
float64 x
float64 y
float64 z

================================================================================
MSG: geometry_msgs/Quaternion
float64 x
float64 y
float64 z
float64 w
"#;

const ROS2_TF_MESSAGE: &str = r#"geometry_msgs/TransformStamped[] transforms

================================================================================
MSG: geometry_msgs/TransformStamped
std_msgs/Header header
string child_frame_id
geometry_msgs/Transform transform

================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id

================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec

================================================================================
MSG: geometry_msgs/Transform
geometry_msgs/Vector3 translation
geometry_msgs/Quaternion rotation

================================================================================
MSG: geometry_msgs/Vector3
float64 x
float64 y
float64 z

================================================================================
MSG: geometry_msgs/Quaternion
float64 x
float64 y
float64 z
float64 w
"#;

const ROS1_LASER_SCAN: &str = r#"Header header
float32 angle_min
float32 angle_max
float32 angle_increment
float32 time_increment
float32 scan_time
float32 range_min
float32 range_max
float32[] ranges
float32[] intensities

================================================================================
MSG: std_msgs/Header
uint32 seq
time stamp
string frame_id
"#;

const ROS1_ODOMETRY: &str = r#"Header header
string child_frame_id
geometry_msgs/PoseWithCovariance pose
geometry_msgs/TwistWithCovariance twist

================================================================================
MSG: std_msgs/Header
uint32 seq
time stamp
string frame_id

================================================================================
MSG: geometry_msgs/PoseWithCovariance
geometry_msgs/Pose pose
float64[36] covariance

================================================================================
MSG: geometry_msgs/Pose
geometry_msgs/Point position
geometry_msgs/Quaternion orientation

================================================================================
MSG: geometry_msgs/Point
float64 x
float64 y
float64 z

================================================================================
MSG: geometry_msgs/Quaternion
float64 x
float64 y
float64 z
float64 w

================================================================================
MSG: geometry_msgs/TwistWithCovariance
geometry_msgs/Twist twist
float64[36] covariance

================================================================================
MSG: geometry_msgs/Twist
geometry_msgs/Vector3 linear
geometry_msgs/Vector3 angular

================================================================================
MSG: geometry_msgs/Vector3
float64 x
float64 y
float64 z
"#;

const ROS2_LASER_SCAN: &str = r#"std_msgs/Header header
float32 angle_min
float32 angle_max
float32 angle_increment
float32 time_increment
float32 scan_time
float32 range_min
float32 range_max
float32[] ranges
float32[] intensities

================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id

================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"#;

const ROS2_ODOMETRY: &str = r#"std_msgs/Header header
string child_frame_id
geometry_msgs/PoseWithCovariance pose
geometry_msgs/TwistWithCovariance twist

================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id

================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec

================================================================================
MSG: geometry_msgs/PoseWithCovariance
geometry_msgs/Pose pose
float64[36] covariance

================================================================================
MSG: geometry_msgs/Pose
geometry_msgs/Point position
geometry_msgs/Quaternion orientation

================================================================================
MSG: geometry_msgs/Point
float64 x
float64 y
float64 z

================================================================================
MSG: geometry_msgs/Quaternion
float64 x
float64 y
float64 z
float64 w

================================================================================
MSG: geometry_msgs/TwistWithCovariance
geometry_msgs/Twist twist
float64[36] covariance

================================================================================
MSG: geometry_msgs/Twist
geometry_msgs/Vector3 linear
geometry_msgs/Vector3 angular

================================================================================
MSG: geometry_msgs/Vector3
float64 x
float64 y
float64 z
"#;
