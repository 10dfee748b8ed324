//! The `map.json` contract: the finished map's segments and polylines, in metres.
//!
//! ```json
//! {"version": 2, "units": "m", "frame": "first_scan", "scans": 13631,
//!  "segments": [{"start": [x, y], "end": [x, y], "born_scan": 0, "length_m": 1.0,
//!                "last_seen_scan": 90, "seen": 12, "seen_through": 1, "through_since_seen": 0,
//!                "confirmed": 11}, ...],
//!  "polylines": [[0, 1, 2], ...]}
//! ```
//!
//! `version` is the format's version ([`VERSION`]); a file without one is version 1 (written
//! before the field existed: the same fields but `scans`), and a newer version than this reader
//! knows is refused with a message naming both. `scans` counts the scans mapped into the map,
//! over every run that built it (a resumed run numbers its scans on from there, so `born_scan`
//! stays unique); a version 1 file gives one more than its highest `born_scan`. The format is
//! documented for users in `docs/MAP_FORMAT.md`.
//!
//! `last_seen_scan`, `seen`, `seen_through` and `through_since_seen` are the segment's
//! [`Observations`] (what later scans saw of it; written together, optional when read: files
//! from before they were recorded have none); `confirmed`, of `seen` the scans tracked `ok`,
//! is optional too (files from before it was kept count every sighting).
//!
//! `frame` names the map frame: [`FRAME_FIRST_SCAN`] (the first scan's pose) or
//! [`FRAME_ODOMETRY`] (odometry's frame). A polyline lists segment indices in order along it.
//! The writer puts one segment or polyline per line, so files diff well; numbers are written in
//! the shortest form that reads back exactly. The reader ignores fields it does not know.
//!
//! ```
//! use polymap::geometry::{Segment, Vec2};
//! use polymap::map::MapSegment;
//! use polymap_io::map_json::{MapJson, read_map_json_from, write_map_json_to};
//! let segments = [MapSegment { segment: Segment::new(Vec2::new(0.0, 0.0), Vec2::new(3.0, 4.0)), born_scan: 7 }];
//! let map = MapJson::new("first_scan", &segments, &[vec![0]]);
//! assert_eq!(map.segments[0].length_m, 5.0);
//! let mut bytes = Vec::new();
//! write_map_json_to(&mut bytes, "map.json", &map).unwrap();
//! let back = read_map_json_from(&bytes[..], "map.json").unwrap();
//! assert_eq!(back, map);
//! assert_eq!(back.map_segments()[0], segments[0]);
//! ```

use std::fs::File;
use std::io::{BufReader, Read, Write};
use std::path::{Path, PathBuf};

use polymap::geometry::{Segment, Vec2};
use polymap::map::{MapSegment, Observations};
use serde::{Deserialize, Serialize};

/// `frame` value: the map frame is the pose of the first scan.
pub const FRAME_FIRST_SCAN: &str = "first_scan";
/// `frame` value: the map frame is the odometry frame of the log.
pub const FRAME_ODOMETRY: &str = "odometry";
/// The only `units` value: metres.
pub const UNITS_METRES: &str = "m";
/// The format version this crate writes, and the newest it reads.
pub const VERSION: u32 = 2;

fn version_1() -> u32 {
    1
}

/// The most segments a saved map may hold: the largest map polymap supports. Measured on a
/// map of 100,000 segments and 240 km of walls (2 cores): `eval map --log` 4.3 s, `merge`
/// 3.5 s, `--resume` (50 scans) 6.8 s and `localize` (1,696 scans) 5.6 s with
/// `--initial-pose`, 1.7 GB of memory; memory grows with the walls' total length
/// ([`MAX_TOTAL_LENGTH_M`]).
pub const MAX_SEGMENTS: usize = 100_000;
/// The largest coordinate a saved map may hold, metres (in size): 10,000 km, room for any
/// projected frame (UTM northings reach 1e7 m).
pub const MAX_COORDINATE_M: f64 = 1e7;
/// The longest segment a saved map may hold, metres: no wall a laser sees is longer.
pub const MAX_SEGMENT_LENGTH_M: f64 = 1_000.0;
/// The most wall a saved map may hold, metres (the segments' lengths summed): the segment
/// index lists a segment in about 11 cells per metre, so this bounds its memory (about 2 GB
/// at this length).
pub const MAX_TOTAL_LENGTH_M: f64 = 300_000.0;

