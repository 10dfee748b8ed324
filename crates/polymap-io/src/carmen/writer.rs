//! Writing scans (and odometry) as a CARMEN log that [`CarmenReader`](super::CarmenReader)
//! and other CARMEN tools read back.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use polymap::geometry::Pose2;
use polymap::scan::{RangeScan, Stamp};

use super::error::CarmenError;
use super::geometry::flaser_beam_geometry;

/// Host name written in the `ipc_hostname` field.
const HOST: &str = "polymap";
/// Bearings closer than this count as equal when deciding whether `FLASER` can hold a scan, rad.
const BEARING_TOLERANCE_RAD: f64 = 1e-12;

/// Writes a CARMEN log: a header comment, then `PARAM`, `FLASER`/`ROBOTLASER1` and `ODOM` lines.
///
/// A scan is written as `FLASER` when `FLASER` can hold it exactly: its bearings follow
/// [`flaser_beam_geometry`](super::flaser_beam_geometry) and its laser sits on the robot's x
/// axis, facing forward. The mounting and the maximum range then go into
/// `PARAM robot_frontlaser_offset` and `PARAM robot_front_laser_max` lines, written whenever they
/// change. Any other scan is written as `ROBOTLASER1`, which carries its own geometry.
///
/// Poses: the robot pose triple is `odom_from_robot` and the laser triple is
/// `odom_from_robot ∘ robot_from_laser` (6 decimals); a scan without odometry gets the identity
/// as robot pose. Ranges: 3 decimals (a valid reading that would round up to the maximum range,
/// or a `float32` value that 3 decimals do not hold, is written in full). Stamps: [`Stamp::text`] unchanged. A scan with a non-finite pose,
/// bearing or maximum range, or whose stamp text is not one number, is refused with
/// [`CarmenError::Unwritable`], since it would not read back.
///
/// ```
/// use polymap::scan::{RangeScan, Stamp};
/// use polymap::geometry::Pose2;
/// use polymap_io::carmen::{CarmenReader, CarmenWriter, ReaderOptions};
/// let scan = RangeScan {
///     stamp: Stamp { seconds: 12.5, text: "12.500000".into() },
///     ranges_m: vec![1.0, 2.25, 3.5],
///     angle_min_rad: -std::f64::consts::FRAC_PI_2,
///     angle_increment_rad: std::f64::consts::FRAC_PI_2,
///     max_range_m: 30.0,
///     robot_from_laser: Pose2::new(0.1, 0.0, 0.0),
///     odom_from_robot: Some(Pose2::new(1.0, 2.0, 0.5)),
/// };
/// let mut writer = CarmenWriter::new(Vec::new(), "sim.clf").unwrap();
/// writer.write_scan(&scan).unwrap();
/// let bytes = writer.finish().unwrap();
/// let mut reader = CarmenReader::from_reader(&bytes[..], "sim.clf", ReaderOptions::default());
/// let back = reader.next_scan().unwrap().unwrap();
/// assert_eq!(back.ranges_m, scan.ranges_m);
/// assert_eq!(back.stamp, scan.stamp);
/// assert_eq!(back.max_range_m, 30.0);
/// assert_eq!(back.robot_from_laser, scan.robot_from_laser);
/// ```
#[derive(Debug)]
pub struct CarmenWriter<W: Write> {
    out: W,
    path: PathBuf,
    frontlaser_offset_m: Option<f64>,
    front_laser_max_m: Option<f64>,
}

impl CarmenWriter<BufWriter<File>> {
    /// Creates (or truncates) a log file and writes its header.
    pub fn create(path: impl AsRef<Path>) -> Result<Self, CarmenError> {
        let path = path.as_ref();
        let file = File::create(path).map_err(|source| CarmenError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::new(BufWriter::new(file), path)
    }
}

impl<W: Write> CarmenWriter<W> {
    /// Writes the header to `out`; `path` names the output in error messages.
    pub fn new(out: W, path: impl Into<PathBuf>) -> Result<Self, CarmenError> {
        let mut writer = CarmenWriter {
            out,
            path: path.into(),
            frontlaser_offset_m: None,
            front_laser_max_m: None,
        };
        writer.emit(format_args!(
            "# CARMEN log written by polymap-io\n\
             # message_name [message contents] ipc_timestamp ipc_hostname logger_timestamp\n\
             # message formats defined: PARAM FLASER ROBOTLASER1 ODOM\n"
        ))?;
        Ok(writer)
    }

