//! The effective configuration: a preset, then a TOML file, then flags.

use std::path::Path;

use anyhow::{Context, Result, anyhow};
use polymap::config::{Config, PRESETS};
use polymap::mapper::MotionPrior;

/// Builds the configuration from a preset name, an optional TOML file and the odometry flag.
pub fn effective_config(preset: &str, file: Option<&Path>, odometry: bool) -> Result<Config> {
    let mut config = match file {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("{}: cannot read", path.display()))?;
            toml::from_str(&text).map_err(|e| anyhow!("{}: {e}", path.display()))?
        }
        None => Config::preset(preset)
            .ok_or_else(|| anyhow!("unknown preset {preset:?}; known: {}", PRESETS.join(", ")))?,
    };
    if odometry {
        config.mapper.motion_prior = MotionPrior::Odometry;
    }
    Ok(config)
}

/// The configuration as TOML text.
pub fn to_toml(config: &Config) -> Result<String> {
    toml::to_string_pretty(config).context("cannot write the configuration as TOML")
}
