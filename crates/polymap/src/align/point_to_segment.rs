//! Point-to-segment ICP on the scan's points (an addition to the paper).

use super::solver::{Constraint, PosePrior, run_icp};
use super::{AlignParams, AlignResult, SegmentLookup};
use crate::extract::fit_line;
use crate::geometry::{Pose2, Segment, Vec2, floor_i64};
use crate::segment_index::NearestCertificate;

/// A scan point is matched to a loose point at most this far, metres (whatever ICP's gate,
/// point to line or point to point): a loose point is a sample, not a mapped wall.
pub const LOOSE_GATE_M: f64 = 0.3;

/// Keeps points at least `spacing_m` from the previously kept one (in order), so that close
/// walls, sampled densely, do not outweigh far ones.
///
/// ```
/// use polymap::align::thin_points;
/// use polymap::geometry::Vec2;
/// let pts: Vec<Vec2> = (0..10).map(|i| Vec2::new(0.01 * i as f64, 0.0)).collect();
/// assert_eq!(thin_points(&pts, 0.05).len(), 2);
/// ```
pub fn thin_points(points: &[Vec2], spacing_m: f64) -> Vec<Vec2> {
    let mut out: Vec<Vec2> = Vec::with_capacity(points.len());
    for &p in points {
        if out
            .last()
            .is_none_or(|l| l.distance_squared(p) >= spacing_m * spacing_m)
        {
            out.push(p);
        }
    }
    out
}

/// Points ICP may also match a scan point to when no map segment explains it (map frame,
/// metres): the recent scans' points the map's segments leave unexplained (door frames,
/// pillars, chair legs, walls too short or too sparsely sampled to become segments), see
/// [`align_points_and_loose`].
///
/// Points within [`LOOSE_DISTINCT_M`] of one already kept count once (a robot that stands or
/// creeps samples a wall at the same places scan after scan, and those repeats are no shape).
/// Each point is matched by the shape of its neighbourhood (the points within
/// [`LOOSE_NEIGHBOURHOOD_M`]): on a line (a wall sampled by several scans) point to line, so
/// that a wall's samples, which no two scans take at the same places, say nothing along the
/// wall; a compact blob (a post, a corner, a chair leg) point to point; a point with fewer than
/// [`LOOSE_MIN_NEIGHBOURS`] neighbours (a single far return) not at all. Shapes are worked out
/// when a scan point first meets the target, so that the many targets no point comes near cost
/// nothing.
#[derive(Debug, Clone, Default)]
pub struct PointTargets {
    tree: rstar::RTree<rstar::primitives::GeomWithData<[f64; 2], usize>>,
    shapes: Vec<std::cell::OnceCell<Option<Shape>>>,
    bins: Bins,
}

/// Points binned into square cells of [`Bins::CELL_M`] over their bounding box: whether any
/// lies within a gate of a query point is a look at the cells the gate's square overlaps
/// ([`Bins::around`]). Most scan points offered to the targets lie far from every one, and a
/// nearest-neighbour search in the tree finds that out at many times the cost.
#[derive(Debug, Clone, Default)]
struct Bins {
    origin: Vec2,
    width: i64,
    height: i64,
    /// Cell `i`'s points are `points[starts[i]..starts[i + 1]]`; empty when there are too
    /// many cells (then every query is answered "maybe").
    starts: Vec<u32>,
    points: Vec<Vec2>,
    /// Each point's index in the points binned.
    ids: Vec<u32>,
}

impl Bins {
    /// The cell side, metres: above the gate's diameter (at most 0.6 m), so that the gate's
    /// square overlaps at most two cells along each axis and a query looks at four cells at
    /// most. Most queries find no point near: the cells visited cost more than the points in
    /// them (sides of 0.2, 0.6, 0.8 and 1.2 m measured; 0.8 and 1.2 did about as well).
    const CELL_M: f64 = 0.8;

    /// The gate's square widened by this share and this distance, metres, before it is cut
    /// into cells: far beyond any rounding of a distance compared with the gate.
    const ROUNDING: (f64, f64) = (1e-9, 1e-9);

