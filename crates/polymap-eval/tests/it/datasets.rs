//! The real `.relations` files, and the relations metric of the logs' own odometry.

use std::path::PathBuf;

use polymap::geometry::Pose2;
use polymap_eval::relation_error::{RelationParams, evaluate_relations};
use polymap_eval::relations::read_relations;

/// `POLYMAP_DATASETS` if set, else `<workspace>/../shared/datasets`.
fn datasets_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("POLYMAP_DATASETS")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/datasets")
        });
    if dir.is_dir() {
        Some(dir)
    } else {
        println!(
            "SKIPPED: no datasets at {} (set POLYMAP_DATASETS)",
            dir.display()
        );
        None
    }
}

const LOGS: [(&str, usize); 3] = [("intel", 2984), ("aces", 1279), ("fr079", 1685)];

#[test]
fn real_relations_files_have_the_published_counts() {
    let Some(dir) = datasets_dir() else { return };
    for (log, count) in LOGS {
        let path = dir.join(log).join(format!("{log}.relations"));
        if !path.is_file() {
            println!("SKIPPED: {} absent", path.display());
            continue;
        }
        let rels = read_relations(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(rels.len(), count, "{log}");
        assert!(rels.iter().all(|r| r.t1_s > 0.0 && r.t2_s > 0.0));
    }
}

/// `(ipc_timestamp, odometry pose)` of every FLASER line, in file order. Test-only parsing:
/// `FLASER n r_1 … r_n x y theta odom_x odom_y odom_theta ipc_timestamp host logger_timestamp`.
fn flaser_odometry(text: &str) -> Vec<(f64, Pose2)> {
    let mut out = Vec::new();
    for line in text.lines().filter(|l| l.starts_with("FLASER ")) {
        let f: Vec<&str> = line.split_whitespace().collect();
        let n: usize = f[1].parse().unwrap();
        let num = |k: usize| f[2 + n + k].parse::<f64>().unwrap();
        out.push((num(6), Pose2::new(num(3), num(4), num(5))));
    }
    out
}

#[test]
fn every_relation_matches_a_scan_stamp_and_odometry_scores_plausibly() {
    let Some(dir) = datasets_dir() else { return };
    for (log, count) in LOGS {
        let clf = dir.join(log).join(format!("{log}.clf"));
        let Ok(text) = std::fs::read_to_string(&clf) else {
            println!("SKIPPED: {} absent", clf.display());
            continue;
        };
        let trajectory = flaser_odometry(&text);
        let rels = read_relations(dir.join(log).join(format!("{log}.relations"))).unwrap();
        let m = evaluate_relations(&rels, &trajectory, &RelationParams::default());
        assert_eq!(
            (m.relations, m.matched),
            (count, count),
            "{log}: every relation finds its scans"
        );
        let t = m.translation_m.unwrap();
        println!("{log}: odometry relation error\n{}", m.to_table());
        // Raw odometry drifts by metres over the long relations (Intel: mean 7.4 m), but most
        // relations are short: the median stays at centimetres (all three logs: 5-8 cm).
        assert!(t.mean > 0.1 && t.mean < 20.0, "{log}: {t:?}");
        assert!(t.median > 0.01 && t.median < 0.2, "{log}: {t:?}");
    }
}
