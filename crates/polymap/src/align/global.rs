//! Global localization: where in a whole map a scan fits, with no guess at all (a run that
//! starts on a saved map, a robot lost for long, a kidnapped robot).
//!
//! The correlative matcher searches the whole map over the whole circle, exactly (branch and
//! bound, [`CorrelativeMatcher`]), for the best few distinct poses ("peaks"); the caller refines
//! each by ICP and keeps the one that explains most points, or none when two distinct poses
//! explain the scan about as well (a symmetric corridor, two identical rooms): a wrong start is
//! worse than a later one.

use super::correlative::{Candidate, CorrelativeMatcher, SearchWindow};
use super::raster::ScoreRaster;
use super::search::score_sample_n;
use crate::geometry::{Pose2, Vec2};
use crate::map::GlobalMap;

/// The peaks of a global search must explain at least this mean raster value per point: a
/// scan that touches the map at a few points is no placement.
pub const GLOBAL_MIN_SCORE: f64 = 0.2;

/// Points of the scan used by a global search, at most: more sharpen the peaks and cost
/// linearly.
pub const GLOBAL_SEARCH_POINTS: usize = 200;

/// A whole map prepared for global searches: its raster with the block maxima of branch and
/// bound, built once and searched for scan after scan while the map does not change.
#[derive(Debug, Clone)]
pub struct GlobalSearch {
    matcher: CorrelativeMatcher,
    /// The whole map and the whole circle.
    whole: SearchWindow,
}

impl GlobalSearch {
    /// Prepares `map` on a raster of `cell_m` cells with a kernel of scale `sigma_m` (metres;
    /// tracking uses `SEARCH_CELL_M` and `SEARCH_SIGMA_M`); `None` for an
    /// empty map.
    pub fn new(map: &GlobalMap, cell_m: f64, sigma_m: f64) -> Option<Self> {
        let (lo, hi) = map_bounds(map)?;
        let c = (lo + hi) * 0.5;
        let whole = SearchWindow {
            center: Pose2::new(c.x, c.y, 0.0),
            half_xy_m: ((hi - lo) * 0.5).max_element(),
            half_theta_rad: std::f64::consts::PI,
        };
        let mut raster = ScoreRaster::new(lo, hi, cell_m, sigma_m);
        for (_, s) in map.iter() {
            raster.add_segment(&s.segment);
        }
        let matcher = CorrelativeMatcher::for_window(raster, whole.half_xy_m);
        Some(GlobalSearch { matcher, whole })
    }

    /// The best `max_peaks` distinct poses (`apart`: more than that many metres or radians
    /// from each other; tracking uses `tracking.verdict.rival_apart_m` and `rival_apart_deg`) of
    /// `points_in_robot` anywhere in the map, or near `hint` when one is given (within
    /// `hint_m` and `hint_rad`), best first. Empty for an empty scan, or when nothing scores
    /// [`GLOBAL_MIN_SCORE`].
    ///
    /// Points farther than `max_range_m` are left out when enough are nearer (a far point
    /// needs a finer rotation step: the search's cost).
    pub fn peaks(
        &self,
        points_in_robot: &[Vec2],
        hint: Option<(Pose2, f64, f64)>,
        max_peaks: usize,
        max_range_m: f64,
        (apart_m, apart_rad): (f64, f64),
    ) -> Vec<Candidate> {
        let near: Vec<Vec2> = points_in_robot
            .iter()
            .copied()
            .filter(|p| p.length() <= max_range_m)
            .collect();
        let points = if near.len() >= 20 {
            &near[..]
        } else {
            points_in_robot
        };
        let sample = score_sample_n(points, GLOBAL_SEARCH_POINTS);
        if sample.is_empty() {
            return Vec::new();
        }
        let window = match hint {
            Some((center, half_xy_m, half_theta_rad)) => SearchWindow {
                center,
                half_xy_m,
                half_theta_rad,
            },
            None => self.whole,
        };
        self.matcher.peaks(
            &sample,
            &window,
            GLOBAL_MIN_SCORE,
            max_peaks,
            apart_m,
            apart_rad,
        )
    }
}

/// The bounding box of the map's segments; `None` for an empty map.
pub fn map_bounds(map: &GlobalMap) -> Option<(Vec2, Vec2)> {
    bounds(
        map.iter()
            .flat_map(|(_, s)| [s.segment.start, s.segment.end]),
    )
}

