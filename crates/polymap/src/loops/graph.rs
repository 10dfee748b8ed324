//! A 2D pose graph and its least-squares solution (Gauss–Newton, preconditioned conjugate
//! gradients on the sparse normal equations, Cauchy weights on loop edges).

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
    /// A loop edge gets a robust (Cauchy) weight; a sequential edge is trusted.
    pub robust: bool,
}

/// Scale of the Cauchy weight on loop edges, in standard deviations.
const CAUCHY_SCALE: f64 = 3.0;

type M3 = [[f64; 3]; 3];
type V3 = [f64; 3];

/// The residual of an edge at the given node poses, in the measurement's frame
/// (`measured⁻¹ ∘ (from⁻¹ ∘ to)`), with its Jacobians with respect to `from` and `to`
/// (x, y, θ in the map frame).
fn residual(e: &Edge, a: &Pose2, b: &Pose2) -> (V3, M3, M3) {
    let (sa, ca) = a.theta_rad.sin_cos();
    let (sz, cz) = e.measured.theta_rad.sin_cos();
    let dx = b.x_m - a.x_m;
    let dy = b.y_m - a.y_m;
    // Translation of b in a's frame.
    let tx = ca * dx + sa * dy;
    let ty = -sa * dx + ca * dy;
    let ux = tx - e.measured.x_m;
    let uy = ty - e.measured.y_m;
    let r = [
        cz * ux + sz * uy,
        -sz * ux + cz * uy,
        normalize_angle_rad(b.theta_rad - a.theta_rad - e.measured.theta_rad),
    ];
    // d(tx, ty)/d(a.x, a.y) = -R_a^T; d/d(a.θ) = (ty, -tx); d/d(b.x, b.y) = R_a^T.
    let rz = |vx: f64, vy: f64| [cz * vx + sz * vy, -sz * vx + cz * vy];
    let c0 = rz(-ca, sa);
    let c1 = rz(-sa, -ca);
    let c2 = rz(ty, -tx);
    let ja = [
        [c0[0], c1[0], c2[0]],
        [c0[1], c1[1], c2[1]],
        [0.0, 0.0, -1.0],
    ];
    let d0 = rz(ca, -sa);
    let d1 = rz(sa, ca);
    let jb = [[d0[0], d1[0], 0.0], [d0[1], d1[1], 0.0], [0.0, 0.0, 1.0]];
    (r, ja, jb)
}

/// `Jᵀ W J` and `Jᵀ W r` pieces for diagonal `W`.
fn jt_w_j(j1: &M3, w: &V3, j2: &M3) -> M3 {
    let mut m = [[0.0; 3]; 3];
    for (r, row) in m.iter_mut().enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            *v = (0..3).map(|k| j1[k][r] * w[k] * j2[k][c]).sum();
        }
    }
    m
}

fn mul(m: &M3, v: &V3) -> V3 {
    [0, 1, 2].map(|r| m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2])
}

fn mul_t(m: &M3, v: &V3) -> V3 {
    [0, 1, 2].map(|c| m[0][c] * v[0] + m[1][c] * v[1] + m[2][c] * v[2])
}

fn add(a: &mut V3, b: &V3) {
    a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
}

fn dot(a: &[V3], b: &[V3]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| x[0] * y[0] + x[1] * y[1] + x[2] * y[2])
        .sum()
}

