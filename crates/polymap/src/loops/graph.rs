//! A 2D pose graph and its least-squares solution (Gauss–Newton, preconditioned conjugate
//! gradients on the sparse normal equations, Cauchy weights on loop edges).

use glam::{DMat2, DMat3, DVec2, DVec3};

use crate::geometry::{Pose2, normalize_angle_rad};

/// A relative-pose measurement between two nodes: `to` seen from `from`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Edge {
    /// The older node.
    pub from: usize,
    /// The newer node.
    pub to: usize,
    /// `from_from_to`: the pose of `to` in the frame of `from`, metres and radians.
    pub measured: Pose2,
    /// Standard deviation of the translation along each axis, metres.
    pub sigma_m: f64,
    /// Standard deviation of the rotation, radians.
    pub sigma_rad: f64,
    /// Covariance of the translation beyond `sigma_m`, m², in the frame of `to` as measured
    /// (the residual's frame): the motion the mapper could not confirm (a sequential edge over
    /// `weak` scans); zero for a loop edge.
    pub doubt_m2: DMat2,
    /// A loop edge gets a robust (Cauchy) weight; a sequential edge is trusted.
    pub robust: bool,
}

/// Scale of the Cauchy weight on loop edges, in standard deviations.
const CAUCHY_SCALE: f64 = 3.0;

/// A weak prior on every free node keeps every diagonal block invertible (a node seen by
/// nothing stays put).
const PRIOR_WEIGHT: f64 = 1e-6;

/// Gauss–Newton stops when no node moves by more than this (metres or radians).
const CONVERGED_STEP: f64 = 1e-4;

/// The residual of an edge at the given node poses, in the measurement's frame
/// (`measured⁻¹ ∘ (from⁻¹ ∘ to)`), with its Jacobians with respect to `from` and `to`
/// (x, y, θ in the map frame).
fn residual(e: &Edge, a: &Pose2, b: &Pose2) -> (DVec3, DMat3, DMat3) {
    let (sa, ca) = a.theta_rad.sin_cos();
    let (sz, cz) = e.measured.theta_rad.sin_cos();
    let dx = b.x_m - a.x_m;
    let dy = b.y_m - a.y_m;
    // Translation of b in a's frame.
    let tx = ca * dx + sa * dy;
    let ty = -sa * dx + ca * dy;
    let ux = tx - e.measured.x_m;
    let uy = ty - e.measured.y_m;
    let r = DVec3::new(
        cz * ux + sz * uy,
        -sz * ux + cz * uy,
        normalize_angle_rad(b.theta_rad - a.theta_rad - e.measured.theta_rad),
    );
    // d(tx, ty)/d(a.x, a.y) = -R_a^T; d/d(a.θ) = (ty, -tx); d/d(b.x, b.y) = R_a^T; each
    // column turned into the measurement's frame.
    let rz = |vx: f64, vy: f64, vt: f64| DVec3::new(cz * vx + sz * vy, -sz * vx + cz * vy, vt);
    let ja = DMat3::from_cols(rz(-ca, sa, 0.0), rz(-sa, -ca, 0.0), rz(ty, -tx, -1.0));
    let jb = DMat3::from_cols(rz(ca, -sa, 0.0), rz(sa, ca, 0.0), DVec3::Z);
    (r, ja, jb)
}

/// `J1ᵀ W J2` (for a diagonal `W` the same sums as scaling the rows of `J1`: the other terms
/// are exact zeros).
fn jt_w_j(j1: &DMat3, w: &DMat3, j2: &DMat3) -> DMat3 {
    j1.transpose() * *w * *j2
}

/// The sum over blocks of their dot products.
fn dot(a: &[DVec3], b: &[DVec3]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x.dot(*y)).sum()
}

/// The inverse of a symmetric positive definite 3×3 matrix (the identity when singular), by
/// the adjugate (cofactors expanded along the first row).
fn inverse(m: &DMat3) -> DMat3 {
    let e = |r: usize, c: usize| m.col(c)[r];
    let det = e(0, 0) * (e(1, 1) * e(2, 2) - e(1, 2) * e(2, 1))
        - e(0, 1) * (e(1, 0) * e(2, 2) - e(1, 2) * e(2, 0))
        + e(0, 2) * (e(1, 0) * e(2, 1) - e(1, 1) * e(2, 0));
    if det.abs() <= 1e-300 || !det.is_finite() {
        return DMat3::IDENTITY;
    }
    let c =
        |r1: usize, r2: usize, c1: usize, c2: usize| e(r1, c1) * e(r2, c2) - e(r1, c2) * e(r2, c1);
    let adjugate = [
        [c(1, 2, 1, 2), -c(0, 2, 1, 2), c(0, 1, 1, 2)],
        [-c(1, 2, 0, 2), c(0, 2, 0, 2), -c(0, 1, 0, 2)],
        [c(1, 2, 0, 1), -c(0, 2, 0, 1), c(0, 1, 0, 1)],
    ];
    // Rows of the adjugate, divided by the determinant, as a column-major matrix.
    DMat3::from_cols_array_2d(&adjugate.map(|row| row.map(|v| v / det))).transpose()
}

