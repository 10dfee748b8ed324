//! What a run says of its tracking ([`TrackingSummary`], `summary.json` `tracking`): verdict
//! counts, lost ranges, gaps in the log, the log's odometry against the tracked travel, steps
//! the odometry contradicts, and stretches of weak scans.

use serde::{Deserialize, Serialize};

use super::short_of_odometry::{MAX_SHORT_STRETCHES, ShortStretch, ShortWindow};
use super::verdict::{Reason, Verdict};

/// Verdict counts over a run, and the runs of consecutive lost scans.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TrackingSummary {
    /// Scans tracked confidently.
    pub ok: u32,
    /// Scans with a direction taken from the motion prior, a direction observed by few
    /// points, a poor fit or a rival pose.
    pub weak: u32,
    /// Of the `weak` scans, those weak only because a direction was observed by few points
    /// (`weakly_observed`): common along any corridor, also where tracking is accurate, so the
    /// run's warning does not count them.
    #[serde(default)]
    pub weakly_observed: u32,
    /// Inclusive ranges `[first, last]` of consecutive scans weak for a reason other than
    /// `weakly_observed` (scan indices, 0-based; the first [`MAX_GAP_SCANS`] ranges): where
    /// the run's warning of weak scans says to look.
    #[serde(default)]
    pub doubtful_ranges: Vec<[u32; 2]>,
    /// Scans with no confident match (they did not enter the map).
    pub lost: u32,
    /// Inclusive ranges `[first, last]` of consecutive lost scans (scan indices, 0-based).
    pub lost_ranges: Vec<[u32; 2]>,
    /// Scans that follow a gap in the log: a time step at least 3 typical ones, in stamps
    /// that keep time (scans are missing there; without odometry the motion across it is
    /// predicted over its time). Stamps that bunch or go back say nothing, and count none.
    #[serde(default)]
    pub gaps: u32,
    /// The first [`MAX_GAP_SCANS`] of them (scan indices, 0-based).
    #[serde(default)]
    pub gap_scans: Vec<u32>,
    /// Where the log has odometry: how far it says the robot went between consecutive scans
    /// both tracked `ok`, metres (summed step lengths)...
    #[serde(default)]
    pub odometry_travel_m: f64,
    /// ...and how far the tracked poses went between the same scans, metres. Odometry that
    /// reads under half or over twice the scans' travel is stuck, scaled or not this robot's
    /// (the benchmark logs: within 2 %).
    #[serde(default)]
    pub tracked_travel_m: f64,
    /// Without the odometry prior, while the log's odometry agrees with the scans
    /// ([`TrackingSummary::odometry_agrees_with_travel`]): the scans not lost whose tracked
    /// step lies more than `tracking.odometry.odometry_witness_m` from the odometry's and from its
    /// reverse ([`OdometryWitness`](super::OdometryWitness)), whatever their verdict (an `ok` one becomes `weak`,
    /// `off_odometry`); one slip of the odometry counts twice, the step to it and from it.
    /// Where sparse scans leave a corridor tracked short (`weakly_observed` scans, which do
    /// not raise the weak warning) these are the sign: the benchmark logs' runs of every 10th
    /// scan have 0.9–9.9 %, their dense runs none. A dense run shortening a corridor by a few
    /// millimetres per scan stays under the threshold at every step.
    #[serde(default)]
    pub off_odometry: u32,
    /// The first [`MAX_GAP_SCANS`] of them (scan indices, 0-based).
    #[serde(default)]
    pub off_odometry_scans: Vec<u32>,
    /// Without the odometry prior: the stretches over which the tracked steps fell under half
    /// the log's odometry's (their median over windows of at least
    /// [`SHORT_WINDOW_M`](super::SHORT_WINDOW_M) and
    /// [`SHORT_WINDOW_STEPS`](super::SHORT_WINDOW_STEPS); a lost scan starts the window over),
    /// the first [`MAX_SHORT_STRETCHES`]. A stall on steps each tracked `ok` and each under the
    /// odometry witness's distance shows only so. Warned where the log's odometry agrees with
    /// the scans' travel ([`TrackingSummary::odometry_agrees_with_travel`]).
    #[serde(default)]
    pub short_of_odometry: Vec<ShortStretch>,
    /// The last steps, as the odometry and the tracking read them.
    #[serde(skip)]
    short_window: ShortWindow,
    /// Runs of consecutive `weak` scans over which the robot went at least
    /// [`WEAK_STRETCH_M`], tracked, by the log's odometry or by the speed last observed (the
    /// largest: a stretch tracked short, the failure it warns of, is short in its tracked
    /// travel, and a log without odometry has only the speed to tell): there the motion
    /// came from the motion prior or from few points for metres on end, and a corridor may
    /// come out short. Scattered weak scans, common along corridors also where tracking is
    /// accurate, make no such stretch.
    #[serde(default)]
    pub weak_stretches: Vec<WeakStretch>,
    /// The run of weak scans going on, with its tracked, odometry and expected travel
    /// (metres).
    #[serde(skip)]
    open_weak: Option<(WeakStretch, f64, f64, f64)>,
    /// How far the tracked poses went between consecutive scans not lost, metres.
    #[serde(default)]
    pub travel_m: f64,
    /// Of [`TrackingSummary::travel_m`], the steps to scans weak because a direction was
    /// observed by few points or none (`weakly_observed`, `degenerate`, `slowed`), metres:
    /// there the motion along that direction came from the motion prior or a few points.
    /// Scattered along corridors such steps are common where tracking is accurate (the
    /// benchmark logs' dense runs 0–3.3 % of the travel, their runs of every 5th and 10th scan
    /// up to 6.8 %, the built-in hallway 6.9–8.0 % over noise seeds); many slightly short ones
    /// add up to a bent or shortened map without one long weak stretch (the logs with the
    /// laser cut to 5.6 m: Intel 12.7 %, 0.28 m mean relation error against 0.026 m; ACES
    /// 25.7 %, 0.76 m). Above [`WEAK_TRAVEL_SHARE`] of the travel the run warns.
    #[serde(default)]
    pub weak_travel_m: f64,
    /// Where that weak travel gathered: the stretches of about [`WEAK_TRAVEL_PART_M`] of
    /// travel whose weak share exceeds [`WEAK_TRAVEL_SHARE`], at most
    /// [`MAX_WEAK_TRAVEL_PARTS`] (those with the most weak travel).
    #[serde(default)]
    pub weak_travel_parts: Vec<WeakTravelPart>,
    /// The stretch of travel going on, from its first step.
    #[serde(skip)]
    open_part: Option<WeakTravelPart>,
}

