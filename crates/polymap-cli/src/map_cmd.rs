//! `polymap map`: a log in, the contract files out.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use polymap::config::Config;
use polymap::geometry::Vec2;
use polymap::mapper::{
    Mapper, MotionPrior, PreparedScan, ScanDiagnostics, StageSeconds, TrackingSummary, Update,
};
use polymap::scan::RangeScan;
use polymap_io::carmen::{CarmenReader, CarmenStats, ReaderOptions};
use polymap_io::map_json::{FRAME_FIRST_SCAN, FRAME_ODOMETRY};
use polymap_io::tum::StampedPose;
use serde_json::json;

use crate::args::MapArgs;
use crate::config_file::{effective_config, to_toml};
use crate::exports::{ExportInput, export};
use crate::outputs::{DiagnosticsWriter, RunOutputs, write_outputs};
use crate::sim_cmd::simulate_to;
use polymap_export::report::{ReportBudget, ReportRecorder, SnapshotContent};

/// At most this many scan points are kept for the picture.
const MAX_SVG_POINTS: usize = 200_000;

pub fn run(a: &MapArgs) -> Result<()> {
    let config = effective_config(&a.preset, &a.config, a.odometry)?;
    anyhow::ensure!(
        a.every_offset < a.every,
        "--every-offset {} must be below --every {}",
        a.every_offset,
        a.every
    );
    if a.print_config {
        say_raw!("{}", to_toml(&config)?);
        return Ok(());
    }
    std::fs::create_dir_all(&a.output)
        .with_context(|| format!("{}: cannot create", a.output.display()))?;
    let log = match &a.log {
        Some(p) => p.clone(),
        None => {
            let dir = a.output.join("sim");
            let files = simulate_to(polymap_sim::DEFAULT_WORLD_NAME, &dir, 1)?;
            eprintln!(
                "polymap: no log given: mapping the built-in simulated world `{}` ({})",
                polymap_sim::DEFAULT_WORLD_NAME,
                files.log.display()
            );
            files.log
        }
    };
    let mut run = map_log(&log, &config, a)?;
    check_not_empty(&log, &run)?;
    let frame = if config.mapper.motion_prior == MotionPrior::Odometry {
        FRAME_ODOMETRY
    } else {
        FRAME_FIRST_SCAN
    };
    let segments = run.mapper.segments();
    let polylines = run.mapper.polylines();
    let every = (a.every, a.every_offset);
    let summary = summary(&log, &config, &run, every, segments.len(), polylines.len())?;
    let final_content = SnapshotContent::of_map(
        &segments,
        run.mapper.scans(),
        &run.mapper.config().directions,
    );
    let recorder = std::mem::replace(
        &mut run.history,
        ReportRecorder::new("", ReportBudget::default()),
    );
    let history = recorder.finish(segments.clone(), polylines.clone(), final_content);
    let history_path = a.output.join("history.json");
    crate::outputs::write_file(&history_path, serde_json::to_string(&history)?.as_bytes())?;
    let title = format!(
        "{} — {} scans, {} segments, {} polylines",
        log.display(),
        run.poses.len(),
        segments.len(),
        polylines.len()
    );
    write_outputs(
        &a.output,
        &RunOutputs {
            frame,
            title: &title,
            segments: &segments,
            polylines: &polylines,
            trajectory: &run.poses,
            scan_points: &run.points,
            summary: &summary,
        },
    )?;
    report(a, &run, segments.len(), polylines.len());
    let input = ExportInput {
        dir: &a.output,
        segments: &segments,
        polylines: &polylines,
        trajectory: &run.poses,
        scan_points: &run.points,
        log: Some(&log),
        skip_bad_lines: a.skip_bad_lines,
        history: Some(&history),
        resolution_m: a.resolution,
    };
    for path in export(&a.export, &input)? {
        say!("wrote {}", path.display());
    }
    Ok(())
}

