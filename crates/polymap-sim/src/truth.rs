//! Ground-truth bookkeeping: which truth walls the laser saw, and frame changes.

use polymap::geometry::{Pose2, Segment};

use crate::raycast::{Obstacle, RayHit};
use crate::world::World;

/// Length of the bins along a truth wall used to measure how much of it was observed, metres.
pub const COVERAGE_BIN_M: f64 = 0.1;

/// Per truth wall (see [`World::truth_walls`]): how many returned beams hit it, and which
/// [`COVERAGE_BIN_M`]-long stretches of it were hit at least once.
#[derive(Debug, Clone, PartialEq)]
pub struct WallTally {
    walls: Vec<Segment>,
    /// Index of each pillar's first polygon side in `walls`.
    pillar_offsets: Vec<usize>,
    /// The pillars' polygon side counts.
    pillar_sides: Vec<usize>,
    hits: Vec<u32>,
    bins: Vec<Vec<bool>>,
}

impl WallTally {
    /// An empty tally over the world's truth walls.
    pub fn new(world: &World) -> WallTally {
        let walls = world.truth_walls();
        let mut pillar_offsets = Vec::with_capacity(world.pillars.len());
        let mut next = world.walls.len();
        for p in &world.pillars {
            pillar_offsets.push(next);
            next += p.sides();
        }
        let bins = walls.iter().map(|w| vec![false; bin_count(w)]).collect();
        let pillar_sides = world.pillars.iter().map(|p| p.sides()).collect();
        WallTally {
            hits: vec![0; walls.len()],
            walls,
            pillar_offsets,
            pillar_sides,
            bins,
        }
    }

    /// The truth wall a hit belongs to. `world` must be the one the tally was built for.
    fn truth_index(&self, world: &World, hit: &RayHit) -> Option<usize> {
        match hit.obstacle {
            Obstacle::Wall(i) => Some(i),
            Obstacle::Pillar(j) => {
                let side = world.pillars.get(j)?.side_at(hit.point);
                Some(
                    self.pillar_offsets.get(j)?
                        + side.min(self.pillar_sides.get(j)?.saturating_sub(1)),
                )
            }
        }
    }

    /// Records one returned beam's true hit.
    pub fn record(&mut self, world: &World, hit: &RayHit) {
        let Some(i) = self.truth_index(world, hit) else {
            return;
        };
        let (Some(wall), Some(bins)) = (self.walls.get(i), self.bins.get_mut(i)) else {
            return;
        };
        self.hits[i] = self.hits[i].saturating_add(1);
        let t = wall.project(hit.point).t;
        let b = ((t * bins.len() as f64) as usize).min(bins.len() - 1);
        bins[b] = true;
    }

    /// The truth walls, metres, world frame.
    pub fn walls(&self) -> &[Segment] {
        &self.walls
    }

    /// Returned beams per truth wall.
    pub fn hits(&self) -> &[u32] {
        &self.hits
    }

    /// Indices of the truth walls hit by at least `min_hits` returned beams.
    pub fn seen(&self, min_hits: u32) -> Vec<usize> {
        (0..self.walls.len())
            .filter(|&i| self.hits[i] >= min_hits.max(1))
            .collect()
    }

    /// Total length of the truth walls with at least one hit bin, metres, counting only
    /// the bins that were hit.
    pub fn observed_length_m(&self) -> f64 {
        let per_wall = |(w, bins): (&Segment, &Vec<bool>)| {
            w.length() * bins.iter().filter(|&&b| b).count() as f64 / bins.len() as f64
        };
        self.walls.iter().zip(&self.bins).map(per_wall).sum()
    }
}

/// Number of coverage bins along a wall: at least one.
fn bin_count(wall: &Segment) -> usize {
    let n = (wall.length() / COVERAGE_BIN_M).ceil();
    if n.is_finite() && n >= 1.0 {
        (n as usize).min(1 << 20)
    } else {
        1
    }
}

/// Poses re-expressed in the frame of the first one: `first⁻¹ ∘ pose`. The first becomes the
/// identity. Use it to compare world-frame ground truth with a map built in the first scan's
/// frame.
///
/// ```
/// use polymap::geometry::Pose2;
/// use polymap_sim::poses_in_first_frame;
/// let world_from_robot = [Pose2::new(2.0, 1.0, std::f64::consts::FRAC_PI_2), Pose2::new(2.0, 3.0, 0.0)];
/// let first_from_robot = poses_in_first_frame(&world_from_robot);
/// assert_eq!(first_from_robot[0], Pose2::IDENTITY);
/// assert!((first_from_robot[1].x_m - 2.0).abs() < 1e-12 && first_from_robot[1].y_m.abs() < 1e-12);
/// ```
pub fn poses_in_first_frame(poses: &[Pose2]) -> Vec<Pose2> {
    let Some(first) = poses.first() else {
        return vec![];
    };
    let first_from_world = first.inverse();
    poses.iter().map(|p| first_from_world.compose(p)).collect()
}

#[cfg(test)]
mod tests {
    use polymap::geometry::Vec2;

    use super::*;
    use crate::world::Pillar;

    fn world() -> World {
        World {
            moved: None,
            name: "t".into(),
            description: String::new(),
            walls: vec![Segment::new(Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0))],
            pillars: vec![Pillar {
                center: Vec2::new(5.0, 0.0),
                radius_m: 0.5,
            }],
            waypoints: vec![],
            laser: Default::default(),
        }
    }

    #[test]
    fn pillar_hits_land_on_the_facing_side() {
        let w = world();
        let mut tally = WallTally::new(&w);
        let point = Vec2::new(4.5, 0.01);
        tally.record(
            &w,
            &RayHit {
                range_m: 1.0,
                point,
                obstacle: Obstacle::Pillar(0),
            },
        );
        let i = tally.seen(1)[0];
        assert!(tally.walls()[i].distance_to_point(point) < 0.01);
        assert!(i > 0);
    }

    #[test]
    fn observed_length_counts_hit_bins() {
        let w = world();
        let mut tally = WallTally::new(&w);
        for x in [0.05, 0.15, 0.17] {
            let point = Vec2::new(x, 0.0);
            tally.record(
                &w,
                &RayHit {
                    range_m: 1.0,
                    point,
                    obstacle: Obstacle::Wall(0),
                },
            );
        }
        assert_eq!(tally.hits()[0], 3);
        assert!((tally.observed_length_m() - 0.2).abs() < 1e-12);
        assert_eq!(tally.seen(3), vec![0]);
        assert!(tally.seen(4).is_empty());
    }
}
