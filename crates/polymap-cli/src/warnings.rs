//! Counted warnings about what the reader accepted but found odd.

use polymap::tracking::{
    ODOMETRY_CHECK_MIN_TRAVEL_M, TrackingSummary, WEAK_STRETCH_M, WEAK_TRAVEL_SHARE,
};
use polymap_export::report::MapConsistency;
use polymap_io::carmen::CarmenStats;

/// Prints one warning line per kind of oddity the reader counted.
pub fn report_reader_warnings(stats: &CarmenStats) {
    for w in stats.warnings() {
        eprintln!("polymap: warning: {w}");
    }
}

/// Over this share of the scans tracked off the log's odometry
/// ([`TrackingSummary::off_odometry`]), the run says so: the benchmark logs' dense runs have
/// none, their runs of every 5th scan at most 1.3 %, of every 10th scan 0.9-9.9 %, where most
/// went wrong.
pub const WARN_OFF_ODOMETRY_ABOVE: f64 = 0.01;

/// Says when tracking failed ([`tracking_warnings`]), one line each.
pub fn warn_tracking(t: &TrackingSummary, scans: usize, witness_m: f64, odometry_used: bool) {
    for w in tracking_warnings(t, scans, witness_m, odometry_used) {
        eprintln!("polymap: warning: {w}");
    }
}

