//! The robot's motion: waypoints → a smooth, speed- and turn-rate-limited trajectory.
//!
//! Corners are rounded with circular arcs (fillets) of at most [`PathParams::corner_radius_m`],
//! smaller where the legs are short; a turn of 180° becomes a turn on the spot. The path is
//! sampled densely, each sample gets a speed limit (cruise speed on straights, `ω_max · r` on
//! arcs, zero at the ends), an acceleration limit is imposed by a forward and a backward pass,
//! and the result is sampled at the scan rate. The robot starts and stops at rest.

use std::f64::consts::PI;

use polymap::geometry::{Pose2, Vec2, normalize_angle_rad};
use serde::{Deserialize, Serialize};

/// Spacing of the dense path samples, metres.
const DS_M: f64 = 0.02;
/// Largest heading change between dense samples, radians (1°).
const DTHETA_RAD: f64 = PI / 180.0;
/// Waypoints closer than this are merged, metres.
const SAME_POINT_M: f64 = 1e-9;

/// How the robot drives. Defaults: a careful indoor robot (Pioneer-like).
///
/// ```
/// use polymap_sim::path::PathParams;
/// let p = PathParams::default();
/// assert_eq!(p.speed_mps, 0.5);
/// assert!((p.max_turn_rate_rad_s.to_degrees() - 40.0).abs() < 1e-9);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct PathParams {
    /// Cruise speed on straights, m/s. Default 0.5.
    pub speed_mps: f64,
    /// Largest turn rate, rad/s. Default 40°/s (0.698 rad/s).
    pub max_turn_rate_rad_s: f64,
    /// Largest change of speed, m/s². Default 0.5 (1 s from rest to cruise).
    pub max_accel_mps2: f64,
    /// Radius of the arcs that round the corners, metres; smaller where legs are short.
    /// Default 1.0 (at 0.5 m/s such an arc turns at 29°/s).
    pub corner_radius_m: f64,
}

impl Default for PathParams {
    fn default() -> Self {
        PathParams {
            speed_mps: 0.5,
            max_turn_rate_rad_s: 40f64.to_radians(),
            max_accel_mps2: 0.5,
            corner_radius_m: 1.0,
        }
    }
}

/// One dense sample of the path.
#[derive(Debug, Clone, Copy)]
struct Node {
    /// Position, metres, world frame.
    p: Vec2,
    /// Heading, radians (not wrapped, so consecutive values differ by the true turn).
    heading_rad: f64,
    /// Speed limit here, m/s.
    speed_mps: f64,
}

/// A rounded corner: tangent distance from the vertex, radius and signed turn.
#[derive(Debug, Clone, Copy)]
struct Fillet {
    tangent_m: f64,
    radius_m: f64,
    turn_rad: f64,
}

/// The robot's true poses (`map_from_robot`, world frame) at `rate_hz` along the waypoints.
///
/// The first pose sits on the first waypoint, facing the second; the robot accelerates from
/// rest and stops at the last waypoint. Fewer than two distinct waypoints give at most one
/// pose. `params` are assumed valid (see [`crate::SimParams::validate`]).
///
/// ```
/// use polymap::geometry::Vec2;
/// use polymap_sim::path::{PathParams, trajectory};
/// let poses = trajectory(&[Vec2::new(0.0, 0.0), Vec2::new(10.0, 0.0)], &PathParams::default(), 10.0);
/// // 10 m at 0.5 m/s plus 1 s lost to starting and stopping: about 21 s.
/// assert!((poses.len() as f64 - 211.0).abs() <= 1.0);
/// assert_eq!(poses[0].x_m, 0.0);
/// assert!(poses.last().unwrap().x_m > 9.99);
/// ```
pub fn trajectory(waypoints: &[Vec2], params: &PathParams, rate_hz: f64) -> Vec<Pose2> {
    let points = distinct(waypoints);
    match points.as_slice() {
        [] => return vec![],
        [p] => return vec![Pose2::new(p.x, p.y, 0.0)],
        _ => {}
    }
    let mut nodes = dense_nodes(&points, params);
    limit_acceleration(&mut nodes, params.max_accel_mps2);
    let times = node_times(&nodes, params);
    sample(&nodes, &times, rate_hz)
}

/// Finite waypoints with consecutive duplicates removed.
fn distinct(waypoints: &[Vec2]) -> Vec<Vec2> {
    let mut out: Vec<Vec2> = Vec::with_capacity(waypoints.len());
    for &p in waypoints.iter().filter(|p| p.is_finite()) {
        if out.last().is_none_or(|q| (p - *q).length() > SAME_POINT_M) {
            out.push(p);
        }
    }
    out
}