    /// At most this many cells (4 MiB of starts); beyond, no bins.
    const MAX_CELLS: i64 = 1 << 20;

    /// `points` (finite) binned.
    fn new(points: &[Vec2]) -> Self {
        let Some(origin) = points.iter().copied().reduce(Vec2::min) else {
            return Bins::default();
        };
        let far = points.iter().copied().fold(origin, Vec2::max);
        let span = |v: f64| floor_i64(v / Self::CELL_M) + 1;
        let (width, height) = (span(far.x - origin.x), span(far.y - origin.y));
        if width.saturating_mul(height) > Self::MAX_CELLS {
            return Bins::default();
        }
        let mut bins = Bins {
            origin,
            width,
            height,
            starts: vec![0; (width * height) as usize + 1],
            points: vec![Vec2::ZERO; points.len()],
            ids: vec![0; points.len()],
        };
        let index = |b: &Bins, p: Vec2| {
            let (x, y) = b.cell(p);
            (y * b.width + x) as usize
        };
        for &p in points {
            let i = index(&bins, p);
            bins.starts[i + 1] += 1;
        }
        for i in 1..bins.starts.len() {
            bins.starts[i] += bins.starts[i - 1];
        }
        let mut next = bins.starts.clone();
        for (id, &p) in points.iter().enumerate() {
            let i = index(&bins, p);
            bins.points[next[i] as usize] = p;
            bins.ids[next[i] as usize] = id as u32;
            next[i] += 1;
        }
        bins
    }

    /// The cell of `p`, which may lie outside the bins.
    fn cell(&self, p: Vec2) -> (i64, i64) {
        let c = (p - self.origin) / Self::CELL_M;
        (floor_i64(c.x), floor_i64(c.y))
    }

    /// The cells, lowest x and y then highest (within the bins), that hold every point within
    /// `max_m` of `q` (both finite): those of the corners of the gate's
    /// square, widened by [`Bins::ROUNDING`]. A point's cell comes from its coordinates by
    /// subtractions, a division and a floor, each of which never decreases, so a point between
    /// the corners lies in a cell between theirs; a point the caller's `distance_squared`
    /// comparison takes within the gate lies within the widened square.
    fn around(&self, q: Vec2, max_m: f64) -> (i64, i64, i64, i64) {
        let reach = max_m.abs() * (1.0 + Self::ROUNDING.0) + Self::ROUNDING.1;
        let (x0, y0) = self.cell(q - Vec2::splat(reach));
        let (x1, y1) = self.cell(q + Vec2::splat(reach));
        (
            x0.max(0),
            y0.max(0),
            x1.min(self.width - 1),
            y1.min(self.height - 1),
        )
    }

    /// Whether a point may lie within `max_m` of `q`: `false` only when none does (the
    /// caller's `distance_squared` comparison, negated: with finite points and gate no
    /// comparison meets a NaN).
    fn maybe_within(&self, q: Vec2, max_m: f64) -> bool {
        let gated = max_m <= LOOSE_GATE_M && max_m.is_finite();
        if self.starts.is_empty() || !gated || !q.is_finite() {
            return true;
        }
        let (x0, y0, x1, y1) = self.around(q, max_m);
        for y in y0..=y1 {
            for x in x0..=x1 {
                let i = (y * self.width + x) as usize;
                let cell = &self.points[self.starts[i] as usize..self.starts[i + 1] as usize];
                if cell.iter().any(|p| p.distance_squared(q) <= max_m * max_m) {
                    return true;
                }
            }
        }
        false
    }

