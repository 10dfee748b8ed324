//! Scans as they arrive: a bounded queue between the DDS receiving thread and the mapping
//! run, which drops the oldest scan when it is full (counted), the odometry kept beside it for
//! the scans' stamps, and every scan's arrival time for its latency.

use std::collections::VecDeque;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::Instant;

use polymap::geometry::{Pose2, Vec2};
use polymap::scan::RangeScan;
use polymap_io::log::{LiveScans, LogStats};

/// Odometry poses kept for interpolation at the scans' stamps, at most.
const ODOMETRY_KEPT: usize = 4096;
/// Bad messages whose errors are kept for the run's report.
const ERRORS_KEPT: usize = 5;
/// Distinct warnings kept, at most (a stream of bad transforms words each differently).
pub const MAX_WARNINGS: usize = 20;
/// How long a scan waits, from its arrival, for an odometry message stamped at or after it, so
/// that its odometry is interpolated as a recording's is rather than held at the last one.
pub const ODOMETRY_WAIT: std::time::Duration = std::time::Duration::from_millis(20);

/// A scan received, with when it arrived.
#[derive(Debug, Clone)]
pub struct Arrived {
    /// The scan, in the robot frame's terms (`robot_from_laser` from tf where known).
    pub scan: RangeScan,
    /// When the receiving thread took it off the wire.
    pub arrived: Instant,
}

/// Counts of what arrived, for the run's report and the status topic.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Received {
    /// Scan messages received (good or bad).
    pub scan_messages: u64,
    /// Scans handed to the mapper.
    pub scans: u64,
    /// Scans dropped because the queue was full (the oldest go first).
    pub dropped: u64,
    /// Scan messages that could not be used (undecodable, impossible geometry), skipped.
    pub bad_messages: u64,
    /// The first few of their errors.
    pub bad_errors: Vec<String>,
    /// Odometry messages received.
    pub odometry_messages: u64,
    /// Valid and no-return readings of the scans handed over.
    pub valid_readings: u64,
    /// Readings that were no-returns.
    pub no_return_readings: u64,
    /// Things the user should know (a scan frame missing from tf, say), each once.
    pub warnings: Vec<String>,
    /// Warnings beyond [`MAX_WARNINGS`], not kept.
    pub warnings_left_out: u64,
}

#[derive(Debug, Default)]
struct State {
    queue: VecDeque<Arrived>,
    /// (stamp seconds, odom_from_robot), in arrival order.
    /// (stamp, nanoseconds; odom_from_robot), in arrival order.
    odometry: VecDeque<(i128, Pose2)>,
    received: Received,
    /// Arrival times of the scans handed over and not yet claimed by [`ScanQueue::claim_arrival`].
    handed: VecDeque<Instant>,
    /// Held-back scans beyond the capacity still queued (they raise the bound while they last).
    held_queued: usize,
    closed: bool,
}

/// The queue shared by the receiving thread (which pushes) and the mapping run (which pops
/// through [`LiveSource`]).
#[derive(Debug)]
pub struct ScanQueue {
    state: Mutex<State>,
    ready: Condvar,
    capacity: usize,
    attach_odometry: bool,
    /// The odometry only witnesses the steps (no `--odometry`): none outside its span or across
    /// a gap in it, as a recording's reader gives.
    witness: bool,
}

impl ScanQueue {
    /// A queue holding at most `capacity` scans (at least 1); with `attach_odometry`, each
    /// scan handed over carries the odometry pose at its stamp (interpolated, or the nearest;
    /// a scan newer than every odometry message waits up to [`ODOMETRY_WAIT`] for the next).
    /// With `witness`, a scan outside the odometry's span, or within a gap of over 1 s in it,
    /// gets none (a recording's reader does the same).
    pub fn new(capacity: usize, attach_odometry: bool, witness: bool) -> Arc<ScanQueue> {
        Arc::new(ScanQueue {
            state: Mutex::new(State::default()),
            ready: Condvar::new(),
            capacity: capacity.max(1),
            attach_odometry,
            witness,
        })
    }

    fn lock(&self) -> MutexGuard<'_, State> {
        // A panic while holding the lock leaves plain counts behind: still usable.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Queues a scan, dropping the oldest waiting one when full (beyond the capacity, plus
    /// whatever held-back scans are still queued). Returns false once closed.
    pub fn push(&self, scan: RangeScan, arrived: Instant) -> bool {
        self.push_bounded(scan, arrived, None)
    }

