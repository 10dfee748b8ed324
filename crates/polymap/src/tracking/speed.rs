//! The speed last observed ([`ObservedSpeed`]): the motion a robot keeps along directions ICP
//! cannot observe, and the time between scans that tells a gap in the log from jitter; the pose
//! and time a scan's reach is bounded from ([`reach_reference`]).

use super::estimator::acceleration_sigma_m_s2;
use crate::geometry::Pose2;

/// How many recent time steps give the typical one.
const TYPICAL_DT_STEPS: usize = 15;

/// A time step at least this many typical ones is a gap (scans missing from the log) that the
/// constant-velocity prediction spans ([`ObservedSpeed::gap_scale`]); below it, jitter.
const GAP_ABOVE_TYPICAL: f64 = 3.0;

/// The prediction spans at most this many typical time steps of a gap: beyond it a robot
/// seldom keeps its motion, and the window search and corner poses take over.
const GAP_SCALE_MAX: f64 = 20.0;

/// Stamps keep time when the last [`TYPICAL_DT_STEPS`] time steps increased and at most this
/// many of them lie outside half to twice the typical one (a gap just before allowed): a log
/// whose laser stamps bunch and stall (Intel's: 1 % of its windows of 15 are regular, and its
/// step per scan is the same whatever the time step) is not timed by them.
const IRREGULAR_STEPS_AT_MOST: usize = 1;

/// A motion step `m` (robot frame) times `k`: translation and turn scaled alike (a straight
/// extrapolation, close to the arc for the turns of a few scans).
pub(super) fn scaled(m: &Pose2, k: f64) -> Pose2 {
    Pose2::new(m.x_m * k, m.y_m * k, m.theta_rad * k)
}

/// A step that turns at least [`TURN_ON_THE_SPOT_AT_LEAST_RAD`] and moves under this many
/// metres per radian turned is a turn on the spot (its arc turns about a point within this
/// distance of the robot): its translation, about none, says nothing of the speed the robot
/// drives on at after the turn, so the observed speed keeps the translation of the last
/// driving step. Robots turn on the spot at
/// corridor junctions and then drive on into a corridor that may be bare; taking the turn's
/// standstill as the speed there held Intel at K = 10 in place at every junction.
const TURN_ON_THE_SPOT_M_PER_RAD: f64 = 0.3;

/// A turn on the spot turns at least this much, radians (about 6°): a standing robot's
/// millimetres of jitter with a fraction of a degree of turn are a stop, which sets the speed
/// to none.
const TURN_ON_THE_SPOT_AT_LEAST_RAD: f64 = 0.1;

/// A driving step of at least [`CRUISE_AT_LEAST_M`] after one under this share of its length
/// is the first out of a stop (or a crawl; [`ObservedSpeed`]): a step of acceleration, which
/// does not set the cruise speed.
const STOP_BELOW_SHARE: f64 = 0.25;

/// A driving step under this many metres is no evidence of a cruise speed (the jitter of a
/// robot standing, or creeping).
const CRUISE_AT_LEAST_M: f64 = 0.05;

/// The last motion observed between two scans (`mapper.keep_observed_velocity`): the step from
/// a scan tracked `ok` with every direction observed to the next such scan, robot frame of the
/// first; not from a step whose stamps say it spans a gap or a burst (under half or over twice
/// the median of the recent time steps), nor from a corner pose (a correction of the earlier
/// error, not a motion). A motion taken from the prior never updates it, so it cannot run on.
/// Its turn is the last observed step's; its translation is the last observed step's that was
/// no turn on the spot ([`TURN_ON_THE_SPOT_M_PER_RAD`]), a stop included, except right after
/// a stop: the first step of at least [`CRUISE_AT_LEAST_M`] out of a stop
/// ([`STOP_BELOW_SHARE`]) is one of acceleration, and its direction is taken at the cruise
/// speed the robot drove at before the stop (where that is faster). A robot that stood, drove off and entered a bare corridor was
/// otherwise driven through it at the speed of its first metre's fraction (ACES every 5th
/// scan: 0.19 m per scan where it went 0.5–0.7).
#[derive(Debug, Clone, Default)]
pub(super) struct ObservedSpeed {
    /// The last observed step, robot frame of the scan it started from.
    motion: Option<Pose2>,
    /// The last observed step that was no turn on the spot (same frame convention).
    driving: Option<Pose2>,
    /// The cruise speed, metres per scan: the length of the last observed driving step of at
    /// least [`CRUISE_AT_LEAST_M`] that was not the first out of a stop.
    cruise_m: Option<f64>,
    /// Whether the last observed driving step was the first out of a stop.
    out_of_stop: bool,
    last_observed: bool,
    last_stamp_s: Option<f64>,
    /// The recent positive time steps, seconds: a ring of [`TYPICAL_DT_STEPS`], the first
    /// `filled` valid, the next written at `next`.
    dts: [f64; TYPICAL_DT_STEPS],
    filled: usize,
    next: usize,
    /// [`ObservedSpeed::gap_scale`] of the last step recorded (1 before any).
    last_gap_scale: Option<f64>,
    /// Steps recorded since the last whose stamps did not increase (or were missing).
    in_time: usize,
    /// Seconds since the last observed step (the stamps' time of the steps since).
    unobserved_s: f64,
    /// The variance of the speed last observed, (m/s)² ([`ObservedSpeed::weigh`]); `None`
    /// before a timed observed step.
    speed_var: Option<f64>,
    /// The median of the recent time steps, once there are a third of the ring, seconds
    /// ([`ObservedSpeed::median_dt_s`], kept: it is asked for several times a scan and changes
    /// only when a time step is pushed).
    typical_dt_s: Option<f64>,
}