    /// The nearest point to `q` where it lies within `max_m` (with its index), `Some(None)`
    /// where none does; `None` where the bins cannot tell (no bins, no gate, or two points
    /// equally near): every point within the gate lies in the cells [`Bins::around`] gives,
    /// so the nearest there is the nearest of all, the one a nearest-neighbour search finds
    /// (in the same arithmetic) wherever no other point is exactly as near.
    fn nearest_within(&self, q: Vec2, max_m: f64) -> Option<Option<(Vec2, usize)>> {
        let gated = max_m <= LOOSE_GATE_M && max_m.is_finite();
        if self.starts.is_empty() || !gated || !q.is_finite() {
            return None;
        }
        let (x0, y0, x1, y1) = self.around(q, max_m);
        let mut best: Option<(f64, usize)> = None;
        let mut tied = false;
        for y in y0..=y1 {
            for x in x0..=x1 {
                let i = (y * self.width + x) as usize;
                for k in self.starts[i] as usize..self.starts[i + 1] as usize {
                    let d2 = self.points[k].distance_squared(q);
                    match best {
                        Some((b, _)) if d2 > b => {}
                        Some((b, _)) if d2 == b => tied = true,
                        _ => {
                            best = Some((d2, k));
                            tied = false;
                        }
                    }
                }
            }
        }
        match best {
            Some((d2, _)) if d2 > max_m * max_m => Some(None),
            Some(_) if tied => None,
            Some((_, k)) => Some(Some((self.points[k], self.ids[k] as usize))),
            None => Some(None),
        }
    }

    /// The reach of a [`TargetCertificate`]'s look, metres: the gate's largest reach
    /// ([`LOOSE_GATE_M`]) with room for a point to move between ICP's iterations, and under
    /// half a cell ([`Bins::CELL_M`]), so that the look still visits at most four cells.
    const CERTIFY_M: f64 = 0.38;

    /// The nearest point to `q` (finite) with a distance every other point lies beyond (see
    /// [`TargetCertificate`]); `None` without bins or for a `q` that is not finite.
    fn certify(&self, q: Vec2) -> Option<TargetCertificate> {
        if self.starts.is_empty() || !q.is_finite() {
            return None;
        }
        // Every point within the reach lies in these cells ([`Bins::around`]): one outside
        // them lies beyond the reach.
        let (x0, y0, x1, y1) = self.around(q, Self::CERTIFY_M);
        let mut first: Option<(f64, usize)> = None;
        let mut second_2 = f64::INFINITY;
        for y in y0..=y1 {
            for x in x0..=x1 {
                let i = (y * self.width + x) as usize;
                for k in self.starts[i] as usize..self.starts[i + 1] as usize {
                    let d2 = self.points[k].distance_squared(q);
                    match first {
                        Some((b, _)) if d2 >= b => second_2 = second_2.min(d2),
                        _ => {
                            if let Some((b, _)) = first {
                                second_2 = b;
                            }
                            first = Some((d2, k));
                        }
                    }
                }
            }
        }
        let clear_m = second_2.sqrt().min(Self::CERTIFY_M);
        Some(match first {
            Some((d2, k)) if d2.sqrt() < Self::CERTIFY_M => TargetCertificate {
                at: q,
                nearest: Some((d2.sqrt(), self.points[k], self.ids[k] as usize)),
                clear_m,
            },
            _ => TargetCertificate {
                at: q,
                nearest: None,
                clear_m: clear_m.min(first.map_or(f64::INFINITY, |(d2, _)| d2.sqrt())),
            },
        })
    }
}

/// What a look at the loose points' bins around a point `at` found: the nearest point (if one
/// lies within the look's reach) and a distance every other point lies beyond. Near `at`, it
/// answers [`PointTargets::constrain`]'s search for the nearest point without a look: ICP
/// moves a scan point a little from one iteration to the next, and most scan points offered
/// to the targets lie far from every one.
#[derive(Debug, Clone, Copy, PartialEq)]
struct TargetCertificate {
    at: Vec2,
    /// The nearest point's distance from `at` (metres), the point and its index.
    nearest: Option<(f64, Vec2, usize)>,
    /// Every point but the nearest lies at least this far from `at`, metres.
    clear_m: f64,
}

