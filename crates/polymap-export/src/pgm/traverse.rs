//! Grid traversal of a line segment (Amanatides & Woo, 1987), clipped to the grid.
//!
//! Coordinates here are in *cell units*: the grid covers `[0, width] × [0, height]`, cell
//! `(col, row)` covers `[col, col + 1) × [row, row + 1)`.

use polymap::geometry::Vec2;

/// Visits every cell that the segment `a → b` (cell units) passes through inside a
/// `width × height` grid, in order from `a`. The flag passed to `visit` is true for the cell
/// that contains `b` when `b` lies inside the grid (the "hit" cell of a ray), false otherwise.
///
/// Segments are clipped to the grid first; nothing is visited for a segment outside it or with
/// non-finite ends. At most `|Δcol| + |Δrow| + 1` cells are visited, so floating-point noise
/// cannot make the walk run away.
pub(crate) fn for_each_cell(
    a: Vec2,
    b: Vec2,
    width: usize,
    height: usize,
    mut visit: impl FnMut(usize, usize, bool),
) {
    let size = Vec2::new(width as f64, height as f64);
    let Some((t0, t1)) = clip_to_box(a, b, size) else {
        return;
    };
    let d = b - a;
    let (start, end) = (a + d * t0, a + d * t1);
    let end_is_b = t1 >= 1.0;
    let cell = |p: Vec2| (to_index(p.x, width), to_index(p.y, height));
    let (mut col, mut row) = cell(start);
    let (last_col, last_row) = cell(end);
    let (step_col, delta_col, mut next_col) = axis_setup(start.x, end.x, col);
    let (step_row, delta_row, mut next_row) = axis_setup(start.y, end.y, row);
    let steps = last_col.abs_diff(col) + last_row.abs_diff(row);
    for _ in 0..=steps {
        let at_last = (col, row) == (last_col, last_row);
        visit(col, row, at_last && end_is_b);
        if at_last {
            return;
        }
        if next_col < next_row {
            col = step(col, step_col, width);
            next_col += delta_col;
        } else {
            row = step(row, step_row, height);
            next_row += delta_row;
        }
    }
}

/// The cell index of a coordinate, clamped into `0..n`.
fn to_index(x: f64, n: usize) -> usize {
    let max = n.saturating_sub(1);
    if x <= 0.0 {
        0
    } else {
        (x.floor() as usize).min(max)
    }
}

/// Moves an index one step (−1, 0, +1), staying inside `0..n`.
fn step(i: usize, direction: i8, n: usize) -> usize {
    match direction {
        1 => (i + 1).min(n.saturating_sub(1)),
        -1 => i.saturating_sub(1),
        _ => i,
    }
}

/// For one axis from `s` to `e` (parameter t in [0, 1]) starting in cell `i`: the step
/// direction, the t needed to cross one cell, and the t of the first cell boundary.
fn axis_setup(s: f64, e: f64, i: usize) -> (i8, f64, f64) {
    let d = e - s;
    if d > 0.0 {
        (1, 1.0 / d, ((i + 1) as f64 - s) / d)
    } else if d < 0.0 {
        (-1, -1.0 / d, (s - i as f64) / -d)
    } else {
        (0, f64::INFINITY, f64::INFINITY)
    }
}

/// Liang–Barsky clipping of `a + t (b − a)`, t ∈ [0, 1], to `[0, size.x] × [0, size.y]`.
fn clip_to_box(a: Vec2, b: Vec2, size: Vec2) -> Option<(f64, f64)> {
    if !(a.is_finite() && b.is_finite()) {
        return None;
    }
    let d = b - a;
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-d.x, a.x),
        (d.x, size.x - a.x),
        (-d.y, a.y),
        (d.y, size.y - a.y),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    (t0 <= t1).then_some((t0, t1))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cells(a: Vec2, b: Vec2, w: usize, h: usize) -> Vec<(usize, usize, bool)> {
        let mut out = Vec::new();
        for_each_cell(a, b, w, h, |c, r, hit| out.push((c, r, hit)));
        out
    }

    #[test]
    fn horizontal_ray_visits_each_cell_once_and_flags_the_hit() {
        let got = cells(Vec2::new(0.5, 1.5), Vec2::new(3.5, 1.5), 5, 3);
        assert_eq!(
            got,
            vec![(0, 1, false), (1, 1, false), (2, 1, false), (3, 1, true)]
        );
    }

    #[test]
    fn diagonal_ray_is_four_connected() {
        let got = cells(Vec2::new(0.2, 0.1), Vec2::new(2.9, 2.7), 4, 4);
        for w in got.windows(2) {
            let (a, b) = (w[0], w[1]);
            assert_eq!(a.0.abs_diff(b.0) + a.1.abs_diff(b.1), 1, "{got:?}");
        }
        assert_eq!(got.first().map(|c| (c.0, c.1)), Some((0, 0)));
        assert_eq!(got.last(), Some(&(2, 2, true)));
    }

    #[test]
    fn ray_leaving_the_grid_is_clipped_and_has_no_hit() {
        let got = cells(Vec2::new(-5.0, 0.5), Vec2::new(10.0, 0.5), 3, 1);
        assert_eq!(got, vec![(0, 0, false), (1, 0, false), (2, 0, false)]);
        assert!(cells(Vec2::new(-5.0, -1.0), Vec2::new(10.0, -1.0), 3, 1).is_empty());
        assert!(cells(Vec2::NAN, Vec2::new(1.0, 1.0), 3, 1).is_empty());
    }

    #[test]
    fn point_ray_visits_its_own_cell() {
        let got = cells(Vec2::new(1.5, 1.5), Vec2::new(1.5, 1.5), 3, 3);
        assert_eq!(got, vec![(1, 1, true)]);
    }
}
