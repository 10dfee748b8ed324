//! The alignment strategy of tracking: where ICP starts, which result wins, when the window
//! search runs and when its pose wins, the whole-circle recovery, and the verdict.
//!
//! The [`Tracker`](super::Tracker) gathers its state into a [`TrackInput`] (the scan, the map, the motion prior's
//! guess and anchor, the recent motion, how many scans in a row were lost) and asks
//! [`track_scan`] for a pose and a verdict. In order:
//!
//! 1. **Starts**: the guess; the anchor when they differ (`mapper.also_start_at_anchor`: a
//!    constant-velocity guess is wrong when a turn starts, stops or reverses); with the
//!    odometry prior, the constant-velocity guess when it disagrees with odometry
//!    (`tracking.odometry.odometry_check_m`, `odometry_check_deg`: a slip, a bad turn; its pose
//!    overrules the odometry's only with a fit, [`Attempt::overrules_odometry`], and by ratio
//!    where the odometry's spread contradicts it, [`Attempt::prefers`]); after a lost
//!    scan (a poor fit, which the guess and anchor come from), the last `ok` pose (with the
//!    odometry prior moved by the odometry since then, [`TrackInput::restart`]); the best coarse
//!    rotation ([`rotation_search`]) when the robot turned faster than ICP's basin. With
//!    `mapper.icp_from_best_start_only`, ICP runs only from the start with the best soft
//!    inlier score (the first start kept unless beaten by `START_SCORE_MARGIN`);
//!    otherwise from each, and the [`better`] fit wins. Where that fits under
//!    `tracking.search.search_below_inlier_share` of the points and odometry disagrees with the
//!    constant-velocity guess, also from the best coarse rotation around the latter (a stalled
//!    wheel reads a turn the robot did not make); where it still fits poorly, with the
//!    odometry prior, also from the odometry's motion since the last `ok` scan reversed
//!    (`tracking.reversed_odometry`: odometry that reads the distance but not the direction),
//!    a pose that must win clearly ([`Attempt::wins_clearly`]).
//! 2. **Recovery**: when under `mapper.recover_below_inlier_share` of the points are inliers
//!    (not with the odometry prior), a window search over the whole circle within
//!    [`RECOVER_TRANSLATION_M`] of the anchor, ICP from its best pose and rival; kept only when
//!    it fits well and doubles the inliers, and only when turned from the guess no farther
//!    than the window search's rotation window; a pose turned farther is held until the window
//!    search has run and replaces its pose only where both are the same or it fits
//!    `CORNER_WIN_RATIO` times the points (plus two): the whole circle holds a building's
//!    twins ([`Attempt::settle`]).
//! 3. **Window search** when ICP's basin may not reach ([`should_search`]): the window of
//!    [`search_window`] (where ICP fits poorly, as wide as the recent motion; with the
//!    odometry prior towards the constant-velocity guess where odometry disagrees with it: its
//!    heading always, its position up to `tracking.search.max_window_m`; after a gap in the log, as
//!    far as the robot can go and turn in its time), or the whole map every
//!    `RELOCALIZE_EVERY_LOST` scans lost in a row; ICP from its best pose replaces
//!    ICP from the starts only with `SEARCH_WIN_MARGIN` more inliers (plus two); without
//!    odometry, a pose the speed's spread excludes against one it allows only by ratio
//!    ([`Attempt::against_speed`], as for every candidate below).
//!    A robot that stood still and still fits poorly is searched again as far as it can turn
//!    since the last `ok` scan, a turn on the spot; that pose must win by
//!    `CORNER_WIN_RATIO` ([`Attempt::turned_on_the_spot`]).
//!    Without odometry, a pose ICP put on its fallback (`TrackInput::unobserved_to`: the
//!    previous pose, or moved by the last observed motion) along a direction it could not
//!    observe is searched too, and the search's
//!    pose wins when ICP from it observes every direction with at least as many inliers
//!    (`tracking.search_unobserved`: evidence against none); when it does not, ICP from
//!    poses along that direction up to `UNOBSERVED_REACH_M` either side may win by
//!    the same test, unless two distinct ones pass ([`Attempt::along_unobserved`]). A pose
//!    ICP observed along a direction only weakly, more than [`PRIOR_OVER_WEAK_M`] from the
//!    fallback, is replaced by ICP from the fallback's place along that direction (at the
//!    pose's own heading) when that fits as well ([`Attempt::prior_over_weak`]). When that
//!    did not win (or was not tried, the pose lying near the fallback), the weak axis is the
//!    fit's only doubt (its verdict would be `weakly_observed`), the pose lies within
//!    [`STOPPED_BELOW_SHARE_OF_STEP`] of the longest
//!    recent step from the anchor (ahead, in the sense of the speed last observed where that
//!    moves at least `tracking.search.search_above_step_m` along the axis), and that
//!    step is at least `tracking.search.search_above_step_m` (a fast robot that ICP, on weak
//!    evidence, says stopped, slowed down or backing), ICP from poses
//!    along the axis may win by the test above, under the same conditions
//!    ([`Attempt::stopped_on_weak_evidence`], [`Attempt::checks_along_axes`]). Last, a step
//!    observed weakly along an axis and short of the robot's usual step (the median of its
//!    sure steps turned alike, where they spread little: a log thinned by travel) takes,
//!    of ICP's poses along the axis that fit about as well as the best, the one nearest the
//!    usual step, not beyond it by more than twice its spread ([`Attempt::own_step_along`]).
//! 4. **Corner hypotheses** when the pose is still `lost` or a `poor_fit`, or fits under half
//!    the points (`tracking.corner_hypotheses`): the motion went beyond the window, or odometry slipped
//!    farther than the window reaches. ICP from the best distinct poses that put a corner of
//!    the scan on a corner of the map within `CORNER_REACH_M` of the guess
//!    ([`corner_seeds`]), scored above ICP's pose on the search raster; the best replaces
//!    ICP's pose with `CORNER_WIN_RATIO` times its inliers (plus two) when at least
//!    `tracking.search.search_below_inlier_share` of the points are inliers and no distinct pose
//!    from another hypothesis, as plausible a turn from the guess (`CORNER_RIVAL_TURN_DEG`),
//!    has `CORNER_RIVAL_BELOW` of its inliers; with the
//!    odometry prior only a pose turned at most `tracking.odometry.odometry_max_window_deg` from the odometry
//!    guess (or from the constant-velocity guess where odometry disagrees with it) may win (any
//!    may veto); with point-to-segment ICP only a pose within reach of the
//!    last `ok` pose in the time the stamps give ([`Attempt::within_reach`]). Where no corner
//!    pose wins, without odometry, ICP from the previous pose moved by steps like the robot's
//!    own ([`StepsSeen::hypotheses`]), screened on a third of the points, ICP on every point
//!    from the best two distinct ([`Attempt::screened`]), by the same test, the other of the
//!    two the only rival ([`Attempt::icp_from_own_steps`]).
//! 5. **Verdict** ([`verdict`]) on the final pose, `weak` (`ambiguous`) when the window search
//!    found a rival (also when a corner pose won: the scan then stays out of the map, see
//!    [`Tracking::enters_map`]; ICP from the rival replaces a pose that no corner pose
//!    placed where it fits more points by `SEARCH_WIN_MARGIN`, plus two, within
//!    reach, observing every direction and not `lost`, with odometry turned at most as far
//!    from its guess as a corner pose: [`Attempt::rival_fits_better`]; the same for a pose
//!    still `lost` or in doubt after the corners, while tracking and not on the spot, and by
//!    `CORNER_WIN_RATIO` over a `lost` one, the scan then at best `ambiguous`),
//!    or when ICP from the search's pose and from the starts
//!    reached distinct poses that both observe every direction and fit alike (within
//!    `tracking.verdict.ambiguous_above` of the inliers); `weak` (`slowed`) for a fast robot put near
//!    no motion on weak evidence ([`Attempt::slowed`]); `weak` (`off_odometry`) where the
//!    log's odometry, witnessing without being the prior, gives the step another length
//!    ([`OdometryWitness`]).

