//! Simulation parameters: one tree (`rate`, `path`, `laser`, `odometry`), with checks.

use std::f64::consts::TAU;
use std::fmt;

use serde::{Deserialize, Serialize};

use crate::{laser::LaserParams, odometry::OdometryParams, path::PathParams};

/// Everything [`crate::simulate`] needs besides the world and the seed.
///
/// ```
/// use polymap_sim::SimParams;
/// let p = SimParams::default();
/// assert_eq!(p.rate_hz, 10.0);
/// assert_eq!(p.start_time_s, 1_000_000_000.0);
/// assert!(p.validate().is_ok());
/// let bad = SimParams { rate_hz: -1.0, ..SimParams::default() };
/// assert_eq!(bad.validate().unwrap_err().field, "rate_hz");
/// assert_eq!(bad.sanitized().rate_hz, 10.0);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SimParams {
    /// Scans per second, Hz. Default 10 (a CARMEN-era SICK at typical logging rates).
    pub rate_hz: f64,
    /// Time stamp of the first scan, seconds. Default 1 000 000 000 (2001-09-09, a plausible
    /// Unix time that needs all ten digits and the six decimals of the stamps).
    pub start_time_s: f64,
    /// Keep only the first this many scans; `None` (default) keeps the whole tour.
    pub max_scans: Option<usize>,
    /// A truth wall counts as seen when at least this many returned beams hit it. Default 3.
    pub min_hits_seen: u32,
    /// How the robot drives.
    pub path: PathParams,
    /// The laser.
    pub laser: LaserParams,
    /// The odometry.
    pub odometry: OdometryParams,
}

impl Default for SimParams {
    fn default() -> Self {
        SimParams {
            rate_hz: 10.0,
            start_time_s: 1_000_000_000.0,
            max_scans: None,
            min_hits_seen: 3,
            path: PathParams::default(),
            laser: LaserParams::default(),
            odometry: OdometryParams::default(),
        }
    }
}

/// A parameter outside its allowed range.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamError {
    /// Dotted path of the field, as in a configuration file (`laser.max_range_m`).
    pub field: &'static str,
    /// The offending value.
    pub value: f64,
    /// What is allowed.
    pub expected: &'static str,
}

impl fmt::Display for ParamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "simulation parameter `{}` = {}: expected {}",
            self.field, self.value, self.expected
        )
    }
}

impl std::error::Error for ParamError {}

/// One checked field: name, accessors, and its allowed range.
struct Rule {
    field: &'static str,
    get: fn(&SimParams) -> f64,
    set: fn(&mut SimParams, f64),
    valid: fn(f64) -> bool,
    expected: &'static str,
}

/// Expected-value texts shared by several rules.
const NON_NEGATIVE: &str = "a finite value >= 0";
const FINITE: &str = "a finite value";
const BIAS: &str = "a value in (-0.5, 0.5)";
const PROBABILITY: &str = "a probability in [0, 1]";
const STEPS: &str = "1 to 1000000 steps";

/// Finite and strictly positive.
fn positive(x: f64) -> bool {
    x.is_finite() && x > 0.0
}

/// Finite and not negative.
fn non_negative(x: f64) -> bool {
    x.is_finite() && x >= 0.0
}

/// Finite.
fn finite(x: f64) -> bool {
    x.is_finite()
}

/// Builds the [`Rule`] table: `"field": path as type, validity, expected;` per line.
macro_rules! rules {
    ($($field:literal: $($path:ident).+ as $ty:ty, $valid:expr, $expected:expr;)*) => {
        vec![$(Rule {
            field: $field,
            get: |p| p.$($path).+ as f64,
            set: |p, v| p.$($path).+ = v as $ty,
            valid: $valid,
            expected: $expected,
        }),*]
    };
}

