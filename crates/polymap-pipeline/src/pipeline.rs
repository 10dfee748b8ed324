//! A mapping run over any scan source: read → prepare → push → record.
//!
//! Reading and preparation (ranges to points, once; points to segments) run ahead on a second
//! thread; the mapping, which carries state from scan to scan, stays on the calling thread, in
//! log order, so the result is the same as one thread's. A regular file is handed over in
//! batches; a stream scan by scan, so a live log is mapped as it arrives. A stop flag (set by a
//! Ctrl-C handler, say) ends the run after the scan being mapped; what was mapped is kept.

use std::error::Error;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, SyncSender};
use std::time::{Duration, Instant};

use polymap::config::Config;
use polymap::geometry::Vec2;
use polymap::mapper::{Mapper, ScanDiagnostics, StageSeconds, Update};
use polymap::scan::PreparedScan;
use polymap::scan::{RangeScan, Stamp};
use polymap_export::report::{ReportBudget, ReportData, ReportRecorder, SnapshotContent};
use polymap_io::snapshot::ScanPoints;
use polymap_io::source::ScanSource;
use polymap_io::tum::StampedPose;

/// A boxed error from a source or a caller's callback.
pub type BoxError = Box<dyn Error + Send + Sync + 'static>;

/// How to run.
#[derive(Debug, Clone, Default)]
pub struct PipelineOptions {
    /// Stop after this many scans mapped (`None`: the whole log), counted after `every`.
    pub max_scans: Option<u64>,
    /// Map every `every`-th scan of the log (0 or 1: every scan)...
    pub every: u64,
    /// ...starting at this 0-based scan (below `every`).
    pub every_offset: u64,
    /// Keep every scan's points (robot frame) in [`RunRecord::scan_points`], for the pictures'
    /// points and the occupancy grid's rays.
    pub keep_scan_points: bool,
    /// Title of the replay history ([`RunRecord::history`]).
    pub history_title: String,
    /// Hand scans over one at a time (for a stream) instead of in batches (for a file).
    pub stream: bool,
    /// When set (by another thread), the run stops after the scan being mapped and keeps what
    /// was mapped; [`RunRecord::interrupted`] then says so.
    pub stop: Option<Arc<AtomicBool>>,
    /// The mapper to push the scans into: `None` for a new map ([`Mapper::new`] of the run's
    /// configuration); a mapper on a saved map ([`Mapper::on_map`]) to continue it or to
    /// localize in it. Its configuration must be the run's.
    pub mapper: Option<Mapper>,
    /// Keep every ICP run tracking makes for a scan in its diagnostics
    /// ([`ScanDiagnostics::tries`], [`Mapper::record_tries`]), for a caller that writes them;
    /// a mapper passed in that already keeps them goes on keeping them.
    pub record_tries: bool,
}

/// One mapped scan, as the caller's callback sees it.
#[derive(Debug)]
pub struct ScanEvent<'a> {
    /// 0-based index of the scan in the run.
    pub index: usize,
    /// The scan's time stamp, as in the log.
    pub stamp: &'a Stamp,
    /// What the mapper did with it.
    pub update: &'a Update,
    /// Bytes of the input read up to this scan (0 when unknown), for progress.
    pub bytes_read: u64,
    /// The mapper after this scan (its map, its trajectory so far), for a caller that shows
    /// them as they grow.
    pub mapper: &'a Mapper,
}

/// Where the time went, wall clock.
#[derive(Debug, Clone, Default)]
pub struct RunTimings {
    /// Reading and parsing, on the reading thread.
    pub read: Duration,
    /// `Mapper::push_prepared` and the final loop closure, on the mapping thread.
    pub map: Duration,
    /// The mapping thread waiting for scans.
    pub wait: Duration,
    /// The whole run.
    pub elapsed: Duration,
    /// Per scan: extraction (reading thread) plus its push.
    pub latencies: Vec<Duration>,
    /// Summed per-stage seconds.
    pub stages: StageSeconds,
}

