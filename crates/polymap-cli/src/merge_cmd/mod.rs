//! `polymap merge A B … -o OUT`: finds where each map lies in the first (global search over
//! segment-pair hypotheses, verified by a raster score), refuses maps that do not overlap or
//! align ambiguously, and merges the others in by the mapper's own merge; writes `map.json`
//! (the first map's frame), `merge.json` (each transform and what it rests on, or why a map
//! was refused) and `map.svg`.
//!
//! When no rigid transform is accepted (each map drifted on its own), B is bent onto A by a
//! joint pose graph of both maps' loop nodes ([`polymap::loops::joint_graph`]) seeded by the
//! rigid match's best poses and by a search of each of B's nodes over A: B's segments move
//! with their nodes, and B's trajectory so moved is written (`trajectory_b.tum` for two maps).
//!
//! More than two maps (`multi.rs`) join the first one at a time, the one that overlaps the
//! merged map most first; a map that fits nowhere, or in two places, is refused with the
//! reason.
//!
//! Files: `input.rs` (reading a map), `pair.rs` (laying one map onto another), `bend.rs` (the
//! joint pose graph), `report.rs` (`merge.json` and refusals), `output.rs` (writing),
//! `multi.rs` (more than two maps).

mod bend;
mod input;
mod multi;
mod output;
mod pair;
mod report;

use std::time::Instant;

use anyhow::{Result, bail};
use polymap::config::Config;
use polymap::map::MapSegment;
use polymap::polyline::group_polylines;
use polymap_io::tum::write_tum;
use polymap_pipeline::folder::{RunFolder, check_output_apart};
use serde_json::json;

use crate::args::MergeArgs;
use input::{global_map, read_input, shown};
use output::{merge, remove_stale, remove_stale_trajectories, write_json, write_outputs};
use pair::lay;

/// Spacing of the points sampled along a map's segments for scoring and ICP, metres.
const SAMPLE_SPACING_M: f64 = 0.05;

pub fn run(a: &MergeArgs) -> Result<()> {
    match a.maps.as_slice() {
        [first, second] => run_pair(a, first, second),
        [_, _, ..] => multi::run(a),
        _ => bail!("polymap merge needs two maps or more"),
    }
}

/// Two maps: B merged into A, or refused.
fn run_pair(a: &MergeArgs, first: &std::path::Path, second: &std::path::Path) -> Result<()> {
    let (map_a, map_b) = (read_input(first)?, read_input(second)?);
    check_output_apart(&a.output, &[("map A", &map_a.dir), ("map B", &map_b.dir)])?;
    let folder = RunFolder::prepare(&a.output)?;
    let config = Config::default();
    let fixed = global_map(&map_a.segments, &config);
    let laid = lay(&map_a, &fixed, &map_b, a.by, &config);
    folder.begin_writing()?;
    if let Some(why) = &laid.refusal {
        remove_stale(folder.path())?;
        write_json(&folder.path().join("merge.json"), &laid.report)?;
        folder.finish_writing(&["merge.json"])?;
        bail!("{why}");
    }
    let started = Instant::now();
    let (merged, counts) = merge(&map_a, &laid.b_segments, fixed, &config);
    let polylines = polylines_of(&merged, &config);
    let mut report = laid.report;
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
    let mut written = vec!["map.json", "merge.json", "map.svg"];
    let mut keep = Vec::new();
    if !laid.b_trajectory.is_empty() {
        write_tum(folder.path().join("trajectory_b.tum"), &laid.b_trajectory)?;
        written.push("trajectory_b.tum");
        keep.push("trajectory_b.tum".to_string());
    }
    remove_stale_trajectories(folder.path(), &keep)?;
    folder.finish_writing(&written)?;
    if !a.quiet {
        for line in &laid.said {
            say!("{line}");
        }
        say!(
            "segments: A {} + B {} -> {} merged; wrote {}",
            map_a.segments.len(),
            map_b.segments.len(),
            merged.len(),
            shown(&a.output)
        );
    }
    Ok(())
}

/// The merged map's polylines (indices into `merged`).
fn polylines_of(merged: &[MapSegment], config: &Config) -> Vec<Vec<usize>> {
    group_polylines(
        &merged.iter().map(|s| s.segment).collect::<Vec<_>>(),
        config.polyline.max_gap_m,
    )
}
