//! polymap as a ROS 2 node, with no ROS installation: `sensor_msgs/LaserScan` (and optionally
//! `nav_msgs/Odometry`) in over DDS; `/map`, `/tf`, `/pose`, `polymap/segments` and
//! `polymap/status` out, following the conventions of slam_toolbox and cartographer_ros
//! (REP-105 frames). The client is `ros2-client` on RustDDS, both pure Rust.
//!
//! The node is a scan source for the mapping pipeline like any log ([`live::LiveSource`]), so a
//! live run and a recorded one are mapped by the same code; the caller (`polymap ros2`) runs
//! the pipeline and calls [`node::Ros2Node::on_scan`] after each scan.
#![forbid(unsafe_code)]
#![deny(missing_docs)]

pub mod dds;
mod grid;
pub mod live;
pub mod msgs;
pub mod node;
pub mod outputs;
mod receive;
