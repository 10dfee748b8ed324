//! Stretches tracked short of the log's odometry ([`TrackingSummary::short_of_odometry`]):
//! where tracking stalls on steps it calls `ok`, no per-scan check sees it.
//!
//! Along a corridor whose few features along it are matched to the wrong ones (a short-range
//! laser; doubled door frames in the map), the fit can hold the robot a few centimetres a scan
//! short, and the speed last observed then predicts the stall: FR079 with the laser cut to
//! 5.6 m tracks 19 steps at −0.10 to +0.07 m where the robot drove 0.11 m a scan, each step
//! `ok` with 7–15 points' worth of information along the corridor, and each under the 0.3 m a
//! step must be off the odometry to count ([`OdometryWitness`](super::OdometryWitness)). Over a
//! few metres the steps tell: the median of tracked over odometry step length falls to 0.28
//! there. Lengths are compared, not directions: odometry that reads a step's length but not its
//! sign (FR079 backing up) is no stall.
//!
//! [`TrackingSummary::short_of_odometry`]: super::TrackingSummary::short_of_odometry

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

/// A window spans at least this much of the odometry's travel, metres...
pub const SHORT_WINDOW_M: f64 = 2.0;

/// ...and at least this many steps: at every 10th scan of a log, 2 m are four steps, whose
/// median one door frame matched a step off decides.
pub const SHORT_WINDOW_STEPS: usize = 8;

/// Steps the odometry reads shorter than this, metres, are left out: a robot standing or
/// turning on the spot says nothing of a stall, and the tracked step's centimetre of noise is
/// no ratio to it.
pub const SHORT_MIN_STEP_M: f64 = 0.02;

/// A window is short where the median of its steps' tracked over odometry length (the upper
/// one of an even count: more than half the steps must be short) is below this: the tracked
/// steps there are under half the odometry's. Measured, the lowest window median of a run: the
/// dense benchmark logs without odometry 0.63 (ACES), 0.80, 0.83; every 2nd to 10th scan
/// (phases 0-4) 0.55 or more except where steps stalled: ACES every 3rd scan, scans 1925-1991,
/// 0.25 (a corridor 1.4 m short of the dense `--odometry` run over 2.5 m), and ACES every 10th
/// scan, phases 0-3, 0.09-0.35 (phase 1, 0.017 m on its one scored relation, tracked 0.3 m
/// steps where the robot drove 0.8 m); the benchmark logs with the laser cut to 5.6 m 0.28
/// (FR079), 0.11 (Intel), 0.12 (ACES).
pub const SHORT_BELOW: f64 = 0.5;

/// At most this many stretches are listed.
pub const MAX_SHORT_STRETCHES: usize = 100;

/// A run of consecutive scans over which tracking fell short of the log's odometry
/// ([`TrackingSummary::short_of_odometry`](super::TrackingSummary::short_of_odometry)): from
/// the first short step (tracked under [`SHORT_BELOW`] of the odometry's length) of its first
/// short window to the last short step of a short window overlapping it.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ShortStretch {
    /// The first scan of the stretch (scan index, 0-based; its step is from the scan before).
    pub first: u32,
    /// The last scan of the stretch (inclusive).
    pub last: u32,
    /// The odometry's travel over the stretch (the lengths of its steps of at least
    /// [`SHORT_MIN_STEP_M`] summed), metres.
    pub odometry_m: f64,
    /// The lowest median over its windows of tracked over odometry step length (under
    /// [`SHORT_BELOW`]; 0: tracked at no motion).
    pub median_ratio: f64,
}

/// The last steps as the log's odometry and the tracking read them, over at least
/// [`SHORT_WINDOW_M`] and [`SHORT_WINDOW_STEPS`], and the short stretch going on.
#[derive(Debug, Clone, PartialEq, Default)]
pub(super) struct ShortWindow {
    /// Per step: the scan it leads to, the odometry's length and the tracked length, metres.
    steps: VecDeque<(u32, f64, f64)>,
    /// The odometry's travel over `steps`, metres.
    odometry_m: f64,
    /// The stretch going on, and the odometry's travel of its steps since its last short one
    /// (metres): it goes on while the window holds one of its steps, short or not.
    open: Option<(ShortStretch, f64)>,
    /// The last scan of the last stretch: a later one starts after it.
    closed_last: Option<u32>,
    /// The window's ratios, partly ordered to find the median (kept to reuse its allocation).
    ratios: Vec<f64>,
}