impl ObservedSpeed {
    /// The observed motion per scan, robot frame of the scan it starts from: the last observed
    /// step's turn, with the translation of the last observed step that was no turn on the spot
    /// (the last step's own when every observed step so far turned on the spot); when that
    /// step was the first out of a stop and slower than the cruise speed, its direction at the
    /// cruise speed (metres per scan).
    pub(super) fn motion(&self) -> Option<Pose2> {
        let turn = self.motion?;
        let along = self.driving.unwrap_or(turn);
        let len = along.translation().length();
        let k = match self.cruise_m {
            Some(cruise) if self.out_of_stop && cruise > len && len > 0.0 => cruise / len,
            _ => 1.0,
        };
        Some(Pose2::new(along.x_m * k, along.y_m * k, turn.theta_rad))
    }

    /// Takes the step to the scan just tracked (`None` for the first), whether that scan was
    /// observed (`ok`, every direction, not a corner pose), and its stamp (seconds). Returns
    /// whether the step set the speed as it is ([`ObservedSpeed::motion`]'s translation is the
    /// step's own: not an older driving step kept over a turn on the spot, nor a step out of a
    /// stop taken at the cruise speed).
    pub(super) fn record(
        &mut self,
        step: Option<Pose2>,
        observed: bool,
        stamp_s: Option<f64>,
    ) -> bool {
        self.last_gap_scale = Some(self.gap_ratio(stamp_s));
        let dt = match (self.last_stamp_s, stamp_s) {
            (Some(a), Some(b)) if b > a => Some(b - a),
            _ => None,
        };
        let typical = self.typical_dt_s;
        let usual = match (dt, typical) {
            (Some(dt), Some(m)) => (0.5 * m..=2.0 * m).contains(&dt),
            _ => true,
        };
        let taken = observed && self.last_observed && usual;
        self.unobserved_s = match taken && step.is_some() {
            true => 0.0,
            false => self.unobserved_s + dt.unwrap_or(0.0),
        };
        if let Some(step) = step.filter(|_| taken) {
            self.motion = Some(step);
            let turn_rad = step.theta_rad.abs();
            let on_the_spot = turn_rad >= TURN_ON_THE_SPOT_AT_LEAST_RAD
                && step.translation().length() < TURN_ON_THE_SPOT_M_PER_RAD * turn_rad;
            if !on_the_spot {
                self.drive(step);
            }
        }
        if let Some(dt) = dt {
            self.dts[self.next] = dt;
            self.next = (self.next + 1) % TYPICAL_DT_STEPS;
            self.filled = (self.filled + 1).min(TYPICAL_DT_STEPS);
            self.typical_dt_s = self.median_dt_s();
        }
        // A stamp that does not increase (or is missing) restarts the count of steps in time.
        self.in_time = match dt {
            Some(_) => self.in_time.saturating_add(1),
            None => 0,
        };
        self.last_observed = observed;
        self.last_stamp_s = stamp_s;
        step.filter(|_| taken).is_some_and(|step| {
            self.motion()
                .is_some_and(|m| m.translation() == step.translation())
        })
    }

