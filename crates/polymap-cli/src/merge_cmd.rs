//! `polymap merge A B -o OUT`: finds where map B lies in map A (global search over
//! segment-pair hypotheses, verified by a raster score), refuses maps that do not overlap or
//! align ambiguously, and merges B into A by the mapper's own merge; writes `map.json` (A's
//! frame), `merge.json` (the transform and what it rests on) and `map.svg`.
//!
//! When no rigid transform is accepted (each map drifted on its own), B is bent onto A by a
//! joint pose graph of both maps' loop nodes ([`polymap::loops::joint_graph`]) seeded by the
//! rigid match's best poses: B's segments move with their nodes, and B's trajectory so moved
//! is written as `trajectory_b.tum`.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use polymap::align::{
    GlobalMatch, GlobalParams, MatchVerdict, MovingSide, ScoredPose, global_match, overlap_share,
    points_along,
};
use polymap::config::Config;
use polymap::geometry::{Pose2, Segment, Vec2};
use polymap::loops::{
    CrossVerdict, JointGraph, JointParams, NodeSearch, NodeSearchParams, SavedNode, joint_graph,
    node_search_seeds,
};
use polymap::map::{GlobalMap, MapSegment};
use polymap::merge::{MapMergeParams, MapMergeResult, merge_map};
use polymap::polyline::group_polylines;
use polymap::segment_index::SegmentIndex;
use polymap_export::svg::{SvgStyle, write_svg};
use polymap_io::atomic::write_bytes_atomic;
use polymap_io::loop_nodes::{LOOP_NODES_FILE, read_loop_nodes};
use polymap_io::map_json::{MapJson, read_map_json, write_map_json};
use polymap_io::snapshot::{MapSnapshot, Polyline};
use polymap_io::tum::{StampedPose, read_tum, write_tum};
use polymap_pipeline::folder::{RunFolder, check_output_apart};
use serde_json::json;

use crate::args::{MergeArgs, MergeBy};
use crate::quote::quoted;

