//! Stretches tracked short of the log's odometry ([`TrackingSummary::short_of_odometry`]):
//! where tracking stalls on steps it calls `ok`, no per-scan check sees it.
//!
//! Along a corridor whose few features along it are matched to the wrong ones (a short-range
//! laser; doubled door frames in the map), the fit can hold the robot a few centimetres a scan
//! short, and the speed last observed then predicts the stall: FR079 with the laser cut to
//! 5.6 m tracks 19 steps at −0.10 to +0.07 m where the robot drove 0.11 m a scan, each step
//! `ok` with 7–15 points' worth of information along the corridor, and each under the 0.3 m a
//! step must be off the odometry to count ([`OdometryWitness`](super::OdometryWitness)). Over a
//! few metres the steps tell: the median of the tracked step over the odometry's step falls
//! to 0.28 there, while accurate runs keep it at 0.58 or more over any 2 m.
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

/// A window whose median of tracked over odometry step is below this is short: the tracked
/// steps there are under half the odometry's. The dense benchmark logs, every 1st to 5th scan
/// without odometry, stay at 0.58 or above except where a step stalled (ACES every 3rd scan,
/// scans 1985–1992: 0.20, tracked 1.4 m short of the dense `--odometry` run's 2.5 m); runs of
/// every 10th scan within 0.1 m reach 0.46; the benchmark logs with the laser cut to 5.6 m
/// fall to 0.28 (FR079), 0.10 (Intel, ACES). Odometry that reads each step's length but not
/// its sign (FR079 backing up) is no stall: the lengths are compared, not the directions.
pub const SHORT_BELOW: f64 = 0.5;

/// At most this many stretches are listed.
pub const MAX_SHORT_STRETCHES: usize = 100;

/// A run of consecutive scans over which tracking fell short of the log's odometry
/// ([`TrackingSummary::short_of_odometry`](super::TrackingSummary::short_of_odometry)).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ShortStretch {
    /// The first scan of the stretch (scan index, 0-based; its step is from the scan before).
    pub first: u32,
    /// The last scan of the stretch (inclusive).
    pub last: u32,
    /// The odometry's travel over the stretch (its steps' lengths summed), metres.
    pub odometry_m: f64,
    /// The tracked travel over the same steps, metres.
    pub tracked_m: f64,
}

/// The last steps as the log's odometry and the tracking read them, over at least
/// [`SHORT_WINDOW_M`] and [`SHORT_WINDOW_STEPS`], and the short stretch going on.
#[derive(Debug, Clone, PartialEq, Default)]
pub(super) struct ShortWindow {
    /// Per step: the scan it leads to, the odometry's length and the tracked length, metres.
    steps: VecDeque<(u32, f64, f64)>,
    /// The odometry's travel over `steps`, metres.
    odometry_m: f64,
    /// The stretch the last window extended, while windows stay short, and the travel of
    /// its steps since its last short one (odometry, tracked; metres).
    open: Option<(ShortStretch, f64, f64)>,
}

impl ShortWindow {
    /// Takes the step to scan `t`, `odometry_m` as the log's odometry read it and `tracked_m`
    /// as tracked (metres). Returns the short stretch going on when the window ending at this
    /// step is short: from the first short step (tracked under [`SHORT_BELOW`] of the
    /// odometry's) of the first short window to the last short step since.
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
        if self.steps.len() < SHORT_WINDOW_STEPS || self.odometry_m < SHORT_WINDOW_M {
            return None;
        }
        let mut ratios: Vec<f64> = self.steps.iter().map(|&(_, o, tr)| tr / o).collect();
        let mid = ratios.len() / 2;
        let (_, median, _) = ratios.select_nth_unstable_by(mid, f64::total_cmp);
        if *median >= SHORT_BELOW {
            self.open = None;
            return None;
        }
        let short = |tracked_m: f64, odometry_m: f64| tracked_m < SHORT_BELOW * odometry_m;
        let stretch = match self.open.take() {
            // Steps between short ones join the stretch with the next short one.
            Some((mut open, mut pending_odometry_m, mut pending_tracked_m)) => {
                pending_odometry_m += odometry_m;
                pending_tracked_m += tracked_m;
                if short(tracked_m, odometry_m) {
                    open.last = t;
                    open.odometry_m += pending_odometry_m;
                    open.tracked_m += pending_tracked_m;
                    (pending_odometry_m, pending_tracked_m) = (0.0, 0.0);
                }
                (open, pending_odometry_m, pending_tracked_m)
            }
            // From the window's first short step to its last.
            None => {
                let from = self.steps.iter().position(|&(_, o, tr)| short(tr, o));
                let (mut open, mut pending) = (ShortStretch::default(), (0.0, 0.0));
                for &(s, o, tr) in self.steps.iter().skip(from.unwrap_or(0)) {
                    if open.odometry_m == 0.0 {
                        open.first = s;
                    }
                    pending = (pending.0 + o, pending.1 + tr);
                    if short(tr, o) {
                        open.last = s;
                        open.odometry_m += pending.0;
                        open.tracked_m += pending.1;
                        pending = (0.0, 0.0);
                    }
                }
                (open, pending.0, pending.1)
            }
        };
        self.open = Some(stretch);
        Some(stretch.0)
    }

    /// Starts over: the next step does not follow the last (a lost scan between them).
    pub(super) fn restart(&mut self) {
        *self = Self::default();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Steps of 0.11 m by the odometry from scan `first` on, tracked at `tracked(i)`.
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
    /// its last.
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
        assert!(last.tracked_m < 0.5 * last.odometry_m, "{last:?}");
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
        let mut w = ShortWindow::default();
        assert!(run(&mut w, 1, 5, |_| 0.0).is_empty());
        w.restart();
        assert!(
            run(&mut w, 10, 5, |_| 0.0).is_empty(),
            "five steps are no window"
        );
        assert!(!run(&mut w, 20, 20, |_| 0.0).is_empty(), "twenty are");
    }
}
