//! One robust Gauss–Newton solver for point-to-line constraints, and the ICP loop around it.

use glam::{DMat3, DVec3};

use super::{AlignParams, AlignResult, TranslationInformation};
use crate::geometry::{Pose2, Vec2, normalize_angle_rad};

/// A point of the scan that should lie on a line of the map.
///
/// The residual is `normal · (map_from_robot · p_in_robot − q_in_map)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Constraint {
    /// The scan point, robot frame.
    pub p_in_robot: Vec2,
    /// A point of the target line, map frame.
    pub q_in_map: Vec2,
    /// Unit normal of the target line, map frame.
    pub normal: Vec2,
}

impl Constraint {
    /// The residual at a pose, metres.
    pub fn residual_m(&self, map_from_robot: &Pose2) -> f64 {
        self.normal
            .dot(map_from_robot.transform_point(self.p_in_robot) - self.q_in_map)
    }

    /// A point-to-point pair as two constraints, along x and along y.
    pub fn point_pair(p_in_robot: Vec2, q_in_map: Vec2) -> [Constraint; 2] {
        [Vec2::X, Vec2::Y].map(|normal| Constraint {
            p_in_robot,
            q_in_map,
            normal,
        })
    }
}

/// A motion prior ICP weighs with the fit at every step: the pose it predicts (map frame) and
/// its information over (x, y, θ) in the fit's own units, those of the normal equations, where
/// one fully weighted point-to-line correspondence adds up to 1 along its normal (a physical
/// information in 1/m², 1/(m·rad), 1/rad² times the variance one weighted point is counted
/// at). ICP then ends at the pose that best agrees with both, not at the nearest pose that fits
/// the map alone: along a direction the scan observes by a few points, the prior's information
/// outweighs them. Give ICP the prior's pose as its anchor too: along a direction the fit
/// cannot observe at all, the result is put on the anchor, where the prior would have held it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PosePrior {
    /// The pose the prior predicts, map frame.
    pub pose: Pose2,
    /// Its information over (x, y, θ), in the fit's units.
    pub information: DMat3,
}

/// Residual statistics of a set of constraints at one pose.
struct Stats {
    rms_m: f64,
    inliers: usize,
}

fn stats(constraints: &[Constraint], pose: &Pose2, robust_scale_m: f64) -> Stats {
    let mut ss = 0.0;
    let mut inliers = 0;
    for c in constraints {
        let r = c.residual_m(pose);
        ss += r * r;
        inliers += usize::from(r.abs() <= robust_scale_m);
    }
    let rms_m = if constraints.is_empty() {
        0.0
    } else {
        (ss / constraints.len() as f64).sqrt()
    };
    Stats { rms_m, inliers }
}

/// One Gauss–Newton step with Cauchy weights, degeneracy-aware: the update is only taken along
/// eigenvectors of the normal matrix whose eigenvalue reaches `min_information`. Along weaker
/// directions (a featureless corridor) the pose stays where the motion prior put it. `None`
/// when no direction is constrained. A `prior` adds its information and its pull to the
/// normal equations.
fn step(
    constraints: &[Constraint],
    pose: &Pose2,
    prior: Option<&PosePrior>,
    params: &AlignParams,
) -> Option<Pose2> {
    let (mut h, mut g) = normal_equations(constraints, pose, params);
    if let Some(p) = prior {
        h += p.information;
        g += p.information * p.pose.offset_to(pose);
    }
    let (values, vectors) = symmetric_eigen(h);
    let mut delta = DVec3::ZERO;
    let mut constrained = false;
    for (i, &value) in values.iter().enumerate() {
        if value >= params.min_information {
            let v = vectors.col(i);
            delta -= v * (v.dot(g) / value);
            constrained = true;
        }
    }
    (constrained && delta.is_finite()).then(|| add(pose, delta))
}

fn add(pose: &Pose2, delta: DVec3) -> Pose2 {
    Pose2::new(
        pose.x_m + delta.x,
        pose.y_m + delta.y,
        pose.theta_rad + delta.z,
    )
}