/// Why segments (`start`, `end` in metres, file order) break the bounds of a saved map,
/// naming the first segment at fault; `None` when they keep them. `what` names the segments
/// in the message (`segment`, `node 3 segment`); `total_m` sums their lengths, across calls
/// for segments kept together.
pub fn segment_bounds_problem(
    what: &str,
    segments: impl IntoIterator<Item = ([f64; 2], [f64; 2])>,
    total_m: &mut f64,
) -> Option<String> {
    for (i, (start, end)) in segments.into_iter().enumerate() {
        if let Some(v) = start
            .iter()
            .chain(&end)
            .find(|v| v.abs() > MAX_COORDINATE_M)
        {
            return Some(format!(
                "{what} {i} has a coordinate of {v:e} m, beyond the ±{MAX_COORDINATE_M} m a saved \
                 map may hold"
            ));
        }
        let length = (end[0] - start[0]).hypot(end[1] - start[1]);
        if length > MAX_SEGMENT_LENGTH_M {
            return Some(format!(
                "{what} {i} is {length:.1} m long, longer than the {MAX_SEGMENT_LENGTH_M} m a \
                 saved map's segment may be"
            ));
        }
        *total_m += length;
        if *total_m > MAX_TOTAL_LENGTH_M {
            return Some(format!(
                "the segments up to {what} {i} are more than {MAX_TOTAL_LENGTH_M} m long in all, \
                 the most a saved map may hold"
            ));
        }
    }
    None
}

/// The whole `map.json` document.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MapJson {
    /// Format version ([`VERSION`] when written; 1 when absent from a file).
    #[serde(default = "version_1")]
    pub version: u32,
    /// Length unit of every coordinate: always `"m"`.
    pub units: String,
    /// Name of the frame the coordinates are in (see [`FRAME_FIRST_SCAN`], [`FRAME_ODOMETRY`]).
    pub frame: String,
    /// Scans mapped into the map over every run that built it; `None` in a version 1 file
    /// (see [`MapJson::scans_mapped`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scans: Option<u32>,
    /// The map's segments.
    pub segments: Vec<SegmentJson>,
    /// Polylines as lists of indices into `segments`, in order along each polyline.
    pub polylines: Vec<Vec<usize>>,
}

/// One segment of `map.json`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SegmentJson {
    /// First endpoint `[x, y]`, metres, map frame.
    pub start: [f64; 2],
    /// Second endpoint `[x, y]`, metres, map frame.
    pub end: [f64; 2],
    /// 0-based index of the scan whose merge created the segment.
    pub born_scan: u32,
    /// Length, metres (derived from the endpoints; written for convenience, optional when
    /// read, never trusted over the endpoints).
    #[serde(default)]
    pub length_m: f64,
    /// What later scans observed of the segment (all four fields, or none).
    #[serde(flatten)]
    pub observations: Option<Observations>,
}

/// An error reading or writing `map.json`, naming the file.
#[derive(Debug, thiserror::Error)]
pub enum MapJsonError {
    /// The file could not be opened, read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The file is not JSON of the expected shape.
    #[error("{}:{line}:{column}: {source}", path.display())]
    Json {
        /// The file.
        path: PathBuf,
        /// 1-based line of the problem.
        line: usize,
        /// 1-based column of the problem.
        column: usize,
        /// The underlying error.
        #[source]
        source: serde_json::Error,
    },
    /// The document is JSON of the right shape but breaks the contract.
    #[error("{}: {problem}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
}

impl MapJson {
    /// A document for `segments` (map frame named `frame`) and `polylines` (segment indices).
    pub fn new(
        frame: impl Into<String>,
        segments: &[MapSegment],
        polylines: &[Vec<usize>],
    ) -> Self {
        MapJson {
            version: VERSION,
            units: UNITS_METRES.to_owned(),
            frame: frame.into(),
            scans: None,
            segments: segments.iter().map(SegmentJson::from).collect(),
            polylines: polylines.to_vec(),
        }
    }

    /// The same document saying `scans` scans built the map.
    pub fn with_scans(mut self, scans: u32) -> Self {
        self.scans = Some(scans);
        self
    }

    /// Scans mapped into the map: `scans` when the file has it, otherwise one more than the
    /// highest `born_scan` (0 for an empty map).
    pub fn scans_mapped(&self) -> u32 {
        self.scans.unwrap_or_else(|| {
            self.segments
                .iter()
                .map(|s| s.born_scan.saturating_add(1))
                .max()
                .unwrap_or(0)
        })
    }

