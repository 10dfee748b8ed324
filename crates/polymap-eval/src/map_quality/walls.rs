//! The map against the true walls of a simulated world: precision and recall by length.

use polymap::geometry::{Pose2, Segment};
use serde::Serialize;

use super::{CELL_M, MAX_PIECES_PER_SEGMENT, REACH_M, coverage};
use polymap::segment_index::SegmentIndex;

/// A wall of the true world.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrueWall {
    /// The wall, metres, world frame.
    pub segment: Segment,
    /// Whether the laser ever saw the wall (the simulator flags it); recall can be restricted to
    /// seen walls.
    pub seen: bool,
}

impl From<Segment> for TrueWall {
    /// A wall counted as seen.
    fn from(segment: Segment) -> Self {
        TrueWall {
            segment,
            seen: true,
        }
    }
}

impl TrueWall {
    /// Walls from a list of segments and the indices of the seen ones (as a simulator's wall
    /// tally reports them); indices out of range are ignored.
    ///
    /// ```
    /// use polymap::geometry::{Segment, Vec2};
    /// use polymap_eval::map_quality::TrueWall;
    /// let s = Segment::new(Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0));
    /// let walls = TrueWall::from_seen_indices(&[s, s, s], &[2, 7]);
    /// assert_eq!(walls.iter().map(|w| w.seen).collect::<Vec<_>>(), [false, false, true]);
    /// ```
    pub fn from_seen_indices(walls: &[Segment], seen: &[usize]) -> Vec<TrueWall> {
        let mut out: Vec<TrueWall> = walls
            .iter()
            .map(|&segment| TrueWall {
                segment,
                seen: false,
            })
            .collect();
        for &i in seen {
            if let Some(w) = out.get_mut(i) {
                w.seen = true;
            }
        }
        out
    }
}

/// Settings of [`map_vs_walls`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct WallParams {
    /// A sample counts as matched when this close to the other set, metres. Default 0.05.
    pub tolerance_m: f64,
    /// Segments are cut into pieces of at most this length, and each piece's midpoint is tested;
    /// the piece's length counts as matched or not, metres. Default 0.01 (1 cm). Non-positive or
    /// non-finite values fall back to the default.
    pub sample_step_m: f64,
    /// Recall over the walls flagged `seen` only (precision always uses every wall). Default true.
    pub recall_only_seen: bool,
}

impl Default for WallParams {
    fn default() -> Self {
        WallParams {
            tolerance_m: 0.05,
            sample_step_m: 0.01,
            recall_only_seen: true,
        }
    }
}

/// Precision and recall of a map against the true walls, by length.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct WallScore {
    /// The parameters used.
    pub params: WallParams,
    /// Total map segment length, metres.
    pub map_length_m: f64,
    /// Map length within `tolerance_m` of a true wall, metres.
    pub map_length_on_walls_m: f64,
    /// Total length of the walls recall is measured on, metres.
    pub wall_length_m: f64,
    /// Wall length within `tolerance_m` of a map segment, metres.
    pub wall_length_mapped_m: f64,
    /// `map_length_on_walls_m / map_length_m`, in `[0, 1]`; `None` for an empty map.
    pub precision: Option<f64>,
    /// `wall_length_mapped_m / wall_length_m`, in `[0, 1]`; `None` without walls.
    pub recall: Option<f64>,
}

/// Scores map segments (map frame) against true walls (world frame); `world_from_map` places the
/// map in the world (the simulator's truth is in the world frame, the map in the first scan's).
///
/// ```
/// use polymap::geometry::{Pose2, Segment, Vec2};
/// use polymap_eval::map_quality::{map_vs_walls, TrueWall, WallParams};
/// let wall = TrueWall::from(Segment::new(Vec2::new(0.0, 0.0), Vec2::new(4.0, 0.0)));
/// // The map has the first half of the wall, 2 cm off, plus 1 m of phantom wall.
/// let map = [
///     Segment::new(Vec2::new(0.0, 0.02), Vec2::new(2.0, 0.02)),
///     Segment::new(Vec2::new(0.0, 3.0), Vec2::new(1.0, 3.0)),
/// ];
/// let s = map_vs_walls(&map, &[wall], &Pose2::IDENTITY, &WallParams::default());
/// assert!((s.precision.unwrap() - 2.0 / 3.0).abs() < 1e-9);
/// // Wall pieces count up to √(5² − 2²) ≈ 4.6 cm past the map's end: 205 pieces of 1 cm.
/// assert!((s.recall.unwrap() - 2.05 / 4.0).abs() < 1e-9);
/// ```
pub fn map_vs_walls(
    map_segments: &[Segment],
    walls: &[TrueWall],
    world_from_map: &Pose2,
    params: &WallParams,
) -> WallScore {
    let map_in_world: Vec<Segment> = map_segments
        .iter()
        .map(|s| s.transformed(world_from_map))
        .collect();
    let all_walls: Vec<Segment> = walls.iter().map(|w| w.segment).collect();
    let recall_walls: Vec<Segment> = walls
        .iter()
        .filter(|w| w.seen || !params.recall_only_seen)
        .map(|w| w.segment)
        .collect();
    let step_m = if params.sample_step_m > 0.0 && params.sample_step_m.is_finite() {
        params.sample_step_m
    } else {
        WallParams::default().sample_step_m
    };
    // Length of one set, and how much of it lies within the tolerance of the other.
    let near = |segments: &[Segment], others: &[Segment]| {
        let others = SegmentIndex::from_segments(others, CELL_M, REACH_M);
        coverage(segments, step_m, |_, p| {
            others.any_within(p, params.tolerance_m)
        })
    };
    let on_walls = near(&map_in_world, &all_walls);
    let mapped = near(&recall_walls, &map_in_world);
    WallScore {
        params: *params,
        map_length_m: on_walls.total_m,
        map_length_on_walls_m: on_walls.covered_m,
        wall_length_m: mapped.total_m,
        wall_length_mapped_m: mapped.covered_m,
        precision: on_walls.ratio(),
        recall: mapped.ratio(),
    }
}

