//! Writes an [`OccupancyGrid`] as a ROS `map_server` / Nav2 map: `STEM.pgm` and `STEM.yaml`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::{Cell, OccupancyGrid};
use crate::ExportError;

/// Pixel value of an occupied cell (black; `map_server` reads `p = (255 − v) / 255 = 1`).
pub const PIXEL_OCCUPIED: u8 = 0;
/// Pixel value of a free cell (`p ≈ 0.004 < free_thresh`).
pub const PIXEL_FREE: u8 = 254;
/// Pixel value of an unknown cell (`p ≈ 0.196`, between the thresholds).
pub const PIXEL_UNKNOWN: u8 = 205;
/// `occupied_thresh` written to the YAML file.
pub const OCCUPIED_THRESH: f64 = 0.65;
/// `free_thresh` written to the YAML file.
pub const FREE_THRESH: f64 = 0.196;

/// The two files written by [`write_map_server`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MapServerFiles {
    /// The binary P5 image.
    pub pgm: PathBuf,
    /// The metadata that names it.
    pub yaml: PathBuf,
}

/// Writes `dir/STEM.pgm` (binary P5, 8 bit, first row = top of the map, i.e. highest y) and
/// `dir/STEM.yaml` (`image`, `resolution`, `origin` = map-frame pose `[x, y, 0.0]` of the
/// lower-left pixel's corner, `negate: 0`, `occupied_thresh: 0.65`, `free_thresh: 0.196`,
/// `mode: trinary`).
///
/// `stem` is the file name without extension; it may hold only ASCII letters, digits, `_`, `-`
/// and `.` (it is written unquoted into the YAML file).
pub fn write_map_server(
    dir: &Path,
    stem: &str,
    grid: &OccupancyGrid,
) -> Result<MapServerFiles, ExportError> {
    check_stem(stem)?;
    let pgm = dir.join(format!("{stem}.pgm"));
    let yaml = dir.join(format!("{stem}.yaml"));
    write_file(&pgm, &pgm_bytes(grid))?;
    write_file(&yaml, yaml_text(&format!("{stem}.pgm"), grid).as_bytes())?;
    Ok(MapServerFiles { pgm, yaml })
}

fn check_stem(stem: &str) -> Result<(), ExportError> {
    let ok = |c: char| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.');
    if stem.is_empty() || !stem.chars().all(ok) || stem.starts_with('.') {
        return Err(ExportError::InvalidParameter {
            name: "stem",
            reason: format!("{stem:?}: use ASCII letters, digits, '_', '-' and '.'"),
        });
    }
    Ok(())
}

fn write_file(path: &Path, bytes: &[u8]) -> Result<(), ExportError> {
    polymap_io::atomic::write_bytes_atomic(path, bytes).map_err(|e| ExportError::io(path, e))
}

/// The whole P5 file: header, then rows from the top of the map (highest y) down.
fn pgm_bytes(grid: &OccupancyGrid) -> Vec<u8> {
    let header = format!("P5\n{} {}\n255\n", grid.width(), grid.height());
    let mut bytes = Vec::with_capacity(header.len() + grid.width() * grid.height());
    bytes.extend_from_slice(header.as_bytes());
    for row in grid.cells.chunks_exact(grid.width()).rev() {
        bytes.extend(row.iter().map(|c| match c {
            Cell::Unknown => PIXEL_UNKNOWN,
            Cell::Free => PIXEL_FREE,
            Cell::Occupied => PIXEL_OCCUPIED,
        }));
    }
    bytes
}

fn yaml_text(image: &str, grid: &OccupancyGrid) -> String {
    let origin = grid.origin_m();
    let mut text = String::new();
    let _ = writeln!(text, "image: {image}");
    let _ = writeln!(text, "mode: trinary");
    let _ = writeln!(text, "resolution: {}", grid.resolution_m());
    let _ = writeln!(text, "origin: [{:.6}, {:.6}, 0.0]", origin.x, origin.y);
    let _ = writeln!(text, "negate: 0");
    let _ = writeln!(text, "occupied_thresh: {OCCUPIED_THRESH}");
    let _ = writeln!(text, "free_thresh: {FREE_THRESH}");
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stems_are_checked() {
        assert!(check_stem("map").is_ok());
        assert!(check_stem("map_2.v1").is_ok());
        for bad in ["", "../map", "a b", "m:ap", ".hidden", "map\n"] {
            assert!(check_stem(bad).is_err(), "{bad:?}");
        }
    }
}

#[cfg(test)]
pub(super) mod tests_support {
    /// The PGM bytes, for the grid's tests.
    pub(crate) fn pgm(grid: &super::OccupancyGrid) -> Vec<u8> {
        super::pgm_bytes(grid)
    }
}
