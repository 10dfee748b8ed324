//! The verdict on each scan ([`Verdict`], [`Reason`], [`Tracking`]) from its final fit, what
//! it means for the map ([`Tracking::enters_map`]) and for the state carried to the next scan
//! ([`Tracking::carries_tracking`]), and the log's odometry as a witness of the step
//! ([`OdometryWitness`]).
//!
//! Each scan gets a [`Verdict`]: `ok`, `weak` (ICP left a direction unobservable, so the pose
//! along it comes from the prior: a bare corridor; or a fit in some doubt) or `lost` (too few
//! points fit anywhere).

use serde::{Deserialize, Serialize};

use super::params::TrackParams;
use crate::align::AlignResult;
use crate::geometry::{Pose2, Vec2};

/// How well a scan was tracked.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// A confident match in every direction.
    #[default]
    Ok,
    /// A match, but some direction was unobservable and came from the motion prior.
    Weak,
    /// No confident match: the pose is the best fit found, but the scan does not enter the map.
    Lost,
}

/// Why a scan got its verdict.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Reason {
    /// The first scan, or a scan with nothing to align to: it starts the map.
    #[default]
    Start,
    /// Enough points fit, every direction observed.
    Fit,
    /// Enough points fit, but some direction was unobservable (a bare corridor).
    Degenerate,
    /// Enough points fit, but one direction is observed by few of them (a corridor with little
    /// across it): the pose may have slid along it (`tracking.verdict.weak_below_information`).
    WeaklyObserved,
    /// Enough points fit, but a robot that moved fast lately was put near "no motion" along a
    /// direction observed by few of them (`tracking.verdict.slowed_below_information`): its step may
    /// have been pulled short.
    Slowed,
    /// Enough points fit, but without the odometry prior the log's odometry, which has agreed
    /// with the scans so far, puts the step more than `tracking.odometry.odometry_witness_m` from the
    /// one tracked ([`OdometryWitness`]): the scans or the odometry slipped there.
    OffOdometry,
    /// Enough points fit to keep the scan, too few to trust it.
    PoorFit,
    /// The window search found a distinct pose that explains the scan about as well (on its
    /// raster, or by ICP from its pose).
    Ambiguous,
    /// Most points near a wall are not on it: the pose contradicts the map.
    Contradicted,
    /// Too few points fit, even after the window search.
    TooFewInliers,
    /// The scan has no valid points.
    NoPoints,
    /// A run on a saved map has not placed itself yet: no pose of the map explains the scan
    /// confidently, or the searches of the last scans do not yet agree on one.
    NotFound,
}

/// The tracking outcome of one scan.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Tracking {
    /// The verdict.
    pub verdict: Verdict,
    /// Why.
    pub reason: Reason,
    /// ICP's inliers over the (thinned) scan points: `[0, 1]`, except that a point matched point
    /// to point to a loose blob counts two (x and y), so it may exceed 1 a little.
    pub inlier_share: f64,
    /// Whether the correlative window search ran.
    pub searched: bool,
    /// Whether a searched pose won over ICP from the prediction: the window search's, the
    /// recovery's, or ICP's from a pose along an axis ICP observed weakly or not at all (the
    /// last may win where the window search did not run).
    pub search_won: bool,
    /// Whether ICP from a corner hypothesis ([`crate::tracking::corner_seeds`]) won, or where
    /// none did, from a step like the robot's own ([`crate::tracking::StepsSeen`]): the scan
    /// moved beyond the window search.
    #[serde(default)]
    pub corner_won: bool,
    /// Map-frame direction, degrees in `[0, 180)`, along which translation was unobservable,
    /// when one was.
    pub weak_direction_deg: Option<f64>,
}

/// The log's odometry as a witness of one step, where it is not the motion prior: the pose
/// the step starts from and the odometry's translation since. The tracker offers it only once
/// the odometry has agreed with the scans (see
/// `TrackingSummary::odometry_agrees_with_travel`): a stuck or scaled odometry witnesses
/// nothing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdometryWitness {
    /// The pose the step starts from, map frame: the previous scan's, or after lost scans the
    /// last `ok` one's.
    pub previous: Pose2,
    /// The odometry's translation from that scan to this one, robot frame of that scan,
    /// metres.
    pub step: Vec2,
}

