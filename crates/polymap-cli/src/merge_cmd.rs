//! `polymap merge A B -o OUT`: finds where map B lies in map A (global search over
//! segment-pair hypotheses, verified by a raster score), refuses maps that do not overlap or
//! align ambiguously, and merges B into A by the mapper's own merge; writes `map.json` (A's
//! frame), `merge.json` (the transform and what it rests on) and `map.svg`.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use polymap::align::{
    GlobalMatch, GlobalParams, MatchVerdict, MovingSide, ScoredPose, global_match, overlap_share,
    points_along,
};
use polymap::config::Config;
use polymap::geometry::{Pose2, Segment, Vec2};
use polymap::map::{GlobalMap, MapSegment};
use polymap::merge::{MapMergeParams, MapMergeResult, merge_map};
use polymap::polyline::group_polylines;
use polymap::segment_index::SegmentIndex;
use polymap_export::svg::{SvgStyle, write_svg};
use polymap_io::atomic::write_bytes_atomic;
use polymap_io::map_json::{MapJson, read_map_json, write_map_json};
use polymap_io::snapshot::{MapSnapshot, Polyline};
use polymap_io::tum::read_tum;
use polymap_pipeline::folder::{RunFolder, check_output_apart};
use serde_json::json;

use crate::args::MergeArgs;
use crate::quote::quoted;

/// The merged map's files in the output folder (removed when a merge is refused; `merge.json`
/// is written either way).
const MAP_FILES: [&str; 2] = ["map.json", "map.svg"];
/// Refined poses listed in `merge.json`, best first.
const CANDIDATES_SHOWN: usize = 8;
/// Spacing of the points sampled along B's segments for scoring and ICP, metres.
const SAMPLE_SPACING_M: f64 = 0.05;

/// One input map: its folder, `map.json` and how many scans made it.
struct Input {
    dir: PathBuf,
    map: MapJson,
    segments: Vec<MapSegment>,
    /// The robot's positions from `trajectory.tum` (empty without it), map frame.
    path: Vec<Vec2>,
    scans: u32,
    /// The folder's lock for reading, held until the merge is written.
    _lock: Option<polymap_pipeline::manifest::FolderLock>,
}

pub fn run(a: &MergeArgs) -> Result<()> {
    let (map_a, map_b) = (read_input(&a.a)?, read_input(&a.b)?);
    check_output_apart(&a.output, &[("map A", &map_a.dir), ("map B", &map_b.dir)])?;
    let folder = RunFolder::prepare(&a.output)?;
    let config = Config::default();
    let params = GlobalParams::default();
    let started = Instant::now();
    let fixed = global_map(&map_a.segments, &config);
    let b_segments: Vec<Segment> = map_b.segments.iter().map(|s| s.segment).collect();
    let b_points = points_along(&b_segments, SAMPLE_SPACING_M);
    let moving = MovingSide {
        segments: &b_segments,
        points: &b_points,
        path: &map_b.path,
    };
    let found = global_match(&fixed, &map_a.path, &moving, &params, &config.align);
    let search_s = started.elapsed().as_secs_f64();
    folder.begin_writing()?;
    let Some(found) = found else {
        remove_stale(folder.path())?;
        let report = json!({
            "a": a.a.display().to_string(),
            "b": a.b.display().to_string(),
            "verdict": MatchVerdict::NoOverlap,
            "reason": "no corner of B matches a corner of A",
            "segments": {"a": map_a.segments.len(), "b": map_b.segments.len()},
        });
        write_json(&folder.path().join("merge.json"), &report)?;
        folder.finish_writing(&["merge.json"])?;
        bail!(
            "{} and {} do not overlap: no corner of B (two non-parallel walls meeting) matches a \
             corner of A in angle, so there is no pose to try: not merged (see merge.json)",
            shown(&map_a.dir),
            shown(&map_b.dir)
        );
    };
    let a_from_b = found.fixed_from_moving;
    let overlap_a = overlap_of_a(&map_a, &b_segments, &a_from_b, &params);
    let verdict = found.verdict(&params);
    let mut report = merge_json(a, &map_a, &map_b, &found, verdict, overlap_a, search_s);
    if verdict != MatchVerdict::Accepted {
        remove_stale(folder.path())?;
        write_json(&folder.path().join("merge.json"), &report)?;
        folder.finish_writing(&["merge.json"])?;
        bail!("{}", refusal(&map_a, &map_b, &found, verdict, &params));
    }
    let started = Instant::now();
    let (merged, counts) = merge(&map_a, &map_b, &a_from_b, fixed, &config);
    let polylines = group_polylines(
        &merged.iter().map(|s| s.segment).collect::<Vec<_>>(),
        config.polyline.max_gap_m,
    );
    report["segments"]["merged"] = json!(merged.len());
    report["segments"]["removed"] = json!(counts.removed);
    report["segments"]["added"] = json!(counts.added);
    report["polylines"] = json!(polylines.len());
    report["merge_s"] = json!(started.elapsed().as_secs_f64());
    write_outputs(
        folder.path(),
        &map_a,
        map_b.scans,
        &merged,
        &polylines,
        &report,
    )?;
    folder.finish_writing(&["map.json", "merge.json", "map.svg"])?;
    if !a.quiet {
        summarize(&map_a, &map_b, &found, overlap_a, merged.len(), &a.output);
    }
    Ok(())
}