/// Moves the poses of nodes `free` (a contiguous range; the others stay fixed) to minimise the
/// weighted squared residuals of `edges`. Returns the Gauss–Newton iterations run.
///
/// Every edge with at least one free node takes part; an edge's fixed end is a constant.
pub fn optimize(
    poses: &mut [Pose2],
    edges: &[Edge],
    free: std::ops::Range<usize>,
    max_iterations: usize,
) -> usize {
    let free = free.start.min(poses.len())..free.end.min(poses.len());
    let n = free.len();
    if n == 0 {
        return 0;
    }
    let active: Vec<&Edge> = edges
        .iter()
        .filter(|e| {
            e.from < poses.len()
                && e.to < poses.len()
                && (free.contains(&e.from) || free.contains(&e.to))
        })
        .collect();
    for iteration in 0..max_iterations {
        let (diag, off, g) = normal_equations(poses, &active, &free);
        let step = solve(&diag, &off, &g, 2 * n + 50);
        let mut largest: f64 = 0.0;
        for (k, s) in step.iter().enumerate() {
            let p = &mut poses[free.start + k];
            *p = Pose2::new(p.x_m - s.x, p.y_m - s.y, p.theta_rad - s.z);
            largest = largest.max(s.x.hypot(s.y)).max(s.z.abs());
        }
        if largest < CONVERGED_STEP {
            return iteration + 1;
        }
    }
    max_iterations
}

/// Upper blocks `(a, b, H_ab)` of a block-sparse symmetric matrix, `a < b` not required.
type OffBlocks = Vec<(usize, usize, DMat3)>;

/// The Gauss–Newton normal equations `H x = g` of the free nodes at the current poses: the
/// diagonal blocks of `H`, its off-diagonal blocks, and `g = Jᵀ W r`.
fn normal_equations(
    poses: &[Pose2],
    active: &[&Edge],
    free: &std::ops::Range<usize>,
) -> (Vec<DMat3>, OffBlocks, Vec<DVec3>) {
    let n = free.len();
    let index = |i: usize| free.contains(&i).then(|| i - free.start);
    let mut diag = vec![DMat3::ZERO; n];
    let mut off: OffBlocks = Vec::new();
    let mut g = vec![DVec3::ZERO; n];
    for e in active {
        let (r, ja, jb) = residual(e, &poses[e.from], &poses[e.to]);
        let w = weights(e, r);
        let wr_v = w * r;
        let (ia, ib) = (index(e.from), index(e.to));
        for (i, j) in [(ia, &ja), (ib, &jb)] {
            if let Some(i) = i {
                diag[i] += jt_w_j(j, &w, j);
                g[i] += j.transpose() * wr_v;
            }
        }
        if let (Some(a), Some(b)) = (ia, ib) {
            off.push((a, b, jt_w_j(&ja, &w, &jb)));
        }
    }
    for d in &mut diag {
        *d += DMat3::from_diagonal(DVec3::splat(PRIOR_WEIGHT));
    }
    (diag, off, g)
}

/// The weight (information) matrix of an edge's residual `r`: the inverse of the translation's
/// covariance (`sigma_m`² plus `doubt_m2`) and of the rotation's variance, times the Cauchy
/// weight for a loop edge.
fn weights(e: &Edge, r: DVec3) -> DMat3 {
    let wt = 1.0 / (e.sigma_m * e.sigma_m);
    let wr = 1.0 / (e.sigma_rad * e.sigma_rad);
    let translation = match e.doubt_m2 == DMat2::ZERO {
        // The common case, computed as inverse variances (no 2×2 inverse's rounding).
        true => DMat2::from_diagonal(DVec2::splat(wt)),
        false => {
            let t =
                (DMat2::from_diagonal(DVec2::splat(e.sigma_m * e.sigma_m)) + e.doubt_m2).inverse();
            if t.is_finite() {
                t
            } else {
                DMat2::from_diagonal(DVec2::splat(wt))
            }
        }
    };
    let w = DMat3::from_cols(
        translation.x_axis.extend(0.0),
        translation.y_axis.extend(0.0),
        DVec3::new(0.0, 0.0, wr),
    );
    if !e.robust {
        return w;
    }
    // rᵀ W r, summed as before the doubt when it is zero.
    let chi2 = r.x * r.x * translation.x_axis.x
        + 2.0 * r.x * r.y * translation.x_axis.y
        + r.y * r.y * translation.y_axis.y
        + r.z * r.z * wr;
    w * (1.0 / (1.0 + chi2 / (CAUCHY_SCALE * CAUCHY_SCALE)))
}

