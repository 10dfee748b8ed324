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

use super::raster::ScoreRaster;
use crate::geometry::{Pose2, Vec2, normalize_angle_rad};
use std::cmp::Ordering;
use std::collections::BinaryHeap;

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
    /// block `[x, x + 2^h) × [y, y + 2^h)`; `pad = 2^top − 1` cells on the low sides.
    levels: Vec<Vec<f32>>,
    pad: i64,
    padded_width: i64,
    padded_height: i64,
    /// [`MAX_QUEUED`], smaller in tests.
    max_queued: usize,
}

impl Drop for CorrelativeMatcher {
    fn drop(&mut self) {
        for level in self.levels.drain(..) {
            super::buffers::recycle(level);
        }
    }
}

/// The rotations of a window: for each, the points' cells at zero offset, all rotations in
/// shared buffers (four allocations per search instead of two per rotation).
#[derive(Debug, Clone, Default)]
struct Rotations {
    theta_rad: Vec<f64>,
    /// Per rotation, the smallest and largest cell coordinates, `(min_x, min_y, max_x, max_y)`,
    /// when its flat indices are valid: a block whose every cell lands inside the raster is
    /// summed from them without checks. `None` for no cells, or for a rotation whose extent
    /// has a corner (`(min_x, min_y)` or `(max_x, max_y)`, bounding every cell's flat index)
    /// whose flat index does not fit an `i32` (far from a wide raster, where a block's offset
    /// may still bring it inside): its blocks are summed with checks (the same sums).
    extent: Vec<Option<(i64, i64, i64, i64)>>,
    /// `points` cells per rotation, rotation after rotation; coordinates clamped to
    /// `±CELL_CLAMP` (still outside every raster).
    cells: Vec<(i32, i32)>,
    /// Each cell as its index into a level's padded values at zero offset (`y × padded width +
    /// x`), valid where the rotation's extent lies inside: a block inside the raster adds one
    /// offset per point instead of a row product.
    flat: Vec<i32>,
    points: usize,
}

/// The largest cell coordinate kept (far beyond any raster: at most 2²⁰ cells).
const CELL_CLAMP: i64 = 1 << 30;

impl Rotations {
    fn len(&self) -> usize {
        self.theta_rad.len()
    }

    fn cells(&self, r: usize) -> &[(i32, i32)] {
        &self.cells[r * self.points..(r + 1) * self.points]
    }

    fn flat(&self, r: usize) -> &[i32] {
        &self.flat[r * self.points..(r + 1) * self.points]
    }
}

/// A block of translations: offsets `[ix, ix + 2^level) × [iy, iy + 2^level)` cells at one
/// rotation, with its bound.
#[derive(Debug, Clone, Copy)]
struct Block {
    rotation: usize,
    ix: i64,
    iy: i64,
    level: u32,
    bound: f32,
}

/// A block waiting to be opened, compact (a frontier holds thousands), ordered by `key`: its
/// bound's bits in an order-preserving form; at equal bounds the higher level first (a block
/// may hold a pose as good as one already queued), then the pose nearer the window's centre
/// (among poses scoring alike, the one the prediction favours, whatever the order of the
/// search).
#[derive(Debug, Clone, Copy)]
struct Queued {
    key: u64,
    rotation: u32,
    ix: i32,
    iy: i32,
}

/// Bits of [`Queued::key`] below the bound's and the level's: the nearness to the centre.
const NEAR_BITS: u32 = 24;

impl Queued {
    /// `b` queued, for a window of `rotations` rotations.
    fn of(b: &Block, rotations: usize) -> Self {
        // Finite and infinite floats ordered as `total_cmp` orders them.
        let bits = b.bound.to_bits();
        let ordered = match bits >> 31 {
            1 => !bits,
            _ => bits | 1 << 31,
        };
        let turn = b.rotation.abs_diff(rotations / 2) as u64;
        let off = turn + b.ix.unsigned_abs() + b.iy.unsigned_abs();
        let near = (1u64 << NEAR_BITS) - 1 - off.min((1 << NEAR_BITS) - 1);
        Queued {
            key: (ordered as u64) << 32 | (b.level as u64) << NEAR_BITS | near,
            rotation: b.rotation as u32,
            ix: b.ix as i32,
            iy: b.iy as i32,
        }
    }