/// The merged map's files in the output folder (removed when a merge is refused; `merge.json`
/// is written either way).
const MAP_FILES: [&str; 3] = ["map.json", "map.svg", "trajectory_b.tum"];
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
    /// The robot's poses from `trajectory.tum` (empty without it), one per scan, map frame.
    trajectory: Vec<StampedPose>,
    /// The loop nodes of `loop_nodes.json`, when the folder has it.
    nodes: Option<Vec<SavedNode>>,
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
    let rigid_verdict = found.verdict(&params);
    let mut report = merge_json(
        a,
        &map_a,
        &map_b,
        &found,
        rigid_verdict,
        overlap_a,
        search_s,
    );
    report["method"] = json!("rigid");
    let bend = match (a.by, rigid_verdict) {
        (MergeBy::Rigid, _) | (MergeBy::Auto, MatchVerdict::Accepted) => None,
        // A map that fits in two places is refused however it is laid.
        (_, MatchVerdict::Ambiguous) => None,
        _ => match (&map_a.nodes, &map_b.nodes) {
            (Some(na), Some(nb)) if !na.is_empty() && !nb.is_empty() => {
                let started = Instant::now();
                let tried = by_pose_graph(&fixed, &map_b, na, nb, &found, &params, &config);
                report["pose_graph"] = pose_graph_json(&tried, started.elapsed().as_secs_f64());
                Some(tried)
            }
            _ => {
                if a.by == MergeBy::PoseGraph {
                    remove_stale(folder.path())?;
                    write_json(&folder.path().join("merge.json"), &report)?;
                    folder.finish_writing(&["merge.json"])?;
                    bail!(
                        "--by pose-graph needs the loop nodes of both maps: {} or {} has no \
                         {LOOP_NODES_FILE} (written by polymap map): not merged",
                        shown(&map_a.dir),
                        shown(&map_b.dir)
                    );
                }
                None
            }
        },
    };
    let verdict = match &bend {
        None => rigid_verdict,
        Some(t) => t.verdict,
    };
    report["verdict"] = json!(verdict);
    if verdict != MatchVerdict::Accepted {
        remove_stale(folder.path())?;
        write_json(&folder.path().join("merge.json"), &report)?;
        folder.finish_writing(&["merge.json"])?;
        match &bend {
            Some(t) => bail!("{}", bend_refusal(&map_a, &map_b, t, &found, &params)),
            None => bail!("{}", refusal(&map_a, &map_b, &found, verdict, &params)),
        }
    }
    let started = Instant::now();
    let bent = bend.as_ref().and_then(|t| t.best.as_ref());
    let (b_moved, b_trajectory) = match bent {
        Some(c) => {
            report["method"] = json!("pose_graph");
            report["a_from_b"] = pose_json(&c.seed);
            (c.b_segments.clone(), c.b_trajectory.clone())
        }
        None => (
            moved_rigidly(&map_b.segments, &a_from_b),
            map_b
                .trajectory
                .iter()
                .map(|p| StampedPose {
                    stamp: p.stamp.clone(),
                    map_from_robot: a_from_b.compose(&p.map_from_robot),
                })
                .collect(),
        ),
    };
    let (merged, counts) = merge(&map_a, &b_moved, fixed, &config);
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
    let mut written = vec!["map.json", "merge.json", "map.svg"];
    if !b_trajectory.is_empty() {
        write_tum(folder.path().join("trajectory_b.tum"), &b_trajectory)?;
        written.push("trajectory_b.tum");
    } else {
        remove_stale_file(&folder.path().join("trajectory_b.tum"))?;
    }
    folder.finish_writing(&written)?;
    if !a.quiet {
        summarize(&map_a, &map_b, &found, overlap_a, merged.len(), &a.output);
        if let Some(c) = bent {
            let (max, mean, _) = c.graph.moved();
            say!(
                "bent by a joint pose graph: {} cross constraints used ({} rejected), B's \
                 nodes moved up to {max:.2} m (mean {mean:.2} m)",
                c.graph.count(CrossVerdict::Used),
                c.graph.cross.len() - c.graph.count(CrossVerdict::Used)
            );
        }
    }
    Ok(())
}