    /// Queues a scan that was held back (waiting for tf) and is let go with others at once:
    /// the queue may then hold up to `extra` more than its capacity, so that a run's first
    /// scans are not dropped for the wait.
    pub fn push_held(&self, scan: RangeScan, arrived: Instant, extra: usize) -> bool {
        self.push_bounded(scan, arrived, Some(extra))
    }

    fn push_bounded(&self, scan: RangeScan, arrived: Instant, held: Option<usize>) -> bool {
        let mut s = self.lock();
        if s.closed {
            return false;
        }
        s.received.scan_messages += 1;
        // While held-back scans are worked off, the scans arriving beside them are not dropped
        // for them: the bound grows by the held scans still queued.
        let capacity = self.capacity + held.unwrap_or(0).max(s.held_queued);
        if s.queue.len() >= capacity {
            s.queue.pop_front();
            s.received.dropped += 1;
        }
        s.queue.push_back(Arrived { scan, arrived });
        if held.is_some() {
            let beyond = s.queue.len().saturating_sub(self.capacity);
            s.held_queued = s.held_queued.max(beyond);
        }
        drop(s);
        self.ready.notify_one();
        true
    }

    /// Counts a scan message that could not be used.
    pub fn bad_message(&self, error: String) {
        let mut s = self.lock();
        s.received.scan_messages += 1;
        s.received.bad_messages += 1;
        if s.received.bad_errors.len() < ERRORS_KEPT {
            s.received.bad_errors.push(error);
        }
    }

    /// Adds a warning, unless the same text was given before or [`MAX_WARNINGS`] are kept
    /// (the rest are counted in `warnings_left_out`). True when it was added.
    pub fn warn_once(&self, warning: String) -> bool {
        let mut s = self.lock();
        if s.received.warnings.contains(&warning) {
            return false;
        }
        if s.received.warnings.len() >= MAX_WARNINGS {
            s.received.warnings_left_out += 1;
            return false;
        }
        s.received.warnings.push(warning);
        true
    }

    /// Keeps an odometry pose (`odom_from_robot` at `stamp_ns`, nanoseconds).
    pub fn odometry(&self, stamp_ns: i128, odom_from_robot: Pose2) {
        let mut s = self.lock();
        s.received.odometry_messages += 1;
        if s.odometry.len() >= ODOMETRY_KEPT {
            s.odometry.pop_front();
        }
        s.odometry.push_back((stamp_ns, odom_from_robot));
        drop(s);
        self.ready.notify_all();
    }

    /// Ends the source: scans still queued are handed over, then `next_scan` says the end.
    pub fn close(&self) {
        self.lock().closed = true;
        self.ready.notify_all();
    }

    /// True once [`close`](Self::close) was called.
    pub fn is_closed(&self) -> bool {
        self.lock().closed
    }

    /// The counts so far.
    pub fn received(&self) -> Received {
        self.lock().received.clone()
    }

    /// The odometry pose at `stamp_ns` (interpolated, else the nearest), from what arrived.
    pub fn odometry_at(&self, stamp_ns: i128) -> Option<Pose2> {
        odometry_at(&self.lock().odometry, stamp_ns, false)
    }

    /// The arrival time of the oldest scan handed over and not yet claimed: the mapping run
    /// maps scans in the order they were handed over, so the k-th claim is the k-th scan's.
    pub fn claim_arrival(&self) -> Option<Instant> {
        self.lock().handed.pop_front()
    }