mod axes;
mod hypotheses;
mod search;
mod starts;
#[cfg(test)]
mod tests;

use super::params::{MapperParams, TrackParams};
use super::recent::{LoosePoints, RecentMotion, StepsSeen};
use super::verdict::{OdometryWitness, Reason, Tracking, Verdict, verdict};
use super::window::WindowMatch;
use crate::align::{AlignMethod, AlignParams, AlignResult, PointTargets, thin_points};
use crate::geometry::{Pose2, Segment, Vec2};
use crate::map::GlobalMap;
use serde::{Deserialize, Serialize};
use starts::loose_targets;
use std::cell::RefCell;

/// What the tracker knows when it aligns one scan.
#[derive(Debug, Clone, Copy)]
pub struct TrackInput<'a> {
    /// The scan's valid points, robot frame, metres (thinned here to
    /// `align.point_spacing_m`).
    pub points_in_robot: &'a [Vec2],
    /// The scan's segments, robot frame, metres (for [`AlignMethod::Endpoints`]).
    pub segments_in_robot: &'a [Segment],
    /// The map to align to, map frame.
    pub map: &'a GlobalMap,
    /// The recent scans' points off the map, map frame (for the window search).
    pub loose: &'a LoosePoints,
    /// The motion prior's guess of the pose, map frame: ICP's first start.
    pub guess: Pose2,
    /// The pose of "no motion" (the previous pose; with the odometry prior, its guess), map
    /// frame: a start of ICP, the reference the window is sized by, the recovery's centre.
    pub anchor: Pose2,
    /// The pose that directions ICP cannot observe fall back to, map frame: the anchor, or the
    /// previous pose moved by the last observed motion (`mapper.keep_observed_velocity`).
    pub unobserved_to: Pose2,
    /// The pose of the last scan tracked `ok`, map frame (the guess when there is none).
    pub reference: Pose2,
    /// The pose of the last scan tracked `ok`, map frame (the guess when there is none),
    /// whatever the stamps say (unlike [`TrackInput::reference`]).
    pub last_ok: Pose2,
    /// Where ICP also starts after a lost scan, map frame: [`TrackInput::reference`], with the
    /// odometry prior moved by the odometry since that scan (the lost scans' poses, which the
    /// guess builds on, are poor fits; the bare last `ok` pose lies where the robot was).
    pub restart: Pose2,
    /// Seconds since that scan, when both stamps are known and increase.
    pub dt_s: Option<f64>,
    /// Without the odometry prior, after a gap in stamps that keep time (a time step of
    /// several typical ones), where the robot is if it moved one scan's worth over it, map
    /// frame: the last pose moved by the last motion per scan, or the last pose before there
    /// is one. The guess spans the gap's time, but a gap is scans missing from the log or a
    /// robot that waited or slowed, and the robot moved anywhere from about one step to the
    /// gap's many; `None` when the scan follows no gap.
    pub after_gap: Option<Pose2>,
    /// The constant-velocity prediction (the last pose moved by the last scan-to-scan motion),
    /// map frame, when there are two poses before; checked against the odometry guess with the
    /// odometry prior.
    pub constant_velocity: Option<Pose2>,
    /// The largest steps and turns of the last scans.
    pub recent: &'a RecentMotion,
    /// The steps the robot was seen to make (the own-step hypotheses, robot frame of the pose
    /// they start from; after lost scans that is the last, lost, pose).
    pub steps_seen: &'a StepsSeen,
    /// Scans lost in a row just before this one.
    pub lost_streak: u32,
    /// Without the odometry prior, the log's odometry as a witness of the step, where the
    /// tracker trusts it to witness (`tracking.odometry.odometry_witness_m`).
    pub odometry_witness: Option<OdometryWitness>,
    /// With the odometry prior, the odometry's step from the scan before (robot frame of that
    /// scan), when both carry odometry and that scan was not lost: the guess is the previous
    /// pose moved by it, and its spread (the motion prior's, `tracking/estimator.rs`) bounds
    /// where the robot may be without the odometry having failed.
    pub odometry_step: Option<Pose2>,
    /// Without the odometry prior, how far the robot may be from the previous pose moved by
    /// the speed last observed ([`TrackInput::unobserved_to`]) unless its speed changed beyond
    /// a robot's acceleration, metres (`tracking/estimator.rs`, `speed_spread_m`): where the
    /// stamps time the step, a step that set the speed told it, and the scan before was not
    /// lost.
    pub speed_spread_m: Option<f64>,
}

