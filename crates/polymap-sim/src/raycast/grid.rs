//! The fast ray caster: a uniform grid of obstacle lists walked cell by cell.

use polymap::geometry::{Segment, Vec2};

use super::{Obstacle, RayHit, closer, direction, hit, ray_circle_m, ray_segment_m};
use crate::world::{Pillar, World};

/// Preferred grid cell size, metres: a few walls per cell in a building.
const CELL_M: f64 = 1.0;
/// Most cells along one axis; huge worlds get coarser cells instead of more of them.
const MAX_CELLS_PER_AXIS: f64 = 512.0;
/// Margin added round the world's bounds, metres.
const MARGIN_M: f64 = 0.5;
/// Slack when registering obstacles in cells and when stopping the walk, metres: keeps
/// rounding at cell borders from hiding a hit.
const SLACK_M: f64 = 1e-6;

/// A ray caster over one world, built once and then queried for every beam.
///
/// ```
/// use polymap::geometry::Vec2;
/// use polymap_sim::{World, raycast::{Obstacle, RayCaster, cast_ray_brute}};
/// let world = World::hallway45();
/// let caster = RayCaster::new(&world);
/// let from = Vec2::new(2.0, 0.0);
/// // Straight down: the outer wall at y = -1 is 1 m away.
/// let hit = caster.cast(from, -std::f64::consts::FRAC_PI_2, 30.0).unwrap();
/// assert!((hit.range_m - 1.0).abs() < 1e-12);
/// assert!(matches!(hit.obstacle, Obstacle::Wall(_)));
/// let brute = cast_ray_brute(&world, from, 0.3, 30.0).map(|h| h.range_m);
/// assert_eq!(caster.cast(from, 0.3, 30.0).map(|h| h.range_m), brute);
/// ```
#[derive(Debug, Clone)]
pub struct RayCaster {
    walls: Vec<Segment>,
    pillars: Vec<Pillar>,
    /// Lower-left corner of the grid, metres, world frame.
    min: Vec2,
    /// Upper-right corner of the grid, metres, world frame.
    max: Vec2,
    cell_m: f64,
    nx: usize,
    ny: usize,
    /// Cell `c`'s obstacles are `items[cell_start[c]..cell_start[c + 1]]`.
    cell_start: Vec<usize>,
    /// Obstacle ids: below `walls.len()` a wall, else a pillar.
    items: Vec<usize>,
}

/// An obstacle's id and bounding box.
type Boxed = (usize, Vec2, Vec2);

impl RayCaster {
    /// Indexes a world's finite walls and valid pillars.
    pub fn new(world: &World) -> RayCaster {
        let (lo, hi) = world.bounds().unwrap_or((Vec2::ZERO, Vec2::ZERO));
        let (min, max) = (lo - Vec2::splat(MARGIN_M), hi + Vec2::splat(MARGIN_M));
        let extent = max - min;
        let cell_m = CELL_M.max(extent.max_element() / MAX_CELLS_PER_AXIS);
        let nx = ((extent.x / cell_m).ceil() as usize).max(1);
        let ny = ((extent.y / cell_m).ceil() as usize).max(1);
        let mut caster = RayCaster {
            walls: world.walls.clone(),
            pillars: world.pillars.clone(),
            min,
            max,
            cell_m,
            nx,
            ny,
            cell_start: Vec::new(),
            items: Vec::new(),
        };
        caster.fill_cells();
        caster
    }

    /// Every obstacle with its bounding box, grown by the slack.
    fn boxes(&self) -> Vec<Boxed> {
        let slack = Vec2::splat(SLACK_M);
        let walls = self
            .walls
            .iter()
            .enumerate()
            .filter(|(_, w)| w.is_finite())
            .map(|(i, w)| {
                let (a, b) = w.bounds();
                (i, a - slack, b + slack)
            });
        let n = self.walls.len();
        let pillars = self
            .pillars
            .iter()
            .enumerate()
            .filter(|(_, p)| p.is_valid())
            .map(|(j, p)| {
                let r = Vec2::splat(p.radius_m + SLACK_M);
                (n + j, p.center - r, p.center + r)
            });
        walls.chain(pillars).collect()
    }

    /// The cell column or row of a coordinate offset from the grid's corner, clamped.
    fn cell_of(&self, offset_m: f64, cells: usize) -> usize {
        let k = (offset_m / self.cell_m).floor();
        if k > 0.0 {
            (k as usize).min(cells - 1)
        } else {
            0
        }
    }

    /// The inclusive cell ranges `(x0, x1, y0, y1)` covered by a bounding box.
    fn cell_range(&self, lo: Vec2, hi: Vec2) -> (usize, usize, usize, usize) {
        let (a, b) = (lo - self.min, hi - self.min);
        (
            self.cell_of(a.x, self.nx),
            self.cell_of(b.x, self.nx),
            self.cell_of(a.y, self.ny),
            self.cell_of(b.y, self.ny),
        )
    }