    fn block(&self) -> Block {
        let bits = (self.key >> 32) as u32;
        let bits = match bits >> 31 {
            1 => bits & !(1 << 31),
            _ => !bits,
        };
        Block {
            rotation: self.rotation as usize,
            ix: self.ix as i64,
            iy: self.iy as i64,
            level: ((self.key >> NEAR_BITS) & 0xff) as u32,
            bound: f32::from_bits(bits),
        }
    }
}

impl Ord for Queued {
    fn cmp(&self, other: &Self) -> Ordering {
        self.key.cmp(&other.key)
    }
}

impl PartialOrd for Queued {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl PartialEq for Queued {
    fn eq(&self, other: &Self) -> bool {
        self.key == other.key
    }
}

impl Eq for Queued {}

/// The blocks of a search not opened yet, best bound first; only blocks whose bound reaches
/// `keep` (a sum of raster values) are queued: no search from this queue asks for less.
/// `spent` once a search went on depth first from it ([`MAX_QUEUED`]): nothing can go on
/// from it then.
#[derive(Debug, Clone, Default)]
struct Frontier {
    queue: BinaryHeap<Queued>,
    keep: f32,
    spent: bool,
}

impl Frontier {
    /// The queue of `blocks` (a window's top blocks, of `rotations` rotations) reaching
    /// `keep`.
    fn of(blocks: &[Block], rotations: usize, keep: f32) -> Self {
        let queue = blocks
            .iter()
            .filter(|b| b.bound >= keep)
            .map(|b| Queued::of(b, rotations))
            .collect();
        Frontier {
            queue,
            keep,
            spent: false,
        }
    }
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

/// One window prepared for one set of points: its rotations and its top blocks.
#[derive(Debug, Clone)]
struct Prepared {
    rotations: Rotations,
    reach: i64,
    blocks: Vec<Block>,
    points: usize,
}

impl Prepared {
    /// The search state over this window with `exclusions`.
    fn context<'a>(
        &'a self,
        matcher: &'a CorrelativeMatcher,
        window: &'a SearchWindow,
        exclusions: &'a [Exclusion],
    ) -> Search<'a> {
        Search {
            matcher,
            rotations: &self.rotations,
            window,
            reach: self.reach,
            exclusions,
        }
    }

    /// The queue of this window's top blocks reaching `keep` (a sum of raster values).
    fn frontier(&self, keep: f32) -> Frontier {
        Frontier::of(&self.blocks, self.rotations.len(), keep)
    }

    /// The sum of raster values a mean score of `min_score` asks for.
    fn floor(&self, min_score: f64) -> f32 {
        (min_score * self.points as f64) as f32
    }

