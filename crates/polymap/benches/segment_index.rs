//! Criterion bench of the nearest-segment index against the R-trees it replaced, on the same
//! queries: the decision behind `polymap::segment_index` (`docs/decisions/2026-11-23-one-segment-index.md`).
//!
//! Inputs: the map of a default-configured `Mapper` after the warm-up scans of the Intel log
//! and of the simulated `hallway45` world (see `support`; `POLYMAP_BENCH_WARM_SCANS=5000` for
//! Intel's larger map later on), taken for the next 10 scans. Queries, per scan:
//!
//! - `nearest`: for every thinned scan point at the pose the mapper settled on, the nearest
//!   map segment within ICP's first gate (`align.initial_gate_m`), as ICP asks;
//! - `box`: for every scan segment in the map frame, the map segments that come within the
//!   merge's proximity gate (`merge.max_gap_m`): candidates from a box query, then the exact
//!   segment-to-segment test, as the merge's candidate pairs do;
//! - `build`: indexing the map's segments.
//!
//! Candidates: `grid` (`polymap::segment_index::SegmentIndex`, the one kept), `rstar_line`
//! (rstar's `Line` primitive with its exact point distance, as `align::SegmentIndex` was),
//! `rstar_box` (bounding boxes with the segment's point distance, as the evaluation's index and
//! the merge's trees were) and `brute` (every segment). One iteration answers the queries of
//! all 10 scans; `elem/s` counts queries.
//!
//! Run: `cargo bench -p polymap --bench segment_index` (about 40 s).

mod support;

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkGroup, Criterion, Throughput, measurement::WallTime};
use polymap::config::Config;
use polymap::geometry::{Segment, Vec2};
use polymap::segment_index::SegmentIndex;
use rstar::primitives::{GeomWithData, Line, Rectangle};
use rstar::{AABB, PointDistance, RTree, RTreeObject};
use support::{STEPS, sources, steps, warm_scans};

/// A segment with its index, indexed by its bounding box (the evaluation's former index).
#[derive(Clone, Copy)]
struct BoxedSegment {
    segment: Segment,
    index: usize,
}

impl RTreeObject for BoxedSegment {
    type Envelope = AABB<[f64; 2]>;

    fn envelope(&self) -> Self::Envelope {
        let (lo, hi) = self.segment.bounds();
        AABB::from_corners([lo.x, lo.y], [hi.x, hi.y])
    }
}

impl PointDistance for BoxedSegment {
    fn distance_2(&self, point: &[f64; 2]) -> f64 {
        self.segment
            .distance_2_to_point(Vec2::new(point[0], point[1]))
    }
}

type LineEntry = GeomWithData<Line<[f64; 2]>, usize>;
type RectEntry = GeomWithData<Rectangle<[f64; 2]>, usize>;

fn line_tree(segments: &[Segment]) -> RTree<LineEntry> {
    RTree::bulk_load(
        segments
            .iter()
            .enumerate()
            .map(|(i, s)| {
                GeomWithData::new(Line::new([s.start.x, s.start.y], [s.end.x, s.end.y]), i)
            })
            .collect(),
    )
}

fn box_tree(segments: &[Segment]) -> RTree<BoxedSegment> {
    RTree::bulk_load(
        segments
            .iter()
            .enumerate()
            .map(|(index, &segment)| BoxedSegment { segment, index })
            .collect(),
    )
}

fn rect_tree(segments: &[Segment]) -> RTree<RectEntry> {
    RTree::bulk_load(
        segments
            .iter()
            .enumerate()
            .map(|(i, s)| {
                let (lo, hi) = s.bounds();
                GeomWithData::new(Rectangle::from_corners([lo.x, lo.y], [hi.x, hi.y]), i)
            })
            .collect(),
    )
}

fn grid(segments: &[Segment]) -> SegmentIndex<usize> {
    SegmentIndex::from_segments(segments, 0.5, 1.0)
}

/// One scan's map and queries.
struct Case {
    map: Vec<Segment>,
    points: Vec<Vec2>,
    scan: Vec<Segment>,
}