/// The Cauchy-weighted Gauss–Newton normal equations `(H, g)` at a pose.
fn normal_equations(
    constraints: &[Constraint],
    pose: &Pose2,
    params: &AlignParams,
) -> (DMat3, DVec3) {
    let mut h = DMat3::ZERO;
    let mut g = DVec3::ZERO;
    let k_2 = params.robust_scale_m * params.robust_scale_m;
    for c in constraints {
        let rp = pose.rotate(c.p_in_robot);
        let r = c.normal.dot(rp + pose.translation() - c.q_in_map);
        let j = DVec3::new(c.normal.x, c.normal.y, c.normal.dot(rp.perp()));
        let w = 1.0 / (1.0 + r * r / k_2);
        h += outer(j, j * w);
        g += j * (w * r);
    }
    (h, g)
}

/// Moves `pose` onto `anchor` along the directions that the information `h` (of the final
/// constraints at `pose`) leaves unobservable; returns how many directions that was, and the
/// map-frame direction (degrees, `[0, 180)`) of the weakest one's translation when there was
/// one with a translational part.
fn anchor_weak_directions(
    h: DMat3,
    pose: &mut Pose2,
    anchor: &Pose2,
    params: &AlignParams,
) -> (u8, Option<f64>) {
    let (values, vectors) = symmetric_eigen(h);
    let to_anchor = pose.offset_to(anchor);
    let mut weak = 0;
    let mut delta = DVec3::ZERO;
    let mut weakest: Option<(f64, DVec3)> = None;
    for (i, &value) in values.iter().enumerate() {
        if value < params.min_information {
            let v = vectors.col(i);
            delta += v * v.dot(to_anchor);
            weak += 1;
            if weakest.is_none_or(|(w, _)| value < w) {
                weakest = Some((value, v));
            }
        }
    }
    *pose = add(pose, delta);
    let direction = weakest
        .filter(|(_, v)| v.x.hypot(v.y) > 0.5)
        .map(|(_, v)| v.y.atan2(v.x).to_degrees().rem_euclid(180.0));
    (weak, direction)
}

/// The translation information of `h` with the rotation marginalized (its Schur complement);
/// zero when `h` is not finite.
fn translation_information(h: &DMat3) -> TranslationInformation {
    let (xx, xy, yy) = (h.x_axis.x, h.y_axis.x, h.y_axis.y);
    let (xr, yr, rr) = (h.z_axis.x, h.z_axis.y, h.z_axis.z);
    let (a, b, c) = if rr > 1e-12 {
        (xx - xr * xr / rr, xy - xr * yr / rr, yy - yr * yr / rr)
    } else {
        (xx, xy, yy)
    };
    let mean = 0.5 * (a + c);
    let spread = (0.25 * (a - c) * (a - c) + b * b).sqrt();
    let weakest = mean - spread;
    // The eigenvector of the smaller eigenvalue: (b, λ − a), or (λ − c, b); the longer one.
    let (u, v) = ((b, weakest - a), (weakest - c, b));
    let (dx, dy) = if u.0.hypot(u.1) >= v.0.hypot(v.1) {
        u
    } else {
        v
    };
    let info = TranslationInformation {
        weakest: weakest.max(0.0),
        strongest: (mean + spread).max(0.0),
        weakest_deg: if dx == 0.0 && dy == 0.0 {
            0.0
        } else {
            dy.atan2(dx).to_degrees().rem_euclid(180.0)
        },
        pose: [xx, xy, xr, yy, yr, rr],
    };
    if info.weakest.is_finite() && info.strongest.is_finite() && info.weakest_deg.is_finite() {
        info
    } else {
        TranslationInformation::default()
    }
}

/// Eigenvalues and eigenvectors (as columns) of a symmetric 3×3 matrix, by cyclic Jacobi
/// rotations.
pub(crate) fn symmetric_eigen(m: DMat3) -> ([f64; 3], DMat3) {
    // a[c][r]: column-major like glam; the matrix is symmetric so a[c][r] == a[r][c].
    let mut a = m.to_cols_array_2d();
    let mut v = DMat3::IDENTITY.to_cols_array_2d();
    for _sweep in 0..32 {
        let diag = a[0][0].abs() + a[1][1].abs() + a[2][2].abs();
        let off = a[0][1].abs() + a[0][2].abs() + a[1][2].abs();
        if off <= 1e-15 * diag.max(f64::MIN_POSITIVE) {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] != 0.0 {
                jacobi_rotate(&mut a, &mut v, p, q);
            }
        }
    }
    ([a[0][0], a[1][1], a[2][2]], DMat3::from_cols_array_2d(&v))
}

