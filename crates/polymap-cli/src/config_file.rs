//! The effective configuration: a preset, the flags that choose a mode, then TOML files in
//! order.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow};
use polymap::config::{Config, PRESETS};
use polymap::tracking::MotionPrior;
use polymap_io::input_file::read_regular_to_string;

/// The most a configuration file may weigh: a full configuration is about 6 kB.
const MAX_CONFIG_BYTES: u64 = 1 << 20;

/// Builds the configuration from a preset name, the odometry flag laid over it, then the TOML
/// files in order (a key a file sets always wins), and validates the result.
pub fn effective_config(preset: &str, files: &[PathBuf], odometry: bool) -> Result<Config> {
    let mut config = Config::preset(preset)
        .ok_or_else(|| anyhow!("unknown preset {preset:?}; known: {}", PRESETS.join(", ")))?;
    if odometry {
        config.mapper.motion_prior = MotionPrior::Odometry;
        // Measured on intel, aces and fr079: from an odometry guess, running ICP from every
        // start and keeping the most inliers wins (0.256 / 0.215 / 0.092 m against 0.676 /
        // 0.453 / 0.730 m for the best-scoring start alone, which is best without odometry).
        config.mapper.icp_from_best_start_only = false;
    }
    for path in files {
        config = layered(config, path)?;
    }
    config
        .validate()
        .map_err(|e| anyhow!("invalid configuration: {e}"))?;
    Ok(config)
}

/// A configuration with a TOML file laid over it: keys the file sets win, the rest stay.
fn layered(preset: Config, path: &Path) -> Result<Config> {
    let text = read_regular_to_string(path, MAX_CONFIG_BYTES)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let file: toml::Table =
        toml::from_str(&text).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    crate::old_keys::refuse_old_keys(&file).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    // The file alone first: an unknown key is then reported with its line.
    toml::from_str::<Config>(&text).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    let mut merged = toml::Table::try_from(&preset).context("cannot write the preset as TOML")?;
    merge(&mut merged, file);
    merged
        .try_into()
        .map_err(|e| anyhow!("{}: {e}", path.display()))
}

fn merge(base: &mut toml::Table, over: toml::Table) {
    for (k, v) in over {
        match (base.get_mut(&k), v) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            (_, v) => {
                base.insert(k, v);
            }
        }
    }
}

/// The configuration as TOML text.
pub fn to_toml(config: &Config) -> Result<String> {
    toml::to_string_pretty(config).context("cannot write the configuration as TOML")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `--odometry` is a layer under the files: what it sets (`icp_from_best_start_only`) a
    /// user's file may set otherwise, and the file wins.
    #[test]
    fn a_config_file_beats_what_odometry_chooses() {
        let from_flag = effective_config("default", &[], true).unwrap();
        assert_eq!(from_flag.mapper.motion_prior, MotionPrior::Odometry);
        assert!(!from_flag.mapper.icp_from_best_start_only);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("mine.toml");
        std::fs::write(&path, "[mapper]\nicp_from_best_start_only = true\n").unwrap();
        let mine = effective_config("default", &[path], true).unwrap();
        assert_eq!(mine.mapper.motion_prior, MotionPrior::Odometry);
        assert!(mine.mapper.icp_from_best_start_only);
    }

    /// `--config /dev/zero` was read until memory ran out.
    #[test]
    fn a_config_that_is_a_device_or_too_large_is_refused() {
        let e = effective_config("default", &[PathBuf::from("/dev/zero")], false).unwrap_err();
        assert!(
            format!("{e:#}").contains("/dev/zero: cannot read: a character device"),
            "{e:#}"
        );
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("huge.toml");
        std::fs::write(&path, vec![b'#'; MAX_CONFIG_BYTES as usize + 1]).unwrap();
        let e = effective_config("default", &[path], false).unwrap_err();
        assert!(format!("{e:#}").contains("more than"), "{e:#}");
    }

    /// A file written for the flat `[tracking]` is refused with the key and its new place;
    /// an unknown key with its line.
    #[test]
    fn an_old_or_unknown_key_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("old.toml");
        std::fs::write(&path, "[tracking]\nmax_speed_m_s = 1.0\n").unwrap();
        let e = effective_config("default", std::slice::from_ref(&path), false).unwrap_err();
        assert!(
            e.to_string()
                .contains("`tracking.max_speed_m_s` is moved: write it under `[tracking.reach]`"),
            "{e}"
        );
        std::fs::write(&path, "[tracking.reach]\nmax_speed_m_s = 1.0\n").unwrap();
        let c = effective_config("default", std::slice::from_ref(&path), false).unwrap();
        assert_eq!(c.tracking.reach.max_speed_m_s, 1.0);
        std::fs::write(&path, "[tracking.reach]\nmax_speed = 1.0\n").unwrap();
        let e = effective_config("default", &[path], false).unwrap_err();
        let e = e.to_string();
        assert!(
            e.contains("line 2") && e.contains("unknown field `max_speed`"),
            "{e}"
        );
    }

    #[test]
    fn an_out_of_range_key_is_named_with_its_rule() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.toml");
        std::fs::write(&path, "[align]\nmax_iterations = 0\n").unwrap();
        let e = effective_config("default", &[path], false).unwrap_err();
        assert_eq!(
            e.to_string(),
            "invalid configuration: align.max_iterations = 0 is out of range: must be within \
             [1, 10000]"
        );
    }
}
