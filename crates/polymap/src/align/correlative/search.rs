//! The search state of the correlative matcher: a window's rotations and the points' cells,
//! blocks of translations with their bounds, the best-first queue, and the search over it.

use super::sums::{SIBLINGS_AFTER, siblings};
use super::{Candidate, CorrelativeMatcher, Exclusion, SearchWindow};
use crate::geometry::{Pose2, Vec2, normalize_angle_rad};
use std::cell::OnceCell;
use std::collections::BinaryHeap;

/// The rotations of a window: for each, the points' cells at zero offset, all rotations in
/// shared buffers (four allocations per search instead of two per rotation).
#[derive(Debug, Clone, Default)]
pub(super) struct Rotations {
    pub(super) theta_rad: Vec<f64>,
    /// Per rotation, the smallest and largest cell coordinates, `(min_x, min_y, max_x, max_y)`,
    /// when its flat indices are valid: a block whose every cell lands inside the raster is
    /// summed from them without checks. `None` for no cells, or for a rotation whose extent
    /// has a corner (`(min_x, min_y)` or `(max_x, max_y)`, bounding every cell's flat index)
    /// whose flat index does not fit an `i32` (far from a wide raster, where a block's offset
    /// may still bring it inside): its blocks are summed with checks (the same sums).
    pub(super) extent: Vec<Option<(i64, i64, i64, i64)>>,
    /// `points` cells per rotation, rotation after rotation; coordinates clamped to
    /// `±CELL_CLAMP` (still outside every raster).
    pub(super) cells: Vec<(i32, i32)>,
    /// Each cell as its index into a level's padded values at zero offset (`y × padded width +
    /// x`), valid where the rotation's extent lies inside: a block inside the raster adds one
    /// offset per point instead of a row product.
    pub(super) flat: Vec<i32>,
    pub(super) points: usize,
}

/// The largest cell coordinate kept (far beyond any raster: at most 2²⁰ cells).
pub(super) const CELL_CLAMP: i64 = 1 << 30;

impl Rotations {
    pub(super) fn len(&self) -> usize {
        self.theta_rad.len()
    }

    pub(super) fn cells(&self, r: usize) -> &[(i32, i32)] {
        &self.cells[r * self.points..(r + 1) * self.points]
    }

    pub(super) fn flat(&self, r: usize) -> &[i32] {
        &self.flat[r * self.points..(r + 1) * self.points]
    }
}

/// A block of translations: offsets `[ix, ix + 2^level) × [iy, iy + 2^level)` cells at one
/// rotation, with its bound.
#[derive(Debug, Clone, Copy)]
pub(super) struct Block {
    pub(super) rotation: usize,
    pub(super) ix: i64,
    pub(super) iy: i64,
    pub(super) level: u32,
    pub(super) bound: f32,
}

/// A block waiting to be opened, compact (a frontier holds thousands: 16 bytes each), in one
/// number whose order is the queue's: above 64 bits the key (its bound's bits in an
/// order-preserving form; at equal bounds the higher level first, a block may hold a pose as
/// good as one already queued; then the pose nearer the window's centre: among poses scoring
/// alike, the one the prediction favours, whatever the order of the search), below them the
/// rotation and the offsets. The order is total, so every block is taken in one fixed order
/// whatever else the queue holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(super) struct Queued(u128);

/// Bits of the key below the bound's and the level's: the nearness to the centre.
pub(super) const NEAR_BITS: u32 = 24;

/// Offsets are kept as `offset + OFFSET_HALF` in 20 bits (a window reaches at most 2¹⁶ cells,
/// and a block 2⁶ beyond; rotations are at most 8,001, kept in 24 bits).
const OFFSET_HALF: i64 = 1 << 19;

impl Queued {
    /// `b` queued, for a window of `rotations` rotations.
    pub(super) fn of(b: &Block, rotations: usize) -> Self {
        // Finite and infinite floats ordered as `total_cmp` orders them.
        let bits = b.bound.to_bits();
        let ordered = match bits >> 31 {
            1 => !bits,
            _ => bits | 1 << 31,
        };
        let turn = b.rotation.abs_diff(rotations / 2) as u64;
        let off = turn + b.ix.unsigned_abs() + b.iy.unsigned_abs();
        let near = (1u64 << NEAR_BITS) - 1 - off.min((1 << NEAR_BITS) - 1);
        let key = (ordered as u64) << 32 | (b.level as u64) << NEAR_BITS | near;
        let offset = |v: i64| (v + OFFSET_HALF).clamp(0, 2 * OFFSET_HALF - 1) as u128;
        Queued(
            (key as u128) << 64
                | ((b.rotation as u128) & 0xff_ffff) << 40
                | offset(b.ix) << 20
                | offset(b.iy),
        )
    }

