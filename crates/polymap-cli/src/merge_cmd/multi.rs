//! More than two maps: the first is the merged map's frame; in each round every map not yet
//! merged is laid onto the merged map so far (rigidly, else bent, as two maps are), and the
//! accepted one whose walls overlap it most joins it. A map that fits nowhere (no overlap or
//! a conflict in the last round) or in two places (ambiguous) is refused with the reason.

use std::path::Path;
use std::time::Instant;

use anyhow::{Result, bail};
use polymap::align::MatchVerdict;
use polymap::config::Config;
use polymap_io::tum::write_tum;
use polymap_pipeline::folder::{RunFolder, check_output_apart};
use serde_json::json;

use super::input::{Input, global_map, read_input, shown};
use super::output::{merge, remove_stale, remove_stale_trajectories, write_json, write_outputs};
use super::pair::{Laid, lay};
use super::polylines_of;
use crate::args::MergeArgs;

/// What became of one input map.
enum Outcome {
    /// The first map: the merged map's frame.
    Frame,
    /// Joined the merged map at this step (1 for the first to join).
    Merged {
        step: usize,
        trajectory: Option<String>,
    },
    /// Refused: the last verdict and why.
    Refused { verdict: MatchVerdict, why: String },
}

pub(super) fn run(a: &MergeArgs) -> Result<()> {
    let inputs: Vec<Input> = a
        .maps
        .iter()
        .map(|m| read_input(m))
        .collect::<Result<_>>()?;
    let names: Vec<String> = (1..=inputs.len()).map(|i| format!("map {i}")).collect();
    let apart: Vec<(&str, &Path)> = names
        .iter()
        .zip(&inputs)
        .map(|(n, m)| (n.as_str(), m.dir.as_path()))
        .collect();
    check_output_apart(&a.output, &apart)?;
    let folder = RunFolder::prepare(&a.output)?;
    let config = Config::default();
    let started = Instant::now();
    let mut merged = start_from(&inputs[0]);
    let mut outcomes: Vec<Outcome> = vec![Outcome::Frame];
    outcomes.extend(inputs[1..].iter().map(|_| Outcome::Frame));
    let mut remaining: Vec<usize> = (1..inputs.len()).collect();
    let mut steps: Vec<serde_json::Value> = Vec::new();
    let mut laid_trajectories = Vec::new();
    while !remaining.is_empty() {
        let fixed = global_map(&merged.segments, &config);
        let mut tried: Vec<(usize, Laid)> = remaining
            .iter()
            .map(|&i| (i, lay(&merged, &fixed, &inputs[i], a.by, &config)))
            .collect();
        // The accepted map that overlaps the merged map most; ties to the earlier input.
        let best = tried
            .iter()
            .enumerate()
            .filter(|(_, (_, l))| l.refusal.is_none())
            .max_by(|x, y| x.1.1.overlap.total_cmp(&y.1.1.overlap).then(y.0.cmp(&x.0)))
            .map(|(k, _)| k);
        let Some(k) = best else {
            for (i, laid) in tried {
                let why = laid.refusal.unwrap_or_default();
                outcomes[i] = Outcome::Refused {
                    verdict: laid.verdict,
                    why,
                };
            }
            break;
        };
        let (i, laid) = tried.swap_remove(k);
        let mut report = laid.report.clone();
        let (segments, counts) = merge(&merged, &laid.b_segments, fixed, &config);
        report["segments"]["merged"] = json!(segments.len());
        report["segments"]["removed"] = json!(counts.removed);
        report["segments"]["added"] = json!(counts.added);
        steps.push(report);
        let trajectory =
            (!laid.b_trajectory.is_empty()).then(|| format!("trajectory_{}.tum", i + 1));
        if let Some(name) = &trajectory {
            laid_trajectories.push((name.clone(), laid.b_trajectory.clone()));
        }
        outcomes[i] = Outcome::Merged {
            step: steps.len(),
            trajectory,
        };
        join(&mut merged, &inputs[i], laid, segments);
        remaining.retain(|&r| r != i);
    }
    folder.begin_writing()?;
    let report = multi_json(&inputs, &outcomes, steps, merged.segments.len(), started);
    let refused: Vec<String> = outcomes
        .iter()
        .zip(&inputs)
        .filter_map(|(o, m)| match o {
            Outcome::Refused { why, .. } => Some(format!("{}: {why}", m.label)),
            _ => None,
        })
        .collect();
    if refused.len() + 1 == inputs.len() {
        remove_stale(folder.path())?;
        write_json(&folder.path().join("merge.json"), &report)?;
        folder.finish_writing(&["merge.json"])?;
        bail!(
            "no map joins {}: not merged (see merge.json)\n{}",
            inputs[0].label,
            refused.join("\n")
        );
    }
    let polylines = polylines_of(&merged.segments, &config);
    let scans_before = merged.scans.saturating_sub(inputs[0].scans);
    write_outputs(
        folder.path(),
        &start_from(&inputs[0]),
        scans_before,
        &merged.segments,
        &polylines,
        &report,
    )?;
    let mut written = vec![
        "map.json".to_string(),
        "merge.json".into(),
        "map.svg".into(),
    ];
    let mut keep = Vec::new();
    for (name, poses) in &laid_trajectories {
        write_tum(folder.path().join(name), poses)?;
        written.push(name.clone());
        keep.push(name.clone());
    }
    remove_stale_trajectories(folder.path(), &keep)?;
    folder.finish_writing(&written.iter().map(String::as_str).collect::<Vec<_>>())?;
    if !a.quiet {
        say!(
            "{} of {} maps merged into {}'s frame: {} segments; wrote {}",
            inputs.len() - refused.len(),
            inputs.len(),
            inputs[0].label,
            merged.segments.len(),
            shown(&a.output)
        );
    }
    if !refused.is_empty() {
        bail!(
            "{} of {} maps refused (the others are merged, see merge.json):\n{}",
            refused.len(),
            inputs.len(),
            refused.join("\n")
        );
    }
    Ok(())
}