/// The parameters [`track_scan`] follows: ICP's, tracking's, and the start policy of `[mapper]`
/// (`also_start_at_anchor`, `icp_from_best_start_only`, `START_SCORE_MARGIN`,
/// `recover_below_inlier_share`, and whether `motion_prior` is odometry).
#[derive(Debug, Clone, Copy)]
pub struct TrackConfig<'a> {
    /// ICP (section `[align]`).
    pub align: &'a AlignParams,
    /// The window search and the verdict (section `[tracking]`).
    pub tracking: &'a TrackParams,
    /// The start policy (section `[mapper]`).
    pub starts: &'a MapperParams,
}

/// With `tracking.search_unobserved`, the search's pose may replace a pose ICP could not
/// observe along an axis only when it lies within this distance of that pose across the
/// axis, metres (ICP observed that direction: the pose moves along the corridor, not across)...
pub const UNOBSERVED_ACROSS_M: f64 = 0.1;

/// ...and is turned from it by at most this, degrees (the walls observed the rotation).
pub const UNOBSERVED_TURN_DEG: f64 = 3.0;

/// With `UNOBSERVED_REACH_M`, ICP runs from poses this far apart along the axis,
/// metres: within the reach of ICP's gate, so a frame or a wall end near the true pose draws it.
pub const UNOBSERVED_SEED_STEP_M: f64 = 0.25;