    /// Takes an observed driving step (no turn on the spot): whether it is the first out of a
    /// stop, and the cruise speed.
    fn drive(&mut self, step: Pose2) {
        let len = step.translation().length();
        let last_m = self.driving.map_or(0.0, |d| d.translation().length());
        if len >= CRUISE_AT_LEAST_M {
            self.out_of_stop = last_m < STOP_BELOW_SHARE * len;
            if !self.out_of_stop {
                self.cruise_m = Some(len);
            }
        } else {
            self.out_of_stop = false;
        }
        self.driving = Some(step);
    }

    /// How many scans' worth of time the step to a scan stamped `stamp_s` spans: its time step
    /// over the typical one when that is at least [`GAP_ABOVE_TYPICAL`] (at most
    /// [`GAP_SCALE_MAX`]) and the stamps keep time (the last [`TYPICAL_DT_STEPS`] time steps
    /// increased, and at most [`IRREGULAR_STEPS_AT_MOST`] of those time steps lie outside half
    /// to twice the typical one); otherwise 1.
    pub(super) fn gap_scale(&self, stamp_s: Option<f64>) -> f64 {
        self.gap_ratio(stamp_s).min(GAP_SCALE_MAX)
    }

    /// [`ObservedSpeed::gap_scale`] before its cap: how many typical time steps a gap spans (1
    /// when the step is no gap, or the stamps do not keep time).
    fn gap_ratio(&self, stamp_s: Option<f64>) -> f64 {
        let (Some(a), Some(b)) = (self.last_stamp_s, stamp_s) else {
            return 1.0;
        };
        // Every step in time pushed a time step: the ring is full.
        let timed = self.in_time >= TYPICAL_DT_STEPS;
        let Some(typical) = self.typical_dt_s.filter(|_| timed) else {
            return 1.0;
        };
        let ratio = (b - a) / typical;
        match self.irregular_steps(typical) <= IRREGULAR_STEPS_AT_MOST && ratio >= GAP_ABOVE_TYPICAL
        {
            true => ratio,
            false => 1.0,
        }
    }

    /// The time step to a scan stamped `stamp_s`, seconds, when the stamps keep time: the
    /// last [`TYPICAL_DT_STEPS`] time steps increased and at most a fifth of them lie outside
    /// half to twice the typical one (laxer than a gap's test: only this step's own length is
    /// used), clamped to that range and to the longest gap the prediction spans. `None` where
    /// the stamps do not time the steps (Intel's bunch: a quarter of its time steps are 1 ms).
    pub(super) fn step_dt_s(&self, stamp_s: Option<f64>) -> Option<f64> {
        let (a, b) = (self.last_stamp_s?, stamp_s?);
        let typical = self
            .typical_dt_s
            .filter(|_| self.in_time >= TYPICAL_DT_STEPS)?;
        (self.irregular_steps(typical) <= TYPICAL_DT_STEPS / 5 && b > a)
            .then(|| (b - a).clamp(0.5 * typical, GAP_SCALE_MAX * typical))
    }

    /// How many of the recent time steps lie outside half to twice `typical` (seconds).
    fn irregular_steps(&self, typical: f64) -> usize {
        self.dts
            .iter()
            .filter(|&&dt| !(0.5 * typical..=2.0 * typical).contains(&dt))
            .count()
    }

    /// Takes how well the step just recorded told the speed, the step `dt_s` seconds long
    /// (`None` where the stamps do not time it): the spread along its weakest direction
    /// (`observed_sigma_m`, metres) of a step that set the speed ([`ObservedSpeed::record`]),
    /// over its time, sets the speed's variance; any other step grows it by what a robot's
    /// acceleration ([`acceleration_sigma_m_s2`], one standard deviation) changes a speed by
    /// over its time, `(σa·dt)²`, each step on its own (a random walk); an untimed step
    /// leaves the speed's spread unknown. A weakly observed step tells nothing: along a
    /// corridor its few points pull it where the map ends, and counting them narrowed the
    /// speed onto a stale one (the simulated corridor with a 360° laser every 2nd scan:
    /// 0.27 → 0.45 m).
    pub(super) fn weigh(&mut self, observed_sigma_m: Option<f64>, dt_s: Option<f64>) {
        let Some(dt) = dt_s.filter(|&dt| dt > 0.0) else {
            self.speed_var = None;
            return;
        };
        self.speed_var = match observed_sigma_m {
            Some(sigma) => Some((sigma / dt).powi(2)),
            None => self
                .speed_var
                .map(|v| v + (acceleration_sigma_m_s2() * dt).powi(2)),
        };
    }