/// A stretch of consecutive scans and how much of its travel was weakly observed
/// ([`TrackingSummary::weak_travel_parts`]).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct WeakTravelPart {
    /// The first scan of the stretch (scan index, 0-based).
    pub first: u32,
    /// The last scan of the stretch (inclusive).
    pub last: u32,
    /// The tracked travel over the stretch, metres.
    pub travel_m: f64,
    /// Of it, the steps weakly observed along a direction, metres.
    pub weak_travel_m: f64,
}

/// A run whose travel on weakly observed steps exceeds this share of its travel (over at least
/// [`WEAK_TRAVEL_MIN_M`]) warns ([`TrackingSummary::weak_travel_m`]): above every accurate
/// run measured (at most 8.0 %, the built-in hallway), below the runs with a short laser
/// (12.7 % and more).
pub const WEAK_TRAVEL_SHARE: f64 = 0.1;

/// Travel below which the weak travel's share is not judged, metres.
pub const WEAK_TRAVEL_MIN_M: f64 = 20.0;

/// The weak travel is located in stretches of about this much travel, metres.
pub const WEAK_TRAVEL_PART_M: f64 = 25.0;

/// At most this many stretches are listed in [`TrackingSummary::weak_travel_parts`].
pub const MAX_WEAK_TRAVEL_PARTS: usize = 20;