/// Reads `DIR/map.json` and counts the scans that made it (its `scans`, or one past the
/// latest birth in a version 1 file).
fn read_input(dir: &Path) -> Result<Input> {
    if !dir.is_dir() {
        bail!("{}: not a folder (a polymap map output)", shown(dir));
    }
    let lock = crate::outputs::check_run_folder(dir, &["map.json", "trajectory.tum"])?;
    let map = read_map_json(dir.join("map.json"))?;
    let segments = map.map_segments();
    if segments.is_empty() {
        bail!("{}: the map has no segments", shown(&dir.join("map.json")));
    }
    let born = segments.iter().map(|s| s.born_scan).max().unwrap_or(0);
    let scans = map.scans_mapped().max(born.saturating_add(1));
    let tum = dir.join("trajectory.tum");
    let path: Vec<Vec2> = match tum.is_file() {
        true => read_tum(&tum)?
            .iter()
            .map(|p| p.map_from_robot.translation())
            .collect(),
        false => Vec::new(),
    };
    Ok(Input {
        dir: dir.to_path_buf(),
        map,
        segments,
        scans,
        path,
        _lock: lock,
    })
}

/// A's segments in a map store indexed as the mapper's.
fn global_map(segments: &[MapSegment], config: &Config) -> GlobalMap {
    let reach = config.align.initial_gate_m.max(config.align.final_gate_m);
    let mut map = GlobalMap::new(config.map.grid_cell_m, reach);
    for s in segments {
        map.insert(*s);
    }
    map
}

/// The share of A's walls within the inlier distance of B's, B placed by `a_from_b`.
fn overlap_of_a(a: &Input, b: &[Segment], a_from_b: &Pose2, params: &GlobalParams) -> f64 {
    let b_in_a: Vec<Segment> = b.iter().map(|s| s.transformed(a_from_b)).collect();
    let a_segments: Vec<Segment> = a.segments.iter().map(|s| s.segment).collect();
    let points = points_along(&a_segments, SAMPLE_SPACING_M);
    overlap_share(
        &points,
        &SegmentIndex::from_segments(&b_in_a, 1.0, params.inlier_m.max(0.5)),
        &Pose2::IDENTITY,
        params.inlier_m,
    )
}

/// B's segments in A's frame merged into A, born after A's scans.
fn merge(
    a: &Input,
    b: &Input,
    a_from_b: &Pose2,
    mut map: GlobalMap,
    config: &Config,
) -> (Vec<MapSegment>, MapMergeResult) {
    let b_in_a: Vec<MapSegment> = b
        .segments
        .iter()
        .map(|s| MapSegment {
            segment: s.segment.transformed(a_from_b),
            born_scan: s.born_scan,
        })
        .collect();
    let counts = merge_map(
        &config.merge,
        &config.directions,
        &MapMergeParams::default(),
        &mut map,
        &b_in_a,
        a.scans,
    );
    (map.iter().map(|(_, s)| *s).collect(), counts)
}

fn pose_json(p: &Pose2) -> serde_json::Value {
    json!({"x": p.x_m, "y": p.y_m, "yaw": p.theta_rad})
}

/// `merge.json` without the merged counts.
fn merge_json(
    a: &MergeArgs,
    map_a: &Input,
    map_b: &Input,
    found: &GlobalMatch,
    verdict: MatchVerdict,
    overlap_a: f64,
    search_s: f64,
) -> serde_json::Value {
    let scored = |r: &ScoredPose| {
        let d = r.fixed_from_moving.between(&found.best.fixed_from_moving);
        json!({
            "a_from_b": pose_json(&r.fixed_from_moving),
            "score": r.score,
            "raster_score": r.raster_score,
            "conflicts": r.conflicts,
            "distance_m": d.translation().length(),
            "turn_deg": d.theta_rad.to_degrees().abs(),
        })
    };
    let candidates: Vec<serde_json::Value> = found
        .candidates
        .iter()
        .take(CANDIDATES_SHOWN)
        .map(scored)
        .collect();
    json!({
        "a": a.a.display().to_string(),
        "b": a.b.display().to_string(),
        "frame": format!("{} of A", map_a.map.frame),
        "verdict": verdict,
        "a_from_b": pose_json(&found.fixed_from_moving),
        "overlap": found.overlap,
        "overlap_of_a": overlap_a,
        "score": found.best.score,
        "raster_score": found.best.raster_score,
        "conflicts": found.best.conflicts,
        "rival": found.rival.as_ref().map(scored),
        "rival_ratio": found.rival_ratio(),
        "passing_rival": found.passing_rival(&GlobalParams::default()).map(scored),
        "candidates": candidates,
        "icp": {
            "iterations": found.icp.iterations,
            "correspondences": found.icp.correspondences,
            "inliers": found.icp.inliers,
            "residual_rms_m": found.icp.residual_rms_m,
            "converged": found.icp.converged,
            "weak_directions": found.icp.weak_directions,
        },
        "search": {
            "corners_a": found.fixed_corners,
            "corners_b": found.moving_corners,
            "hypotheses": found.hypotheses,
            "seconds": search_s,
        },
        "segments": {"a": map_a.segments.len(), "b": map_b.segments.len()},
        "scans": {"a": map_a.scans, "b": map_b.scans},
    })
}

