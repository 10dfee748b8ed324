//! `polymap map`: a log in, the run folder out. The work is in `polymap-pipeline`; this file
//! opens the log, checks the folder, shows progress and says what happened.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use polymap::config::Config;
use polymap::mapper::{MapRole, Mapper};
use polymap::scan::Stamp;
use polymap::tracking::{MotionPrior, Verdict};
use polymap_export::formats::Format;
use polymap_export::report::MapConsistency;
use polymap_export::report::ReportData;
use polymap_io::carmen::CarmenStats;
use polymap_io::log::{LogKind, LogOptions, LogSource, LogStats};
use polymap_io::map_json::{FRAME_FIRST_SCAN, FRAME_ODOMETRY};
use polymap_io::snapshot::{MapSnapshot, Polyline, ScanPoints};
use polymap_io::tum::StampedPose;
use polymap_pipeline::folder::{
    DIAGNOSTICS_FILE, RunFiles, RunFolder, check_output_apart, percentiles_ms, summary_json,
};
use polymap_pipeline::pipeline::{self, PipelineOptions, RunRecord, ScanEvent};
use serde_json::json;
use std::time::Instant;

use crate::args::{LocalizeArgs, MapArgs};
use crate::config_file::{effective_config, to_toml};
use crate::outputs::DiagnosticsWriter;
use crate::quote::quoted;
pub use crate::saved_map::SavedMap;
use crate::sim_cmd::simulate_to;

/// At most this many scan points are drawn in the pictures.
const MAX_PICTURE_POINTS: usize = 200_000;

