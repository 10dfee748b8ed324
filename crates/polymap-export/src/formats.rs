//! The optional formats of a run folder by name (`--export png,html,pgm,dxf`), and [`export`],
//! which writes the requested ones from one [`MapSnapshot`].

use std::path::{Path, PathBuf};
use std::str::FromStr;

use polymap::geometry::Pose2;
use polymap_io::snapshot::{MapSnapshot, ScanPoints};

use crate::ExportError;
use crate::pgm::{GridParams, OccupancyGrid, write_map_server};
use crate::png::{PngStyle, write_png};
use crate::report::{ReportData, write_report_html};

/// An optional output format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Format {
    /// `map.png`: a raster picture of the map and trajectory.
    Png,
    /// `report.html`: a self-contained page replaying how the map grew.
    Html,
    /// `map.pgm` + `map.yaml`: an occupancy grid for ROS map_server / Nav2.
    Pgm,
    /// `map.dxf`: the map as CAD lines (layer MAP) and the trajectory (layer TRAJECTORY).
    Dxf,
}

impl Format {
    /// Every format.
    pub const ALL: [Format; 4] = [Format::Png, Format::Html, Format::Pgm, Format::Dxf];

    /// The name used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Format::Png => "png",
            Format::Html => "html",
            Format::Pgm => "pgm",
            Format::Dxf => "dxf",
        }
    }

    /// The files the format writes into a run folder.
    pub fn files(self) -> &'static [&'static str] {
        match self {
            Format::Png => &["map.png"],
            Format::Html => &["report.html"],
            Format::Pgm => &["map.pgm", "map.yaml"],
            Format::Dxf => &["map.dxf"],
        }
    }
}

impl FromStr for Format {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        Format::ALL
            .into_iter()
            .find(|f| f.name().eq_ignore_ascii_case(text.trim()))
            .ok_or_else(|| format!("unknown format {text:?}: use png, html, pgm or dxf"))
    }
}

/// What the formats draw from.
#[derive(Debug, Clone, Copy)]
pub struct ExportInput<'a> {
    /// The folder written into.
    pub dir: &'a Path,
    /// The map, trajectory and (for the PNG) scan points in the map frame.
    pub snapshot: &'a MapSnapshot,
    /// The laser rays for the occupancy grid's free space: each scan's points in the robot
    /// frame, scan `i` seen from trajectory pose `i`. `None`: only occupied cells.
    pub rays: Option<&'a ScanPoints>,
    /// The replay history, for `report.html`.
    pub history: Option<&'a ReportData>,
    /// Cell size of the occupancy grid, metres.
    pub resolution_m: f64,
}

/// Writes each requested format into `input.dir` (atomically); returns the files written.
pub fn export(formats: &[Format], input: &ExportInput<'_>) -> Result<Vec<PathBuf>, ExportError> {
    let mut written = Vec::new();
    for format in formats {
        match format {
            Format::Png => {
                let path = input.dir.join("map.png");
                write_png(&path, input.snapshot, &PngStyle::default())?;
                written.push(path);
            }
            Format::Dxf => {
                let path = input.dir.join("map.dxf");
                crate::dxf::write_dxf(&path, input.snapshot)?;
                written.push(path);
            }
            Format::Html => {
                let path = input.dir.join("report.html");
                let Some(history) = input.history else {
                    return Err(ExportError::Missing {
                        path,
                        what: "the replay history (history.json)".to_owned(),
                    });
                };
                write_report_html(&path, input.snapshot, history)?;
                written.push(path);
            }
            Format::Pgm => {
                let files = write_map_server(input.dir, "map", &occupancy_grid(input)?)?;
                written.extend([files.pgm, files.yaml]);
            }
        }
    }
    Ok(written)
}

/// Occupied cells from the map, free cells along the rays from the trajectory's poses.
fn occupancy_grid(input: &ExportInput<'_>) -> Result<OccupancyGrid, ExportError> {
    let segments: Vec<_> = input.snapshot.segments.iter().map(|s| s.segment).collect();
    let params = GridParams {
        resolution_m: input.resolution_m,
        ..GridParams::default()
    };
    let poses: Vec<Pose2> = input
        .snapshot
        .trajectory
        .iter()
        .map(|p| p.map_from_robot)
        .collect();
    match input.rays {
        Some(rays) => OccupancyGrid::build(&segments, rays.rays(&poses), &params),
        None => OccupancyGrid::build(&segments, std::iter::empty::<(Pose2, &[_])>(), &params),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_read_back() {
        for f in Format::ALL {
            assert_eq!(f.name().parse::<Format>(), Ok(f));
        }
        assert!("svg".parse::<Format>().is_err());
    }
}
