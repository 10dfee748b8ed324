//! What the last scans leave for the next: their largest steps and turns ([`RecentMotion`],
//! which sizes the window search), the steps the robot was seen to make ([`StepsSeen`], the
//! own-step hypotheses) and their points that no map segment explains ([`LoosePoints`],
//! which the search raster and ICP match).

use super::verdict::{Tracking, Verdict};
use crate::align::AlignResult;
use crate::geometry::{Pose2, Vec2, normalize_angle_rad};

/// The largest step and turn over the last few scans.
#[derive(Debug, Clone, Default)]
pub struct RecentMotion {
    steps: std::collections::VecDeque<(f64, f64)>,
}

impl RecentMotion {
    /// How many scans are remembered.
    pub const SCANS: usize = 5;

    /// Records the motion from one scan's pose to the next's.
    pub fn push(&mut self, from: &Pose2, to: &Pose2) {
        let d = from.between(to);
        self.steps.push_back((
            d.translation().length(),
            normalize_angle_rad(d.theta_rad).abs(),
        ));
        while self.steps.len() > Self::SCANS {
            self.steps.pop_front();
        }
    }

    /// The longest recent step, metres (0 before any).
    pub fn step_m(&self) -> f64 {
        self.steps.iter().map(|s| s.0).fold(0.0, f64::max)
    }

    /// The largest recent turn, degrees (0 before any).
    pub fn turn_deg(&self) -> f64 {
        self.steps
            .iter()
            .map(|s| s.1)
            .fold(0.0, f64::max)
            .to_degrees()
    }
}

/// The steps the robot was seen to make: each motion into a scan tracked `ok` (or only
/// `slowed`) with every direction observed, not placed by a corner pose, from the scan just
/// before when that one was tracked `ok` (or `slowed`); as its length (negative for a step
/// backed) and signed turn, the last [`STEPS_SEEN`]. What a robot did
/// once it may do again: where the prediction and its window lose a scan (a robot that drove
/// 3 m between scans after steps of 1 m), a step like one of these finds it
/// ([`StepsSeen::hypotheses`]). On a dense log every step rounds to no motion, and the one
/// hypothesis is the previous pose. Apart, the sure steps (between two scans tracked `ok`, each
/// observed along every translation by at least `tracking.verdict.slowed_below_information`
/// points' worth) tell the robot's usual step for a turn ([`StepsSeen::usual_length`]).
#[derive(Debug, Clone, Default)]
pub struct StepsSeen {
    steps: std::collections::VecDeque<(f64, f64)>,
    /// The sure steps: between two scans each tracked `ok` and observed well along every
    /// translation.
    sure: std::collections::VecDeque<(f64, f64)>,
    /// Whether the scan of the last step taken in ([`StepsSeen::record`]) was tracked sure.
    last_sure: bool,
}

/// Sure steps turned within this of a step's turn tell its usual length, degrees...
pub const USUAL_TURN_DEG: f64 = 10.0;

/// ...when at least this many.
pub const USUAL_MIN_STEPS: usize = 8;

/// How many steps [`StepsSeen`] remembers: several minutes of a sparse log's travel, so that a
/// long step seen early still counts.
pub const STEPS_SEEN: usize = 300;

/// The own-step hypotheses take the steps' lengths to this, metres (about ICP's reach from a
/// start, so that one of them lies in the basin of any step of a length seen)...
pub const OWN_STEP_LENGTH_M: f64 = 0.5;

/// ...and their turns to this, degrees.
pub const OWN_STEP_TURN_DEG: f64 = 15.0;

/// ...and take at most this many lengths and turns each, the most often seen (each pair
/// costs a screening ICP run: 36 at most). Eight of each tracked the sparse logs alike; four
/// lost Orebro's 3 m step (a length seen only a few times).
pub const OWN_STEP_VALUES: usize = 6;

impl StepsSeen {
    /// Records a step (the motion from one scan's pose to the next's, robot frame of the
    /// first): its length, negative for a step backed (behind the first pose), and its turn.
    pub fn push(&mut self, step: &Pose2) {
        keep_last(&mut self.steps, step);
    }

