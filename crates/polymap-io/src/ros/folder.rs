//! rosbag2 folders: a `metadata.yaml` naming the storage files, read one after the other.

use std::path::{Path, PathBuf};

use super::error::RosError;
use super::source::{Connection, MessageSource, RawMessage};
use crate::input_file::{check_regular, read_regular_to_string};

/// What polymap needs of a rosbag2 `metadata.yaml`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BagMetadata {
    /// `storage_identifier` (`sqlite3`, `mcap`).
    pub storage_identifier: String,
    /// `relative_file_paths`, in order.
    pub relative_file_paths: Vec<String>,
    /// `compression_mode` (`''`, `FILE`, `MESSAGE`).
    pub compression_mode: String,
}

/// Reads the keys polymap needs from `metadata.yaml` (a line-based reading of the fixed layout
/// rosbag2 writes: `  key: value` and `  - item` lists).
///
/// ```
/// use polymap_io::ros::parse_metadata;
/// let m = parse_metadata("rosbag2_bagfile_information:\n  compression_mode: ''\n  \
///     relative_file_paths:\n  - a_0.mcap\n  - a_1.mcap\n  storage_identifier: mcap\n");
/// assert_eq!(m.relative_file_paths, ["a_0.mcap", "a_1.mcap"]);
/// assert_eq!(m.storage_identifier, "mcap");
/// assert_eq!(m.compression_mode, "");
/// ```
pub fn parse_metadata(text: &str) -> BagMetadata {
    let mut m = BagMetadata {
        storage_identifier: String::new(),
        relative_file_paths: Vec::new(),
        compression_mode: String::new(),
    };
    let mut in_paths = false;
    for line in text.lines() {
        let trimmed = line.trim();
        if in_paths {
            if let Some(item) = trimmed.strip_prefix("- ") {
                m.relative_file_paths.push(unquote(item));
                continue;
            }
            in_paths = false;
        }
        if let Some((key, value)) = trimmed.split_once(':') {
            match key {
                "relative_file_paths" => in_paths = true,
                "storage_identifier" => m.storage_identifier = unquote(value),
                "compression_mode" => m.compression_mode = unquote(value),
                _ => {}
            }
        }
    }
    m
}

fn unquote(v: &str) -> String {
    v.trim().trim_matches(|c| c == '\'' || c == '"').to_owned()
}

/// The most `metadata.yaml` may weigh, bytes (rosbag2 writes a few kB).
const MAX_METADATA_BYTES: u64 = 1 << 20;

/// The storage files of a rosbag2 folder, each checked to be a regular file (a FIFO would block
/// the reader, a device never end) and listed once (a file listed twice would be mapped twice).
pub(crate) fn folder_files(dir: &Path) -> Result<Vec<PathBuf>, RosError> {
    let yaml = dir.join("metadata.yaml");
    let text =
        read_regular_to_string(&yaml, MAX_METADATA_BYTES).map_err(|e| RosError::io(&yaml, e))?;
    let m = parse_metadata(&text);
    if !m.compression_mode.is_empty() {
        return Err(RosError::Unsupported {
            path: yaml,
            what: format!(
                "compressed rosbag2 storage (compression_mode {}) is not supported; decompress it with `ros2 bag convert` first",
                m.compression_mode
            ),
        });
    }
    if m.relative_file_paths.is_empty() {
        return Err(RosError::Unsupported {
            path: yaml,
            what: "no `relative_file_paths` listed".into(),
        });
    }
    let mut seen = std::collections::HashSet::new();
    let mut files = Vec::with_capacity(m.relative_file_paths.len());
    for name in &m.relative_file_paths {
        let path = dir.join(name);
        check_regular(&path).map_err(|e| RosError::io(&path, e))?;
        // The same file under two names (`a.db3`, `./a.db3`, a link) is the same file.
        let same = std::fs::canonicalize(&path).map_err(|e| RosError::io(&path, e))?;
        if !seen.insert(same) {
            return Err(RosError::Unsupported {
                path: yaml,
                what: format!(
                    "`relative_file_paths` lists {} more than once: its messages would be read \
                     twice; list each storage file once",
                    crate::printable::printable(name)
                ),
            });
        }
        files.push(path);
    }
    Ok(files)
}

/// Opens the reader of one storage file.
pub(crate) type OpenPart = Box<dyn FnMut(&Path) -> Result<Box<dyn MessageSource>, RosError> + Send>;

/// Several storage files read as one: connections are merged by topic and type.
pub(crate) struct Chain {
    parts: Vec<PathBuf>,
    next_part: usize,
    open: OpenPart,
    current: Option<Box<dyn MessageSource>>,
    /// For the current part: its connection index → ours.
    map: Vec<usize>,
    connections: Vec<Connection>,
    position_before: u64,
    skipped: (u64, Vec<String>),
    warnings: Vec<String>,
}

