//! Inputs shared by the benches: the first scans of the Intel log (when the datasets are there)
//! and of the simulated `hallway45` world (always), and the inputs of every pipeline stage for
//! a few consecutive scans taken from a realistic map state.
//!
//! The datasets are looked for in `$POLYMAP_DATASETS`, else in `../shared/datasets` beside the
//! workspace, as the tests do.

// Each bench target compiles this module and uses a part of it.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use polymap::config::Config;
use polymap::geometry::{Pose2, Segment, Vec2};
use polymap::mapper::Mapper;
use polymap::merge::{Pairing, Piece, insert_vertices, restrictive_pairing};
use polymap::scan::RangeScan;
use polymap_io::carmen::{CarmenReader, ReaderOptions};
use polymap_sim::{SimParams, World, simulate};

/// Scans pushed to build the map state the per-stage benches start from, unless
/// `POLYMAP_BENCH_WARM_SCANS` says otherwise (e.g. 5000, for Intel's larger map later on).
pub const WARM_SCANS: usize = 500;

/// [`WARM_SCANS`], or `$POLYMAP_BENCH_WARM_SCANS` when that is a number of at least 2.
pub fn warm_scans() -> usize {
    std::env::var("POLYMAP_BENCH_WARM_SCANS")
        .ok()
        .and_then(|v| v.parse().ok())
        .filter(|n: &usize| *n >= 2)
        .unwrap_or(WARM_SCANS)
}
/// Consecutive scans after the warm-up whose stages are timed; one bench iteration runs the
/// stage once for each of them.
pub const STEPS: usize = 10;

/// The datasets folder (it may not exist).
pub fn datasets_dir() -> PathBuf {
    match std::env::var_os("POLYMAP_DATASETS") {
        Some(dir) => PathBuf::from(dir),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/datasets"),
    }
}

/// The Intel log, or `None` with a printed `SKIPPED` message when it is absent.
pub fn intel_log() -> Option<PathBuf> {
    let path = datasets_dir().join("intel/intel.clf");
    if path.is_file() {
        Some(path)
    } else {
        eprintln!(
            "SKIPPED: {} is absent: the Intel benches do not run (set POLYMAP_DATASETS)",
            path.display()
        );
        None
    }
}

/// The first `n` scans of a CARMEN log. Panics with the reader's message on a bad log: a bench
/// has no better way to fail.
pub fn read_scans(path: &Path, n: usize) -> Vec<RangeScan> {
    let mut reader = CarmenReader::open(path, ReaderOptions::default())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut scans = Vec::with_capacity(n);
    while scans.len() < n {
        match reader.next_scan() {
            Ok(Some(scan)) => scans.push(scan),
            Ok(None) => break,
            Err(e) => panic!("{e}"),
        }
    }
    scans
}

/// The first `n` scans of the simulated `hallway45` world (default parameters, seed 1).
pub fn hallway45_scans(n: usize) -> Vec<RangeScan> {
    let params = SimParams {
        max_scans: Some(n),
        ..SimParams::default()
    };
    simulate(&World::hallway45(), &params, 1).scans
}

/// The named scan sources: Intel's first scans when present, and `hallway45`'s.
pub fn sources(n: usize) -> Vec<(&'static str, Vec<RangeScan>)> {
    let mut out = Vec::new();
    if let Some(log) = intel_log() {
        out.push(("intel", read_scans(&log, n)));
    }
    out.push(("hallway45", hallway45_scans(n)));
    out
}

/// What each stage of [`Mapper::push`] gets for one scan, computed from the state before it.
pub struct Step {
    /// The mapper before the scan.
    pub mapper: Mapper,
    /// The scan.
    pub scan: RangeScan,
    /// Its valid points, robot frame.
    pub points: Vec<Vec2>,
    /// Its points thinned for ICP.
    pub thinned: Vec<Vec2>,
    /// ICP's constant-velocity starting pose and its anchor (the previous pose).
    pub guess: Pose2,
    /// The anchor.
    pub anchor: Pose2,
    /// The pose `Mapper::push` settled on.
    pub pose: Pose2,
    /// Segments of `G_{t-1}` born in the last `tm` scans (the main directions' input).
    pub recent: Vec<Segment>,
    /// The main directions used for merging, radians.
    pub directions_rad: Vec<f64>,
    /// The scan's segments, map frame.
    pub scan_in_map: Vec<Segment>,
    /// The map segments near the scan (class C1 before vertex insertion).
    pub c1: Vec<Segment>,
    /// Map and scan pieces after vertex insertion.
    pub pieces: (Vec<Piece>, Vec<Piece>),
    /// `A_t`: children and the segments that did not become parents (simplification's input).
    pub a_t: Vec<Segment>,
}