    /// The pose and mean score of a leaf found with its sum.
    fn candidate(
        &self,
        matcher: &CorrelativeMatcher,
        window: &SearchWindow,
        (sum, b): (f32, Block),
    ) -> Candidate {
        Candidate {
            map_from_robot: self.context(matcher, window, &[]).pose(b),
            score: sum as f64 / self.points as f64,
        }
    }
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
        let mut base = super::buffers::zeroed(len);
        for (y, row) in raster.values().chunks(w.max(1)).enumerate() {
            let at = (y as i64 + pad) * pw + pad;
            base[at as usize..at as usize + row.len()].copy_from_slice(row);
        }
        let mut levels = Vec::with_capacity(max_level as usize + 1);
        levels.push(base);
        for level in 1..=max_level {
            let half = 1usize << (level - 1);
            let prev = &levels[level as usize - 1];
            // Along x, then along y, each a max of two blocks of the level below (plain
            // loops over slices: the iterator chain it replaces cost three times as much).
            let mut both = super::buffers::zeroed(len);
            for (out, row) in both.chunks_exact_mut(wu).zip(prev.chunks_exact(wu)) {
                let split = wu.saturating_sub(half);
                for ((o, a), b) in out[..split].iter_mut().zip(&row[..split]).zip(&row[half..]) {
                    *o = a.max(*b);
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
                    *o = o.max(*b);
                }
                start += step;
            }
            levels.push(both);
        }
        CorrelativeMatcher {
            raster,
            levels,
            pad,
            padded_width: pw,
            padded_height: ph,
            max_queued: MAX_QUEUED,
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
        let ctx = Search {
            matcher: self,
            rotations: &rotations,
            window,
            reach,
            exclusions,
        };
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
        let clamp = CELL_CLAMP as f64;
        for k in -count..=count {
            let theta_rad = normalize_angle_rad(c.theta_rad + k as f64 * step);
            let pose = Pose2::new(c.x_m, c.y_m, theta_rad);
            // `Pose2::transform_point` and `ScoreRaster::cell_of` with the sine and cosine taken
            // once per rotation, in the same arithmetic (the same cells), in passes without
            // branches the compiler can vectorize: the cells, then their extent, then the flat
            // indices (this loop was an eighth of a sparse run's time).
            let (sin, cos) = pose.theta_rad.sin_cos();
            let t = pose.translation();
            let start = out.cells.len();
            out.cells.extend(points.iter().map(|p| {
                let qx = cos * p.x - sin * p.y + t.x;
                let qy = sin * p.x + cos * p.y + t.y;
                (
                    clamped_floor((qx - origin.x) / cell, clamp),
                    clamped_floor((qy - origin.y) / cell, clamp),
                )
            }));
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

    /// The block at `(ix, iy)` of `level` for rotation `r`, with its bound.
    fn block(&self, rotations: &Rotations, r: usize, ix: i64, iy: i64, level: u32) -> Block {
        let values = &self.levels[level as usize];
        let (ox, oy) = (ix + self.pad, iy + self.pad);
        let inside = rotations.extent[r].is_some_and(|(x0, y0, x1, y1)| {
            x0 + ox >= 0
                && y0 + oy >= 0
                && x1 + ox < self.padded_width
                && y1 + oy < self.padded_height
        });
        // The same sum in the same order either way (f32 results are bit-identical): point
        // `i` into lane `i % LANES`, the lanes added in order at the end. Independent lanes
        // let the additions overlap (one chain of dependent additions was most of the cost),
        // and any fixed order keeps a block's bound at or above every sum it covers.
        let mut lanes = [0f32; LANES];
        if inside {
            let offset = oy * self.padded_width + ox;
            let mut chunks = rotations.flat(r).chunks_exact(LANES);
            for chunk in &mut chunks {
                for (lane, &at) in lanes.iter_mut().zip(chunk) {
                    *lane += values[(at as i64 + offset) as usize];
                }
            }
            for (lane, &at) in lanes.iter_mut().zip(chunks.remainder()) {
                *lane += values[(at as i64 + offset) as usize];
            }
        } else {
            for (i, &(cx, cy)) in rotations.cells(r).iter().enumerate() {
                let (x, y) = (cx as i64 + ox, cy as i64 + oy);
                if x >= 0 && y >= 0 && x < self.padded_width && y < self.padded_height {
                    lanes[i % LANES] += values[(y * self.padded_width + x) as usize];
                }
            }
        }
        let bound = lanes.iter().fold(0f32, |sum, lane| sum + lane);
        Block {
            rotation: r,
            ix,
            iy,
            level,
            bound,
        }
    }
}

/// The state of one search.
struct Search<'a> {
    matcher: &'a CorrelativeMatcher,
    rotations: &'a Rotations,
    window: &'a SearchWindow,
    reach: i64,
    exclusions: &'a [Exclusion],
}

impl Search<'_> {
    /// The best pose left in `frontier` outside the exclusions and reaching `floor` (a sum of
    /// raster values), as its sum and leaf block: blocks are opened best bound first, so the
    /// first pose taken scores at least every bound left. Opened and excluded blocks leave the
    /// queue; children reaching the queue's `keep` join it. Beyond `max_queued` blocks the
    /// search goes on depth first from the queue, which is then spent.
    fn next(&self, frontier: &mut Frontier, floor: f32) -> Option<(f32, Block)> {
        while let Some(b) = frontier.queue.peek().map(Queued::block) {
            if b.bound < floor {
                return None;
            }
            if frontier.queue.len() > self.matcher.max_queued {
                let queue = std::mem::take(&mut frontier.queue).into_sorted_vec();
                frontier.spent = true;
                let mut best = None;
                for q in queue.iter().rev() {
                    self.descend(q.block(), floor, &mut best);
                }
                return best;
            }
            frontier.queue.pop();
            // A whole block inside an exclusion holds nothing to find (for a single pose, the
            // pose itself).
            if self.excluded(&b) {
                continue;
            }
            if b.level == 0 {
                return Some((b.bound, b));
            }
            for child in self.children(&b).into_iter().flatten() {
                if child.bound >= frontier.keep {
                    frontier
                        .queue
                        .push(Queued::of(&child, self.rotations.len()));
                }
            }
        }
        None
    }