/// A weakly observed pose farther than this along its weak axis from the last observed
/// motion's is checked against it, metres.
pub const PRIOR_OVER_WEAK_M: f64 = 0.1;

/// A pose ICP observed only weakly along an axis, moved from the anchor along it by less than
/// this share of the longest recent step, counts as stopped (`Attempt::icp`).
pub const STOPPED_BELOW_SHARE_OF_STEP: f64 = 0.5;

/// ICP's weakest information under this is about one point's (a point-to-line constraint adds
/// at most 1): see `Attempt::unpinned`.
pub const PINNED_BELOW_INFORMATION: f64 = 1.5;

/// The recovery searches positions within this distance of the anchor (each axis), metres.
pub const RECOVER_TRANSLATION_M: f64 = 1.0;

/// True when `a` explains the scan better than `b`: more inliers, then a lower residual.
pub fn better(a: &AlignResult, b: &AlignResult) -> bool {
    (a.inliers, -a.residual_rms_m) > (b.inliers, -b.residual_rms_m)
}

/// The [`better`] of some results, the first among equals; `None` for none.
fn best_of(results: impl IntoIterator<Item = AlignResult>) -> Option<AlignResult> {
    results
        .into_iter()
        .reduce(|best, r| if better(&r, &best) { r } else { best })
}

