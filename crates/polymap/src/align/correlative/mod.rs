//! Correlative scan matching, exact within its window by branch and bound (an addition to the
//! paper, after Olson's real-time correlative scan matching, 2009, and the fast correlative
//! matcher of Hess et al., 2016).
//!
//! A pose is scored by the sum of the [`ScoreRaster`] values under the scan's points. The
//! window's rotations are stepped so that the farthest point moves by at most one cell; for
//! each rotation the points fall on cells, and a translation by whole cells only shifts them,
//! so every candidate's score is a sum of lookups. Branch and bound covers the translations
//! with square blocks of `2^h` cells whose bound is the sum, per point, of the raster's maximum
//! over the block (precomputed once per raster for each `h`). Blocks are opened best bound
//! first (a priority queue over every rotation's blocks): the first single pose taken from the
//! queue scores at least every bound left in it. Since floating-point addition is monotone, a
//! bound is never below any score it covers, so the answer is the best candidate of the window,
//! exactly: the same score a brute-force scan of all candidates finds. Best first opens only
//! blocks whose bound reaches the best score (a depth-first search also opens those that beat
//! only the best found so far), and the queue left behind is where the search for a rival, the
//! best pose apart from the best, goes on. ICP refines the answer below the cell size.

use super::buffers::Buffer;
use super::raster::ScoreRaster;
use crate::geometry::{Pose2, Vec2, normalize_angle_rad};
use search::{Block, Frontier, Prepared, Rotations, Search, ceil_log2, cells_into, must_clamp};
use std::cell::{Cell, OnceCell};

/// Highest block level: blocks of up to `2^6 = 64` cells a side.
const MAX_LEVEL: u32 = 6;

/// Independent partial sums of a block's bound.
const LANES: usize = 8;

/// Most blocks a search's queue holds (24 bytes each: 1.5 MiB). Best first queues every child
/// whose bound reaches the floor; where bounds are loose over a wide window (the whole circle
/// over metres, a cluttered scan) that grows with the work, so beyond this the search goes on
/// depth first from the blocks queued (exact too; memory only for its depth), and a search
/// that would go on from the queue (the rival, the next peak) starts afresh.
const MAX_QUEUED: usize = 1 << 16;

/// A box of poses to search: translations within `half_xy_m` of the centre along x and y (map
/// frame), rotations within `half_theta_rad` of its heading (at least π: the whole circle).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SearchWindow {
    /// The centre of the window, map frame.
    pub center: Pose2,
    /// Half-width of the translation window along each axis, metres.
    pub half_xy_m: f64,
    /// Half-width of the rotation window, radians.
    pub half_theta_rad: f64,
}

/// A pose of the window with its score.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// The pose, map frame.
    pub map_from_robot: Pose2,
    /// Mean raster value under the points, in `[0, 1]`.
    pub score: f64,
}

/// A region of poses a search must skip: within `radius_m` of a pose's translation and
/// `radius_rad` of its heading (to find the best pose apart from peaks already found).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Exclusion {
    /// The centre of the excluded region, map frame.
    pub center: Pose2,
    /// Radius in translation, metres.
    pub radius_m: f64,
    /// Radius in rotation, radians.
    pub radius_rad: f64,
}

/// A raster prepared for branch and bound: its block maxima at every level.
#[derive(Debug, Clone)]
pub struct CorrelativeMatcher {
    raster: ScoreRaster,
    /// Level `h` holds, at padded cell `(x + pad, y + pad)`, the raster's maximum over the
    /// block `[x, x + 2^h) × [y, y + 2^h)`; `pad = 2^top − 1` cells on the low sides. Each
    /// level's length is a power of two, at least its `padded_width × padded_height` cells
    /// (values past them are never read): a cell's index masked by the length less one is
    /// the same index, and the compiler drops the bounds check of a masked index
    /// (`masked`).
    levels: Vec<Buffer>,
    pad: i64,
    padded_width: i64,
    padded_height: i64,
    /// [`MAX_QUEUED`], smaller in tests.
    max_queued: usize,
    /// Per level, how many blocks' children the searches of this matcher summed there, and
    /// the level's values beside their siblings' once that reached
    /// [`SIBLINGS_AFTER`](sums::SIBLINGS_AFTER): built once for all the searches of the
    /// matcher (the search for the best, its rival's, each peak's), which then all sum from
    /// them.
    summed: [Cell<u32>; MAX_LEVEL as usize + 1],
    siblings: [OnceCell<Buffer>; MAX_LEVEL as usize + 1],
}

/// The best pose of a window search ([`CorrelativeMatcher::window_best`]), with what a search
/// for its rival needs.
#[derive(Debug, Clone)]
pub struct WindowBest {
    /// The best pose of the window, or the seed when no pose of the window beat it.
    pub best: Candidate,
    window: SearchWindow,
    prepared: Option<Prepared>,
    /// The blocks the search for the best left unopened: where the search for its rival goes
    /// on.
    frontier: Frontier,
    /// The share of the best's score a rival must reach.
    rival_above: f64,
}

