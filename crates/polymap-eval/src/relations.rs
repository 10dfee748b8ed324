//! Reading `.relations` files: manually verified relative poses (Kümmerle et al. 2009).
//!
//! Each non-blank line that does not start with `#` holds eight numbers,
//! `t1 t2 x y z roll pitch yaw`: the true pose of the robot at time `t2` in the robot frame at
//! time `t1` (metres, radians). `t1` and `t2` are the `ipc_timestamp` of FLASER lines.
//! `z`, `roll` and `pitch` are zero in the planar logs and are ignored.

use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};

use polymap::geometry::Pose2;
use serde::Serialize;

/// Number of whitespace-separated fields on a relation line.
const FIELDS_PER_LINE: usize = 8;

/// One ground-truth relation: where the robot was at `t2_s`, seen from where it was at `t1_s`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Relation {
    /// Time stamp of the first scan, seconds (the log's `ipc_timestamp`).
    pub t1_s: f64,
    /// Time stamp of the second scan, seconds.
    pub t2_s: f64,
    /// True pose of the robot at `t2_s` in the robot frame at `t1_s` (`x`, `y` in metres,
    /// `yaw` in radians, normalised to `(-π, π]`).
    pub robot1_from_robot2: Pose2,
    /// 1-based line number in the source file.
    pub line: usize,
}