/// The pose of one scan and the verdict on it: ICP from the starts, the whole-circle recovery,
/// the window search (see the module); the result is `None` when there is nothing to align
/// to (an empty map, a scan without points). With every ICP run it made ([`TriedPose`]), in
/// order, where `record` asks for them (empty otherwise).
pub fn track_scan(
    input: &TrackInput,
    config: &TrackConfig,
    record: bool,
) -> (Option<AlignResult>, Tracking, Vec<TriedPose>) {
    let points = thin_points(input.points_in_robot, config.align.point_spacing_m);
    let targets = loose_targets(input, config);
    let tries = RefCell::new(Vec::new());
    let attempt = Attempt {
        input,
        config,
        points: &points,
        targets: targets.as_ref(),
        tries: record.then_some(&tries),
    };
    let Aligned {
        mut result,
        found,
        search_won,
        second_fit,
        on_the_spot,
    } = attempt.icp();
    if let Some(free) = result.as_ref().and_then(|r| attempt.unpinned(r)) {
        result = Some(free);
    }
    let first = input.map.is_empty();
    let mut tracking = verdict(result.as_ref(), points.len(), first, config.tracking);
    if config.tracking.corner_hypotheses
        && doubtful(&tracking, config)
        && let Some(c) = result.as_ref().and_then(|r| attempt.icp_from_corners(r))
    {
        tracking = verdict(Some(&c), points.len(), first, config.tracking);
        tracking.corner_won = true;
        result = Some(c);
    }
    tracking.searched = found.is_some();
    tracking.search_won = search_won;
    // The search's rival, searched for at most once per scan (it goes on with the search).
    let rival_found = std::cell::OnceCell::new();
    let rival_of_search = || *rival_found.get_or_init(|| found.as_ref().and_then(|m| m.rival()));
    // A pose still in doubt after the corners (see `doubtful`): ICP from the search's rival
    // may fit clearly more points, as for an `ok` scan below (Intel every 5th scan, a
    // nuisance variant, phase 4, scan 2502: a robot spinning 25° per scan, the pose taken
    // turned 0.2° at 44 % of the points, ICP from the rival 32° at 60 %). Not while
    // relocalizing after lost scans, nor for a pose of the search on the spot (its own guards
    // decide there); over a `lost` pose it must win as a corner pose does, by
    // `CORNER_WIN_RATIO`, since it then enters the map where the lost one would not. The
    // raster preferred the other pose, so the scan is at best `ambiguous`.
    let doubted = !tracking.corner_won
        && !on_the_spot
        && input.lost_streak == 0
        && doubtful(&tracking, config);
    let lost = tracking.verdict == Verdict::Lost;
    if let Some((better, judged)) = doubted
        .then(rival_of_search)
        .flatten()
        .zip(result.as_ref())
        .and_then(|(rival, current)| {
            attempt
                .rival_fits_better(&rival, current)
                .filter(|(fit, _)| !lost || attempt.wins_by_ratio(fit, current))
        })
    {
        tracking = Tracking {
            searched: true,
            search_won: true,
            ..judged
        };
        if tracking.verdict == Verdict::Ok {
            tracking.verdict = Verdict::Weak;
            tracking.reason = Reason::Ambiguous;
        }
        result = Some(better);
    }
    // A rival on the raster, or (unless a corner pose replaced ICP's) ICP from the search's
    // pose fitting nearly as well elsewhere.
    let second_fit = second_fit && !tracking.corner_won;
    let ok = tracking.verdict == Verdict::Ok;
    let rival = (ok && !second_fit).then(rival_of_search).flatten();
    if ok && (second_fit || rival.is_some()) {
        // ICP from the rival may fit clearly more points than the pose taken: a turn the
        // raster scored just below its mirror image (a corridor seen turned by 180°). Not
        // over a corner pose, which stays out of the map while a rival doubts it, nor again
        // where the pose in doubt above already tried it.
        if let Some((better, judged)) = rival
            .zip(result.as_ref())
            .filter(|_| !tracking.corner_won && !doubted)
            .and_then(|(rival, current)| attempt.rival_fits_better(&rival, current))
        {
            tracking = Tracking {
                searched: true,
                search_won: true,
                ..judged
            };
            result = Some(better);
        }
        tracking.verdict = Verdict::Weak;
        tracking.reason = Reason::Ambiguous;
    }
    if tracking.verdict == Verdict::Ok
        && let Some(axis_deg) = result.as_ref().and_then(|r| attempt.slowed(r))
    {
        tracking.verdict = Verdict::Weak;
        tracking.reason = Reason::Slowed;
        tracking.weak_direction_deg = Some(axis_deg);
    }
    // The log's odometry, not the prior, says the step is another length: one of the two
    // slipped, and a scan matched `ok` to the wrong door frame is as likely as a wheel's slip.
    if tracking.verdict == Verdict::Ok
        && let (Some(witness), Some(r)) = (input.odometry_witness, result.as_ref())
        && witness.contradicts(
            &r.map_from_robot,
            config.tracking.odometry.odometry_witness_m,
        )
    {
        tracking.verdict = Verdict::Weak;
        tracking.reason = Reason::OffOdometry;
    }
    // The pose, chosen by the fit, weighed with the motion prior; the verdict stays the fit's.
    if tracking.verdict != Verdict::Lost
        && let Some(held) = result.as_ref().and_then(|r| attempt.weighed(r))
    {
        result = Some(held);
    }
    (result, tracking, tries.into_inner())
}

/// Whether `other`, an ICP pose that lost to `kept`, makes the scan's place ambiguous: distinct
/// from it (more than `tracking.verdict.rival_apart_m` or `rival_apart_deg`), observed in every
/// direction, and fitting at least `tracking.verdict.ambiguous_above` of its inliers.
fn fits_nearly_as_well(other: &AlignResult, kept: &AlignResult, tracking: &TrackParams) -> bool {
    other.weak_directions == 0
        && tracking.apart(&kept.map_from_robot, &other.map_from_robot)
        && other.inliers as f64 >= tracking.verdict.ambiguous_above * kept.inliers as f64
}

/// Whether a verdict leaves the pose in doubt enough to try the corner hypotheses: `lost`,
/// `weak` for a poor fit, or any pose that fits fewer than `search_below_inlier_share` of the
/// points (a fit that would be searched whatever the motion: FR079 with odometry at every 5th
/// scan, phase 4, took a step of 0.52 m forward from odometry where the robot backed 0.49 m,
/// as `ok` with 44 % of its points inliers; see `docs/ARCHITECTURE.md`, "The strategy, per scan").
/// Endpoint ICP (`--preset paper`) counts endpoint pairs against the scan's points, a share
/// that is nearly always under half, so there only the verdict decides.
fn doubtful(tracking: &Tracking, config: &TrackConfig) -> bool {
    tracking.verdict == Verdict::Lost
        || tracking.reason == Reason::PoorFit
        || (config.align.method == AlignMethod::PointToSegment
            && tracking.inlier_share < config.tracking.search.search_below_inlier_share)
}

