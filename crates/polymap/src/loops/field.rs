//! A raster of the soft inlier score around a set of segments, for scoring many candidate
//! poses quickly (the grid search of loop matching).

use crate::geometry::{Pose2, Segment, Vec2};

/// Most cells of one field; a larger extent gets coarser cells (bounded memory).
const MAX_CELLS: usize = 1 << 20;

/// Per cell, `max(0, 1 − d²/σ²)` for `d` the distance from the cell's centre to the nearest
/// segment: the score [`crate::align::fit_score`] gives a point there, to within the cell size.
#[derive(Debug, Clone)]
pub struct ScoreField {
    origin: Vec2,
    cell_m: f64,
    width: usize,
    height: usize,
    values: Vec<f32>,
}

impl ScoreField {
    /// The field of `segments` (any frame) for the score's scale `sigma_m`, with cells of
    /// `cell_m` (coarser when the extent would need more than about a million cells).
    pub fn new(segments: &[Segment], sigma_m: f64, cell_m: f64) -> Self {
        let mut lo = Vec2::splat(f64::INFINITY);
        let mut hi = Vec2::splat(f64::NEG_INFINITY);
        for s in segments {
            lo = lo.min(s.start).min(s.end);
            hi = hi.max(s.start).max(s.end);
        }
        if !(lo.x.is_finite() && hi.x.is_finite() && lo.y.is_finite() && hi.y.is_finite()) {
            return ScoreField {
                origin: Vec2::ZERO,
                cell_m: 1.0,
                width: 0,
                height: 0,
                values: Vec::new(),
            };
        }
        let origin = lo - Vec2::splat(sigma_m);
        let extent = hi + Vec2::splat(sigma_m) - origin;
        let mut cell = cell_m.max(1e-3);
        while (extent.x / cell + 1.0) * (extent.y / cell + 1.0) > MAX_CELLS as f64 {
            cell *= 2.0;
        }
        let width = (extent.x / cell).ceil() as usize + 1;
        let height = (extent.y / cell).ceil() as usize + 1;
        let mut values = vec![0f32; width * height];
        let sigma_2 = sigma_m * sigma_m;
        for s in segments {
            // Rows of cells within σ of the segment: for each row, the span of x where the
            // segment (widened by σ) crosses it, instead of the whole bounding box.
            let a = s.start.min(s.end) - Vec2::splat(sigma_m) - origin;
            let b = s.start.max(s.end) + Vec2::splat(sigma_m) - origin;
            let y0 = (a.y / cell).floor().max(0.0) as usize;
            let y1 = ((b.y / cell).ceil() as usize).min(height - 1);
            let (p, q) = (s.start - origin, s.end - origin);
            for y in y0..=y1 {
                let (ylo, yhi) = (y as f64 * cell - sigma_m, (y + 1) as f64 * cell + sigma_m);
                let (xlo, xhi) = x_span(p, q, ylo, yhi);
                let x0 = ((xlo - sigma_m) / cell).floor().max(0.0) as usize;
                let x1 = (((xhi + sigma_m) / cell).ceil().max(0.0) as usize).min(width - 1);
                for x in x0..=x1 {
                    let c = origin + Vec2::new((x as f64 + 0.5) * cell, (y as f64 + 0.5) * cell);
                    let v = 1.0 - s.distance_2_to_point(c) / sigma_2;
                    let slot = &mut values[y * width + x];
                    if v > *slot as f64 {
                        *slot = v as f32;
                    }
                }
            }
        }
        ScoreField {
            origin,
            cell_m: cell,
            width,
            height,
            values,
        }
    }

    /// The score of one point (the field's frame); 0 outside the field.
    pub fn at(&self, p: Vec2) -> f64 {
        let q = (p - self.origin) / self.cell_m;
        if !(q.x >= 0.0 && q.y >= 0.0) {
            return 0.0;
        }
        let (x, y) = (q.x as usize, q.y as usize);
        if x >= self.width || y >= self.height {
            return 0.0;
        }
        self.values[y * self.width + x] as f64
    }

    /// The summed score of `points` (their own frame) placed at `field_from_points`.
    pub fn score(&self, points: &[Vec2], field_from_points: &Pose2) -> f64 {
        points
            .iter()
            .map(|p| self.at(field_from_points.transform_point(*p)))
            .sum()
    }
}

/// A grid of poses around a centre: translations `±steps_xy × step_m` along x and y, rotations
/// `rotations × step_rad` added to the centre's heading.
#[derive(Debug, Clone)]
pub(crate) struct PoseGrid {
    pub center: Pose2,
    pub steps_xy: i32,
    pub step_m: f64,
    pub rotations: std::ops::Range<i32>,
    pub step_rad: f64,
}