/// A run of consecutive `weak` scans ([`TrackingSummary::weak_stretches`]).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct WeakStretch {
    /// The first scan of the run (scan index, 0-based).
    pub first: u32,
    /// The last scan of the run (inclusive).
    pub last: u32,
    /// How far the robot went over the run, from the scan before it to its last scan: the
    /// tracked poses' travel, the log's odometry's or the speed last observed's, the largest,
    /// metres.
    pub travel_m: f64,
}

/// A run of consecutive weak scans over at least this travel is a weak stretch
/// ([`TrackingSummary::weak_stretches`]), metres. The benchmark logs' dense runs have none
/// (the longest: ACES 4.1 m, Intel 1.7 m, FR079 none), nor do their runs of every 3rd scan or
/// the three of five phases of every 5th scan that stay within 0.1 m (mean relation error);
/// ACES' two other phases of every 5th scan (0.136 and 0.159 m) have one each (12.2 and
/// 10.7 m, long only at the speed last observed: tracked short). The simulated corridor, whose
/// middle no feature observes along it, has two of 25 and 28 m (ATE 1.17 m), and 14 of the 30
/// runs of every 10th scan have them, all broken (every ACES phase, FR079 phases 4, 6 and 8,
/// Intel phase 9). The sparse logs: ACES 4 (two of them where its corridor steps were tracked
/// near no motion), Intel 12, Örebro 3, the accurate seattle and freiburg-101 none.
pub const WEAK_STRETCH_M: f64 = 10.0;

/// At most this many gap scans are listed in [`TrackingSummary::gap_scans`] (all are counted),
/// and as many in [`TrackingSummary::off_odometry_scans`].
pub const MAX_GAP_SCANS: usize = 100;

/// Tracked travel below which the log's odometry is not judged against the scans, metres: a
/// few scans of a robot that hardly moved say nothing of its odometry.
pub const ODOMETRY_CHECK_MIN_TRAVEL_M: f64 = 5.0;

/// The log's odometry witnesses the steps ([`OdometryWitness`](super::OdometryWitness)) while its travel between
/// consecutive `ok` scans is within this factor of the scans' either way (the benchmark logs:
/// within 2 %; a wheel 10 % too small still witnesses).
pub const ODOMETRY_WITNESS_WITHIN: f64 = 1.25;

impl TrackingSummary {
    /// Counts the lost scans `first..=last` (one lost range) as weak instead.
    pub(super) fn relabel_lost_as_weak(&mut self, first: u32, last: u32) {
        let n = last - first + 1;
        if let Some(i) = self.lost_ranges.iter().position(|r| *r == [first, last]) {
            self.lost_ranges.remove(i);
            self.lost -= n;
            self.weak += n;
        }
    }

    /// Counts scan `t` as following a gap in the log.
    pub(super) fn count_gap(&mut self, t: u32) {
        self.gaps += 1;
        if self.gap_scans.len() < MAX_GAP_SCANS {
            self.gap_scans.push(t);
        }
    }

    /// Adds the step between two consecutive scans tracked `ok`: `odometry_m` as the log's
    /// odometry reads it, `tracked_m` as tracked.
    pub(super) fn count_travel(&mut self, odometry_m: f64, tracked_m: f64) {
        if odometry_m.is_finite() && tracked_m.is_finite() {
            self.odometry_travel_m += odometry_m;
            self.tracked_travel_m += tracked_m;
        }
    }

    /// Whether the log's odometry travelled under half or over twice what the scans did, over
    /// at least `min_travel_m` of tracked travel: odometry that is stuck, scaled or not the
    /// robot's (see [`TrackingSummary::tracked_travel_m`]).
    pub fn odometry_disagrees_with_travel(&self, min_travel_m: f64) -> bool {
        self.odometry_within(min_travel_m, 2.0) == Some(false)
    }

    /// Whether the log's odometry travelled within [`ODOMETRY_WITNESS_WITHIN`] of what the
    /// scans did (see [`TrackingSummary::odometry_travel_m`]), over at least `min_travel_m` of
    /// tracked travel: odometry fit to witness the steps.
    pub fn odometry_agrees_with_travel(&self, min_travel_m: f64) -> bool {
        self.odometry_within(min_travel_m, ODOMETRY_WITNESS_WITHIN) == Some(true)
    }