    /// Takes in the step into a scan: `step` where it is one the robot was seen to make
    /// ([`StepsSeen::push`]; `None` otherwise), and also a sure step ([`StepsSeen::push_sure`])
    /// where this scan and the one before were both tracked sure (`tracked_sure`: `ok`, every translation observed well).
    pub fn record(&mut self, step: Option<&Pose2>, sure: bool) {
        if let Some(step) = step {
            self.push(step);
            if sure && self.last_sure {
                self.push_sure(step);
            }
        }
        self.last_sure = sure;
    }

    /// Records a sure step (between two scans each tracked `ok` and observed well along every
    /// translation), as [`StepsSeen::push`] does.
    pub fn push_sure(&mut self, step: &Pose2) {
        keep_last(&mut self.sure, step);
    }

    /// The usual length of a step turned by about `turn` (radians): the median signed length
    /// of the sure steps turned within `USUAL_TURN_DEG` of it, with half their interquartile
    /// range, metres; `None` with fewer than `USUAL_MIN_STEPS` such steps.
    pub fn usual_length(&self, turn: f64) -> Option<(f64, f64)> {
        let mut lengths: Vec<f64> = self
            .sure
            .iter()
            .filter(|s| normalize_angle_rad(s.1 - turn).abs() <= USUAL_TURN_DEG.to_radians())
            .map(|s| s.0)
            .collect();
        if lengths.len() < USUAL_MIN_STEPS {
            return None;
        }
        lengths.sort_by(f64::total_cmp);
        let at = |q: f64| lengths[((lengths.len() - 1) as f64 * q).round() as usize];
        Some((at(0.5), (at(0.75) - at(0.25)) / 2.0))
    }

    /// Steps like the robot's own (robot frame of the pose they start from): every length
    /// seen (to [`OWN_STEP_LENGTH_M`]) with every turn seen (to [`OWN_STEP_TURN_DEG`]), and
    /// none, each length driven along the arc's chord (at half the turn), backed for a length
    /// seen backed, standing still for a length of 0; empty while no step was seen.
    pub fn hypotheses(&self) -> Vec<Pose2> {
        if self.steps.is_empty() {
            return Vec::new();
        }
        let lengths = most_seen(self.steps.iter().map(|s| s.0), OWN_STEP_LENGTH_M);
        let turn_q = OWN_STEP_TURN_DEG.to_radians();
        let turns = most_seen(self.steps.iter().map(|s| s.1), turn_q);
        let mut out = Vec::with_capacity(lengths.len() * turns.len());
        for &d in &lengths {
            for &t in &turns {
                out.push(Pose2::new(d * (t / 2.0).cos(), d * (t / 2.0).sin(), t));
            }
        }
        out
    }
}

/// Whether a scan was tracked sure: `ok`, with every translation observed by at least
/// `below` points' worth (`tracking.verdict.slowed_below_information`, the information under
/// which a short step is doubted: `slowed`, and the robot's usual step checks it).
pub fn tracked_sure(tracking: &Tracking, align: Option<&AlignResult>, below: f64) -> bool {
    tracking.verdict == Verdict::Ok
        && align.is_some_and(|a| a.translation_information.weakest >= below)
}

/// Appends `step` to `steps` as its signed length (negative behind) and turn, keeping the last
/// [`STEPS_SEEN`]; a step that is not finite is left out.
fn keep_last(steps: &mut std::collections::VecDeque<(f64, f64)>, step: &Pose2) {
    let length = step.translation().length();
    let (length, turn) = (
        if step.x_m < 0.0 { -length } else { length },
        normalize_angle_rad(step.theta_rad),
    );
    if !(length.is_finite() && turn.is_finite()) {
        return;
    }
    steps.push_back((length, turn));
    while steps.len() > STEPS_SEEN {
        steps.pop_front();
    }
}