    /// The document with each segment's observation record (`observations[i]` for segment `i`);
    /// unchanged when the counts differ.
    pub fn with_observations(mut self, observations: &[Observations]) -> Self {
        if observations.len() == self.segments.len() {
            for (s, o) in self.segments.iter_mut().zip(observations) {
                s.observations = Some(*o);
            }
        }
        self
    }

    /// Every segment's observation record, in file order; `None` when a segment has none.
    pub fn observations(&self) -> Option<Vec<Observations>> {
        self.segments.iter().map(|s| s.observations).collect()
    }

    /// The segments as [`MapSegment`]s, in file order.
    pub fn map_segments(&self) -> Vec<MapSegment> {
        self.segments.iter().map(|s| s.to_map_segment()).collect()
    }

    /// Checks what a saved map may hold, as the reader does: [`MAX_SEGMENTS`],
    /// [`MAX_COORDINATE_M`], [`MAX_SEGMENT_LENGTH_M`], [`MAX_TOTAL_LENGTH_M`], and polylines
    /// listing at most twice as many indices as there are segments. The writer does not: a run
    /// keeps its map whatever its size, and reading it back says which bound it breaks.
    pub fn check_bounds(&self) -> Result<(), String> {
        if self.segments.len() > MAX_SEGMENTS {
            return Err(format!(
                "{} segments, more than the {MAX_SEGMENTS} a saved map may hold",
                self.segments.len()
            ));
        }
        let ends = self.segments.iter().map(|s| (s.start, s.end));
        if let Some(problem) = segment_bounds_problem("segment", ends, &mut 0.0) {
            return Err(problem);
        }
        let listed: usize = self.polylines.iter().map(Vec::len).sum();
        if listed > 2 * self.segments.len() {
            return Err(format!(
                "the polylines list {listed} segment indices, more than twice the {} segments",
                self.segments.len()
            ));
        }
        Ok(())
    }

    /// Checks the contract: units `"m"`, finite coordinates, `confirmed` at most `seen`,
    /// polyline indices in range.
    pub fn validate(&self) -> Result<(), String> {
        if let Some(problem) = version_problem("map.json", self.version, VERSION) {
            return Err(problem);
        }
        if let Some(scans) = self.scans
            && let Some(s) = self.segments.iter().find(|s| s.born_scan >= scans)
        {
            return Err(format!(
                "a segment was born at scan {} but the map says {scans} scans built it",
                s.born_scan
            ));
        }
        if self.units != UNITS_METRES {
            return Err(format!("units must be \"m\", found {:?}", self.units));
        }
        let bad = self.segments.iter().position(|s| {
            !(s.start.iter().chain(&s.end).all(|v| v.is_finite()) && s.length_m.is_finite())
        });
        if let Some(i) = bad {
            return Err(format!("segment {i} has a non-finite coordinate or length"));
        }
        let over = self.segments.iter().enumerate().find_map(|(i, s)| {
            let o = s.observations?;
            o.confirmed.filter(|&c| c > o.seen).map(|c| (i, c, o.seen))
        });
        if let Some((i, confirmed, seen)) = over {
            return Err(format!(
                "segment {i} was confirmed by {confirmed} scans but seen by only {seen}"
            ));
        }
        for (p, polyline) in self.polylines.iter().enumerate() {
            if let Some(&i) = polyline.iter().find(|&&i| i >= self.segments.len()) {
                return Err(format!(
                    "polyline {p} refers to segment {i}, but there are {} segments",
                    self.segments.len()
                ));
            }
        }
        Ok(())
    }
}

impl From<&MapSegment> for SegmentJson {
    fn from(m: &MapSegment) -> Self {
        let s = m.segment;
        SegmentJson {
            start: [s.start.x, s.start.y],
            end: [s.end.x, s.end.y],
            born_scan: m.born_scan,
            length_m: s.length(),
            observations: None,
        }
    }
}

impl SegmentJson {
    /// The segment as a [`MapSegment`] (`length_m` is not needed: it follows from the endpoints).
    pub fn to_map_segment(&self) -> MapSegment {
        let start = Vec2::new(self.start[0], self.start[1]);
        let end = Vec2::new(self.end[0], self.end[1]);
        MapSegment {
            segment: Segment::new(start, end),
            born_scan: self.born_scan,
        }
    }
}