    /// The bound queued (a sum of raster values).
    pub(super) fn bound(&self) -> f32 {
        let bits = (self.0 >> 96) as u32;
        f32::from_bits(match bits >> 31 {
            1 => bits & !(1 << 31),
            _ => !bits,
        })
    }

    pub(super) fn block(&self) -> Block {
        let offset = |shift: u32| ((self.0 >> shift) & 0xf_ffff) as i64 - OFFSET_HALF;
        Block {
            rotation: ((self.0 >> 40) & 0xff_ffff) as usize,
            ix: offset(20),
            iy: offset(0),
            level: ((self.0 >> (64 + NEAR_BITS)) & 0xff) as u32,
            bound: self.bound(),
        }
    }
}

/// The blocks of a search not opened yet, best bound first; only blocks whose bound reaches
/// `keep` (a sum of raster values) are kept: no search from this frontier asks for less.
/// Blocks under every floor asked so far wait in `deferred`, out of the queue (most blocks
/// kept for a rival are never taken: a queue of them only made every taking dearer), and join
/// the queue when a search asks for a lower floor. `spent` once a search went on depth first
/// from it ([`MAX_QUEUED`]): nothing can go on from it then.
#[derive(Debug, Clone, Default)]
pub(super) struct Frontier {
    pub(super) queue: BinaryHeap<Queued>,
    /// Blocks bounded under `deferred_below`, in no order.
    deferred: Vec<Queued>,
    /// Every deferred block's bound lies under it; `None` before any search.
    deferred_below: Option<f32>,
    pub(super) keep: f32,
    pub(super) spent: bool,
}

impl Frontier {
    /// The queue of `blocks` (a window's top blocks, of `rotations` rotations) reaching
    /// `keep`.
    pub(super) fn of(blocks: &[Block], rotations: usize, keep: f32) -> Self {
        let queue = blocks
            .iter()
            .filter(|b| b.bound >= keep)
            .map(|b| Queued::of(b, rotations))
            .collect();
        Frontier {
            queue,
            keep,
            ..Frontier::default()
        }
    }

    /// How many blocks wait, queued or deferred.
    pub(super) fn len(&self) -> usize {
        self.queue.len() + self.deferred.len()
    }

    /// Moves the deferred blocks reaching `floor` into the queue: a search for `floor` then
    /// takes every block it could take from the queue.
    fn admit(&mut self, floor: f32) {
        if self.deferred_below.is_some_and(|below| below <= floor) {
            return;
        }
        let mut i = 0;
        while i < self.deferred.len() {
            if self.deferred[i].bound() >= floor {
                self.queue.push(self.deferred.swap_remove(i));
            } else {
                i += 1;
            }
        }
        self.deferred_below = Some(floor);
    }

    /// Whether a block bounded by `bound` waits deferred: under the lowest floor asked.
    fn defers(&self, bound: f32) -> bool {
        self.deferred_below.is_some_and(|below| bound < below)
    }

    /// Keeps block `q` (bound `bound`): queued when it reaches the lowest floor asked, else
    /// deferred.
    fn add(&mut self, q: Queued, bound: f32) {
        match self.defers(bound) {
            true => self.deferred.push(q),
            false => self.queue.push(q),
        }
    }

    /// Every block waiting, in ascending order; the frontier is left empty.
    fn take_sorted(&mut self) -> Vec<Queued> {
        let mut all = std::mem::take(&mut self.queue).into_vec();
        all.append(&mut self.deferred);
        all.sort_unstable();
        all
    }
}

/// One window prepared for one set of points: its rotations and its top blocks.
#[derive(Debug, Clone)]
pub(super) struct Prepared {
    pub(super) rotations: Rotations,
    pub(super) reach: i64,
    pub(super) blocks: Vec<Block>,
    pub(super) points: usize,
}

impl Prepared {
    /// The search state over this window with `exclusions`.
    pub(super) fn context<'a>(
        &'a self,
        matcher: &'a CorrelativeMatcher,
        window: &'a SearchWindow,
        exclusions: &'a [Exclusion],
    ) -> Search<'a> {
        Search::new(matcher, &self.rotations, window, self.reach, exclusions)
    }

    /// The queue of this window's top blocks reaching `keep` (a sum of raster values).
    pub(super) fn frontier(&self, keep: f32) -> Frontier {
        Frontier::of(&self.blocks, self.rotations.len(), keep)
    }

    /// The sum of raster values a mean score of `min_score` asks for.
    pub(super) fn floor(&self, min_score: f64) -> f32 {
        (min_score * self.points as f64) as f32
    }

    /// The pose and mean score of a leaf found with its sum.
    pub(super) fn candidate(
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

/// The state of one search.
pub(super) struct Search<'a> {
    pub(super) matcher: &'a CorrelativeMatcher,
    pub(super) rotations: &'a Rotations,
    pub(super) window: &'a SearchWindow,
    pub(super) reach: i64,
    pub(super) exclusions: &'a [Exclusion],
}