impl OdometryWitness {
    /// Whether the tracked step to `pose` (map frame) lies more than `off_above_m` from the
    /// odometry's, or from its reverse: odometry that reads a reverse as forward (FR079's)
    /// still witnesses the step's length and line, not its sense. Never when `off_above_m`
    /// is 0.
    pub fn contradicts(&self, pose: &Pose2, off_above_m: f64) -> bool {
        let tracked = self.previous.between(pose).translation();
        let off = (tracked - self.step)
            .length()
            .min((tracked + self.step).length());
        off_above_m > 0.0 && off > off_above_m
    }
}

impl Tracking {
    /// Whether tracking carries on from this scan as from an `ok` one (the speed observed, the
    /// last `ok` pose that bounds the reach, the odometry's travel check) and the mapper counts
    /// its sightings in the support of the walls: `ok`, or `weak` only as `slowed` or
    /// `off_odometry`. Those verdicts tell the user the step may be wrong; tracking from it is
    /// unchanged, since keeping such scans out of that state reshuffles the sparse runs
    /// (`docs/ARCHITECTURE.md`, "The verdict and what a run says"), and the odometry's travel check,
    /// which decides whether the odometry may witness at all, must see every step it judges.
    pub fn carries_tracking(&self) -> bool {
        self.verdict == Verdict::Ok
            || (self.verdict == Verdict::Weak
                && matches!(self.reason, Reason::Slowed | Reason::OffOdometry))
    }

    /// Whether the scan's segments enter the map: never for a `lost` scan; not for one `weak`
    /// for a poor fit or an ambiguous search unless `merge_doubtful_scans`; not for one placed
    /// by a corner hypothesis unless it is `ok` (a pose away from the prediction enters the
    /// map only when the scan fits there without doubt; the scan still tracks from it) or
    /// only `off_odometry`, a label: keeping those out too takes ACES every 5th scan, phase 2,
    /// from 0.076 to 0.330 m.
    pub fn enters_map(&self, merge_doubtful_scans: bool) -> bool {
        let doubtful = matches!(self.reason, Reason::PoorFit | Reason::Ambiguous);
        let confident = self.verdict == Verdict::Ok || self.reason == Reason::OffOdometry;
        self.verdict != Verdict::Lost
            && (merge_doubtful_scans || !doubtful)
            && (!self.corner_won || confident)
    }
}