/// Solves `H x = g` for the block-sparse symmetric `H` (diagonal blocks and upper blocks
/// `(a, b, H_ab)`) by conjugate gradients with a block-Jacobi preconditioner.
fn solve(
    diag: &[DMat3],
    off: &[(usize, usize, DMat3)],
    g: &[DVec3],
    max_iterations: usize,
) -> Vec<DVec3> {
    let n = diag.len();
    let apply = |x: &[DVec3]| -> Vec<DVec3> {
        let mut y: Vec<DVec3> = diag.iter().zip(x).map(|(d, v)| *d * *v).collect();
        for (a, b, h) in off {
            y[*a] += *h * x[*b];
            y[*b] += h.transpose() * x[*a];
        }
        y
    };
    let pre: Vec<DMat3> = diag.iter().map(inverse).collect();
    let mut x = vec![DVec3::ZERO; n];
    let mut r = g.to_vec();
    let mut z: Vec<DVec3> = pre.iter().zip(&r).map(|(p, v)| *p * *v).collect();
    let mut p = z.clone();
    let mut rz = dot(&r, &z);
    let target = 1e-16 * dot(g, g).max(1e-300);
    for _ in 0..max_iterations {
        if dot(&r, &r) <= target {
            break;
        }
        let hp = apply(&p);
        let php = dot(&p, &hp);
        if php.is_nan() || php <= 0.0 {
            break;
        }
        let alpha = rz / php;
        for k in 0..n {
            x[k] += alpha * p[k];
            r[k] -= alpha * hp[k];
        }
        z = pre.iter().zip(&r).map(|(pm, v)| *pm * *v).collect();
        let rz_next = dot(&r, &z);
        let beta = rz_next / rz;
        rz = rz_next;
        for k in 0..n {
            p[k] = z[k] + beta * p[k];
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    fn edge(from: usize, to: usize, measured: Pose2, robust: bool) -> Edge {
        Edge {
            from,
            to,
            measured,
            sigma_m: 0.05,
            sigma_rad: 0.01,
            doubt_m2: DMat2::ZERO,
            robust,
        }
    }

    /// A corridor of six 1 m steps whose middle two were not observed along it (doubted along
    /// x): the loop edge that finds the end 0.4 m short of the chain puts the correction into
    /// the doubted steps and leaves the observed ones as measured; without the doubt it
    /// spreads over every step.
    #[test]
    fn a_loop_correction_goes_where_the_motion_was_doubted() {
        let step = Pose2::new(1.0, 0.0, 0.0);
        let steps_after = |doubt: f64| {
            let mut poses: Vec<Pose2> = (0..7).map(|i| Pose2::new(i as f64, 0.0, 0.0)).collect();
            let mut edges: Vec<Edge> = (0..6)
                .map(|i| Edge {
                    doubt_m2: match i {
                        2 | 3 => DMat2::from_cols(DVec2::new(doubt, 0.0), DVec2::ZERO),
                        _ => DMat2::ZERO,
                    },
                    ..edge(i, i + 1, step, false)
                })
                .collect();
            edges.push(edge(0, 6, Pose2::new(5.6, 0.0, 0.0), false));
            optimize(&mut poses, &edges, 1..7, 20);
            (0..6)
                .map(|i| poses[i + 1].x_m - poses[i].x_m)
                .collect::<Vec<_>>()
        };
        let doubted = steps_after(0.5 * 0.5);
        for (i, s) in doubted.iter().enumerate() {
            match i {
                2 | 3 => assert!((s - 0.8).abs() < 0.01, "step {i}: {doubted:?}"),
                _ => assert!((s - 1.0).abs() < 0.01, "step {i}: {doubted:?}"),
            }
        }
        let even = steps_after(0.0);
        for s in &even {
            assert!((s - 5.6 / 6.0).abs() < 0.01, "{even:?}");
        }
    }

    /// Numerical Jacobians agree with the analytic ones.
    #[test]
    fn jacobians_match_finite_differences() {
        let e = edge(0, 1, Pose2::new(0.7, -0.2, 0.3), false);
        let a = Pose2::new(1.0, 2.0, 0.4);
        let b = Pose2::new(1.5, 2.8, 0.9);
        let (r0, ja, jb) = residual(&e, &a, &b);
        let h = 1e-6;
        for k in 0..3 {
            let bump = |p: &Pose2| {
                let mut v = [p.x_m, p.y_m, p.theta_rad];
                v[k] += h;
                Pose2::new(v[0], v[1], v[2])
            };
            let (ra, _, _) = residual(&e, &bump(&a), &b);
            let (rb, _, _) = residual(&e, &a, &bump(&b));
            for row in 0..3 {
                assert!(
                    ((ra[row] - r0[row]) / h - ja.col(k)[row]).abs() < 1e-4,
                    "ja[{row}][{k}]"
                );
                assert!(
                    ((rb[row] - r0[row]) / h - jb.col(k)[row]).abs() < 1e-4,
                    "jb[{row}][{k}]"
                );
            }
        }
    }

    /// A square loop of four 2 m steps whose odometry turns 92° instead of 90°: the loop edge
    /// pulls the corners back onto a square, spreading the error.
    #[test]
    fn a_loop_edge_closes_a_square() {
        let turn = 92f64.to_radians();
        let step = Pose2::new(2.0, 0.0, turn);
        let mut poses = vec![Pose2::IDENTITY];
        for _ in 0..4 {
            let last = *poses.last().unwrap();
            poses.push(last.compose(&step));
        }
        let mut edges: Vec<Edge> = (0..4).map(|i| edge(i, i + 1, step, false)).collect();
        // The last node is the first again (a plain edge: 8° off is an outlier to the kernel
        // at these deviations).
        edges.push(edge(0, 4, Pose2::IDENTITY, false));
        let before = poses[4].translation().length();
        assert!(before > 0.1);
        optimize(&mut poses, &edges, 1..5, 20);
        let after = poses[4].translation().length();
        assert!(after < 0.05 * before, "{before} -> {after}");
        // The corners are near the unit square's.
        let square = [(2.0, 0.0), (2.0, 2.0), (0.0, 2.0)];
        for (p, (x, y)) in poses[1..4].iter().zip(square) {
            assert!((p.x_m - x).hypot(p.y_m - y) < 0.1, "{p:?}");
        }
        // Node 0 was not free.
        assert_eq!(poses[0], Pose2::IDENTITY);
    }

    /// One wrong loop edge among consistent ones is down-weighted by the robust kernel.
    #[test]
    fn a_wrong_loop_edge_is_down_weighted() {
        let step = Pose2::new(1.0, 0.0, 0.0);
        let mut poses: Vec<Pose2> = (0..6).map(|i| Pose2::new(i as f64, 0.0, 0.0)).collect();
        let mut edges: Vec<Edge> = (0..5).map(|i| edge(i, i + 1, step, false)).collect();
        edges.push(edge(0, 5, Pose2::new(5.0, 0.0, 0.0), true));
        edges.push(edge(1, 4, Pose2::new(3.0, 0.0, 0.0), true));
        edges.push(edge(0, 4, Pose2::new(6.0, 2.0, 0.5), true));
        optimize(&mut poses, &edges, 1..6, 20);
        assert!(
            (poses[5].x_m - 5.0).abs() < 0.2 && poses[5].y_m.abs() < 0.2,
            "{:?}",
            poses[5]
        );
    }

    /// Conjugate gradients solve a small system exactly.
    #[test]
    fn block_solver_solves() {
        let d = DMat3::from_cols_array_2d(&[[4.0, 1.0, 0.0], [1.0, 3.0, 0.5], [0.0, 0.5, 2.0]]);
        let o = DMat3::from_cols_array_2d(&[[0.5, 0.0, 0.1], [0.0, 0.2, 0.0], [0.3, 0.0, 0.4]]);
        let g = vec![DVec3::new(1.0, 2.0, 3.0), DVec3::new(-1.0, 0.5, 0.0)];
        let x = solve(&[d, d], &[(0, 1, o)], &g, 100);
        let y0 = d * x[0] + o * x[1];
        let y1 = d * x[1] + o.transpose() * x[0];
        for k in 0..3 {
            assert!((y0[k] - g[0][k]).abs() < 1e-9 && (y1[k] - g[1][k]).abs() < 1e-9);
        }
    }
}