impl TargetCertificate {
    /// The answer of [`Bins::nearest_within`] for `q` and a gate of `max_m`, when the
    /// certificate decides it: `Some(None)` when no point lies within the gate, `Some(Some(_))`
    /// with the nearest point of all, strictly nearer than any other (which may lie beyond the
    /// gate: the caller compares its distance with the gate, as for the bins' answer). `None`
    /// when `q` moved too far from `at` for the certificate to tell, or for a gate the bins do
    /// not answer.
    fn answer(&self, q: Vec2, max_m: f64) -> Option<Option<(Vec2, usize)>> {
        let gated = max_m <= LOOSE_GATE_M && max_m.is_finite();
        if !gated {
            return None;
        }
        let moved = (q - self.at).length();
        // A hair for the rounding of the distances compared.
        let hair = 1e-9 * (1.0 + self.clear_m);
        match self.nearest {
            // Every other point stays farther from `q` than this one.
            Some((near_m, at, id)) => {
                (near_m + 2.0 * moved + hair < self.clear_m).then_some(Some((at, id)))
            }
            None => (max_m.abs() + moved + hair < self.clear_m).then_some(None),
        }
    }
}

/// How a target point constrains a scan point matched to it.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Shape {
    /// On a line with this unit normal (map frame): one point-to-line constraint.
    Line(Vec2),
    /// A compact feature: point to point.
    Blob,
}

/// Radius of a target point's neighbourhood, metres.
pub const LOOSE_NEIGHBOURHOOD_M: f64 = 0.5;

/// Points within this distance of one already counted count once, metres.
pub const LOOSE_DISTINCT_M: f64 = 0.05;

/// A target point needs this many points (itself included) within [`LOOSE_NEIGHBOURHOOD_M`].
pub const LOOSE_MIN_NEIGHBOURS: usize = 3;

/// A neighbourhood whose smaller spread (covariance eigenvalue) is under this share of the
/// larger is a line.
pub const LOOSE_LINE_BELOW: f64 = 0.1;

impl PointTargets {
    /// Indexes the distinct points of `points_in_map` (map frame, metres; points that are not
    /// finite are left out).
    pub fn new(points_in_map: &[Vec2]) -> Self {
        let cell = |p: Vec2| {
            (
                floor_i64(p.x / LOOSE_DISTINCT_M),
                floor_i64(p.y / LOOSE_DISTINCT_M),
            )
        };
        let mut grid: rustc_hash::FxHashMap<(i64, i64), Vec<Vec2>> = Default::default();
        let d2 = LOOSE_DISTINCT_M * LOOSE_DISTINCT_M;
        let mut distinct: Vec<rstar::primitives::GeomWithData<[f64; 2], usize>> = Vec::new();
        for &p in points_in_map.iter().filter(|p| p.is_finite()) {
            let (cx, cy) = cell(p);
            let repeat = (cx - 1..=cx + 1).any(|x| {
                (cy - 1..=cy + 1).any(|y| {
                    grid.get(&(x, y))
                        .is_some_and(|kept| kept.iter().any(|k| k.distance_squared(p) < d2))
                })
            });
            if !repeat {
                grid.entry((cx, cy)).or_default().push(p);
                distinct.push(rstar::primitives::GeomWithData::new(
                    [p.x, p.y],
                    distinct.len(),
                ));
            }
        }
        let shapes = vec![std::cell::OnceCell::new(); distinct.len()];
        let kept: Vec<Vec2> = distinct
            .iter()
            .map(|d| Vec2::new(d.geom()[0], d.geom()[1]))
            .collect();
        PointTargets {
            tree: rstar::RTree::bulk_load(distinct),
            shapes,
            bins: Bins::new(&kept),
        }
    }

    /// True when there is no point.
    pub fn is_empty(&self) -> bool {
        self.shapes.is_empty()
    }

    /// How many distinct points there are.
    pub fn len(&self) -> usize {
        self.shapes.len()
    }

