//! An occupancy grid for ROS `map_server` / Nav2: occupied cells from the map's segments, free
//! cells from the laser rays along the trajectory, unknown elsewhere.
//!
//! The grid covers the bounding box of the map segments grown by [`GridParams::margin_m`] (a
//! 2 m square around the origin when the map is empty); rays are clipped to it. Cell
//! `(col, row)` covers `[origin + col·res, origin + (col+1)·res)` in x and likewise in y, so row
//! 0 is the *bottom* row (lowest y); [`write_map_server`] flips it, as PGM rows go top-down.
//!
//! ```
//! use polymap::geometry::{Pose2, Segment, Vec2};
//! use polymap_export::pgm::{Cell, GridParams, OccupancyGrid};
//! let wall = [Segment::new(Vec2::new(2.0, -1.0), Vec2::new(2.0, 1.0))];
//! let rays = [(Pose2::IDENTITY, vec![Vec2::new(2.0, 0.0)])];
//! let grid = OccupancyGrid::build(&wall, rays, &GridParams::default()).unwrap();
//! assert_eq!(grid.cell_at(Vec2::new(1.0, 0.0)), Some(Cell::Free));
//! assert_eq!(grid.cell_at(Vec2::new(2.0, 0.5)), Some(Cell::Occupied));
//! assert_eq!(grid.cell_at(Vec2::new(1.0, 0.8)), Some(Cell::Unknown));
//! ```

mod map_server;
mod traverse;

pub use map_server::{
    FREE_THRESH, MapServerFiles, OCCUPIED_THRESH, PIXEL_FREE, PIXEL_OCCUPIED, PIXEL_UNKNOWN,
    write_map_server,
};

use polymap::geometry::{Pose2, Segment, Vec2};

use crate::ExportError;
use crate::picture::Bounds;
use traverse::for_each_cell;

/// How the occupancy grid is laid out.
#[derive(Debug, Clone, PartialEq)]
pub struct GridParams {
    /// Cell size, metres (default 0.05, the usual `map_server` resolution).
    pub resolution_m: f64,
    /// Unknown border around the map segments' bounding box, metres (default 1.0).
    pub margin_m: f64,
    /// Largest number of cells allowed (default 50 000 000, 50 MB); a bigger grid is an error,
    /// checked before anything is allocated.
    pub max_cells: usize,
}

impl Default for GridParams {
    fn default() -> Self {
        GridParams {
            resolution_m: 0.05,
            margin_m: 1.0,
            max_cells: 50_000_000,
        }
    }
}

/// The state of one cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Cell {
    /// Never observed.
    Unknown,
    /// A laser ray passed through it.
    Free,
    /// A map segment passes through it (wins over free).
    Occupied,
}

/// A 2D occupancy grid in the map frame.
#[derive(Debug, Clone, PartialEq)]
pub struct OccupancyGrid {
    resolution_m: f64,
    origin_m: Vec2,
    width: usize,
    height: usize,
    /// Row-major, row 0 at the bottom (lowest y).
    cells: Vec<Cell>,
}

impl OccupancyGrid {
    /// Builds the grid from the map's segments (metres, map frame) and the laser rays: for each
    /// scan, the robot pose `map_from_robot` and the scan's hit points in the robot frame.
    ///
    /// Rays mark the cells from the robot's position up to, not including, the hit cell as free;
    /// segments mark every cell they cross as occupied, and occupied wins. Non-finite points
    /// and segments are skipped.
    pub fn build<P: AsRef<[Vec2]>>(
        map_segments: &[Segment],
        rays: impl IntoIterator<Item = (Pose2, P)>,
        params: &GridParams,
    ) -> Result<OccupancyGrid, ExportError> {
        let mut grid = OccupancyGrid::empty(map_segments, params)?;
        for s in map_segments {
            grid.mark_segment(s);
        }
        for (map_from_robot, points_in_robot) in rays {
            grid.mark_rays(&map_from_robot, points_in_robot.as_ref());
        }
        Ok(grid)
    }