/// Why the maps are not merged, with the figures.
fn refusal(
    a: &Input,
    b: &Input,
    found: &GlobalMatch,
    verdict: MatchVerdict,
    params: &GlobalParams,
) -> String {
    let (a, b) = (shown(&a.dir), shown(&b.dir));
    let rival = found.passing_rival(params).or(found.rival.as_ref());
    match (verdict, rival) {
        (MatchVerdict::Ambiguous, Some(r)) => {
            let d = r.fixed_from_moving.between(&found.best.fixed_from_moving);
            format!(
                "{b} fits {a} in two places: a pose {:.2} m and {:.1}° from the best explains \
                 {:.0} % of B's walls with {:.0} % conflicts, {:.0} % of the best's score (refused \
                 when another pose would pass on its own or reaches {:.0} %; a symmetric place, \
                 or halves that mirror each other?): not merged (see merge.json)",
                d.translation().length(),
                d.theta_rad.to_degrees().abs(),
                100.0 * r.raster_score,
                100.0 * r.conflicts,
                100.0 * r.score.max(0.0) / found.best.score.max(1e-9),
                100.0 * params.max_rival_ratio
            )
        }
        (MatchVerdict::Conflicting, _) => format!(
            "{a} and {b} contradict each other at the best alignment: {:.0} % of the robots' \
             positions lie within {} m of the other map's walls or were reached through one \
             (refused above {:.0} %): not the same place, or a map is bent: not merged (see \
             merge.json)",
            100.0 * found.best.conflicts,
            params.clearance_m,
            100.0 * params.max_conflicts
        ),
        _ => format!(
            "{a} and {b} do not overlap: the best alignment scores {:.2} (needs {:.2}) and puts \
             {:.0} % of B's walls within {} m of A's (needs {:.0} %): not merged (see merge.json)",
            found.best.raster_score,
            params.min_score,
            100.0 * found.overlap,
            params.inlier_m,
            100.0 * params.min_overlap
        ),
    }
}

/// `map.json`, `merge.json`, `map.svg`, each atomically, the small contract files first.
fn write_outputs(
    dir: &Path,
    a: &Input,
    b_scans: u32,
    merged: &[MapSegment],
    polylines: &[Vec<usize>],
    report: &serde_json::Value,
) -> Result<()> {
    let snapshot = MapSnapshot {
        frame: a.map.frame.clone(),
        title: format!(
            "merged map — {} segments, {} polylines",
            merged.len(),
            polylines.len()
        ),
        segments: merged.to_vec(),
        polylines: polylines
            .iter()
            .map(|p| Polyline {
                segments: p.clone(),
            })
            .collect(),
        // B's scans are numbered after A's.
        scans_before: a.scans.saturating_add(b_scans),
        ..MapSnapshot::default()
    };
    write_map_json(dir.join("map.json"), &snapshot.map_json())?;
    write_json(&dir.join("merge.json"), report)?;
    write_svg(&dir.join("map.svg"), &snapshot, &SvgStyle::default())?;
    Ok(())
}

fn write_json(path: &Path, value: &serde_json::Value) -> Result<()> {
    let mut text = serde_json::to_string_pretty(value)?;
    text.push('\n');
    write_bytes_atomic(path, text.as_bytes())
        .with_context(|| format!("{}: cannot write", path.display()))
}

/// Removes a merged map an earlier merge left in the folder, so none stays beside a refusal.
fn remove_stale(dir: &Path) -> Result<()> {
    for name in MAP_FILES {
        let path = dir.join(name);
        if path.is_file() {
            std::fs::remove_file(&path)
                .with_context(|| format!("{}: cannot remove", path.display()))?;
            eprintln!("polymap: removed {} of an earlier merge", path.display());
        }
    }
    Ok(())
}

fn summarize(a: &Input, b: &Input, found: &GlobalMatch, overlap_a: f64, merged: usize, out: &Path) {
    let p = found.fixed_from_moving;
    say!(
        "a_from_b: x {:.3} m, y {:.3} m, yaw {:.2}°",
        p.x_m,
        p.y_m,
        p.theta_rad.to_degrees()
    );
    say!(
        "score {:.3}, rival {:.0} % of it; {:.0} % of B and {:.0} % of A within 0.1 m of the other",
        found.best.score,
        100.0 * found.rival_ratio(),
        100.0 * found.overlap,
        100.0 * overlap_a
    );
    say!(
        "segments: A {} + B {} -> {} merged; wrote {}",
        a.segments.len(),
        b.segments.len(),
        merged,
        shown(out)
    );
}

fn shown(p: &Path) -> String {
    quoted(&p.display().to_string())
}
