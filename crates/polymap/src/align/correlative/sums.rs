//! The bounds of blocks: a block's sum over the scan's points, and the four children of an
//! opened block in one pass, optionally from a level's values side by side with their
//! right-hand siblings'.
//!
//! The children of a block one level up lie at `(x, y)`, `(x + s, y)`, `(x, y + s)` and
//! `(x + s, y + s)` with `s = 2^level`: per scan point, four values of the level apart in
//! memory, each loaded on its own (the index computed, masked and loaded four times: the sums
//! of the four children were a third of a sparse run's instructions). With each value stored
//! beside the one `s` cells to its right ([`siblings`]), a point's four values are two loads
//! of two values: the children's sums take less than half the instructions. Building that
//! copy of a level costs about as much as 50 openings at that level save, so a matcher builds
//! it only once its searches (the best's, the rival's, the peaks') have opened
//! [`SIBLINGS_AFTER`] blocks there together (a search on the sparse logs opens from a few
//! hundred to a few thousand), and keeps it for the searches after. The values are those of
//! the level, so every sum is the same either way.

use super::search::{Block, Rotations};
use super::{CorrelativeMatcher, LANES, masked};
use crate::align::buffers::{self, Buffer};

/// A matcher builds a level's [`siblings`] once its searches have summed the children of this
/// many blocks at that level.
pub(super) const SIBLINGS_AFTER: u32 = 64;

/// Level values `values` (rows of the padded width; `len` of them valid, the slice's length a
/// power of two) with the value `2^level` cells to their right: entry `i` of the result (as
/// pairs: `2i`, `2i + 1`) is `(values[i], values[i + 2^level])`, the second 0 past `len`. The
/// result holds as many pairs as `values` holds values; pairs past `len` are never read.
pub(super) fn siblings(values: &[f32], len: usize, level: u32) -> Buffer {
    let s = (1usize << level).min(len);
    let mut out = buffers::reused(2 * values.len());
    let (pairs, _) = out.as_chunks_mut::<2>();
    let (near, far) = pairs[..len].split_at_mut(len - s);
    for ((p, &a), &b) in near.iter_mut().zip(&values[..len - s]).zip(&values[s..len]) {
        *p = [a, b];
    }
    for (p, &a) in far.iter_mut().zip(&values[len - s..len]) {
        *p = [a, 0.0];
    }
    out
}

/// The sums of `N` children over the points at flat indices `flat`, the values of a point
/// given by `values`: point `i` into lane `i % LANES` of each child (the order of
/// [`CorrelativeMatcher::block`]), as `N` sums per lane. A point's `N` values stay together
/// and are added to its lane's `N` sums at once (one vector addition for `N = 4`, with
/// [`siblings`] two loads straight into it): no shuffling of values across children, and
/// the eight lanes' sums fit in registers. Each child's lane still adds its points in their
/// order, so every sum is the same.
#[inline(always)]
fn sum_children<const N: usize>(
    flat: &[i32],
    values: impl Fn(i32) -> [f32; N],
) -> [[f32; N]; LANES] {
    let mut lanes = [[0f32; N]; LANES];
    let mut chunks = flat.chunks_exact(LANES);
    for chunk in &mut chunks {
        for (lane, &at) in lanes.iter_mut().zip(chunk) {
            for (sum, v) in lane.iter_mut().zip(values(at)) {
                *sum += v;
            }
        }
    }
    for (lane, &at) in lanes.iter_mut().zip(chunks.remainder()) {
        for (sum, v) in lane.iter_mut().zip(values(at)) {
            *sum += v;
        }
    }
    lanes
}

/// Child `c`'s bound from the lanes of [`sum_children`]: its lanes added in order, as in
/// [`CorrelativeMatcher::block`].
#[inline(always)]
fn child_bound<const N: usize>(lanes: &[[f32; N]; LANES], c: usize) -> f32 {
    lanes.iter().fold(0f32, |sum, lane| sum + lane[c])
}