    /// An all-unknown grid around `map_segments`, with its size checked against the cap.
    fn empty(map_segments: &[Segment], params: &GridParams) -> Result<OccupancyGrid, ExportError> {
        check_params(params)?;
        let endpoints = map_segments.iter().flat_map(|s| [s.start, s.end]);
        let bounds = Bounds::around(endpoints)
            .unwrap_or(Bounds {
                min: Vec2::splat(-1.0),
                max: Vec2::splat(1.0),
            })
            .padded(params.margin_m, params.resolution_m);
        let size_cells = (bounds.size() / params.resolution_m).ceil().max(Vec2::ONE);
        let cells = size_cells.x * size_cells.y;
        if !cells.is_finite() || cells > params.max_cells as f64 {
            return Err(ExportError::GridTooLarge {
                width_cells: size_cells.x,
                height_cells: size_cells.y,
                resolution_m: params.resolution_m,
                max_cells: params.max_cells,
            });
        }
        let (width, height) = (size_cells.x as usize, size_cells.y as usize);
        Ok(OccupancyGrid {
            resolution_m: params.resolution_m,
            origin_m: bounds.min,
            width,
            height,
            cells: vec![Cell::Unknown; width * height],
        })
    }

    fn mark_segment(&mut self, s: &Segment) {
        let (a, b) = (self.to_cell_units(s.start), self.to_cell_units(s.end));
        let (w, h) = (self.width, self.height);
        let cells = &mut self.cells;
        for_each_cell(a, b, w, h, |col, row, _| {
            cells[row * w + col] = Cell::Occupied
        });
    }

    fn mark_rays(&mut self, map_from_robot: &Pose2, points_in_robot: &[Vec2]) {
        let from = self.to_cell_units(map_from_robot.translation());
        let (w, h) = (self.width, self.height);
        for p_in_robot in points_in_robot {
            let to = self.to_cell_units(map_from_robot.transform_point(*p_in_robot));
            let cells = &mut self.cells;
            for_each_cell(from, to, w, h, |col, row, is_hit| {
                let cell = &mut cells[row * w + col];
                if !is_hit && *cell == Cell::Unknown {
                    *cell = Cell::Free;
                }
            });
        }
    }

    /// A map-frame point in cell units (cell `(c, r)` covers `[c, c+1) × [r, r+1)`).
    fn to_cell_units(&self, p_in_map: Vec2) -> Vec2 {
        (p_in_map - self.origin_m) / self.resolution_m
    }

    /// Cell size, metres.
    pub fn resolution_m(&self) -> f64 {
        self.resolution_m
    }

    /// Map-frame position of the lower-left corner of cell `(0, 0)`, metres.
    pub fn origin_m(&self) -> Vec2 {
        self.origin_m
    }

    /// Number of columns (along map x).
    pub fn width(&self) -> usize {
        self.width
    }

    /// Number of rows (along map y).
    pub fn height(&self) -> usize {
        self.height
    }

    /// The cell in column `col` (from the left) and row `row` (from the bottom).
    pub fn cell(&self, col: usize, row: usize) -> Option<Cell> {
        (col < self.width && row < self.height).then(|| self.cells[row * self.width + col])
    }

    /// The column and row of the cell holding a map-frame point, if it is inside the grid.
    pub fn cell_index(&self, p_in_map: Vec2) -> Option<(usize, usize)> {
        let c = self.to_cell_units(p_in_map).floor();
        let inside =
            c.x >= 0.0 && c.y >= 0.0 && c.x < self.width as f64 && c.y < self.height as f64;
        inside.then_some((c.x as usize, c.y as usize))
    }

    /// The cell holding a map-frame point, if it is inside the grid.
    pub fn cell_at(&self, p_in_map: Vec2) -> Option<Cell> {
        let (col, row) = self.cell_index(p_in_map)?;
        self.cell(col, row)
    }

    /// How many cells are in each state: `(unknown, free, occupied)`.
    pub fn counts(&self) -> (usize, usize, usize) {
        self.cells.iter().fold((0, 0, 0), |(u, f, o), c| match c {
            Cell::Unknown => (u + 1, f, o),
            Cell::Free => (u, f + 1, o),
            Cell::Occupied => (u, f, o + 1),
        })
    }
}

fn check_params(params: &GridParams) -> Result<(), ExportError> {
    if !(params.resolution_m.is_finite() && params.resolution_m > 0.0) {
        return Err(ExportError::InvalidParameter {
            name: "resolution_m",
            reason: format!(
                "must be a positive number of metres, got {}",
                params.resolution_m
            ),
        });
    }
    if !(params.margin_m.is_finite() && params.margin_m >= 0.0) {
        return Err(ExportError::InvalidParameter {
            name: "margin_m",
            reason: format!(
                "must be a non-negative number of metres, got {}",
                params.margin_m
            ),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests;