/// Every checked field. The limits keep a run's size and arithmetic sane.
#[rustfmt::skip]
fn rules() -> Vec<Rule> {
    rules! {
        "rate_hz": rate_hz as f64, |x| positive(x) && x <= 1000.0, "a value in (0, 1000]";
        "start_time_s": start_time_s as f64, non_negative, NON_NEGATIVE;
        "path.speed_mps": path.speed_mps as f64, |x| (0.01..=10.0).contains(&x), "a value in [0.01, 10]";
        "path.max_turn_rate_rad_s": path.max_turn_rate_rad_s as f64, |x| (0.01..=20.0).contains(&x), "a value in [0.01, 20]";
        "path.max_accel_mps2": path.max_accel_mps2 as f64, |x| (0.01..=100.0).contains(&x), "a value in [0.01, 100]";
        "path.corner_radius_m": path.corner_radius_m as f64, non_negative, NON_NEGATIVE;
        "laser.num_beams": laser.num_beams as usize, |x| (1.0..=100_000.0).contains(&x), "1 to 100000 beams";
        "laser.fov_rad": laser.fov_rad as f64, |x| positive(x) && x <= TAU, "a value in (0, 2π]";
        "laser.angle_min_rad": laser.angle_min_rad as f64, finite, FINITE;
        "laser.max_range_m": laser.max_range_m as f64, |x| positive(x) && x <= 10_000.0, "a value in (0, 10000]";
        "laser.range_sigma_m": laser.range_sigma_m as f64, non_negative, NON_NEGATIVE;
        "laser.dropout_probability": laser.dropout_probability as f64, |x| (0.0..=1.0).contains(&x), PROBABILITY;
        "laser.bearing_sigma_rad": laser.bearing_sigma_rad as f64, non_negative, NON_NEGATIVE;
        "laser.robot_from_laser.x_m": laser.robot_from_laser.x_m as f64, finite, FINITE;
        "laser.robot_from_laser.y_m": laser.robot_from_laser.y_m as f64, finite, FINITE;
        "laser.robot_from_laser.theta_rad": laser.robot_from_laser.theta_rad as f64, finite, FINITE;
        "odometry.initial_odom_from_robot.x_m": odometry.initial_odom_from_robot.x_m as f64, finite, FINITE;
        "odometry.initial_odom_from_robot.y_m": odometry.initial_odom_from_robot.y_m as f64, finite, FINITE;
        "odometry.initial_odom_from_robot.theta_rad": odometry.initial_odom_from_robot.theta_rad as f64, finite, FINITE;
        "odometry.translation_scale_bias": odometry.translation_scale_bias as f64, |x| x > -0.5 && x < 0.5, BIAS;
        "odometry.rotation_scale_bias": odometry.rotation_scale_bias as f64, |x| x > -0.5 && x < 0.5, BIAS;
        "odometry.heading_drift_rad_per_m": odometry.heading_drift_rad_per_m as f64, finite, FINITE;
        "odometry.translation_sigma_frac": odometry.translation_sigma_frac as f64, non_negative, NON_NEGATIVE;
        "odometry.rotation_sigma_frac": odometry.rotation_sigma_frac as f64, non_negative, NON_NEGATIVE;
        "odometry.lateral_sigma_frac": odometry.lateral_sigma_frac as f64, non_negative, NON_NEGATIVE;
        "odometry.translation_sigma_m": odometry.translation_sigma_m as f64, non_negative, NON_NEGATIVE;
        "odometry.rotation_sigma_rad": odometry.rotation_sigma_rad as f64, non_negative, NON_NEGATIVE;
        "odometry.faults.slip_probability": odometry.faults.slip_probability as f64, |x| (0.0..=1.0).contains(&x), PROBABILITY;
        "odometry.faults.slip_steps": odometry.faults.slip_steps as u32, |x| (1.0..=1e6).contains(&x), STEPS;
        "odometry.faults.slip_max_factor": odometry.faults.slip_max_factor as f64, |x| (0.0..=100.0).contains(&x), "a value in [0, 100]";
        "odometry.faults.turn_bias_frac": odometry.faults.turn_bias_frac as f64, |x| (-1.0..=10.0).contains(&x), "a value in [-1, 10]";
        "odometry.faults.stall_probability": odometry.faults.stall_probability as f64, |x| (0.0..=1.0).contains(&x), PROBABILITY;
        "odometry.faults.stall_steps": odometry.faults.stall_steps as u32, |x| (1.0..=1e6).contains(&x), STEPS;
        "odometry.faults.wheel_base_m": odometry.faults.wheel_base_m as f64, |x| positive(x) && x <= 100.0, "a value in (0, 100]";
    }
}

impl SimParams {
    /// The first parameter outside its allowed range, if any. Call this where parameters
    /// come in (a configuration file, the command line) and report the error there.
    pub fn validate(&self) -> Result<(), ParamError> {
        match rules().into_iter().find(|r| !(r.valid)((r.get)(self))) {
            Some(r) => Err(ParamError {
                field: r.field,
                value: (r.get)(self),
                expected: r.expected,
            }),
            None => Ok(()),
        }
    }

    /// A copy with every parameter that fails [`SimParams::validate`] replaced by its default.
    /// [`crate::simulate`] runs on this, so it never panics; validate first to report errors.
    pub fn sanitized(&self) -> SimParams {
        let defaults = SimParams::default();
        let mut out = self.clone();
        for r in rules() {
            if !(r.valid)((r.get)(&out)) {
                (r.set)(&mut out, (r.get)(&defaults));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid() {
        assert_eq!(SimParams::default().validate(), Ok(()));
    }

    #[test]
    fn every_rule_rejects_nan_and_sanitizing_fixes_it() {
        for r in rules() {
            let mut p = SimParams::default();
            (r.set)(&mut p, f64::NAN);
            if r.field == "laser.num_beams" {
                p.laser.num_beams = 0;
            }
            if r.field.ends_with("_steps") {
                assert_eq!((r.get)(&p), 0.0, "NaN as u32 is 0: {}", r.field);
            }
            assert_eq!(p.validate().map_err(|e| e.field), Err(r.field));
            assert_eq!(p.sanitized(), SimParams::default(), "{}", r.field);
        }
    }

    #[test]
    fn error_message_names_the_field() {
        let p = SimParams {
            laser: LaserParams {
                max_range_m: 0.0,
                ..LaserParams::default()
            },
            ..SimParams::default()
        };
        let msg = p
            .validate()
            .map(|_| String::new())
            .unwrap_or_else(|e| e.to_string());
        assert_eq!(
            msg,
            "simulation parameter `laser.max_range_m` = 0: expected a value in (0, 10000]"
        );
    }

    #[test]
    fn partial_configuration_fills_in_defaults() {
        let p: SimParams = serde_json::from_str(r#"{"rate_hz": 5.0, "laser": {"num_beams": 360}}"#)
            .expect("valid json");
        assert_eq!(p.rate_hz, 5.0);
        assert_eq!(p.laser.num_beams, 360);
        assert_eq!(p.laser.max_range_m, 30.0);
    }
}
