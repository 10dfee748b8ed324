//! A localize run's trajectory: its place from the saved map, its motion over a few seconds
//! from a map of its own.
//!
//! Tracking against a finished map puts each scan where that map's walls say. Those walls were
//! averaged over every pass and moved by every loop correction: right on the whole, a few
//! centimetres off in ways that differ from place to place, so two scans a second apart are
//! each put a little off on their own. Mapping tracks each scan against walls the last scans
//! built, off (if at all) in the same way for both: its motion over short spans is the more
//! precise (ACES' second half localized in the map its own mapping made: 0.0559 m mean error
//! over relations at most 10 s apart, against mapping's own 0.0421 m). A localize run therefore
//! also tracks its scans on a fresh map of their own ([`OwnMotion`]), and its trajectory takes
//! the motion from that map and the place from the saved map ([`fuse`]).

use crate::geometry::Pose2;
use crate::tracking::Verdict;

use super::Mapper;

/// A localize run's own tracking: its scans mapped on a fresh map of their own (no loop
/// closure: only the motion over a few seconds is used), with what [`fuse`] needs of each scan.
#[derive(Debug, Clone)]
pub(super) struct OwnMotion {
    mapper: Box<Mapper>,
    /// Per scan of the run: its time, seconds (its stamp plus `offset_s`, always after the scan
    /// before's: logs have stamps that step back or repeat, and a scan whose stamp does not
    /// advance, or has none, is taken `STEP_WITHOUT_STAMP_S` later; so at most three windows'
    /// worth of such scans fall in one scan's reach, however long the stamps stand still)...
    stamps_s: Vec<f64>,
    /// ...whether tracking on the saved map placed it (not lost)...
    placed: Vec<bool>,
    /// ...and whether its own tracking lost it (its own pose is a poor fit or a guess: its
    /// motion from the scans before and to those after is unknown).
    own_lost: Vec<bool>,
    /// What the stamps since the last clock set back (`SET_BACK_S`) are moved by, seconds.
    offset_s: f64,
}

/// A scan without a stamp is taken this long after the one before, seconds.
const STEP_WITHOUT_STAMP_S: f64 = 0.1;

/// A stamp more than this before the time of the scan before is a clock set back (a reset, logs
/// joined), not the jitter of a log's stamps (Intel's step back by up to 0.9 s), seconds: the
/// scan is taken `STEP_WITHOUT_STAMP_S` after the one before and the stamps after it count on
/// from there. Without it, every scan until the stamps caught up (never, after a reset) would
/// count `STEP_WITHOUT_STAMP_S` on from the one before, whatever its stamps say.
const SET_BACK_S: f64 = 2.0;

impl OwnMotion {
    /// Own tracking with `config` (loop closure off).
    pub(super) fn new(config: &crate::config::Config) -> Self {
        let mut config = config.clone();
        config.loops.enabled = false;
        OwnMotion {
            mapper: Box::new(Mapper::new(config).without_sightings()),
            stamps_s: Vec::new(),
            placed: Vec::new(),
            own_lost: Vec::new(),
            offset_s: 0.0,
        }
    }

    /// Tracks `scan` on the run's own map; `placed` whether the saved map's tracking placed it.
    pub(super) fn push(&mut self, scan: crate::scan::PreparedScan, placed: bool) {
        let previous = self.stamps_s.last().copied();
        let stamp = time_of(scan.stamp_s, previous, &mut self.offset_s);
        let update = self.mapper.push_prepared(scan);
        self.stamps_s.push(stamp);
        self.placed.push(placed);
        self.own_lost
            .push(update.diagnostics.tracking.verdict == Verdict::Lost);
    }

    /// The run's trajectory from `in_map` (each scan's pose from the saved map, with every
    /// correction) and its own motion (see [`fuse`]).
    pub(super) fn fused(&self, in_map: &[Pose2], window_s: f64) -> Vec<Pose2> {
        let own = self.mapper.trajectory();
        let samples: Vec<Sample> = (0..in_map.len().min(own.len()))
            .map(|i| Sample {
                in_map: in_map[i],
                placed: self.placed[i],
                own: own[i],
                own_lost: self.own_lost[i],
                stamp_s: self.stamps_s[i],
            })
            .collect();
        let mut fused = fuse(&samples, window_s);
        // Scans not taken by the own tracking (none, unless pushed past it) keep their pose.
        fused.extend_from_slice(&in_map[fused.len()..]);
        fused
    }
}

