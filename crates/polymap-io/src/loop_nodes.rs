//! `loop_nodes.json`: the loop-closure nodes of a run, kept so that a run continuing the map
//! (`--resume`) closes loops into the old part of it, not only among its own scans.
//!
//! ```json
//! {"version": 1, "units": "m", "frame": "first_scan",
//! "nodes": [
//!   {"pose": [x, y, yaw], "segments": [[x0, y0, x1, y1], ...]},
//!   ...
//! ]}
//! ```
//!
//! One node per line: its pose (metres, metres, radians; map frame, after every correction)
//! and its submap's segments in the node's own frame (metres). Documented for users in
//! `docs/MAP_FORMAT.md`. A newer version than [`VERSION`] is refused with a message naming it.
//!
//! ```
//! use polymap::geometry::{Pose2, Segment, Vec2};
//! use polymap::loops::SavedNode;
//! use polymap_io::loop_nodes::{read_loop_nodes_from, write_loop_nodes_to};
//! let nodes = [SavedNode {
//!     pose: Pose2::new(1.0, 2.0, 0.5),
//!     segments: vec![Segment::new(Vec2::ZERO, Vec2::new(3.0, 0.0))],
//! }];
//! let mut bytes = Vec::new();
//! write_loop_nodes_to(&mut bytes, "loop_nodes.json", "first_scan", &nodes).unwrap();
//! let back = read_loop_nodes_from(&bytes[..], "loop_nodes.json").unwrap();
//! assert_eq!(back, nodes);
//! ```

use std::io::{Read, Write};
use std::path::Path;

use polymap::geometry::{Pose2, Segment, Vec2};
use polymap::loops::SavedNode;
use serde::{Deserialize, Serialize};

use crate::map_json::{
    MapJsonError, UNITS_METRES, check_version, io_error, json_error, open_saved, read_text,
    write_file,
};

/// The file's name in a run folder.
pub const LOOP_NODES_FILE: &str = "loop_nodes.json";
/// The format version written, and the newest read.
pub const VERSION: u32 = 1;

#[derive(Debug, Serialize, Deserialize)]
struct Document {
    version: u32,
    units: String,
    frame: String,
    nodes: Vec<NodeJson>,
}

#[derive(Debug, Serialize, Deserialize)]
struct NodeJson {
    pose: [f64; 3],
    segments: Vec<[f64; 4]>,
}

/// Writes `nodes` (map frame named `frame`) to a file atomically.
pub fn write_loop_nodes(
    path: impl AsRef<Path>,
    frame: &str,
    nodes: &[SavedNode],
) -> Result<(), MapJsonError> {
    let path = path.as_ref();
    write_file(path, |out| write_loop_nodes_to(out, path, frame, nodes))
}

/// Writes `nodes` to `out`, one node per line; `path` names it in errors.
pub fn write_loop_nodes_to(
    mut out: impl Write,
    path: impl AsRef<Path>,
    frame: &str,
    nodes: &[SavedNode],
) -> Result<(), MapJsonError> {
    let path = path.as_ref();
    let json = |e: serde_json::Error| json_error(path, e);
    let mut text = format!(
        "{{\"version\": {VERSION}, \"units\": {}, \"frame\": {},\n\"nodes\": [",
        serde_json::to_string(UNITS_METRES).map_err(json)?,
        serde_json::to_string(frame).map_err(json)?
    );
    for (i, n) in nodes.iter().enumerate() {
        if !(n.pose.is_finite() && n.segments.iter().all(|s| s.is_finite())) {
            return Err(MapJsonError::Invalid {
                path: path.to_path_buf(),
                problem: format!("node {i} has a non-finite pose or segment"),
            });
        }
        let node = NodeJson {
            pose: [n.pose.x_m, n.pose.y_m, n.pose.theta_rad],
            segments: n
                .segments
                .iter()
                .map(|s| [s.start.x, s.start.y, s.end.x, s.end.y])
                .collect(),
        };
        text.push_str(if i == 0 { "\n  " } else { ",\n  " });
        text.push_str(&serde_json::to_string(&node).map_err(json)?);
    }
    if !nodes.is_empty() {
        text.push('\n');
    }
    text.push_str("]}\n");
    out.write_all(text.as_bytes()).map_err(io_error(path))
}

/// Reads a `loop_nodes.json` file.
pub fn read_loop_nodes(path: impl AsRef<Path>) -> Result<Vec<SavedNode>, MapJsonError> {
    let path = path.as_ref();
    read_loop_nodes_from(open_saved(path)?, path)
}

