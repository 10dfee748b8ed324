//! Parsers of the individual message types, one function per type.
//!
//! Each takes the line after the message name and the number of tokens found there, and checks
//! the token count implied by the message's own counts before allocating anything.

use polymap::geometry::Pose2;
use polymap::scan::{RangeScan, Stamp};

use super::error::LineProblem;
use super::fields::Fields;
use super::geometry::flaser_beam_geometry;

/// One `ODOM` message: the robot's odometry pose and velocities.
#[derive(Debug, Clone, PartialEq)]
pub struct OdometryReading {
    /// The message's `ipc_timestamp`, as written.
    pub stamp: Stamp,
    /// The robot's pose in the odometry frame.
    pub odom_from_robot: Pose2,
    /// Translational velocity, m/s.
    pub velocity_m_per_s: f64,
    /// Rotational velocity, rad/s.
    pub angular_velocity_rad_per_s: f64,
    /// Acceleration, m/s².
    pub acceleration_m_per_s2: f64,
}

/// Settings that shape how a `FLASER` line becomes a [`RangeScan`].
#[derive(Debug, Clone, Copy)]
pub(crate) struct FlaserContext {
    pub(crate) max_beams: usize,
    pub(crate) max_range_m: f64,
    pub(crate) robot_from_laser: Pose2,
}

/// Tokens after the name of a `FLASER` besides the readings: n, two poses, trailer.
const FLASER_FIXED: usize = 1 + 6 + 3;
/// Tokens after the name of a `ROBOTLASER1` besides readings and remissions.
const ROBOTLASER_FIXED: usize = 7 + 1 + 1 + 6 + 5 + 3;
/// Tokens after the name of an `ODOM`.
const ODOM_TOKENS: usize = 6 + 3;

/// Token-count error; counts include the message name.
fn token_count_error(message: &'static str, expected: usize, found: usize) -> LineProblem {
    LineProblem::TokenCount {
        message,
        expected: expected + 1,
        found: found + 1,
    }
}

/// Parses `FLASER n r_1 … r_n laser_pose odom_pose trailer`.
pub(crate) fn parse_flaser(
    rest: &str,
    found: usize,
    ctx: &FlaserContext,
) -> Result<RangeScan, LineProblem> {
    const M: &str = "FLASER";
    let mut f = Fields::new(rest, M);
    let n = f.count("num_readings", ctx.max_beams)?;
    if found != FLASER_FIXED + n {
        return Err(token_count_error(M, FLASER_FIXED + n, found));
    }
    let mut ranges_m = Vec::with_capacity(n);
    f.floats_into(n, "range_reading", &mut ranges_m)?;
    f.pose("laser_pose")?;
    let odom_from_robot = f.pose("odometry_pose")?;
    let stamp = f.trailer()?;
    let g = flaser_beam_geometry(n);
    Ok(RangeScan {
        stamp,
        ranges_m,
        angle_min_rad: g.angle_min_rad,
        angle_increment_rad: g.angle_increment_rad,
        max_range_m: ctx.max_range_m,
        robot_from_laser: ctx.robot_from_laser,
        odom_from_robot: Some(odom_from_robot),
    })
}

/// The laser configuration fields at the start of a `ROBOTLASER1`.
struct LaserConfig {
    start_angle_rad: f64,
    angular_resolution_rad: f64,
    field_of_view_rad: f64,
    maximum_range_m: f64,
}

fn parse_laser_config(f: &mut Fields<'_>) -> Result<LaserConfig, LineProblem> {
    f.integer("laser_type")?;
    let start_angle_rad = f.finite("start_angle")?;
    let field_of_view_rad = f.finite("field_of_view")?;
    let angular_resolution_rad = f.finite("angular_resolution")?;
    let maximum_range_m = f.finite("maximum_range")?;
    f.finite("accuracy")?;
    f.integer("remission_mode")?;
    Ok(LaserConfig {
        start_angle_rad,
        angular_resolution_rad,
        field_of_view_rad,
        maximum_range_m,
    })
}

/// Smallest angular resolution accepted, radians (0.0006°; real lasers step 0.06° or more).
pub(crate) const MIN_RESOLUTION_RAD: f64 = 1e-5;

/// Why `beams` beams `step_rad` apart cannot be a laser's: they span more than a full turn;
/// `None` when they do not. The one rule of every reader (CARMEN `ROBOTLASER1`, ROS
/// `LaserScan`, whose step may be negative).
pub(crate) fn beyond_a_turn(step_rad: f64, beams: usize) -> Option<String> {
    let span = step_rad.abs() * beams.saturating_sub(1) as f64;
    (span > std::f64::consts::TAU * 1.001).then(|| {
        format!("{beams} beams at {step_rad} rad span {span:.3} rad, more than a full turn")
    })
}