fn group<'a>(c: &'a mut Criterion, name: &str, queries: usize) -> BenchmarkGroup<'a, WallTime> {
    let mut g = c.benchmark_group(name);
    g.warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .throughput(Throughput::Elements(queries as u64));
    g
}

fn nearest_brute(map: &[Segment], p: Vec2, gate_m: f64) -> Option<usize> {
    map.iter()
        .enumerate()
        .map(|(i, s)| (s.distance_2_to_point(p), i))
        .filter(|(d_2, _)| *d_2 <= gate_m * gate_m)
        .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
        .map(|(_, i)| i)
}

fn bench_nearest(c: &mut Criterion, name: &str, cases: &[Case], gate_m: f64) {
    let queries = cases.iter().map(|c| c.points.len()).sum();
    let mut g = group(c, "segment_index/nearest", queries);
    let grids: Vec<_> = cases.iter().map(|c| grid(&c.map)).collect();
    g.bench_function(format!("grid/{name}"), |b| {
        b.iter(|| {
            for (case, index) in cases.iter().zip(&grids) {
                for p in &case.points {
                    black_box(index.nearest(*p, gate_m));
                }
            }
        })
    });
    let lines: Vec<_> = cases.iter().map(|c| line_tree(&c.map)).collect();
    g.bench_function(format!("rstar_line/{name}"), |b| {
        b.iter(|| {
            for (case, tree) in cases.iter().zip(&lines) {
                for p in &case.points {
                    let mut best: Option<(f64, usize)> = None;
                    for (e, d_2) in tree.nearest_neighbor_iter_with_distance_2([p.x, p.y]) {
                        if d_2 > gate_m * gate_m || best.is_some_and(|b| d_2 > b.0) {
                            break;
                        }
                        let d_2 = case.map[e.data].distance_2_to_point(*p);
                        if best.is_none_or(|b| (d_2, e.data) < b) {
                            best = Some((d_2, e.data));
                        }
                    }
                    black_box(best);
                }
            }
        })
    });
    let boxes: Vec<_> = cases.iter().map(|c| box_tree(&c.map)).collect();
    g.bench_function(format!("rstar_box/{name}"), |b| {
        b.iter(|| {
            for (case, tree) in cases.iter().zip(&boxes) {
                for p in &case.points {
                    let hit = tree
                        .nearest_neighbor_with_distance_2([p.x, p.y])
                        .filter(|(_, d_2)| *d_2 <= gate_m * gate_m)
                        .map(|(e, _)| e.index);
                    black_box(hit);
                }
            }
        })
    });
    g.bench_function(format!("brute/{name}"), |b| {
        b.iter(|| {
            for case in cases {
                for p in &case.points {
                    black_box(nearest_brute(&case.map, *p, gate_m));
                }
            }
        })
    });
    g.finish();
}

fn box_of(s: &Segment, margin_m: f64) -> (Vec2, Vec2) {
    let (lo, hi) = s.bounds();
    (lo - Vec2::splat(margin_m), hi + Vec2::splat(margin_m))
}

fn within(map: &[Segment], s: &Segment, j: usize, gap_m: f64) -> bool {
    map[j].distance_to_segment_within(s, gap_m).is_some()
}

/// Each scan segment's box query on its case's grid, filtered to the map segments truly
/// within `gap_m`.
fn grid_box_hits(cases: &[Case], grids: &[SegmentIndex<usize>], gap_m: f64) {
    for (case, index) in cases.iter().zip(grids) {
        for s in &case.scan {
            let (lo, hi) = box_of(s, gap_m);
            let keys = index.in_box(lo, hi);
            black_box(
                keys.into_iter()
                    .filter(|&j| within(&case.map, s, j, gap_m))
                    .count(),
            );
        }
    }
}