/// What a run leaves.
#[derive(Debug)]
pub struct RunRecord {
    /// The mapper after the last scan (and [`Mapper::finish`]).
    pub mapper: Mapper,
    /// One pose per mapped scan, final (loop corrections applied), with the log's stamps.
    pub trajectory: Vec<StampedPose>,
    /// Every scan's valid returns, robot frame (with [`PipelineOptions::keep_scan_points`]).
    pub scan_points: Option<ScanPoints>,
    /// The replay history for the report.
    pub history: ReportData,
    /// Timings.
    pub timings: RunTimings,
    /// The last scan's diagnostics (with the final loop figures).
    pub last: ScanDiagnostics,
    /// Scans whose ICP did not converge.
    pub icp_not_converged: u64,
    /// Valid returns in the scans mapped (before any range cut of the mapper).
    pub valid_returns: u64,
    /// True when the stop flag ended the run early.
    pub interrupted: bool,
}

/// Why a run failed.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    /// The source failed (a malformed line, an I/O error): its message names file and line.
    #[error(transparent)]
    Read(BoxError),
    /// The caller's callback failed (e.g. writing diagnostics).
    #[error(transparent)]
    Callback(BoxError),
    /// The reading thread could not be started.
    #[error("cannot start the reading thread: {0}")]
    Spawn(std::io::Error),
    /// The reading thread panicked (a bug): its message.
    #[error("the reading thread failed: {0}")]
    ReadingThread(String),
    /// Loop closure failed on its thread (a bug): the node and the message.
    #[error(transparent)]
    LoopClosure(#[from] polymap::loops::LoopFailure),
}

/// Scans handed over per batch from a regular file...
const READ_AHEAD_SCANS: usize = 32;
/// ...with at most this many batches in flight, which bounds the memory read ahead.
const READ_AHEAD_BATCHES: usize = 8;
/// How often the mapping thread looks at the stop flag while waiting for scans.
const STOP_POLL: Duration = Duration::from_millis(50);

/// A scan read and prepared ahead of the mapper.
struct Ready {
    stamp: Stamp,
    prepared: PreparedScan,
    /// All valid returns, robot frame (when kept).
    points: Option<Vec<Vec2>>,
    /// How many valid returns the scan has.
    valid: u64,
    read: Duration,
    bytes_read: u64,
}

type Batch = Result<Vec<Ready>, BoxError>;

/// A scan's valid returns in the robot frame: the one conversion from ranges to points that
/// the mapper, the pictures and the occupancy grid all use.
pub fn scan_points(scan: &RangeScan) -> Vec<Vec2> {
    let mut points = Vec::new();
    scan.points_in_robot(&mut points);
    points
}