/// Refuses a resolution that cannot be a laser's: not above [`MIN_RESOLUTION_RAD`], or beams
/// spanning more than a full turn.
fn check_resolution(config: &LaserConfig, beams: usize) -> Result<(), LineProblem> {
    let res = config.angular_resolution_rad;
    let reason = if res < MIN_RESOLUTION_RAD {
        format!("{res} rad is not a laser's angular resolution (at least {MIN_RESOLUTION_RAD} rad)")
    } else if let Some(reason) = beyond_a_turn(res, beams) {
        reason
    } else {
        return Ok(());
    };
    Err(LineProblem::BadGeometry {
        message: "ROBOTLASER1",
        field: "angular_resolution",
        reason,
    })
}

/// True when the field of view matches neither `(n − 1)` nor `n` beam steps (within one step
/// or 1 %): the log contradicts itself, and the beams follow the resolution.
fn fov_mismatch(config: &LaserConfig, beams: usize) -> bool {
    let (res, fov) = (config.angular_resolution_rad, config.field_of_view_rad);
    let tolerance = res.max(0.01 * fov.abs());
    let n = beams as f64;
    beams > 1
        && [(n - 1.0) * res, n * res]
            .iter()
            .all(|span| (span - fov).abs() > tolerance)
}

/// Parses a `ROBOTLASER1` line, which carries its own geometry and both poses.
///
/// Returns the scan and whether its field of view contradicts its beam count and resolution.
pub(crate) fn parse_robotlaser(
    rest: &str,
    found: usize,
    max_beams: usize,
) -> Result<(RangeScan, bool), LineProblem> {
    const M: &str = "ROBOTLASER1";
    let mut f = Fields::new(rest, M);
    let config = parse_laser_config(&mut f)?;
    let n = f.count("num_readings", max_beams)?;
    check_resolution(&config, n)?;
    // The readings and the remission count must fit before anything is allocated.
    if found < ROBOTLASER_FIXED + n {
        return Err(token_count_error(M, ROBOTLASER_FIXED + n, found));
    }
    let mut ranges_m = Vec::with_capacity(n);
    f.floats_into(n, "range_reading", &mut ranges_m)?;
    let m = f.count("num_remissions", max_beams)?;
    if found != ROBOTLASER_FIXED + n + m {
        return Err(token_count_error(M, ROBOTLASER_FIXED + n + m, found));
    }
    for _ in 0..m {
        f.float("remission")?;
    }
    let odom_from_laser = f.pose("laser_pose")?;
    let odom_from_robot = f.pose("robot_pose")?;
    for field in [
        "laser_tv",
        "laser_rv",
        "forward_safety_dist",
        "side_safety_dist",
        "turn_axis",
    ] {
        f.finite(field)?;
    }
    let stamp = f.trailer()?;
    let scan = RangeScan {
        stamp,
        ranges_m,
        angle_min_rad: config.start_angle_rad,
        angle_increment_rad: config.angular_resolution_rad,
        max_range_m: config.maximum_range_m,
        // Equal poses mean the identity mount exactly (`between` would leave rounding residue).
        robot_from_laser: if odom_from_laser == odom_from_robot {
            Pose2::IDENTITY
        } else {
            odom_from_robot.between(&odom_from_laser)
        },
        odom_from_robot: Some(odom_from_robot),
    };
    Ok((scan, fov_mismatch(&config, n)))
}

/// Parses `ODOM x y theta tv rv accel trailer`.
pub(crate) fn parse_odom(rest: &str, found: usize) -> Result<OdometryReading, LineProblem> {
    const M: &str = "ODOM";
    if found != ODOM_TOKENS {
        return Err(token_count_error(M, ODOM_TOKENS, found));
    }
    let mut f = Fields::new(rest, M);
    let odom_from_robot = f.pose("pose")?;
    let velocity_m_per_s = f.finite("tv")?;
    let angular_velocity_rad_per_s = f.finite("rv")?;
    let acceleration_m_per_s2 = f.finite("accel")?;
    let stamp = f.trailer()?;
    Ok(OdometryReading {
        stamp,
        odom_from_robot,
        velocity_m_per_s,
        angular_velocity_rad_per_s,
        acceleration_m_per_s2,
    })
}

/// What a `PARAM` line means for the reader.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum ParamEffect {
    /// `robot_frontlaser_offset`: the front laser sits this far along the robot's x axis, metres.
    FrontLaserOffset(f64),
    /// `robot_front_laser_max`: the front laser's maximum range, metres (positive).
    FrontLaserMaxRange(f64),
    /// Any other parameter: counted only.
    Other,
}

/// Parses `PARAM name value …`. Values of other parameters may be any text (even several words).
pub(crate) fn parse_param(rest: &str) -> Result<ParamEffect, LineProblem> {
    const M: &str = "PARAM";
    let mut f = Fields::new(rest, M);
    let name = f.token("param_name")?;
    match name {
        "robot_frontlaser_offset" => Ok(ParamEffect::FrontLaserOffset(f.finite("param_value")?)),
        "robot_front_laser_max" => match f.finite("param_value")? {
            v if v > 0.0 => Ok(ParamEffect::FrontLaserMaxRange(v)),
            v => Err(LineProblem::BadNumber {
                message: M,
                field: "param_value",
                token: format!("{v} (must be positive)"),
            }),
        },
        _ => {
            f.token("param_value")?;
            Ok(ParamEffect::Other)
        }
    }
}