impl CorrelativeMatcher {
    /// Prepares `raster` for searching windows of any size (cost: two passes over its cells
    /// for each of six levels).
    pub fn new(raster: ScoreRaster) -> Self {
        Self::with_levels(raster, MAX_LEVEL)
    }

    /// Prepares `raster` for windows up to `half_xy_m` (fewer levels: cheaper to prepare; a
    /// larger window is still searched exactly, from more top blocks).
    pub fn for_window(raster: ScoreRaster, half_xy_m: f64) -> Self {
        let reach = ((half_xy_m.max(0.0) / raster.cell_m()).ceil() as i64).min(1 << 16);
        Self::with_levels(raster, ceil_log2(2 * reach + 1).min(MAX_LEVEL))
    }

    fn with_levels(raster: ScoreRaster, max_level: u32) -> Self {
        let (w, h) = raster.size();
        let pad = (1i64 << max_level) - 1;
        let (pw, ph) = (w as i64 + pad, h as i64 + pad);
        let (wu, len) = (pw as usize, (pw * ph) as usize);
        let cap = len.next_power_of_two();
        // Values past `len` are never read: only the cells are written (and every level above
        // the first is written whole before it is read). The first `pad` rows and the first
        // `pad` cells of every row are zeros, the rest of each row the raster's row: each
        // cell written once.
        let mut base = super::buffers::reused(cap);
        let (top, rows) = base[..len].split_at_mut((pad * pw) as usize);
        top.fill(0.0);
        let padding = pad as usize;
        for (out, row) in rows
            .chunks_exact_mut(wu)
            .zip(raster.values().chunks(w.max(1)))
        {
            let (zeros, cells) = out.split_at_mut(padding);
            zeros.fill(0.0);
            cells.copy_from_slice(row);
        }
        let mut levels = Vec::with_capacity(max_level as usize + 1);
        levels.push(base);
        for level in 1..=max_level {
            let half = 1usize << (level - 1);
            let prev = &levels[level as usize - 1][..len];
            // Along x, then along y, each a max of two blocks of the level below (plain
            // loops over slices: the iterator chain it replaces cost three times as much).
            let mut padded = super::buffers::reused(cap);
            let both = &mut padded[..len];
            for (out, row) in both.chunks_exact_mut(wu).zip(prev.chunks_exact(wu)) {
                let split = wu.saturating_sub(half);
                for ((o, a), b) in out[..split].iter_mut().zip(&row[..split]).zip(&row[half..]) {
                    *o = larger(*a, *b);
                }
                out[split..].copy_from_slice(&row[split..]);
            }
            // Along y in chunks of `half` rows: each chunk reads the next, not yet written.
            let step = half * wu;
            let mut start = 0;
            while start + step < len {
                let (done, rest) = both.split_at_mut(start + step);
                let m = step.min(rest.len());
                for (o, b) in done[start..start + m].iter_mut().zip(&rest[..m]) {
                    *o = larger(*o, *b);
                }
                start += step;
            }
            levels.push(padded);
        }
        CorrelativeMatcher {
            raster,
            levels,
            pad,
            padded_width: pw,
            padded_height: ph,
            max_queued: MAX_QUEUED,
            summed: Default::default(),
            siblings: Default::default(),
        }
    }

    /// The same matcher with a queue of at most `max_queued` blocks (tests of the depth-first
    /// fallback).
    #[cfg(test)]
    fn with_max_queued(mut self, max_queued: usize) -> Self {
        self.max_queued = max_queued;
        self
    }

    /// The raster searched.
    pub fn raster(&self) -> &ScoreRaster {
        &self.raster
    }

    /// The best pose of `window` for `points_in_robot` (robot frame) outside every exclusion,
    /// if its score reaches `min_score` (mean raster value, `[0, 1]`).
    pub fn best(
        &self,
        points_in_robot: &[Vec2],
        window: &SearchWindow,
        min_score: f64,
        exclusions: &[Exclusion],
    ) -> Option<Candidate> {
        let prepared = self.prepare(points_in_robot, window)?;
        let floor = prepared.floor(min_score);
        let mut frontier = prepared.frontier(floor);
        let found = prepared
            .context(self, window, exclusions)
            .next(&mut frontier, floor);
        found.map(|leaf| prepared.candidate(self, window, leaf))
    }