/// The bounding box `(lo, hi)` of some points (any frame); `None` for none.
pub(crate) fn bounds(points: impl Iterator<Item = Vec2>) -> Option<(Vec2, Vec2)> {
    points.fold(None, |acc, p| match acc {
        None => Some((p, p)),
        Some((lo, hi)) => Some((lo.min(p), hi.max(p))),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Segment;
    use crate::testutil::map_of;

    /// An L-shaped room with a notch: no symmetry, so one pose explains a scan.
    fn room() -> Vec<Segment> {
        let p = |x: f64, y: f64| Vec2::new(x, y);
        let corners = [
            p(0.0, 0.0),
            p(12.0, 0.0),
            p(12.0, 5.0),
            p(7.0, 5.0),
            p(7.0, 9.0),
            p(3.0, 9.0),
            p(3.0, 7.5),
            p(0.0, 7.5),
        ];
        (0..corners.len())
            .map(|i| Segment::new(corners[i], corners[(i + 1) % corners.len()]))
            .collect()
    }

    /// Tracking's raster cell and kernel scale, metres, and how far apart its rivals are
    /// (metres, radians).
    const CELL_M: f64 = 0.1;
    const SIGMA_M: f64 = 0.2;
    const APART: (f64, f64) = (0.5, 10f64.to_radians());

    /// The peaks of a search over all of `map` prepared for it, points up to 8 m.
    fn peaks(
        map: &GlobalMap,
        points: &[Vec2],
        hint: Option<(Pose2, f64, f64)>,
        max: usize,
    ) -> Vec<Candidate> {
        GlobalSearch::new(map, CELL_M, SIGMA_M)
            .expect("a map with segments")
            .peaks(points, hint, max, 8.0, APART)
    }

    /// Points of the walls seen from `pose` (robot frame): every wall point within range that
    /// no other wall hides, by ray casting 360 beams.
    fn scan_from(segments: &[Segment], pose: Pose2) -> Vec<Vec2> {
        let origin = pose.translation();
        (0..360)
            .filter_map(|i| {
                let a = pose.theta_rad + (i as f64).to_radians();
                let dir = Vec2::new(a.cos(), a.sin());
                segments
                    .iter()
                    .filter_map(|s| ray_hit(origin, dir, s))
                    .min_by(f64::total_cmp)
                    .filter(|r| *r < 20.0)
                    .map(|r| pose.inverse().transform_point(origin + dir * r))
            })
            .collect()
    }

    fn ray_hit(o: Vec2, d: Vec2, s: &Segment) -> Option<f64> {
        let e = s.end - s.start;
        let den = d.perp_dot(e);
        if den.abs() < 1e-12 {
            return None;
        }
        let w = s.start - o;
        let t = w.perp_dot(e) / den;
        let u = w.perp_dot(d) / den;
        (t > 1e-9 && (0.0..=1.0).contains(&u)).then_some(t)
    }

    #[test]
    fn finds_a_scan_anywhere_in_the_map_at_any_heading() {
        let walls = room();
        let map = map_of(&walls, 1.0);
        for truth in [
            Pose2::new(2.0, 2.0, 0.3),
            Pose2::new(10.5, 3.0, -2.5),
            Pose2::new(5.0, 7.5, 3.0),
        ] {
            let points = scan_from(&walls, truth);
            let peaks = peaks(&map, &points, None, 3);
            let best = peaks.first().expect("a peak").map_from_robot;
            let d = truth.between(&best);
            assert!(
                d.translation().length() < 0.15 && d.theta_rad.abs() < 0.03,
                "truth {truth:?}, found {best:?}"
            );
        }
    }

    #[test]
    fn a_hint_limits_the_search_and_an_empty_map_gives_nothing() {
        let walls = room();
        let map = map_of(&walls, 1.0);
        let truth = Pose2::new(2.0, 2.0, 0.3);
        let points = scan_from(&walls, truth);
        let near = peaks(&map, &points, Some((truth, 0.5, 0.2)), 1);
        assert!(
            near[0]
                .map_from_robot
                .translation()
                .distance(truth.translation())
                < 0.15
        );
        // A window far from the truth cannot hold it.
        let far = Pose2::new(10.0, 2.0, 0.3);
        let elsewhere = peaks(&map, &points, Some((far, 0.5, 0.2)), 1);
        assert!(
            elsewhere
                .iter()
                .all(|c| c.map_from_robot.translation().distance(truth.translation()) > 7.0)
        );
        assert!(GlobalSearch::new(&GlobalMap::new(1.0, 1.0), CELL_M, SIGMA_M).is_none());
        assert!(peaks(&map, &[], None, 3).is_empty());
    }
}