/// The time of a scan stamped `stamp_s` after a scan at time `previous_s` (see
/// [`OwnMotion`]'s `stamps_s`), seconds; `offset_s` is what the stamps are moved by since the
/// last clock set back, and moves on at the next.
fn time_of(stamp_s: Option<f64>, previous_s: Option<f64>, offset_s: &mut f64) -> f64 {
    match (stamp_s.map(|s| s + *offset_s), previous_s) {
        (Some(s), Some(p)) if s < p - SET_BACK_S => {
            *offset_s += p + STEP_WITHOUT_STAMP_S - s;
            p + STEP_WITHOUT_STAMP_S
        }
        (Some(s), Some(p)) if s <= p => p + STEP_WITHOUT_STAMP_S,
        (Some(s), Some(_)) => s,
        (Some(s), None) => s,
        (None, Some(p)) => p + STEP_WITHOUT_STAMP_S,
        (None, None) => 0.0,
    }
}

/// One scan of a localize run, for [`fuse`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Sample {
    /// Its pose from tracking on the saved map (map frame).
    pub in_map: Pose2,
    /// Whether that pose places it (it was not lost).
    pub placed: bool,
    /// Its pose on the run's own map (that map's frame).
    pub own: Pose2,
    /// Whether its own tracking lost it: its own motion from the scans before and to those
    /// after is unknown.
    pub own_lost: bool,
    /// Its time, seconds (always after the scan before's).
    pub stamp_s: f64,
}