impl ScoreField {
    /// Every pose of `grid` with the summed score of `sample` (robot frame) placed there, best
    /// first (ties in grid order).
    pub(crate) fn scored_grid(&self, sample: &[Vec2], grid: &PoseGrid) -> Vec<(f64, Pose2)> {
        let c = grid.center;
        let mut scored = Vec::new();
        for ir in grid.rotations.clone() {
            let theta = c.theta_rad + ir as f64 * grid.step_rad;
            for ix in -grid.steps_xy..=grid.steps_xy {
                for iy in -grid.steps_xy..=grid.steps_xy {
                    let pose = Pose2::new(
                        c.x_m + ix as f64 * grid.step_m,
                        c.y_m + iy as f64 * grid.step_m,
                        theta,
                    );
                    scored.push((self.score(sample, &pose), pose));
                }
            }
        }
        scored.sort_by(|a, b| b.0.total_cmp(&a.0));
        scored
    }
}

/// Greedy peaks of `scored` (best first): each pose more than `apart_m` or `apart_rad` from
/// every one taken before (starting with `taken`), at most `max` new ones, none scoring below
/// `min_score`.
pub(crate) fn distinct_peaks(
    scored: &[(f64, Pose2)],
    taken: &[Pose2],
    apart_m: f64,
    apart_rad: f64,
    max: usize,
    min_score: f64,
) -> Vec<Pose2> {
    let mut all = taken.to_vec();
    for (score, pose) in scored {
        if all.len() >= taken.len() + max || *score < min_score {
            break;
        }
        let apart = |p: &Pose2| {
            let d = p.between(pose);
            d.translation().length() > apart_m || d.theta_rad.abs() > apart_rad
        };
        if all.iter().all(apart) {
            all.push(*pose);
        }
    }
    all.split_off(taken.len())
}

/// The range of x of the segment `p`–`q` where its y lies in `[ylo, yhi]` (the whole segment's
/// x range when it is horizontal).
fn x_span(p: Vec2, q: Vec2, ylo: f64, yhi: f64) -> (f64, f64) {
    let dy = q.y - p.y;
    if dy.abs() < 1e-12 {
        return (p.x.min(q.x), p.x.max(q.x));
    }
    let t0 = ((ylo - p.y) / dy).clamp(0.0, 1.0);
    let t1 = ((yhi - p.y) / dy).clamp(0.0, 1.0);
    let (xa, xb) = (p.x + t0 * (q.x - p.x), p.x + t1 * (q.x - p.x));
    (xa.min(xb), xa.max(xb))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::align::{AlignParams, SegmentIndex, fit_score};

    #[test]
    fn field_scores_like_fit_score_within_a_cell() {
        let segs = vec![
            Segment::new(Vec2::new(0.0, 0.0), Vec2::new(4.0, 0.0)),
            Segment::new(Vec2::new(4.0, 0.0), Vec2::new(4.0, 3.0)),
        ];
        let params = AlignParams::default();
        let field = ScoreField::new(&segs, params.rotation_search_sigma_m, 0.02);
        let index = SegmentIndex::new(segs);
        let points: Vec<Vec2> = (0..40)
            .map(|i| Vec2::new(0.1 * i as f64, 0.05 + 0.003 * i as f64))
            .collect();
        for pose in [
            Pose2::IDENTITY,
            Pose2::new(0.1, -0.05, 0.02),
            Pose2::new(3.0, 2.0, 1.0),
        ] {
            let exact = fit_score(&points, &index, &pose, &params);
            let fast = field.score(&points, &pose);
            assert!(
                (exact - fast).abs() < 0.05 * points.len() as f64,
                "{exact} vs {fast}"
            );
        }
        assert_eq!(field.at(Vec2::new(-10.0, 0.0)), 0.0);
        assert_eq!(field.at(Vec2::new(f64::NAN, 0.0)), 0.0);
    }

    #[test]
    fn peaks_are_apart_from_each_other_and_from_the_taken() {
        let p = |x: f64, deg: f64| Pose2::new(x, 0.0, deg.to_radians());
        let scored = vec![
            (9.0, p(0.0, 0.0)),
            (8.0, p(0.1, 0.0)),
            (7.0, p(1.0, 0.0)),
            (6.0, p(1.0, 10.0)),
            (2.0, p(3.0, 0.0)),
        ];
        // The second is within 0.5 m of the first; the fourth is apart by its rotation.
        let peaks = distinct_peaks(&scored, &[], 0.5, 5f64.to_radians(), 3, 5.0);
        assert_eq!(peaks, vec![p(0.0, 0.0), p(1.0, 0.0), p(1.0, 10.0)]);
        // A taken pose excludes its neighbours; the low score ends the list.
        let peaks = distinct_peaks(&scored, &[p(1.1, 0.0)], 0.5, 5f64.to_radians(), 5, 5.0);
        assert_eq!(peaks, vec![p(0.0, 0.0), p(1.0, 10.0)]);
    }

    #[test]
    fn a_huge_extent_gets_coarser_cells() {
        let segs = vec![Segment::new(Vec2::new(0.0, 0.0), Vec2::new(1e4, 1e4))];
        let field = ScoreField::new(&segs, 0.3, 0.1);
        assert!(field.values.len() <= 2 * MAX_CELLS);
        assert!(ScoreField::new(&[], 0.3, 0.1).at(Vec2::ZERO) == 0.0);
    }
}