/// Zeroes `a[p][q]` by the rotation `a ← Jᵀ·a·J`, accumulating `v ← v·J`.
fn jacobi_rotate(a: &mut [[f64; 3]; 3], v: &mut [[f64; 3]; 3], p: usize, q: usize) {
    let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
    let t = if theta == 0.0 {
        1.0
    } else {
        theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt())
    };
    let c = 1.0 / (t * t + 1.0).sqrt();
    let s = t * c;
    for row in a.iter_mut() {
        let (akp, akq) = (row[p], row[q]);
        row[p] = c * akp - s * akq;
        row[q] = s * akp + c * akq;
    }
    let (ap, aq) = (a[p], a[q]);
    for k in 0..3 {
        a[p][k] = c * ap[k] - s * aq[k];
        a[q][k] = s * ap[k] + c * aq[k];
    }
    let (vp, vq) = (v[p], v[q]);
    for k in 0..3 {
        v[p][k] = c * vp[k] - s * vq[k];
        v[q][k] = s * vp[k] + c * vq[k];
    }
}

fn outer(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x, a * b.y, a * b.z)
}

/// Runs ICP from `guess`: `gather` fills the constraints for a pose and a gate (metres).
///
/// Each step minimizes the fit, and with a `prior` the fit plus the prior. Along directions the
/// final constraints leave unobservable, the result is moved onto `anchor` (for instance the
/// previous pose: "no evidence of motion, assume none"). The result's information is the
/// fit's own, without the prior's: it says what the scan observed.
pub(crate) fn run_icp(
    guess: Pose2,
    anchor: Pose2,
    prior: Option<&PosePrior>,
    params: &AlignParams,
    mut gather: impl FnMut(&Pose2, f64, &mut Vec<Constraint>),
) -> AlignResult {
    let mut pose = guess;
    let mut constraints = Vec::new();
    let mut result = AlignResult {
        map_from_robot: guess,
        iterations: 0,
        correspondences: 0,
        inliers: 0,
        residual_rms_m: 0.0,
        converged: false,
        weak_directions: 0,
        weak_direction_deg: None,
        translation_information: TranslationInformation::default(),
        weighed_prior: prior.is_some(),
    };
    for i in 0..params.max_iterations {
        constraints.clear();
        gather(&pose, params.gate_m(i), &mut constraints);
        let s = stats(&constraints, &pose, params.robust_scale_m);
        result = AlignResult {
            map_from_robot: pose,
            iterations: i,
            correspondences: constraints.len(),
            inliers: s.inliers,
            residual_rms_m: s.rms_m,
            converged: false,
            weak_directions: 0,
            weak_direction_deg: None,
            translation_information: TranslationInformation::default(),
            weighed_prior: prior.is_some(),
        };
        if constraints.len() < params.min_correspondences {
            result.map_from_robot = anchor;
            result.weak_directions = 3;
            return result;
        }
        let Some(next) = step(&constraints, &pose, prior, params) else {
            break;
        };
        let moved_m = (next.translation() - pose.translation()).length();
        let turned_deg = normalize_angle_rad(next.theta_rad - pose.theta_rad)
            .abs()
            .to_degrees();
        pose = next;
        result.map_from_robot = pose;
        result.iterations = i + 1;
        // Only stop once the gate has shrunk to its final size: early stops at a wide gate
        // would keep outliers' pull.
        if moved_m < params.converged_translation_m
            && turned_deg < params.converged_rotation_deg
            && params.gate_m(i) <= params.final_gate_m
        {
            result.converged = true;
            break;
        }
    }
    // The information of the final constraints at the final pose, before the weak directions
    // are put on the anchor.
    let (h, _) = normal_equations(&constraints, &result.map_from_robot, params);
    result.translation_information = translation_information(&h);
    let (weak, direction) = anchor_weak_directions(h, &mut result.map_from_robot, &anchor, params);
    result.weak_directions = weak;
    result.weak_direction_deg = direction;
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A prior is weighed with the fit in information form: along the corridor, which two
    /// points of a door frame observe, a prior of far more information holds the pose; across
    /// it, where the walls' forty points observe, a prior of one point's worth moves it by
    /// millimetres. The result's information stays the fit's own.
    #[test]
    fn a_prior_holds_what_the_fit_observes_weakly_and_yields_where_it_observes_well() {
        let walls = (0..40).map(|i| {
            let y = if i % 2 == 0 { 1.0 } else { -1.0 };
            Constraint {
                p_in_robot: Vec2::new(-2.0 + 0.2 * (i / 2) as f64, y),
                q_in_map: Vec2::new(0.0, y),
                normal: Vec2::Y,
            }
        });
        let frame = [0.5, -0.5].map(|y| Constraint {
            p_in_robot: Vec2::new(2.0, y),
            q_in_map: Vec2::new(2.0, 0.0),
            normal: Vec2::X,
        });
        let constraints: Vec<Constraint> = walls.chain(frame).collect();
        let params = AlignParams::default();
        let icp = |prior: Option<&PosePrior>, anchor: Pose2| {
            run_icp(
                Pose2::new(0.1, 0.05, 0.0),
                anchor,
                prior,
                &params,
                |_, _, out| out.extend_from_slice(&constraints),
            )
        };
        let free = icp(None, Pose2::IDENTITY);
        let at = free.map_from_robot;
        assert!(at.x_m.abs() < 0.01 && at.y_m.abs() < 0.01, "{at:?}");
        assert!(!free.weighed_prior);
        let prior = PosePrior {
            pose: Pose2::new(0.3, 0.2, 0.0),
            information: DMat3::from_diagonal(DVec3::new(1000.0, 1.0, 0.0)),
        };
        let held = icp(Some(&prior), prior.pose);
        let at = held.map_from_robot;
        assert!((at.x_m - 0.3).abs() < 0.02 && at.y_m.abs() < 0.02, "{at:?}");
        assert!(held.weighed_prior);
        assert!(held.translation_information.weakest < 5.0, "{held:?}");
    }

    #[test]
    fn translation_information_names_a_corridor_axis() {
        // Walls along x at y = ±1, 20 points each, every 0.2 m: nothing fixes x.
        let constraints: Vec<Constraint> = (0..40)
            .map(|i| {
                let y = if i % 2 == 0 { 1.0 } else { -1.0 };
                Constraint {
                    p_in_robot: Vec2::new(-2.0 + 0.2 * (i / 2) as f64, y),
                    q_in_map: Vec2::new(0.0, y),
                    normal: Vec2::Y,
                }
            })
            .collect();
        let params = AlignParams::default();
        let pose = Pose2::IDENTITY;
        let along = |deg: f64| {
            let info = translation_information(&normal_equations(&constraints, &pose, &params).0);
            (
                info,
                (info.weakest_deg - deg)
                    .abs()
                    .min(180.0 - (info.weakest_deg - deg).abs()),
            )
        };
        let (info, off_deg) = along(0.0);
        assert!(info.weakest < 1e-9, "{info:?}");
        assert!((info.strongest - 40.0).abs() < 1.0, "{info:?}");
        assert!(off_deg < 1e-6, "{info:?}");
        // A wall across the corridor (normal along x) observes x: 10 points.
        let mut closed = constraints.clone();
        closed.extend((0..10).map(|i| Constraint {
            p_in_robot: Vec2::new(5.0, -0.9 + 0.2 * i as f64),
            q_in_map: Vec2::new(5.0, 0.0),
            normal: Vec2::X,
        }));
        let info = translation_information(&normal_equations(&closed, &Pose2::IDENTITY, &params).0);
        assert!(info.weakest > 5.0, "{info:?}");
    }

    #[test]
    fn jacobi_eigen_reconstructs_the_matrix() {
        let m = DMat3::from_cols(
            DVec3::new(4.0, 1.0, 0.5),
            DVec3::new(1.0, 3.0, -0.2),
            DVec3::new(0.5, -0.2, 0.01),
        );
        let (values, vectors) = symmetric_eigen(m);
        for (i, value) in values.iter().enumerate() {
            let v = vectors.col(i);
            assert!((m * v - v * *value).length() < 1e-9, "pair {i}");
            assert!((v.length() - 1.0).abs() < 1e-9);
        }
    }
}