/// The state of a finished mapping run.
struct Run {
    mapper: Mapper,
    poses: Vec<StampedPose>,
    /// Scan points drawn in the SVG (`--svg-points`): robot frame until [`Run::finish`] puts
    /// them into the map frame with the final poses.
    points: Vec<Vec2>,
    /// For each scan recorded, where its points end in `points`.
    points_end: Vec<usize>,
    stats: CarmenStats,
    latencies: Vec<Duration>,
    /// Reading and parsing, on the reading thread.
    read_time: Duration,
    /// `Mapper::push_prepared`, on the mapping thread.
    map_time: Duration,
    /// The mapping thread waiting for scans.
    wait_time: Duration,
    elapsed: Duration,
    last: ScanDiagnostics,
    icp_failures: u64,
    stages: StageSeconds,
    history: ReportRecorder,
    /// A reused buffer for one scan's points.
    scan_points: Vec<Vec2>,
}

fn map_log(log: &Path, config: &Config, a: &MapArgs) -> Result<Run> {
    let start = Instant::now();
    let (reader, size, bytes_read) = open_log(log, a.skip_bad_lines)?;
    let bar = progress_bar(a.quiet, size);
    let mut run = Run::new(Mapper::new(config.clone()), log);
    let mut diag = match a.diagnostics {
        true => Some(DiagnosticsWriter::create(
            &a.output.join("diagnostics.jsonl"),
        )?),
        false => None,
    };
    // Reading and extraction run ahead on a second thread; the mapping, which carries state
    // from scan to scan, stays on this one, in log order: the result is the same as one
    // thread's. A regular file is handed over in batches; a pipe or FIFO scan by scan, so a
    // live stream is mapped as it arrives.
    let batch = if size > 0 && std::fs::metadata(log).is_ok_and(|m| m.is_file()) {
        READ_AHEAD_SCANS
    } else {
        1
    };
    let (tx, rx) = std::sync::mpsc::sync_channel(READ_AHEAD_BATCHES);
    let reading = {
        let config = config.clone();
        let pick = Pick {
            max_scans: a.max_scans,
            every: a.every,
            offset: a.every_offset,
        };
        std::thread::Builder::new()
            .name("polymap-read".into())
            .spawn(move || read_ahead(reader, &config, pick, batch, tx))
            .with_context(|| format!("{}: cannot start the reading thread", log.display()))?
    };
    // On an error this returns at once, dropping `rx`: the reading thread ends at its next
    // hand-over and is not waited for (it may be blocked reading a stream).
    let mut waited = Instant::now();
    for batch in rx {
        run.wait_time += waited.elapsed();
        for ready in batch? {
            let t1 = Instant::now();
            run.read_time += ready.read;
            let update = run.mapper.push_prepared(ready.prepared);
            let map_time = t1.elapsed();
            if let Some(w) = diag.as_mut() {
                w.write(&ready.scan.stamp.text, &update)?;
            }
            run.record(ready.scan, update, map_time, a.svg_points);
            if run.poses.len() % 64 == 0 {
                bar.set_position(bytes_read.load(Ordering::Relaxed));
                bar.set_message(format!(
                    "{} scans, {} segments",
                    run.poses.len(),
                    run.last.map_segments
                ));
            }
        }
        waited = Instant::now();
    }
    run.stats = reading
        .join()
        .map_err(|_| anyhow::anyhow!("{}: the reading thread failed", log.display()))?;
    bar.finish_and_clear();
    if let Some(w) = diag {
        w.finish()?;
    }
    run.finish();
    run.elapsed = start.elapsed();
    Ok(run)
}

/// Scans are handed from the reading thread to the mapping thread in batches of this many
/// (from a regular file)...
const READ_AHEAD_SCANS: usize = 32;
/// ...with at most this many batches in flight, which bounds the memory read ahead.
const READ_AHEAD_BATCHES: usize = 8;

/// A scan read and prepared ahead of the mapper.
struct Ready {
    scan: RangeScan,
    prepared: PreparedScan,
    /// Time spent reading and parsing it.
    read: Duration,
}

