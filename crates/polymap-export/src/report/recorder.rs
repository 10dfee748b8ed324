//! [`ReportRecorder`]: fed scan by scan during mapping, it keeps what the report shows within
//! a [`ReportBudget`] and produces the [`ReportData`] at the end.

use polymap::geometry::Pose2;

use super::decimate::{MinMaxSeries, StrideThinning};
use super::{
    ReportData, ScanSeries, ScanStat, SeriesPoint, Snapshot, SnapshotContent, TrajectoryPose,
};

/// How much the report may store; the defaults keep a 13 631-scan run near 3 MB of HTML.
#[derive(Debug, Clone, PartialEq)]
pub struct ReportBudget {
    /// Numbers (coordinates and histogram bins) kept over all snapshots (default 300 000). When
    /// exceeded, the snapshot interval doubles and every other snapshot is dropped; the first
    /// and the final snapshot are always kept.
    pub max_snapshot_numbers: usize,
    /// Points per plotted series (default 4000; min/max bucketing).
    pub max_series_points: usize,
    /// Trajectory poses kept (default 20 000; thinned to every 2^k-th scan beyond that).
    pub max_trajectory_poses: usize,
}

impl Default for ReportBudget {
    fn default() -> Self {
        ReportBudget {
            max_snapshot_numbers: 300_000,
            max_series_points: 4000,
            max_trajectory_poses: 20_000,
        }
    }
}

/// Collects report data scan by scan in bounded memory.
///
/// Call [`ReportRecorder::record`] after every scan with that scan's numbers and a closure that
/// builds the snapshot content; the closure runs only when a snapshot is due (every k-th scan,
/// k a power of two that grows with the stored data), so recording is cheap. Then call
/// [`ReportRecorder::finish`] with the final map.
#[derive(Debug, Clone)]
pub struct ReportRecorder {
    title: String,
    budget: ReportBudget,
    scans: u32,
    last: Option<TrajectoryPose>,
    trajectory: StrideThinning<Pose2>,
    snapshots: StrideThinning<Snapshot>,
    residual: MinMaxSeries,
    iterations: MinMaxSeries,
    scan_segments: MinMaxSeries,
    map_segments: MinMaxSeries,
    lost_ranges: Vec<[u32; 2]>,
    gap_scans: Vec<u32>,
    gaps: u32,
    off_odometry_scans: Vec<u32>,
    off_odometry: u32,
}

impl ReportRecorder {
    /// An empty recorder for a report titled `title`.
    pub fn new(title: impl Into<String>, budget: ReportBudget) -> Self {
        let series = || MinMaxSeries::new(budget.max_series_points);
        ReportRecorder {
            title: title.into(),
            scans: 0,
            last: None,
            trajectory: StrideThinning::new(),
            snapshots: StrideThinning::new(),
            residual: series(),
            iterations: series(),
            scan_segments: series(),
            map_segments: series(),
            lost_ranges: Vec::new(),
            gap_scans: Vec::new(),
            gaps: 0,
            off_odometry_scans: Vec::new(),
            off_odometry: 0,
            budget,
        }
    }

    /// True when [`ReportRecorder::record`] for `scan_index` will build a snapshot.
    pub fn snapshot_due(&self, scan_index: u32) -> bool {
        self.snapshots.is_due(scan_index)
    }

    /// Records one scan: its diagnostics, the robot pose `map_from_robot` after it, and — only
    /// if a snapshot is due — the map as `snapshot()` builds it. Scan indices should increase.
    pub fn record(
        &mut self,
        stat: ScanStat,
        map_from_robot: Pose2,
        snapshot: impl FnOnce() -> SnapshotContent,
    ) {
        let t = stat.scan_index;
        self.scans = self.scans.max(t.saturating_add(1));
        self.last = Some(TrajectoryPose {
            scan_index: t,
            map_from_robot,
        });
        if self.trajectory.is_due(t) {
            let budget = self.budget.max_trajectory_poses;
            self.trajectory.push(t, map_from_robot, budget, |_| 1);
        }
        if self.snapshots.is_due(t) {
            let snap = Snapshot {
                scan_index: t,
                map_from_robot,
                content: snapshot(),
            };
            let budget = self.budget.max_snapshot_numbers;
            self.snapshots
                .push(t, snap, budget, |s| s.content.numbers());
        }
        self.push_stats(&stat);
    }

    /// Convenience for the mapper's output: [`ReportRecorder::record`] with the numbers of
    /// `update`.
    pub fn record_update(
        &mut self,
        update: &polymap::mapper::Update,
        snapshot: impl FnOnce() -> SnapshotContent,
    ) {
        self.record(
            ScanStat::from_update(update),
            update.map_from_robot,
            snapshot,
        );
    }

    fn push_stats(&mut self, stat: &ScanStat) {
        let point = |value: f64| SeriesPoint {
            scan_index: stat.scan_index,
            value,
        };
        if let Some(r) = stat.icp_residual_m {
            self.residual.push(point(r));
        }
        self.iterations.push(point(f64::from(stat.icp_iterations)));
        self.scan_segments
            .push(point(f64::from(stat.scan_segments)));
        self.map_segments.push(point(f64::from(stat.map_segments)));
        if stat.after_gap {
            self.gaps = self.gaps.saturating_add(1);
            if self.gap_scans.len() < super::MAX_GAP_MARKS {
                self.gap_scans.push(stat.scan_index);
            }
        }
        if stat.off_odometry {
            self.off_odometry = self.off_odometry.saturating_add(1);
            if self.off_odometry_scans.len() < super::MAX_GAP_MARKS {
                self.off_odometry_scans.push(stat.scan_index);
            }
        }
        if stat.lost {
            let t = stat.scan_index;
            match self.lost_ranges.last_mut() {
                Some(r) if r[1].checked_add(1) == Some(t) => r[1] = t,
                _ => self.lost_ranges.push([t, t]),
            }
        }
    }

    /// The report data, with the snapshot content of the final map added as the last snapshot
    /// unless the last recorded scan already has one.
    pub fn finish(self, final_content: SnapshotContent) -> ReportData {
        let mut snapshots: Vec<Snapshot> =
            self.snapshots.kept.into_iter().map(|(_, s)| s).collect();
        let mut trajectory: Vec<TrajectoryPose> = self
            .trajectory
            .kept
            .into_iter()
            .map(|(scan_index, map_from_robot)| TrajectoryPose {
                scan_index,
                map_from_robot,
            })
            .collect();
        if let Some(last) = self.last {
            if trajectory.last().map(|p| p.scan_index) != Some(last.scan_index) {
                trajectory.push(last);
            }
            if snapshots.last().map(|s| s.scan_index) != Some(last.scan_index) {
                snapshots.push(Snapshot {
                    scan_index: last.scan_index,
                    map_from_robot: last.map_from_robot,
                    content: final_content,
                });
            }
        }
        ReportData {
            title: self.title,
            total_scans: self.scans,
            trajectory,
            snapshots,
            series: ScanSeries {
                icp_residual_m: self.residual.points(),
                icp_iterations: self.iterations.points(),
                scan_segments: self.scan_segments.points(),
                map_segments: self.map_segments.points(),
            },
            lost_ranges: self.lost_ranges,
            gap_scans: self.gap_scans,
            gaps: self.gaps,
            off_odometry_scans: self.off_odometry_scans,
            off_odometry: self.off_odometry,
            map_consistency: None,
            weak_stretches: Vec::new(),
        }
    }
}