/// What tracking says of a run: the scans lost (not in the map), a large share of weak ones,
/// or of steps the log's odometry contradicts (by more than `witness_m`, metres), long
/// stretches of weak ones ([`TrackingSummary::weak_stretches`]) and travel on weakly observed
/// steps; and where scans are missing from the log (gaps in stamps that keep time). Where
/// weak travel is named, a run without `--odometry` (`odometry_used`) on a log whose odometry
/// agrees with the scans' travel is told that `--odometry` carries such stretches: the scans
/// cannot observe them, and the odometry can (the benchmark logs with the laser cut to 5.6 m,
/// median over 12 nuisance variants: Intel, ACES, FR079 within 0.1 m in 0, 0 and 9 of 12 runs
/// without it, 10, 12 and 12 with it).
pub fn tracking_warnings(
    t: &TrackingSummary,
    scans: usize,
    witness_m: f64,
    odometry_used: bool,
) -> Vec<String> {
    let mut out = Vec::new();
    let odometry_witnesses =
        !odometry_used && t.odometry_agrees_with_travel(ODOMETRY_CHECK_MIN_TRAVEL_M);
    let advice = match odometry_witnesses {
        true => {
            "; the log's odometry agrees with the scans' travel: mapping with --odometry \
                 carries such stretches"
        }
        false => "",
    };
    if t.lost > 0 {
        let ranges: Vec<String> = t
            .lost_ranges
            .iter()
            .take(10)
            .map(|[a, b]| {
                if a == b {
                    format!("{a}")
                } else {
                    format!("{a}-{b}")
                }
            })
            .collect();
        let more = if t.lost_ranges.len() > 10 {
            ", ..."
        } else {
            ""
        };
        out.push(format!(
            "tracking lost {} of {scans} scans (scans {}{more}): they are not \
             in the map and their poses are unreliable (summary.json: tracking)",
            t.lost,
            ranges.join(", ")
        ));
    }
    if t.gaps > 0 {
        let listed: Vec<String> = t.gap_scans.iter().take(10).map(|s| s.to_string()).collect();
        let more = if t.gaps as usize > listed.len() {
            ", ..."
        } else {
            ""
        };
        out.push(format!(
            "{} gap(s) in the log, where scans are missing (a time step at \
             least 3 times the usual one; the scans after them: {}{more}): tracking across a gap is less \
             sure, check the map there (summary.json: tracking.gaps)",
            t.gaps,
            listed.join(", ")
        ));
    }
    if t.off_odometry as f64 > WARN_OFF_ODOMETRY_ABOVE * scans as f64 {
        let listed: Vec<String> = t
            .off_odometry_scans
            .iter()
            .take(10)
            .map(|s| s.to_string())
            .collect();
        let more = if t.off_odometry as usize > listed.len() {
            ", ..."
        } else {
            ""
        };
        out.push(format!(
            "the tracked step of {} of {scans} scans is more than {witness_m} m \
             off the log's odometry (scans {}{more}): tracking slipped \
             there (a corridor tracked short, a wrong door frame) or the odometry did; check \
             the map, and since the odometry's travel agrees with the scans', try --odometry \
             (summary.json: tracking.off_odometry)",
            t.off_odometry,
            listed.join(", ")
        ));
    }
    if odometry_witnesses && !t.short_of_odometry.is_empty() {
        let listed: Vec<String> = t
            .short_of_odometry
            .iter()
            .take(5)
            .map(|s| {
                format!(
                    "{}-{} ({:.1} m by the odometry; median tracked step {:.0} % of the odometry's)",
                    s.first,
                    s.last,
                    s.odometry_m,
                    100.0 * s.median_ratio
                )
            })
            .collect();
        let more = if t.short_of_odometry.len() > listed.len() {
            "; ..."
        } else {
            ""
        };
        out.push(format!(
            "tracking fell short of the log's odometry over {} stretch(es), scans {}{more}: \
             the median tracked step was under half the odometry's, while over the run the two \
             agree; the robot was likely held back (features along a corridor matched to the \
             wrong ones) and the map may be shortened; check the map at those scans; mapping \
             with --odometry carries such stretches (summary.json: tracking.short_of_odometry)",
            t.short_of_odometry.len(),
            listed.join("; ")
        ));
    }
    if !t.weak_stretches.is_empty() {
        let listed: Vec<String> = t
            .weak_stretches
            .iter()
            .take(5)
            .map(|w| format!("{}-{}: {:.1} m", w.first, w.last, w.travel_m))
            .collect();
        let more = if t.weak_stretches.len() > listed.len() {
            ", ..."
        } else {
            ""
        };
        out.push(format!(
            "tracking was weak for {} stretch(es) of at least {WEAK_STRETCH_M} \
             m of travel (scans {}{more}): the motion along them came from the motion prior or \
             from few points, so distances there may be off (a corridor tracked short); check \
             the map there{advice} (summary.json: tracking.weak_stretches)",
            t.weak_stretches.len(),
            listed.join(", ")
        ));
    }
    if t.weak_travel_warns() {
        let mut parts = t.weak_travel_parts.clone();
        parts.sort_by(|a, b| b.weak_travel_m.total_cmp(&a.weak_travel_m));
        let listed: Vec<String> = parts
            .iter()
            .take(3)
            .map(|p| {
                format!(
                    "scans {}-{}: {:.0} % of {:.0} m",
                    p.first,
                    p.last,
                    100.0 * p.weak_travel_m / p.travel_m.max(1e-9),
                    p.travel_m
                )
            })
            .collect();
        let most = match listed.is_empty() {
            true => String::new(),
            false => format!(" (most in {})", listed.join(", ")),
        };
        out.push(format!(
            "{:.0} % of the travel ({:.1} of {:.1} m) was on steps observed \
             by few points along a direction (above {:.0} %){most}: distances along corridors \
             came from the motion prior there, and many slightly short steps bend or shorten \
             the map (a short-range laser, long bare corridors); check the map there{advice} \
             (summary.json: tracking.weak_travel_m, weak_travel_parts)",
            100.0 * t.weak_travel_m / t.travel_m.max(1e-9),
            t.weak_travel_m,
            t.travel_m,
            100.0 * WEAK_TRAVEL_SHARE,
        ));
    }
    // Scans weak only because a direction was observed by few points are common along any
    // corridor, also where tracking is accurate (the built-in hallway: 12 %); they are counted
    // in summary.json but do not raise the warning.
    let doubtful = t.weak.saturating_sub(t.weakly_observed);
    if doubtful as f64 > 0.1 * scans as f64 {
        out.push(format!(
            "tracking was weak on {doubtful} of {scans} scans (a direction came \
             from the motion prior, the fit was poor or ambiguous, or the step fell short of the \
             robot's speed or off the log's odometry; the longest runs of them: scans {}): check \
             the map there (summary.json: tracking.doubtful_ranges)",
            longest_ranges(&t.doubtful_ranges, 10)
        ));
    }
    out
}

/// The `n` longest of `ranges` (inclusive scan ranges), in scan order, as `a-b` or `a`;
/// `...` at the end when some were left out.
fn longest_ranges(ranges: &[[u32; 2]], n: usize) -> String {
    let mut longest: Vec<&[u32; 2]> = ranges.iter().collect();
    longest.sort_by_key(|r| std::cmp::Reverse(r[1] - r[0]));
    longest.truncate(n);
    longest.sort();
    let mut listed: Vec<String> = longest
        .iter()
        .map(|[a, b]| match a == b {
            true => format!("{a}"),
            false => format!("{a}-{b}"),
        })
        .collect();
    if ranges.len() > n {
        listed.push("...".into());
    }
    listed.join(", ")
}