/// The inverse of a symmetric positive definite 3×3 matrix (the identity when singular).
fn inverse(m: &M3) -> M3 {
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    if det.abs() <= 1e-300 || !det.is_finite() {
        return [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    }
    let c =
        |r1: usize, r2: usize, c1: usize, c2: usize| m[r1][c1] * m[r2][c2] - m[r1][c2] * m[r2][c1];
    let adj = [
        [c(1, 2, 1, 2), -c(0, 2, 1, 2), c(0, 1, 1, 2)],
        [-c(1, 2, 0, 2), c(0, 2, 0, 2), -c(0, 1, 0, 2)],
        [c(1, 2, 0, 1), -c(0, 2, 0, 1), c(0, 1, 0, 1)],
    ];
    adj.map(|row| row.map(|v| v / det))
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
    let index = |i: usize| free.contains(&i).then(|| i - free.start);
    for iteration in 0..max_iterations {
        let mut diag = vec![[[0.0; 3]; 3]; n];
        let mut off: Vec<(usize, usize, M3)> = Vec::new();
        let mut g = vec![[0.0; 3]; n];
        for e in &active {
            let (r, ja, jb) = residual(e, &poses[e.from], &poses[e.to]);
            let wt = 1.0 / (e.sigma_m * e.sigma_m);
            let wr = 1.0 / (e.sigma_rad * e.sigma_rad);
            let mut w = [wt, wt, wr];
            if e.robust {
                let chi2 = r[0] * r[0] * wt + r[1] * r[1] * wt + r[2] * r[2] * wr;
                let k = 1.0 / (1.0 + chi2 / (CAUCHY_SCALE * CAUCHY_SCALE));
                w = w.map(|x| x * k);
            }
            let wr_v = [w[0] * r[0], w[1] * r[1], w[2] * r[2]];
            let (ia, ib) = (index(e.from), index(e.to));
            for (i, j) in [(ia, &ja), (ib, &jb)] {
                if let Some(i) = i {
                    let h = jt_w_j(j, &w, j);
                    diag[i]
                        .iter_mut()
                        .flatten()
                        .zip(h.iter().flatten())
                        .for_each(|(x, y)| *x += y);
                    add(&mut g[i], &mul_t(j, &wr_v));
                }
            }
            if let (Some(a), Some(b)) = (ia, ib) {
                off.push((a, b, jt_w_j(&ja, &w, &jb)));
            }
        }
        // A weak prior keeps every block invertible (a node seen by nothing stays put).
        for d in &mut diag {
            for (k, row) in d.iter_mut().enumerate() {
                row[k] += 1e-6;
            }
        }
        let step = solve(&diag, &off, &g, 2 * n + 50);
        let mut largest: f64 = 0.0;
        for (k, s) in step.iter().enumerate() {
            let p = &mut poses[free.start + k];
            *p = Pose2::new(p.x_m - s[0], p.y_m - s[1], p.theta_rad - s[2]);
            largest = largest.max(s[0].hypot(s[1])).max(s[2].abs());
        }
        if largest < 1e-4 {
            return iteration + 1;
        }
    }
    max_iterations
}

/// Solves `H x = g` for the block-sparse symmetric `H` (diagonal blocks and upper blocks
/// `(a, b, H_ab)`) by conjugate gradients with a block-Jacobi preconditioner.
fn solve(diag: &[M3], off: &[(usize, usize, M3)], g: &[V3], max_iterations: usize) -> Vec<V3> {
    let n = diag.len();
    let apply = |x: &[V3]| -> Vec<V3> {
        let mut y: Vec<V3> = diag.iter().zip(x).map(|(d, v)| mul(d, v)).collect();
        for (a, b, h) in off {
            add(&mut y[*a], &mul(h, &x[*b]));
            add(&mut y[*b], &mul_t(h, &x[*a]));
        }
        y
    };
    let pre: Vec<M3> = diag.iter().map(inverse).collect();
    let mut x = vec![[0.0; 3]; n];
    let mut r = g.to_vec();
    let mut z: Vec<V3> = pre.iter().zip(&r).map(|(p, v)| mul(p, v)).collect();
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
            for c in 0..3 {
                x[k][c] += alpha * p[k][c];
                r[k][c] -= alpha * hp[k][c];
            }
        }
        z = pre.iter().zip(&r).map(|(pm, v)| mul(pm, v)).collect();
        let rz_next = dot(&r, &z);
        let beta = rz_next / rz;
        rz = rz_next;
        for k in 0..n {
            for c in 0..3 {
                p[k][c] = z[k][c] + beta * p[k][c];
            }
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
            robust,
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
                    ((ra[row] - r0[row]) / h - ja[row][k]).abs() < 1e-4,
                    "ja[{row}][{k}]"
                );
                assert!(
                    ((rb[row] - r0[row]) / h - jb[row][k]).abs() < 1e-4,
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
        let d = [[4.0, 1.0, 0.0], [1.0, 3.0, 0.5], [0.0, 0.5, 2.0]];
        let o = [[0.5, 0.0, 0.1], [0.0, 0.2, 0.0], [0.3, 0.0, 0.4]];
        let g = vec![[1.0, 2.0, 3.0], [-1.0, 0.5, 0.0]];
        let x = solve(&[d, d], &[(0, 1, o)], &g, 100);
        let y0: V3 = {
            let mut v = mul(&d, &x[0]);
            add(&mut v, &mul(&o, &x[1]));
            v
        };
        let y1: V3 = {
            let mut v = mul(&d, &x[1]);
            add(&mut v, &mul_t(&o, &x[0]));
            v
        };
        for k in 0..3 {
            assert!((y0[k] - g[0][k]).abs() < 1e-9 && (y1[k] - g[1][k]).abs() < 1e-9);
        }
    }
}
