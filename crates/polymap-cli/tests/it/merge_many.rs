//! `polymap merge A B C …`: pieces of one simulated tour mapped apart and merged in the order
//! of their overlap, with maps that fit nowhere or in two places refused.

use std::fs;
use std::path::Path;

use polymap::geometry::Pose2;
use polymap_io::tum::read_tum;

use crate::support::{map_quietly, polymap, text};

/// Writes `pieces` consecutive pieces of a CARMEN log by laser scans into `dir/P1.clf`, … (lines
/// before the first scan and `PARAM` lines go to every piece, every other line to the piece
/// where it falls) and maps each into `dir/P1`, …; returns each piece's first scan.
fn map_pieces(log: &Path, dir: &Path, pieces: usize) -> Vec<usize> {
    let text_in = fs::read_to_string(log).unwrap();
    let is_scan = |l: &str| l.starts_with("FLASER ") || l.starts_with("ROBOTLASER1 ");
    let scans = text_in.lines().filter(|l| is_scan(l)).count();
    let firsts: Vec<usize> = (0..pieces).map(|p| p * scans / pieces).collect();
    let mut outs = vec![String::new(); pieces];
    let mut seen = 0;
    for line in text_in.lines() {
        let both = seen == 0 && !is_scan(line) || line.starts_with("PARAM ");
        let here = firsts.iter().rposition(|&f| f <= seen).unwrap_or(0);
        for (p, out) in outs.iter_mut().enumerate() {
            if both || p == here {
                out.push_str(line);
                out.push('\n');
            }
        }
        seen += usize::from(is_scan(line));
    }
    for (p, out) in outs.iter().enumerate() {
        let clf = dir.join(format!("P{}.clf", p + 1));
        fs::write(&clf, out).unwrap();
        let o = map_quietly(&clf, &dir.join(format!("P{}", p + 1)), &[]);
        assert!(o.status.success(), "{}", text(&o));
    }
    firsts
}

/// `polymap merge MAPS… -o OUT`: the output and `OUT/merge.json`.
fn merge(maps: &[&Path], out: &Path) -> (std::process::Output, serde_json::Value) {
    let mut args = vec!["merge".to_string()];
    args.extend(maps.iter().map(|m| m.to_str().unwrap().to_string()));
    args.extend(["-o".to_string(), out.to_str().unwrap().to_string()]);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = polymap(&args);
    let report = fs::read_to_string(out.join("merge.json"))
        .unwrap_or_else(|e| panic!("merge.json: {e}\n{}", text(&o)));
    (o, serde_json::from_str(&report).unwrap())
}

fn simulate(world: &str, dir: &Path) -> std::path::PathBuf {
    let o = polymap(&["simulate", world, "-o", dir.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    dir.join(format!("{world}.clf"))
}

#[test]
fn three_pieces_of_a_tour_merge_and_a_map_of_another_world_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let firsts = map_pieces(&simulate("clutter", d), d, 3);
    let hex = d.join("hex");
    fs::create_dir_all(&hex).unwrap();
    let o = map_quietly(&simulate("hex60", &hex), &hex.join("H"), &[]);
    assert!(o.status.success(), "{}", text(&o));
    let (p1, p2, p3, h) = (d.join("P1"), d.join("P2"), d.join("P3"), hex.join("H"));
    // Given out of order, with a map of another world among them.
    let (o, report) = merge(&[&p1, &p3, &h, &p2], &d.join("M"));
    assert!(!o.status.success(), "one map is refused: {}", text(&o));
    assert!(text(&o).contains("do not overlap"), "{}", text(&o));
    let maps = report["maps"].as_array().unwrap();
    let outcomes: Vec<&str> = maps
        .iter()
        .map(|m| m["outcome"].as_str().unwrap())
        .collect();
    assert_eq!(
        outcomes,
        ["frame", "merged", "refused", "merged"],
        "{report:#}"
    );
    assert_eq!(maps[2]["verdict"], "no_overlap", "{report:#}");
    assert!(
        maps[2]["reason"]
            .as_str()
            .unwrap()
            .contains("do not overlap")
    );
    assert_eq!(report["verdict"], "partial");
    assert_eq!(report["steps"].as_array().unwrap().len(), 2);
    // Each merged piece's trajectory, as laid, lies on the truth in P1's frame (the first
    // scan's robot frame).
    let truth = read_tum(d.join("clutter.truth.tum")).unwrap();
    let p1_from_world = truth[0].map_from_robot.inverse();
    for (k, first) in [(1, firsts[2]), (3, firsts[1])] {
        let name = maps[k]["trajectory"].as_str().unwrap();
        let laid = read_tum(d.join("M").join(name)).unwrap();
        let off: f64 = laid
            .iter()
            .zip(&truth[first..])
            .map(|(p, t)| {
                let t_in_p1: Pose2 = p1_from_world.compose(&t.map_from_robot);
                p.map_from_robot
                    .translation()
                    .distance(t_in_p1.translation())
            })
            .sum::<f64>()
            / laid.len() as f64;
        assert!(off < 0.3, "{name} laid {off} m off the truth: {report:#}");
    }
    let merged = polymap_io::map_json::read_map_json(d.join("M/map.json")).unwrap();
    assert_eq!(report["segments"]["merged"], merged.segments.len());
}

#[test]
fn a_map_that_fits_in_two_places_is_refused_and_nothing_is_merged_without_a_join() {
    // The office is symmetric under half a turn, and each half of the round saw half of it:
    // the second half fits the first where it was, and turned onto the first's own half.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    map_pieces(&simulate("office", d), d, 2);
    let hex = d.join("hex");
    fs::create_dir_all(&hex).unwrap();
    let o = map_quietly(&simulate("hex60", &hex), &hex.join("H"), &[]);
    assert!(o.status.success(), "{}", text(&o));
    fs::create_dir_all(d.join("M")).unwrap();
    fs::write(d.join("M/map.json"), "stale").unwrap();
    let (o, report) = merge(
        &[&d.join("P1"), &d.join("P2"), &hex.join("H")],
        &d.join("M"),
    );
    assert!(!o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("two places"), "{}", text(&o));
    let maps = report["maps"].as_array().unwrap();
    assert_eq!(maps[1]["outcome"], "refused");
    assert_eq!(maps[1]["verdict"], "ambiguous", "{report:#}");
    assert_eq!(maps[2]["outcome"], "refused");
    assert_eq!(report["verdict"], "refused");
    assert!(
        !d.join("M/map.json").exists(),
        "no merged map beside a refusal"
    );
}
