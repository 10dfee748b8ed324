//! The map as every writer takes it: one snapshot of a run (segments, polylines, trajectory,
//! optional scan points), in metres in the map frame.
//!
//! `map.json` and `trajectory.tum` (here), and the pictures and foreign formats of
//! `polymap-export` (SVG, PNG, DXF, the occupancy grid) all draw from a [`MapSnapshot`].
//!
//! ```
//! use polymap::geometry::{Pose2, Segment, Vec2};
//! use polymap::map::MapSegment;
//! use polymap::scan::Stamp;
//! use polymap_io::snapshot::{MapSnapshot, Polyline};
//! use polymap_io::tum::StampedPose;
//! let snapshot = MapSnapshot {
//!     segments: vec![MapSegment { segment: Segment::new(Vec2::ZERO, Vec2::new(2.0, 0.0)), born_scan: 0 }],
//!     polylines: vec![Polyline { segments: vec![0] }],
//!     trajectory: vec![StampedPose { stamp: Stamp::from_seconds(1.0), map_from_robot: Pose2::new(1.0, 1.0, 0.0) }],
//!     ..MapSnapshot::default()
//! };
//! assert_eq!(snapshot.positions(), vec![Vec2::new(1.0, 1.0)]);
//! assert_eq!(snapshot.map_json().polylines, vec![vec![0]]);
//! ```

use polymap::geometry::Vec2;
use polymap::map::{MapSegment, Observations};
use serde::{Deserialize, Serialize};

use crate::map_json::{FRAME_FIRST_SCAN, MapJson};
use crate::tum::StampedPose;

/// A generalized polyline of the map: indices into [`MapSnapshot::segments`], in order along it.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(transparent)]
pub struct Polyline {
    /// Indices into the snapshot's segments, in order along the polyline.
    pub segments: Vec<usize>,
}

/// The map and trajectory of a run at one moment (usually its end); metres, map frame.
#[derive(Debug, Clone, PartialEq)]
pub struct MapSnapshot {
    /// Name of the map frame ([`FRAME_FIRST_SCAN`] or
    /// [`FRAME_ODOMETRY`](crate::map_json::FRAME_ODOMETRY)).
    pub frame: String,
    /// A title for pictures (escaped by each writer as its format needs).
    pub title: String,
    /// The map's segments.
    pub segments: Vec<MapSegment>,
    /// What later scans observed of each segment (`observations[i]` for `segments[i]`), for
    /// `map.json`; empty when not known. The pictures do not use it.
    pub observations: Vec<Observations>,
    /// The map's polylines; out-of-range indices are ignored by the pictures.
    pub polylines: Vec<Polyline>,
    /// One pose per scan, `map_from_robot`, with the scan's own time stamp.
    pub trajectory: Vec<StampedPose>,
    /// Scan points in the map frame, for pictures; may be empty.
    pub points: Vec<Vec2>,
    /// Scans of earlier runs that this map continues (`--resume`); 0 for a map of one run.
    /// `map.json`'s `scans` is this plus the trajectory's length.
    pub scans_before: u32,
}

impl Default for MapSnapshot {
    fn default() -> Self {
        MapSnapshot {
            frame: FRAME_FIRST_SCAN.to_owned(),
            title: String::new(),
            segments: Vec::new(),
            observations: Vec::new(),
            polylines: Vec::new(),
            trajectory: Vec::new(),
            points: Vec::new(),
            scans_before: 0,
        }
    }
}

impl MapSnapshot {
    /// A snapshot of a finished run read back from its `map.json` and `trajectory.tum`.
    pub fn from_files(map: &MapJson, trajectory: Vec<StampedPose>) -> MapSnapshot {
        MapSnapshot {
            frame: map.frame.clone(),
            title: String::new(),
            segments: map.map_segments(),
            observations: map.observations().unwrap_or_default(),
            polylines: map
                .polylines
                .iter()
                .map(|p| Polyline {
                    segments: p.clone(),
                })
                .collect(),
            scans_before: map
                .scans_mapped()
                .saturating_sub(trajectory.len().min(u32::MAX as usize) as u32),
            trajectory,
            points: Vec::new(),
        }
    }

