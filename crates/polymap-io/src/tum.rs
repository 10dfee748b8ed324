//! Trajectories in the TUM format: one pose per line, `timestamp x y z qx qy qz qw`.
//!
//! Planar poses are written with `z = 0`, `qx = qy = 0`, `qz = sin(θ/2)`, `qw = cos(θ/2)`; the
//! time stamp is [`Stamp::text`] unchanged, so no precision is lost (tools such as `evo` read
//! the file). Positions and quaternions get 9 decimals.
//!
//! ```
//! use polymap::geometry::Pose2;
//! use polymap::scan::Stamp;
//! use polymap_io::tum::{StampedPose, read_tum_from, write_tum_to};
//! let poses = vec![StampedPose {
//!     stamp: Stamp { seconds: 976052857.337284, text: "976052857.337284".into() },
//!     map_from_robot: Pose2::new(1.0, -2.0, 3.0),
//! }];
//! let mut bytes = Vec::new();
//! write_tum_to(&mut bytes, "t.tum", &poses).unwrap();
//! let text = String::from_utf8(bytes.clone()).unwrap();
//! assert!(text.starts_with("976052857.337284 1.000000000 -2.000000000 0 0 0 "));
//! let back = read_tum_from(&bytes[..], "t.tum").unwrap();
//! assert_eq!(back[0].stamp.text, "976052857.337284");
//! assert!((back[0].map_from_robot.theta_rad - 3.0).abs() < 1e-9);
//! ```

use std::io::{BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};

use polymap::geometry::Pose2;
use polymap::scan::Stamp;

/// Longest line the reader accepts, bytes.
const MAX_LINE_BYTES: usize = 1 << 16;

/// One pose of a trajectory with its time stamp.
#[derive(Debug, Clone, PartialEq)]
pub struct StampedPose {
    /// When the robot was there (for `polymap map`: the scan's own stamp from the log).
    pub stamp: Stamp,
    /// The robot's pose in the trajectory's frame (the map frame), metres and radians.
    pub map_from_robot: Pose2,
}

/// An error reading or writing a TUM trajectory, naming the file and, if any, the 1-based line.
#[derive(Debug, thiserror::Error)]
pub enum TumError {
    /// The file could not be opened, read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A line is not `timestamp x y z qx qy qz qw`.
    #[error("{}:{line}: {problem}", path.display())]
    Malformed {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: u64,
        /// What is wrong.
        problem: String,
    },
    /// A pose cannot be written so that it reads back (non-finite, or a stamp that is not one
    /// number).
    #[error("{}: cannot write pose {index}: {problem}", path.display())]
    Unwritable {
        /// The file.
        path: PathBuf,
        /// 0-based index of the pose.
        index: usize,
        /// What is wrong.
        problem: String,
    },
}

/// Writes a trajectory file atomically (see [`crate::atomic`]).
pub fn write_tum(path: impl AsRef<Path>, poses: &[StampedPose]) -> Result<(), TumError> {
    let path = path.as_ref();
    crate::atomic::write_atomic_with(
        path,
        |out| write_tum_to(out, path, poses),
        |source| TumError::Io {
            path: path.to_path_buf(),
            source,
        },
    )
}

/// Writes a trajectory to `out`; `path` names it in errors.
pub fn write_tum_to(
    mut out: impl Write,
    path: impl AsRef<Path>,
    poses: &[StampedPose],
) -> Result<(), TumError> {
    let path = path.as_ref();
    for (index, pose) in poses.iter().enumerate() {
        check_writable(pose).map_err(|problem| TumError::Unwritable {
            path: path.to_path_buf(),
            index,
            problem,
        })?;
        out.write_all(format_line(pose).as_bytes())
            .map_err(|source| TumError::Io {
                path: path.to_path_buf(),
                source,
            })?;
    }
    Ok(())
}

/// One TUM line for `pose`, newline included.
fn format_line(pose: &StampedPose) -> String {
    let p = &pose.map_from_robot;
    let (qz, qw) = (p.theta_rad * 0.5).sin_cos();
    format!(
        "{} {:.9} {:.9} 0 0 0 {qz:.9} {qw:.9}\n",
        pose.stamp.text, p.x_m, p.y_m
    )
}

