//! Integration tests of polymap-io, in one test binary.

mod real_logs;
mod ros_damaged;
mod ros_files;
mod ros_rosbags;
mod ros_tf;
mod ros_written;
