//! Draws the scan points and odometry trajectory of a CARMEN log (first N scans) as SVG.
//!
//! `cargo run --release -p polymap-export --example svg_preview -- LOG.clf OUT.svg [N]`

use std::process::ExitCode;

use polymap::geometry::Vec2;
use polymap_export::svg::{SvgStyle, write_svg};
use polymap_io::carmen::{CarmenReader, ReaderOptions};
use polymap_io::snapshot::MapSnapshot;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().collect();
    let (Some(log), Some(out)) = (args.get(1), args.get(2)) else {
        eprintln!("usage: svg_preview LOG.clf OUT.svg [SCANS]");
        return ExitCode::FAILURE;
    };
    let max_scans: usize = args.get(3).and_then(|n| n.parse().ok()).unwrap_or(500);
    match run(log, out, max_scans) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(log: &str, out: &str, max_scans: usize) -> Result<(), Box<dyn std::error::Error>> {
    let reader = CarmenReader::open(log, ReaderOptions::default())?;
    let (mut points, mut trajectory, mut in_robot) = (Vec::new(), Vec::new(), Vec::new());
    for scan in reader.take(max_scans) {
        let scan = scan?;
        let Some(odom_from_robot) = scan.odom_from_robot else {
            continue;
        };
        scan.points_in_robot(&mut in_robot);
        points.extend(in_robot.iter().map(|&p| odom_from_robot.transform_point(p)));
        trajectory.push(Vec2::new(odom_from_robot.x_m, odom_from_robot.y_m));
    }
    let title = format!(
        "{log}: first {} scans in the odometry frame",
        trajectory.len()
    );
    let snapshot = MapSnapshot {
        title,
        ..MapSnapshot::from_parts(Vec::new(), Vec::new(), &trajectory, points)
    };
    write_svg(std::path::Path::new(out), &snapshot, &SvgStyle::default())?;
    Ok(())
}