impl Chain {
    pub(crate) fn new(parts: Vec<PathBuf>, open: OpenPart) -> Result<Self, RosError> {
        let mut chain = Chain {
            parts,
            next_part: 0,
            open,
            current: None,
            map: Vec::new(),
            connections: Vec::new(),
            position_before: 0,
            skipped: (0, Vec::new()),
            warnings: Vec::new(),
        };
        chain.open_next()?;
        Ok(chain)
    }

    /// Opens the next part; false when there is none.
    fn open_next(&mut self) -> Result<bool, RosError> {
        if let Some(old) = self.current.take() {
            self.position_before += old.position();
            let (n, msgs) = old.skipped();
            self.skipped.0 += n;
            self.skipped.1.extend(msgs.iter().cloned());
            self.warnings.extend(old.warnings().iter().cloned());
        }
        let Some(path) = self.parts.get(self.next_part).cloned() else {
            return Ok(false);
        };
        self.next_part += 1;
        self.current = Some((self.open)(&path)?);
        self.map.clear();
        self.sync_connections();
        Ok(true)
    }

    /// Maps connections the current part has declared since the last call.
    fn sync_connections(&mut self) {
        let Some(current) = &self.current else { return };
        for c in &current.connections()[self.map.len()..] {
            let ours = match self.connections.iter().position(|o| o == c) {
                Some(i) => i,
                None => {
                    self.connections.push(c.clone());
                    self.connections.len() - 1
                }
            };
            self.map.push(ours);
        }
    }
}

impl MessageSource for Chain {
    fn advance(&mut self) -> Result<bool, RosError> {
        loop {
            let Some(current) = self.current.as_mut() else {
                return Ok(false);
            };
            if current.advance()? {
                self.sync_connections();
                return Ok(true);
            }
            if !self.open_next()? {
                return Ok(false);
            }
        }
    }

    fn current(&self) -> RawMessage<'_> {
        match &self.current {
            Some(c) => {
                let m = c.current();
                RawMessage {
                    connection: self.map.get(m.connection).copied().unwrap_or(0),
                    ..m
                }
            }
            None => RawMessage {
                connection: 0,
                data: &[],
                place: super::source::Place::Byte(0),
                log_time_ns: 0,
            },
        }
    }

    fn connections(&self) -> &[Connection] {
        &self.connections
    }

    fn position(&self) -> u64 {
        self.position_before + self.current.as_ref().map_or(0, |c| c.position())
    }

    fn skipped(&self) -> (u64, &[String]) {
        let extra = self.current.as_ref().map_or(0, |c| c.skipped().0);
        (self.skipped.0 + extra, &self.skipped.1)
    }

    fn warnings(&self) -> &[String] {
        // Those of the parts read; the current part's are taken in when the next opens.
        &self.warnings
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A rosbag2 folder whose `metadata.yaml` lists `listed`, holding the file `a_0.db3`.
    fn folder(listed: &[&str]) -> tempfile::TempDir {
        let dir = tempfile::tempdir().unwrap();
        let items: String = listed.iter().map(|n| format!("  - {n}\n")).collect();
        let yaml = format!(
            "rosbag2_bagfile_information:\n  compression_mode: ''\n  relative_file_paths:\n\
             {items}  storage_identifier: sqlite3\n"
        );
        std::fs::write(dir.path().join("metadata.yaml"), yaml).unwrap();
        std::fs::write(dir.path().join("a_0.db3"), "SQLite format 3\0").unwrap();
        dir
    }

    /// A `metadata.yaml` listing one `.db3` 24 times mapped it 24 times.
    #[test]
    fn a_storage_file_listed_twice_is_refused() {
        let once = folder(&["a_0.db3"]);
        assert_eq!(folder_files(once.path()).unwrap().len(), 1);
        let twice = folder(&["a_0.db3", "b.db3", "./a_0.db3"]);
        std::fs::write(twice.path().join("b.db3"), "x").unwrap();
        let e = folder_files(twice.path()).unwrap_err().to_string();
        assert!(
            e.contains("metadata.yaml") && e.contains("lists ./a_0.db3 more than once"),
            "{e}"
        );
    }

    /// A FIFO named in `metadata.yaml` blocked the reader (opening it waits for a writer).
    #[cfg(unix)]
    #[test]
    fn a_storage_file_that_is_a_fifo_is_refused() {
        let dir = folder(&["pipe.db3"]);
        let made = std::process::Command::new("mkfifo")
            .arg(dir.path().join("pipe.db3"))
            .status()
            .unwrap();
        assert!(made.success());
        let e = folder_files(dir.path()).unwrap_err().to_string();
        assert!(
            e.contains("pipe.db3: a FIFO (named pipe), not a regular file"),
            "{e}"
        );
    }
}