/// The rigid transform `world_from_map` that best lays the map onto the true walls: ICP of
/// points sampled along the map (every 5 cm, at most 20 000) to their closest wall points,
/// pairs gated at 1 m shrinking to 0.2 m, 60 iterations at most.
///
/// A map is anchored at its first scan's estimated pose; a small error there (a fraction of a
/// degree) turns the whole map, and moves walls 20 m away by decimetres, although every wall
/// is where the scans put it. Precision and recall after this alignment measure the map's
/// shape (as ATE aligns a trajectory first); with [`Pose2::IDENTITY`] they measure its
/// placement too. `Pose2::IDENTITY` when the map or the walls are empty.
///
/// ```
/// use polymap::geometry::{Pose2, Segment, Vec2};
/// use polymap_eval::map_quality::{TrueWall, align_map_to_walls};
/// let walls: Vec<Segment> = vec![
///     Segment::new(Vec2::new(0.0, 0.0), Vec2::new(10.0, 0.0)),
///     Segment::new(Vec2::new(0.0, 0.0), Vec2::new(0.0, 8.0)),
///     Segment::new(Vec2::new(10.0, 0.0), Vec2::new(10.0, 8.0)),
/// ];
/// let map_from_world = Pose2::new(0.05, -0.03, 0.01);
/// let map: Vec<Segment> = walls.iter().map(|w| w.transformed(&map_from_world)).collect();
/// let truth: Vec<TrueWall> = walls.into_iter().map(TrueWall::from).collect();
/// let world_from_map = align_map_to_walls(&map, &truth);
/// let residual = world_from_map.compose(&map_from_world);
/// // Within 1 mm and 0.01° (ICP to closest points converges linearly).
/// assert!(residual.translation().length() < 1e-3 && residual.theta_rad.abs() < 2e-4, "{residual:?}");
/// ```
pub fn align_map_to_walls(map_segments: &[Segment], walls: &[TrueWall]) -> Pose2 {
    const STEP_M: f64 = 0.05;
    const MAX_SAMPLES: usize = 20_000;
    let wall_segments: Vec<Segment> = walls.iter().map(|w| w.segment).collect();
    let index = SegmentIndex::from_segments(&wall_segments, CELL_M, REACH_M);
    let total_m: f64 = map_segments
        .iter()
        .filter(|s| s.is_finite())
        .map(Segment::length)
        .sum();
    if index.is_empty() || total_m.is_nan() || total_m <= 0.0 {
        return Pose2::IDENTITY;
    }
    let step_m = STEP_M.max(total_m / MAX_SAMPLES as f64);
    let samples: Vec<polymap::geometry::Vec2> = map_segments
        .iter()
        .filter(|s| s.is_finite())
        .flat_map(|s| {
            let n = (s.length() / step_m)
                .ceil()
                .clamp(1.0, MAX_PIECES_PER_SEGMENT) as usize;
            (0..n).map(move |i| s.start + s.vector() * ((i as f64 + 0.5) / n as f64))
        })
        .collect();
    let mut world_from_map = Pose2::IDENTITY;
    for iteration in 0..60 {
        let gate_m = (1.0 * 0.8f64.powi(iteration)).max(0.2);
        let (mut from, mut to) = (Vec::new(), Vec::new());
        for p in &samples {
            let q = world_from_map.transform_point(*p);
            if let Some((_, _, projection)) = index.nearest(q, gate_m) {
                from.push(*p);
                to.push(projection.point);
            }
        }
        let Some(a) = crate::align::align_se2(&from, &to) else {
            break;
        };
        let moved = a.truth_from_estimate.between(&world_from_map);
        world_from_map = a.truth_from_estimate;
        if moved.translation().length() < 1e-7 && moved.theta_rad.abs() < 1e-9 {
            break;
        }
    }
    world_from_map
}