    /// Builds the compressed cell lists (count, prefix sum, fill).
    fn fill_cells(&mut self) {
        let boxes = self.boxes();
        let mut counts = vec![0usize; self.nx * self.ny + 1];
        for &(_, lo, hi) in &boxes {
            let (x0, x1, y0, y1) = self.cell_range(lo, hi);
            for iy in y0..=y1 {
                for ix in x0..=x1 {
                    counts[iy * self.nx + ix + 1] += 1;
                }
            }
        }
        for c in 1..counts.len() {
            counts[c] += counts[c - 1];
        }
        let mut next = counts.clone();
        let mut items = vec![0usize; counts[counts.len() - 1]];
        for &(id, lo, hi) in &boxes {
            let (x0, x1, y0, y1) = self.cell_range(lo, hi);
            for iy in y0..=y1 {
                for ix in x0..=x1 {
                    let c = iy * self.nx + ix;
                    items[next[c]] = id;
                    next[c] += 1;
                }
            }
        }
        self.cell_start = counts;
        self.items = items;
    }

    /// The nearest wall or pillar hit from `origin` (world frame) at `bearing_rad` (from the
    /// world x axis), closer than `max_range_m`; `None` means no return.
    ///
    /// Returns the same range as [`super::cast_ray_brute`].
    pub fn cast(&self, origin: Vec2, bearing_rad: f64, max_range_m: f64) -> Option<RayHit> {
        let dir = direction(bearing_rad);
        if !origin.is_finite() || !dir.is_finite() || self.items.is_empty() {
            return None;
        }
        let (t_enter, t_leave) = self.clip(origin, dir)?;
        let t0 = t_enter.max(0.0);
        if t0 >= t_leave.min(max_range_m) {
            return None;
        }
        let best = self.walk(origin, dir, t0, max_range_m);
        best.map(|(t, o)| hit(origin, dir, t, o))
    }

    /// Where the ray enters and leaves the grid's box (slab method), or `None` if it misses.
    fn clip(&self, origin: Vec2, dir: Vec2) -> Option<(f64, f64)> {
        let inv = dir.recip();
        let ta = (self.min - origin) * inv;
        let tb = (self.max - origin) * inv;
        let (lo, hi) = (ta.min(tb), ta.max(tb));
        // An axis-parallel ray gives NaN (0 · ∞) only when it runs along a box face: treat the
        // face as inside.
        let enter = lo.x.max(lo.y);
        let leave = hi.x.min(hi.y);
        (enter <= leave && leave > 0.0).then_some((enter, leave))
    }

    /// One axis of the walk: `(step, t of the next border, t between borders)`.
    fn axis(&self, o: f64, d: f64, lo: f64, cell: usize) -> (isize, f64, f64) {
        if d > 0.0 {
            (
                1,
                (lo + (cell + 1) as f64 * self.cell_m - o) / d,
                self.cell_m / d,
            )
        } else if d < 0.0 {
            (
                -1,
                (lo + cell as f64 * self.cell_m - o) / d,
                -self.cell_m / d,
            )
        } else {
            (0, f64::INFINITY, f64::INFINITY)
        }
    }

    /// The grid walk from parameter `t0`: the nearest hit and what it hit.
    fn walk(&self, origin: Vec2, dir: Vec2, t0: f64, max_range_m: f64) -> Option<(f64, Obstacle)> {
        let p = origin + dir * t0 - self.min;
        let (mut ix, mut iy) = (self.cell_of(p.x, self.nx), self.cell_of(p.y, self.ny));
        let (sx, mut tx, dtx) = self.axis(origin.x, dir.x, self.min.x, ix);
        let (sy, mut ty, dty) = self.axis(origin.y, dir.y, self.min.y, iy);
        let mut best: Option<(f64, Obstacle)> = None;
        let mut best_m = max_range_m;
        loop {
            self.test_cell(iy * self.nx + ix, origin, dir, &mut best, &mut best_m);
            let t_exit = tx.min(ty);
            if best_m < t_exit - SLACK_M || t_exit >= max_range_m {
                return best;
            }
            let (i, n, s, t, dt) = if tx < ty {
                (&mut ix, self.nx, sx, &mut tx, dtx)
            } else {
                (&mut iy, self.ny, sy, &mut ty, dty)
            };
            match i.checked_add_signed(s) {
                Some(k) if k < n => *i = k,
                _ => return best,
            }
            *t += dt;
        }
    }

    /// Tests every obstacle listed in one cell, keeping the nearest.
    fn test_cell(
        &self,
        c: usize,
        origin: Vec2,
        dir: Vec2,
        best: &mut Option<(f64, Obstacle)>,
        best_m: &mut f64,
    ) {
        for &id in &self.items[self.cell_start[c]..self.cell_start[c + 1]] {
            let (t, obstacle) = match self.walls.get(id) {
                Some(w) => (ray_segment_m(origin, dir, w), Obstacle::Wall(id)),
                None => {
                    let j = id - self.walls.len();
                    (
                        self.pillars
                            .get(j)
                            .and_then(|p| ray_circle_m(origin, dir, p)),
                        Obstacle::Pillar(j),
                    )
                }
            };
            if let Some(t) = closer(t, *best_m) {
                *best = Some((t, obstacle));
                *best_m = t;
            }
        }
    }
}