impl ShortWindow {
    /// Takes the step to scan `t`, `odometry_m` as the log's odometry read it and `tracked_m`
    /// as tracked (metres). Returns the stretch going on when it changed: a short window
    /// starts one (from its first short step after the last stretch) or extends the one whose
    /// steps it holds.
    pub(super) fn push(&mut self, t: u32, odometry_m: f64, tracked_m: f64) -> Option<ShortStretch> {
        if !(odometry_m.is_finite() && tracked_m.is_finite()) || odometry_m < SHORT_MIN_STEP_M {
            return None;
        }
        self.steps.push_back((t, odometry_m, tracked_m));
        self.odometry_m += odometry_m;
        // The shortest window ending here that spans both bounds.
        while let Some(&(_, front_m, _)) = self.steps.front() {
            let enough = self.steps.len() > SHORT_WINDOW_STEPS
                && self.odometry_m - front_m >= SHORT_WINDOW_M;
            if !enough {
                break;
            }
            self.steps.pop_front();
            self.odometry_m -= front_m;
        }
        let front = self.steps.front().map_or(t, |s| s.0);
        // A stretch the window no longer holds is over.
        if let Some((open, _)) = self.open
            && open.last < front
        {
            self.closed_last = Some(open.last);
            self.open = None;
        }
        let Some(median) = self.median().filter(|&m| m < SHORT_BELOW) else {
            if let Some((_, pending_m)) = &mut self.open {
                *pending_m += odometry_m;
            }
            return None;
        };
        let mut open = match self.open.take() {
            Some(mut open) => {
                extend(&mut open, t, odometry_m, tracked_m);
                open
            }
            // From the window's first short step after the last stretch.
            None => {
                let after = |s: u32| self.closed_last.is_none_or(|last| s > last);
                let steps = self
                    .steps
                    .iter()
                    .skip_while(|&&(s, o, tr)| !(after(s) && is_short(tr, o)));
                let &(first, _, _) = steps.clone().next()?;
                let mut open = (
                    ShortStretch {
                        first,
                        last: first,
                        odometry_m: 0.0,
                        median_ratio: median,
                    },
                    0.0,
                );
                for &(s, o, tr) in steps {
                    extend(&mut open, s, o, tr);
                }
                open
            }
        };
        open.0.median_ratio = open.0.median_ratio.min(median);
        self.open = Some(open);
        Some(open.0)
    }

    /// The window's median ratio of tracked over odometry step length (the upper median),
    /// once it spans both bounds.
    fn median(&mut self) -> Option<f64> {
        if self.steps.len() < SHORT_WINDOW_STEPS || self.odometry_m < SHORT_WINDOW_M {
            return None;
        }
        self.ratios.clear();
        self.ratios
            .extend(self.steps.iter().map(|&(_, o, tr)| tr / o));
        let mid = self.ratios.len() / 2;
        let (_, median, _) = self.ratios.select_nth_unstable_by(mid, f64::total_cmp);
        Some(*median)
    }

    /// Starts over: the next step does not follow the last (a lost scan between them). A
    /// stretch going on ends.
    pub(super) fn restart(&mut self) {
        let closed_last = self.open.map(|(open, _)| open.last).or(self.closed_last);
        *self = Self {
            closed_last,
            ..Self::default()
        };
    }
}

/// Whether a step tracked `tracked_m` where the odometry read `odometry_m` is short.
fn is_short(tracked_m: f64, odometry_m: f64) -> bool {
    tracked_m < SHORT_BELOW * odometry_m
}