    /// How far the constant-velocity prediction to a scan stamped `stamp_s` may lie from where
    /// the speed last observed puts the robot after the step's own time, metres: the
    /// prediction spans one scan's motion (a gap's many, [`ObservedSpeed::gap_scale`]), the
    /// step lasts its time step over the typical one; `None` where the stamps do not time it.
    pub(super) fn span_mismatch_m(&self, stamp_s: Option<f64>) -> Option<f64> {
        let (dt, typical) = (self.step_dt_s(stamp_s)?, self.typical_dt_s?);
        let per_scan_m = self.motion()?.translation().length();
        Some(per_scan_m * (dt / typical - self.gap_scale(stamp_s)).abs())
    }

    /// The standard deviation of the speed last observed, m/s ([`ObservedSpeed::weigh`]).
    pub(super) fn speed_sigma_m_s(&self) -> Option<f64> {
        self.speed_var.map(f64::sqrt)
    }

    /// Seconds since the last observed step, by the stamps (0 without them).
    pub(super) fn unobserved_s(&self) -> f64 {
        self.unobserved_s
    }

    /// How many typical time steps the last step recorded spans (the gap's whole time, not
    /// capped: the step covered all of it): 1 before any, and for a step that was no gap.
    pub(super) fn last_gap_scale(&self) -> f64 {
        self.last_gap_scale.unwrap_or(1.0)
    }

    /// The constant-velocity step to a scan stamped `stamp_s`, robot frame of the last scan:
    /// the last `step` per scan (divided by the gap it spanned), times this scan's
    /// [`ObservedSpeed::gap_scale`].
    pub(super) fn predicted_step(&self, step: &Pose2, stamp_s: Option<f64>) -> Pose2 {
        scaled(&self.one_step(step), self.gap_scale(stamp_s))
    }

    /// The last `step` per scan (divided by the gap it spanned), robot frame of the last
    /// scan: the motion over one typical time step.
    pub(super) fn one_step(&self, step: &Pose2) -> Pose2 {
        scaled(step, 1.0 / self.last_gap_scale())
    }

    /// The median of the recent time steps, once there are a third of the ring.
    fn median_dt_s(&self) -> Option<f64> {
        if self.filled < TYPICAL_DT_STEPS / 3 {
            return None;
        }
        let mut sorted = self.dts;
        let sorted = &mut sorted[..self.filled];
        sorted.sort_unstable_by(f64::total_cmp);
        Some(sorted[sorted.len() / 2])
    }
}