fn check_writable(pose: &StampedPose) -> Result<(), String> {
    let text = &pose.stamp.text;
    if text.is_empty() || text.contains(char::is_whitespace) || parse_finite(text).is_none() {
        return Err(format!(
            "time stamp text {text:?} is not a single finite number"
        ));
    }
    if !pose.map_from_robot.is_finite() {
        return Err("the pose is not finite".into());
    }
    Ok(())
}

/// Reads a trajectory file; `#` comments and blank lines are skipped.
pub fn read_tum(path: impl AsRef<Path>) -> Result<Vec<StampedPose>, TumError> {
    let path = path.as_ref();
    let file = crate::input_file::open_regular(path).map_err(|source| TumError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    read_tum_from(BufReader::new(file), path)
}

/// Reads a trajectory from `input`; `path` names it in errors.
pub fn read_tum_from(
    mut input: impl BufRead,
    path: impl AsRef<Path>,
) -> Result<Vec<StampedPose>, TumError> {
    let path = path.as_ref();
    let mut poses = Vec::new();
    let mut buf = Vec::new();
    let mut line_number = 0u64;
    loop {
        buf.clear();
        let read = (&mut input)
            .take(MAX_LINE_BYTES as u64 + 1)
            .read_until(b'\n', &mut buf)
            .map_err(|source| TumError::Io {
                path: path.to_path_buf(),
                source,
            })?;
        if read == 0 {
            return Ok(poses);
        }
        line_number += 1;
        let malformed = |problem| TumError::Malformed {
            path: path.to_path_buf(),
            line: line_number,
            problem,
        };
        if buf.len() > MAX_LINE_BYTES && buf.last() != Some(&b'\n') {
            return Err(malformed(format!(
                "the line is longer than {MAX_LINE_BYTES} bytes"
            )));
        }
        let line = std::str::from_utf8(&buf).map_err(|_| malformed("not valid UTF-8".into()))?;
        if let Some(pose) = parse_line(line).map_err(malformed)? {
            poses.push(pose);
        }
    }
}

/// Parses one line; `Ok(None)` for comments and blank lines.
fn parse_line(line: &str) -> Result<Option<StampedPose>, String> {
    let line = line.trim();
    if line.is_empty() || line.starts_with('#') {
        return Ok(None);
    }
    let tokens: Vec<&str> = line.split_ascii_whitespace().take(9).collect();
    if tokens.len() != 8 {
        return Err(format!(
            "expected 8 fields `timestamp x y z qx qy qz qw`, found {}",
            tokens.len()
        ));
    }
    let mut values = [0.0; 8];
    for (i, (value, token)) in values.iter_mut().zip(&tokens).enumerate() {
        *value = parse_finite(token)
            .ok_or_else(|| format!("field {} is not a finite number: `{token}`", i + 1))?;
    }
    let [seconds, x_m, y_m, _z, qx, qy, qz, qw] = values;
    let theta_rad = yaw_from_quaternion(qx, qy, qz, qw).ok_or("the quaternion is zero")?;
    let stamp = Stamp {
        seconds,
        text: tokens[0].to_owned(),
    };
    Ok(Some(StampedPose {
        stamp,
        map_from_robot: Pose2::new(x_m, y_m, theta_rad),
    }))
}

/// Yaw (rotation about z), radians, of the quaternion `(qx, qy, qz, qw)`, which need not be
/// normalised; `None` for the zero quaternion.
///
/// Uses the full formula `atan2(2(qw·qz + qx·qy), qw² + qx² − qy² − qz²)`, which stays correct
/// for unnormalised quaternions and for rotations with a small roll or pitch.
///
/// ```
/// use polymap_io::tum::yaw_from_quaternion;
/// let h = (0.5f64).sqrt();
/// assert!((yaw_from_quaternion(0.0, 0.0, h, h).unwrap() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
/// assert!((yaw_from_quaternion(0.0, 0.0, 2.0, 0.0).unwrap().abs() - std::f64::consts::PI).abs() < 1e-12);
/// assert_eq!(yaw_from_quaternion(0.0, 0.0, 0.0, 0.0), None);
/// ```
pub fn yaw_from_quaternion(qx: f64, qy: f64, qz: f64, qw: f64) -> Option<f64> {
    let norm_2 = qx * qx + qy * qy + qz * qz + qw * qw;
    if norm_2.is_nan() || norm_2 <= 0.0 || norm_2.is_infinite() {
        return None;
    }
    let sin_term = 2.0 * (qw * qz + qx * qy);
    let cos_term = qw * qw + qx * qx - qy * qy - qz * qz;
    Some(sin_term.atan2(cos_term))
}

fn parse_finite(token: &str) -> Option<f64> {
    fast_float2::parse::<f64, _>(token)
        .ok()
        .filter(|v: &f64| v.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(text: &str, x: f64, y: f64, theta: f64) -> StampedPose {
        let seconds = text.parse().unwrap_or(0.0);
        StampedPose {
            stamp: Stamp {
                seconds,
                text: text.into(),
            },
            map_from_robot: Pose2::new(x, y, theta),
        }
    }

    fn round_trip(poses: &[StampedPose]) -> Vec<StampedPose> {
        let mut bytes = Vec::new();
        write_tum_to(&mut bytes, "t.tum", poses).unwrap();
        read_tum_from(&bytes[..], "t.tum").unwrap()
    }

    #[test]
    fn round_trip_keeps_stamps_and_poses() {
        let poses: Vec<_> = (0..50)
            .map(|i| {
                let a = -3.1 + i as f64 * 0.125;
                pose(
                    &format!("{}.{:06}", 976052857 + i, i * 7919 % 1_000_000),
                    i as f64 * 0.3,
                    -a,
                    a,
                )
            })
            .collect();
        let back = round_trip(&poses);
        assert_eq!(back.len(), poses.len());
        for (a, b) in poses.iter().zip(&back) {
            assert_eq!(a.stamp, b.stamp);
            assert!(
                (a.map_from_robot.translation() - b.map_from_robot.translation()).length() < 1e-9
            );
            assert!((a.map_from_robot.theta_rad - b.map_from_robot.theta_rad).abs() < 1e-8);
        }
    }

    #[test]
    fn yaw_near_pi_survives() {
        let back = round_trip(&[pose("1.0", 0.0, 0.0, std::f64::consts::PI - 1e-9)]);
        let err = polymap::geometry::normalize_angle_rad(
            back[0].map_from_robot.theta_rad - std::f64::consts::PI,
        );
        assert!(err.abs() < 1e-8);
    }

    #[test]
    fn comments_and_blank_lines_are_skipped() {
        let text = "# timestamp x y z qx qy qz qw\n\n1.5 1 2 0 0 0 0 1\r\n";
        let poses = read_tum_from(text.as_bytes(), "t.tum").unwrap();
        assert_eq!(poses.len(), 1);
        assert_eq!(poses[0].stamp.text, "1.5");
        assert_eq!(poses[0].map_from_robot, Pose2::new(1.0, 2.0, 0.0));
    }

    #[test]
    fn malformed_lines_name_the_line() {
        for (text, line) in [
            ("1 2 3 0 0 0 0 1\n1 2 3\n", 2),
            ("# c\n1 2 x 0 0 0 0 1\n", 2),
            ("1 2 3 0 0 0 0 0\n", 1),
            ("1 2 3 0 0 0 0 1 9\n", 1),
            ("1 nan 3 0 0 0 0 1\n", 1),
        ] {
            match read_tum_from(text.as_bytes(), "bad.tum") {
                Err(TumError::Malformed { line: l, path, .. }) => {
                    assert_eq!(l, line, "{text:?}");
                    assert_eq!(path, Path::new("bad.tum"));
                }
                other => panic!("{text:?}: {other:?}"),
            }
        }
        assert!(read_tum_from(&b"1 2 3 0 0 0 0 \xff\n"[..], "b.tum").is_err());
    }

    #[test]
    fn unwritable_poses_are_errors() {
        let mut out = Vec::new();
        let bad_stamp = pose("1 2", 0.0, 0.0, 0.0);
        assert!(matches!(
            write_tum_to(&mut out, "t", &[bad_stamp]),
            Err(TumError::Unwritable { index: 0, .. })
        ));
        let mut nan = pose("1", 0.0, 0.0, 0.0);
        nan.map_from_robot.x_m = f64::NAN;
        assert!(write_tum_to(&mut out, "t", &[nan]).is_err());
    }

    #[test]
    fn files_round_trip() {
        let dir = std::env::temp_dir().join(format!("polymap-io-tum-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("t.tum");
        write_tum(&path, &[pose("2.000001", 1.0, 2.0, 0.5)]).unwrap();
        let back = read_tum(&path).unwrap();
        assert_eq!(back[0].stamp.text, "2.000001");
        std::fs::remove_dir_all(&dir).unwrap();
        assert!(matches!(read_tum(&path), Err(TumError::Io { .. })));
    }
}