/// What [`Attempt::icp`] found.
struct Aligned {
    /// The pose kept (`None`: nothing to align to).
    result: Option<AlignResult>,
    /// The window search's outcome, when it ran.
    found: Option<WindowMatch>,
    /// Whether ICP from the search's pose replaced ICP from the starts.
    search_won: bool,
    /// Whether the other of the two ICP poses is distinct from the one kept (more than
    /// `tracking.verdict.rival_apart_m` or `rival_apart_deg`), observed in every direction, and fits
    /// at least `tracking.verdict.ambiguous_above` of its inliers.
    second_fit: bool,
    /// Whether the pose kept came from the search as wide as the robot can turn on the spot
    /// ([`Attempt::turned_on_the_spot`]), whose outcome `found` then is: its own guards (on
    /// the spot, `CORNER_WIN_RATIO`) are the only ones its poses may win by.
    on_the_spot: bool,
}

impl Aligned {
    /// ICP from the starts alone: no search.
    fn icp(result: Option<AlignResult>) -> Aligned {
        Aligned {
            result,
            found: None,
            search_won: false,
            second_fit: false,
            on_the_spot: false,
        }
    }
}

/// One scan's alignment in progress.
struct Attempt<'a> {
    input: &'a TrackInput<'a>,
    config: &'a TrackConfig<'a>,
    /// The scan's points thinned to `align.point_spacing_m`, robot frame.
    points: &'a [Vec2],
    /// The loose points ICP may match point to point.
    targets: Option<&'a PointTargets>,
    /// Where every ICP run of the attempt is recorded ([`TriedPose`]), when asked.
    tries: Option<&'a RefCell<Vec<TriedPose>>>,
}

/// One ICP run of a scan's tracking: where it converged and how well the scan fitted there.
/// Every start, search pose, check along an axis and hypothesis the strategy tried gives one
/// (not the own-step hypotheses' screening runs on a third of the points, only the ICP runs on
/// every point from the two poses kept):
/// the strategy's pose is one of them (the tracker may then move it towards the motion prior,
/// `tracking/estimator.rs`), the others are the candidates it was preferred to
/// (`diagnostics.jsonl`: `tries`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TriedPose {
    /// The pose ICP converged to, map frame.
    pub map_from_robot: Pose2,
    /// Scan points within ICP's robust scale of the map there.
    pub inliers: usize,
    /// Scan points with a map segment (or loose point) within ICP's final gate there.
    pub correspondences: usize,
}

impl TriedPose {
    fn of(result: &AlignResult) -> Self {
        TriedPose {
            map_from_robot: result.map_from_robot,
            inliers: result.inliers,
            correspondences: result.correspondences,
        }
    }
}

impl Attempt<'_> {
    /// ICP from the starts, the recovery, the window search, and along an axis neither could
    /// observe ([`Attempt::along_unobserved`]), or along one ICP observed only weakly where
    /// the fallback ([`Attempt::prior_over_weak`]) did not win and the robot, fast lately,
    /// seems to have stopped ([`Attempt::stopped_on_weak_evidence`]), then against the robot's
    /// usual step ([`Attempt::own_step_along`]); with the search's outcome when it ran, whether
    /// its pose (or one along the axis) won, and whether the loser fitted nearly as well.
    fn icp(&self) -> Aligned {
        let aligned = self.icp_along();
        if let Some(own) = aligned.result.as_ref().and_then(|r| self.own_step_along(r)) {
            return Aligned {
                result: Some(own),
                search_won: true,
                second_fit: false,
                ..aligned
            };
        }
        aligned
    }

    /// [`Attempt::icp`] before the robot's usual step is checked.
    fn icp_along(&self) -> Aligned {
        let aligned = self.icp_and_search();
        let Some(result) = aligned.result else {
            return aligned;
        };
        let axis = match self.unobserved(&result) {
            Some(axis) => axis,
            None => {
                if let Some(prior) = self.prior_over_weak(&result) {
                    return Aligned {
                        result: Some(prior),
                        ..aligned
                    };
                }
                match self.stopped_on_weak_evidence(&result) {
                    Some(axis) => axis,
                    None => return aligned,
                }
            }
        };
        match self.along_unobserved(&result, axis) {
            Some(moved) => Aligned {
                result: Some(moved),
                search_won: true,
                second_fit: false,
                ..aligned
            },
            None => aligned,
        }
    }
}