/// The pose a scan's motion is bounded from, and the seconds since it: the last `ok` pose is
/// where the robot was for sure, and the time since then bounds how far it can be now, when
/// the stamps say it (both known, increasing); otherwise `fallback` and no bound.
pub(super) fn reach_reference(
    last_ok: Option<(u32, Pose2, Option<f64>)>,
    stamp_s: Option<f64>,
    fallback: Pose2,
) -> (Pose2, Option<f64>) {
    match (last_ok, stamp_s) {
        (Some((_, pose, Some(a))), Some(b)) if b > a => (pose, Some(b - a)),
        _ => (fallback, None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_observed_speed_comes_only_from_observed_steps_at_the_usual_rate() {
        let step = Pose2::new(0.1, 0.0, 0.0);
        let mut speed = ObservedSpeed::default();
        // The first observed scan has no step; the second gives one.
        speed.record(None, true, Some(0.0));
        assert_eq!(speed.motion(), None);
        for k in 1..=10 {
            speed.record(Some(step), true, Some(0.1 * k as f64));
        }
        assert_eq!(speed.motion(), Some(step));
        // An unobserved scan's step (taken from the prior) never updates it, nor does the
        // next one, which starts from the unobserved scan.
        let filled = Pose2::new(0.3, 0.0, 0.0);
        speed.record(Some(filled), false, Some(1.1));
        speed.record(Some(filled), true, Some(1.2));
        assert_eq!(speed.motion(), Some(step));
        // A step across a gap (1 s where 0.1 s is usual) or a burst (1 ms) is no speed.
        speed.record(Some(filled), true, Some(2.2));
        speed.record(Some(filled), true, Some(2.201));
        assert_eq!(speed.motion(), Some(step));
        // Back at the usual rate it is.
        let faster = Pose2::new(0.15, 0.0, 0.0);
        speed.record(Some(faster), true, Some(2.3));
        assert_eq!(speed.motion(), Some(faster));
        // Without stamps every observed step counts.
        let mut unstamped = ObservedSpeed::default();
        unstamped.record(None, true, None);
        unstamped.record(Some(faster), true, None);
        assert_eq!(unstamped.motion(), Some(faster));
    }

    /// The speed's spread is an observed step's own, over its time, and grows with every step
    /// since by what a robot's acceleration changes a speed by; an untimed step unsets it.
    #[test]
    fn the_speeds_spread_is_the_observed_steps_own_and_grows_with_each_step_since() {
        let mut speed = ObservedSpeed::default();
        assert_eq!(speed.speed_sigma_m_s(), None);
        // An unobserved step before any observed one tells nothing.
        speed.weigh(None, Some(0.1));
        assert_eq!(speed.speed_sigma_m_s(), None);
        // A step observed to 5 mm over 0.1 s: the speed to 0.05 m/s.
        speed.weigh(Some(0.005), Some(0.1));
        assert!((speed.speed_sigma_m_s().unwrap() - 0.05).abs() < 1e-12);
        // Three steps of 0.1 s without evidence: (σa·dt)² each, 0.0025 + 3 × 0.01 / 13.8 (m/s)².
        for _ in 0..3 {
            speed.weigh(None, Some(0.1));
        }
        let grown = (0.0025 + 3.0 * (acceleration_sigma_m_s2() * 0.1).powi(2)).sqrt();
        assert!((grown - (0.0025f64 + 0.03 / 13.8).sqrt()).abs() < 1e-12);
        assert!((speed.speed_sigma_m_s().unwrap() - grown).abs() < 1e-12);
        // An untimed step leaves it unknown until the next observed step sets it anew.
        speed.weigh(None, None);
        assert_eq!(speed.speed_sigma_m_s(), None);
        speed.weigh(None, Some(0.1));
        assert_eq!(speed.speed_sigma_m_s(), None);
        speed.weigh(Some(0.002), Some(0.2));
        assert!((speed.speed_sigma_m_s().unwrap() - 0.01).abs() < 1e-12);
    }

    /// Only a step that set the speed as it is tells the speed's spread: not an unobserved
    /// step nor the first observed one after it, nor one at an unusual time step, nor a turn
    /// on the spot (the speed keeps the driving step before it), nor a step out of a stop
    /// taken at the cruise speed.
    #[test]
    fn a_step_sets_the_speed_only_where_the_speed_is_that_step() {
        let mut speed = ObservedSpeed::default();
        let drive = Pose2::new(0.5, 0.0, 0.0);
        assert!(!speed.record(None, true, Some(0.0)));
        for k in 1..=6 {
            assert!(speed.record(Some(drive), true, Some(0.1 * k as f64)));
        }
        assert!(!speed.record(Some(drive), false, Some(0.7)));
        assert!(!speed.record(Some(drive), true, Some(0.8)));
        assert!(speed.record(Some(drive), true, Some(0.9)));
        assert!(!speed.record(Some(drive), true, Some(0.901)));
        assert!(speed.record(Some(drive), true, Some(1.0)));
        assert!(!speed.record(Some(Pose2::new(0.02, 0.0, 0.9)), true, Some(1.2)));
        assert!(speed.record(Some(Pose2::new(0.01, 0.0, 0.0)), true, Some(1.3)));
        assert!(!speed.record(Some(Pose2::new(0.2, 0.0, 0.0)), true, Some(1.4)));
        assert!(speed.record(Some(Pose2::new(0.3, 0.0, 0.0)), true, Some(1.5)));
    }

    #[test]
    fn a_turn_on_the_spot_keeps_the_speed_driven_before_it() {
        let drive = Pose2::new(0.5, 0.01, 0.05);
        let turn = Pose2::new(0.04, 0.02, 0.9);
        let mut speed = ObservedSpeed::default();
        speed.record(None, true, None);
        speed.record(Some(drive), true, None);
        // A turn of 0.9 rad moving 4.5 cm (an arc about a point 5 cm away) is on the spot: the
        // motion turns as it did, and drives on at the speed before it.
        speed.record(Some(turn), true, None);
        assert_eq!(speed.motion(), Some(Pose2::new(0.5, 0.01, 0.9)));
        // A curve driven (0.5 m over 0.9 rad: a radius of 0.56 m) is driving, and so is a stop.
        let curve = Pose2::new(0.45, 0.2, 0.9);
        speed.record(Some(curve), true, None);
        assert_eq!(speed.motion(), Some(curve));
        let stop = Pose2::new(0.001, 0.0, 0.0);
        speed.record(Some(stop), true, None);
        assert_eq!(speed.motion(), Some(stop));
        // Before any driving step the turn's own translation is all there is.
        let mut spinning = ObservedSpeed::default();
        spinning.record(None, true, None);
        spinning.record(Some(turn), true, None);
        assert_eq!(spinning.motion(), Some(turn));
    }

    #[test]
    fn the_first_step_out_of_a_stop_goes_on_at_the_cruise_speed() {
        let mut speed = ObservedSpeed::default();
        speed.record(None, true, None);
        // Cruising at 0.6 m per scan (the first step, out of nothing, sets no cruise), then
        // standing (jitter of millimetres).
        for _ in 0..2 {
            speed.record(Some(Pose2::new(0.6, 0.0, 0.0)), true, None);
        }
        for _ in 0..5 {
            speed.record(Some(Pose2::new(0.004, 0.001, 0.0)), true, None);
        }
        assert_eq!(speed.motion(), Some(Pose2::new(0.004, 0.001, 0.0)));
        // The first step out of the stop (0.2 m, the robot accelerating) goes on at the cruise
        // speed in its own direction and turn.
        let start = Pose2::new(0.16, 0.12, 0.01);
        speed.record(Some(start), true, None);
        let m = speed.motion().unwrap();
        assert!(
            (m.x_m - 0.48).abs() < 1e-9 && (m.y_m - 0.36).abs() < 1e-9,
            "{m:?}"
        );
        assert_eq!(m.theta_rad, 0.01);
        // The next step sets the speed as it is, slower than the old cruise or not.
        let slower = Pose2::new(0.3, 0.0, 0.0);
        speed.record(Some(slower), true, None);
        assert_eq!(speed.motion(), Some(slower));
        // A step out of a stop faster than the cruise is taken as it is.
        speed.record(Some(Pose2::new(0.01, 0.0, 0.0)), true, None);
        let fast = Pose2::new(0.5, 0.0, 0.0);
        speed.record(Some(fast), true, None);
        assert_eq!(speed.motion(), Some(fast));
        // A standing robot's jitter, of any size and with a fraction of a degree of turn, is a
        // stop: no turn on the spot, no step out of a stop.
        let mut jitter = ObservedSpeed::default();
        jitter.record(None, true, None);
        for _ in 0..2 {
            jitter.record(Some(Pose2::new(0.6, 0.0, 0.0)), true, None);
        }
        for (x, y, t) in [
            (0.001, 0.0, 0.0),
            (0.0, -0.005, 0.004),
            (0.0, 0.0, 0.0),
            (0.002, 0.0, 0.009),
        ] {
            let step = Pose2::new(x, y, t);
            jitter.record(Some(step), true, None);
            assert_eq!(jitter.motion(), Some(step));
        }
        // Jitter sets no cruise speed: out of a stop with no cruise before, the step stands.
        let mut standing = ObservedSpeed::default();
        standing.record(None, true, None);
        for _ in 0..5 {
            standing.record(Some(Pose2::new(0.004, 0.0, 0.0)), true, None);
        }
        standing.record(Some(start), true, None);
        assert_eq!(standing.motion(), Some(start));
    }

    #[test]
    fn the_time_since_the_speed_was_observed_grows_until_a_step_is_observed() {
        let step = Some(Pose2::new(0.05, 0.0, 0.0));
        let mut speed = ObservedSpeed::default();
        speed.record(None, true, Some(0.0));
        speed.record(step, true, Some(0.1));
        assert_eq!(speed.unobserved_s(), 0.0);
        // Three weak scans: 0.3 s since the speed was observed.
        for k in 2..=4 {
            speed.record(step, false, Some(0.1 * k as f64));
        }
        assert!((speed.unobserved_s() - 0.3).abs() < 1e-9);
        // The first observed scan after them gives no step (its predecessor was weak)...
        speed.record(step, true, Some(0.5));
        assert!((speed.unobserved_s() - 0.4).abs() < 1e-9);
        // ...the next one does.
        speed.record(step, true, Some(0.6));
        assert_eq!(speed.unobserved_s(), 0.0);
    }

    #[test]
    fn a_gap_spans_its_time_only_where_the_stamps_keep_time() {
        let step = Some(Pose2::new(0.1, 0.0, 0.0));
        let mut speed = ObservedSpeed::default();
        for k in 0..=TYPICAL_DT_STEPS {
            speed.record(step, true, Some(0.1 * k as f64));
        }
        let last = 0.1 * TYPICAL_DT_STEPS as f64;
        assert!((speed.gap_scale(Some(last + 0.5)) - 5.0).abs() < 1e-9);
        // Jitter under three time steps is no gap; a long gap is spanned only so far.
        assert_eq!(speed.gap_scale(Some(last + 0.25)), 1.0);
        assert_eq!(speed.gap_scale(Some(last + 10.0)), GAP_SCALE_MAX);
        assert_eq!(speed.gap_scale(None), 1.0);
        // The step just recorded spanned a gap: the next prediction divides it back.
        speed.record(step, true, Some(last + 0.5));
        assert!((speed.last_gap_scale() - 5.0).abs() < 1e-9);
        // A stamp going back 1 s in an otherwise regular log: the next stamp, 1.1 s after it,
        // is no gap (the ring itself stays regular: only the count of steps in time says so),
        // nor is any until the stamps have kept time for a ring's worth again.
        let mut regular = ObservedSpeed::default();
        let mut t = 0.0;
        for _ in 0..=TYPICAL_DT_STEPS {
            t += 0.1;
            regular.record(step, true, Some(t));
        }
        regular.record(step, true, Some(t - 1.0));
        t += 0.1;
        assert_eq!(regular.gap_scale(Some(t)), 1.0);
        regular.record(step, true, Some(t));
        for _ in 0..TYPICAL_DT_STEPS - 1 {
            assert_eq!(regular.gap_scale(Some(t + 0.5)), 1.0);
            t += 0.1;
            regular.record(step, true, Some(t));
        }
        assert!((regular.gap_scale(Some(t + 0.5)) - 5.0).abs() < 1e-6);
        // A gap over the cap: the prediction spans at most the cap, and the next one divides
        // the step by the whole gap it spanned (not by the cap).
        assert_eq!(regular.gap_scale(Some(t + 5.0)), GAP_SCALE_MAX);
        regular.record(step, true, Some(t + 5.0));
        assert!((regular.last_gap_scale() - 50.0).abs() < 1e-6);
        let after = regular.predicted_step(&Pose2::new(5.0, 0.0, 0.0), Some(t + 5.1));
        assert!((after.x_m - 0.1).abs() < 1e-6, "{after:?}");
        // Uneven time steps (more than one of the ring off by over twice): no gap.
        let mut uneven = ObservedSpeed::default();
        let mut t = 0.0;
        for k in 0..=TYPICAL_DT_STEPS {
            t += if k % 3 == 0 { 0.5 } else { 0.1 };
            uneven.record(step, true, Some(t));
        }
        assert_eq!(uneven.gap_scale(Some(t + 1.0)), 1.0);
    }

    #[test]
    fn bunched_stamps_do_not_time_a_gap() {
        // Every other scan 1 ms after the one before: the stamps keep no time, and a long
        // step is no gap.
        let bunched = |i: usize| 0.2 * (i / 2) as f64 + 0.001 * (i % 2) as f64;
        let mut speed = ObservedSpeed::default();
        for i in 0..40 {
            speed.record(Some(Pose2::new(0.1, 0.0, 0.0)), true, Some(bunched(i)));
        }
        assert_eq!(speed.gap_scale(Some(bunched(55))), 1.0);
    }

    #[test]
    fn the_reach_is_bounded_only_when_the_stamps_increase() {
        let ok = Pose2::new(1.0, 2.0, 0.3);
        let fallback = Pose2::IDENTITY;
        let at = |stamp: Option<f64>| Some((7, ok, stamp));
        assert_eq!(
            reach_reference(at(Some(10.0)), Some(10.25), fallback),
            (ok, Some(0.25))
        );
        // Bunched, reordered or missing stamps say nothing about the time.
        for (last, now) in [
            (Some(10.0), Some(10.0)),
            (Some(10.0), Some(9.0)),
            (None, Some(1.0)),
            (Some(1.0), None),
        ] {
            assert_eq!(reach_reference(at(last), now, fallback), (fallback, None));
        }
        assert_eq!(reach_reference(None, Some(1.0), fallback), (fallback, None));
    }
}