    fn pop(&self) -> Option<Arrived> {
        let mut s = self.lock();
        loop {
            if let Some(front) = s.queue.front() {
                // Odometry seen but none yet at or after the scan: wait a little for it.
                let t = stamp_ns(&front.scan.stamp);
                // Seen odometry, but none stamped at or after the scan (stamps may arrive out
                // of order: any message counts, not only the last).
                let behind = !s.odometry.is_empty() && s.odometry.iter().all(|(st, _)| *st < t);
                let waited = front.arrived.elapsed();
                if self.attach_odometry && behind && !s.closed && waited < ODOMETRY_WAIT {
                    let (next, _) = self
                        .ready
                        .wait_timeout(s, ODOMETRY_WAIT - waited)
                        .unwrap_or_else(|e| e.into_inner());
                    s = next;
                    continue;
                }
            }
            if let Some(mut a) = s.queue.pop_front() {
                if self.attach_odometry {
                    let t = stamp_ns(&a.scan.stamp);
                    a.scan.odom_from_robot = odometry_at(&s.odometry, t, self.witness);
                }
                let valid = a
                    .scan
                    .ranges_m
                    .iter()
                    .filter(|&&r| a.scan.is_valid_range(r))
                    .count() as u64;
                s.received.scans += 1;
                s.held_queued = s.held_queued.saturating_sub(1);
                s.received.valid_readings += valid;
                s.received.no_return_readings += a.scan.ranges_m.len() as u64 - valid;
                s.handed.push_back(a.arrived);
                return Some(a);
            }
            if s.closed {
                return None;
            }
            s = self.ready.wait(s).unwrap_or_else(|e| e.into_inner());
        }
    }
}

/// A scan's stamp in nanoseconds, exactly as it was read (from its text), else from its seconds.
pub fn stamp_ns(stamp: &polymap::scan::Stamp) -> i128 {
    polymap_io::ros::RosTime::from_stamp(stamp)
        .map_or((stamp.seconds * 1e9).round() as i128, |t| t.nanos())
}

/// Witnessing odometry is interpolated only between messages at most this far apart,
/// nanoseconds (a recording's reader's bound).
const WITNESS_MAX_BRACKET_NS: i128 = 1_000_000_000;

/// The odometry pose at `t_ns`, as a recording's reader gives it: a message's at its stamp,
/// interpolated between the two around it, else the nearest; with `witness`, none outside the
/// span nor across a gap of over 1 s.
fn odometry_at(odometry: &VecDeque<(i128, Pose2)>, t_ns: i128, witness: bool) -> Option<Pose2> {
    let after = odometry.iter().position(|(s, _)| *s >= t_ns);
    match after {
        Some(i) if odometry[i].0 == t_ns => Some(odometry[i].1),
        Some(i) if i > 0 => {
            let (t0, p0) = odometry[i - 1];
            let (t1, p1) = odometry[i];
            if witness && t1 - t0 > WITNESS_MAX_BRACKET_NS {
                return None;
            }
            let f = ((t_ns - t0) as f64) / ((t1 - t0) as f64);
            Some(p0.interpolate(&p1, f))
        }
        _ if witness => None,
        None => odometry.back().map(|(_, p)| *p),
        Some(_) => odometry.front().map(|(_, p)| *p),
    }
}

/// The mapping run's end of the queue: a [`LiveScans`] for [`polymap_io::log::LogSource::live`].
#[derive(Debug)]
pub struct LiveSource {
    queue: Arc<ScanQueue>,
    topic: String,
    rays: Arc<RayStore>,
}

impl LiveSource {
    /// The source of `queue`'s scans, from `topic` (for messages); each scan's points are kept
    /// in `rays` for the occupancy grid.
    pub fn new(queue: Arc<ScanQueue>, topic: &str, rays: Arc<RayStore>) -> Self {
        LiveSource {
            queue,
            topic: topic.to_owned(),
            rays,
        }
    }
}

impl LiveScans for LiveSource {
    fn next_scan(&mut self) -> Option<RangeScan> {
        let a = self.queue.pop()?;
        let mut points = Vec::new();
        a.scan.points_in_robot(&mut points);
        self.rays.push(points);
        Some(a.scan)
    }

    fn stats(&self) -> LogStats {
        let r = self.queue.received();
        let mut warnings = r.warnings.clone();
        if r.warnings_left_out > 0 {
            warnings.push(format!(
                "{} more warnings were left out",
                r.warnings_left_out
            ));
        }
        if r.dropped > 0 {
            warnings.push(format!(
                "{} of {} scans arrived while the queue was full and were dropped (the oldest \
                 first): the mapper did not keep up",
                r.dropped, r.scan_messages
            ));
        }
        LogStats {
            records: r.scan_messages + r.odometry_messages,
            record_unit: "messages",
            scan_source: format!("LaserScan messages on {}", self.topic),
            scans: r.scans,
            odometry_messages: r.odometry_messages,
            bad_records: r.bad_messages,
            bad_record_errors: r.bad_errors,
            no_return_readings: r.no_return_readings,
            valid_readings: r.valid_readings,
            warnings,
            ..LogStats::default()
        }
    }
}

