//! `polymap eval`: measure a trajectory and a map against ground truth or the data.

use std::path::Path;

use anyhow::{Context, Result, bail};
use polymap::geometry::{Pose2, Segment};
use polymap::scan::RangeScan;
use polymap_eval::map_quality::{
    DoubledParams, PointFitParams, TrueWall, WallParams, align_map_to_walls, doubled_walls,
    map_fit_to_points, map_vs_walls,
};
use polymap_eval::relation_error::{RelationParams, evaluate_relations};
use polymap_eval::relations::read_relations;
use polymap_eval::trajectory::{TrajectoryParams, evaluate_trajectory};
use polymap_io::log::{LogOptions, LogSource};
use polymap_io::map_json::read_map_json;
use polymap_io::tum::read_tum;
use serde_json::json;

use crate::args::{EvalArgs, EvalCommand};

pub fn run(a: &EvalArgs) -> Result<()> {
    match &a.command {
        EvalCommand::Relations {
            trajectory,
            relations,
            json,
        } => {
            check_kinds(trajectory, relations)?;
            let m = evaluate_relations(
                &read_relations(relations)?,
                &stamped(trajectory)?,
                &RelationParams::default(),
            );
            if m.matched == 0 {
                bail!(
                    "{}: no relation matched a pose of {} by time stamp",
                    relations.display(),
                    trajectory.display()
                );
            }
            let share = m.matched as f64 / m.relations.max(1) as f64;
            if share < MIN_RELATION_SHARE {
                eprintln!(
                    "polymap: warning: only {:.1} % of the relations ({} of {}) have both poses in {}: \
                     the error describes part of the log only",
                    100.0 * share,
                    m.matched,
                    m.relations,
                    trajectory.display()
                );
            }
            say_raw!(
                "{}",
                if *json {
                    m.to_json() + "\n"
                } else {
                    m.to_table() + "\n"
                }
            );
        }
        EvalCommand::Trajectory {
            estimate,
            truth,
            json,
        } => {
            let m = evaluate_trajectory(
                &stamped(estimate)?,
                &stamped(truth)?,
                &TrajectoryParams::default(),
            );
            if m.associated == 0 {
                bail!(
                    "no pose of {} matched one of {} by time stamp",
                    estimate.display(),
                    truth.display()
                );
            }
            print_json_or(&serde_json::to_value(&m)?, *json, || trajectory_table(&m));
        }
        EvalCommand::Map {
            run,
            log,
            walls,
            stride,
            json,
        } => {
            let map = map_segments(&run.join("map.json"))?;
            let mut out = json!({
                "segments": map.len(),
                "doubled": doubled_walls(&map, &DoubledParams::default()),
            });
            if let Some(c) = polymap::observe::crossed_walls_of(&map) {
                out["crossed"] = json!({ "share": c.share, "crossings": c.crossings });
            }
            if let Some(log) = log {
                let trajectory = read_tum(run.join("trajectory.tum"))?;
                let scans = read_scans(log)?;
                let scans = matching_scans(&scans, &trajectory, log)?;
                let poses: Vec<Pose2> = trajectory.into_iter().map(|p| p.map_from_robot).collect();
                let fit = map_fit_to_points(
                    &map,
                    scans,
                    &poses,
                    &PointFitParams {
                        scan_stride: (*stride).max(1),
                        ..PointFitParams::default()
                    },
                );
                out["points"] = serde_json::to_value(fit)?;
            }
            if let Some(walls) = walls {
                let truth: Vec<TrueWall> = map_segments(walls)?
                    .into_iter()
                    .map(TrueWall::from)
                    .collect();
                // The map's shape after the best rigid fit (as ATE aligns a trajectory), and
                // its placement in the first scan's frame as mapped.
                let world_from_map = align_map_to_walls(&map, &truth);
                let params = WallParams::default();
                out["walls"] =
                    serde_json::to_value(map_vs_walls(&map, &truth, &world_from_map, &params))?;
                out["walls_alignment"] = json!({
                    "x_m": world_from_map.x_m,
                    "y_m": world_from_map.y_m,
                    "theta_deg": world_from_map.theta_rad.to_degrees(),
                });
                out["walls_unaligned"] =
                    serde_json::to_value(map_vs_walls(&map, &truth, &Pose2::IDENTITY, &params))?;
            }
            print_json_or(&out, *json, || map_table(&out));
        }
    }
    Ok(())
}

