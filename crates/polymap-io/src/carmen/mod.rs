//! CARMEN log files (`.clf`): a streaming reader and a writer.
//!
//! One message per line: `NAME fields… ipc_timestamp ipc_hostname logger_timestamp`.
//! The reader understands:
//!
//! - `FLASER n r_1 … r_n x y theta odom_x odom_y odom_theta ipc_timestamp host logger_timestamp`:
//!   a front laser scan. The bearings follow [`flaser_beam_geometry`]; the maximum range is
//!   [`ReaderOptions::flaser_max_range_m`]; the laser sits at `PARAM robot_frontlaser_offset`
//!   metres along the robot's x axis; the second pose triple is the robot's odometry pose
//!   (when it is the last `ODOM` message's and older than the scan by more than
//!   [`ReaderOptions::stale_odometry_s`], as after a gap in the log, it is interpolated at the
//!   scan's stamp from the `ODOM` messages around it; the scan waits for the next message).
//! - `ROBOTLASER1 laser_type start_angle fov resolution max_range accuracy remission_mode
//!   n r_1 … r_n m rem_1 … rem_m laser_x laser_y laser_theta robot_x robot_y robot_theta
//!   tv rv forward_safety_dist side_safety_dist turn_axis ipc_timestamp host logger_timestamp`:
//!   a scan with its own geometry; `robot_from_laser = robot_pose.between(laser_pose)`.
//! - `ODOM x y theta tv rv accel ipc_timestamp host logger_timestamp`: odometry.
//! - `PARAM name value …`: settings; only `robot_frontlaser_offset` changes how later lines
//!   are read.
//!
//! Comments (`#`) and blank lines are skipped; every other message type (`RLASER`,
//! `TRUEPOS`, `SYNC`, `NMEA-GGA`, …) is skipped and counted in [`CarmenStats`].
//!
//! Scans come out in file order, never sorted (Intel's time stamps go backwards 631 times).
//! The time stamp of a message is its `ipc_timestamp`, kept as written in
//! [`Stamp::text`](polymap::scan::Stamp).
//!
//! ```
//! use polymap_io::carmen::{CarmenReader, ReaderOptions};
//! let log = "PARAM robot_frontlaser_offset 0.1 nohost 0\n\
//!            FLASER 3 1.0 2.0 81.83 0 0 0 5 6 0.5 100.25 nohost 0.1\n";
//! let mut reader = CarmenReader::from_reader(log.as_bytes(), "inline.clf", ReaderOptions::default());
//! let scan = reader.next_scan().unwrap().unwrap();
//! assert_eq!(scan.ranges_m, vec![1.0, 2.0, 81.83]);
//! assert_eq!(scan.stamp.text, "100.25");
//! assert_eq!(scan.robot_from_laser.x_m, 0.1);
//! assert_eq!(scan.odom_from_robot.unwrap().y_m, 6.0);
//! assert!(reader.next_scan().unwrap().is_none());
//! assert_eq!(reader.stats().no_return_readings, 1);
//! ```

mod error;
mod fields;
mod geometry;
mod messages;
pub(crate) use messages::beyond_a_turn;
mod reader;
mod stats;
mod writer;

#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_malformed;
#[cfg(test)]
mod tests_oddities;

pub use error::{CarmenError, LineProblem};
pub use geometry::{FlaserGeometry, flaser_beam_geometry};
pub use messages::OdometryReading;
pub use reader::{CarmenReader, CarmenRecord, MAX_HELD_SCANS, ReaderOptions};
pub use stats::{CarmenStats, OTHER_TYPES, Oddity};
pub use writer::{CarmenWriter, write_flaser_log};