/// Writes `map` to a file atomically (see [`crate::atomic`]), after checking it with
/// [`MapJson::validate`].
pub fn write_map_json(path: impl AsRef<Path>, map: &MapJson) -> Result<(), MapJsonError> {
    let path = path.as_ref();
    write_file(path, |out| write_map_json_to(out, path, map))
}

/// Writes a file of this crate's JSON formats atomically (see [`crate::atomic`]) with `fill`;
/// I/O errors name `path`.
pub(crate) fn write_file(
    path: &Path,
    fill: impl FnOnce(&mut dyn Write) -> Result<(), MapJsonError>,
) -> Result<(), MapJsonError> {
    crate::atomic::write_atomic_with(path, fill, io_error(path))
}

/// Maps an I/O error on `path` to [`MapJsonError::Io`].
pub(crate) fn io_error(path: &Path) -> impl Fn(std::io::Error) -> MapJsonError + '_ {
    move |source| MapJsonError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// The most a `map.json` may weigh, bytes: what [`MAX_SEGMENTS`] segments with their
/// observations and polylines need (about 250 bytes a segment: 25 MB), with room to spare.
/// The whole document is parsed before its bounds are checked, and parsing takes many times
/// the text's size for some shapes (polylines of one index each: about 19 times), so this cap
/// is what bounds the memory of reading a saved map.
pub const MAX_FILE_BYTES: u64 = 64 << 20;

/// The whole of `input` as text, at most `max_bytes`; I/O errors name `path`.
pub(crate) fn read_text(
    input: impl Read,
    path: &Path,
    max_bytes: u64,
) -> Result<String, MapJsonError> {
    let bytes = crate::input_file::read_bounded(input, max_bytes).map_err(io_error(path))?;
    String::from_utf8(bytes).map_err(|_| {
        io_error(path)(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            "stream did not contain valid UTF-8",
        ))
    })
}

/// Opens a saved map file for reading: a regular file (not a device, a FIFO or a folder; its
/// size is capped by [`read_text`] as it is read); I/O errors name `path`.
pub(crate) fn open_saved(path: &Path) -> Result<BufReader<File>, MapJsonError> {
    let file = crate::input_file::open_regular(path).map_err(io_error(path))?;
    Ok(BufReader::new(file))
}

/// Writes `map` to `out`, one segment or polyline per line; `path` names it in errors.
pub fn write_map_json_to(
    mut out: impl Write,
    path: impl AsRef<Path>,
    map: &MapJson,
) -> Result<(), MapJsonError> {
    let path = path.as_ref();
    map.validate().map_err(|problem| MapJsonError::Invalid {
        path: path.to_path_buf(),
        problem,
    })?;
    let text = to_json_text(map).map_err(|source| json_error(path, source))?;
    out.write_all(text.as_bytes()).map_err(io_error(path))
}

/// The document as text, one array element per line.
fn to_json_text(map: &MapJson) -> Result<String, serde_json::Error> {
    let mut text = format!(
        "{{\"version\": {}, \"units\": {}, \"frame\": {},",
        map.version,
        serde_json::to_string(&map.units)?,
        serde_json::to_string(&map.frame)?
    );
    if let Some(scans) = map.scans {
        text.push_str(&format!(" \"scans\": {scans},"));
    }
    text.push_str("\n\"segments\": [");
    push_lines(&mut text, &map.segments)?;
    text.push_str("],\n\"polylines\": [");
    push_lines(&mut text, &map.polylines)?;
    text.push_str("]}\n");
    Ok(text)
}

fn push_lines<T: Serialize>(text: &mut String, items: &[T]) -> Result<(), serde_json::Error> {
    for (i, item) in items.iter().enumerate() {
        text.push_str(if i == 0 { "\n  " } else { ",\n  " });
        text.push_str(&serde_json::to_string(item)?);
    }
    if !items.is_empty() {
        text.push('\n');
    }
    Ok(())
}

/// Reads and validates a `map.json` file.
pub fn read_map_json(path: impl AsRef<Path>) -> Result<MapJson, MapJsonError> {
    let path = path.as_ref();
    read_map_json_from(open_saved(path)?, path)
}