    /// The constraints for scan point `p_in_robot`, at `q` in the map frame, from the nearest
    /// target within `max_m`: none, one (point to line) or two (point to point). `certificate`
    /// is what a look near `q` found (for the same scan point at an earlier ICP iteration),
    /// replaced by a new look where it cannot tell: the same answers, without a look while
    /// the point moves little.
    fn constrain(
        &self,
        p_in_robot: Vec2,
        q: Vec2,
        max_m: f64,
        certificate: &mut Option<TargetCertificate>,
        out: &mut Vec<Constraint>,
    ) {
        let known = certificate.and_then(|c| c.answer(q, max_m));
        let certified = known.or_else(|| {
            *certificate = self.bins.certify(q);
            certificate.and_then(|c| c.answer(q, max_m))
        });
        // The nearest from the bins where they can tell (the tree's search cost many times
        // more); no point within the gate: the nearest, wherever it is, lies beyond it.
        let found = certified.or_else(|| self.bins.nearest_within(q, max_m));
        let (at, id) = match found {
            Some(Some(found)) => found,
            Some(None) => return,
            None => {
                if !self.bins.maybe_within(q, max_m) {
                    return;
                }
                let Some(t) = self.tree.nearest_neighbor([q.x, q.y]) else {
                    return;
                };
                (Vec2::new(t.geom()[0], t.geom()[1]), t.data)
            }
        };
        if at.distance_squared(q) > max_m * max_m {
            return;
        }
        let shape = self.shapes[id].get_or_init(|| {
            let r2 = LOOSE_NEIGHBOURHOOD_M * LOOSE_NEIGHBOURHOOD_M;
            let near: Vec<Vec2> = self
                .tree
                .locate_within_distance([at.x, at.y], r2)
                .map(|n| Vec2::new(n.geom()[0], n.geom()[1]))
                .collect();
            shape_of(&near)
        });
        match *shape {
            Some(Shape::Line(normal)) => out.push(Constraint {
                p_in_robot,
                q_in_map: at,
                normal,
            }),
            Some(Shape::Blob) => out.extend(Constraint::point_pair(p_in_robot, at)),
            None => {}
        }
    }
}

/// The shape of a neighbourhood; `None` when it has too few points. The spreads across and
/// along are those of its total-least-squares line ([`fit_line`]).
fn shape_of(near: &[Vec2]) -> Option<Shape> {
    if near.len() < LOOSE_MIN_NEIGHBOURS {
        return None;
    }
    // No line through points that all coincide.
    let Some(fit) = fit_line(near) else {
        return Some(Shape::Blob);
    };
    let across = fit.rms_m * fit.rms_m * near.len() as f64;
    let total: f64 = near
        .iter()
        .map(|p| (*p - fit.centroid).length_squared())
        .sum();
    if across >= LOOSE_LINE_BELOW * (total - across) {
        return Some(Shape::Blob);
    }
    Some(Shape::Line(fit.direction.perp()))
}

/// Aligns scan points (robot frame) to map segments by point-to-line ICP, starting at `guess`;
/// unobservable directions end on `anchor`.
pub fn align_points(
    points_in_robot: &[Vec2],
    map: &impl SegmentLookup,
    guess: Pose2,
    anchor: Pose2,
    params: &AlignParams,
) -> AlignResult {
    align_points_and_loose(points_in_robot, map, None, guess, anchor, None, params)
}

/// [`align_points`], where a scan point no map segment explains within the gate may also match
/// the nearest of `targets` within it (see [`PointTargets`]), and a `prior` is weighed with the
/// fit at every step ([`PosePrior`]).
pub fn align_points_and_loose(
    points_in_robot: &[Vec2],
    map: &impl SegmentLookup,
    targets: Option<&PointTargets>,
    guess: Pose2,
    anchor: Pose2,
    prior: Option<&PosePrior>,
    params: &AlignParams,
) -> AlignResult {
    let held = Held { anchor, prior };
    align_points_matched(points_in_robot, map, targets, guess, held, params, false)
}

/// A beam whose direction has a component under this along a segment's normal (it runs
/// within about 15° of the segment's line) sees the segment edge on.
pub const EDGE_ON_BELOW: f64 = 0.26;

