//! Small construction helpers shared by the built-in worlds.

use polymap::geometry::{Segment, Vec2};

/// Shortest wall kept when a helper would produce a degenerate one, metres.
const MIN_WALL_M: f64 = 1e-6;

/// A niche cut into a wall: a rectangular or trapezoidal recess (or a doorway-less alcove).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Niche {
    /// Distance from the edge's start to the middle of the niche's mouth, metres.
    pub at_m: f64,
    /// Width of the mouth, metres.
    pub width_m: f64,
    /// Depth, metres; positive to the right of the edge's direction (outward for a
    /// counter-clockwise polygon), negative to the left.
    pub depth_m: f64,
    /// Angle between the wall and the niche's sides, radians (π/2: rectangular).
    pub side_angle_rad: f64,
}

impl Niche {
    /// A rectangular niche.
    pub(crate) fn rect(at_m: f64, width_m: f64, depth_m: f64) -> Niche {
        Niche {
            at_m,
            width_m,
            depth_m,
            side_angle_rad: std::f64::consts::FRAC_PI_2,
        }
    }

    /// A trapezoidal niche whose sides make 60° with the wall (walls stay on a 60° lattice).
    pub(crate) fn hex(at_m: f64, width_m: f64, depth_m: f64) -> Niche {
        Niche {
            at_m,
            width_m,
            depth_m,
            side_angle_rad: std::f64::consts::FRAC_PI_3,
        }
    }

    /// The niche's vertices between the wall's `a` and `b`, in order from `a`.
    fn points(&self, a: Vec2, b: Vec2) -> Vec<Vec2> {
        let e = (b - a).normalize_or_zero();
        let n_right = Vec2::new(e.y, -e.x);
        let p1 = a + e * (self.at_m - self.width_m / 2.0);
        let p2 = a + e * (self.at_m + self.width_m / 2.0);
        let inset = (self.depth_m.abs() / self.side_angle_rad.tan()).min(self.width_m / 2.0);
        let depth = if inset * 2.0 >= self.width_m {
            // The sides meet before the full depth: a triangle.
            self.depth_m.signum() * self.width_m / 2.0 * self.side_angle_rad.tan()
        } else {
            self.depth_m
        };
        let q1 = p1 + e * inset + n_right * depth;
        let q2 = p2 - e * inset + n_right * depth;
        vec![p1, q1, q2, p2]
    }
}

/// The vertices along one polygon edge from `a` (included) to `b` (excluded), niches cut in.
pub(crate) fn edge_points(a: Vec2, b: Vec2, niches: &[Niche]) -> Vec<Vec2> {
    let mut sorted: Vec<Niche> = niches.to_vec();
    sorted.sort_by(|x, y| x.at_m.total_cmp(&y.at_m));
    let mut out = vec![a];
    for niche in &sorted {
        out.extend(niche.points(a, b));
    }
    out
}

/// Walls along an open chain of points, degenerate pieces dropped.
pub(crate) fn chain_walls(points: &[Vec2]) -> Vec<Segment> {
    points
        .windows(2)
        .map(|w| Segment::new(w[0], w[1]))
        .filter(|s| s.length() > MIN_WALL_M)
        .collect()
}

/// Walls around a closed polygon, degenerate pieces dropped.
pub(crate) fn closed_walls(points: &[Vec2]) -> Vec<Segment> {
    let mut closed = points.to_vec();
    if let Some(&first) = points.first() {
        closed.push(first);
    }
    chain_walls(&closed)
}

/// A closed polygon's walls with niches: `niches[i]` lists the niches of edge `i`
/// (from vertex `i` to vertex `i + 1`).
pub(crate) fn polygon_with_niches(vertices: &[Vec2], niches: &[(usize, Niche)]) -> Vec<Segment> {
    let n = vertices.len();
    let mut points = Vec::new();
    for i in 0..n {
        let on_edge: Vec<Niche> = niches
            .iter()
            .filter(|(e, _)| *e == i)
            .map(|(_, k)| *k)
            .collect();
        points.extend(edge_points(vertices[i], vertices[(i + 1) % n], &on_edge));
    }
    closed_walls(&points)
}