/// Reads a `loop_nodes.json` document from `input`; `path` names it in errors.
pub fn read_loop_nodes_from(
    input: impl Read,
    path: impl AsRef<Path>,
) -> Result<Vec<SavedNode>, MapJsonError> {
    let path = path.as_ref();
    let invalid = |problem: String| MapJsonError::Invalid {
        path: path.to_path_buf(),
        problem,
    };
    let text = read_text(input, path, MAX_FILE_BYTES)?;
    check_version(&text, path, "loop_nodes.json", VERSION)?;
    let doc: Document = serde_json::from_str(&text).map_err(|e| json_error(path, e))?;
    if doc.units != UNITS_METRES {
        return Err(invalid(format!(
            "units must be \"m\", found {:?}",
            doc.units
        )));
    }
    check_bounds(&doc.nodes).map_err(invalid)?;
    doc.nodes
        .into_iter()
        .enumerate()
        .map(|(i, n)| {
            let pose = Pose2::new(n.pose[0], n.pose[1], n.pose[2]);
            let segments: Vec<Segment> = n
                .segments
                .iter()
                .map(|s| Segment::new(Vec2::new(s[0], s[1]), Vec2::new(s[2], s[3])))
                .collect();
            if pose.is_finite() && segments.iter().all(|s| s.is_finite()) {
                Ok(SavedNode { pose, segments })
            } else {
                Err(invalid(format!(
                    "node {i} has a non-finite pose or segment"
                )))
            }
        })
        .collect()
}

/// The most nodes a saved `loop_nodes.json` may hold (a node per few metres of travel).
pub const MAX_NODES: usize = 100_000;
/// The most a `loop_nodes.json` may weigh, bytes: what [`MAX_NODE_SEGMENTS`] segments need
/// (about 85 bytes each), with room to spare; it bounds the memory of parsing the file.
pub const MAX_FILE_BYTES: u64 = 128 << 20;
/// The most segments all nodes' submaps may hold together.
pub const MAX_NODE_SEGMENTS: usize = 1_000_000;

/// Checks what the nodes may hold (a saved map's bounds, see [`crate::map_json`]): counts,
/// poses and each submap's segments, naming the node at fault.
fn check_bounds(nodes: &[NodeJson]) -> Result<(), String> {
    use crate::map_json::{MAX_COORDINATE_M, segment_bounds_problem};
    if nodes.len() > MAX_NODES {
        return Err(format!(
            "{} nodes, more than the {MAX_NODES} a saved map may hold",
            nodes.len()
        ));
    }
    let segments: usize = nodes.iter().map(|n| n.segments.len()).sum();
    if segments > MAX_NODE_SEGMENTS {
        return Err(format!(
            "{segments} segments in the nodes, more than the {MAX_NODE_SEGMENTS} a saved map may \
             hold"
        ));
    }
    let mut total_m = 0.0;
    for (i, n) in nodes.iter().enumerate() {
        if n.pose[..2].iter().any(|v| v.abs() > MAX_COORDINATE_M) {
            return Err(format!(
                "node {i} has a pose beyond the ±{MAX_COORDINATE_M} m a saved map may hold"
            ));
        }
        let ends = n.segments.iter().map(|s| ([s[0], s[1]], [s[2], s[3]]));
        if let Some(problem) =
            segment_bounds_problem(&format!("node {i} segment"), ends, &mut total_m)
        {
            return Err(problem);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_is_exact_and_bad_files_are_named() {
        let nodes = vec![
            SavedNode {
                pose: Pose2::new(2.5821710003345766, -12.443522198055373, -3.1),
                segments: vec![Segment::new(
                    Vec2::new(0.1, 0.2),
                    Vec2::new(-1.0 / 3.0, 4.0),
                )],
            },
            SavedNode {
                pose: Pose2::IDENTITY,
                segments: Vec::new(),
            },
        ];
        let mut bytes = Vec::new();
        write_loop_nodes_to(&mut bytes, "n.json", "odometry", &nodes).unwrap();
        assert_eq!(read_loop_nodes_from(&bytes[..], "n.json").unwrap(), nodes);
        assert_eq!(String::from_utf8(bytes).unwrap().lines().count(), 5);
        let newer = r#"{"version": 4, "nodes": "packed"}"#;
        let err = read_loop_nodes_from(newer.as_bytes(), "n.json").unwrap_err();
        assert!(
            err.to_string()
                .contains("n.json: loop_nodes.json version 4"),
            "{err}"
        );
        let cut = r#"{"version": 1, "units": "m", "frame": "x", "nodes": [{"pose": [1, 2"#;
        assert!(matches!(
            read_loop_nodes_from(cut.as_bytes(), "n.json"),
            Err(MapJsonError::Json { .. })
        ));
        // Coordinates a hostile file may hold are bounded, with the node named.
        let far = r#"{"version": 1, "units": "m", "frame": "x", "nodes": [
            {"pose": [0, 0, 0], "segments": []},
            {"pose": [0, 0, 0], "segments": [[0, 0, 1e300, 1]]}]}"#;
        let err = read_loop_nodes_from(far.as_bytes(), "n.json").unwrap_err();
        assert!(
            err.to_string()
                .contains("n.json: node 1 segment 0 has a coordinate of 1e300 m"),
            "{err}"
        );
        let mut bad = nodes.clone();
        bad[0].pose.x_m = f64::NAN;
        assert!(write_loop_nodes_to(Vec::new(), "n", "x", &bad).is_err());
    }
}