    /// The four blocks of the level below `b` (level > 0) that lie in the window.
    fn children(&self, b: &Block) -> [Option<Block>; 4] {
        let size = 1i64 << (b.level - 1);
        [(0, 0), (size, 0), (0, size), (size, size)].map(|(dx, dy)| {
            let (ix, iy) = (b.ix + dx, b.iy + dy);
            (ix <= self.reach && iy <= self.reach).then(|| {
                self.matcher
                    .block(self.rotations, b.rotation, ix, iy, b.level - 1)
            })
        })
    }

    /// Depth first below `b`: the best pose outside the exclusions beating `best` (or reaching
    /// `floor` while there is none) goes to `best`; children are opened best bound first.
    fn descend(&self, b: Block, floor: f32, best: &mut Option<(f32, Block)>) {
        let beats = match best {
            Some((sum, _)) => b.bound > *sum,
            None => b.bound >= floor,
        };
        if !beats || self.excluded(&b) {
            return;
        }
        if b.level == 0 {
            *best = Some((b.bound, b));
            return;
        }
        let mut children = self.children(&b);
        let bound = |c: &Option<Block>| c.map_or(f32::NEG_INFINITY, |c| c.bound);
        children.sort_by(|a, b| bound(b).total_cmp(&bound(a)));
        for c in children.iter().flatten() {
            self.descend(*c, floor, best);
        }
    }

    /// The pose of a block's lowest offset.
    fn pose(&self, b: Block) -> Pose2 {
        let cell = self.matcher.raster.cell_m();
        let c = self.window.center;
        Pose2::new(
            c.x_m + b.ix as f64 * cell,
            c.y_m + b.iy as f64 * cell,
            self.rotations.theta_rad[b.rotation],
        )
    }

    /// Whether the block lies wholly inside an exclusion (its four corner offsets do: the
    /// exclusion's disc is convex).
    fn excluded(&self, b: &Block) -> bool {
        if self.exclusions.is_empty() {
            return false;
        }
        let cell = self.matcher.raster.cell_m();
        let span = ((1i64 << b.level) - 1) as f64 * cell;
        let p = self.pose(*b);
        self.exclusions.iter().any(|e| {
            let turned = normalize_angle_rad(p.theta_rad - e.center.theta_rad).abs();
            if turned > e.radius_rad {
                return false;
            }
            let corners = [(0.0, 0.0), (span, 0.0), (0.0, span), (span, span)];
            corners.iter().all(|(dx, dy)| {
                Vec2::new(p.x_m + dx, p.y_m + dy).distance(e.center.translation()) <= e.radius_m
            })
        })
    }
}

