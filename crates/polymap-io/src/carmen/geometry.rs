//! Beam bearings of `FLASER` messages, which carry no field of view of their own.

use std::f64::consts::{FRAC_PI_2, PI};

/// Bearings of a `FLASER` scan in the laser frame (x forward, y left): beam `i` points at
/// `angle_min_rad + i · angle_increment_rad`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlaserGeometry {
    /// Bearing of the first beam (the robot's right), radians.
    pub angle_min_rad: f64,
    /// Bearing step between consecutive beams, radians, counter-clockwise.
    pub angle_increment_rad: f64,
}

/// The CARMEN convention for the bearings of an `n`-beam `FLASER` scan.
///
/// The first beam always points exactly at −90° (the robot's right), and beams step
/// counter-clockwise:
///
/// | n | step | last beam |
/// | --- | --- | --- |
/// | 180 | 1° | +89° (the +90° beam is not in the message) |
/// | 181 | 1° | +90° |
/// | 360 | 0.5° | +89.5° (the +90° beam is not in the message) |
/// | 361 | 0.5° | +90° |
/// | other n ≥ 2 | 180° / (n − 1) | +90° |
/// | 0 or 1 | 0 | −90° |
///
/// Source: CARMEN's own log reader, `src/logger/readlog.c`
/// (`carmen_string_to_robot_laser_message_orig`), sets `start_angle = -M_PI / 2.0` for every
/// `FLASER` and takes the step from `carmen_laser_guess_angle_increment`: `M_PI / 180.0` for
/// 180 or 181 beams, `M_PI / 360.0` for 360 or 361, otherwise `fov / (n - 1)` with a 180° fov;
/// `carmen_laser_guess_fov` says 179° for 180 beams and 179.5° for 360, "last beam ignored".
/// GMapping's `gfs` tools agree (`theta = -M_PI/2`, step `M_PI/180` or `M_PI/360` for 180/181 or
/// 360/361 beams). CARMEN's 0.25° guess for 400/401 beams is not reproduced (no such logs here).
///
/// ```
/// use polymap_io::carmen::flaser_beam_geometry;
/// let g = flaser_beam_geometry(180);
/// assert_eq!(g.angle_min_rad, -std::f64::consts::FRAC_PI_2);
/// assert_eq!(g.angle_increment_rad.to_degrees().round(), 1.0);
/// let last_deg = (g.angle_min_rad + 179.0 * g.angle_increment_rad).to_degrees();
/// assert!((last_deg - 89.0).abs() < 1e-9);
/// ```
pub fn flaser_beam_geometry(n: usize) -> FlaserGeometry {
    let angle_increment_rad = match n {
        180 | 181 => PI / 180.0,
        360 | 361 => PI / 360.0,
        0 | 1 => 0.0,
        _ => PI / (n - 1) as f64,
    };
    FlaserGeometry {
        angle_min_rad: -FRAC_PI_2,
        angle_increment_rad,
    }
}