    /// Writes one scan (see the type's documentation for the line it becomes).
    pub fn write_scan(&mut self, scan: &RangeScan) -> Result<(), CarmenError> {
        check_stamp(&scan.stamp, &self.path)?;
        check_poses(scan, &self.path)?;
        if flaser_can_hold(scan) {
            self.write_params(scan)?;
            self.write_flaser(scan)
        } else {
            self.write_robotlaser(scan)
        }
    }

    /// Writes an `ODOM` line with the robot's odometry pose and zero velocities.
    pub fn write_odometry(
        &mut self,
        stamp: &Stamp,
        odom_from_robot: &Pose2,
    ) -> Result<(), CarmenError> {
        check_stamp(stamp, &self.path)?;
        if !odom_from_robot.is_finite() {
            return Err(unwritable(&self.path, "odometry pose is not finite".into()));
        }
        let p = odom_from_robot;
        let text = &stamp.text;
        self.emit(format_args!(
            "ODOM {:.6} {:.6} {:.6} 0.000000 0.000000 0.000000 {text} {HOST} 0.000000\n",
            p.x_m, p.y_m, p.theta_rad
        ))
    }

    /// Flushes and returns the output.
    pub fn finish(mut self) -> Result<W, CarmenError> {
        self.out.flush().map_err(|source| self.io_error(source))?;
        Ok(self.out)
    }

    fn write_params(&mut self, scan: &RangeScan) -> Result<(), CarmenError> {
        let offset_m = scan.robot_from_laser.x_m;
        if self.frontlaser_offset_m != Some(offset_m) {
            self.emit(format_args!(
                "PARAM robot_frontlaser_offset {offset_m} {HOST} 0\n"
            ))?;
            self.frontlaser_offset_m = Some(offset_m);
        }
        let max_m = scan.max_range_m;
        if self.front_laser_max_m != Some(max_m) {
            self.emit(format_args!(
                "PARAM robot_front_laser_max {max_m} {HOST} 0\n"
            ))?;
            self.front_laser_max_m = Some(max_m);
        }
        Ok(())
    }

    fn write_flaser(&mut self, scan: &RangeScan) -> Result<(), CarmenError> {
        let mut line = format!("FLASER {}", scan.ranges_m.len());
        push_ranges(&mut line, scan);
        push_poses(&mut line, scan);
        push_trailer(&mut line, &scan.stamp);
        self.emit_str(&line)
    }

    fn write_robotlaser(&mut self, scan: &RangeScan) -> Result<(), CarmenError> {
        let n = scan.ranges_m.len();
        let fov_rad = scan.angle_increment_rad * n.saturating_sub(1) as f64;
        let mut line = format!(
            "ROBOTLASER1 0 {} {} {} {} 0.01 0 {n}",
            scan.angle_min_rad, fov_rad, scan.angle_increment_rad, scan.max_range_m
        );
        push_ranges(&mut line, scan);
        line.push_str(" 0");
        push_poses(&mut line, scan);
        line.push_str(" 0 0 0 0 0");
        push_trailer(&mut line, &scan.stamp);
        self.emit_str(&line)
    }

    fn emit(&mut self, args: std::fmt::Arguments<'_>) -> Result<(), CarmenError> {
        self.out
            .write_fmt(args)
            .map_err(|source| self.io_error(source))
    }

    fn emit_str(&mut self, text: &str) -> Result<(), CarmenError> {
        self.out
            .write_all(text.as_bytes())
            .map_err(|source| self.io_error(source))
    }