    /// Over at least `min_travel_m` of tracked travel, whether the odometry's travel lies
    /// within `factor` of the scans' either way; `None` below it.
    fn odometry_within(&self, min_travel_m: f64, factor: f64) -> Option<bool> {
        let (odo, scans) = (self.odometry_travel_m, self.tracked_travel_m);
        (scans >= min_travel_m).then(|| odo >= scans / factor && odo <= scans * factor)
    }

    /// Takes the step to scan `t` into the run of weak scans: `weak` extends it (by
    /// `tracked_m`, `odometry_m` where the log has odometry, and `expected_m`, the step the
    /// speed last observed predicts; metres), anything else ends it; a run that reaches
    /// [`WEAK_STRETCH_M`] is listed, and updated while it goes on.
    pub(super) fn count_weak_step(
        &mut self,
        t: u32,
        weak: bool,
        tracked_m: f64,
        odometry_m: Option<f64>,
        expected_m: f64,
    ) {
        if !weak {
            self.open_weak = None;
            return;
        }
        let finite = |m: f64| if m.is_finite() { m } else { 0.0 };
        let (mut run, mut tracked, mut odometry, mut expected) = self.open_weak.take().unwrap_or((
            WeakStretch {
                first: t,
                last: t,
                travel_m: 0.0,
            },
            0.0,
            0.0,
            0.0,
        ));
        tracked += finite(tracked_m);
        odometry += odometry_m.map_or(0.0, finite);
        expected += finite(expected_m);
        run.last = t;
        run.travel_m = tracked.max(odometry).max(expected);
        if run.travel_m >= WEAK_STRETCH_M {
            match self.weak_stretches.last_mut() {
                Some(listed) if listed.first == run.first => *listed = run,
                _ => self.weak_stretches.push(run),
            }
        }
        self.open_weak = Some((run, tracked, odometry, expected));
    }

    /// Takes the tracked step to scan `t` (metres) into the travel; `weakly_observed` when the
    /// scan is weak because a direction was observed by few points or none.
    pub(super) fn count_step(&mut self, t: u32, tracked_m: f64, weakly_observed: bool) {
        if !tracked_m.is_finite() {
            return;
        }
        let weak_m = if weakly_observed { tracked_m } else { 0.0 };
        self.travel_m += tracked_m;
        self.weak_travel_m += weak_m;
        let part = self.open_part.get_or_insert(WeakTravelPart {
            first: t,
            ..WeakTravelPart::default()
        });
        part.last = t;
        part.travel_m += tracked_m;
        part.weak_travel_m += weak_m;
        if part.travel_m >= WEAK_TRAVEL_PART_M
            && let Some(done) = self.open_part.take()
        {
            self.keep_part(done);
        }
    }

    /// Lists a finished stretch whose weak share exceeds [`WEAK_TRAVEL_SHARE`], keeping the
    /// [`MAX_WEAK_TRAVEL_PARTS`] with the most weak travel, in scan order.
    fn keep_part(&mut self, part: WeakTravelPart) {
        if part.weak_travel_m <= WEAK_TRAVEL_SHARE * part.travel_m {
            return;
        }
        self.weak_travel_parts.push(part);
        if self.weak_travel_parts.len() > MAX_WEAK_TRAVEL_PARTS {
            let least = (0..self.weak_travel_parts.len())
                .min_by(|&a, &b| {
                    let w = |i: usize| self.weak_travel_parts[i].weak_travel_m;
                    w(a).total_cmp(&w(b))
                })
                .unwrap_or(0);
            self.weak_travel_parts.remove(least);
        }
    }

    /// Ends the stretch of travel going on (at the end of a run): listed when it is over half
    /// as long as the others and weak enough.
    pub(super) fn close_part(&mut self) {
        if let Some(part) = self.open_part.take()
            && part.travel_m >= 0.5 * WEAK_TRAVEL_PART_M
        {
            self.keep_part(part);
        }
    }