/// Scans' points (robot frame) for the occupancy grid's free space, bounded: above `max_scans`
/// every other scan kept is let go and from then on only every other new one is kept, so the
/// scans kept stay evenly spread over the run.
#[derive(Debug)]
pub struct RayStore {
    inner: Mutex<Rays>,
    max_scans: usize,
}

#[derive(Debug, Default)]
struct Rays {
    /// (scan index in the run, points in the robot frame).
    kept: Vec<(usize, Arc<Vec<Vec2>>)>,
    /// Scans seen.
    seen: usize,
    /// Keep scans whose index is a multiple of this.
    stride: usize,
}

impl RayStore {
    /// A store keeping at most `max_scans` scans' points (at least 2).
    pub fn new(max_scans: usize) -> Arc<RayStore> {
        Arc::new(RayStore {
            inner: Mutex::new(Rays {
                stride: 1,
                ..Rays::default()
            }),
            max_scans: max_scans.max(2),
        })
    }

    fn push(&self, points: Vec<Vec2>) {
        let mut r = self.inner.lock().unwrap_or_else(|e| e.into_inner());
        let index = r.seen;
        r.seen += 1;
        if !index.is_multiple_of(r.stride) {
            return;
        }
        r.kept.push((index, Arc::new(points)));
        if r.kept.len() > self.max_scans {
            r.stride *= 2;
            let stride = r.stride;
            r.kept.retain(|(i, _)| i.is_multiple_of(stride));
        }
    }

