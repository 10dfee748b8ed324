//! The grid search of loop matching: every pose of a grid scored on a likelihood raster of
//! the candidate's submap ([`crate::align::ScoreRaster`]), and its distinct peaks.

use crate::align::ScoreRaster;
use crate::geometry::{Pose2, Vec2};

/// A grid of poses around a centre: translations `±steps_xy × step_m` along x and y, rotations
/// `rotations × step_rad` added to the centre's heading.
#[derive(Debug, Clone)]
pub(crate) struct PoseGrid {
    pub center: Pose2,
    pub steps_xy: i32,
    pub step_m: f64,
    pub rotations: std::ops::Range<i32>,
    pub step_rad: f64,
}

/// Every pose of `grid` with the summed score of `sample` (robot frame) placed there on
/// `raster`, best first (ties in grid order).
pub(crate) fn scored_grid(
    raster: &ScoreRaster,
    sample: &[Vec2],
    grid: &PoseGrid,
) -> Vec<(f64, Pose2)> {
    let c = grid.center;
    let mut scored = Vec::new();
    for ir in grid.rotations.clone() {
        let theta = c.theta_rad + ir as f64 * grid.step_rad;
        for ix in -grid.steps_xy..=grid.steps_xy {
            for iy in -grid.steps_xy..=grid.steps_xy {
                let pose = Pose2::new(
                    c.x_m + ix as f64 * grid.step_m,
                    c.y_m + iy as f64 * grid.step_m,
                    theta,
                );
                let score: f64 = sample
                    .iter()
                    .map(|p| raster.at(pose.transform_point(*p)))
                    .sum();
                scored.push((score, pose));
            }
        }
    }
    scored.sort_by(|a, b| b.0.total_cmp(&a.0));
    scored
}

/// Greedy peaks of `scored` (best first): each pose more than `apart_m` or `apart_rad` from
/// every one taken before (starting with `taken`), at most `max` new ones, none scoring below
/// `min_score`.
pub(crate) fn distinct_peaks(
    scored: &[(f64, Pose2)],
    taken: &[Pose2],
    apart_m: f64,
    apart_rad: f64,
    max: usize,
    min_score: f64,
) -> Vec<Pose2> {
    let mut all = taken.to_vec();
    for (score, pose) in scored {
        if all.len() >= taken.len() + max || *score < min_score {
            break;
        }
        let apart = |p: &Pose2| {
            let d = p.between(pose);
            d.translation().length() > apart_m || d.theta_rad.abs() > apart_rad
        };
        if all.iter().all(apart) {
            all.push(*pose);
        }
    }
    all.split_off(taken.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn peaks_are_apart_from_each_other_and_from_the_taken() {
        let p = |x: f64, deg: f64| Pose2::new(x, 0.0, deg.to_radians());
        let scored = vec![
            (9.0, p(0.0, 0.0)),
            (8.0, p(0.1, 0.0)),
            (7.0, p(1.0, 0.0)),
            (6.0, p(1.0, 10.0)),
            (2.0, p(3.0, 0.0)),
        ];
        // The second is within 0.5 m of the first; the fourth is apart by its rotation.
        let peaks = distinct_peaks(&scored, &[], 0.5, 5f64.to_radians(), 3, 5.0);
        assert_eq!(peaks, vec![p(0.0, 0.0), p(1.0, 0.0), p(1.0, 10.0)]);
        // A taken pose excludes its neighbours; the low score ends the list.
        let peaks = distinct_peaks(&scored, &[p(1.1, 0.0)], 0.5, 5f64.to_radians(), 5, 5.0);
        assert_eq!(peaks, vec![p(0.0, 0.0), p(1.0, 10.0)]);
    }
}