    /// Whether the travel on weakly observed steps exceeds [`WEAK_TRAVEL_SHARE`] of the travel,
    /// over at least [`WEAK_TRAVEL_MIN_M`] (see [`TrackingSummary::weak_travel_m`]).
    pub fn weak_travel_warns(&self) -> bool {
        self.travel_m >= WEAK_TRAVEL_MIN_M && self.weak_travel_m > WEAK_TRAVEL_SHARE * self.travel_m
    }

    /// Takes the step to scan `t` into the stretches tracked short of the odometry
    /// ([`TrackingSummary::short_of_odometry`]): `odometry_m` as the log's odometry read it,
    /// `tracked_m` as tracked (metres); `None` where the step does not follow the scan before
    /// (from or to a lost scan), which starts the window over.
    pub(super) fn count_witnessed_step(&mut self, t: u32, steps: Option<(f64, f64)>) {
        let Some((odometry_m, tracked_m)) = steps else {
            self.short_window.restart();
            return;
        };
        let Some(stretch) = self.short_window.push(t, odometry_m, tracked_m) else {
            return;
        };
        let listed = &mut self.short_of_odometry;
        match listed.last_mut() {
            Some(last) if last.first == stretch.first => *last = stretch,
            _ => {
                if listed.len() < MAX_SHORT_STRETCHES {
                    listed.push(stretch);
                }
            }
        }
    }

    /// Counts scan `t` as tracked off the log's odometry.
    pub(super) fn count_off_odometry(&mut self, t: u32) {
        self.off_odometry += 1;
        if self.off_odometry_scans.len() < MAX_GAP_SCANS {
            self.off_odometry_scans.push(t);
        }
    }