/// The stage inputs of scans `warm..warm + STEPS` of `scans`, each from the map state a
/// default-configured mapper reached just before it; `None` when there are too few scans.
pub fn steps(scans: &[RangeScan], warm: usize) -> Option<Vec<Step>> {
    if scans.len() < warm + STEPS || warm < 2 {
        return None;
    }
    let mut mapper = Mapper::new(Config::default());
    let mut poses: Vec<Pose2> = Vec::new();
    for scan in &scans[..warm] {
        poses.push(mapper.push(scan).map_from_robot);
    }
    let mut out = Vec::with_capacity(STEPS);
    for scan in &scans[warm..warm + STEPS] {
        let before = mapper.clone();
        let update = mapper.push(scan);
        out.push(step(
            before,
            scan,
            &poses,
            update.map_from_robot,
            update_dirs(&update),
        ));
        poses.push(update.map_from_robot);
    }
    Some(out)
}

fn update_dirs(update: &polymap::mapper::Update) -> Vec<f64> {
    let deg = &update.diagnostics.main_directions_deg;
    deg.iter().map(|d| d.to_radians()).collect()
}

fn step(
    mapper: Mapper,
    scan: &RangeScan,
    poses: &[Pose2],
    pose: Pose2,
    directions_rad: Vec<f64>,
) -> Step {
    let config = mapper.config().clone();
    let mut points = Vec::new();
    scan.points_in_robot(&mut points);
    let thinned = polymap::align::thin_points(&points, config.align.point_spacing_m);
    let (prev, last) = (poses[poses.len() - 2], poses[poses.len() - 1]);
    let t = mapper.scans();
    let recent = mapper
        .map()
        .clone()
        .born_since(t.saturating_sub(config.directions.time_memory_scans));
    let scan_in_map: Vec<Segment> =
        polymap::extract::extract_segments(&points, scan.angle_increment_rad, &config.extract)
            .iter()
            .map(|e| e.segment.transformed(&pose))
            .collect();
    let c1 = local_map(&mapper, &scan_in_map, config.merge.local_margin_m);
    let pieces = insert_vertices(&c1, &scan_in_map, &config.merge);
    let pairing = restrictive_pairing(
        &segments(&pieces.0),
        &segments(&pieces.1),
        &directions_rad,
        &config.merge,
    );
    let a_t = a_t(&pieces, &pairing, &c1, &scan_in_map);
    Step {
        guess: last.compose(&prev.between(&last)),
        anchor: last,
        mapper,
        scan: scan.clone(),
        points,
        thinned,
        pose,
        recent,
        directions_rad,
        scan_in_map,
        c1,
        pieces,
        a_t,
    }
}

/// The map segments whose boxes come within `margin_m` of a scan segment's box, as the mapper
/// takes them for merging.
fn local_map(mapper: &Mapper, scan_in_map: &[Segment], margin_m: f64) -> Vec<Segment> {
    let map = mapper.map();
    let margin = Vec2::splat(margin_m);
    let mut ids: Vec<_> = scan_in_map
        .iter()
        .flat_map(|s| {
            let (lo, hi) = s.bounds();
            map.query(lo - margin, hi + margin)
        })
        .collect();
    ids.sort_unstable();
    ids.dedup();
    ids.iter()
        .filter_map(|id| map.get(*id).map(|s| s.segment))
        .collect()
}

fn segments(pieces: &[Piece]) -> Vec<Segment> {
    pieces.iter().map(|p| p.segment).collect()
}

/// Children, plus for every source segment either its non-parent pieces or, when none of its
/// pieces became a parent, the whole segment (the default `rejoin_unpaired_pieces`).
fn a_t(
    (map_pieces, scan_pieces): &(Vec<Piece>, Vec<Piece>),
    pairing: &Pairing,
    c1: &[Segment],
    scan: &[Segment],
) -> Vec<Segment> {
    let mut out: Vec<Segment> = pairing.children.iter().map(|c| c.segment).collect();
    keep(&mut out, map_pieces, &pairing.map_is_parent, c1);
    keep(&mut out, scan_pieces, &pairing.scan_is_parent, scan);
    out
}

fn keep(out: &mut Vec<Segment>, pieces: &[Piece], is_parent: &[bool], whole: &[Segment]) {
    for (source, original) in whole.iter().enumerate() {
        let mine = || {
            pieces
                .iter()
                .zip(is_parent)
                .filter(move |(p, _)| p.source == source)
        };
        if mine().any(|(_, parent)| *parent) {
            out.extend(mine().filter(|(_, p)| !**p).map(|(piece, _)| piece.segment));
        } else {
            out.push(*original);
        }
    }
}
