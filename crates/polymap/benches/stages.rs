//! Criterion benches of each pipeline stage of `Mapper::push`, on realistic inputs.
//!
//! Inputs: the first 510 scans of the Intel log (skipped, with a `SKIPPED` line, when
//! `../shared/datasets/intel/intel.clf` is absent; `POLYMAP_DATASETS` points elsewhere) and of
//! the simulated `hallway45` world (always). A default-configured `Mapper` first integrates 500
//! scans; every stage's inputs are then taken for the next 10 scans (scans 500..510), each from
//! the map state just before it. **One bench iteration runs the stage once for each of those 10
//! scans**, so the time per scan is the reported time / 10 (criterion's throughput line gives
//! scans/s directly as `elem/s`).
//!
//! Groups (bench ids are `group/function/source`):
//!
//! - `extract`: `RangeScan::points_in_robot` and `extract::extract_segments` (DCE).
//! - `icp`: `align::thin_points`; one `align::align_points` run from the constant-velocity guess
//!   against the `GlobalMap` (`Mapper::push` runs it up to twice: also from the anchor); and the
//!   nearest-segment query that dominates ICP, for every thinned point at the 1 m gate, through
//!   `GlobalMap` (the `SegmentLookup` ICP uses; the index's rivals are compared in
//!   `benches/segment_index.rs`).
//! - `directions`: `directions::main_directions` over the segments born in the last `tm` scans.
//! - `merge`: `merge::insert_vertices`, `merge::restrictive_pairing` and `merge::simplify`, on
//!   the map near the scan (as the mapper takes it) and the aligned scan segments; and the
//!   whole stage, `merge::merge_scan`, on a clone of the map (cloning is not timed).
//! - `observe`: `observe::observe_scan` of the scan from its pose, on a clone of the map
//!   (cloning is not timed), looking at every scan (`min_travel_m = 0`; the mapper looks only
//!   after 0.25 m or 15°, on Intel about one scan in 8).
//! - `mapper_push`: a whole `Mapper::push`, on a clone of the mapper (cloning is not timed).
//!
//! Run: `cargo bench -p polymap --bench stages` (all), `... -- icp` (one group),
//! `... -- --quick` (a quick pass). Each group takes well under 30 s. Criterion's options need
//! the benches named (`cargo bench -p polymap --bench '*' -- --quick`): the library's own
//! libtest harness also runs under `cargo bench -p polymap` and rejects them.
//! `POLYMAP_BENCH_WARM_SCANS=5000 cargo bench ...` times the stages on a later, larger map
//! instead (a source with too few scans is skipped with a message).

mod support;

use std::hint::black_box;
use std::time::Duration;

use criterion::{BatchSize, BenchmarkGroup, Criterion, Throughput, measurement::WallTime};
use polymap::align::{SegmentLookup, align_points, thin_points};
use polymap::config::Config;
use polymap::directions::main_directions;
use polymap::extract::extract_segments;
use polymap::map::GlobalMap;
use polymap::merge::{insert_vertices, merge_scan, restrictive_pairing, simplify};
use polymap::observe::{ObserveParams, observe_scan};
use support::{STEPS, Step, sources, steps, warm_scans};

/// One source's stage inputs.
struct Source {
    name: &'static str,
    warm: usize,
    steps: Vec<Step>,
}

fn inputs() -> Vec<Source> {
    let warm = warm_scans();
    sources(warm + STEPS)
        .into_iter()
        .filter_map(|(name, scans)| match steps(&scans, warm) {
            Some(steps) => Some(Source { name, warm, steps }),
            None => {
                eprintln!("SKIPPED: {name} has fewer than {} scans", warm + STEPS);
                None
            }
        })
        .collect()
}

fn group<'a>(c: &'a mut Criterion, name: &str) -> BenchmarkGroup<'a, WallTime> {
    let mut g = c.benchmark_group(name);
    g.warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .throughput(Throughput::Elements(STEPS as u64));
    g
}

fn bench_extract(c: &mut Criterion, sources: &[Source]) {
    let config = Config::default();
    let mut g = group(c, "extract");
    for s in sources {
        g.bench_function(format!("points_in_robot/{}", s.name), |b| {
            let mut points = Vec::new();
            b.iter(|| {
                for step in &s.steps {
                    step.scan.points_in_robot(&mut points);
                    black_box(&points);
                }
            })
        });
        g.bench_function(format!("extract_segments/{}", s.name), |b| {
            b.iter(|| {
                for step in &s.steps {
                    let inc = step.scan.angle_increment_rad;
                    black_box(extract_segments(&step.points, inc, &config.extract));
                }
            })
        });
    }
    g.finish();
}

fn bench_icp(c: &mut Criterion, sources: &[Source]) {
    let params = Config::default().align;
    let mut g = group(c, "icp");
    g.sample_size(50);
    for s in sources {
        g.bench_function(format!("thin_points/{}", s.name), |b| {
            b.iter(|| {
                for step in &s.steps {
                    black_box(thin_points(&step.points, params.point_spacing_m));
                }
            })
        });
        g.bench_function(format!("align_points/{}", s.name), |b| {
            b.iter(|| {
                for st in &s.steps {
                    let map = st.mapper.map();
                    black_box(align_points(&st.thinned, map, st.guess, st.anchor, &params));
                }
            })
        });
        g.bench_function(format!("nearest_global_map/{}", s.name), |b| {
            b.iter(|| {
                for st in &s.steps {
                    for p in &st.thinned {
                        let q = st.pose.transform_point(*p);
                        black_box(st.mapper.map().nearest_segment(q, params.initial_gate_m));
                    }
                }
            })
        });
    }
    g.finish();
}