/// [`align_points_and_loose`] without the points a beam that runs along a segment
/// ([`EDGE_ON_BELOW`]) puts within `align.endpoint_slack_m` of its end (or beyond it): a beam
/// cannot end on a face it runs along; near the face's end it passes it and hits what lies
/// beyond (often the wall the face meets), and such a point moves with the robot. Where it is
/// all ICP observes along a direction it pins the robot there (see
/// `align::strategy`'s unpinning).
pub fn align_points_past_ends(
    points_in_robot: &[Vec2],
    map: &impl SegmentLookup,
    targets: Option<&PointTargets>,
    guess: Pose2,
    anchor: Pose2,
    prior: Option<&PosePrior>,
    params: &AlignParams,
) -> AlignResult {
    let held = Held { anchor, prior };
    align_points_matched(points_in_robot, map, targets, guess, held, params, true)
}

/// Where ICP leaves the directions the fit cannot observe, and the prior it weighs.
struct Held<'a> {
    anchor: Pose2,
    prior: Option<&'a PosePrior>,
}

fn align_points_matched(
    points_in_robot: &[Vec2],
    map: &impl SegmentLookup,
    targets: Option<&PointTargets>,
    guess: Pose2,
    held: Held<'_>,
    params: &AlignParams,
    skip_past_ends: bool,
) -> AlignResult {
    // Per point, what the last search found: while a point moves little between iterations,
    // its nearest segment is known without searching again (same answers, exactly).
    let mut certificates: Vec<Option<NearestCertificate>> = vec![None; points_in_robot.len()];
    // And likewise the nearest loose point.
    let mut loose: Vec<Option<TargetCertificate>> = vec![None; points_in_robot.len()];
    let Held { anchor, prior } = held;
    run_icp(guess, anchor, prior, params, |pose, gate_m, out| {
        let each = points_in_robot
            .iter()
            .zip(&mut certificates)
            .zip(&mut loose);
        for ((&p, certificate), loose) in each {
            let q = pose.transform_point(p);
            let known = certificate.and_then(|c| c.answer(q, gate_m));
            let nearest = match known {
                Some(answer) => answer,
                None => {
                    *certificate = map.nearest_certified(q);
                    match certificate.and_then(|c| c.answer(q, gate_m)) {
                        Some(answer) => answer,
                        None => map.nearest_segment_only(q, gate_m),
                    }
                }
            };
            let on_segment = nearest.and_then(|s| {
                let len = s.length();
                if len <= 0.0 {
                    return None;
                }
                let dir = s.vector() / len;
                let along = (q - s.start).dot(dir);
                // Beyond the mapped part of the wall: unknown space.
                (along >= -params.endpoint_slack_m && along <= len + params.endpoint_slack_m)
                    .then_some((s, dir))
            });
            let past_end = |(s, dir): &(Segment, Vec2)| {
                let slack = params.endpoint_slack_m;
                let along = (q - s.start).dot(*dir);
                let beam = pose.rotate(p).normalize_or_zero();
                beam.dot(dir.perp()).abs() < EDGE_ON_BELOW
                    && !(slack..=s.length() - slack).contains(&along)
            };
            if skip_past_ends && on_segment.as_ref().is_some_and(past_end) {
                continue;
            }
            let Some((s, dir)) = on_segment else {
                if let Some(t) = targets {
                    t.constrain(p, q, gate_m.min(LOOSE_GATE_M), loose, out);
                }
                continue;
            };
            out.push(Constraint {
                p_in_robot: p,
                q_in_map: s.start,
                normal: dir.perp(),
            });
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::segment_index::SegmentIndex;

    /// The bins say "none within the gate" exactly when the nearest point (by brute force)
    /// lies beyond it, and find that nearest point where it lies within, for queries on, near
    /// and far from the points and at cell borders.
    #[test]
    fn bins_tell_no_point_within_the_gate_exactly_when_none_is() {
        let points: Vec<Vec2> = (0..40)
            .map(|i| {
                let a = f64::from(i) * 0.7;
                Vec2::new(3.0 * a.cos() + 0.1 * a, 2.0 * a.sin() - 0.05 * a)
            })
            .chain([Vec2::new(0.4, 0.4), Vec2::new(0.8, 0.4)])
            .collect();
        let bins = Bins::new(&points);
        assert!(!bins.starts.is_empty());
        let (mut far, mut near) = (0, 0);
        for i in -60..=60 {
            for j in -60..=60 {
                let q = Vec2::new(
                    f64::from(i) * 0.1,
                    f64::from(j) * 0.1 + 0.004 * f64::from(i),
                );
                for max_m in [0.0, 0.05, 0.2, LOOSE_GATE_M] {
                    let within = points
                        .iter()
                        .any(|p| p.distance_squared(q) <= max_m * max_m);
                    assert_eq!(bins.maybe_within(q, max_m), within, "{q:?} {max_m}");
                    // The nearest within the gate is the unique nearest of all points, or
                    // the bins cannot tell where two are equally near.
                    let d2 = |p: &Vec2| p.distance_squared(q);
                    let nearest = points.iter().map(d2).fold(f64::INFINITY, f64::min);
                    match bins.nearest_within(q, max_m) {
                        Some(Some((at, id))) => {
                            assert_eq!(points[id], at);
                            assert_eq!(d2(&at), nearest);
                            assert!(within);
                        }
                        Some(None) => assert!(!within, "{q:?} {max_m}"),
                        None => assert!(points.iter().filter(|p| d2(p) == nearest).count() > 1),
                    }
                    match within {
                        true => near += 1,
                        false => far += 1,
                    }
                }
            }
        }
        assert!(near > 100 && far > 100, "{near} {far}");
        // Beyond the gate, or with no bins, the answer is always "maybe".
        assert!(bins.maybe_within(Vec2::new(100.0, 100.0), 1.0));
        assert!(Bins::new(&[]).maybe_within(Vec2::ZERO, 0.1));
        let wide = Bins::new(&[Vec2::ZERO, Vec2::new(1e6, 1e6)]);
        assert!(wide.maybe_within(Vec2::new(5e5, 5e5), 0.1));
    }

    /// A certificate answers, near the point it was made at, what the bins answer: no point
    /// within the gate, or the nearest of all points (compared with the gate by the caller);
    /// and it answers most queries a few centimetres away.
    #[test]
    fn a_certificate_answers_as_the_bins_do() {
        let points: Vec<Vec2> = (0..60)
            .map(|i| {
                let a = f64::from(i) * 0.37;
                Vec2::new(3.0 * a.cos() + 0.1 * a, 2.0 * a.sin() - 0.05 * a)
            })
            .collect();
        let bins = Bins::new(&points);
        let (mut told, mut asked) = (0, 0);
        for i in -50..=50 {
            for j in -50..=50 {
                let q = Vec2::new(
                    f64::from(i) * 0.08,
                    f64::from(j) * 0.08 + 0.003 * f64::from(i),
                );
                let certificate = bins.certify(q).unwrap();
                for (dx, dy) in [(0.0, 0.0), (0.01, -0.02), (-0.05, 0.03), (0.2, 0.1)] {
                    let moved = q + Vec2::new(dx, dy);
                    for max_m in [0.05, 0.2, LOOSE_GATE_M] {
                        asked += 1;
                        let Some(answer) = certificate.answer(moved, max_m) else {
                            continue;
                        };
                        told += 1;
                        let d2 = |p: &Vec2| p.distance_squared(moved);
                        match answer {
                            None => assert!(points.iter().all(|p| d2(p) > max_m * max_m)),
                            Some((at, id)) => {
                                assert_eq!(points[id], at);
                                assert!(points.iter().all(|p| *p == at || d2(p) > d2(&at)));
                            }
                        }
                        match bins.nearest_within(moved, max_m) {
                            Some(Some((at, _))) => assert_eq!(answer.map(|a| a.0), Some(at)),
                            Some(None) => assert!(answer.is_none_or(|(at, _)| {
                                at.distance_squared(moved) > max_m * max_m
                            })),
                            None => {}
                        }
                    }
                }
            }
        }
        assert!(told * 10 > asked * 7, "{told} of {asked}");
        assert!(Bins::new(&[]).certify(Vec2::ZERO).is_none());
    }

    /// A corridor whose only mark along it is a box's face against its north wall (x = 0,
    /// reaching a little past the wall, as a merged face does), a robot beside that face, and
    /// its side beam's point at `side_y`.
    fn corridor_with_a_face(side_y: f64) -> (SegmentIndex<usize>, Vec<Vec2>) {
        let map = SegmentIndex::from_segments(
            &[
                Segment::new(Vec2::new(-20.0, 1.2), Vec2::new(20.0, 1.2)),
                Segment::new(Vec2::new(-20.0, -1.2), Vec2::new(20.0, -1.2)),
                Segment::new(Vec2::new(0.0, 0.7), Vec2::new(0.0, 1.25)),
            ],
            0.5,
            1.0,
        );
        let mut points: Vec<Vec2> = (1..=30)
            .flat_map(|i| {
                let x = 0.25 * f64::from(i);
                [Vec2::new(x, 1.2), Vec2::new(x, -1.2)]
            })
            .collect();
        points.push(Vec2::new(0.0, side_y));
        (map, points)
    }

    /// The side beam runs along the face and ends by its end, on the wall: matched to the
    /// face it is ICP's only evidence along the corridor (about one point's information) and
    /// holds the robot there; without such points the direction is unobservable. A point the
    /// beam puts well inside the face stays.
    #[test]
    fn a_beam_along_a_face_ending_by_its_end_is_left_out_past_ends() {
        let params = AlignParams::default();
        let at = Pose2::new(0.0, 0.0, 0.0);
        let (map, points) = corridor_with_a_face(1.21);
        let pinned = align_points_and_loose(&points, &map, None, at, at, None, &params);
        assert_eq!(pinned.weak_directions, 0, "{pinned:?}");
        let info = pinned.translation_information.weakest;
        assert!(info > 0.5 && info < 1.5, "{pinned:?}");
        let free = align_points_past_ends(&points, &map, None, at, at, None, &params);
        assert_eq!(free.weak_directions, 1, "{free:?}");
        // Well inside the face (0.25 m from its end), the point is evidence either way.
        let (map, points) = corridor_with_a_face(1.0);
        let kept = align_points_past_ends(&points, &map, None, at, at, None, &params);
        assert_eq!(kept.weak_directions, 0, "{kept:?}");
        assert!(kept.translation_information.weakest > 0.5, "{kept:?}");
    }

    /// A line of points at any angle is a line whose normal is across it; a compact cluster
    /// is a blob; two points are no shape.
    #[test]
    fn shapes_are_lines_at_any_angle_blobs_or_nothing() {
        for deg in [0.0f64, 17.0, 60.0, 90.0, 100.0, 135.0, 160.0] {
            let dir = Vec2::new(deg.to_radians().cos(), deg.to_radians().sin());
            // Samples 0.1 m apart with a few millimetres across the line.
            let near: Vec<Vec2> = (0..6)
                .map(|i| dir * (0.1 * f64::from(i)) + dir.perp() * (0.003 * f64::from(i % 2)))
                .collect();
            match shape_of(&near) {
                Some(Shape::Line(normal)) => {
                    assert!(normal.dot(dir).abs() < 0.05, "{deg}°: normal {normal:?}");
                    assert!((normal.length() - 1.0).abs() < 1e-9);
                }
                other => panic!("{deg}°: {other:?}"),
            }
        }
        let blob = [
            Vec2::new(0.0, 0.0),
            Vec2::new(0.06, 0.01),
            Vec2::new(0.02, 0.07),
            Vec2::new(0.07, 0.06),
        ];
        assert_eq!(shape_of(&blob), Some(Shape::Blob));
        assert_eq!(shape_of(&blob[..2]), None);
        // Points that are not finite are left out of the targets.
        let targets = PointTargets::new(&[Vec2::new(f64::INFINITY, 0.0), Vec2::new(f64::NAN, 1.0)]);
        assert!(targets.is_empty());
    }
}