/// Says when the log's odometry travelled under half or over twice what the scans tracked `ok`
/// did ([`TrackingSummary::odometry_disagrees_with_travel`]): odometry that is stuck (a log
/// whose odometry fields are zeros), scaled or not the robot's. With `--odometry` (`used`)
/// that odometry seeds tracking.
pub fn warn_odometry(t: &TrackingSummary, used: bool) {
    if !t.odometry_disagrees_with_travel(ODOMETRY_CHECK_MIN_TRAVEL_M) {
        return;
    }
    let advice = match used {
        true => "--odometry starts tracking from it: map without --odometry",
        false => "do not map this log with --odometry",
    };
    eprintln!(
        "polymap: warning: the log's odometry travelled {:.1} m where the scans tracked ok \
         travelled {:.1} m: the odometry is stuck, scaled or not this robot's (or tracking \
         went wrong: look at the picture); {advice} (summary.json: tracking.odometry_travel_m)",
        t.odometry_travel_m, t.tracked_travel_m
    );
}

/// Says when the map is likely inconsistent: its scans saw through its walls more than
/// `warn_above` as often as they saw them (`observe.warn_seen_through_above`; see
/// [`polymap::observe::seen_through_share`]); and when more than `warn_crossed_above` of its
/// length is drawn twice about walls that cross (`observe.warn_crossed_above`; see
/// [`polymap::observe::crossed_walls`]), naming the scans that last merged into them; and when
/// every second observing scan, cast again at its final pose, saw through the finished map's
/// walls more than `warn_walls_above` as often as it saw them
/// ([`polymap::observe::walls_seen_through`]), naming the scans that placed those walls.
pub fn warn_consistency(consistency: Option<&MapConsistency>) {
    if let Some(c) = consistency.filter(|c| c.seen_through_share > c.warn_above) {
        eprintln!(
            "polymap: warning: the map is likely inconsistent: the scans saw through its walls \
             {:.0} % as often as they saw them (above {:.0} %; 2-9 % where tracking held on the \
             benchmark logs): walls mapped from wrong poses, doubled walls or a loop that did \
             not close; look at the picture (summary.json: map_consistency)",
            100.0 * c.seen_through_share,
            100.0 * c.warn_above
        );
    }
    if let Some(c) = consistency.filter(|c| c.walls_seen_through()) {
        eprintln!("polymap: warning: {}", walls_seen_through_warning(c));
    }
    if let Some(c) = consistency.filter(|c| c.walls_drawn_twice()) {
        eprintln!(
            "polymap: warning: the map draws walls twice, turned apart: {:.1} % of its length \
             is drawn twice about walls that cross each other at 5-30° (above {:.0} %; at \
             most 6.2 % on the maps of the benchmark and sparse logs): a curved wall drawn as \
             straight chords, or walls mapped from poses turned against each other; the walls \
             were last merged into by {} (summary.json: map_consistency.crossed_share)",
            100.0 * c.crossed_share.unwrap_or(0.0),
            100.0 * c.warn_crossed_above,
            match c.crossed_scans.is_empty() {
                true => "the runs before this one (the map it continued)".to_string(),
                false => format!("scans {}", longest_ranges(&c.crossed_scans, 10)),
            }
        );
    }
}

