//! Exports of a polymap run for people and for other tools.
//!
//! Every format reads one [`MapSnapshot`](polymap_io::snapshot::MapSnapshot) (map segments in
//! metres in the map frame, polylines as indices into them, robot poses `map_from_robot`,
//! optional scan points) and writes one file or a pair, atomically (a temporary file renamed
//! into place, [`polymap_io::atomic`]):
//!
//! - [`svg`] — the map as an SVG picture (renders the same in browsers, librsvg and Inkscape).
//! - [`pgm`] — a ROS `map_server` / Nav2 occupancy map: `STEM.pgm` (binary P5) and
//!   `STEM.yaml`; occupied cells from the map segments, free cells from the laser rays.
//! - [`dxf`] — a DXF drawing (R12 ASCII) for CAD programs: one `LINE` per segment on layer
//!   `MAP`, the trajectory as a `POLYLINE` on layer `TRAJECTORY`.
//! - [`png`] — a raster picture of the map (tiny-skia), the same content as the SVG.
//! - [`picture`] — what the pictures share (extent, scale bar length, palette).
//! - [`report`] — one self-contained `report.html`: the map replayed over time, the main
//!   directions, and per-scan plots; fed scan by scan through [`report::ReportRecorder`].
//!
//! [`formats`] names them for the command line and writes the requested ones.
//!
//! Errors are [`ExportError`]s naming the file or the limit involved; sizes that come from the
//! input (grid cells, picture pixels, report contents) are capped before anything is allocated.

#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod dxf;
mod error;
pub mod formats;
pub mod pgm;
pub mod picture;
pub mod png;
pub mod report;
pub mod svg;

pub use error::ExportError;