impl CorrelativeMatcher {
    /// The block at `(ix, iy)` of `level` for rotation `r`, with its bound.
    pub(super) fn block(
        &self,
        rotations: &Rotations,
        r: usize,
        ix: i64,
        iy: i64,
        level: u32,
    ) -> Block {
        let values = &self.levels[level as usize];
        let mask = masked(values);
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
                    *lane += values[(at as i64 + offset) as usize & mask];
                }
            }
            for (lane, &at) in lanes.iter_mut().zip(chunks.remainder()) {
                *lane += values[(at as i64 + offset) as usize & mask];
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

    /// The four blocks of `level` at `(ix, iy)`, `(ix + s, iy)`, `(ix, iy + s)` and `(ix + s,
    /// iy + s)` with `s = 2^level` (the children of a block one level up), when all four lie
    /// inside the raster (else `None`): each bound is [`CorrelativeMatcher::block`]'s sum in
    /// its order (bit-identical), the four taken in one pass over the points, which shares
    /// the index loads and lets four gathers overlap. With the level's `pairs` ([`siblings`]),
    /// a point's four values are two loads; the values, and so the sums, are the same.
    pub(super) fn quad(
        &self,
        rotations: &Rotations,
        r: usize,
        (ix, iy): (i64, i64),
        level: u32,
        pairs: Option<&[[f32; 2]]>,
    ) -> Option<[Block; 4]> {
        let size = 1i64 << level;
        let (ox, oy) = (ix + self.pad, iy + self.pad);
        let (x0, y0, x1, y1) = rotations.extent[r]?;
        let inside = x0 + ox >= 0
            && y0 + oy >= 0
            && x1 + ox + size < self.padded_width
            && y1 + oy + size < self.padded_height;
        if !inside {
            return None;
        }
        let offset = oy * self.padded_width + ox;
        let up = (size * self.padded_width) as usize;
        let lanes = match pairs {
            Some(pairs) => {
                // Each point's four values as two pairs: the point and its right-hand
                // sibling, the point a block up and its sibling.
                let mask = pairs.len().wrapping_sub(1);
                sum_children(rotations.flat(r), |at| {
                    let here = (at as i64 + offset) as usize;
                    let ([a, b], [c, d]) = (pairs[here & mask], pairs[(here + up) & mask]);
                    [a, b, c, d]
                })
            }
            None => {
                let values = &self.levels[level as usize];
                let mask = masked(values);
                let corners = [0, size as usize, up, up + size as usize];
                sum_children(rotations.flat(r), |at| {
                    let here = (at as i64 + offset) as usize;
                    corners.map(|c| values[(here + c) & mask])
                })
            }
        };
        let block = |(dx, dy), c| Block {
            rotation: r,
            ix: ix + dx,
            iy: iy + dy,
            level,
            bound: child_bound(&lanes, c),
        };
        Some([
            block((0, 0), 0),
            block((size, 0), 1),
            block((0, size), 2),
            block((size, size), 3),
        ])
    }
}

impl CorrelativeMatcher {
    /// The two blocks of `level` at `(ix, iy)` and at `(ix + s, iy)` (`across`) or `(ix, iy +
    /// s)` (else), `s = 2^level`: the children of a block one level up at the window's far
    /// edge, where the other two lie outside the window. `None` unless the block one level up
    /// lies inside the raster (as for [`CorrelativeMatcher::quad`]). Each bound is
    /// [`CorrelativeMatcher::block`]'s sum in its order (bit-identical), the two taken in one
    /// pass over the points; with the level's `pairs` ([`siblings`]) the two blocks across are
    /// one load per point.
    pub(super) fn pair(
        &self,
        rotations: &Rotations,
        r: usize,
        (ix, iy): (i64, i64),
        level: u32,
        across: bool,
        pairs: Option<&[[f32; 2]]>,
    ) -> Option<[Block; 2]> {
        let size = 1i64 << level;
        let (ox, oy) = (ix + self.pad, iy + self.pad);
        let (x0, y0, x1, y1) = rotations.extent[r]?;
        let inside = x0 + ox >= 0
            && y0 + oy >= 0
            && x1 + ox + size < self.padded_width
            && y1 + oy + size < self.padded_height;
        if !inside {
            return None;
        }
        let offset = oy * self.padded_width + ox;
        let step = match across {
            true => size as usize,
            false => (size * self.padded_width) as usize,
        };
        let lanes = match pairs {
            Some(pairs) if across => {
                let mask = pairs.len().wrapping_sub(1);
                sum_children(rotations.flat(r), |at| {
                    pairs[(at as i64 + offset) as usize & mask]
                })
            }
            _ => {
                let values = &self.levels[level as usize];
                let mask = masked(values);
                sum_children(rotations.flat(r), |at| {
                    let here = (at as i64 + offset) as usize;
                    [values[here & mask], values[(here + step) & mask]]
                })
            }
        };
        let (dx, dy) = match across {
            true => (size, 0),
            false => (0, size),
        };
        let block = |(dx, dy), c| Block {
            rotation: r,
            ix: ix + dx,
            iy: iy + dy,
            level,
            bound: child_bound(&lanes, c),
        };
        Some([block((0, 0), 0), block((dx, dy), 1)])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_value_sits_beside_the_one_a_block_to_its_right() {
        let values: Vec<f32> = (0..32).map(|i| i as f32 * 0.5).collect();
        for level in 0..4 {
            let len = 27;
            let out = siblings(&values, len, level);
            assert_eq!(out.len(), 64);
            let s = 1usize << level;
            for i in 0..len {
                let right = if i + s < len { values[i + s] } else { 0.0 };
                assert_eq!(
                    (out[2 * i], out[2 * i + 1]),
                    (values[i], right),
                    "{level} {i}"
                );
            }
        }
    }
}