    /// The scans kept: (scan index in the run, points in the robot frame).
    pub fn kept(&self) -> Vec<(usize, Arc<Vec<Vec2>>)> {
        self.inner
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .kept
            .clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use polymap::scan::Stamp;

    fn scan(t: f64) -> RangeScan {
        RangeScan {
            stamp: Stamp::from_seconds(t),
            ranges_m: vec![1.0, f64::INFINITY, 2.0],
            angle_min_rad: -0.1,
            angle_increment_rad: 0.1,
            max_range_m: 10.0,
            robot_from_laser: Pose2::IDENTITY,
            odom_from_robot: None,
        }
    }

    #[test]
    fn a_full_queue_drops_the_oldest_scan_and_counts_it() {
        let q = ScanQueue::new(2, false, false);
        let now = Instant::now();
        for t in [1.0, 2.0, 3.0] {
            assert!(q.push(scan(t), now));
        }
        q.close();
        let mut source = LiveSource::new(Arc::clone(&q), "/scan", RayStore::new(10));
        let stamps: Vec<f64> = std::iter::from_fn(|| source.next_scan())
            .map(|s| s.stamp.seconds)
            .collect();
        assert_eq!(stamps, [2.0, 3.0]);
        let stats = source.stats();
        assert_eq!((stats.scans, q.received().dropped), (2, 1));
        assert!(
            stats.warnings[0].contains("1 of 3 scans"),
            "{:?}",
            stats.warnings
        );
        assert_eq!((stats.valid_readings, stats.no_return_readings), (4, 2));
    }

    #[test]
    fn scans_held_back_may_exceed_the_capacity_by_their_allowance() {
        let q = ScanQueue::new(2, false, false);
        for t in 0..5 {
            q.push_held(scan(f64::from(t)), Instant::now(), 3);
        }
        q.push_held(scan(5.0), Instant::now(), 3);
        assert_eq!(q.received().dropped, 1);
        q.push(scan(6.0), Instant::now());
        assert_eq!(
            q.received().dropped,
            2,
            "a plain push does not grow it further"
        );
        q.close();
        let mut source = LiveSource::new(Arc::clone(&q), "/scan", RayStore::new(10));
        assert_eq!(std::iter::from_fn(|| source.next_scan()).count(), 5);
        // As the held scans are worked off, the bound comes back to the capacity.
        let q = ScanQueue::new(2, false, false);
        for t in 0..4 {
            q.push_held(scan(f64::from(t)), Instant::now(), 10);
        }
        let mut source = LiveSource::new(Arc::clone(&q), "/scan", RayStore::new(10));
        for _ in 0..4 {
            source.next_scan();
        }
        for t in 4..8 {
            q.push(scan(f64::from(t)), Instant::now());
        }
        assert_eq!(
            q.received().dropped,
            2,
            "the plain bound again once they are gone"
        );
    }

    #[test]
    fn a_closed_queue_hands_over_what_it_holds_then_ends() {
        let q = ScanQueue::new(8, false, false);
        q.push(scan(1.0), Instant::now());
        q.close();
        assert!(!q.push(scan(2.0), Instant::now()));
        let mut source = LiveSource::new(Arc::clone(&q), "/scan", RayStore::new(10));
        assert!(source.next_scan().is_some());
        assert!(source.next_scan().is_none());
        assert!(q.claim_arrival().is_some());
        assert!(q.claim_arrival().is_none());
    }

    #[test]
    fn a_waiting_reader_wakes_for_a_scan_from_another_thread() {
        let q = ScanQueue::new(8, false, false);
        let pusher = {
            let q = Arc::clone(&q);
            std::thread::spawn(move || {
                q.push(scan(1.0), Instant::now());
                q.close();
            })
        };
        let mut source = LiveSource::new(Arc::clone(&q), "/scan", RayStore::new(10));
        assert_eq!(source.next_scan().map(|s| s.stamp.seconds), Some(1.0));
        pusher.join().unwrap();
        assert!(source.next_scan().is_none());
    }

    #[test]
    fn odometry_is_interpolated_at_the_scans_stamp() {
        let q = ScanQueue::new(8, true, false);
        q.odometry(1_000_000_000, Pose2::new(0.0, 0.0, 0.0));
        q.odometry(2_000_000_000, Pose2::new(1.0, 0.0, 0.0));
        q.push(scan(1.25), Instant::now());
        q.push(scan(5.0), Instant::now());
        q.close();
        let mut source = LiveSource::new(Arc::clone(&q), "/scan", RayStore::new(10));
        let a = source.next_scan().unwrap().odom_from_robot.unwrap();
        assert!((a.x_m - 0.25).abs() < 1e-12);
        let b = source.next_scan().unwrap().odom_from_robot.unwrap();
        assert!(
            (b.x_m - 1.0).abs() < 1e-12,
            "the latest pose after the last message"
        );
    }

    #[test]
    fn a_scan_newer_than_the_odometry_waits_for_the_next_message() {
        let q = ScanQueue::new(8, true, false);
        q.odometry(1_000_000_000, Pose2::new(0.0, 0.0, 0.0));
        q.push(scan(1.5), Instant::now());
        let odometer = {
            let q = Arc::clone(&q);
            std::thread::spawn(move || {
                std::thread::sleep(std::time::Duration::from_millis(2));
                q.odometry(2_000_000_000, Pose2::new(1.0, 0.0, 0.0));
            })
        };
        let mut source = LiveSource::new(Arc::clone(&q), "/scan", RayStore::new(10));
        let p = source.next_scan().unwrap().odom_from_robot.unwrap();
        odometer.join().unwrap();
        // Interpolated (0.5) when the message came within the wait; held (0.0) otherwise,
        // which a loaded machine may cause: never anything else.
        assert!(p.x_m == 0.5 || p.x_m == 0.0, "{p:?}");
    }

    #[test]
    fn warnings_are_kept_up_to_their_bound_and_the_rest_counted() {
        let q = ScanQueue::new(8, false, false);
        for i in 0..(MAX_WARNINGS + 3) {
            q.warn_once(format!("warning {i}"));
        }
        assert!(!q.warn_once("warning 0".into()));
        let r = q.received();
        assert_eq!((r.warnings.len(), r.warnings_left_out), (MAX_WARNINGS, 3));
    }

    #[test]
    fn the_ray_store_keeps_an_even_spread_within_its_bound() {
        let store = RayStore::new(4);
        for _ in 0..20 {
            store.push(vec![Vec2::new(1.0, 0.0)]);
        }
        let kept: Vec<usize> = store.kept().iter().map(|(i, _)| *i).collect();
        assert!(kept.len() <= 4, "{kept:?}");
        assert_eq!(kept, [0, 8, 16]);
    }
}