/// The values (rounded to multiples of `q`) seen most often, at most [`OWN_STEP_VALUES`],
/// 0 always among them, in increasing order (ties to the smaller in size, then the positive:
/// a length driven, a turn to the left).
fn most_seen(values: impl Iterator<Item = f64>, q: f64) -> Vec<f64> {
    let mut counts: std::collections::BTreeMap<i64, usize> = std::collections::BTreeMap::new();
    for v in values {
        *counts.entry((v / q).round() as i64).or_default() += 1;
    }
    counts.insert(0, usize::MAX);
    let mut by_count: Vec<(i64, usize)> = counts.into_iter().collect();
    by_count.sort_by(|a, b| {
        let size = |k: i64| (k.unsigned_abs(), k < 0);
        b.1.cmp(&a.1).then(size(a.0).cmp(&size(b.0)))
    });
    let mut kept: Vec<i64> = by_count
        .into_iter()
        .take(OWN_STEP_VALUES)
        .map(|(k, _)| k)
        .collect();
    kept.sort_unstable();
    kept.into_iter().map(|k| k as f64 * q).collect()
}

/// With `tracking.icp_loose_points`, a loose point at least this far from every map segment is
/// one the map leaves unexplained, metres (closer, it is a sample of a mapped wall, which
/// ICP matches to the segment).
pub const LOOSE_OFF_MAP_M: f64 = 0.15;

/// Keeps the loose points of the last scans: points of a tracked scan (robot frame, placed by
/// `map_from_robot`) farther than `off_m` from the map, thinned.
#[derive(Debug, Clone, Default)]
pub struct LoosePoints {
    scans: std::collections::VecDeque<Vec<Vec2>>,
}

impl LoosePoints {
    /// Adds one scan's points (map frame, already filtered to those off the map), keeping the
    /// last `keep_scans` scans.
    pub fn push(&mut self, points_in_map: Vec<Vec2>, keep_scans: usize) {
        self.scans.push_back(points_in_map);
        while self.scans.len() > keep_scans {
            self.scans.pop_front();
        }
    }

    /// Every kept point, map frame.
    pub fn all(&self) -> Vec<Vec2> {
        self.scans.iter().flatten().copied().collect()
    }