/// The most a trajectory or relations file told apart by its lines may weigh (a pose line is
/// about 100 bytes: ten million poses).
const MAX_TRAJECTORY_BYTES: u64 = 1 << 30;

/// Below this share of relations matched, `eval relations` warns.
const MIN_RELATION_SHARE: f64 = 0.9;

/// Share of the 8-number lines of a text file whose last four numbers are a unit quaternion, as
/// in a TUM trajectory (a `.relations` line ends in `z roll pitch yaw`, which is not); `None`
/// when the file has no such line.
fn unit_quaternion_share(path: &Path) -> Result<Option<f64>> {
    let text = polymap_io::input_file::read_regular(path, MAX_TRAJECTORY_BYTES)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let (mut lines, mut unit) = (0usize, 0usize);
    for line in String::from_utf8_lossy(&text).lines() {
        let v: Vec<f64> = line
            .split_whitespace()
            .filter_map(|t| t.parse().ok())
            .collect();
        if v.len() == 8 {
            lines += 1;
            let n2: f64 = v[4..].iter().map(|q| q * q).sum();
            unit += usize::from((n2 - 1.0).abs() < 0.01);
        }
    }
    Ok((lines > 0).then(|| unit as f64 / lines as f64))
}

/// Names the file that is not what its place says in `eval relations TRAJECTORY RELATIONS`
/// (the files swapped would otherwise only give "no relation matched").
fn check_kinds(trajectory: &Path, relations: &Path) -> Result<()> {
    let usage = "usage: polymap eval relations TRAJECTORY.tum LOG.relations";
    if unit_quaternion_share(trajectory)?.is_some_and(|s| s < 0.5) {
        bail!(
            "{}: not a TUM trajectory (its lines do not end in a unit quaternion; a .relations \
             file?): {usage}",
            trajectory.display()
        );
    }
    if unit_quaternion_share(relations)?.is_some_and(|s| s > 0.9) {
        bail!(
            "{}: not a relations file (its lines end in unit quaternions, as a TUM trajectory's \
             do): {usage}",
            relations.display()
        );
    }
    Ok(())
}

fn stamped(path: &Path) -> Result<Vec<(f64, Pose2)>> {
    Ok(read_tum(path)?
        .into_iter()
        .map(|p| (p.stamp.seconds, p.map_from_robot))
        .collect())
}

fn map_segments(path: &Path) -> Result<Vec<Segment>> {
    Ok(read_map_json(path)?
        .map_segments()
        .into_iter()
        .map(|s| s.segment)
        .collect())
}

/// The trajectory must hold one pose per scan of the log (or of its first scans, for a run
/// cut short with --max-scans), each with the scan's own stamp. Returns the scans it covers.
fn matching_scans<'a>(
    scans: &'a [RangeScan],
    trajectory: &[polymap_io::tum::StampedPose],
    log: &Path,
) -> Result<&'a [RangeScan]> {
    if trajectory.len() > scans.len() {
        bail!(
            "{}: {} scans, but the trajectory has {} poses: not this log's trajectory",
            log.display(),
            scans.len(),
            trajectory.len()
        );
    }
    if let Some(i) = scans
        .iter()
        .zip(trajectory)
        .position(|(s, p)| s.stamp.text != p.stamp.text)
    {
        bail!(
            "{}: scan {} has stamp {} but trajectory pose {} has {}",
            log.display(),
            i + 1,
            scans[i].stamp.text,
            i + 1,
            trajectory[i].stamp.text
        );
    }
    Ok(&scans[..trajectory.len()])
}