    /// The best pose of `window` for `points_in_robot` (robot frame) scoring at least
    /// `min_score`, or else `seed` (a pose scored by the caller on the same raster), kept with
    /// what [`CorrelativeMatcher::rival`] needs to search on for a pose scoring at least
    /// `rival_above` times the best's score; `None` when there is neither a pose nor a seed.
    pub fn window_best(
        &self,
        points_in_robot: &[Vec2],
        window: &SearchWindow,
        min_score: f64,
        seed: Option<Candidate>,
        rival_above: f64,
    ) -> Option<WindowBest> {
        let Some(prepared) = self.prepare(points_in_robot, window) else {
            return seed.map(|best| WindowBest {
                best,
                window: *window,
                prepared: None,
                frontier: Frontier::default(),
                rival_above,
            });
        };
        // The best scores at least `min_score` (or is the seed, which may score less: its
        // rival is then searched afresh), so its rival at least `rival_above` of that.
        let floor = prepared.floor(min_score);
        let keep = prepared.floor(rival_above.min(1.0) * min_score);
        let mut frontier = prepared.frontier(keep);
        let found = prepared
            .context(self, window, &[])
            .next(&mut frontier, floor);
        let best = found
            .map(|leaf| prepared.candidate(self, window, leaf))
            .or(seed)?;
        Some(WindowBest {
            best,
            window: *window,
            prepared: Some(prepared),
            frontier,
            rival_above,
        })
    }

    /// The rival of `found` (from [`CorrelativeMatcher::window_best`] on this matcher): the
    /// best pose of its window more than `apart_m` or `apart_rad` from its best (see
    /// [`Exclusion`]) scoring at least `rival_above` (given to `window_best`) times the best's
    /// score. The search goes on from the blocks the search for the best left unopened.
    pub fn rival(&self, found: &WindowBest, (apart_m, apart_rad): (f64, f64)) -> Option<Candidate> {
        let prepared = found.prepared.as_ref()?;
        let window = &found.window;
        let exclusion = [Exclusion {
            center: found.best.map_from_robot,
            radius_m: apart_m,
            radius_rad: apart_rad,
        }];
        let floor = prepared.floor(found.rival_above * found.best.score);
        let mut frontier = match floor >= found.frontier.keep && !found.frontier.spent {
            true => found.frontier.clone(),
            // A seed scoring under the floor of the search for the best, or a queue spent.
            false => prepared.frontier(floor),
        };
        prepared
            .context(self, window, &exclusion)
            .next(&mut frontier, floor)
            .map(|leaf| prepared.candidate(self, window, leaf))
    }

    /// The rotations of `window` for `points` and the top blocks of translations: where every
    /// search of that window for those points starts. `None` for no points or an empty raster.
    fn prepare(&self, points: &[Vec2], window: &SearchWindow) -> Option<Prepared> {
        let n = points.len();
        if n == 0 || self.raster.size().0 == 0 {
            return None;
        }
        let rotations = self.rotations(points, window);
        let reach = self.translation_steps(window);
        let top = (self.levels.len() as u32 - 1).min(ceil_log2(2 * reach + 1));
        let mut blocks = Vec::new();
        for r in 0..rotations.len() {
            let mut ix = -reach;
            while ix <= reach {
                let mut iy = -reach;
                while iy <= reach {
                    blocks.push(self.block(&rotations, r, ix, iy, top));
                    iy += 1 << top;
                }
                ix += 1 << top;
            }
        }
        Some(Prepared {
            rotations,
            reach,
            blocks,
            points: n,
        })
    }

    /// Up to `max` best poses of `window`, each apart from the ones before by `apart_m` or
    /// `apart_rad` (peaks, best first), scoring at least `min_score`.
    pub fn peaks(
        &self,
        points_in_robot: &[Vec2],
        window: &SearchWindow,
        min_score: f64,
        max: usize,
        apart_m: f64,
        apart_rad: f64,
    ) -> Vec<Candidate> {
        let mut found: Vec<Candidate> = Vec::new();
        let Some(prepared) = self.prepare(points_in_robot, window) else {
            return found;
        };
        // Each peak is the best pose outside the ones before: the search goes on from the
        // same queue (a block left out by an exclusion stays out: exclusions only grow).
        let floor = prepared.floor(min_score);
        let mut frontier = prepared.frontier(floor);
        let mut exclusions = Vec::new();
        while found.len() < max {
            if frontier.spent {
                frontier = prepared.frontier(floor);
            }
            let ctx = prepared.context(self, window, &exclusions);
            let Some(leaf) = ctx.next(&mut frontier, floor) else {
                break;
            };
            let c = prepared.candidate(self, window, leaf);
            exclusions.push(Exclusion {
                center: c.map_from_robot,
                radius_m: apart_m,
                radius_rad: apart_rad,
            });
            found.push(c);
        }
        found
    }