/// Why a `.relations` file could not be read.
#[derive(Debug, thiserror::Error)]
pub enum RelationsError {
    /// Opening or reading the source failed (including non-UTF-8 text).
    #[error("{path}:{line}: cannot read: {source}", path = .path.display())]
    Io {
        /// The file (or the name given for the reader).
        path: PathBuf,
        /// 1-based line number being read (0 when opening the file failed).
        line: usize,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A line had the wrong number of fields.
    #[error("{path}:{line}: expected {FIELDS_PER_LINE} fields (t1 t2 x y z roll pitch yaw), found {found}", path = .path.display())]
    FieldCount {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// Number of fields found.
        found: usize,
    },
    /// A field was not a finite number.
    #[error("{path}:{line}: field {field} ({name}) is not a finite number: {text:?}", path = .path.display())]
    BadNumber {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// 1-based field index.
        field: usize,
        /// The field's name (`t1`, `x`, `yaw`, ...).
        name: &'static str,
        /// The offending text.
        text: String,
    },
}

/// Field names, in file order, for error messages.
const FIELD_NAMES: [&str; FIELDS_PER_LINE] = ["t1", "t2", "x", "y", "z", "roll", "pitch", "yaw"];

/// Parses relations from any buffered reader; `path` names the source in errors.
///
/// Blank lines and lines whose first non-blank character is `#` are skipped.
///
/// ```
/// use polymap_eval::relations::parse_relations;
/// let text = "# t1 t2 x y z roll pitch yaw\n\n1.5 2.5 0.4 -0.1 0 0 0 0.2\n";
/// let rels = parse_relations(text.as_bytes(), "demo.relations").unwrap();
/// assert_eq!(rels.len(), 1);
/// assert_eq!(rels[0].t2_s, 2.5);
/// assert_eq!(rels[0].robot1_from_robot2.x_m, 0.4);
/// assert_eq!(rels[0].line, 3);
///
/// let err = parse_relations("1 2 3\n".as_bytes(), "bad.relations").unwrap_err();
/// assert!(err.to_string().starts_with("bad.relations:1:"));
/// ```
pub fn parse_relations(
    reader: impl BufRead,
    path: impl AsRef<Path>,
) -> Result<Vec<Relation>, RelationsError> {
    let path = path.as_ref();
    let mut relations = Vec::new();
    for (i, line) in reader.lines().enumerate() {
        let line_no = i + 1;
        let text = line.map_err(|source| RelationsError::Io {
            path: path.to_path_buf(),
            line: line_no,
            source,
        })?;
        let trimmed = text.trim();
        if trimmed.is_empty() || trimmed.starts_with('#') {
            continue;
        }
        relations.push(parse_line(trimmed, path, line_no)?);
    }
    Ok(relations)
}

/// Opens and parses a `.relations` file.
pub fn read_relations(path: impl AsRef<Path>) -> Result<Vec<Relation>, RelationsError> {
    let path = path.as_ref();
    let file = File::open(path).map_err(|source| RelationsError::Io {
        path: path.to_path_buf(),
        line: 0,
        source,
    })?;
    parse_relations(BufReader::new(file), path)
}

/// Parses one non-blank, non-comment line.
fn parse_line(text: &str, path: &Path, line: usize) -> Result<Relation, RelationsError> {
    let fields: Vec<&str> = text.split_whitespace().collect();
    if fields.len() != FIELDS_PER_LINE {
        return Err(RelationsError::FieldCount {
            path: path.to_path_buf(),
            line,
            found: fields.len(),
        });
    }
    let mut values = [0.0; FIELDS_PER_LINE];
    for (k, field) in fields.iter().enumerate() {
        values[k] = match field.parse::<f64>() {
            Ok(v) if v.is_finite() => v,
            _ => {
                return Err(RelationsError::BadNumber {
                    path: path.to_path_buf(),
                    line,
                    field: k + 1,
                    name: FIELD_NAMES[k],
                    text: (*field).to_string(),
                });
            }
        };
    }
    let [t1_s, t2_s, x_m, y_m, _z, _roll, _pitch, yaw_rad] = values;
    Ok(Relation {
        t1_s,
        t2_s,
        robot1_from_robot2: Pose2::new(x_m, y_m, yaw_rad),
        line,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_real_line_format() {
        let text = "976052905.167303 976052911.885496 -0.056990 -0.128430 0.000000 0.000000 0.000000 -1.682210\n";
        let rels = parse_relations(text.as_bytes(), "intel.relations").unwrap();
        let r = rels[0];
        assert_eq!(r.t1_s, 976052905.167303);
        assert_eq!(r.robot1_from_robot2.y_m, -0.128430);
        // Pose2::new wraps the angle through rem_euclid, which may move it by an ulp.
        assert!((r.robot1_from_robot2.theta_rad + 1.682210).abs() < 1e-12);
    }

    #[test]
    fn bad_number_names_line_and_field() {
        let text = "1 2 0 0 0 0 0 0\n# comment\n1 2 0 zero 0 0 0 0\n";
        let err = parse_relations(text.as_bytes(), "x.relations").unwrap_err();
        match &err {
            RelationsError::BadNumber {
                line, field, name, ..
            } => {
                assert_eq!((*line, *field, *name), (3, 4, "y"));
            }
            other => panic!("unexpected error {other:?}"),
        }
        assert!(err.to_string().contains("x.relations:3:"), "{err}");
    }

    #[test]
    fn non_finite_values_are_rejected() {
        let err = parse_relations("1 2 0 0 0 0 0 nan\n".as_bytes(), "n.relations").unwrap_err();
        assert!(matches!(err, RelationsError::BadNumber { field: 8, .. }));
    }

    #[test]
    fn too_many_fields_is_an_error() {
        let err = parse_relations("\n1 2 0 0 0 0 0 0 9\n".as_bytes(), "f.relations").unwrap_err();
        assert!(matches!(
            err,
            RelationsError::FieldCount {
                line: 2,
                found: 9,
                ..
            }
        ));
    }

    #[test]
    fn invalid_utf8_is_an_io_error_with_line() {
        let bytes: &[u8] = b"1 2 0 0 0 0 0 0\n\xff\xfe\n";
        let err = parse_relations(bytes, "u.relations").unwrap_err();
        assert!(matches!(err, RelationsError::Io { line: 2, .. }));
    }

    #[test]
    fn missing_file_is_an_io_error() {
        let err = read_relations("/nonexistent/dir/none.relations").unwrap_err();
        assert!(err.to_string().contains("none.relations"));
    }
}
