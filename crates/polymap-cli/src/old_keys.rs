//! Keys of `[tracking]` and `[mapper]` that moved into a subsection or became fixed values:
//! a configuration file that still sets one is refused with what to write instead.

use anyhow::{Result, bail};

/// Each old key (`section.key`) and what became of it.
const OLD_KEYS: &[(&str, &str)] = &[
    (
        "tracking.window_search",
        "moved: write `enabled` under `[tracking.search]`",
    ),
    (
        "tracking.search_above_step_m",
        "moved: write it under `[tracking.search]`",
    ),
    (
        "tracking.search_above_turn_deg",
        "moved: write it under `[tracking.search]`",
    ),
    (
        "tracking.search_below_inlier_share",
        "moved: write it under `[tracking.search]`",
    ),
    (
        "tracking.min_window_m",
        "moved: write it under `[tracking.search]`",
    ),
    (
        "tracking.max_window_m",
        "moved: write it under `[tracking.search]`",
    ),
    (
        "tracking.min_window_deg",
        "moved: write it under `[tracking.search]`",
    ),
    (
        "tracking.max_window_deg",
        "moved: write it under `[tracking.search]`",
    ),
    (
        "tracking.lost_below_inlier_share",
        "moved: write it under `[tracking.verdict]`",
    ),
    (
        "tracking.weak_below_inlier_share",
        "moved: write it under `[tracking.verdict]`",
    ),
    (
        "tracking.lost_below_inlier_ratio",
        "moved: write it under `[tracking.verdict]`",
    ),
    (
        "tracking.weak_below_inlier_ratio",
        "moved: write it under `[tracking.verdict]`",
    ),
    (
        "tracking.weak_below_information",
        "moved: write it under `[tracking.verdict]`",
    ),
    (
        "tracking.slowed_below_information",
        "moved: write it under `[tracking.verdict]`",
    ),
    (
        "tracking.ambiguous_above",
        "moved: write it under `[tracking.verdict]`",
    ),
    (
        "tracking.rival_apart_m",
        "moved: write it under `[tracking.verdict]`",
    ),
    (
        "tracking.rival_apart_deg",
        "moved: write it under `[tracking.verdict]`",
    ),
    (
        "tracking.max_speed_m_s",
        "moved: write it under `[tracking.reach]`",
    ),
    (
        "tracking.max_turn_deg_s",
        "moved: write it under `[tracking.reach]`",
    ),
    (
        "tracking.odometry_witness_m",
        "moved: write it under `[tracking.odometry]`",
    ),
    (
        "tracking.odometry_check_m",
        "moved: write it under `[tracking.odometry]`",
    ),
    (
        "tracking.odometry_check_deg",
        "moved: write it under `[tracking.odometry]`",
    ),
    (
        "tracking.odometry_max_window_deg",
        "moved: write it under `[tracking.odometry]`",
    ),
    (
        "tracking.search_skip_above_inlier_share",
        "no longer a key: fixed at 0.9 (`polymap::tracking::SEARCH_SKIP_ABOVE_INLIER_SHARE`)",
    ),
    (
        "tracking.window_per_step",
        "no longer a key: fixed at 1.0 (`polymap::tracking::WINDOW_PER_STEP`)",
    ),
    (
        "tracking.window_per_recent",
        "no longer a key: fixed at 1.0 (`polymap::tracking::WINDOW_PER_RECENT`)",
    ),
    (
        "tracking.window_per_turn",
        "no longer a key: fixed at 1.0 (`polymap::tracking::WINDOW_PER_TURN`)",
    ),
    (
        "tracking.window_deg_per_m",
        "no longer a key: fixed at 60.0 (`polymap::tracking::WINDOW_DEG_PER_M`)",
    ),
    (
        "tracking.lost_window_growth_m",
        "no longer a key: fixed at 0.5 (`polymap::tracking::LOST_WINDOW_GROWTH_M`)",
    ),
    (
        "tracking.lost_window_max_m",
        "no longer a key: fixed at 3.0 (`polymap::tracking::LOST_WINDOW_MAX_M`)",
    ),
    (
        "tracking.relocalize_every_lost",
        "no longer a key: fixed at 10 (`polymap::tracking::RELOCALIZE_EVERY_LOST`)",
    ),
    (
        "tracking.search_cell_m",
        "no longer a key: fixed at 0.1 (`polymap::tracking::SEARCH_CELL_M`)",
    ),
    (
        "tracking.search_sigma_m",
        "no longer a key: fixed at 0.2 (`polymap::tracking::SEARCH_SIGMA_M`)",
    ),
    (
        "tracking.search_points",
        "no longer a key: fixed at 100 (`polymap::tracking::SEARCH_POINTS`)",
    ),
    (
        "tracking.search_max_range_m",
        "no longer a key: fixed at 8.0 (`polymap::tracking::SEARCH_MAX_RANGE_M`)",
    ),
    (
        "tracking.search_win_margin",
        "no longer a key: fixed at 0.1 (`polymap::tracking::SEARCH_WIN_MARGIN`)",
    ),
    (
        "tracking.unobserved_reach_m",
        "no longer a key: fixed at 1.0 (`polymap::tracking::UNOBSERVED_REACH_M`)",
    ),
    (
        "tracking.loose_point_scans",
        "no longer a key: fixed at 5 (`polymap::tracking::LOOSE_POINT_SCANS`)",
    ),
    (
        "tracking.loose_point_spacing_m",
        "no longer a key: fixed at 0.1 (`polymap::tracking::LOOSE_POINT_SPACING_M`)",
    ),
    (
        "tracking.corner_reach_m",
        "no longer a key: fixed at 3.0 (`polymap::tracking::CORNER_REACH_M`)",
    ),
    (
        "tracking.corner_seeds",
        "no longer a key: fixed at 3 (`polymap::tracking::CORNER_SEEDS`)",
    ),
    (
        "tracking.corner_win_ratio",
        "no longer a key: fixed at 1.5 (`polymap::tracking::CORNER_WIN_RATIO`)",
    ),
    (
        "tracking.corner_rival_below",
        "no longer a key: fixed at 0.85 (`polymap::tracking::CORNER_RIVAL_BELOW`)",
    ),
    (
        "tracking.corner_min_segment_m",
        "no longer a key: fixed at 0.3 (`polymap::tracking::CORNER_MIN_SEGMENT_M`)",
    ),
    (
        "tracking.reach_slack_m",
        "no longer a key: fixed at 0.3 (`polymap::tracking::REACH_SLACK_M`)",
    ),
    (
        "tracking.reach_slack_deg",
        "no longer a key: fixed at 20.0 (`polymap::tracking::REACH_SLACK_DEG`)",
    ),
    (
        "mapper.weak_direction_velocity",
        "no longer a key: fixed at 0.0 (`polymap::tracking::WEAK_DIRECTION_VELOCITY`)",
    ),
    (
        "mapper.start_score_margin",
        "no longer a key: fixed at 1.0 (`polymap::tracking::START_SCORE_MARGIN`)",
    ),
    (
        "tracking.search_unobserved",
        "no longer a key: the rule is always on",
    ),
    (
        "tracking.merge_doubtful_scans",
        "no longer a key: the rule is always on",
    ),
    (
        "tracking.icp_loose_points",
        "no longer a key: the rule is always on",
    ),
    (
        "tracking.turn_on_the_spot",
        "no longer a key: the rule is always on",
    ),
    (
        "tracking.gap_window",
        "no longer a key: the rule is always on",
    ),
    (
        "tracking.reversed_odometry",
        "no longer a key: the rule is always on",
    ),
    (
        "tracking.corner_hypotheses",
        "no longer a key: the rule is always on",
    ),
];