/// The warning of [`MapConsistency::walls_seen_through`], naming where to look.
fn walls_seen_through_warning(c: &MapConsistency) -> String {
    // The walls counted are the run's own, so each one named has scans of this run.
    let named = match c.seen_through_scans.is_empty() {
        true => "no wall of 1 m or more is seen through at least 5 times and at least half as \
                 often as it is seen: look at the picture"
            .to_string(),
        false => format!(
            "the walls seen through at least half as often as seen were last merged into by \
             scans {}",
            longest_ranges(&c.seen_through_scans, 10)
        ),
    };
    format!(
        "the map is likely inconsistent: cast again at their final poses, every second scan \
         that observed saw through the finished map's walls (1 m or longer) {:.1} % as often as \
         they saw them (above {:.1} %; at most 4.4 % on the dense benchmark runs): walls placed \
         from wrong poses stand where other scans saw free space, or walls crept with the poses \
         away from where earlier scans saw them; {named} (summary.json: \
         map_consistency.walls_seen_through_share)",
        100.0 * c.walls_seen_through_share.unwrap_or(0.0),
        100.0 * c.warn_walls_above,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run 30 % of whose 100 m of travel was weakly observed, in one weak stretch of 12 m,
    /// the log's odometry travelling `odometry_m`.
    fn weakly_observed_run(odometry_m: f64) -> TrackingSummary {
        let mut t = TrackingSummary::default();
        (t.ok, t.weak, t.weakly_observed) = (700, 300, 300);
        (t.travel_m, t.tracked_travel_m, t.weak_travel_m) = (100.0, 90.0, 30.0);
        t.odometry_travel_m = odometry_m;
        t.weak_stretches = vec![polymap::tracking::WeakStretch {
            first: 400,
            last: 520,
            travel_m: 12.0,
        }];
        t
    }

    /// Weak travel the scans cannot observe is what odometry carries: without `--odometry`,
    /// on a log whose odometry agrees with the scans' travel, both warnings that name weak
    /// travel say so; not with `--odometry`, nor where the odometry disagrees (stuck at zero).
    #[test]
    fn weak_travel_names_odometry_where_the_log_has_odometry_that_agrees() {
        let advice = "mapping with --odometry carries such stretches";
        let named = |t: &TrackingSummary, used: bool| {
            let lines = tracking_warnings(t, 1000, 0.3, used);
            let weak: Vec<&String> = lines
                .iter()
                .filter(|l| l.contains("weak_stretches") || l.contains("weak_travel_m"))
                .collect();
            assert_eq!(weak.len(), 2, "{lines:?}");
            weak.iter().filter(|l| l.contains(advice)).count()
        };
        assert_eq!(named(&weakly_observed_run(95.0), false), 2);
        assert_eq!(named(&weakly_observed_run(95.0), true), 0);
        assert_eq!(named(&weakly_observed_run(0.0), false), 0);
    }

    /// A stretch tracked short of the odometry is told, named by its scans, where the log's
    /// odometry witnesses: not with `--odometry` (the odometry was the prior), nor where the
    /// odometry disagrees with the scans' travel over the run (stuck, scaled, not the robot's).
    #[test]
    fn a_stretch_short_of_the_odometry_is_named_where_the_odometry_witnesses() {
        let short = |odometry_m: f64| {
            let mut t = weakly_observed_run(odometry_m);
            t.short_of_odometry = vec![polymap::tracking::ShortStretch {
                first: 4797,
                last: 4815,
                odometry_m: 2.05,
                median_ratio: 0.28,
            }];
            t
        };
        let told = |t: &TrackingSummary, used: bool| {
            let lines = tracking_warnings(t, 1000, 0.3, used);
            let found: Vec<&String> = lines
                .iter()
                .filter(|l| l.contains("short_of_odometry"))
                .collect();
            assert!(found.len() <= 1, "{lines:?}");
            found.first().map(|l| {
                l.contains(
                    "scans 4797-4815 (2.0 m by the odometry; median tracked step 28 % of the odometry's):",
                )
            })
        };
        assert_eq!(told(&short(95.0), false), Some(true));
        assert_eq!(told(&short(95.0), true), None);
        assert_eq!(told(&short(0.0), false), None);
        assert_eq!(told(&weakly_observed_run(95.0), false), None);
    }

    #[test]
    fn the_longest_ranges_are_named_in_scan_order() {
        let ranges = [[1, 1], [4, 9], [12, 12], [20, 23], [30, 30]];
        assert_eq!(longest_ranges(&ranges, 2), "4-9, 20-23, ...");
        assert_eq!(longest_ranges(&ranges, 5), "1, 4-9, 12, 20-23, 30");
        assert_eq!(longest_ranges(&[], 3), "");
    }

    /// The walls-seen-through warning names the scans of the walls, and says so when no one
    /// wall stands out.
    #[test]
    fn the_walls_seen_through_warning_names_where_to_look() {
        let c = MapConsistency {
            walls_seen_through_share: Some(0.084),
            warn_walls_above: 0.06,
            walls_contradicted: 3,
            seen_through_scans: vec![[2554, 2564], [2641, 2654]],
            ..MapConsistency::default()
        };
        assert!(c.likely_inconsistent());
        let line = walls_seen_through_warning(&c);
        assert!(
            line.contains("8.4 %") && line.contains("above 6.0 %"),
            "{line}"
        );
        assert!(line.contains("scans 2554-2564, 2641-2654"), "{line}");
        let spread = MapConsistency {
            walls_contradicted: 0,
            seen_through_scans: Vec::new(),
            ..c
        };
        let line = walls_seen_through_warning(&spread);
        assert!(
            line.contains("look at the picture") && !line.contains("merged into by scans"),
            "{line}"
        );
    }
}