/// Maps everything `source` yields (up to `options.max_scans`) with `config`, calling
/// `on_scan` after each scan is mapped; `options.mapper` (a saved map's) is moved into the run. On a read error, the error (what was mapped before is
/// dropped: the log is not what it claims to be).
pub fn run<S>(
    source: S,
    config: &Config,
    mut options: PipelineOptions,
    mut on_scan: impl FnMut(&ScanEvent<'_>) -> Result<(), BoxError>,
) -> Result<RunOutcome<S>, PipelineError>
where
    S: ScanSource + 'static,
{
    let start = Instant::now();
    let batch = if options.stream { 1 } else { READ_AHEAD_SCANS };
    // A stream's scans wait in the source (a live source bounds and drops them there), not
    // here: one scan in hand-over, one being prepared.
    let in_flight = if options.stream {
        1
    } else {
        READ_AHEAD_BATCHES
    };
    let (tx, rx) = std::sync::mpsc::sync_channel(in_flight);
    let reading = {
        let config = config.clone();
        let pick = Pick {
            max_scans: options.max_scans,
            every: options.every.max(1),
            offset: options.every_offset,
        };
        let keep = options.keep_scan_points;
        std::thread::Builder::new()
            .name("polymap-read".into())
            .spawn(move || read_ahead(source, &config, pick, keep, batch, tx))
            .map_err(PipelineError::Spawn)?
    };
    // The saved map's mapper moves in: a copy of a large map's index doubled its memory.
    let mut mapper = options
        .mapper
        .take()
        .unwrap_or_else(|| Mapper::new(config.clone()));
    if options.record_tries {
        mapper.record_tries(true);
    }
    let mut rec = Recorder::new(mapper, &options);
    // On an error this returns at once, dropping `rx`: the reading thread ends at its next
    // hand-over and is not waited for (it may be blocked reading a stream).
    let stop = options.stop.clone().unwrap_or_default();
    let mut waited = Instant::now();
    while let Some(batch) = next_batch(&rx, &stop) {
        rec.timings.wait += waited.elapsed();
        for ready in batch.map_err(PipelineError::Read)? {
            if stop.load(Ordering::Relaxed) {
                break;
            }
            let t1 = Instant::now();
            rec.timings.read += ready.read;
            let update = rec.mapper.push_prepared(ready.prepared);
            let map_time = t1.elapsed();
            on_scan(&ScanEvent {
                index: rec.trajectory.len(),
                stamp: &ready.stamp,
                update: &update,
                bytes_read: ready.bytes_read,
                mapper: &rec.mapper,
            })
            .map_err(PipelineError::Callback)?;
            rec.valid_returns += ready.valid;
            rec.record(ready.stamp, ready.points, update, map_time);
        }
        waited = Instant::now();
    }
    let interrupted = stop.load(Ordering::Relaxed);
    let source = if interrupted {
        // The reading thread may be blocked on a stream: do not wait for it.
        drop(rx);
        None
    } else {
        Some(
            reading
                .join()
                .map_err(|panic| PipelineError::ReadingThread(panic_message(&panic)))?,
        )
    };
    let mut record = rec.finish(interrupted)?;
    record.timings.elapsed = start.elapsed();
    Ok(RunOutcome { record, source })
}

/// A finished (or interrupted) run.
#[derive(Debug)]
pub struct RunOutcome<S> {
    /// What was mapped.
    pub record: RunRecord,
    /// The source, for its counts; `None` when the run was interrupted (it stays with its
    /// thread, which may be blocked reading a stream).
    pub source: Option<S>,
}

fn next_batch(rx: &Receiver<Batch>, stop: &AtomicBool) -> Option<Batch> {
    loop {
        if stop.load(Ordering::Relaxed) {
            return None;
        }
        match rx.recv_timeout(STOP_POLL) {
            Ok(batch) => return Some(batch),
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => return None,
        }
    }
}

fn panic_message(panic: &Box<dyn std::any::Any + Send>) -> String {
    panic
        .downcast_ref::<&str>()
        .map(|s| (*s).to_owned())
        .or_else(|| panic.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic".to_owned())
}

/// Which scans of the log are mapped: every `every`-th from `offset`, at most `max_scans`.
#[derive(Debug, Clone, Copy)]
struct Pick {
    max_scans: Option<u64>,
    every: u64,
    offset: u64,
}

/// Reads the picked scans and prepares them, sending them in batches of `batch_scans`;
/// a read error is sent after the scans before it. Stops early when the receiver has gone (the
/// mapping side failed or stopped and reports why itself, so nothing is lost by not sending).
fn read_ahead<S: ScanSource>(
    mut source: S,
    config: &Config,
    pick: Pick,
    keep_points: bool,
    batch_scans: usize,
    tx: SyncSender<Batch>,
) -> S {
    let mut batch = Vec::with_capacity(batch_scans);
    let mut count = 0u64;
    let mut index = 0u64;
    while pick.max_scans.is_none_or(|m| count < m) {
        let t0 = Instant::now();
        let scan = match source.next_scan() {
            Ok(Some(scan)) => scan,
            Ok(None) => break,
            Err(e) => {
                if tx.send(Ok(std::mem::take(&mut batch))).is_ok() {
                    // If this send fails the receiver is gone, which is reported there.
                    let _ = tx.send(Err(Box::new(e)));
                }
                return source;
            }
        };
        index += 1;
        if (index - 1) % pick.every != pick.offset {
            continue;
        }
        let read = t0.elapsed();
        batch.push(prepare(
            scan,
            config,
            keep_points,
            read,
            source.bytes_read(),
        ));
        count += 1;
        if batch.len() >= batch_scans {
            let full = std::mem::replace(&mut batch, Vec::with_capacity(batch_scans));
            if tx.send(Ok(full)).is_err() {
                return source;
            }
        }
    }
    if !batch.is_empty() {
        // A gone receiver has reported why it stopped.
        let _ = tx.send(Ok(batch));
    }
    source
}

fn prepare(scan: RangeScan, config: &Config, keep: bool, read: Duration, bytes: u64) -> Ready {
    let clock = Instant::now();
    let points = scan_points(&scan);
    let kept = keep.then(|| points.clone());
    let valid = points.len() as u64;
    let mut prepared = Mapper::prepare_points(
        config,
        points,
        scan.angle_increment_rad,
        scan.is_full_circle(),
        scan.odom_from_robot,
        scan.stamp.seconds,
    );
    prepared.extract_s = clock.elapsed().as_secs_f64();
    Ready {
        stamp: scan.stamp,
        prepared,
        points: kept,
        valid,
        read,
        bytes_read: bytes,
    }
}

/// What the mapping thread keeps of each scan.
struct Recorder {
    mapper: Mapper,
    trajectory: Vec<StampedPose>,
    scan_points: Option<ScanPoints>,
    history: ReportRecorder,
    timings: RunTimings,
    last: ScanDiagnostics,
    icp_not_converged: u64,
    valid_returns: u64,
}

impl Recorder {
    fn new(mapper: Mapper, options: &PipelineOptions) -> Self {
        Recorder {
            mapper,
            trajectory: Vec::new(),
            scan_points: options.keep_scan_points.then(ScanPoints::default),
            history: ReportRecorder::new(options.history_title.clone(), ReportBudget::default()),
            timings: RunTimings::default(),
            last: ScanDiagnostics::default(),
            icp_not_converged: 0,
            valid_returns: 0,
        }
    }

    fn record(&mut self, stamp: Stamp, points: Option<Vec<Vec2>>, update: Update, map: Duration) {
        let t = &mut self.timings;
        t.map += map;
        t.latencies
            .push(map + Duration::from_secs_f64(update.diagnostics.stage_s.extract));
        t.stages += update.diagnostics.stage_s;
        self.icp_not_converged += u64::from(update.diagnostics.align.is_some_and(|r| !r.converged));
        if let (Some(all), Some(points)) = (self.scan_points.as_mut(), points) {
            all.push(&points);
        }
        let mapper = &self.mapper;
        self.history.record_update(&update, || {
            SnapshotContent::of_map(
                &mapper.segments(),
                mapper.scans(),
                &mapper.config().directions,
            )
        });
        self.trajectory.push(StampedPose {
            stamp,
            map_from_robot: update.map_from_robot,
        });
        self.last = update.diagnostics;
    }

    /// Finishes loop closure and puts the final poses into the trajectory; a failure of loop
    /// closure during the run is the error.
    fn finish(mut self, interrupted: bool) -> Result<RunRecord, polymap::loops::LoopFailure> {
        let clock = Instant::now();
        let loops = self.mapper.finish()?;
        self.timings.map += clock.elapsed();
        self.timings.stages.loops += clock.elapsed().as_secs_f64();
        self.last.loops = loops;
        for (p, q) in self.trajectory.iter_mut().zip(self.mapper.trajectory()) {
            p.map_from_robot = *q;
        }
        let content = SnapshotContent::of_map(
            &self.mapper.segments(),
            self.mapper.scans(),
            &self.mapper.config().directions,
        );
        let history = self.history.finish(content);
        Ok(RunRecord {
            mapper: self.mapper,
            trajectory: self.trajectory,
            scan_points: self.scan_points,
            history,
            timings: self.timings,
            last: self.last,
            icp_not_converged: self.icp_not_converged,
            valid_returns: self.valid_returns,
            interrupted,
        })
    }
}

/// Reads `source` again through the same conversion as [`run`]: the first `scans` scans'
/// points (robot frame) and their stamps, for the occupancy grid of a finished run.
pub fn reread_scan_points<S: ScanSource>(
    source: &mut S,
    scans: usize,
) -> Result<(ScanPoints, Vec<Stamp>), S::Error> {
    let mut points = ScanPoints::default();
    let mut stamps = Vec::with_capacity(scans);
    while points.len() < scans {
        let Some(scan) = source.next_scan()? else {
            break;
        };
        points.push(&scan_points(&scan));
        stamps.push(scan.stamp);
    }
    Ok((points, stamps))
}

#[cfg(test)]
mod tests {
    use super::*;
    use polymap_sim::{SimParams, simulate, world_by_name};

    /// Scans from memory; fails with `error_at` when it reaches that index.
    #[derive(Debug)]
    struct VecSource {
        scans: std::collections::VecDeque<RangeScan>,
        read: usize,
        error_at: Option<usize>,
    }

    impl ScanSource for VecSource {
        type Error = std::io::Error;

        fn next_scan(&mut self) -> Result<Option<RangeScan>, std::io::Error> {
            if self.error_at == Some(self.read) {
                return Err(std::io::Error::other("line 7: broken"));
            }
            self.read += 1;
            Ok(self.scans.pop_front())
        }

        /// 100 bytes per scan read.
        fn bytes_read(&self) -> u64 {
            100 * self.read as u64
        }
    }

    fn scans(n: usize) -> Vec<RangeScan> {
        let world = world_by_name("hallway45").expect("a built-in world");
        let mut run = simulate(&world, &SimParams::default(), 1);
        run.scans.truncate(n);
        run.scans
    }

    fn source(scans: &[RangeScan]) -> VecSource {
        VecSource {
            scans: scans.iter().cloned().collect(),
            read: 0,
            error_at: None,
        }
    }

    #[test]
    fn the_pipeline_maps_as_one_thread_does_in_batches_and_streams() {
        let scans = scans(300);
        let config = Config::default();
        let mut mapper = Mapper::new(config.clone());
        for s in &scans {
            mapper.push(s);
        }
        mapper.finish().expect("loop closure does not fail");
        for stream in [false, true] {
            let options = PipelineOptions {
                stream,
                keep_scan_points: true,
                ..PipelineOptions::default()
            };
            let out = run(source(&scans), &config, options, |_| Ok(())).expect("runs");
            let r = &out.record;
            assert_eq!(r.mapper.segments(), mapper.segments());
            let poses: Vec<_> = r.trajectory.iter().map(|p| p.map_from_robot).collect();
            assert_eq!(poses, mapper.trajectory());
            assert!(
                r.trajectory
                    .iter()
                    .zip(&scans)
                    .all(|(p, s)| p.stamp == s.stamp)
            );
            let points = r.scan_points.as_ref().expect("kept");
            assert_eq!(points.len(), 300);
            assert_eq!(points.scan(17), scan_points(&scans[17]).as_slice());
            let valid: usize = scans.iter().map(RangeScan::valid_count).sum();
            assert_eq!(r.valid_returns, valid as u64);
            assert!(!r.interrupted && out.source.is_some());
        }
    }

    /// Each event carries the input position of the scan just mapped, not the bytes read ahead
    /// (a progress bar following those shows 100 % on a pipe with 57 % of the scans mapped).
    #[test]
    fn progress_follows_the_scans_mapped_not_the_read_ahead() {
        let scans = scans(200);
        let mut seen = Vec::new();
        run(
            source(&scans),
            &Config::default(),
            PipelineOptions::default(),
            |e| {
                seen.push((e.index, e.bytes_read));
                Ok(())
            },
        )
        .expect("runs");
        assert_eq!(seen.len(), 200);
        assert!(
            seen.iter().all(|&(i, b)| b == 100 * (i as u64 + 1)),
            "{seen:?}"
        );
    }

    #[test]
    fn a_stop_keeps_what_was_mapped() {
        let scans = scans(200);
        let stop = Arc::new(AtomicBool::new(false));
        let options = PipelineOptions {
            stop: Some(Arc::clone(&stop)),
            ..PipelineOptions::default()
        };
        let out = run(source(&scans), &Config::default(), options, |e| {
            if e.index == 49 {
                stop.store(true, Ordering::SeqCst);
            }
            Ok(())
        })
        .expect("runs");
        assert!(out.record.interrupted);
        assert_eq!(out.record.trajectory.len(), 50);
        assert!(out.source.is_none());
    }

    #[test]
    fn every_kth_scan_and_read_errors() {
        let scans = scans(100);
        let options = PipelineOptions {
            every: 3,
            every_offset: 1,
            max_scans: Some(10),
            ..PipelineOptions::default()
        };
        let out = run(source(&scans), &Config::default(), options, |_| Ok(())).expect("runs");
        let stamps: Vec<_> = out
            .record
            .trajectory
            .iter()
            .map(|p| p.stamp.clone())
            .collect();
        let picked: Vec<_> = (0..10).map(|i| scans[1 + 3 * i].stamp.clone()).collect();
        assert_eq!(stamps, picked);
        let failing = VecSource {
            error_at: Some(40),
            ..source(&scans)
        };
        let e = run(
            failing,
            &Config::default(),
            PipelineOptions::default(),
            |_| Ok(()),
        )
        .expect_err("the read error fails the run");
        assert!(e.to_string().contains("line 7: broken"), "{e}");
    }
}