/// Which scans of the log are mapped: every `every`-th from `offset`, at most `max_scans`.
#[derive(Debug, Clone, Copy)]
struct Pick {
    max_scans: Option<u64>,
    every: u64,
    offset: u64,
}

/// Reads the picked scans and prepares them for the mapper, sending them in batches of
/// `batch_scans`; a read error is sent after the scans before it. Stops early when the
/// receiver has gone.
fn read_ahead(
    mut reader: LogReader,
    config: &Config,
    pick: Pick,
    batch_scans: usize,
    tx: std::sync::mpsc::SyncSender<Result<Vec<Ready>>>,
) -> CarmenStats {
    let mut batch = Vec::with_capacity(batch_scans);
    let mut count = 0u64;
    let mut index = 0u64;
    while pick.max_scans.is_none_or(|m| count < m) {
        let t0 = Instant::now();
        let scan = match reader.next_scan() {
            Ok(Some(scan)) => scan,
            Ok(None) => break,
            Err(e) => {
                let _ = tx.send(Ok(std::mem::take(&mut batch)));
                let _ = tx.send(Err(e.into()));
                return reader.stats().clone();
            }
        };
        index += 1;
        if (index - 1) % pick.every != pick.offset {
            continue;
        }
        let read = t0.elapsed();
        let prepared = Mapper::prepare(config, &scan);
        batch.push(Ready {
            scan,
            prepared,
            read,
        });
        count += 1;
        if batch.len() >= batch_scans
            && tx
                .send(Ok(std::mem::replace(
                    &mut batch,
                    Vec::with_capacity(batch_scans),
                )))
                .is_err()
        {
            return reader.stats().clone();
        }
    }
    if !batch.is_empty() {
        let _ = tx.send(Ok(batch));
    }
    reader.stats().clone()
}

/// A log without a single scan is the wrong file or format, not an empty map; a log whose
/// scans hold no valid return maps to nothing, which deserves a warning.
fn check_not_empty(log: &Path, run: &Run) -> Result<()> {
    let s = &run.stats;
    if run.poses.is_empty() {
        let others: Vec<String> = s
            .skipped_types
            .iter()
            .map(|(t, n)| format!("{n} {t}"))
            .collect();
        let seen = if others.is_empty() {
            String::new()
        } else {
            format!(" (other lines: {})", others.join(", "))
        };
        anyhow::bail!(
            "{}: no laser scans (FLASER or ROBOTLASER1 lines) in {} lines{seen}",
            log.display(),
            s.lines
        );
    }
    if s.valid_readings == 0 {
        eprintln!(
            "polymap: warning: {}: none of the {} scans has a valid return ({} no-return readings)",
            log.display(),
            run.poses.len(),
            s.no_return_readings
        );
    }
    Ok(())
}

/// A reader over the log that counts the bytes it has read (for the progress bar), and the
/// log's size in bytes.
type LogReader = CarmenReader<std::io::BufReader<CountingReader<std::fs::File>>>;

fn open_log(log: &Path, skip_bad_lines: bool) -> Result<(LogReader, u64, Arc<AtomicU64>)> {
    let file =
        std::fs::File::open(log).with_context(|| format!("{}: cannot open", log.display()))?;
    let size = file.metadata().map(|m| m.len()).unwrap_or(0);
    let bytes_read = Arc::new(AtomicU64::new(0));
    let input = std::io::BufReader::with_capacity(
        1 << 16,
        CountingReader {
            inner: file,
            count: Arc::clone(&bytes_read),
        },
    );
    let options = ReaderOptions {
        skip_bad_lines,
        ..ReaderOptions::default()
    };
    Ok((
        CarmenReader::from_reader(input, log, options),
        size,
        bytes_read,
    ))
}

