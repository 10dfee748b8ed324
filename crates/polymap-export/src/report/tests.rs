use super::*;
use polymap::geometry::Vec2;

fn wall(i: u32) -> Segment {
    let x = f64::from(i);
    Segment::new(Vec2::new(x, 0.0), Vec2::new(x + 0.5, 0.0))
}

/// A recorder fed `scans` scans whose map grows by one segment per scan up to 500.
fn record_growing_map(scans: u32, budget: ReportBudget) -> (ReportData, u32) {
    let mut recorder = ReportRecorder::new("growing", budget);
    let mut built = 0;
    for t in 0..scans {
        let stat = ScanStat {
            scan_index: t,
            icp_residual_m: (t > 0).then_some(0.01 * f64::from(t % 5)),
            icp_iterations: 3,
            scan_segments: 4,
            map_segments: t + 1,
            lost: false,
            after_gap: false,
            off_odometry: false,
        };
        recorder.record(stat, Pose2::new(f64::from(t), 0.0, 0.0), || {
            built += 1;
            SnapshotContent {
                segments: (0..=t.min(499)).map(wall).collect(),
                histogram_m: vec![0.0; 180],
                main_directions_deg: vec![0.0],
            }
        });
    }
    let final_content = SnapshotContent {
        segments: (0..scans).map(wall).collect(),
        ..Default::default()
    };
    (recorder.finish(final_content), built)
}

#[test]
fn short_runs_keep_everything() {
    let (data, built) = record_growing_map(20, ReportBudget::default());
    assert_eq!(built, 20);
    assert_eq!(data.total_scans, 20);
    assert_eq!(data.snapshots.len(), 20);
    assert_eq!(data.trajectory.len(), 20);
    assert_eq!(data.series.map_segments.len(), 20);
    assert_eq!(
        data.series.icp_residual_m.len(),
        19,
        "scan 0 was not aligned"
    );
    assert_eq!(data.snapshots[7].content.segments.len(), 8);
}

#[test]
fn long_runs_stay_within_the_budget_and_keep_the_ends() {
    let budget = ReportBudget {
        max_snapshot_numbers: 100_000,
        max_series_points: 400,
        max_trajectory_poses: 1000,
    };
    let (data, built) = record_growing_map(13_631, budget.clone());
    let numbers: usize = data.snapshots.iter().map(|s| s.content.numbers()).sum();
    let last = data
        .snapshots
        .last()
        .map(|s| s.content.numbers())
        .unwrap_or(0);
    assert!(numbers <= budget.max_snapshot_numbers + last, "{numbers}");
    assert!(data.snapshots.len() >= 16, "{}", data.snapshots.len());
    assert_eq!(data.snapshots.first().map(|s| s.scan_index), Some(0));
    assert_eq!(data.snapshots.last().map(|s| s.scan_index), Some(13_630));
    assert!(data.trajectory.len() <= 1001);
    assert_eq!(data.trajectory.last().map(|p| p.scan_index), Some(13_630));
    assert!(data.series.map_segments.len() <= 400);
    // The closure ran for only a small fraction of the scans.
    assert!(built < 2_000, "{built}");
}

#[test]
fn snapshot_content_of_map_uses_recent_segments_for_directions() {
    let old = MapSegment {
        segment: Segment::new(Vec2::ZERO, Vec2::new(0.0, 10.0)),
        born_scan: 0,
    };
    let recent = MapSegment {
        segment: Segment::new(Vec2::ZERO, Vec2::new(10.0, 0.0)),
        born_scan: 95,
    };
    let params = DirectionParams::default();
    let content = SnapshotContent::of_map(&[old, recent], 100, &params);
    assert_eq!(content.segments.len(), 2);
    assert_eq!(content.histogram_m.len(), 180);
    assert_eq!(content.main_directions_deg.len(), 1);
    let d = content.main_directions_deg[0];
    assert!(d.min(180.0 - d) < 1.0, "{d}");
}

#[test]
fn series_from_stats_skip_missing_residuals() {
    let stats: Vec<ScanStat> = (0..10u32)
        .map(|t| ScanStat {
            scan_index: t,
            icp_residual_m: (t % 2 == 0).then_some(0.02),
            map_segments: t,
            ..Default::default()
        })
        .collect();
    let series = ScanSeries::from_stats(&stats, 4000);
    assert_eq!(series.icp_residual_m.len(), 5);
    assert_eq!(series.map_segments.len(), 10);
    assert_eq!(series.map_segments[9].value, 9.0);
}

/// A segment with coordinates of the usual length (metres with three decimals, some negative).
fn realistic_segment(i: u32) -> Segment {
    let x = -17.123_4 + 0.731_7 * f64::from(i % 53);
    let y = -9.876_5 + 0.519_3 * f64::from(i / 53);
    Segment::new(Vec2::new(x, y), Vec2::new(x + 0.612_3, y + 0.287_1))
}