/// The fillet at interior vertex `k`, given the unit leg directions and lengths.
fn fillet(k: usize, dirs: &[Vec2], lengths: &[f64], radius_m: f64) -> Fillet {
    let (u_in, u_out) = (dirs[k - 1], dirs[k]);
    let turn_rad = u_in.perp_dot(u_out).atan2(u_in.dot(u_out));
    let half_tan = (turn_rad.abs() / 2.0).tan();
    // A leg between two corners is shared; the first and last legs belong to one corner.
    let share = |leg: usize| {
        if leg == 0 || leg == lengths.len() - 1 {
            1.0
        } else {
            0.5
        }
    };
    let avail_m = (lengths[k - 1] * share(k - 1)).min(lengths[k] * share(k));
    if turn_rad.abs() < 1e-12 || turn_rad.abs() > PI - 1e-9 || !half_tan.is_finite() {
        return Fillet {
            tangent_m: 0.0,
            radius_m: 0.0,
            turn_rad,
        };
    }
    let r = radius_m.min(avail_m / half_tan);
    Fillet {
        tangent_m: r * half_tan,
        radius_m: r,
        turn_rad,
    }
}

/// The speed limit on an arc of radius `r`.
fn arc_speed(r_m: f64, params: &PathParams) -> f64 {
    params.speed_mps.min(params.max_turn_rate_rad_s * r_m)
}

/// The dense samples: straight legs and corner arcs, speed limits set, not yet accelerated.
fn dense_nodes(points: &[Vec2], params: &PathParams) -> Vec<Node> {
    let legs: Vec<Vec2> = points.windows(2).map(|w| w[1] - w[0]).collect();
    let lengths: Vec<f64> = legs.iter().map(|v| v.length()).collect();
    let dirs: Vec<Vec2> = legs.iter().map(|v| v.normalize_or_zero()).collect();
    let fillets: Vec<Option<Fillet>> = (0..points.len())
        .map(|k| {
            (k > 0 && k + 1 < points.len())
                .then(|| fillet(k, &dirs, &lengths, params.corner_radius_m))
        })
        .collect();
    let tangent = |k: usize| fillets[k].map_or(0.0, |f| f.tangent_m);
    let mut heading = dirs[0].y.atan2(dirs[0].x);
    let mut nodes = vec![Node {
        p: points[0],
        heading_rad: heading,
        speed_mps: 0.0,
    }];
    for (i, &dir) in dirs.iter().enumerate() {
        let end = points[i + 1] - dir * tangent(i + 1);
        push_line(&mut nodes, end, params.speed_mps);
        if let Some(f) = fillets[i + 1] {
            heading = push_arc(&mut nodes, dir, f, params);
        }
    }
    if let Some(last) = nodes.last_mut() {
        last.speed_mps = 0.0;
    }
    debug_assert!(
        nodes
            .iter()
            .all(|n| n.p.is_finite() && n.heading_rad.is_finite()),
        "{heading}"
    );
    nodes
}

/// Appends a straight run from the last node to `end`, keeping the last node's heading.
fn push_line(nodes: &mut Vec<Node>, end: Vec2, speed_mps: f64) {
    let Some(&start) = nodes.last() else { return };
    let length = (end - start.p).length();
    // The small bias keeps rounding from adding a sample, so a moved world samples alike.
    let n = (length / DS_M - 1e-6).ceil() as usize;
    for k in 1..=n {
        let p = start.p.lerp(end, k as f64 / n as f64);
        nodes.push(Node {
            p,
            heading_rad: start.heading_rad,
            speed_mps,
        });
    }
}

/// Appends a corner arc starting at the last node (entered along `dir_in`); returns the new
/// heading.
fn push_arc(nodes: &mut Vec<Node>, dir_in: Vec2, f: Fillet, params: &PathParams) -> f64 {
    let Some(&start) = nodes.last() else {
        return 0.0;
    };
    let left = Vec2::new(-dir_in.y, dir_in.x);
    let centre = start.p + left * (f.radius_m * f.turn_rad.signum());
    let arm = start.p - centre;
    let n = ((f.radius_m * f.turn_rad.abs() / DS_M).max(f.turn_rad.abs() / DTHETA_RAD) - 1e-6)
        .ceil() as usize;
    let speed_mps = arc_speed(f.radius_m, params);
    for k in 1..=n {
        let a = f.turn_rad * k as f64 / n as f64;
        let p = centre + Vec2::from_angle(a).rotate(arm);
        nodes.push(Node {
            p,
            heading_rad: start.heading_rad + a,
            speed_mps,
        });
    }
    start.heading_rad + f.turn_rad
}