    /// A snapshot for a picture from plain parts: polylines as index lists, and a trajectory
    /// of positions only (stamped 0, 1, 2, … s, heading 0), e.g. for previews and tests.
    pub fn from_parts(
        segments: Vec<MapSegment>,
        polylines: Vec<Vec<usize>>,
        positions: &[Vec2],
        points: Vec<Vec2>,
    ) -> MapSnapshot {
        MapSnapshot {
            segments,
            polylines: polylines
                .into_iter()
                .map(|segments| Polyline { segments })
                .collect(),
            trajectory: positions
                .iter()
                .enumerate()
                .map(|(i, p)| StampedPose {
                    stamp: polymap::scan::Stamp::from_seconds(i as f64),
                    map_from_robot: polymap::geometry::Pose2::new(p.x, p.y, 0.0),
                })
                .collect(),
            points,
            ..MapSnapshot::default()
        }
    }

    /// The robot's positions along the trajectory, metres, map frame.
    pub fn positions(&self) -> Vec<Vec2> {
        self.trajectory
            .iter()
            .map(|p| p.map_from_robot.translation())
            .collect()
    }

    /// The `map.json` document of this snapshot.
    pub fn map_json(&self) -> MapJson {
        let polylines: Vec<Vec<usize>> =
            self.polylines.iter().map(|p| p.segments.clone()).collect();
        let scans = self.trajectory.len().min(u32::MAX as usize) as u32;
        MapJson::new(self.frame.clone(), &self.segments, &polylines)
            .with_scans(self.scans_before.saturating_add(scans))
            .with_observations(&self.observations)
    }
}

/// The valid returns of every scan of a run, in the robot frame, converted from the ranges once
/// (by the pipeline) and kept for the pictures' points and the occupancy grid's rays.
///
/// Scan `i`'s points are `points_in_robot[ends[i - 1]..ends[i]]` (from 0 for the first); scan
/// `i` goes with pose `i` of the trajectory.
///
/// ```
/// use polymap::geometry::{Pose2, Vec2};
/// use polymap_io::snapshot::ScanPoints;
/// let mut scans = ScanPoints::default();
/// scans.push(&[Vec2::new(1.0, 0.0)]);
/// scans.push(&[Vec2::new(2.0, 0.0), Vec2::new(3.0, 0.0)]);
/// assert_eq!(scans.len(), 2);
/// assert_eq!(scans.scan(1).len(), 2);
/// let poses = [Pose2::new(0.0, 1.0, 0.0), Pose2::new(0.0, 2.0, 0.0)];
/// assert_eq!(scans.in_map(&poses, usize::MAX)[2], Vec2::new(3.0, 2.0));
/// ```
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ScanPoints {
    /// All scans' points, robot frame, metres, scan after scan.
    pub points_in_robot: Vec<Vec2>,
    /// Where each scan's points end in `points_in_robot`.
    pub ends: Vec<usize>,
}

impl ScanPoints {
    /// Appends one scan's points (robot frame).
    pub fn push(&mut self, points_in_robot: &[Vec2]) {
        self.points_in_robot.extend_from_slice(points_in_robot);
        self.ends.push(self.points_in_robot.len());
    }

    /// Number of scans.
    pub fn len(&self) -> usize {
        self.ends.len()
    }

    /// True when no scan was recorded.
    pub fn is_empty(&self) -> bool {
        self.ends.is_empty()
    }

    /// Scan `i`'s points, robot frame (empty when out of range).
    pub fn scan(&self, i: usize) -> &[Vec2] {
        let (Some(&end), begin) = (
            self.ends.get(i),
            i.checked_sub(1).map_or(0, |j| self.ends[j]),
        ) else {
            return &[];
        };
        &self.points_in_robot[begin..end]
    }

    /// Each scan's pose (from `map_from_robot`, scan `i` with pose `i`) with its points in the
    /// robot frame: the laser rays, for the occupancy grid. Scans without a pose are left out.
    pub fn rays<'a>(
        &'a self,
        map_from_robot: &'a [polymap::geometry::Pose2],
    ) -> impl Iterator<Item = (polymap::geometry::Pose2, &'a [Vec2])> + 'a {
        map_from_robot
            .iter()
            .enumerate()
            .take(self.len())
            .map(|(i, pose)| (*pose, self.scan(i)))
    }

    /// At most about `max_points` of the points (every k-th), in the map frame.
    pub fn in_map(
        &self,
        map_from_robot: &[polymap::geometry::Pose2],
        max_points: usize,
    ) -> Vec<Vec2> {
        let step = self
            .points_in_robot
            .len()
            .div_ceil(max_points.max(1))
            .max(1);
        let mut out = Vec::with_capacity(self.points_in_robot.len() / step + 1);
        let mut index = 0usize;
        for (pose, points) in self.rays(map_from_robot) {
            for p in points {
                if index.is_multiple_of(step) {
                    out.push(pose.transform_point(*p));
                }
                index += 1;
            }
        }
        out
    }
}