/// Takes the step to scan `t` into the stretch going on (with the odometry's travel since its
/// last short step, metres): a short step ends the stretch there, with the steps before it.
fn extend(open: &mut (ShortStretch, f64), t: u32, odometry_m: f64, tracked_m: f64) {
    let (stretch, pending_m) = open;
    *pending_m += odometry_m;
    if is_short(tracked_m, odometry_m) {
        stretch.last = t;
        stretch.odometry_m += *pending_m;
        *pending_m = 0.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Steps of 0.11 m by the odometry from scan `first` on, tracked at `tracked(t)`; the
    /// stretches as they were returned.
    fn run(
        window: &mut ShortWindow,
        first: u32,
        n: u32,
        tracked: impl Fn(u32) -> f64,
    ) -> Vec<ShortStretch> {
        (first..first + n)
            .filter_map(|t| window.push(t, 0.11, tracked(t)))
            .collect()
    }

    #[test]
    fn steps_tracked_as_the_odometry_read_them_are_not_short() {
        let mut w = ShortWindow::default();
        assert!(run(&mut w, 1, 100, |t| if t % 2 == 0 { 0.10 } else { 0.12 }).is_empty());
    }

    /// The short-laser FR079 stall: 19 steps tracked at about no motion (some backwards:
    /// their lengths count) among steps of 0.11 m; one stretch, from its first short step to
    /// its last, with the odometry's travel over it and the lowest median.
    #[test]
    fn a_stall_among_driven_steps_is_one_stretch() {
        let mut w = ShortWindow::default();
        let stalled = |t: u32| (30..49).contains(&t);
        let found = run(&mut w, 1, 80, |t| match stalled(t) {
            true => [0.02, 0.09, 0.01, 0.04][t as usize % 4],
            false => 0.11,
        });
        let last = *found.last().expect("the stall is found");
        assert!(found.iter().all(|s| s.first == last.first), "{found:?}");
        assert_eq!((last.first, last.last), (30, 48), "{last:?}");
        assert!((last.odometry_m - 19.0 * 0.11).abs() < 1e-9, "{last:?}");
        // The window of the stall's 19 steps: five of 0.01 m, five of 0.02 m, the median.
        assert!((last.median_ratio - 0.02 / 0.11).abs() < 1e-9, "{last:?}");
    }

    /// Where the median wavers about [`SHORT_BELOW`] (every other step short: windows of
    /// nineteen steps hold ten short ones, then nine), the stretch goes on; two stalls further
    /// apart than a window are two stretches that do not overlap.
    #[test]
    fn a_stall_is_one_stretch_however_its_median_wavers_and_two_do_not_overlap() {
        let mut w = ShortWindow::default();
        let short = |t: u32| (20..60).contains(&t) && t.is_multiple_of(2) || (90..110).contains(&t);
        let found = run(&mut w, 1, 140, |t| if short(t) { 0.0 } else { 0.11 });
        let mut stretches: Vec<ShortStretch> = Vec::new();
        for s in found {
            match stretches.last_mut() {
                Some(last) if last.first == s.first => *last = s,
                _ => stretches.push(s),
            }
        }
        let ranges: Vec<(u32, u32)> = stretches.iter().map(|s| (s.first, s.last)).collect();
        assert_eq!(ranges, [(20, 58), (90, 109)], "{stretches:?}");
    }

    /// Short steps a few scans long (one door frame matched a step off) do not make the
    /// median of a window; a robot turning on the spot (odometry steps under 2 cm) is no
    /// evidence; a lost scan starts the window over.
    #[test]
    fn a_few_short_steps_a_turn_on_the_spot_or_a_restart_are_not_a_stretch() {
        let mut w = ShortWindow::default();
        assert!(
            run(&mut w, 1, 60, |t| if (20..23).contains(&t) {
                0.0
            } else {
                0.11
            })
            .is_empty()
        );
        assert!((100..200).all(|t| w.push(t, 0.01, 0.0).is_none()));
        // Ten steps of 0.11 m on each side of a restart: twenty would be a window.
        let mut w = ShortWindow::default();
        assert!(run(&mut w, 1, 10, |_| 0.0).is_empty());
        w.restart();
        assert!(
            run(&mut w, 20, 10, |_| 0.0).is_empty(),
            "ten steps are no window"
        );
        let mut w = ShortWindow::default();
        assert!(!run(&mut w, 1, 20, |_| 0.0).is_empty(), "twenty are");
    }
}
