//! A self-contained HTML report of a run: the final map, the trajectory, a time slider that
//! replays how the map grew, the main-direction histogram at the chosen time, and per-scan
//! plots of the ICP residual and the segment counts.
//!
//! The page is one file with inline CSS and JavaScript and the data embedded as JSON: it needs
//! no network. What it stores is bounded by a [`ReportBudget`]: [`ReportRecorder`] keeps map
//! snapshots every k scans (k doubling whenever the stored numbers outgrow the budget), thins
//! the trajectory the same way, and decimates the per-scan series by min/max bucketing, so a
//! 13 631-scan run stays a few megabytes and the page stays responsive.
//!
//! Opened with `#selftest` appended to its URL, the page moves its slider through several
//! positions, redraws, and writes `SELFTEST PASS` or `SELFTEST FAIL: reason` into
//! `<pre id="selftest">` (`scripts/check-report-in-browser.sh` checks it in headless Chromium).
//!
//! ```
//! use polymap::geometry::{Pose2, Segment, Vec2};
//! use polymap_export::report::{ReportBudget, ReportRecorder, ScanStat, SnapshotContent, render_report_html};
//! use polymap_io::snapshot::MapSnapshot;
//! let wall = Segment::new(Vec2::new(2.0, -1.0), Vec2::new(2.0, 1.0));
//! let mut recorder = ReportRecorder::new("demo", ReportBudget::default());
//! for t in 0..10u32 {
//!     let stat = ScanStat { scan_index: t, map_segments: 1, ..Default::default() };
//!     let pose = Pose2::new(0.1 * f64::from(t), 0.0, 0.0);
//!     recorder.record(stat, pose, || SnapshotContent { segments: vec![wall], ..Default::default() });
//! }
//! let data = recorder.finish(SnapshotContent::default());
//! assert_eq!(data.trajectory.len(), 10);
//! let html = render_report_html(&MapSnapshot::default(), &data).unwrap();
//! assert!(html.contains("id=\"selftest\""));
//! ```

mod decimate;
mod html;
mod recorder;

pub use decimate::decimate_min_max;
pub use html::{render_report_html, write_report_html};
pub use recorder::{ReportBudget, ReportRecorder};

use polymap::directions::{DirectionParams, main_directions};
use polymap::geometry::{Pose2, Segment};
use polymap::map::MapSegment;

/// The replay history the report page shows beside the final map (which it takes from the
/// run's [`MapSnapshot`](polymap_io::snapshot::MapSnapshot), as every writer does); saved as
/// `history.json`. Coordinates are metres in the map frame.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct ReportData {
    /// Shown as the page's title (escaped).
    pub title: String,
    /// Number of scans in the run.
    pub total_scans: u32,
    /// Robot poses `map_from_robot` in scan order, possibly thinned (each carries its scan).
    pub trajectory: Vec<TrajectoryPose>,
    /// Snapshots of the map `G_t` in scan order; the slider steps through them.
    pub snapshots: Vec<Snapshot>,
    /// Per-scan diagnostics, decimated for plotting.
    pub series: ScanSeries,
    /// Inclusive ranges `[first, last]` of consecutive scans whose tracking was lost (shaded on
    /// the page's time lines).
    #[serde(default)]
    pub lost_ranges: Vec<[u32; 2]>,
    /// Scans that follow a gap in the log (marked on the page's time lines), the first
    /// [`MAX_GAP_MARKS`].
    #[serde(default)]
    pub gap_scans: Vec<u32>,
    /// How many scans follow a gap in the log (all of them, also beyond the marks).
    #[serde(default)]
    pub gaps: u32,
    /// Scans whose tracked step the log's odometry contradicts (marked on the page's time
    /// lines), the first [`MAX_GAP_MARKS`].
    #[serde(default)]
    pub off_odometry_scans: Vec<u32>,
    /// How many such scans (all of them, also beyond the marks).
    #[serde(default)]
    pub off_odometry: u32,
    /// The run's check of the map as a whole (`summary.json` `map_consistency`), when the
    /// scans observed the map; shown beside the counts.
    #[serde(default)]
    pub map_consistency: Option<MapConsistency>,
    /// Inclusive ranges `[first, last]` of the run's weak stretches (`summary.json`
    /// `tracking.weak_stretches`: consecutive weak scans over at least 10 m of travel), shaded
    /// on the page's time lines; set by the caller from the mapper's summary.
    #[serde(default)]
    pub weak_stretches: Vec<[u32; 2]>,
}