impl Run {
    fn new(mapper: Mapper, log: &Path) -> Self {
        Run {
            mapper,
            poses: Vec::new(),
            points: Vec::new(),
            points_end: Vec::new(),
            stats: CarmenStats::default(),
            latencies: Vec::new(),
            read_time: Duration::ZERO,
            map_time: Duration::ZERO,
            wait_time: Duration::ZERO,
            elapsed: Duration::ZERO,
            last: ScanDiagnostics::default(),
            icp_failures: 0,
            stages: StageSeconds::default(),
            history: ReportRecorder::new(log.display().to_string(), ReportBudget::default()),
            scan_points: Vec::new(),
        }
    }

    /// Keeps what the outputs need of one mapped scan; `map_time` is how long the push took.
    /// The scan's latency is its extraction (on the reading thread) plus its push.
    fn record(&mut self, scan: RangeScan, update: Update, map_time: Duration, svg_points: bool) {
        self.map_time += map_time;
        self.latencies
            .push(map_time + Duration::from_secs_f64(update.diagnostics.stage_s.extract));
        self.icp_failures += u64::from(update.diagnostics.align.is_some_and(|r| !r.converged));
        self.stages += update.diagnostics.stage_s;
        if svg_points && self.points.len() < MAX_SVG_POINTS {
            scan.points_in_robot(&mut self.scan_points);
            self.points.extend_from_slice(&self.scan_points);
        }
        self.points_end.push(self.points.len());
        let mapper = &self.mapper;
        self.history.record_update(&update, || {
            SnapshotContent::of_map(
                &mapper.segments(),
                mapper.scans(),
                &mapper.config().directions,
            )
        });
        self.poses.push(StampedPose {
            stamp: scan.stamp,
            map_from_robot: update.map_from_robot,
        });
        self.last = update.diagnostics;
    }

    /// Puts the final poses (with loop closure's corrections, which may have moved poses after
    /// they were recorded) into the trajectory, and the SVG's points into the map frame.
    fn finish(&mut self) {
        let clock = Instant::now();
        let loops = self.mapper.finish();
        self.map_time += clock.elapsed();
        self.stages.loops += clock.elapsed().as_secs_f64();
        self.last.loops = loops;
        for (p, q) in self.poses.iter_mut().zip(self.mapper.trajectory()) {
            p.map_from_robot = *q;
        }
        let mut begin = 0;
        for (end, p) in self.points_end.iter().zip(&self.poses) {
            for q in &mut self.points[begin..*end] {
                *q = p.map_from_robot.transform_point(*q);
            }
            begin = *end;
        }
    }
}

/// Counts the bytes read through it, for the progress bar.
struct CountingReader<R> {
    inner: R,
    count: Arc<AtomicU64>,
}

impl<R: Read> Read for CountingReader<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.count.fetch_add(n as u64, Ordering::Relaxed);
        Ok(n)
    }
}

/// A bar over the log's bytes with scans, segments and time left; hidden with `--quiet` or
/// when standard error is not a terminal.
fn progress_bar(quiet: bool, size: u64) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(size);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {percent:>3}% {elapsed}<{eta} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}

/// Latency percentiles in milliseconds: p50, p99, max.
fn percentiles_ms(latencies: &[Duration]) -> [f64; 3] {
    let mut ms: Vec<f64> = latencies.iter().map(|d| d.as_secs_f64() * 1e3).collect();
    ms.sort_by(f64::total_cmp);
    let at = |q: f64| {
        ms.get(((ms.len() as f64 - 1.0) * q).round() as usize)
            .copied()
            .unwrap_or(0.0)
    };
    [at(0.5), at(0.99), ms.last().copied().unwrap_or(0.0)]
}