/// Every scan of the log (CARMEN plain, gzip or bzip2, `-` for standard input; or a ROS
/// recording).
fn read_scans(log: &Path) -> Result<Vec<RangeScan>> {
    let mut reader = LogSource::open(log, &LogOptions::default())?;
    let mut scans = Vec::new();
    while let Some(s) = reader.next_scan()? {
        scans.push(s);
    }
    Ok(scans)
}

fn print_json_or(value: &serde_json::Value, json: bool, table: impl FnOnce() -> String) {
    if json {
        say!(
            "{}",
            serde_json::to_string_pretty(value).unwrap_or_default()
        );
    } else {
        say_raw!("{}", table());
    }
}

fn trajectory_table(m: &polymap_eval::trajectory::TrajectoryMetrics) -> String {
    let mut s = format!(
        "associated poses: {} of {} (truth {})\n",
        m.associated, m.estimate_poses, m.truth_poses
    );
    if let Some(ate) = &m.ate {
        s += &format!(
            "ATE position: rmse {:.4} m, mean {:.4} m, max {:.4} m\n",
            ate.position_m.rms, ate.position_m.mean, ate.position_m.max
        );
        s += &format!(
            "ATE heading:  mean {:.3}°, max {:.3}°\n",
            ate.heading_deg.mean, ate.heading_deg.max
        );
    }
    if let Some(rpe) = &m.rpe {
        s += &format!(
            "RPE ({:?}): translation rmse {:.4} m, rotation mean {:.3}°\n",
            rpe.delta, rpe.translation_m.rms, rpe.rotation_deg.mean
        );
    }
    s
}

fn map_table(v: &serde_json::Value) -> String {
    let mut s = format!("map segments: {}\n", v["segments"]);
    let pct = |x: &serde_json::Value| {
        x.as_f64()
            .map_or("-".to_owned(), |f| format!("{:.1}%", 100.0 * f))
    };
    if let Some(d) = v.get("doubled") {
        let p = &d["params"];
        s += &format!(
            "doubled walls: {} of the map's length ({:.1} of {:.1} m) lies within {} m of another \
             segment turned at most {}°\n",
            pct(&d["share"]),
            d["doubled_length_m"].as_f64().unwrap_or(0.0),
            d["map_length_m"].as_f64().unwrap_or(0.0),
            p["within_m"],
            p["within_deg"],
        );
    }
    if let Some(c) = v.get("crossed") {
        s += &format!(
            "walls crossing at 5-30°: {} of the map's length drawn twice about {} pairs of \
             them\n",
            pct(&c["share"]),
            c["crossings"],
        );
    }
    let m = |x: &serde_json::Value| x.as_f64().map_or("-".to_owned(), |f| format!("{f:.4} m"));
    if let Some(p) = v.get("points") {
        s += &format!(
            "scan points: {} in {} scans; within 5 cm {}, within 10 cm {}; rms {} (within 0.5 m: {})\n",
            p["points"],
            p["scans_used"],
            pct(&p["share_within_tight"]),
            pct(&p["share_within_loose"]),
            m(&p["rms_m"]),
            m(&p["rms_within_cutoff_m"])
        );
    }
    if let Some(w) = v.get("walls") {
        let a = &v["walls_alignment"];
        let (x, y) = (
            a["x_m"].as_f64().unwrap_or(0.0),
            a["y_m"].as_f64().unwrap_or(0.0),
        );
        s += &format!(
            "true walls: precision {}, recall {} (within 5 cm, after laying the map onto the \
             walls: turned {:.2}°, shifted {:.3} m)\n",
            pct(&w["precision"]),
            pct(&w["recall"]),
            a["theta_deg"].as_f64().unwrap_or(0.0),
            x.hypot(y)
        );
        let u = &v["walls_unaligned"];
        s += &format!(
            "true walls as placed in the first scan's frame: precision {}, recall {}\n",
            pct(&u["precision"]),
            pct(&u["recall"])
        );
    }
    s
}
