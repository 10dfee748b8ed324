//! A likelihood raster of a map: per cell, how well a scan point there would be explained.
//!
//! The value of a cell is `max(0, 1 − d²/σ²)` for `d` the distance from the cell's centre to
//! the nearest segment or loose point drawn into it: the soft inlier score that
//! [`crate::align::fit_score`] gives a point, to within the cell size. Loose points are scan
//! points that form no segment (pillars, corners, door frames): a map of segments alone would
//! not see them, and in a bare corridor they are what fixes the position along it.

use super::buffers::Buffer;
use crate::geometry::{Segment, Vec2, floor_i64};

/// Most cells of one raster; a larger extent gets coarser cells (bounded memory: 4 MiB).
pub const MAX_RASTER_CELLS: usize = 1 << 20;

/// A likelihood raster over an axis-aligned box of the map frame.
#[derive(Debug, Clone, PartialEq)]
pub struct ScoreRaster {
    origin: Vec2,
    cell_m: f64,
    sigma_m: f64,
    width: usize,
    height: usize,
    /// Given back for reuse when dropped ([`super::buffers`]).
    values: Buffer,
    /// The map-frame x of every column's centre, `origin.x + (x + 0.5) × cell`, computed once
    /// (for [`ScoreRaster::add_segment`]).
    centres_x: Vec<f64>,
}

impl ScoreRaster {
    /// An empty raster (all zero) covering `lo..hi` (map frame, metres) widened by `sigma_m`,
    /// with cells of `cell_m` metres, doubled until the raster has at most
    /// [`MAX_RASTER_CELLS`] cells. A box that is not finite gives a raster with no cells.
    pub fn new(lo: Vec2, hi: Vec2, cell_m: f64, sigma_m: f64) -> Self {
        let sigma_m = sigma_m.max(1e-6);
        if !(lo.is_finite() && hi.is_finite() && lo.x <= hi.x && lo.y <= hi.y) {
            return ScoreRaster {
                origin: Vec2::ZERO,
                cell_m: cell_m.max(1e-3),
                sigma_m,
                width: 0,
                height: 0,
                values: Buffer::default(),
                centres_x: Vec::new(),
            };
        }
        let origin = lo - Vec2::splat(sigma_m);
        let extent = hi + Vec2::splat(sigma_m) - origin;
        let mut cell = cell_m.max(1e-3);
        while (extent.x / cell + 2.0) * (extent.y / cell + 2.0) > MAX_RASTER_CELLS as f64 {
            cell *= 2.0;
        }
        let width = (extent.x / cell).ceil() as usize + 1;
        let height = (extent.y / cell).ceil() as usize + 1;
        ScoreRaster {
            origin,
            cell_m: cell,
            sigma_m,
            width,
            height,
            values: super::buffers::zeroed(width * height),
            centres_x: (0..width)
                .map(|x| origin.x + (x as f64 + 0.5) * cell)
                .collect(),
        }
    }