/// Reads and validates a `map.json` document from `input`, and checks its bounds
/// ([`MapJson::check_bounds`]); `path` names it in errors.
pub fn read_map_json_from(
    input: impl Read,
    path: impl AsRef<Path>,
) -> Result<MapJson, MapJsonError> {
    let path = path.as_ref();
    let text = read_text(input, path, MAX_FILE_BYTES)?;
    check_version(&text, path, "map.json", VERSION)?;
    let map: MapJson = serde_json::from_str(&text).map_err(|e| json_error(path, e))?;
    drop(text);
    map.validate()
        .and_then(|()| map.check_bounds())
        .map_err(|problem| MapJsonError::Invalid {
            path: path.to_path_buf(),
            problem,
        })?;
    Ok(map)
}

/// Why a `format` document (e.g. `map.json`) of `version` is not read, when it is not: only
/// versions 1 to `newest` are.
fn version_problem(format: &str, version: u32, newest: u32) -> Option<String> {
    (version == 0 || version > newest).then(|| {
        format!(
            "{format} version {version} is not one this polymap reads (versions 1 to {newest}); \
             it was written by a newer or a different program"
        )
    })
}

/// Checks the version of a `format` document (`text`, from `file`) before its shape: a newer
/// file may differ in shape, and its version is then the message. A document without a
/// version is version 1; one that is not JSON at all is left to the full parse, which names
/// the line.
pub(crate) fn check_version(
    text: &str,
    file: &Path,
    format: &str,
    newest: u32,
) -> Result<(), MapJsonError> {
    #[derive(Deserialize)]
    struct Version {
        #[serde(default = "version_1")]
        version: u32,
    }
    let Ok(Version { version }) = serde_json::from_str::<Version>(text) else {
        return Ok(());
    };
    match version_problem(format, version, newest) {
        Some(problem) => Err(MapJsonError::Invalid {
            path: file.to_path_buf(),
            problem,
        }),
        None => Ok(()),
    }
}