fn bench_box(c: &mut Criterion, name: &str, cases: &[Case], gap_m: f64) {
    let queries = cases.iter().map(|c| c.scan.len()).sum();
    let mut g = group(c, "segment_index/box", queries);
    let grids: Vec<_> = cases.iter().map(|c| grid(&c.map)).collect();
    g.bench_function(format!("grid/{name}"), |b| {
        b.iter(|| grid_box_hits(cases, &grids, gap_m))
    });
    g.bench_function(format!("grid_near_segment/{name}"), |b| {
        b.iter(|| {
            for (case, index) in cases.iter().zip(&grids) {
                for s in &case.scan {
                    black_box(index.near_segment(s, gap_m));
                }
            }
        })
    });
    let grids0: Vec<_> = cases
        .iter()
        .map(|c| SegmentIndex::from_segments(&c.map, 0.5, 0.0))
        .collect();
    g.bench_function(format!("grid_reach0/{name}"), |b| {
        b.iter(|| grid_box_hits(cases, &grids0, gap_m))
    });
    let rects: Vec<_> = cases.iter().map(|c| rect_tree(&c.map)).collect();
    g.bench_function(format!("rstar_box/{name}"), |b| {
        b.iter(|| {
            for (case, tree) in cases.iter().zip(&rects) {
                for s in &case.scan {
                    let (lo, hi) = box_of(s, gap_m);
                    let env = AABB::from_corners([lo.x, lo.y], [hi.x, hi.y]);
                    let mut keys: Vec<usize> = tree
                        .locate_in_envelope_intersecting(env)
                        .map(|e| e.data)
                        .collect();
                    keys.sort_unstable();
                    black_box(
                        keys.into_iter()
                            .filter(|&j| within(&case.map, s, j, gap_m))
                            .count(),
                    );
                }
            }
        })
    });
    g.bench_function(format!("brute/{name}"), |b| {
        b.iter(|| {
            for case in cases {
                for s in &case.scan {
                    let hits = (0..case.map.len()).filter(|&j| within(&case.map, s, j, gap_m));
                    black_box(hits.count());
                }
            }
        })
    });
    g.finish();
}

fn bench_build(c: &mut Criterion, name: &str, cases: &[Case]) {
    let mut g = group(c, "segment_index/build", cases.len());
    g.bench_function(format!("grid/{name}"), |b| {
        b.iter(|| {
            for case in cases {
                black_box(grid(&case.map));
            }
        })
    });
    g.bench_function(format!("grid_reach0/{name}"), |b| {
        b.iter(|| {
            for case in cases {
                black_box(SegmentIndex::from_segments(&case.map, 0.5, 0.0));
            }
        })
    });
    g.bench_function(format!("rstar_line/{name}"), |b| {
        b.iter(|| {
            for case in cases {
                black_box(line_tree(&case.map));
            }
        })
    });
    g.bench_function(format!("rstar_box/{name}"), |b| {
        b.iter(|| {
            for case in cases {
                black_box(rect_tree(&case.map));
            }
        })
    });
    g.finish();
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    let config = Config::default();
    let warm = warm_scans();
    for (name, scans) in sources(warm + STEPS) {
        let Some(steps) = steps(&scans, warm) else {
            eprintln!("SKIPPED: {name} has fewer than {} scans", warm + STEPS);
            continue;
        };
        let cases: Vec<Case> = steps
            .iter()
            .map(|st| Case {
                map: st.mapper.segments().iter().map(|m| m.segment).collect(),
                points: st
                    .thinned
                    .iter()
                    .map(|p| st.pose.transform_point(*p))
                    .collect(),
                scan: st.scan_in_map.clone(),
            })
            .collect();
        let n = cases.len() as f64;
        let avg = |f: &dyn Fn(&Case) -> usize| cases.iter().map(f).sum::<usize>() as f64 / n;
        eprintln!(
            "{name}: scans {warm}..{}, map {:.0} segments, per scan {:.0} point queries, \
             {:.0} segment queries",
            warm + STEPS,
            avg(&|c| c.map.len()),
            avg(&|c| c.points.len()),
            avg(&|c| c.scan.len()),
        );
        bench_nearest(&mut c, name, &cases, config.align.initial_gate_m);
        bench_box(&mut c, name, &cases, config.merge.max_gap_m);
        bench_build(&mut c, name, &cases);
    }
    c.final_summary();
}