/// Caps each node's speed so that speed changes by at most `accel` m/s² (both directions).
fn limit_acceleration(nodes: &mut [Node], accel_mps2: f64) {
    for j in 1..nodes.len() {
        let ds = (nodes[j].p - nodes[j - 1].p).length();
        let reachable = (nodes[j - 1].speed_mps.powi(2) + 2.0 * accel_mps2 * ds).sqrt();
        nodes[j].speed_mps = nodes[j].speed_mps.min(reachable);
    }
    for j in (0..nodes.len().saturating_sub(1)).rev() {
        let ds = (nodes[j + 1].p - nodes[j].p).length();
        let reachable = (nodes[j + 1].speed_mps.powi(2) + 2.0 * accel_mps2 * ds).sqrt();
        nodes[j].speed_mps = nodes[j].speed_mps.min(reachable);
    }
}

/// The time at which the robot passes each node, seconds from the start.
fn node_times(nodes: &[Node], params: &PathParams) -> Vec<f64> {
    let mut t = 0.0;
    let mut times = Vec::with_capacity(nodes.len());
    times.push(0.0);
    for w in nodes.windows(2) {
        let ds = (w[1].p - w[0].p).length();
        let v_sum = w[0].speed_mps + w[1].speed_mps;
        let dt_move = if ds == 0.0 {
            0.0
        } else if v_sum > 1e-12 {
            2.0 * ds / v_sum
        } else {
            ds / params.speed_mps
        };
        let dt_turn = (w[1].heading_rad - w[0].heading_rad).abs() / params.max_turn_rate_rad_s;
        t += dt_move.max(dt_turn);
        times.push(t);
    }
    times
}

/// Samples the timed nodes every `1 / rate_hz` seconds, interpolating between nodes.
fn sample(nodes: &[Node], times: &[f64], rate_hz: f64) -> Vec<Pose2> {
    if !(rate_hz.is_finite() && rate_hz > 0.0) || nodes.is_empty() {
        return vec![];
    }
    let t_end = times.last().copied().unwrap_or(0.0);
    let mut out = Vec::new();
    let mut j = 0;
    for k in 0.. {
        let t = k as f64 / rate_hz;
        if t > t_end {
            break;
        }
        while j + 2 < times.len() && times[j + 1] <= t {
            j += 1;
        }
        let (a, b) = (nodes[j], nodes[(j + 1).min(nodes.len() - 1)]);
        let span = times[(j + 1).min(times.len() - 1)] - times[j];
        let f = if span > 0.0 {
            ((t - times[j]) / span).clamp(0.0, 1.0)
        } else {
            1.0
        };
        let p = a.p.lerp(b.p, f);
        let heading = a.heading_rad + normalize_angle_rad(b.heading_rad - a.heading_rad) * f;
        out.push(Pose2::new(p.x, p.y, heading));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> Vec<Vec2> {
        [
            (0.0, 0.0),
            (10.0, 0.0),
            (10.0, 10.0),
            (0.0, 10.0),
            (0.0, 0.0),
        ]
        .map(|(x, y)| Vec2::new(x, y))
        .to_vec()
    }

    #[test]
    fn speed_and_turn_rate_stay_within_limits() {
        let params = PathParams::default();
        let poses = trajectory(&square(), &params, 10.0);
        for w in poses.windows(2) {
            let d = w[0].between(&w[1]);
            assert!(d.translation().length() <= params.speed_mps / 10.0 + 1e-9);
            assert!(d.theta_rad.abs() <= params.max_turn_rate_rad_s / 10.0 + 1e-9);
        }
    }

    #[test]
    fn corners_are_cut_by_the_fillet_only() {
        let poses = trajectory(&square(), &PathParams::default(), 10.0);
        // A 90° fillet of radius 1 m passes (√2 - 1) m from the corner.
        let nearest = poses
            .iter()
            .map(|p| (p.translation() - Vec2::new(10.0, 0.0)).length())
            .fold(f64::MAX, f64::min);
        assert!((nearest - (2f64.sqrt() - 1.0)).abs() < 0.03, "{nearest}");
    }

    #[test]
    fn u_turn_happens_on_the_spot() {
        let pts = [
            Vec2::new(0.0, 0.0),
            Vec2::new(2.0, 0.0),
            Vec2::new(0.0, 0.0),
        ];
        let poses = trajectory(&pts, &PathParams::default(), 10.0);
        assert!(
            poses
                .iter()
                .all(|p| p.y_m.abs() < 1e-9 && p.x_m <= 2.0 + 1e-9)
        );
        let last = poses.last().map(|p| p.theta_rad.abs()).unwrap_or(0.0);
        assert!((last - PI).abs() < 0.05, "{last}");
    }

    #[test]
    fn degenerate_waypoints_give_few_poses() {
        assert!(trajectory(&[], &PathParams::default(), 10.0).is_empty());
        let one = trajectory(
            &[Vec2::ONE, Vec2::ONE, Vec2::new(f64::NAN, 0.0)],
            &PathParams::default(),
            10.0,
        );
        assert_eq!(one, vec![Pose2::new(1.0, 1.0, 0.0)]);
    }
}