fn summary(
    log: &Path,
    config: &Config,
    run: &Run,
    a_every: (u64, u64),
    segments: usize,
    polylines: usize,
) -> Result<serde_json::Value> {
    let scans = run.poses.len();
    let elapsed_s = run.elapsed.as_secs_f64();
    let [p50, p99, max] = percentiles_ms(&run.latencies);
    Ok(json!({
        "log": std::fs::canonicalize(log).unwrap_or_else(|_| log.to_path_buf()).display().to_string(),
        "scans": scans,
        "points": run.stats.valid_readings,
        "segments": segments,
        "polylines": polylines,
        "elapsed_s": elapsed_s,
        "scans_per_s": if elapsed_s > 0.0 { scans as f64 / elapsed_s } else { 0.0 },
        "read_s": run.read_time.as_secs_f64(),
        "map_s": run.map_time.as_secs_f64(),
        "wait_s": run.wait_time.as_secs_f64(),
        "latency_ms": { "p50": p50, "p99": p99, "max": max },
        "icp_not_converged": run.icp_failures,
        "loop_closures": run.mapper.loop_closures(),
        "every": { "k": a_every.0, "offset": a_every.1 },
        "tracking": run.mapper.tracking_summary(),
        "stage_s": run.stages,
        "final_main_directions_deg": run.last.main_directions_deg,
        "reader": {
            "lines": run.stats.lines,
            "no_return_readings": run.stats.no_return_readings,
            "odometry_messages": run.stats.odometry_messages,
            "skipped_types": run.stats.skipped_types,
            "bad_lines_skipped": run.stats.bad_lines,
        },
        "config": serde_json::to_value(config)?,
    }))
}

/// Says when tracking failed: the scans lost (not in the map), or a large share of weak ones.
fn warn_tracking(t: &TrackingSummary, scans: usize) {
    if t.lost > 0 {
        let ranges: Vec<String> = t
            .lost_ranges
            .iter()
            .take(10)
            .map(|[a, b]| {
                if a == b {
                    format!("{a}")
                } else {
                    format!("{a}-{b}")
                }
            })
            .collect();
        let more = if t.lost_ranges.len() > 10 {
            ", ..."
        } else {
            ""
        };
        eprintln!(
            "polymap: warning: tracking lost {} of {scans} scans (scans {}{more}): they are not \
             in the map and their poses are unreliable (summary.json: tracking)",
            t.lost,
            ranges.join(", ")
        );
    }
    if t.weak as f64 > 0.1 * scans as f64 {
        eprintln!(
            "polymap: warning: tracking was weak on {} of {scans} scans (a direction came from \
             the motion prior, the fit was poor or ambiguous): check the map",
            t.weak
        );
    }
}

fn report(a: &MapArgs, run: &Run, segments: usize, polylines: usize) {
    let s = &run.stats;
    if s.bad_lines > 0 {
        eprintln!(
            "polymap: warning: skipped {} malformed line(s); first: {}",
            s.bad_lines,
            s.bad_line_messages.first().map_or("", String::as_str)
        );
    }
    let elapsed = run.elapsed.as_secs_f64();
    say!(
        "{} scans, {} points -> {} segments in {} polylines; {:.2} s ({:.0} scans/s); wrote {}",
        run.poses.len(),
        s.valid_readings,
        segments,
        polylines,
        elapsed,
        run.poses.len() as f64 / elapsed.max(1e-9),
        PathBuf::from(&a.output).display()
    );
    warn_tracking(run.mapper.tracking_summary(), run.poses.len());
    if a.timings {
        let [p50, p99, max] = percentiles_ms(&run.latencies);
        let st = &run.stages;
        say!(
            "reading thread: read {:.3} s, extract {:.3} s",
            run.read_time.as_secs_f64(),
            st.extract
        );
        say!(
            "mapping thread: map {:.3} s (align {:.3} s, directions {:.3} s, merge {:.3} s), \
             waiting for scans {:.3} s, other {:.3} s",
            run.map_time.as_secs_f64(),
            st.align,
            st.directions,
            st.merge,
            run.wait_time.as_secs_f64(),
            run.elapsed
                .saturating_sub(run.map_time + run.wait_time)
                .as_secs_f64()
        );
        say!("per-scan latency (extract + map): p50 {p50:.3} ms, p99 {p99:.3} ms, max {max:.3} ms");
    }
}