    /// The raster of `segments` and loose `points` (map frame), covering all of them.
    pub fn of(segments: &[Segment], points: &[Vec2], cell_m: f64, sigma_m: f64) -> Self {
        let ends = segments.iter().flat_map(|s| [s.start, s.end]);
        let (lo, hi) = ends.chain(points.iter().copied()).fold(
            (Vec2::splat(f64::INFINITY), Vec2::splat(f64::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(p), hi.max(p)),
        );
        let mut raster = ScoreRaster::new(lo, hi, cell_m, sigma_m);
        for s in segments {
            raster.add_segment(s);
        }
        for p in points {
            raster.add_point(*p);
        }
        raster
    }

    /// Cell size, metres.
    pub fn cell_m(&self) -> f64 {
        self.cell_m
    }

    /// Scale of the kernel, metres.
    pub fn sigma_m(&self) -> f64 {
        self.sigma_m
    }

    /// Width and height in cells.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// The map-frame position of the lower corner of cell `(0, 0)`, metres.
    pub fn origin(&self) -> Vec2 {
        self.origin
    }

    /// Draws a segment (map frame) into the raster.
    pub fn add_segment(&mut self, s: &Segment) {
        if self.width == 0 || !(s.start.is_finite() && s.end.is_finite()) {
            return;
        }
        let (sigma, cell) = (self.sigma_m, self.cell_m);
        let sigma_2 = sigma * sigma;
        let a = s.start.min(s.end) - Vec2::splat(sigma) - self.origin;
        let b = s.start.max(s.end) + Vec2::splat(sigma) - self.origin;
        if b.x < 0.0 || b.y < 0.0 {
            return;
        }
        let y0 = low_cell(a.y / cell);
        let y1 = high_cell(b.y / cell).min(self.height - 1);
        let (p, q) = (s.start - self.origin, s.end - self.origin);
        let (start, v) = (s.start, s.vector());
        let len_2 = v.length_squared();
        let centres = &self.centres_x;
        for y in y0..=y1 {
            // Only the span of x where the segment, widened by σ, crosses this row.
            let (ylo, yhi) = (y as f64 * cell - sigma, (y + 1) as f64 * cell + sigma);
            let (xlo, xhi) = x_span(p, q, ylo, yhi);
            let x0 = low_cell((xlo - sigma) / cell);
            let x1 = high_cell((xhi + sigma) / cell).min(self.width - 1);
            if x0 > x1 {
                continue;
            }
            // Every cell of the span in one pass without branches (the compiler vectorizes
            // it), in the arithmetic of `Segment::distance_2_to_point` at the cell's centre:
            // a cell farther than σ from the segment gets a value under 0, which raises no
            // cell (all start at 0), so the values are those of drawing only the cells that
            // score. (The cells' centres along x come from a table: the same values, without
            // a conversion and two operations per cell.)
            let cy = self.origin.y + (y as f64 + 0.5) * cell;
            let dy = cy - start.y;
            let row = &mut self.values[y * self.width + x0..=y * self.width + x1];
            for (&cx, slot) in centres[x0..=x1].iter().zip(row.iter_mut()) {
                let dx = cx - start.x;
                let t = match len_2 > 0.0 {
                    true => ((dx * v.x + dy * v.y) / len_2).clamp(0.0, 1.0),
                    false => 0.0,
                };
                let (ex, ey) = (cx - (start.x + v.x * t), cy - (start.y + v.y * t));
                let value = 1.0 - (ex * ex + ey * ey) / sigma_2;
                *slot = match value > *slot as f64 {
                    true => value as f32,
                    false => *slot,
                };
            }
        }
    }

    /// Draws a loose point (map frame) into the raster.
    pub fn add_point(&mut self, p: Vec2) {
        if self.width == 0 || !p.is_finite() {
            return;
        }
        let (sigma, cell) = (self.sigma_m, self.cell_m);
        let q = p - self.origin;
        let x0 = low_cell((q.x - sigma) / cell);
        let y0 = low_cell((q.y - sigma) / cell);
        let x1 = high_cell((q.x + sigma) / cell).min(self.width - 1);
        let y1 = high_cell((q.y + sigma) / cell).min(self.height - 1);
        for y in y0..=y1 {
            for x in x0..=x1 {
                let c = Vec2::new((x as f64 + 0.5) * cell, (y as f64 + 0.5) * cell);
                self.raise(x, y, 1.0 - c.distance_squared(q) / (sigma * sigma));
            }
        }
    }

    fn raise(&mut self, x: usize, y: usize, v: f64) {
        let slot = &mut self.values[y * self.width + x];
        if v > *slot as f64 {
            *slot = v as f32;
        }
    }

    /// The cell holding `p` (map frame), as signed cell coordinates (may lie outside).
    pub fn cell_of(&self, p: Vec2) -> (i64, i64) {
        let q = (p - self.origin) / self.cell_m;
        // Saturating casts: NaN gives 0, far points stay far outside.
        (floor_i64(q.x), floor_i64(q.y))
    }

    /// The value of cell `(x, y)`; 0 outside the raster.
    pub fn cell(&self, x: i64, y: i64) -> f32 {
        if x < 0 || y < 0 || x >= self.width as i64 || y >= self.height as i64 {
            return 0.0;
        }
        self.values[y as usize * self.width + x as usize]
    }

    /// The score of one point (map frame); 0 outside the raster.
    pub fn at(&self, p: Vec2) -> f64 {
        if !p.is_finite() {
            return 0.0;
        }
        let (x, y) = self.cell_of(p);
        self.cell(x, y) as f64
    }

    /// The raw values, row by row (`width × height`).
    pub(crate) fn values(&self) -> &[f32] {
        &self.values
    }
}

/// The first cell of a span starting at `v` cells: `floor(v)`, at least 0 (0 for NaN), by
/// [`floor_i64`] instead of a call to the library's `floor` (the default x86-64 target has no
/// rounding instruction). Beyond `i64` it saturates lower than `floor(v) as usize` would, but
/// past every raster's last cell either way: the span is then empty alike.
fn low_cell(v: f64) -> usize {
    floor_i64(v).max(0) as usize
}

/// The last cell of a span ending at `v` cells before the raster's bound: `ceil(v)`, at least 0
/// (0 for NaN), as `-floor(-v)` ([`low_cell`]); the callers cap it at the raster's last cell,
/// which a saturated value exceeds as `ceil(v) as usize` does.
fn high_cell(v: f64) -> usize {
    floor_i64(-v).saturating_neg().max(0) as usize
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
    use crate::align::{AlignParams, fit_score};
    use crate::geometry::Pose2;
    use crate::segment_index::SegmentIndex;

    #[test]
    fn raster_scores_like_fit_score_within_a_cell() {
        let segs = vec![
            Segment::new(Vec2::new(0.0, 0.0), Vec2::new(4.0, 0.0)),
            Segment::new(Vec2::new(4.0, 0.0), Vec2::new(4.0, 3.0)),
        ];
        let params = AlignParams::default();
        let raster = ScoreRaster::of(&segs, &[], 0.02, params.rotation_search_sigma_m);
        let index = SegmentIndex::from_segments(&segs, 0.5, 1.0);
        let points: Vec<Vec2> = (0..40)
            .map(|i| Vec2::new(0.1 * i as f64, 0.05 + 0.003 * i as f64))
            .collect();
        for pose in [
            Pose2::IDENTITY,
            Pose2::new(0.1, -0.05, 0.02),
            Pose2::new(3.0, 2.0, 1.0),
        ] {
            let exact = fit_score(&points, &index, &pose, &params);
            let fast: f64 = points
                .iter()
                .map(|p| raster.at(pose.transform_point(*p)))
                .sum();
            assert!(
                (exact - fast).abs() < 0.05 * points.len() as f64,
                "{exact} vs {fast}"
            );
        }
        assert_eq!(raster.at(Vec2::new(-10.0, 0.0)), 0.0);
        assert_eq!(raster.at(Vec2::new(f64::NAN, 0.0)), 0.0);
    }

    /// Drawing a segment only where it can score (its row spans and the cross-product skip)
    /// gives every cell the value the kernel gives it when every cell is computed.
    #[test]
    fn drawing_skips_only_cells_that_score_nothing() {
        let segs = [
            Segment::new(Vec2::new(0.03, 0.07), Vec2::new(4.91, 3.13)),
            Segment::new(Vec2::new(4.2, 0.1), Vec2::new(0.4, 2.9)),
            Segment::new(Vec2::new(1.0, 1.55), Vec2::new(3.7, 1.55)),
            Segment::new(Vec2::new(2.45, 0.2), Vec2::new(2.45, 3.0)),
            Segment::new(Vec2::new(3.0, 3.0), Vec2::new(3.0, 3.0)),
        ];
        let (cell, sigma) = (0.1, 0.2);
        let raster = ScoreRaster::of(&segs, &[], cell, sigma);
        let (w, h) = raster.size();
        for y in 0..h {
            for x in 0..w {
                let c =
                    raster.origin() + Vec2::new((x as f64 + 0.5) * cell, (y as f64 + 0.5) * cell);
                let want = segs
                    .iter()
                    .map(|s| 1.0 - s.distance_2_to_point(c) / (sigma * sigma))
                    .fold(0f32, |v, d| if d > v as f64 { d as f32 } else { v });
                assert_eq!(raster.cell(x as i64, y as i64).to_bits(), want.to_bits());
            }
        }
    }

    #[test]
    fn a_loose_point_scores_near_it_only() {
        let raster = ScoreRaster::of(&[], &[Vec2::new(1.0, 1.0)], 0.05, 0.2);
        assert!(raster.at(Vec2::new(1.0, 1.0)) > 0.9);
        assert!(raster.at(Vec2::new(1.1, 1.0)) > 0.4);
        assert_eq!(raster.at(Vec2::new(1.3, 1.0)), 0.0);
    }

    #[test]
    fn a_huge_extent_gets_coarser_cells() {
        let segs = vec![Segment::new(Vec2::new(0.0, 0.0), Vec2::new(1e4, 1e4))];
        let raster = ScoreRaster::of(&segs, &[], 0.1, 0.3);
        assert!(raster.values.len() <= MAX_RASTER_CELLS);
        assert!(raster.cell_m() > 0.1);
        let empty = ScoreRaster::of(&[], &[], 0.1, 0.3);
        assert_eq!(empty.at(Vec2::ZERO), 0.0);
        assert_eq!(empty.size(), (0, 0));
    }
}