/// Reads `DIR/map.json` and counts the scans that made it (its `scans`, or one past the
/// latest birth in a version 1 file).
fn read_input(dir: &Path) -> Result<Input> {
    if !dir.is_dir() {
        bail!("{}: not a folder (a polymap map output)", shown(dir));
    }
    let lock =
        crate::outputs::check_run_folder(dir, &["map.json", "trajectory.tum", LOOP_NODES_FILE])?;
    let map = read_map_json(dir.join("map.json"))?;
    let segments = map.map_segments();
    if segments.is_empty() {
        bail!("{}: the map has no segments", shown(&dir.join("map.json")));
    }
    let born = segments.iter().map(|s| s.born_scan).max().unwrap_or(0);
    let scans = map.scans_mapped().max(born.saturating_add(1));
    let tum = dir.join("trajectory.tum");
    let trajectory = match tum.is_file() {
        true => read_tum(&tum)?,
        false => Vec::new(),
    };
    let path: Vec<Vec2> = trajectory
        .iter()
        .map(|p| p.map_from_robot.translation())
        .collect();
    let nodes_file = dir.join(LOOP_NODES_FILE);
    let nodes = match nodes_file.is_file() {
        true => Some(read_loop_nodes(&nodes_file)?),
        false => None,
    };
    Ok(Input {
        dir: dir.to_path_buf(),
        map,
        segments,
        scans,
        path,
        trajectory,
        nodes,
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

/// Seeds of the joint pose graph tried, at most: the rigid match's best poses.
const MAX_SEEDS: usize = 3;
/// A seed after the first explains at least this mean raster value of B's points.
const SEED_MIN_RASTER: f64 = 0.15;
/// Least cross constraints a merge by the joint pose graph keeps.
const MIN_CROSS: usize = 5;
/// Least share of B's bent walls within `inlier_m` of A's in a merge by the joint pose graph.
const MIN_BENT_OVERLAP: f64 = 0.2;
/// B's bent walls within this of A's are where the maps meet, metres.
const NEAR_M: f64 = 0.5;
/// Least share of B's bent walls where the maps meet (within `NEAR_M` of A's) that lie on
/// A's (within `inlier_m`): bent onto the right place, the two maps' walls coincide there.
const MIN_AGREEMENT: f64 = 0.5;
/// Cross constraints listed in `merge.json`, at most (the rejected first).
const CROSS_SHOWN: usize = 10;

/// B bent onto A by the joint pose graph from one seed.
struct Bent {
    /// B's placement in A seeding the graph.
    seed: Pose2,
    graph: JointGraph,
    /// B's segments moved with their nodes, A's frame.
    b_segments: Vec<MapSegment>,
    /// B's trajectory moved with its nodes, A's frame (empty without `trajectory.tum`).
    b_trajectory: Vec<StampedPose>,
    /// The share of B's bent walls within `inlier_m` of A's.
    overlap: f64,
    /// Of B's bent walls within `NEAR_M` of A's, the share within `inlier_m`.
    agreement: f64,
    /// Enough cross constraints kept and enough overlap.
    passes: bool,
}

/// The outcome of laying B onto A by the joint pose graph.
struct Tried {
    verdict: MatchVerdict,
    /// Every seed tried: its pose, cross constraints used, overlap, agreement, whether it
    /// passed.
    seeds: Vec<(Pose2, usize, f64, f64, bool)>,
    /// The first this many seeds are the rigid match's; the others the node search's.
    rigid_seeds: usize,
    /// The search of each of B's nodes over A.
    node_search: NodeSearch,
    /// The first passing attempt in seed order, else the first attempt.
    best: Option<Bent>,
    /// Another passing attempt that puts B elsewhere (the merge is then ambiguous).
    rival: Option<Pose2>,
}

/// B bent onto A by the joint pose graph from each of the rigid match's best distinct poses;
/// accepted when one passes (see [`Bent::passes`]) and no other passing one puts B elsewhere.
fn by_pose_graph(
    fixed: &GlobalMap,
    b: &Input,
    a_nodes: &[SavedNode],
    b_nodes: &[SavedNode],
    found: &GlobalMatch,
    params: &GlobalParams,
    config: &Config,
) -> Tried {
    let mut seeds = vec![found.fixed_from_moving];
    for c in &found.candidates {
        if seeds.len() >= MAX_SEEDS {
            break;
        }
        if c.raster_score >= SEED_MIN_RASTER
            && seeds.iter().all(|s| apart(s, &c.fixed_from_moving, params))
        {
            seeds.push(c.fixed_from_moving);
        }
    }
    let rigid_seeds = seeds.len();
    let node_search = node_search_seeds(
        a_nodes,
        b_nodes,
        &config.loops,
        &config.align,
        config.map.grid_cell_m,
        &JointParams::default(),
        &NodeSearchParams::default(),
    );
    for s in &node_search.seeds {
        if seeds.iter().all(|t| apart(t, &s.a_from_b, params)) {
            seeds.push(s.a_from_b);
        }
    }
    let a_segments: Vec<Segment> = fixed.iter().map(|(_, s)| s.segment).collect();
    let a_index = SegmentIndex::from_segments(&a_segments, 1.0, NEAR_M);
    let mut attempts: Vec<Bent> = seeds
        .iter()
        .map(|seed| {
            let graph = joint_graph(
                a_nodes,
                b_nodes,
                seed,
                &config.loops,
                &config.align,
                config.map.grid_cell_m,
                &JointParams::default(),
            );
            let (b_segments, b_trajectory) =
                bend_b(b, b_nodes, &graph, seed, config.loops.node_scans);
            let bent: Vec<Segment> = b_segments.iter().map(|s| s.segment).collect();
            let points = points_along(&bent, SAMPLE_SPACING_M);
            let overlap = overlap_share(&points, &a_index, &Pose2::IDENTITY, params.inlier_m);
            let near = overlap_share(&points, &a_index, &Pose2::IDENTITY, NEAR_M);
            let agreement = if near > 0.0 { overlap / near } else { 0.0 };
            let passes = graph.count(CrossVerdict::Used) >= MIN_CROSS
                && overlap >= MIN_BENT_OVERLAP
                && agreement >= MIN_AGREEMENT;
            Bent {
                seed: *seed,
                graph,
                b_segments,
                b_trajectory,
                overlap,
                agreement,
                passes,
            }
        })
        .collect();
    let summary = attempts
        .iter()
        .map(|t| {
            (
                t.seed,
                t.graph.count(CrossVerdict::Used),
                t.overlap,
                t.agreement,
                t.passes,
            )
        })
        .collect();
    // The passing attempts first, each group in seed order (the rigid match's best first).
    attempts.sort_by_key(|t| !t.passes);
    let rival = attempts.first().filter(|t| t.passes).and_then(|best| {
        attempts
            .iter()
            .skip(1)
            .find(|t| t.passes && elsewhere(best, t, params))
            .map(|t| t.seed)
    });
    let best = attempts.into_iter().next();
    let verdict = match (&best, rival) {
        (Some(t), None) if t.passes => MatchVerdict::Accepted,
        (Some(t), Some(_)) if t.passes => MatchVerdict::Ambiguous,
        _ => MatchVerdict::NoOverlap,
    };
    Tried {
        verdict,
        seeds: summary,
        rigid_seeds,
        node_search,
        best,
        rival,
    }
}

/// True when two bent Bs lie in different places: half of B's nodes or more are farther
/// apart than `apart_m` or turned more than `apart_deg` between the two (parts of B far from
/// A may bend differently from different seeds; a second place moves all of B).
fn elsewhere(one: &Bent, other: &Bent, params: &GlobalParams) -> bool {
    let (a, b) = (&one.graph.b_poses, &other.graph.b_poses);
    if a.is_empty() || a.len() != b.len() {
        return apart(&one.seed, &other.seed, params);
    }
    let moved = a.iter().zip(b).filter(|(p, q)| apart(p, q, params)).count();
    2 * moved >= a.len()
}

/// True when two poses are farther apart than `apart_m` or `apart_deg`.
fn apart(a: &Pose2, b: &Pose2, params: &GlobalParams) -> bool {
    let d = a.between(b);
    d.translation().length() > params.apart_m || d.theta_rad.abs() > params.apart_deg.to_radians()
}

/// The first scan of each of B's nodes: the scan of B's trajectory at the node's pose (a node
/// is posed at its first scan, both corrected alike), in order; every `node_scans`-th scan
/// when some node is not found there (no trajectory, or nodes of an earlier run).
fn node_starts(nodes: &[SavedNode], trajectory: &[StampedPose], node_scans: u32) -> Vec<u32> {
    const SAME_M: f64 = 1e-5;
    const SAME_RAD: f64 = 1e-5;
    let mut starts = Vec::with_capacity(nodes.len());
    let mut from = 0;
    for n in nodes {
        let at = trajectory.get(from..).and_then(|rest| {
            rest.iter().position(|p| {
                let d = p.map_from_robot.between(&n.pose);
                d.translation().length() <= SAME_M && d.theta_rad.abs() <= SAME_RAD
            })
        });
        match at {
            Some(i) => {
                starts.push((from + i) as u32);
                from += i + 1;
            }
            None => {
                return (0..nodes.len())
                    .map(|k| (k as u64 * node_scans as u64).min(u32::MAX as u64) as u32)
                    .collect();
            }
        }
    }
    starts
}

/// B's segments and trajectory in A's frame, each moved with its scan: a scan between two
/// nodes' first scans moves by the blend of the two nodes' corrections
/// ([`JointGraph::moved_pose`]); a segment moves with the scan it was born in.
fn bend_b(
    b: &Input,
    nodes: &[SavedNode],
    graph: &JointGraph,
    seed: &Pose2,
    node_scans: u32,
) -> (Vec<MapSegment>, Vec<StampedPose>) {
    let starts = node_starts(nodes, &b.trajectory, node_scans);
    let node_and_share = |t: u32| {
        let k = starts.partition_point(|&s| s <= t).saturating_sub(1);
        let share = match (starts.get(k), starts.get(k + 1)) {
            (Some(&s0), Some(&s1)) if s1 > s0 && t >= s0 => (t - s0) as f64 / (s1 - s0) as f64,
            _ => 0.0,
        };
        (k, share)
    };
    // The correction (new ∘ old⁻¹, A's frame) of scan t.
    let correction = |t: u32| -> Pose2 {
        let (k, share) = node_and_share(t);
        match b.trajectory.get(t as usize) {
            Some(p) => {
                let old = seed.compose(&p.map_from_robot);
                graph.moved_pose(k, share, &old).compose(&old.inverse())
            }
            None => match (graph.b_poses.get(k), graph.b_seeded.get(k)) {
                (Some(new), Some(old)) => new.compose(&old.inverse()),
                _ => Pose2::IDENTITY,
            },
        }
    };
    let segments = b
        .segments
        .iter()
        .map(|s| MapSegment {
            segment: s
                .segment
                .transformed(&correction(s.born_scan).compose(seed)),
            born_scan: s.born_scan,
        })
        .collect();
    let trajectory = b
        .trajectory
        .iter()
        .enumerate()
        .map(|(t, p)| StampedPose {
            stamp: p.stamp.clone(),
            map_from_robot: correction(t as u32).compose(&seed.compose(&p.map_from_robot)),
        })
        .collect();
    (segments, trajectory)
}

/// `merge.json`'s `pose_graph`: the seeds tried, the cross constraints, how far each map's
/// nodes moved.
fn pose_graph_json(t: &Tried, seconds: f64) -> serde_json::Value {
    let seeds: Vec<serde_json::Value> = t
        .seeds
        .iter()
        .enumerate()
        .map(|(i, (seed, used, overlap, agreement, passes))| {
            let from = if i < t.rigid_seeds {
                "rigid"
            } else {
                "node_search"
            };
            json!({"a_from_b": pose_json(seed), "from": from, "cross_used": used,
                   "overlap": overlap, "agreement": agreement, "passes": passes})
        })
        .collect();
    let mut out = json!({
        "verdict": t.verdict,
        "seeds": seeds,
        "min_cross": MIN_CROSS,
        "min_overlap": MIN_BENT_OVERLAP,
        "min_agreement": MIN_AGREEMENT,
        "rival": t.rival.as_ref().map(pose_json),
        "node_search": {
            "searched": t.node_search.searched,
            "matched": t.node_search.matched,
            "confirmed": t.node_search.confirmed,
            "seeds": t.node_search.seeds.iter().map(|s| json!({
                "a_from_b": pose_json(&s.a_from_b), "support": s.support,
            })).collect::<Vec<_>>(),
        },
        "seconds": seconds,
    });
    let Some(best) = &t.best else {
        return out;
    };
    let g = &best.graph;
    let (max_m, mean_m, max_deg) = g.moved();
    let mut shown: Vec<_> = g.cross.iter().collect();
    shown.sort_by_key(|c| c.verdict == CrossVerdict::Used);
    let shown: Vec<serde_json::Value> = shown
        .iter()
        .take(CROSS_SHOWN)
        .map(|c| {
            json!({"a_node": c.a_node, "b_node": c.b_node, "verdict": c.verdict,
                   "residual_m": c.residual_m, "residual_deg": c.residual_deg})
        })
        .collect();
    out["seed"] = pose_json(&best.seed);
    out["overlap"] = json!(best.overlap);
    out["moved"] = json!({
        "a": {"max_m": 0.0, "mean_m": 0.0, "max_deg": 0.0},
        "b": {"max_m": max_m, "mean_m": mean_m, "max_deg": max_deg},
    });
    out["nodes"] = json!({"b": g.b_poses.len()});
    out["b_loop_edges"] = json!(g.b_loop_edges);
    out["cross"] = json!({
        "tried": g.candidates,
        "found": g.cross.len(),
        "used": g.count(CrossVerdict::Used),
        "unconfirmed": g.count(CrossVerdict::Unconfirmed),
        "residual": g.count(CrossVerdict::Residual),
        "shown": shown,
    });
    out
}

/// Why the maps are not merged by the joint pose graph either, with the figures.
fn bend_refusal(
    a: &Input,
    b: &Input,
    t: &Tried,
    found: &GlobalMatch,
    params: &GlobalParams,
) -> String {
    let (a, b) = (shown(&a.dir), shown(&b.dir));
    let (used, overlap, agreement) = t.best.as_ref().map_or((0, 0.0, 0.0), |x| {
        (x.graph.count(CrossVerdict::Used), x.overlap, x.agreement)
    });
    match (t.verdict, t.rival, &t.best) {
        (MatchVerdict::Ambiguous, Some(r), Some(best)) => {
            let d = r.between(&best.seed);
            format!(
                "{b} fits {a} in two places: bent by a joint pose graph of their loop nodes \
                 from two seeds {:.1} m and {:.0}° apart, both keep enough cross constraints \
                 and overlap: not merged (see merge.json)",
                d.translation().length(),
                d.theta_rad.to_degrees().abs()
            )
        }
        _ => format!(
            "{a} and {b} do not overlap: the best rigid alignment scores {:.2} (needs {:.2}) \
             with {:.0} % of B's walls within {} m of A's (needs {:.0} %), and bent by a joint \
             pose graph of their loop nodes ({} seeds) B keeps {used} cross constraints (needs \
             {MIN_CROSS}) with {:.0} % of its walls within {} m of A's (needs {:.0} %), {:.0} % \
             of those within {NEAR_M} m (needs {:.0} %): not merged (see merge.json)",
            found.best.raster_score,
            params.min_score,
            100.0 * found.overlap,
            params.inlier_m,
            100.0 * params.min_overlap,
            t.seeds.len(),
            100.0 * overlap,
            params.inlier_m,
            100.0 * MIN_BENT_OVERLAP,
            100.0 * agreement,
            100.0 * MIN_AGREEMENT,
        ),
    }
}

/// B's segments placed in A's frame by one transform.
fn moved_rigidly(b: &[MapSegment], a_from_b: &Pose2) -> Vec<MapSegment> {
    b.iter()
        .map(|s| MapSegment {
            segment: s.segment.transformed(a_from_b),
            born_scan: s.born_scan,
        })
        .collect()
}

/// B's segments (already in A's frame) merged into A, born after A's scans.
fn merge(
    a: &Input,
    b_in_a: &[MapSegment],
    mut map: GlobalMap,
    config: &Config,
) -> (Vec<MapSegment>, MapMergeResult) {
    let counts = merge_map(
        &config.merge,
        &config.directions,
        &MapMergeParams::default(),
        &mut map,
        b_in_a,
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
        remove_stale_file(&dir.join(name))?;
    }
    Ok(())
}

/// Removes one file of an earlier merge, if there.
fn remove_stale_file(path: &Path) -> Result<()> {
    if path.is_file() {
        std::fs::remove_file(path).with_context(|| format!("{}: cannot remove", path.display()))?;
        eprintln!("polymap: removed {} of an earlier merge", path.display());
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