impl<'a> Search<'a> {
    /// A search of `window` for the points of `rotations`, `reach` cells each way, outside
    /// `exclusions`.
    pub(super) fn new(
        matcher: &'a CorrelativeMatcher,
        rotations: &'a Rotations,
        window: &'a SearchWindow,
        reach: i64,
        exclusions: &'a [Exclusion],
    ) -> Self {
        Search {
            matcher,
            rotations,
            window,
            reach,
            exclusions,
        }
    }

    /// Level `level`'s values beside their siblings' ([`siblings`]) once the searches of this
    /// matcher have summed the children of [`SIBLINGS_AFTER`] blocks there (built then);
    /// `None` before.
    fn pairs(&self, level: u32) -> Option<&'a [[f32; 2]]> {
        let l = level as usize;
        let m = self.matcher;
        let built = m.siblings.get(l)?.get().or_else(|| {
            let n = m.summed[l].get() + 1;
            m.summed[l].set(n);
            (n >= SIBLINGS_AFTER).then(|| {
                let len = (m.padded_width * m.padded_height) as usize;
                m.siblings[l].get_or_init(|| siblings(&m.levels[l], len, level))
            })
        })?;
        Some(built.as_chunks::<2>().0)
    }
}

impl Search<'_> {
    /// The best pose left in `frontier` outside the exclusions and reaching `floor` (a sum of
    /// raster values), as its sum and leaf block: blocks are opened best bound first, so the
    /// first pose taken scores at least every bound left. Opened and excluded blocks leave the
    /// queue; children reaching the queue's `keep` join it. Beyond `max_queued` blocks the
    /// search goes on depth first from the queue, which is then spent.
    pub(super) fn next(&self, frontier: &mut Frontier, floor: f32) -> Option<(f32, Block)> {
        frontier.admit(floor);
        while let Some(b) = frontier.queue.peek().map(Queued::block) {
            if b.bound < floor {
                return None;
            }
            if frontier.len() > self.matcher.max_queued {
                let queue = frontier.take_sorted();
                frontier.spent = true;
                let mut best = None;
                for q in queue.iter().rev() {
                    self.descend(q.block(), floor, &mut best);
                }
                return best;
            }
            // A whole block inside an exclusion holds nothing to find (for a single pose, the
            // pose itself).
            if self.excluded(&b) {
                frontier.queue.pop();
                continue;
            }
            if b.level == 0 {
                frontier.queue.pop();
                return Some((b.bound, b));
            }
            // The opened block leaves the queue: its first child bound for the queue takes its
            // place at the top (one sift down instead of a pop and a push; every child ranks
            // below its parent). The queue holds the same blocks either way, and its order is
            // total, so they are taken in the same order.
            let mut opened = false;
            for child in self.children(&b).into_iter().flatten() {
                if child.bound < frontier.keep {
                    continue;
                }
                let q = Queued::of(&child, self.rotations.len());
                match opened || frontier.defers(child.bound) {
                    true => frontier.add(q, child.bound),
                    false => {
                        if let Some(mut top) = frontier.queue.peek_mut() {
                            *top = q;
                        }
                        opened = true;
                    }
                }
            }
            if !opened {
                frontier.queue.pop();
            }
        }
        None
    }

    /// The four blocks of the level below `b` (level > 0) that lie in the window.
    pub(super) fn children(&self, b: &Block) -> [Option<Block>; 4] {
        let size = 1i64 << (b.level - 1);
        let level = b.level - 1;
        let (across, up) = (b.ix + size <= self.reach, b.iy + size <= self.reach);
        if across && up {
            let pairs = self.pairs(level);
            let quad = self
                .matcher
                .quad(self.rotations, b.rotation, (b.ix, b.iy), level, pairs);
            if let Some(quad) = quad {
                return quad.map(Some);
            }
        } else if across || up {
            // At the window's far edge two children lie inside: summed in one pass (from the
            // level's siblings if built, without counting towards building them).
            let pairs = self
                .matcher
                .siblings
                .get(level as usize)
                .and_then(OnceCell::get)
                .map(|v| v.as_chunks::<2>().0);
            let pair = self.matcher.pair(
                self.rotations,
                b.rotation,
                (b.ix, b.iy),
                level,
                across,
                pairs,
            );
            if let Some([a, c]) = pair {
                return [Some(a), across.then_some(c), up.then_some(c), None];
            }
        }
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
    pub(super) fn descend(&self, b: Block, floor: f32, best: &mut Option<(f32, Block)>) {
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
    pub(super) fn pose(&self, b: Block) -> Pose2 {
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
    pub(super) fn excluded(&self, b: &Block) -> bool {
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
/// [`crate::geometry::floor_i64`] then a clamp, 0 for NaN, without branches and without a
/// float-to-integer conversion (whose saturating semantics kept the loop of
/// [`cells_into`] from being vectorized); see [`floor_in_bits`].
#[inline]
pub(super) fn clamped_floor(v: f64, clamp: f64) -> i32 {
    let v = match v.is_nan() {
        true => 0.0,
        false => v.max(-clamp).min(clamp),
    };
    floor_in_bits(v)
}

/// `floor(v)` as an `i32` for `v` within `±2³⁰`: a value below 2⁵¹ plus 1.5 × 2⁵² rounds to
/// the nearest integer, whose two's complement is then the low 32 bits of that sum. Where the
/// nearest integer lies above the value, the floor is one less: in that sum's range (2⁵² to
/// 2⁵³) consecutive integers are consecutive bit patterns, so one less in the bits.
#[inline]
fn floor_in_bits(v: f64) -> i32 {
    const SHIFT: f64 = 6_755_399_441_055_744.0; // 1.5 × 2⁵²
    let shifted = v + SHIFT;
    let above = u64::from(shifted - SHIFT > v);
    (shifted.to_bits() - above) as u32 as i32
}

/// Whether [`cells_into`] must clamp for the points (`xs`, `ys`) turned by any angle and moved
/// to `center`'s position (its heading finite, as every rotation around it is), on a raster at
/// `origin` with cells of `cell` metres: false where every point is finite and every cell lies
/// within half of [`CELL_CLAMP`] (a point turned keeps each coordinate within `|x| + |y|`;
/// the bound is widened far beyond any rounding), where the clamp and the check for NaN
/// change nothing.
pub(super) fn must_clamp(xs: &[f64], ys: &[f64], center: &Pose2, origin: Vec2, cell: f64) -> bool {
    let t = center.translation();
    let finite = center.theta_rad.is_finite() && xs.iter().chain(ys).all(|v| v.is_finite());
    let spread = xs
        .iter()
        .zip(ys)
        .map(|(x, y)| x.abs() + y.abs())
        .fold(0.0, f64::max);
    let within = |t: f64, o: f64| {
        let reach_m = spread + (t - o).abs() + 1e-6 * (1.0 + spread + t.abs() + o.abs());
        reach_m / cell <= CELL_CLAMP as f64 / 2.0
    };
    !(finite && cell > 0.0 && within(t.x, origin.x) && within(t.y, origin.y))
}

/// Appends to `out` the cells of the points (`xs`, `ys`, robot frame) turned by `(sin, cos)`
/// and moved by `t`, on a raster at `origin` with cells of `cell` metres: the arithmetic of
/// `Pose2::transform_point` then `ScoreRaster::cell_of` (the same cells), clamped to
/// [`CELL_CLAMP`] where `clamped` (as [`must_clamp`] tells: without it the clamp changes
/// nothing). One pass over plain slices, which the compiler vectorizes.
#[allow(clippy::too_many_arguments)]
pub(super) fn cells_into(
    xs: &[f64],
    ys: &[f64],
    (sin, cos): (f64, f64),
    t: Vec2,
    origin: Vec2,
    cell: f64,
    clamped: bool,
    out: &mut Vec<(i32, i32)>,
) {
    let clamp = CELL_CLAMP as f64;
    match clamped {
        true => cells_by(xs, ys, (sin, cos), t, origin, cell, out, |v| {
            clamped_floor(v, clamp)
        }),
        false => cells_by(xs, ys, (sin, cos), t, origin, cell, out, floor_in_bits),
    }
}

/// [`cells_into`] with the floor `floor`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn cells_by(
    xs: &[f64],
    ys: &[f64],
    (sin, cos): (f64, f64),
    t: Vec2,
    origin: Vec2,
    cell: f64,
    out: &mut Vec<(i32, i32)>,
    floor: impl Fn(f64) -> i32,
) {
    // Appended from an iterator of known length: no zeros written first only to be
    // overwritten.
    out.extend(xs.iter().zip(ys).map(|(&x, &y)| {
        let qx = cos * x - sin * y + t.x;
        let qy = sin * x + cos * y + t.y;
        (floor((qx - origin.x) / cell), floor((qy - origin.y) / cell))
    }));
}

pub(super) fn ceil_log2(n: i64) -> u32 {
    let mut level = 0;
    while (1i64 << level) < n {
        level += 1;
    }
    level
}
