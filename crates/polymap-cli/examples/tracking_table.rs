//! Tracking on the simulated worlds: per world and step K (every K-th scan), the
//! ATE without odometry, with the odometry prior, and with the odometry prior on faulty
//! odometry (slips, a 30 % heading bias, stalled wheels); the verdict counts without
//! odometry; mapping speed; and the honesty check: scans whose tracked motion is more than
//! 0.3 m off the truth, and how many of them were not flagged `weak` or `lost`; silent
//! drifts: scans ending a stretch of at most 2 m of travel, all `ok`, over which the tracked
//! motion is more than 0.3 m off.
//!
//! A second table runs every phase (offset 0 … K−1) at K = 5 and 10 without odometry: the
//! mean and worst ATE over the phases, and the jumps over all of them.
//!
//! `cargo run --release -p polymap-cli --example tracking_table`

#[allow(dead_code)]
#[path = "../tests/it/tracking_support.rs"]
mod tracking_support;

use polymap::tracking::Verdict;
use tracking_support::{
    WORLDS, config, jumps, map_every, odometry_ate_m, silent_drifts, simulate_world,
};

/// A step error above this counts as a jump, metres.
const JUMP_M: f64 = 0.3;

fn main() {
    println!(
        "| world | K | scans | ATE m | ATE m, odometry | ATE m, faulty odometry (alone) | ok / weak / lost | jumps (unflagged) | silent drifts | seen through (faulty odometry) | scans/s |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for name in WORLDS {
        let clean = simulate_world(name, false);
        let faulty = simulate_world(name, true);
        for every in [1, 5, 10] {
            let plain = map_every(&clean, every, 0, config(false));
            let odom = map_every(&clean, every, 0, config(true));
            let bad = map_every(&faulty, every, 0, config(true));
            let s = &plain.summary;
            let jumps = jumps(&plain, JUMP_M);
            let unflagged = jumps
                .iter()
                .filter(|&&i| plain.tracking[i].verdict == Verdict::Ok)
                .count();
            println!(
                "| {name} | {every} | {} | {:.3} | {:.3} | {:.3} ({:.2}) | {} / {} / {} | {} ({unflagged}) | {} | {} ({}) | {:.0} |",
                plain.kept.len(),
                plain.ate_all_m(),
                odom.ate_all_m(),
                bad.ate_all_m(),
                odometry_ate_m(&faulty),
                s.ok,
                s.weak,
                s.lost,
                jumps.len(),
                silent_drifts(&plain, 2.0, JUMP_M).len(),
                share(plain.seen_through),
                share(bad.seen_through),
                plain.scans_per_s()
            );
        }
    }
    phases();
}

/// A seen-through share to three places, or "–" when there is none.
fn share(s: Option<f64>) -> String {
    s.map_or_else(|| "–".to_string(), |s| format!("{s:.3}"))
}

/// Every phase of K = 5 and 10, without odometry.
fn phases() {
    println!();
    println!(
        "| world | K | ATE m, mean over phases | worst phase | jumps (unflagged), all phases | lost |"
    );
    println!("|---|---|---|---|---|---|");
    for name in WORLDS {
        let clean = simulate_world(name, false);
        for every in [5, 10] {
            let runs: Vec<_> = (0..every)
                .map(|offset| map_every(&clean, every, offset, config(false)))
                .collect();
            let ates: Vec<f64> = runs.iter().map(|m| m.ate_all_m()).collect();
            let (mut total, mut unflagged) = (0, 0);
            for m in &runs {
                let j = jumps(m, JUMP_M);
                total += j.len();
                unflagged += j
                    .iter()
                    .filter(|&&i| m.tracking[i].verdict == Verdict::Ok)
                    .count();
            }
            let lost: u32 = runs.iter().map(|m| m.summary.lost).sum();
            println!(
                "| {name} | {every} | {:.3} | {:.3} | {total} ({unflagged}) | {lost} |",
                ates.iter().sum::<f64>() / ates.len() as f64,
                ates.iter().copied().fold(0.0, f64::max)
            );
        }
    }
}