/// A polygon offset by `d_m` to the right of its edges (outward for counter-clockwise), by
/// intersecting neighbouring offset edges (miter joins).
pub(crate) fn offset_polygon(vertices: &[Vec2], d_m: f64) -> Vec<Vec2> {
    let n = vertices.len();
    let right = |a: Vec2, b: Vec2| {
        let e = (b - a).normalize_or_zero();
        Vec2::new(e.y, -e.x)
    };
    (0..n)
        .map(|i| {
            let prev = vertices[(i + n - 1) % n];
            let v = vertices[i];
            let next = vertices[(i + 1) % n];
            let (n1, n2) = (right(prev, v), right(v, next));
            v + (n1 + n2) * (d_m / (1.0 + n1.dot(n2)))
        })
        .collect()
}

/// A straight wall broken by doorways: `doors` are `(start, end)` distances along the wall
/// from `a`, metres.
pub(crate) fn wall_with_doors(a: Vec2, b: Vec2, doors: &[(f64, f64)]) -> Vec<Segment> {
    let e = (b - a).normalize_or_zero();
    let mut cursor = 0.0;
    let mut out = Vec::new();
    for &(d0, d1) in doors {
        out.push(Segment::new(a + e * cursor, a + e * d0));
        cursor = d1;
    }
    out.push(Segment::new(a + e * cursor, b));
    out.retain(|s| s.length() > MIN_WALL_M);
    out
}

/// The four walls of a box with half extents `(hx, hy)` metres, rotated by `angle_rad` about
/// its centre.
pub(crate) fn rotated_box(center: Vec2, hx: f64, hy: f64, angle_rad: f64) -> Vec<Segment> {
    let (s, c) = angle_rad.sin_cos();
    let corner = |x: f64, y: f64| center + Vec2::new(c * x - s * y, s * x + c * y);
    closed_walls(&[
        corner(-hx, -hy),
        corner(hx, -hy),
        corner(hx, hy),
        corner(-hx, hy),
    ])
}

/// Shorthand for a point.
pub(crate) fn v(x: f64, y: f64) -> Vec2 {
    Vec2::new(x, y)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_square_grows_by_d() {
        let sq = [v(0.0, 0.0), v(2.0, 0.0), v(2.0, 2.0), v(0.0, 2.0)];
        let out = offset_polygon(&sq, 0.5);
        assert!((out[0] - v(-0.5, -0.5)).length() < 1e-12);
        assert!((out[2] - v(2.5, 2.5)).length() < 1e-12);
    }

    #[test]
    fn rectangular_niche_goes_right_of_edge() {
        let pts = edge_points(v(0.0, 0.0), v(4.0, 0.0), &[Niche::rect(2.0, 1.0, 0.5)]);
        assert_eq!(
            pts,
            vec![
                v(0.0, 0.0),
                v(1.5, 0.0),
                v(1.5, -0.5),
                v(2.5, -0.5),
                v(2.5, 0.0)
            ]
        );
    }

    #[test]
    fn hex_niche_sides_are_at_sixty_degrees() {
        let pts = edge_points(v(0.0, 0.0), v(4.0, 0.0), &[Niche::hex(2.0, 2.0, 0.5)]);
        let side = pts[2] - pts[1];
        assert!((side.y.atan2(side.x).abs() - std::f64::consts::FRAC_PI_3).abs() < 1e-12);
    }

    #[test]
    fn doors_split_a_wall_into_collinear_pieces() {
        let walls = wall_with_doors(v(0.0, 0.0), v(10.0, 0.0), &[(2.0, 2.9), (6.0, 6.9)]);
        assert_eq!(walls.len(), 3);
        let total: f64 = walls.iter().map(Segment::length).sum();
        assert!((total - 8.2).abs() < 1e-12);
    }

    #[test]
    fn rotated_box_has_four_equal_pairs() {
        let walls = rotated_box(v(1.0, 1.0), 1.0, 0.5, 0.3);
        assert_eq!(walls.len(), 4);
        assert!((walls[0].length() - 2.0).abs() < 1e-12 && (walls[1].length() - 1.0).abs() < 1e-12);
    }
}