fn bench_directions(c: &mut Criterion, sources: &[Source]) {
    let params = Config::default().directions;
    let mut g = group(c, "directions");
    for s in sources {
        g.bench_function(format!("main_directions/{}", s.name), |b| {
            b.iter(|| {
                for st in &s.steps {
                    black_box(main_directions(st.recent.iter(), &params));
                }
            })
        });
    }
    g.finish();
}

fn bench_merge(c: &mut Criterion, sources: &[Source]) {
    let p = Config::default().merge;
    let mut g = group(c, "merge");
    for s in sources {
        g.bench_function(format!("insert_vertices/{}", s.name), |b| {
            b.iter(|| {
                for st in &s.steps {
                    black_box(insert_vertices(&st.c1, &st.scan_in_map, &p));
                }
            })
        });
        let pieces: Vec<_> = s
            .steps
            .iter()
            .map(|st| {
                let seg = |v: &Vec<polymap::merge::Piece>| -> Vec<_> {
                    v.iter().map(|x| x.segment).collect()
                };
                (seg(&st.pieces.0), seg(&st.pieces.1))
            })
            .collect();
        g.bench_function(format!("restrictive_pairing/{}", s.name), |b| {
            b.iter(|| {
                for (st, (map, scan)) in s.steps.iter().zip(&pieces) {
                    black_box(restrictive_pairing(map, scan, &st.directions_rad, &p));
                }
            })
        });
        g.bench_function(format!("simplify/{}", s.name), |b| {
            b.iter(|| {
                for st in &s.steps {
                    black_box(simplify(&st.a_t, &st.directions_rad, &p));
                }
            })
        });
        g.bench_function(format!("merge_scan/{}", s.name), |b| {
            b.iter_batched(
                || maps_before(s),
                |mut maps| {
                    for (map, st) in maps.iter_mut().zip(&s.steps) {
                        let t = st.mapper.scans();
                        black_box(merge_scan(
                            &p,
                            map,
                            &st.scan_in_map,
                            &st.directions_rad,
                            t,
                            true,
                        ));
                    }
                    maps
                },
                BatchSize::SmallInput,
            )
        });
    }
    g.finish();
}

/// Each step's map before its scan, cloned (the setup of a batch that changes them).
fn maps_before(s: &Source) -> Vec<GlobalMap> {
    s.steps.iter().map(|st| st.mapper.map().clone()).collect()
}

fn bench_observe(c: &mut Criterion, sources: &[Source]) {
    let p = ObserveParams {
        min_travel_m: 0.0,
        ..ObserveParams::default()
    };
    let mut g = group(c, "observe");
    for s in sources {
        g.bench_function(format!("observe_scan/{}", s.name), |b| {
            b.iter_batched(
                || maps_before(s),
                |mut maps| {
                    for (map, st) in maps.iter_mut().zip(&s.steps) {
                        let t = st.mapper.scans();
                        black_box(observe_scan(map, &st.points, &st.pose, t, true, &p));
                    }
                    maps
                },
                BatchSize::SmallInput,
            )
        });
    }
    g.finish();
}

fn bench_push(c: &mut Criterion, sources: &[Source]) {
    let mut g = group(c, "mapper_push");
    g.sample_size(30);
    for s in sources {
        g.bench_function(format!("push/{}", s.name), |b| {
            b.iter_batched(
                || {
                    s.steps
                        .iter()
                        .map(|st| st.mapper.clone())
                        .collect::<Vec<_>>()
                },
                |mut mappers| {
                    for (m, st) in mappers.iter_mut().zip(&s.steps) {
                        black_box(m.push(&st.scan));
                    }
                    mappers
                },
                BatchSize::SmallInput,
            )
        });
    }
    g.finish();
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    let sources = inputs();
    describe(&sources);
    bench_extract(&mut c, &sources);
    bench_icp(&mut c, &sources);
    bench_directions(&mut c, &sources);
    bench_merge(&mut c, &sources);
    bench_observe(&mut c, &sources);
    bench_push(&mut c, &sources);
    c.final_summary();
}

/// One line per source: the sizes the stages work on, averaged over the timed scans.
fn describe(sources: &[Source]) {
    for s in sources {
        let n = s.steps.len() as f64;
        let avg = |f: &dyn Fn(&Step) -> usize| s.steps.iter().map(f).sum::<usize>() as f64 / n;
        eprintln!(
            "{}: scans {}..{}, map {:.0} segments, per scan: {:.0} points ({:.0} thinned), \
             {:.0} scan segments, {:.0} near map segments, {:.0} A_t segments, {:.0} recent",
            s.name,
            s.warm,
            s.warm + STEPS,
            avg(&|st| st.mapper.map().len()),
            avg(&|st| st.points.len()),
            avg(&|st| st.thinned.len()),
            avg(&|st| st.scan_in_map.len()),
            avg(&|st| st.c1.len()),
            avg(&|st| st.a_t.len()),
            avg(&|st| st.recent.len()),
        );
    }
}