/// A source of scans that arrive as they are taken (the ROS 2 node), with what it does beside
/// the mapping: act on each scan as it is mapped, and say what it measured at the end.
pub trait Live {
    /// The scans, once.
    fn take_source(&mut self) -> Result<LogSource>;
    /// Ends the source (its queued scans are still mapped) once `stop` is set.
    fn stop_on(&mut self, stop: Arc<AtomicBool>);
    /// After each scan is mapped.
    fn on_scan(&mut self, event: &ScanEvent<'_>);
    /// Asked after each scan: true when the run folder should be written now (a periodic save,
    /// so that a crash loses at most the scans since).
    fn save_due(&mut self) -> bool;
    /// After the last scan: what the run's summary.json says of the live run (`live`).
    fn finish(&mut self, mapper: &Mapper) -> serde_json::Value;
}

/// `polymap map`, new or (with `--resume`) continuing a saved map.
pub fn run(a: &MapArgs) -> Result<()> {
    let saved = match &a.resume {
        Some(dir) => Some(SavedMap::read(dir, MapRole::Build)?),
        None => None,
    };
    run_with(a, saved, None)
}

/// `polymap localize`: a log placed in a saved map that stays as it is.
pub fn localize(l: &LocalizeArgs) -> Result<()> {
    anyhow::ensure!(
        l.run.resume.is_none(),
        "localize takes the map with --map DIR; --resume is for `polymap map`"
    );
    anyhow::ensure!(l.run.log.is_some(), "localize needs the LOG to localize");
    anyhow::ensure!(
        !l.run.prune_contradicted,
        "localize leaves the map as it is: --prune-contradicted is for `polymap map` (with or \
         without --resume)"
    );
    let saved = SavedMap::read(&l.map, MapRole::Localize)?;
    run_with(&l.run, Some(saved), None)
}

/// Maps `a.log` (or, with `live`, the live source's scans) into `a.output`, continuing or
/// localizing in `saved`.
pub fn run_with(
    a: &MapArgs,
    saved: Option<SavedMap>,
    mut live: Option<&mut dyn Live>,
) -> Result<()> {
    let config = effective_config(&a.preset, &a.config, a.odometry)?;
    anyhow::ensure!(
        a.initial_pose.is_none() || saved.is_some(),
        "--initial-pose places the log in a saved map: give --resume DIR (or use `polymap localize`)"
    );
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
    if let Some(s) = saved.as_ref().filter(|_| a.initial_pose.is_none()) {
        s.check_searchable(config.tracking.start_search_scans)?;
    }
    // Before any work: an output that is an input, a file named by -o, or a folder that cannot
    // be written, is an error now, not after the whole mapping run.
    let mut inputs: Vec<(&str, &Path)> = Vec::new();
    if let Some(s) = &saved {
        inputs.push((s.role_name(), &s.dir));
    }
    if let Some(log) = a.log.as_deref().filter(|l| l.is_dir()) {
        inputs.push(("log", log));
    }
    check_output_apart(&a.output, &inputs)?;
    let folder = RunFolder::prepare(&a.output)?;
    let stop = crate::interrupt::flag()?;
    let source = match live.as_deref_mut() {
        Some(l) => {
            // A live source ends when told to; the scans it holds are mapped, not dropped.
            l.stop_on(Arc::clone(&stop));
            l.take_source()?
        }
        None => {
            let log = match &a.log {
                Some(p) => p.clone(),
                None => simulated_log(&a.output)?,
            };
            // Any kind of log: CARMEN (plain, compressed, standard input) or a ROS recording.
            let options = LogOptions {
                skip_bad_input: a.skip_bad_lines,
                topic: a.topic.clone(),
                odometry: a.odometry,
                odom_topic: a.odom_topic.clone(),
                base_frame: a.base_frame.clone(),
                // Without --odometry the log's odometry, where a ROS file has it, still
                // witnesses the steps (CARMEN scans carry theirs anyway).
                witness_odometry: true,
                ..LogOptions::default()
            };
            LogSource::open(&log, &options)?
        }
    };
    let log_name = log_name(&source);
    let stop = live.is_none().then_some(stop);
    let (mut record, counts, diag) = map_source(
        source,
        &config,
        a,
        &folder,
        stop,
        saved.as_ref(),
        live.as_deref_mut().map(|l| (l, log_name.as_str())),
    )?;
    check_not_empty(&log_name, &record, counts.as_ref().map(|c| &c.1))?;
    let tf = counts.as_ref().and_then(|c| c.1.tf.clone());
    let stats = counts.map(|c| c.0);
    // Before pruning: the segments pruned are the evidence.
    let warn_above = config.observe.warn_seen_through_above;
    let crossed = record.mapper.crossed_walls();
    let walls = record.mapper.walls_seen_through();
    record.history.map_consistency = record
        .mapper
        .seen_through_share()
        .map(|seen_through_share| MapConsistency {
            seen_through_share,
            warn_above,
            crossed_share: crossed.as_ref().map(|c| c.share),
            warn_crossed_above: config.observe.warn_crossed_above,
            crossed_scans: crossed
                .as_ref()
                .map(|c| c.scans.clone())
                .unwrap_or_default(),
            walls_seen_through_share: walls.as_ref().map(|w| w.share),
            warn_walls_above: config.observe.warn_walls_seen_through_above,
            walls_contradicted: walls.as_ref().map_or(0, |w| w.contradicted),
            seen_through_scans: walls.as_ref().map(|w| w.scans.clone()).unwrap_or_default(),
        });
    record.history.weak_stretches = record
        .mapper
        .tracking_summary()
        .weak_stretches
        .iter()
        .map(|w| [w.first, w.last])
        .collect();
    let pruned = a
        .prune_contradicted
        .then(|| record.mapper.prune_contradicted());
    let snapshot = snapshot(&log_name, &config, &record, a.svg_points, saved.as_ref());
    let mut reader = stats.as_ref().map_or(serde_json::Value::Null, reader_json);
    // What tf gave the scans of a ROS recording that has tf: the robot's frame, the scans
    // placed and not, the odometry.
    if let (Some(tf), Some(object)) = (tf, reader.as_object_mut()) {
        object.insert("tf".into(), serde_json::to_value(tf)?);
    }
    let every = [a.every, a.every_offset];
    let mut summary = summary_json(
        &log_name,
        &config,
        &record,
        every,
        record.valid_returns,
        reader,
    );
    if let Some(l) = live {
        summary["live"] = l.finish(&record.mapper);
    }
    if let Some(c) = &record.history.map_consistency {
        summary["map_consistency"] = json!({
            "seen_through_share": c.seen_through_share,
            "warn_above": c.warn_above,
            "likely_inconsistent": c.likely_inconsistent(),
            "crossed_share": c.crossed_share,
            "crossings": crossed.as_ref().map(|c| c.crossings),
            "crossed_scans": c.crossed_scans,
            "warn_crossed_above": c.warn_crossed_above,
            "walls_drawn_twice": c.walls_drawn_twice(),
            "walls_seen_through_share": c.walls_seen_through_share,
            "walls_contradicted": c.walls_contradicted,
            "seen_through_scans": c.seen_through_scans,
            "warn_walls_above": c.warn_walls_above,
            "walls_seen_through": c.walls_seen_through(),
        });
    }
    if let Some(n) = pruned {
        summary["pruned_segments"] = json!(n);
        if !a.quiet {
            say!("pruned {n} map segments that later scans saw through");
        }
    }
    let loop_nodes = record.mapper.loop_nodes();
    // The write phase starts here, after every check that can fail without changing a file:
    // from now on the folder is not one run's until the manifest says so. A run refused
    // before (a log without scans) leaves the previous run's folder as it was, readable.
    folder.begin_writing()?;
    if let Some(w) = diag {
        w.finish()?;
    }
    let removed = folder
        .remove_stale(&a.export, a.diagnostics)
        .with_context(|| format!("{}: cannot remove old outputs", folder.path().display()))?;
    if !removed.is_empty() {
        eprintln!(
            "polymap: removed {} from an earlier run in {} (not written by this run)",
            removed.join(", "),
            folder.path().display()
        );
    }
    let written = folder.write_run(&RunFiles {
        snapshot: &snapshot,
        loop_nodes: &loop_nodes,
        summary: &summary,
        history: &record.history,
        formats: &a.export,
        rays: record.scan_points.as_ref(),
        resolution_m: a.resolution,
    })?;
    report(a, &record, stats.as_ref());
    if !a.quiet {
        for path in written {
            say!("wrote {}", path.display());
        }
    }
    if record.interrupted {
        eprintln!(
            "polymap: interrupted: saved the {} scans mapped so far in {}",
            record.trajectory.len(),
            folder.path().display()
        );
        return Err(crate::interrupt::Interrupted.into());
    }
    Ok(())
}

fn simulated_log(output: &Path) -> Result<PathBuf> {
    let dir = output.join("sim");
    let files = simulate_to(polymap_sim::DEFAULT_WORLD_NAME, &dir, 1)?;
    eprintln!(
        "polymap: no log given: mapping the built-in simulated world `{}` ({})",
        polymap_sim::DEFAULT_WORLD_NAME,
        files.log.display()
    );
    Ok(files.log)
}

/// The log as `summary.json` names it: its canonical path, `-` for standard input and other
/// streams (which cannot be read again), or a live topic's name.
fn log_name(source: &LogSource) -> String {
    let log = source.path();
    if source.kind() == LogKind::Live {
        return log.display().to_string();
    }
    if !source.is_regular_file() {
        return "-".to_owned();
    }
    std::fs::canonicalize(log)
        .unwrap_or_else(|_| log.to_path_buf())
        .display()
        .to_string()
}

/// The record of a run, the reader's counts (`None` when interrupted) and the diagnostics
/// written so far (to a temporary file, renamed into place in the write phase).
type Mapped = (
    RunRecord,
    Option<(CarmenStats, LogStats)>,
    Option<DiagnosticsWriter>,
);

/// Runs the pipeline with the progress bar and the diagnostics file; changes no file of the
/// folder.
fn map_source(
    source: LogSource,
    config: &Config,
    a: &MapArgs,
    folder: &RunFolder,
    stop: Option<Arc<AtomicBool>>,
    saved: Option<&SavedMap>,
    mut live: Option<(&mut (dyn Live + '_), &str)>,
) -> Result<Mapped> {
    let bar = progress_bar(a.quiet, source.size_bytes());
    let mut diag = match a.diagnostics {
        true => Some(DiagnosticsWriter::create(
            &folder.path().join(DIAGNOSTICS_FILE),
        )?),
        false => None,
    };
    let options = PipelineOptions {
        max_scans: a.max_scans,
        every: a.every,
        every_offset: a.every_offset,
        keep_scan_points: a.svg_points || a.export.contains(&Format::Pgm),
        history_title: quoted(&source.path().display().to_string()),
        stream: !source.is_regular_file(),
        stop,
        mapper: saved.map(|s| s.mapper(config, a.initial_pose)),
        record_tries: a.diagnostics,
    };
    // A run on a saved map is placed by its first confident scan (or by --initial-pose); one
    // that is not after `tracking.start_search_scans` scans stops, rather than map on blind.
    let mut placed = saved.is_none() || a.initial_pose.is_some();
    // A live run's stamps, for its periodic saves.
    let mut stamps: Vec<Stamp> = Vec::new();
    let search_scans = config.tracking.start_search_scans as usize;
    let outcome = pipeline::run(source, config, options, |e: &ScanEvent<'_>| {
        if let Some((l, log)) = live.as_mut() {
            l.on_scan(e);
            stamps.push(e.stamp.clone());
            if l.save_due() {
                // A save that fails (a full disk) is said and mapping goes on: the next save,
                // or the one at the end, may succeed.
                let saved_at = Instant::now();
                match checkpoint(log, config, a, folder, e, &stamps, saved) {
                    Ok(()) if !a.quiet => eprintln!(
                        "polymap: saved the {} scans mapped so far in {} ({:.0} ms)",
                        stamps.len(),
                        folder.path().display(),
                        saved_at.elapsed().as_secs_f64() * 1e3
                    ),
                    Ok(()) => {}
                    Err(err) => eprintln!(
                        "polymap: warning: the periodic save in {} failed: {err:#}",
                        folder.path().display()
                    ),
                }
            }
        }
        if let Some(w) = diag.as_mut() {
            w.write(&e.stamp.text, e.update)?;
        }
        placed |= e.update.diagnostics.tracking.verdict != Verdict::Lost;
        if !placed
            && e.index + 1 >= search_scans
            && let Some(s) = saved
        {
            return Err(format!(
                "the log's start was not found in the map of {}: none of its first {} scans \
                 fits one place of it confidently and alone; give --initial-pose x,y,yaw \
                 (metres, metres, radians) if you know where it starts",
                quoted(&s.dir.display().to_string()),
                e.index + 1
            )
            .into());
        }
        let mapped = e.index as u64 + 1;
        if mapped.is_multiple_of(64) {
            if bar.length().is_some() {
                bar.set_position(e.bytes_read);
            }
            bar.set_message(format!(
                "{mapped} scans mapped, {} segments",
                e.update.diagnostics.map_segments
            ));
        }
        Ok(())
    })?;
    bar.finish_and_clear();
    let counts = outcome.source.map(|s| (s.carmen_stats(), s.stats()));
    Ok((outcome.record, counts, diag))
}

/// The final map, trajectory and (with `--svg-points`) points for the pictures.
fn snapshot(
    log: &str,
    config: &Config,
    run: &RunRecord,
    points: bool,
    saved: Option<&SavedMap>,
) -> MapSnapshot {
    let points = run.scan_points.as_ref().filter(|_| points);
    snapshot_of(
        log,
        config,
        &run.mapper,
        run.trajectory.clone(),
        points,
        saved,
    )
}

/// The map, trajectory and (given `scan_points`) points for the pictures, from the mapper.
fn snapshot_of(
    log: &str,
    config: &Config,
    mapper: &Mapper,
    trajectory: Vec<StampedPose>,
    scan_points: Option<&ScanPoints>,
    saved: Option<&SavedMap>,
) -> MapSnapshot {
    // A saved map keeps its frame.
    let frame = match saved {
        Some(s) => s.map.frame.as_str(),
        None if config.mapper.motion_prior == MotionPrior::Odometry => FRAME_ODOMETRY,
        None => FRAME_FIRST_SCAN,
    };
    let what = match saved.map(|s| s.role) {
        Some(MapRole::Localize) => " localized in a saved map",
        Some(MapRole::Build) => " continuing a saved map",
        None => "",
    };
    let segments = mapper.segments();
    let observations = mapper.observations();
    let polylines: Vec<Polyline> = mapper
        .polylines()
        .into_iter()
        .map(|segments| Polyline { segments })
        .collect();
    let poses: Vec<_> = trajectory.iter().map(|p| p.map_from_robot).collect();
    let points = match scan_points {
        Some(scans) => scans.in_map(&poses, MAX_PICTURE_POINTS),
        None => Vec::new(),
    };
    MapSnapshot {
        frame: frame.to_owned(),
        title: format!(
            "{} — {} scans{what}, {} segments, {} polylines",
            quoted(log),
            trajectory.len(),
            segments.len(),
            polylines.len()
        ),
        segments,
        observations,
        polylines,
        trajectory,
        points,
        scans_before: mapper.first_scan(),
    }
}

/// Writes the run folder in the middle of a live run: the map, the trajectory (with the loop
/// corrections so far), the loop nodes, map.svg, and a summary.json marked `checkpoint` with
/// the figures known mid-run. The end of the run writes the whole folder again.
fn checkpoint(
    log: &str,
    config: &Config,
    a: &MapArgs,
    folder: &RunFolder,
    e: &ScanEvent<'_>,
    stamps: &[Stamp],
    saved: Option<&SavedMap>,
) -> Result<()> {
    let mapper = e.mapper;
    let trajectory = stamps
        .iter()
        .zip(mapper.trajectory())
        .map(|(stamp, p)| StampedPose {
            stamp: stamp.clone(),
            map_from_robot: *p,
        })
        .collect();
    let snapshot = snapshot_of(log, config, mapper, trajectory, None, saved);
    let summary = json!({
        "log": log,
        "checkpoint": true,
        "scans": stamps.len(),
        "segments": snapshot.segments.len(),
        "polylines": snapshot.polylines.len(),
        "loop_closures": mapper.loop_closures(),
        "tracking": mapper.tracking_summary(),
        "map_role": mapper.role(),
        "placed": mapper.placed(),
        "scans_before": mapper.first_scan(),
        "config": serde_json::to_value(config).unwrap_or(serde_json::Value::Null),
    });
    folder.write_run(&RunFiles {
        snapshot: &snapshot,
        loop_nodes: &mapper.loop_nodes(),
        summary: &summary,
        history: &ReportData::default(),
        formats: &[],
        rays: None,
        resolution_m: a.resolution,
    })?;
    Ok(())
}

fn reader_json(s: &CarmenStats) -> serde_json::Value {
    json!({
        "lines": s.lines,
        "no_return_readings": s.no_return_readings,
        "odometry_messages": s.odometry_messages,
        "skipped_types": s.skipped_types,
        "bad_lines_skipped": s.bad_lines,
        "odometry_dropped_for_jumps": s.odometry_jumps.count,
        "odometry_interpolated_stale": s.stale_odometry.count,
        "odometry_stale_kept": s.stale_odometry_kept.count,
        "other_warnings": s.other_warnings,
    })
}

/// A log without a single scan is the wrong file or format, not an empty map (what a scan is
/// and what was read are named in the log's own terms: lines of a CARMEN log, messages of a ROS
/// recording, with the bad ones skipped); a log whose scans hold no valid return maps to
/// nothing, which deserves a warning.
fn check_not_empty(log: &str, run: &RunRecord, stats: Option<&LogStats>) -> Result<()> {
    if run.trajectory.is_empty() && !run.interrupted {
        let s = stats.cloned().unwrap_or_default();
        let others: Vec<String> = s
            .skipped
            .iter()
            .map(|(t, n)| format!("{n} {}", quoted(t)))
            .collect();
        let mut seen = String::new();
        if !others.is_empty() {
            seen = format!(" (other {}: {})", s.record_unit, others.join(", "));
        }
        if s.bad_records > 0 {
            seen.push_str(&format!(
                "; {} bad {} skipped, first: {}",
                s.bad_records,
                s.record_unit,
                quoted(s.bad_record_errors.first().map_or("", String::as_str))
            ));
        }
        anyhow::bail!(
            "{}: no laser scans ({}) in {} {}{seen}",
            quoted(log),
            s.scan_source,
            s.records,
            s.record_unit
        );
    }
    if run.valid_returns == 0 && !run.trajectory.is_empty() {
        eprintln!(
            "polymap: warning: {}: none of the {} scans has a valid return",
            quoted(log),
            run.trajectory.len(),
        );
    }
    Ok(())
}

/// A bar over the log's bytes (of the scans mapped, not read ahead) for a file; a spinner
/// counting scans mapped for a stream. Hidden with `--quiet` or when standard error is not a
/// terminal.
fn progress_bar(quiet: bool, size: Option<u64>) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    match size {
        Some(size) if size > 0 => {
            let bar = ProgressBar::new(size);
            bar.set_style(
                ProgressStyle::with_template("{bar:40} {percent:>3}% {elapsed}<{eta} {msg}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            bar
        }
        _ => {
            let bar = ProgressBar::new_spinner();
            bar.set_style(
                ProgressStyle::with_template("{spinner} {elapsed} {msg}")
                    .unwrap_or_else(|_| ProgressStyle::default_spinner()),
            );
            bar
        }
    }
}

/// The warnings, then (unless quiet) the summary line.
fn report(a: &MapArgs, run: &RunRecord, stats: Option<&CarmenStats>) {
    if let Some(s) = stats.filter(|s| s.bad_lines > 0) {
        eprintln!(
            "polymap: warning: skipped {} malformed line(s); first: {}",
            s.bad_lines,
            s.bad_line_messages.first().map_or("", String::as_str)
        );
    }
    if let Some(s) = stats {
        crate::warnings::report_reader_warnings(s);
    }
    crate::warnings::warn_tracking(
        run.mapper.tracking_summary(),
        run.trajectory.len(),
        run.mapper.config().tracking.odometry.odometry_witness_m,
        run.mapper.config().mapper.motion_prior == polymap::tracking::MotionPrior::Odometry,
    );
    crate::warnings::warn_odometry(run.mapper.tracking_summary(), a.odometry);
    crate::warnings::warn_consistency(run.history.map_consistency.as_ref());
    if a.quiet {
        return;
    }
    let t = &run.timings;
    let elapsed = t.elapsed.as_secs_f64();
    let scans = run.trajectory.len();
    say!(
        "{} scans, {} points -> {} segments in {} polylines; {:.2} s ({:.0} scans/s); wrote {}",
        scans,
        run.valid_returns,
        run.mapper.segments().len(),
        run.mapper.polylines().len(),
        elapsed,
        scans as f64 / elapsed.max(1e-9),
        a.output.display()
    );
    if a.timings {
        let [p50, p99, max] = percentiles_ms(&t.latencies);
        let st = &t.stages;
        say!(
            "reading thread: read {:.3} s, extract {:.3} s",
            t.read.as_secs_f64(),
            st.extract
        );
        say!(
            "mapping thread: map {:.3} s (align {:.3} s, directions {:.3} s, merge {:.3} s), \
             waiting for scans {:.3} s, other {:.3} s",
            t.map.as_secs_f64(),
            st.align,
            st.directions,
            st.merge,
            t.wait.as_secs_f64(),
            t.elapsed.saturating_sub(t.map + t.wait).as_secs_f64()
        );
        say!("per-scan latency (extract + map): p50 {p50:.3} ms, p99 {p99:.3} ms, max {max:.3} ms");
    }
}