/// Refuses a configuration file (its TOML table) that sets an old key, naming the key and
/// what to write instead.
pub fn refuse_old_keys(file: &toml::Table) -> Result<()> {
    for (section, table) in file {
        let Some(table) = table.as_table() else {
            continue;
        };
        for key in table.keys() {
            let old = format!("{section}.{key}");
            if let Some((_, now)) = OLD_KEYS.iter().find(|(k, _)| *k == old) {
                bail!("`{old}` is {now} (see CHANGELOG.md, 'Changed')");
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_moved_or_removed_key_is_named_with_what_to_write_instead() {
        let file: toml::Table = toml::from_str("[tracking]\nmax_window_m = 2.0\n").unwrap();
        let e = refuse_old_keys(&file).unwrap_err().to_string();
        assert_eq!(
            e,
            "`tracking.max_window_m` is moved: write it under `[tracking.search]` (see \
             CHANGELOG.md, 'Changed')"
        );
        let file: toml::Table = toml::from_str("[tracking]\ncorner_seeds = 5\n").unwrap();
        let e = refuse_old_keys(&file).unwrap_err().to_string();
        assert!(
            e.contains("`tracking.corner_seeds` is no longer a key"),
            "{e}"
        );
        let now: toml::Table = toml::from_str("[tracking.search]\nmax_window_m = 2.0\n").unwrap();
        assert!(refuse_old_keys(&now).is_ok());
    }
}