/// At most this many gap marks are kept for the page (a log of dropouts has many; the count
/// is in `summary.json`), and as many marks of scans off the odometry.
pub const MAX_GAP_MARKS: usize = 1000;

/// The run's checks of the map as a whole: how often its scans saw through the map's walls for
/// each time they saw one ([`polymap::observe::seen_through_share`]), how much of its length is
/// drawn twice about walls that cross at a shallow angle ([`polymap::observe::crossed_walls`]),
/// and how often every second observing scan, cast again at its final pose, saw through the
/// finished map's walls ([`polymap::observe::walls_seen_through`]), each with the share above
/// which the run warns (`[observe] warn_seen_through_above`, `warn_crossed_above`,
/// `warn_walls_seen_through_above`). Plain ratios.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct MapConsistency {
    /// Σ length × seen through / Σ length × seen over the map's segments.
    pub seen_through_share: f64,
    /// The run warns above this share.
    pub warn_above: f64,
    /// The share of the map's length drawn twice about walls that cross; `None` when the
    /// report has no such field.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub crossed_share: Option<f64>,
    /// The run warns above this share.
    #[serde(default)]
    pub warn_crossed_above: f64,
    /// The scans (this run's numbering) that last merged into the walls that cross, as
    /// inclusive ranges `[first, last]`.
    #[serde(default)]
    pub crossed_scans: Vec<[u32; 2]>,
    /// The finished map's walls (segments of at least 1 m) as the run's observing scans see
    /// them cast again at their final poses: Σ length × seen through / Σ length × seen
    /// ([`polymap::observe::walls_seen_through`]); `None` when the report has no such field.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub walls_seen_through_share: Option<f64>,
    /// The run warns above this share.
    #[serde(default)]
    pub warn_walls_above: f64,
    /// How many walls those scans saw through at least half as often as they saw them.
    #[serde(default)]
    pub walls_contradicted: usize,
    /// The scans (this run's numbering) that last merged into those walls, as inclusive ranges
    /// `[first, last]`.
    #[serde(default)]
    pub seen_through_scans: Vec<[u32; 2]>,
}

impl MapConsistency {
    /// Whether the scans saw through the map's walls above the threshold, as they came or cast
    /// again at their final poses ([`MapConsistency::walls_seen_through`]): the map is likely
    /// inconsistent.
    pub fn likely_inconsistent(&self) -> bool {
        self.seen_through_share > self.warn_above || self.walls_seen_through()
    }

    /// Whether the finished map's walls were seen through above their threshold by the run's
    /// scans cast again at their final poses.
    pub fn walls_seen_through(&self) -> bool {
        self.walls_seen_through_share
            .is_some_and(|share| share > self.warn_walls_above)
    }

    /// Whether more of the map's length than the threshold is drawn twice about walls that
    /// cross: the map likely draws walls twice, turned apart.
    pub fn walls_drawn_twice(&self) -> bool {
        self.crossed_share
            .is_some_and(|share| share > self.warn_crossed_above)
    }
}

/// One robot pose of the trajectory.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct TrajectoryPose {
    /// The scan (0-based, in processing order).
    pub scan_index: u32,
    /// The robot's pose in the map after that scan.
    pub map_from_robot: Pose2,
}

/// The map and its main directions right after one scan.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Snapshot {
    /// The scan after which the snapshot was taken.
    pub scan_index: u32,
    /// The robot's pose in the map after that scan.
    pub map_from_robot: Pose2,
    /// The map's segments, metres, map frame.
    pub content: SnapshotContent,
}

/// What a snapshot holds of the map; built only when a snapshot is due.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct SnapshotContent {
    /// The map's segments, metres, map frame.
    pub segments: Vec<Segment>,
    /// Length-weighted direction histogram, metres per bin; 180 one-degree bins over
    /// `[0°, 180°)` (any length is drawn as given).
    pub histogram_m: Vec<f64>,
    /// The main directions, degrees in `[0, 180)`.
    pub main_directions_deg: Vec<f64>,
}