    fn io_error(&self, source: std::io::Error) -> CarmenError {
        CarmenError::Io {
            path: self.path.clone(),
            source,
        }
    }
}

/// Writes `scans` as a CARMEN log file (see [`CarmenWriter`]).
/// The file is written atomically (see [`crate::atomic`]).
pub fn write_flaser_log(path: impl AsRef<Path>, scans: &[RangeScan]) -> Result<(), CarmenError> {
    let path = path.as_ref();
    crate::atomic::write_atomic_with(
        path,
        |out| {
            let mut writer = CarmenWriter::new(out, path)?;
            for scan in scans {
                writer.write_scan(scan)?;
            }
            writer.finish().map(drop)
        },
        |source| CarmenError::Io {
            path: path.to_path_buf(),
            source,
        },
    )
}

/// True when a `FLASER` line (plus `PARAM`s) describes `scan` exactly.
fn flaser_can_hold(scan: &RangeScan) -> bool {
    let g = flaser_beam_geometry(scan.ranges_m.len());
    let mount = scan.robot_from_laser;
    (scan.angle_min_rad - g.angle_min_rad).abs() <= BEARING_TOLERANCE_RAD
        && (scan.angle_increment_rad - g.angle_increment_rad).abs() <= BEARING_TOLERANCE_RAD
        && mount.y_m == 0.0
        && mount.theta_rad == 0.0
        && mount.x_m.is_finite()
        && scan.max_range_m.is_finite()
        && scan.max_range_m > 0.0
}

/// Appends ` r_1 … r_n`: 3 decimals, unless rounding would turn a return into a no-return, or
/// the reading is a `float32` value (as a ROS laser gives it) that 3 decimals do not hold: then
/// the shortest text that reads back exactly.
fn push_ranges(line: &mut String, scan: &RangeScan) {
    use std::fmt::Write as _;
    for &r in &scan.ranges_m {
        let rounded = (r * 1000.0).round() / 1000.0;
        let float32 = r.is_finite() && f64::from(r as f32) == r && rounded != r;
        // Writing to a String cannot fail.
        let _ = if float32 || (scan.is_valid_range(r) && !scan.is_valid_range(rounded)) {
            write!(line, " {r}")
        } else {
            write!(line, " {r:.3}")
        };
    }
}

/// Appends the laser and robot pose triples.
fn push_poses(line: &mut String, scan: &RangeScan) {
    use std::fmt::Write as _;
    let odom_from_robot = scan.odom_from_robot.unwrap_or(Pose2::IDENTITY);
    let odom_from_laser = odom_from_robot.compose(&scan.robot_from_laser);
    for p in [odom_from_laser, odom_from_robot] {
        let _ = write!(line, " {:.6} {:.6} {:.6}", p.x_m, p.y_m, p.theta_rad);
    }
}

/// Appends ` ipc_timestamp host logger_timestamp` and the newline.
fn push_trailer(line: &mut String, stamp: &Stamp) {
    line.push(' ');
    line.push_str(&stamp.text);
    line.push_str(" polymap 0.000000\n");
}

/// A stamp's text must be one token that reads back as a finite number.
fn check_stamp(stamp: &Stamp, path: &Path) -> Result<(), CarmenError> {
    let ok = !stamp.text.is_empty()
        && !stamp.text.contains(|c: char| c.is_whitespace())
        && fast_float2::parse::<f64, _>(&stamp.text).is_ok_and(f64::is_finite);
    if ok {
        return Ok(());
    }
    Err(unwritable(
        path,
        format!(
            "time stamp text {:?} is not a single finite number",
            stamp.text
        ),
    ))
}

/// Poses and bearings must be finite to read back.
fn check_poses(scan: &RangeScan, path: &Path) -> Result<(), CarmenError> {
    let odom_ok = scan.odom_from_robot.is_none_or(|p| p.is_finite());
    let ok = odom_ok
        && scan.robot_from_laser.is_finite()
        && scan.angle_min_rad.is_finite()
        && scan.angle_increment_rad.is_finite()
        && scan.max_range_m.is_finite();
    if ok {
        return Ok(());
    }
    Err(unwritable(
        path,
        format!(
            "scan {} has a non-finite pose, bearing or max range",
            scan.stamp.text
        ),
    ))
}

fn unwritable(path: &Path, reason: String) -> CarmenError {
    CarmenError::Unwritable {
        path: path.to_path_buf(),
        reason,
    }
}