/// Maps a JSON error on `path` to [`MapJsonError::Json`] (with its line and column), or to
/// [`MapJsonError::Io`] when reading failed.
pub(crate) fn json_error(path: &Path, source: serde_json::Error) -> MapJsonError {
    if let Some(io) = source.io_error_kind() {
        let source = std::io::Error::new(io, source);
        return MapJsonError::Io {
            path: path.to_path_buf(),
            source,
        };
    }
    MapJsonError::Json {
        path: path.to_path_buf(),
        line: source.line(),
        column: source.column(),
        source,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A map.json of polylines `[[0],[0],…]` within the former 256 MiB cap took about 19
    /// times its size in memory (a 40 MB file: 746 MB) before its bounds were checked: the
    /// cap is now what the bounds need, and a file above it is refused before it is parsed.
    #[test]
    fn a_map_file_above_what_the_bounds_need_is_refused_before_it_is_parsed() {
        let head = r#"{"version":2,"units":"m","frame":"first_scan","segments":[],"polylines":["#;
        let body = "[0],".repeat((MAX_FILE_BYTES / 4) as usize + 1);
        let text = format!("{head}{body}[0]]}}");
        assert!((text.len() as u64) < 256 << 20);
        let e = read_map_json_from(text.as_bytes(), "big/map.json").unwrap_err();
        assert!(
            e.to_string()
                .contains("big/map.json: more than the 67108864 bytes"),
            "{e}"
        );
    }

    fn segment(x0: f64, y0: f64, x1: f64, y1: f64, born_scan: u32) -> MapSegment {
        MapSegment {
            segment: Segment::new(Vec2::new(x0, y0), Vec2::new(x1, y1)),
            born_scan,
        }
    }

    fn sample() -> MapJson {
        let segments = [
            segment(0.0, 0.0, 1.0, 0.0, 0),
            segment(1.0, 0.0, 1.0, 2.5, 3),
            segment(-0.1, 1e-7, 923.456789, -0.3333333333333333, 42),
            // Read back wrong in the last digit by serde_json's default float parser (found
            // in Intel's map): a saved map must come back exactly (`float_roundtrip`).
            segment(2.5821710003345766, -12.443522198055373, 0.0, 0.0, 43),
        ];
        MapJson::new(FRAME_ODOMETRY, &segments, &[vec![0, 1], vec![2, 3]])
    }

    #[test]
    fn round_trip_is_exact() {
        let map = sample();
        let mut bytes = Vec::new();
        write_map_json_to(&mut bytes, "m.json", &map).unwrap();
        let back = read_map_json_from(&bytes[..], "m.json").unwrap();
        assert_eq!(back, map);
        let value: serde_json::Value = serde_json::from_slice(&bytes).unwrap();
        assert_eq!(value["units"], "m");
        assert_eq!(value["segments"][1]["end"][1], 2.5);
        assert_eq!(value["polylines"][0][1], 1);
    }

    #[test]
    fn versions_are_read_or_refused_by_name() {
        // Version 1: no version field, no scans; scans follow from born_scan.
        let v1 = r#"{"units": "m", "frame": "first_scan",
            "segments": [{"start": [0, 0], "end": [1, 0], "born_scan": 6}], "polylines": []}"#;
        let map = read_map_json_from(v1.as_bytes(), "old.json").unwrap();
        assert_eq!((map.version, map.scans, map.scans_mapped()), (1, None, 7));
        // Written back, it is the current version.
        let mut bytes = Vec::new();
        let current = MapJson::new(FRAME_FIRST_SCAN, &map.map_segments(), &[]).with_scans(9);
        write_map_json_to(&mut bytes, "m.json", &current).unwrap();
        let text = String::from_utf8(bytes).unwrap();
        assert!(text.starts_with("{\"version\": 2, "), "{text}");
        assert_eq!(
            read_map_json_from(text.as_bytes(), "m")
                .unwrap()
                .scans_mapped(),
            9
        );
        // A newer version is refused with its number, even in a shape this reader cannot read.
        let v9 = r#"{"version": 9, "units": "m", "segments": {"packed": "AAAA"}}"#;
        let err = read_map_json_from(v9.as_bytes(), "new.json").unwrap_err();
        assert!(
            err.to_string().contains("new.json: map.json version 9"),
            "{err}"
        );
        // A born_scan beyond the scan count breaks the contract.
        let bad = r#"{"version": 2, "units": "m", "frame": "x", "scans": 3,
            "segments": [{"start": [0, 0], "end": [1, 0], "born_scan": 3}], "polylines": []}"#;
        assert!(read_map_json_from(bad.as_bytes(), "b").is_err());
    }

    #[test]
    fn empty_map_round_trips() {
        let map = MapJson::new(FRAME_FIRST_SCAN, &[], &[]);
        let mut bytes = Vec::new();
        write_map_json_to(&mut bytes, "m.json", &map).unwrap();
        assert_eq!(read_map_json_from(&bytes[..], "m.json").unwrap(), map);
    }

    #[test]
    fn file_round_trip() {
        let dir = std::env::temp_dir().join(format!("polymap-io-mapjson-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("map.json");
        write_map_json(&path, &sample()).unwrap();
        assert_eq!(read_map_json(&path).unwrap(), sample());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn contract_violations_are_errors() {
        let mut map = sample();
        map.polylines.push(vec![4]);
        assert!(matches!(
            write_map_json_to(Vec::new(), "m", &map),
            Err(MapJsonError::Invalid { .. })
        ));
        let mut map = sample();
        map.segments[0].start[0] = f64::NAN;
        assert!(write_map_json_to(Vec::new(), "m", &map).is_err());
        let text = r#"{"units": "ft", "frame": "x", "segments": [], "polylines": []}"#;
        assert!(matches!(
            read_map_json_from(text.as_bytes(), "m"),
            Err(MapJsonError::Invalid { .. })
        ));
    }

    #[test]
    fn syntax_errors_carry_line_and_column() {
        let text = "{\"units\": \"m\",\n \"frame\": 3}";
        match read_map_json_from(text.as_bytes(), "bad.json") {
            Err(MapJsonError::Json { line, path, .. }) => {
                assert_eq!(line, 2);
                assert_eq!(path, Path::new("bad.json"));
            }
            other => panic!("{other:?}"),
        }
    }

    /// A `map.json` that was a link to `/dev/zero` was read until memory ran out.
    #[cfg(unix)]
    #[test]
    fn a_map_that_is_a_device_or_endless_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("map.json");
        std::os::unix::fs::symlink("/dev/zero", &path).unwrap();
        let e = read_map_json(&path).unwrap_err();
        assert!(e.to_string().contains("a character device"), "{e}");
        let endless = std::io::repeat(b' ');
        let e = read_map_json_from(endless, "map.json").unwrap_err();
        assert!(e.to_string().contains("more than the"), "{e}");
    }

    /// Every coordinate of a map times 1e298 ended `merge` in a 16 GB allocation; one segment
    /// from (1e6, 1e6) to (-1e6, -1e6) made `--resume` run for minutes. A saved map's bounds
    /// are checked with the element named.
    #[test]
    fn a_map_beyond_the_bounds_is_refused_naming_the_element() {
        let read = |segments: &str| {
            let text = format!(
                r#"{{"version": 2, "units": "m", "frame": "x", "segments": [{segments}], "polylines": []}}"#
            );
            read_map_json_from(text.as_bytes(), "map.json").map(|_| ())
        };
        let ok = r#"{"start": [0, 0], "end": [1, 0], "born_scan": 0}"#;
        assert!(read(ok).is_ok());
        let far = r#"{"start": [1e298, 0], "end": [1e298, 1], "born_scan": 0}"#;
        let long = r#"{"start": [1e6, 1e6], "end": [-1e6, -1e6], "born_scan": 0}"#;
        for (segments, message) in [
            (
                format!("{ok}, {far}"),
                "map.json: segment 1 has a coordinate of 1e298 m",
            ),
            (long.to_owned(), "map.json: segment 0 is 2828427.1 m long"),
        ] {
            let e = read(&segments).unwrap_err().to_string();
            assert!(e.contains(message), "{e}");
        }
        let wall = r#"{"start": [0, 0], "end": [900, 0], "born_scan": 0}"#;
        let walls = vec![wall; 400].join(", ");
        let e = read(&walls).unwrap_err().to_string();
        assert!(
            e.contains("the segments up to segment 333 are more than"),
            "{e}"
        );
        let many = vec![ok; MAX_SEGMENTS + 1].join(", ");
        let e = read(&many).unwrap_err().to_string();
        assert!(e.contains("100001 segments, more than the 100000"), "{e}");
    }

    #[test]
    fn unknown_fields_are_ignored() {
        let text = r#"{"units": "m", "frame": "x", "extra": 1,
            "segments": [{"start": [0, 0], "end": [1, 0], "born_scan": 2, "length_m": 1, "kind": "wall"}],
            "polylines": [[0]]}"#;
        let map = read_map_json_from(text.as_bytes(), "m").unwrap();
        assert_eq!(map.map_segments()[0], segment(0.0, 0.0, 1.0, 0.0, 2));
    }

    #[test]
    fn observations_round_trip_and_older_files_have_none() {
        let segments = [
            segment(0.0, 0.0, 1.0, 0.0, 2),
            segment(0.0, 1.0, 1.0, 1.0, 3),
        ];
        let mut seen = Observations::born(3);
        seen.saw_through();
        let records = [Observations::born(2), seen];
        let map = MapJson::new(FRAME_FIRST_SCAN, &segments, &[]).with_observations(&records);
        let mut bytes = Vec::new();
        write_map_json_to(&mut bytes, "map.json", &map).unwrap();
        let text = String::from_utf8(bytes.clone()).unwrap();
        assert!(
            text.contains("\"seen_through\":1,\"through_since_seen\":1,\"confirmed\":1"),
            "{text}"
        );
        let back = read_map_json_from(&bytes[..], "map.json").unwrap();
        assert_eq!(back.observations(), Some(records.to_vec()));
        // Written before `confirmed` was kept: every sighting counts as support.
        let before = text.replace(",\"confirmed\":1", "");
        let before = read_map_json_from(before.as_bytes(), "map.json").unwrap();
        let before = before.observations().unwrap();
        assert_eq!(before[1].confirmed, None);
        assert_eq!(before[1].support(), 1);
        // More confirmations than sightings breaks the contract, with the segment named.
        let over = text.replace(
            "\"seen\":1,\"seen_through\":1",
            "\"seen\":0,\"seen_through\":1",
        );
        let error = read_map_json_from(over.as_bytes(), "map.json").unwrap_err();
        assert!(
            error.to_string().contains("segment 1 was confirmed by 1"),
            "{error}"
        );
        let old = r#"{"units": "m", "frame": "first_scan",
            "segments": [{"start": [0, 0], "end": [1, 0], "born_scan": 2, "length_m": 1}],
            "polylines": []}"#;
        let old = read_map_json_from(old.as_bytes(), "old.json").unwrap();
        assert_eq!(old.segments[0].observations, None);
        assert_eq!(old.observations(), None);
    }
}