/// The verdict on a scan from its final alignment.
pub fn verdict(
    result: Option<&AlignResult>,
    thinned_points: usize,
    first: bool,
    params: &TrackParams,
) -> Tracking {
    let Some(r) = result else {
        let reason = if first || thinned_points > 0 {
            Reason::Start
        } else {
            Reason::NoPoints
        };
        let verdict = if reason == Reason::Start {
            Verdict::Ok
        } else {
            Verdict::Lost
        };
        return Tracking {
            verdict,
            reason,
            ..Tracking::default()
        };
    };
    let share = r.inliers as f64 / thinned_points.max(1) as f64;
    let ratio = r.inliers as f64 / r.correspondences.max(1) as f64;
    let (verdict, reason) = if share < params.verdict.lost_below_inlier_share {
        (Verdict::Lost, Reason::TooFewInliers)
    } else if ratio < params.verdict.lost_below_inlier_ratio {
        (Verdict::Lost, Reason::Contradicted)
    } else if share < params.verdict.weak_below_inlier_share
        || ratio < params.verdict.weak_below_inlier_ratio
    {
        (Verdict::Weak, Reason::PoorFit)
    } else if r.weak_directions > 0 {
        (Verdict::Weak, Reason::Degenerate)
    } else if r.translation_information.weakest < params.verdict.weak_below_information {
        (Verdict::Weak, Reason::WeaklyObserved)
    } else {
        (Verdict::Ok, Reason::Fit)
    };
    let weak_direction_deg = match reason {
        Reason::WeaklyObserved => Some(r.translation_information.weakest_deg),
        _ => r.weak_direction_deg,
    };
    Tracking {
        verdict,
        reason,
        inlier_share: share,
        searched: false,
        search_won: false,
        corner_won: false,
        weak_direction_deg,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::align::TranslationInformation;

    #[test]
    fn lost_doubtful_and_unsure_corner_scans_stay_out_of_the_map() {
        let at = |verdict, reason, corner_won| Tracking {
            verdict,
            reason,
            corner_won,
            ..Tracking::default()
        };
        let ok = at(Verdict::Ok, Reason::Fit, false);
        assert!(ok.enters_map(false) && ok.enters_map(true));
        let lost = at(Verdict::Lost, Reason::Contradicted, false);
        assert!(!lost.enters_map(true));
        let poor = at(Verdict::Weak, Reason::PoorFit, false);
        assert!(poor.enters_map(true) && !poor.enters_map(false));
        let slid = at(Verdict::Weak, Reason::WeaklyObserved, false);
        assert!(slid.enters_map(false));
        let corner_ok = at(Verdict::Ok, Reason::Fit, true);
        assert!(corner_ok.enters_map(true));
        for reason in [Reason::Ambiguous, Reason::WeaklyObserved, Reason::PoorFit] {
            assert!(!at(Verdict::Weak, reason, true).enters_map(true));
        }
        // `off_odometry` is a label: a corner pose enters the map and tracking carries on
        // from it as from an `ok` one.
        let witnessed = at(Verdict::Weak, Reason::OffOdometry, true);
        assert!(witnessed.enters_map(false) && witnessed.carries_tracking());
        assert!(!slid.carries_tracking() && !poor.carries_tracking() && ok.carries_tracking());
    }

    #[test]
    fn the_odometry_witnesses_the_steps_line_not_its_sense() {
        let previous = Pose2::new(1.0, 2.0, std::f64::consts::FRAC_PI_2);
        // The odometry read 1 m ahead (robot frame): map frame +y from `previous`.
        let witness = OdometryWitness {
            previous,
            step: Vec2::new(1.0, 0.0),
        };
        let at = |x: f64, y: f64| Pose2::new(x, y, 0.0);
        assert!(!witness.contradicts(&at(1.0, 3.0), 0.3));
        assert!(!witness.contradicts(&at(1.2, 3.1), 0.3));
        // Backwards 1 m: the odometry's line, in reverse (odometry that reads a reverse as
        // forward).
        assert!(!witness.contradicts(&at(1.0, 1.0), 0.3));
        // A stall, half the step, a step sideways.
        assert!(witness.contradicts(&at(1.0, 2.0), 0.3));
        assert!(witness.contradicts(&at(1.0, 2.5), 0.3));
        assert!(witness.contradicts(&at(2.0, 2.0), 0.3));
        // 0 turns it off.
        assert!(!witness.contradicts(&at(1.0, 2.0), 0.0));
    }

    #[test]
    fn verdicts_follow_the_share_and_the_weak_directions() {
        let p = TrackParams::default();
        let mut r = AlignResult {
            map_from_robot: Pose2::IDENTITY,
            iterations: 3,
            correspondences: 100,
            inliers: 90,
            residual_rms_m: 0.01,
            converged: true,
            weak_directions: 0,
            weak_direction_deg: None,
            translation_information: TranslationInformation {
                weakest: 50.0,
                strongest: 100.0,
                weakest_deg: 0.0,
                ..Default::default()
            },
            weighed_prior: false,
        };
        assert_eq!(verdict(Some(&r), 100, false, &p).verdict, Verdict::Ok);
        r.weak_directions = 1;
        assert_eq!(verdict(Some(&r), 100, false, &p).verdict, Verdict::Weak);
        r.weak_directions = 0;
        r.inliers = 30;
        r.correspondences = 40;
        assert_eq!(verdict(Some(&r), 100, false, &p).reason, Reason::PoorFit);
        r.correspondences = 100;
        r.inliers = 10;
        assert_eq!(verdict(Some(&r), 100, false, &p).verdict, Verdict::Lost);
        r.inliers = 45;
        assert_eq!(
            verdict(Some(&r), 100, false, &p).reason,
            Reason::Contradicted
        );
        r.correspondences = 50;
        assert_eq!(verdict(Some(&r), 100, false, &p).verdict, Verdict::Ok);
        assert_eq!(verdict(None, 0, false, &p).verdict, Verdict::Lost);
        assert_eq!(verdict(None, 10, true, &p).verdict, Verdict::Ok);
    }
}