impl SnapshotContent {
    /// The content for the map after `scans_done` scans: all its segments, and the histogram
    /// and main directions of the segments born in the last `params.time_memory_scans` scans
    /// (the ones the next merge will use).
    pub fn of_map(map_segments: &[MapSegment], scans_done: u32, params: &DirectionParams) -> Self {
        let since = scans_done.saturating_sub(params.time_memory_scans);
        let recent: Vec<Segment> = map_segments
            .iter()
            .filter(|m| m.born_scan >= since)
            .map(|m| m.segment)
            .collect();
        let md = main_directions(recent.iter(), params);
        SnapshotContent {
            segments: map_segments.iter().map(|m| m.segment).collect(),
            histogram_m: md.histogram_m,
            main_directions_deg: md.directions_rad.iter().map(|d| d.to_degrees()).collect(),
        }
    }

    /// How many numbers the snapshot stores (its share of [`ReportBudget::max_snapshot_numbers`]).
    pub fn numbers(&self) -> usize {
        4 * self.segments.len() + self.histogram_m.len() + self.main_directions_deg.len() + 4
    }
}

/// The diagnostics of one scan.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct ScanStat {
    /// The scan (0-based, in processing order).
    pub scan_index: u32,
    /// RMS residual of the scan's alignment, metres; `None` when it was not aligned.
    pub icp_residual_m: Option<f64>,
    /// ICP iterations run.
    pub icp_iterations: u32,
    /// Segments extracted from the scan.
    pub scan_segments: u32,
    /// Segments in the map after the scan.
    pub map_segments: u32,
    /// Tracking was lost on this scan.
    #[serde(default)]
    pub lost: bool,
    /// The scan follows a gap in the log (scans missing; see
    /// [`polymap::mapper::ScanDiagnostics::after_gap`]).
    #[serde(default)]
    pub after_gap: bool,
    /// The log's odometry contradicts the scan's tracked step (see
    /// [`polymap::mapper::ScanDiagnostics::off_odometry`]).
    #[serde(default)]
    pub off_odometry: bool,
}

impl ScanStat {
    /// The numbers of a [`polymap::mapper::Update`].
    pub fn from_update(update: &polymap::mapper::Update) -> Self {
        let d = &update.diagnostics;
        let sat = |n: usize| u32::try_from(n).unwrap_or(u32::MAX);
        ScanStat {
            scan_index: update.scan_index,
            icp_residual_m: d.align.as_ref().map(|a| a.residual_rms_m),
            icp_iterations: d.align.as_ref().map_or(0, |a| sat(a.iterations)),
            scan_segments: sat(d.scan_segments),
            map_segments: sat(d.map_segments),
            lost: d.tracking.verdict == polymap::tracking::Verdict::Lost,
            after_gap: d.after_gap,
            off_odometry: d.off_odometry,
        }
    }
}

/// One point of a plotted series.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct SeriesPoint {
    /// The scan.
    pub scan_index: u32,
    /// The value (unit given by the series).
    pub value: f64,
}

/// The per-scan series, each decimated to a bounded number of points (min and max of each
/// bucket of scans, so spikes survive).
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct ScanSeries {
    /// RMS ICP residual, metres.
    pub icp_residual_m: Vec<SeriesPoint>,
    /// ICP iterations.
    pub icp_iterations: Vec<SeriesPoint>,
    /// Segments extracted per scan.
    pub scan_segments: Vec<SeriesPoint>,
    /// Segments in the map.
    pub map_segments: Vec<SeriesPoint>,
}

impl ScanSeries {
    /// The series of a list of scan statistics, each decimated to at most `max_points` points.
    pub fn from_stats(stats: &[ScanStat], max_points: usize) -> Self {
        let series = |f: &dyn Fn(&ScanStat) -> Option<f64>| {
            let points = stats.iter().filter_map(|s| {
                f(s).map(|value| SeriesPoint {
                    scan_index: s.scan_index,
                    value,
                })
            });
            decimate_min_max(points, max_points)
        };
        ScanSeries {
            icp_residual_m: series(&|s| s.icp_residual_m),
            icp_iterations: series(&|s| Some(f64::from(s.icp_iterations))),
            scan_segments: series(&|s| Some(f64::from(s.scan_segments))),
            map_segments: series(&|s| Some(f64::from(s.map_segments))),
        }
    }
}

#[cfg(test)]
mod tests;