    pub(super) fn count(&mut self, t: u32, verdict: Verdict, reason: Reason) {
        match verdict {
            Verdict::Ok => self.ok += 1,
            Verdict::Weak => {
                self.weak += 1;
                self.weakly_observed += u32::from(reason == Reason::WeaklyObserved);
                let room = self.doubtful_ranges.len() < MAX_GAP_SCANS;
                if reason != Reason::WeaklyObserved {
                    match self.doubtful_ranges.last_mut() {
                        Some(r) if r[1] + 1 == t => r[1] = t,
                        _ if room => self.doubtful_ranges.push([t, t]),
                        _ => {}
                    }
                }
            }
            Verdict::Lost => {
                self.lost += 1;
                match self.lost_ranges.last_mut() {
                    Some(r) if r[1] + 1 == t => r[1] = t,
                    _ => self.lost_ranges.push([t, t]),
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weakly_observed_scans_are_counted_apart_within_the_weak() {
        let mut t = TrackingSummary::default();
        t.count(0, Verdict::Ok, Reason::Fit);
        t.count(1, Verdict::Weak, Reason::WeaklyObserved);
        t.count(2, Verdict::Weak, Reason::Degenerate);
        t.count(3, Verdict::Lost, Reason::Contradicted);
        t.count(4, Verdict::Lost, Reason::TooFewInliers);
        assert_eq!((t.ok, t.weak, t.weakly_observed, t.lost), (1, 2, 1, 2));
        assert_eq!(t.lost_ranges, vec![[3, 4]]);
        // summary.json files written before the field read as none.
        let old: TrackingSummary =
            serde_json::from_str(r#"{"ok": 3, "weak": 1, "lost": 0, "lost_ranges": []}"#).unwrap();
        assert_eq!(old.weakly_observed, 0);
        assert!(old.doubtful_ranges.is_empty());
    }

    #[test]
    fn scans_weak_for_a_doubt_are_kept_as_ranges_the_weakly_observed_not() {
        let mut t = TrackingSummary::default();
        let weak = [
            (1, Reason::PoorFit),
            (2, Reason::Ambiguous),
            (3, Reason::WeaklyObserved),
            (4, Reason::Degenerate),
            (6, Reason::Slowed),
        ];
        for (scan, reason) in weak {
            t.count(scan, Verdict::Weak, reason);
        }
        assert_eq!(t.doubtful_ranges, vec![[1, 2], [4, 4], [6, 6]]);
        // Bounded: at most `MAX_GAP_SCANS` ranges are kept, however many there are.
        for scan in (10..10 + 4 * MAX_GAP_SCANS as u32).step_by(2) {
            t.count(scan, Verdict::Weak, Reason::PoorFit);
        }
        assert_eq!(t.doubtful_ranges.len(), MAX_GAP_SCANS);
    }

    #[test]
    fn travel_on_weakly_observed_steps_warns_above_its_share_and_is_located() {
        let mut t = TrackingSummary::default();
        // 100 m in 1 m steps, every 20th weak: 5 %, no warning.
        for i in 0..100 {
            t.count_step(i, 1.0, i % 20 == 0);
        }
        t.close_part();
        assert!((t.travel_m - 100.0).abs() < 1e-9);
        assert!(!t.weak_travel_warns());
        assert!(t.weak_travel_parts.is_empty());
        // 30 m more with every other step weak: 20 % overall, the weak stretch named.
        for i in 100..130 {
            t.count_step(i, 1.0, i % 2 == 0);
        }
        t.close_part();
        assert!(t.weak_travel_warns());
        assert_eq!(t.weak_travel_parts.len(), 1);
        let part = t.weak_travel_parts[0];
        assert_eq!((part.first, part.last), (100, 124));
        assert!((part.weak_travel_m - 13.0).abs() < 1e-9);
        // Too little travel is not judged; a step that is not finite counts nothing.
        let mut short = TrackingSummary::default();
        for i in 0..10 {
            short.count_step(i, 1.0, true);
        }
        short.count_step(10, f64::NAN, true);
        assert!(!short.weak_travel_warns());
        assert!((short.travel_m - 10.0).abs() < 1e-9);
    }

    #[test]
    fn runs_of_weak_scans_over_ten_metres_are_weak_stretches() {
        let mut t = TrackingSummary::default();
        // Nine weak metres, then an `ok` scan: no stretch.
        for i in 0..9 {
            t.count_weak_step(i, true, 1.0, None, 0.0);
        }
        t.count_weak_step(9, false, 1.0, None, 0.0);
        assert!(t.weak_stretches.is_empty());
        // Weak from scan 10: listed once it reaches 10 m (scan 19), updated while it goes on,
        // ended by a scan that is not weak.
        for i in 10..25 {
            t.count_weak_step(i, true, 1.0, Some(0.5), 0.5);
            let listed = t.weak_stretches.len();
            assert_eq!(listed, usize::from(i >= 19), "scan {i}");
        }
        t.count_weak_step(25, false, 1.0, None, 0.0);
        let run = WeakStretch {
            first: 10,
            last: 24,
            travel_m: 15.0,
        };
        assert_eq!(t.weak_stretches, vec![run]);
        // A stall tracked at no motion where the log's odometry went on: the odometry's travel
        // counts; a step that is not finite counts nothing.
        for i in 30..42 {
            t.count_weak_step(i, true, 0.0, Some(1.0), 0.0);
        }
        t.count_weak_step(42, true, f64::NAN, Some(f64::INFINITY), f64::NAN);
        assert_eq!(t.weak_stretches.len(), 2);
        assert_eq!(t.weak_stretches[1].first, 30);
        assert_eq!(t.weak_stretches[1].last, 42);
        assert!((t.weak_stretches[1].travel_m - 12.0).abs() < 1e-12);
        // A corridor tracked short with no odometry (a sparse log's scans put near no motion
        // where the robot kept its speed of 1 m per scan): the speed's travel counts.
        t.count_weak_step(43, false, 1.0, None, 1.0);
        for i in 44..55 {
            t.count_weak_step(i, true, 0.05, None, 1.0);
        }
        assert_eq!(t.weak_stretches.len(), 3);
        assert_eq!(t.weak_stretches[2].first, 44);
        assert!((t.weak_stretches[2].travel_m - 11.0).abs() < 1e-12);
        // Serialized without the run going on.
        let json = serde_json::to_string(&t).expect("json");
        assert!(json.contains("\"weak_stretches\""), "{json}");
        assert!(!json.contains("open_weak"), "{json}");
    }
}