/// `floor(v)` clamped to `±clamp` (at most 2³⁰), as an `i32`: the same cell as
/// [`crate::geometry::floor_i64`] then a clamp, 0 for NaN, without branches.
#[inline]
fn clamped_floor(v: f64, clamp: f64) -> i32 {
    let v = v.clamp(-clamp, clamp);
    let t = v as i32;
    t - ((t as f64) > v) as i32
}

fn ceil_log2(n: i64) -> u32 {
    let mut level = 0;
    while (1i64 << level) < n {
        level += 1;
    }
    level
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Segment;

    #[test]
    fn the_clamped_floor_is_the_floor_then_the_clamp() {
        let clamp = CELL_CLAMP as f64;
        let cases = [
            -2.5,
            -2.0,
            -0.5,
            -0.0,
            0.0,
            0.5,
            2.0,
            2.5,
            1e30,
            -1e30,
            clamp,
            clamp + 0.5,
            -clamp - 0.5,
            1e-300,
            -1e-300,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        for v in cases {
            let want = crate::geometry::floor_i64(v).clamp(-CELL_CLAMP, CELL_CLAMP);
            assert_eq!(clamped_floor(v, clamp) as i64, want, "{v}");
        }
    }

    /// A room with a pillar and a doorway: asymmetric enough for one best pose.
    fn room() -> (Vec<Segment>, Vec<Vec2>) {
        let p = |x, y| Vec2::new(x, y);
        let segs = vec![
            Segment::new(p(-3.0, -2.0), p(5.0, -2.0)),
            Segment::new(p(5.0, -2.0), p(5.0, 3.0)),
            Segment::new(p(5.0, 3.0), p(1.0, 3.0)),
            Segment::new(p(0.0, 3.0), p(-3.0, 3.0)),
            Segment::new(p(-3.0, 3.0), p(-3.0, -2.0)),
        ];
        let pillar = (0..12)
            .map(|i| {
                let a = i as f64 * std::f64::consts::TAU / 12.0;
                p(2.0 + 0.15 * a.cos(), 1.0 + 0.15 * a.sin())
            })
            .collect();
        (segs, pillar)
    }

    fn scan_of(segs: &[Segment], pillar: &[Vec2], map_from_robot: Pose2) -> Vec<Vec2> {
        let robot_from_map = map_from_robot.inverse();
        let mut pts: Vec<Vec2> = segs
            .iter()
            .flat_map(|s| (0..=20).map(move |i| s.start + s.vector() * (i as f64 / 20.0)))
            .collect();
        pts.extend_from_slice(pillar);
        pts.iter()
            .map(|p| robot_from_map.transform_point(*p))
            .collect()
    }

    /// Within 0.15 m and 0.03 rad of the truth: a cell and a rotation step or so.
    fn assert_near(truth: &Pose2, found: &Candidate) {
        let d = truth.between(&found.map_from_robot);
        assert!(
            d.translation().length() < 0.15 && d.theta_rad.abs() < 0.03,
            "{found:?}"
        );
    }

    #[test]
    fn branch_and_bound_finds_the_brute_force_best() {
        let (segs, pillar) = room();
        let matcher = CorrelativeMatcher::new(ScoreRaster::of(&segs, &pillar, 0.1, 0.2));
        let truth = Pose2::new(0.4, -0.3, 0.35);
        let points = scan_of(&segs, &pillar, truth);
        for (center, half_xy, half_deg) in [
            (Pose2::IDENTITY, 0.6, 30.0),
            (Pose2::new(0.1, 0.2, 0.1), 1.0, 45.0),
            (Pose2::new(-0.5, 0.5, -1.0), 0.3, 10.0), // truth outside: best of the window
        ] {
            let window = SearchWindow {
                center,
                half_xy_m: half_xy,
                half_theta_rad: f64::to_radians(half_deg),
            };
            let fast = matcher.best(&points, &window, 0.0, &[]).unwrap();
            let slow = matcher.best_brute_force(&points, &window, &[]).unwrap();
            assert_eq!(fast.score, slow.score, "window {window:?}");
        }
        let window = SearchWindow {
            center: Pose2::IDENTITY,
            half_xy_m: 1.0,
            half_theta_rad: 0.6,
        };
        let found = matcher.best(&points, &window, 0.0, &[]).unwrap();
        assert_near(&truth, &found);
    }

    #[test]
    fn the_whole_circle_recovers_a_turned_scan() {
        let (segs, pillar) = room();
        let matcher = CorrelativeMatcher::new(ScoreRaster::of(&segs, &pillar, 0.1, 0.2));
        let truth = Pose2::new(1.0, 0.5, 2.6);
        let points = scan_of(&segs, &pillar, truth);
        let window = SearchWindow {
            center: Pose2::new(0.5, 0.0, -0.4),
            half_xy_m: 1.0,
            half_theta_rad: std::f64::consts::PI,
        };
        let found = matcher.best(&points, &window, 0.5, &[]).unwrap();
        assert_near(&truth, &found);
    }

    /// The rival of `found` and the brute force's best pose `apart` from its best, scoring at
    /// least its `rival_above` share of the best's score (the floor is rounded to f32: allow
    /// that rounding).
    fn rival_and_brute_force(
        matcher: &CorrelativeMatcher,
        points: &[Vec2],
        found: &WindowBest,
        apart: (f64, f64),
    ) -> (Option<Candidate>, Option<Candidate>) {
        let exclusion = [Exclusion {
            center: found.best.map_from_robot,
            radius_m: apart.0,
            radius_rad: apart.1,
        }];
        let brute = matcher
            .best_brute_force(points, &found.window, &exclusion)
            .filter(|c| c.score >= found.rival_above * found.best.score - 1e-6);
        (matcher.rival(found, apart), brute)
    }

    #[test]
    fn the_rival_is_the_best_pose_apart_from_the_best() {
        let (segs, pillar) = room();
        let matcher = CorrelativeMatcher::new(ScoreRaster::of(&segs, &pillar, 0.1, 0.2));
        let points = scan_of(&segs, &pillar, Pose2::new(0.2, 0.1, 0.05));
        let window = SearchWindow {
            center: Pose2::IDENTITY,
            half_xy_m: 0.6,
            half_theta_rad: 0.4,
        };
        let apart = (0.3, 0.1);
        let mut both_kinds = [false, false];
        for rival_above in [0.1, 0.3, 0.5, 0.7, 0.8, 0.9, 0.95, 0.99] {
            let found = matcher
                .window_best(&points, &window, 0.0, None, rival_above)
                .unwrap();
            let best = matcher.best_brute_force(&points, &window, &[]).unwrap();
            assert_eq!(found.best.score, best.score);
            // The search goes on from the queue the best's search left: the same score as
            // scoring every pose apart from the best.
            let (rival, brute) = rival_and_brute_force(&matcher, &points, &found, apart);
            assert_eq!(
                rival.map(|c| c.score),
                brute.map(|c| c.score),
                "{rival_above}"
            );
            both_kinds[rival.is_some() as usize] = true;
            if let Some(r) = rival {
                let d = best.map_from_robot.between(&r.map_from_robot);
                assert!(d.translation().length() > apart.0 || d.theta_rad.abs() > apart.1);
            }
        }
        assert_eq!(
            both_kinds,
            [true, true],
            "some floors find a rival, some do not"
        );
        // A seed scoring above every pose of the window is the best, and has no rival here.
        let seed = Candidate {
            map_from_robot: Pose2::new(0.2, 0.1, 0.05),
            score: 2.0,
        };
        let found = matcher
            .window_best(&points, &window, 2.0, Some(seed), 0.95)
            .unwrap();
        assert_eq!((found.best, matcher.rival(&found, apart)), (seed, None));
        // A seed scoring under the search's floor (nothing reached it): its rival is searched
        // afresh, down to its own floor.
        let low = Candidate {
            map_from_robot: Pose2::new(0.2, 0.1, 0.05),
            score: 0.3,
        };
        let found = matcher
            .window_best(&points, &window, 2.0, Some(low), 0.95)
            .unwrap();
        let rival = matcher.rival(&found, apart).expect("a pose above 0.3");
        assert!(rival.score >= 0.95 * 0.3 - 1e-6, "{rival:?}");
    }

    /// A queue of at most a few blocks: every search goes on depth first from it, and finds
    /// the same scores as the brute force (the best, the rival apart from it, the peaks).
    #[test]
    fn a_full_queue_goes_on_depth_first_with_the_same_scores() {
        let (segs, pillar) = room();
        let raster = ScoreRaster::of(&segs, &pillar, 0.1, 0.2);
        let queued = CorrelativeMatcher::new(raster.clone());
        let small = CorrelativeMatcher::new(raster).with_max_queued(4);
        let points = scan_of(&segs, &pillar, Pose2::new(0.2, 0.1, 0.05));
        let window = SearchWindow {
            center: Pose2::IDENTITY,
            half_xy_m: 0.6,
            half_theta_rad: 0.4,
        };
        let best = small.best(&points, &window, 0.0, &[]).unwrap();
        let brute = small.best_brute_force(&points, &window, &[]).unwrap();
        assert_eq!(best.score, brute.score);
        let apart = (0.3, 0.1);
        for rival_above in [0.5, 0.8, 0.9] {
            let found = small
                .window_best(&points, &window, 0.0, None, rival_above)
                .unwrap();
            assert!(found.frontier.spent, "the queue overflowed");
            let (rival, brute) = rival_and_brute_force(&small, &points, &found, apart);
            assert_eq!(rival.map(|c| c.score), brute.map(|c| c.score));
        }
        let score = |peaks: Vec<Candidate>| peaks.iter().map(|c| c.score).collect::<Vec<_>>();
        assert_eq!(
            score(small.peaks(&points, &window, 0.0, 3, 0.3, 0.1)),
            score(queued.peaks(&points, &window, 0.0, 3, 0.3, 0.1))
        );
    }

    /// A window centred far off a long, thin raster: cells whose flat index would overflow
    /// an `i32` at zero offset, brought onto the raster by the window's offsets, are summed
    /// with checks (once an index out of bounds).
    #[test]
    fn a_window_far_off_a_wide_raster_is_searched_with_checks() {
        let segs = [Segment::new(Vec2::new(0.0, 0.0), Vec2::new(6000.0, 0.0))];
        let raster = ScoreRaster::of(&segs, &[], 0.1, 0.2);
        let matcher = CorrelativeMatcher::new(raster);
        let points = [
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(2.0, 0.0),
        ];
        let window = SearchWindow {
            center: Pose2::new(3000.0, -4000.0, 0.0),
            half_xy_m: 4100.0,
            half_theta_rad: 0.0,
        };
        let found = matcher.best(&points, &window, 0.5, &[]).expect("the wall");
        assert!(found.score > 0.9, "{found:?}");
        assert!(found.map_from_robot.y_m.abs() < 0.2, "{found:?}");
    }

    #[test]
    fn peaks_are_apart_and_a_high_floor_finds_nothing() {
        let (segs, pillar) = room();
        let matcher = CorrelativeMatcher::new(ScoreRaster::of(&segs, &pillar, 0.1, 0.2));
        let points = scan_of(&segs, &pillar, Pose2::IDENTITY);
        let window = SearchWindow {
            center: Pose2::IDENTITY,
            half_xy_m: 0.8,
            half_theta_rad: 0.3,
        };
        let peaks = matcher.peaks(&points, &window, 0.0, 3, 0.3, 0.1);
        assert_eq!(peaks.len(), 3);
        for (i, a) in peaks.iter().enumerate() {
            for b in &peaks[i + 1..] {
                let d = a.map_from_robot.between(&b.map_from_robot);
                assert!(d.translation().length() > 0.3 || d.theta_rad.abs() > 0.1);
                assert!(a.score >= b.score);
            }
        }
        assert!(matcher.best(&points, &window, 1.01, &[]).is_none());
        assert!(matcher.best(&[], &window, 0.0, &[]).is_none());
    }
}
