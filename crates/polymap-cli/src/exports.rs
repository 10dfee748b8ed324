//! The optional output formats (`--export`, `polymap export`): PNG, HTML report, ROS map_server
//! grid, DXF.

use std::cell::RefCell;
use std::path::{Path, PathBuf};

use anyhow::{Result, bail};
use clap::ValueEnum;
use polymap::geometry::{Pose2, Vec2};
use polymap::map::MapSegment;
use polymap_export::dxf::{DxfScene, write_dxf};
use polymap_export::pgm::{GridParams, OccupancyGrid, write_map_server};
use polymap_export::png::{PngScene, write_png};
use polymap_export::report::{ReportData, write_report_html};
use polymap_io::carmen::{CarmenReader, ReaderOptions};
use polymap_io::tum::StampedPose;

/// An export format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// map.png: a raster picture of the map and trajectory.
    Png,
    /// report.html: a self-contained page replaying how the map grew.
    Html,
    /// map.pgm + map.yaml: an occupancy grid for ROS map_server / Nav2.
    Pgm,
    /// map.dxf: the map as CAD lines (layer MAP) and the trajectory (layer TRAJECTORY).
    Dxf,
}

/// What the exporters draw from.
pub struct ExportInput<'a> {
    pub dir: &'a Path,
    pub segments: &'a [MapSegment],
    pub polylines: &'a [Vec<usize>],
    pub trajectory: &'a [StampedPose],
    pub scan_points: &'a [Vec2],
    /// The mapped log, re-read for the free space of the occupancy grid.
    pub log: Option<&'a Path>,
    pub skip_bad_lines: bool,
    pub history: Option<&'a ReportData>,
    pub resolution_m: f64,
}

/// Writes each requested format into `input.dir`; returns the files written.
pub fn export(formats: &[Format], input: &ExportInput<'_>) -> Result<Vec<PathBuf>> {
    let positions: Vec<Vec2> = input
        .trajectory
        .iter()
        .map(|p| p.map_from_robot.translation())
        .collect();
    let mut written = Vec::new();
    for format in formats {
        match format {
            Format::Png => {
                let path = input.dir.join("map.png");
                let scene = PngScene {
                    segments: input.segments,
                    polylines: input.polylines,
                    trajectory: &positions,
                    scan_points: input.scan_points,
                    ..PngScene::default()
                };
                write_png(&path, &scene)?;
                written.push(path);
            }
            Format::Dxf => {
                let path = input.dir.join("map.dxf");
                write_dxf(
                    &path,
                    &DxfScene {
                        segments: input.segments,
                        polylines: input.polylines,
                        trajectory: &positions,
                    },
                )?;
                written.push(path);
            }
            Format::Html => {
                let Some(history) = input.history else {
                    bail!(
                        "{}: no history.json to build the report from",
                        input.dir.display()
                    )
                };
                let path = input.dir.join("report.html");
                write_report_html(&path, history)?;
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

/// The occupancy grid: occupied from the map, free along the log's rays from the trajectory.
fn occupancy_grid(input: &ExportInput<'_>) -> Result<OccupancyGrid> {
    let segments: Vec<_> = input.segments.iter().map(|s| s.segment).collect();
    let params = GridParams {
        resolution_m: input.resolution_m,
        ..GridParams::default()
    };
    let Some(log) = input.log else {
        return Ok(OccupancyGrid::build(
            &segments,
            std::iter::empty::<(Pose2, Vec<Vec2>)>(),
            &params,
        )?);
    };
    let mut reader = CarmenReader::open(
        log,
        ReaderOptions {
            skip_bad_lines: input.skip_bad_lines,
            ..ReaderOptions::default()
        },
    )?;
    let failure: RefCell<Option<anyhow::Error>> = RefCell::new(None);
    let mut poses = input.trajectory.iter().enumerate();
    let rays = std::iter::from_fn(|| {
        let fail = |e: anyhow::Error| {
            *failure.borrow_mut() = Some(e);
            None
        };
        match (reader.next_scan(), poses.next()) {
            (Ok(Some(scan)), Some((_, pose))) if scan.stamp.text == pose.stamp.text => {
                let mut points = Vec::new();
                scan.points_in_robot(&mut points);
                Some((pose.map_from_robot, points))
            }
            (Ok(Some(scan)), Some((i, pose))) => fail(anyhow::anyhow!(
                "trajectory pose {} has stamp {} but scan {} of the log has {}: not this log's trajectory",
                i + 1,
                pose.stamp.text,
                i + 1,
                scan.stamp.text
            )),
            (Ok(Some(_)), None) => {
                eprintln!(
                    "polymap: note: the trajectory covers the first {} scans of the log",
                    input.trajectory.len()
                );
                None
            }
            (Ok(None), Some(_)) => fail(anyhow::anyhow!(
                "the trajectory has {} poses, more than the log has scans: not this log's trajectory",
                input.trajectory.len()
            )),
            (Ok(None), None) => None,
            (Err(e), _) => fail(e.into()),
        }
    });
    let grid = OccupancyGrid::build(&segments, rays, &params)?;
    if let Some(e) = failure.into_inner() {
        return Err(e.context(format!(
            "re-reading {} for the occupancy grid",
            log.display()
        )));
    }
    Ok(grid)
}