#[test]
fn an_intel_sized_run_renders_to_a_few_megabytes() {
    // 13 631 scans (the intel log) with a map that grows to 1 500 segments.
    let mut recorder = ReportRecorder::new("intel-sized", ReportBudget::default());
    for t in 0..13_631u32 {
        let stat = ScanStat {
            scan_index: t,
            icp_residual_m: Some(0.0123 + 1e-6 * f64::from(t % 97)),
            icp_iterations: 5,
            scan_segments: 12,
            map_segments: (t / 9).min(1500),
            lost: false,
            after_gap: false,
            off_odometry: false,
        };
        let pose = Pose2::new(
            0.01 * f64::from(t % 3000),
            -12.345 + 0.001 * f64::from(t),
            1.0,
        );
        recorder.record(stat, pose, || SnapshotContent {
            segments: (0..(t / 9).min(1500)).map(realistic_segment).collect(),
            histogram_m: (0..180).map(|b| 0.123 * f64::from(b % 7)).collect(),
            main_directions_deg: vec![1.25, 91.5],
        });
    }
    let data = recorder.finish(SnapshotContent::default());
    let html =
        render_report_html(&polymap_io::snapshot::MapSnapshot::default(), &data).expect("renders");
    println!(
        "intel-sized report: {} bytes, {} snapshots, {} poses",
        html.len(),
        data.snapshots.len(),
        data.trajectory.len()
    );
    assert!(html.len() < 4_000_000, "{} bytes", html.len());
    assert!(data.snapshots.len() >= 40, "{}", data.snapshots.len());
}

#[test]
fn lost_scans_become_ranges_and_gaps_marks_on_the_time_line() {
    let mut recorder = ReportRecorder::new("lost", ReportBudget::default());
    for t in 0..10u32 {
        let stat = ScanStat {
            scan_index: t,
            lost: matches!(t, 2..=4 | 7),
            after_gap: t == 5,
            off_odometry: matches!(t, 6 | 8),
            ..Default::default()
        };
        recorder.record(stat, Pose2::IDENTITY, SnapshotContent::default);
    }
    let mut data = recorder.finish(SnapshotContent::default());
    // The caller adds the mapper's weak stretches; the recorder has none of its own.
    assert!(data.weak_stretches.is_empty());
    data.weak_stretches = vec![[0, 1]];
    assert_eq!(data.lost_ranges, vec![[2, 4], [7, 7]]);
    assert_eq!((data.gap_scans.clone(), data.gaps), (vec![5], 1));
    assert_eq!(
        (data.off_odometry_scans.clone(), data.off_odometry),
        (vec![6, 8], 2)
    );
    let html =
        crate::report::render_report_html(&polymap_io::snapshot::MapSnapshot::default(), &data)
            .expect("renders");
    assert!(html.contains("\"lost_ranges\":[[2,4],[7,7]]"));
    assert!(html.contains("\"gap_scans\":[5]"));
    assert!(html.contains("\"off_odometry_scans\":[6,8]"));
    assert!(html.contains("\"weak_stretches\":[[0,1]]"));
    assert!(html.contains("\"map_consistency\":null"));
    let checked = ReportData {
        map_consistency: Some(crate::report::MapConsistency {
            seen_through_share: 0.25,
            warn_above: 0.1,
            crossed_share: Some(0.5),
            warn_crossed_above: 0.2,
            crossed_scans: vec![[3, 9]],
            walls_seen_through_share: Some(0.08),
            warn_walls_above: 0.06,
            walls_contradicted: 3,
            seen_through_scans: vec![[40, 52]],
        }),
        ..data
    };
    let html =
        crate::report::render_report_html(&polymap_io::snapshot::MapSnapshot::default(), &checked)
            .expect("renders");
    assert!(html.contains(
        "\"map_consistency\":{\"seen_through_share\":0.25,\"warn_above\":0.1,\
         \"crossed_share\":0.5,\"warn_crossed_above\":0.2,\"crossed_scans\":[[3,9]],\
         \"walls_seen_through_share\":0.08,\"warn_walls_above\":0.06,\
         \"walls_contradicted\":3,\"seen_through_scans\":[[40,52]]}"
    ));
}

/// A report written before the check of walls that cross reads back without it: no share,
/// no warning of walls drawn twice (the page shows no row for it).
#[test]
fn a_map_consistency_without_the_crossing_check_reads_as_not_checked() {
    let old: crate::report::MapConsistency =
        serde_json::from_str(r#"{"seen_through_share":0.25,"warn_above":0.1}"#).unwrap();
    assert_eq!(old.crossed_share, None);
    assert!(old.likely_inconsistent());
    assert!(!old.walls_drawn_twice());
    assert!(!old.walls_seen_through());
    let written = serde_json::to_string(&old).unwrap();
    assert!(!written.contains("crossed_share"), "{written}");
}