/// The merged map before any other joins it: the first map's walls, path, nodes and scans.
fn start_from(first: &Input) -> Input {
    Input {
        dir: first.dir.clone(),
        path_text: first.path_text.clone(),
        label: first.label.clone(),
        frame: first.frame.clone(),
        segments: first.segments.clone(),
        path: first.path.clone(),
        trajectory: first.trajectory.clone(),
        nodes: first.nodes.clone(),
        scans: first.scans,
        _lock: None,
    }
}

/// `merged` after `input`, laid as `laid`, joined it (`segments`: the merged walls).
fn join(merged: &mut Input, input: &Input, laid: Laid, segments: Vec<polymap::map::MapSegment>) {
    merged.segments = segments;
    merged.path.extend(
        laid.b_trajectory
            .iter()
            .map(|p| p.map_from_robot.translation()),
    );
    merged.trajectory.extend(laid.b_trajectory);
    merged.nodes = match (merged.nodes.take(), laid.b_nodes) {
        (Some(mut a), Some(b)) => {
            a.extend(b);
            Some(a)
        }
        _ => None,
    };
    merged.scans = merged.scans.saturating_add(input.scans);
    merged.path_text = format!("{} + {}", merged.path_text, input.path_text);
    merged.label = format!("{} + {}", merged.label, input.label);
}

/// `merge.json` of several maps: each map's outcome, the steps in the order they joined.
fn multi_json(
    inputs: &[Input],
    outcomes: &[Outcome],
    steps: Vec<serde_json::Value>,
    merged_segments: usize,
    started: Instant,
) -> serde_json::Value {
    let maps: Vec<serde_json::Value> = inputs
        .iter()
        .zip(outcomes)
        .map(|(m, o)| {
            let mut v = json!({"map": m.path_text, "segments": m.segments.len(), "scans": m.scans});
            match o {
                Outcome::Frame => v["outcome"] = json!("frame"),
                Outcome::Merged { step, trajectory } => {
                    let s = &steps[step - 1];
                    v["outcome"] = json!("merged");
                    v["step"] = json!(step);
                    v["method"] = s["method"].clone();
                    v["a_from_b"] = s["a_from_b"].clone();
                    v["trajectory"] = json!(trajectory);
                }
                Outcome::Refused { verdict, why } => {
                    v["outcome"] = json!("refused");
                    v["verdict"] = json!(verdict);
                    v["reason"] = json!(why);
                }
            }
            v
        })
        .collect();
    let all = outcomes
        .iter()
        .all(|o| !matches!(o, Outcome::Refused { .. }));
    json!({
        "frame": format!("{} of {}", inputs[0].frame, inputs[0].path_text),
        "verdict": if all { "accepted" } else if steps.is_empty() { "refused" } else { "partial" },
        "maps": maps,
        "steps": steps,
        "segments": {"merged": merged_segments},
        "seconds": started.elapsed().as_secs_f64(),
    })
}