    /// The best candidate outside every exclusion by scoring every one (the oracle of
    /// [`CorrelativeMatcher::best`] and [`CorrelativeMatcher::rival`]).
    pub fn best_brute_force(
        &self,
        points_in_robot: &[Vec2],
        window: &SearchWindow,
        exclusions: &[Exclusion],
    ) -> Option<Candidate> {
        let n = points_in_robot.len();
        if n == 0 || self.raster.size().0 == 0 {
            return None;
        }
        let rotations = self.rotations(points_in_robot, window);
        let reach = self.translation_steps(window);
        let ctx = Search::new(self, &rotations, window, reach, exclusions);
        let mut best: Option<(f32, Block)> = None;
        for r in 0..rotations.len() {
            for ix in -reach..=reach {
                for iy in -reach..=reach {
                    let b = self.block(&rotations, r, ix, iy, 0);
                    if best.is_none_or(|(s, _)| b.bound > s) && !ctx.excluded(&b) {
                        best = Some((b.bound, b));
                    }
                }
            }
        }
        best.map(|(sum, b)| Candidate {
            map_from_robot: ctx.pose(b),
            score: sum as f64 / n as f64,
        })
    }

    /// The rotations of the window, stepped so that the farthest point moves at most one cell.
    fn rotations(&self, points: &[Vec2], window: &SearchWindow) -> Rotations {
        let cell = self.raster.cell_m();
        let reach_m = points
            .iter()
            .map(|p| p.length())
            .fold(cell, f64::max)
            .min(1e6);
        let step = (1.0 - cell * cell / (2.0 * reach_m * reach_m))
            .clamp(-1.0, 1.0)
            .acos();
        let half = window.half_theta_rad.clamp(0.0, std::f64::consts::PI);
        let count = ((half / step.max(1e-4)).ceil() as i64).min(4000);
        let c = window.center;
        let pw = self.padded_width;
        let total = (2 * count + 1) as usize;
        let mut out = Rotations {
            theta_rad: Vec::with_capacity(total),
            extent: Vec::with_capacity(total),
            cells: Vec::with_capacity(total * points.len()),
            flat: Vec::with_capacity(total * points.len()),
            points: points.len(),
        };
        let origin = self.raster.origin();
        let xs: Vec<f64> = points.iter().map(|p| p.x).collect();
        let ys: Vec<f64> = points.iter().map(|p| p.y).collect();
        let clamped = must_clamp(&xs, &ys, &c, origin, cell);
        for k in -count..=count {
            let theta_rad = normalize_angle_rad(c.theta_rad + k as f64 * step);
            let pose = Pose2::new(c.x_m, c.y_m, theta_rad);
            // `Pose2::transform_point` and `ScoreRaster::cell_of` with the sine and cosine taken
            // once per rotation, in the same arithmetic (the same cells), in passes without
            // branches the compiler can vectorize: the cells, then their extent, then the flat
            // indices (this loop was an eighth of a sparse run's time).
            let start = out.cells.len();
            let turn = pose.theta_rad.sin_cos();
            cells_into(
                &xs,
                &ys,
                turn,
                pose.translation(),
                origin,
                cell,
                clamped,
                &mut out.cells,
            );
            let cells = &out.cells[start..];
            let extent = cells.iter().fold(
                (i32::MAX, i32::MAX, i32::MIN, i32::MIN),
                |(a, b, c, d), &(x, y)| (a.min(x), b.min(y), c.max(x), d.max(y)),
            );
            let extent = (
                extent.0 as i64,
                extent.1 as i64,
                extent.2 as i64,
                extent.3 as i64,
            );
            // `y × pw + x` grows with x and y: every flat index fits an `i32` when the extent's
            // corners do.
            let fits = |x: i64, y: i64| i32::try_from(y * pw + x).is_ok();
            let flat_fits = fits(extent.0, extent.1) && fits(extent.2, extent.3);
            if flat_fits {
                let pw = pw as i32;
                out.flat.extend(
                    cells
                        .iter()
                        .map(|&(x, y)| y.wrapping_mul(pw).wrapping_add(x)),
                );
            } else {
                out.flat.resize(out.cells.len(), 0);
            }
            out.theta_rad.push(theta_rad);
            out.extent
                .push(Some(extent).filter(|_| flat_fits && !points.is_empty()));
        }
        out
    }

    /// The translation window in whole cells each way.
    fn translation_steps(&self, window: &SearchWindow) -> i64 {
        let cell = self.raster.cell_m();
        ((window.half_xy_m.max(0.0) / cell).ceil() as i64).min(1 << 16)
    }
}

/// The larger of two raster values. A raster holds no NaN and no −0 (its values are 0 or
/// raised above it), where this is `f32::max`; without their cases it is one comparison
/// the compiler vectorizes to one instruction (`f32::max` took five per value).
#[inline]
fn larger(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}

/// The mask of a level's indices: its length (a power of two) less one.
fn masked(values: &[f32]) -> usize {
    values.len().wrapping_sub(1)
}

mod search;
mod sums;
#[cfg(test)]
mod tests;