/// Each scan's pose from the others' places and its own motion: every placed scan `j` within
/// three `window_s` of scan `i` (neither of them, nor any scan between them, lost by its own
/// tracking, unless `j` is `i`) puts `i` at `in_map_j ∘ (own_j⁻¹ ∘ own_i)`; the pose is their
/// average weighted by a Gaussian of the time between (standard deviation `window_s`). Over spans shorter than the window the motion is the
/// own map's; over longer ones the place follows the saved map. A scan with no placed scan in
/// reach, and every scan with `window_s` 0, keeps its pose from the saved map.
pub(crate) fn fuse(samples: &[Sample], window_s: f64) -> Vec<Pose2> {
    let n = samples.len();
    if window_s <= 0.0 {
        return samples.iter().map(|s| s.in_map).collect();
    }
    let reach_s = 3.0 * window_s;
    // Each scan's span of one unbroken own motion. A scan its own tracking lost is a span of
    // its own: its own pose is a poor fit or a guess, so its motion to the scans after it is
    // as unknown as from those before.
    let mut span = Vec::with_capacity(n);
    let mut id = 0_usize;
    for s in samples {
        id += usize::from(s.own_lost);
        span.push(id);
        id += usize::from(s.own_lost);
    }
    (0..n)
        .map(|i| {
            let here = &samples[i];
            let (mut x, mut y, mut sin, mut cos, mut weights) = (0.0, 0.0, 0.0, 0.0, 0.0);
            let mut add = |j: usize| {
                let there = &samples[j];
                let dt = (there.stamp_s - here.stamp_s).abs();
                if dt > reach_s {
                    return false;
                }
                if there.placed {
                    let w = (-0.5 * (dt / window_s).powi(2)).exp();
                    let p = there.in_map.compose(&there.own.between(&here.own));
                    x += w * p.x_m;
                    y += w * p.y_m;
                    sin += w * p.theta_rad.sin();
                    cos += w * p.theta_rad.cos();
                    weights += w;
                }
                true
            };
            for j in (0..=i).rev() {
                if span[j] != span[i] || !add(j) {
                    break;
                }
            }
            for j in i + 1..n {
                if span[j] != span[i] || !add(j) {
                    break;
                }
            }
            if weights > 0.0 {
                Pose2::new(x / weights, y / weights, sin.atan2(cos))
            } else {
                here.in_map
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(t: f64, in_map: Pose2, own: Pose2) -> Sample {
        Sample {
            in_map,
            placed: true,
            own,
            own_lost: false,
            stamp_s: t,
        }
    }

    /// A robot driving straight at 1 m/s, its own motion exact, its poses on the saved map
    /// jittering by ±3 cm across the track from scan to scan: the fused trajectory keeps the
    /// own motion's steps and the saved map's place.
    #[test]
    fn the_steps_come_from_the_own_motion_and_the_place_from_the_saved_map() {
        let samples: Vec<Sample> = (0..200)
            .map(|i| {
                let t = i as f64 * 0.1;
                let jitter = if i % 2 == 0 { 0.03 } else { -0.03 };
                // The own map's frame: turned and shifted against the saved map's.
                let own = Pose2::new(5.0, -2.0, 1.0).compose(&Pose2::new(t, 0.0, 0.0));
                sample(t, Pose2::new(t, 1.0 + jitter, 0.0), own)
            })
            .collect();
        let fused = fuse(&samples, 3.0);
        for (i, p) in fused.iter().enumerate() {
            let t = i as f64 * 0.1;
            assert!((p.x_m - t).abs() < 1e-9, "{i}: {p:?}");
            assert!((p.y_m - 1.0).abs() < 0.01, "{i}: {p:?}");
            assert!(p.theta_rad.abs() < 1e-9, "{i}: {p:?}");
        }
        let raw_step = samples[100].in_map.between(&samples[101].in_map);
        let step = fused[100].between(&fused[101]);
        assert!((raw_step.y_m.abs() - 0.06).abs() < 1e-9);
        assert!(step.y_m.abs() < 1e-3, "{step:?}");
        // Without a window, the saved map's poses as they were.
        let unfused = fuse(&samples, 0.0);
        assert!(unfused.iter().zip(&samples).all(|(p, s)| *p == s.in_map));
    }

    /// A scan its own tracking lost breaks the own motion: a jump of the own map there moves
    /// neither side, and lost places on the saved map count for nothing.
    #[test]
    fn a_scan_the_own_tracking_lost_breaks_the_own_motion() {
        let mut samples: Vec<Sample> = (0..100)
            .map(|i| {
                let t = i as f64 * 0.1;
                let own_x = if i < 50 { t } else { t + 2.0 };
                sample(t, Pose2::new(t, 0.0, 0.0), Pose2::new(own_x, 0.0, 0.0))
            })
            .collect();
        samples[50].own_lost = true;
        samples[20].placed = false;
        samples[20].in_map = Pose2::new(40.0, 40.0, 2.0);
        let fused = fuse(&samples, 3.0);
        for (i, p) in fused.iter().enumerate() {
            let t = i as f64 * 0.1;
            assert!((p.x_m - t).abs() < 1e-9 && p.y_m.abs() < 1e-9, "{i}: {p:?}");
        }
        // Without the break, the jump leaks into the scans around it.
        samples[50].own_lost = false;
        let leaked = fuse(&samples, 3.0);
        assert!((leaked[49].x_m - 4.9).abs() > 0.1, "{:?}", leaked[49]);
    }

    fn times(stamps: &[Option<f64>]) -> Vec<f64> {
        let (mut out, mut offset_s) = (Vec::<f64>::new(), 0.0);
        for s in stamps {
            let t = time_of(*s, out.last().copied(), &mut offset_s);
            out.push(t);
        }
        out
    }

    /// Stamps that step back a little are held at the time before; a clock set back (here by
    /// 100 s) counts on from the time before, so that the scans after it do not all fall on one
    /// time; a scan without a stamp is one step later.
    #[test]
    fn times_never_step_back_and_a_clock_set_back_counts_on() {
        let stamps = [
            Some(100.0),
            Some(100.1),
            Some(99.5),
            Some(100.3),
            None,
            Some(0.0),
            Some(0.1),
            Some(0.2),
        ];
        let expected = [100.0, 100.1, 100.2, 100.3, 100.4, 100.5, 100.6, 100.7];
        for (t, e) in times(&stamps).iter().zip(expected) {
            assert!((t - e).abs() < 1e-9, "{:?}", times(&stamps));
        }
    }

    /// Stamps that stand still (a driver that stamps every scan alike) count on one scan step
    /// each: no scan has the whole run in its window.
    #[test]
    fn stamps_that_stand_still_count_on() {
        let stamps = vec![Some(5.0); 1000];
        let t = times(&stamps);
        assert!(t.windows(2).all(|w| w[1] > w[0]), "{:?}", &t[..5]);
        assert!((t[999] - t[0] - 999.0 * STEP_WITHOUT_STAMP_S).abs() < 1e-6);
    }

    /// A scan its own tracking lost keeps a poor fit (or the motion prior's guess) on the own
    /// map, while the scans after it are tracked on that map again: its own pose moves neither
    /// itself nor the scans after it.
    #[test]
    fn a_scan_the_own_tracking_lost_moves_nothing_by_its_own_pose() {
        let mut samples: Vec<Sample> = (0..100)
            .map(|i| {
                let t = i as f64 * 0.1;
                sample(t, Pose2::new(t, 0.0, 0.0), Pose2::new(t, 0.0, 0.0))
            })
            .collect();
        samples[50].own_lost = true;
        samples[50].own = Pose2::new(6.0, 0.5, 0.3);
        let fused = fuse(&samples, 3.0);
        for (i, p) in fused.iter().enumerate() {
            let t = i as f64 * 0.1;
            assert!(
                (p.x_m - t).abs() < 1e-9 && p.y_m.abs() < 1e-9 && p.theta_rad.abs() < 1e-9,
                "{i}: {p:?}"
            );
        }
    }
}