    /// Moves every kept point by `new_from_old` (a loop correction).
    pub fn transform(&mut self, new_from_old: &Pose2) {
        for p in self.scans.iter_mut().flatten() {
            *p = new_from_old.transform_point(*p);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn own_step_hypotheses_pair_every_length_seen_with_every_turn_seen() {
        let mut seen = StepsSeen::default();
        assert!(seen.hypotheses().is_empty());
        for _ in 0..3 {
            seen.push(&Pose2::new(1.05, 0.02, 0.01));
            seen.push(&Pose2::new(0.02, 0.0, 40f64.to_radians()));
        }
        let h = seen.hypotheses();
        // Lengths 0 and 1 m, turns 0 and 45°: four steps, none the zero step twice.
        assert_eq!(h.len(), 4, "{h:?}");
        let half = 22.5f64.to_radians();
        assert!(has(&h, 0.0, 0.0, 0.0) && has(&h, 1.0, 0.0, 0.0) && has(&h, 0.0, 0.0, 45.0));
        assert!(has(&h, half.cos(), half.sin(), 45.0), "{h:?}");
    }

    #[test]
    fn the_usual_step_is_the_median_of_the_sure_steps_turned_alike() {
        let mut seen = StepsSeen::default();
        // Seven drives of about 1 m and eight turns on the spot: too few drives to tell.
        for l in [0.9, 0.95, 1.0, 1.0, 1.05, 1.1, 1.2] {
            seen.push_sure(&Pose2::new(l, 0.0, 2f64.to_radians()));
        }
        for _ in 0..8 {
            seen.push_sure(&Pose2::new(0.01, 0.0, 35f64.to_radians()));
        }
        // `push` alone (a step after a `slowed` scan) tells nothing of the usual step.
        seen.push(&Pose2::new(0.0, 0.0, 0.0));
        assert_eq!(seen.usual_length(0.0), None);
        seen.push_sure(&Pose2::new(-1.0, 0.0, -9f64.to_radians()));
        let (usual, spread) = seen.usual_length(0.0).expect("eight drives");
        // Sorted: -1.0, 0.9, 0.95, 1.0, 1.0, 1.05, 1.1, 1.2; quartiles 0.95 and 1.05.
        assert!((usual - 1.0).abs() < 1e-9 && (spread - 0.05).abs() < 1e-9);
        let (on_the_spot, _) = seen.usual_length(40f64.to_radians()).expect("eight turns");
        assert!((on_the_spot - 0.01).abs() < 1e-9);
    }

    /// Whether `h` holds the step `(x, y)` metres turning `deg` degrees.
    fn has(h: &[Pose2], x: f64, y: f64, deg: f64) -> bool {
        h.iter().any(|p| {
            (p.x_m - x).abs() < 1e-9
                && (p.y_m - y).abs() < 1e-9
                && (p.theta_rad.to_degrees() - deg).abs() < 1e-9
        })
    }

    #[test]
    fn a_step_seen_backed_is_proposed_backed() {
        let mut seen = StepsSeen::default();
        seen.push(&Pose2::new(-0.97, 0.26, -30f64.to_radians()));
        let h = seen.hypotheses();
        // Backed 1 m turning −30°: along the chord at −15°, behind; nothing ahead.
        let half = -15f64.to_radians();
        assert!(has(&h, -half.cos(), -half.sin(), -30.0), "{h:?}");
        assert!(h.iter().all(|p| p.x_m <= 0.0), "{h:?}");
    }

    #[test]
    fn own_step_ties_go_to_the_shorter_step_then_the_one_driven() {
        let mut seen = StepsSeen::default();
        // Seven lengths and seven turns, each seen once: 0 and five of each are kept, the
        // smaller in size first, then the length driven (the turn to the left): not the 2.5 m
        // backed, nor the turn of 45° to the right.
        let lengths_m = [-2.5, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0];
        let turns_deg = [-45.0, 15.0, -15.0, 30.0, -30.0, 45.0, 60.0];
        for (length_m, turn_deg) in lengths_m.into_iter().zip(turns_deg) {
            seen.push(&Pose2::new(length_m, 0.0, f64::to_radians(turn_deg)));
        }
        let h = seen.hypotheses();
        let mut lengths: Vec<f64> = h
            .iter()
            .map(|p| (p.x_m.hypot(p.y_m).copysign(p.x_m) * 1e3).round() / 1e3)
            .collect();
        lengths.sort_by(f64::total_cmp);
        lengths.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
        assert_eq!(lengths, [0.0, 0.5, 1.0, 1.5, 2.0, 2.5], "{h:?}");
        let mut turns: Vec<i64> = h
            .iter()
            .map(|p| p.theta_rad.to_degrees().round() as i64)
            .collect();
        turns.sort_unstable();
        turns.dedup();
        assert_eq!(turns, [-30, -15, 0, 15, 30, 45], "{h:?}");
    }

    #[test]
    fn own_step_hypotheses_keep_the_values_seen_most_often() {
        let mut seen = StepsSeen::default();
        for k in 1..=12 {
            // Length k × 0.5 m seen k times: 0 and the most often seen are kept.
            for _ in 0..k {
                seen.push(&Pose2::new(0.5 * k as f64, 0.0, 0.0));
            }
        }
        seen.push(&Pose2::new(f64::NAN, 0.0, 0.0));
        let h = seen.hypotheses();
        let mut lengths: Vec<f64> = h.iter().map(|p| p.x_m).collect();
        lengths.dedup();
        let expect: Vec<f64> = std::iter::once(0.0)
            .chain((14 - OWN_STEP_VALUES..=12).map(|k| 0.5 * k as f64))
            .collect();
        assert_eq!(lengths, expect);
        // The memory is bounded.
        for _ in 0..2 * STEPS_SEEN {
            seen.push(&Pose2::new(1.0, 0.0, 0.0));
        }
        assert_eq!(seen.steps.len(), STEPS_SEEN);
    }
}
