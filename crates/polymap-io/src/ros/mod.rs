//! ROS recordings without ROS: ROS 1 bags, ROS 2 MCAP files, rosbag2 sqlite3 files and
//! folders, read message by message with bounded memory.
//!
//! One module per container format, each a [`MessageSource`] yielding raw messages in the
//! file's own order:
//!
//! - [`ros1`]: bag format 2.0, chunks uncompressed, `bz2` or `lz4`, read in file order without
//!   the index (which may be wrong); and a writer.
//! - [`mcap_file`]: MCAP through the `mcap` crate's sans-I/O reader (chunks `zstd`/`lz4`); and
//!   a writer. [`mcap_indexed`]: the same through the summary, skipping chunks without the
//!   topics asked for.
//! - `sqlite` (feature `sqlite`, on by default): rosbag2 `.db3` files.
//! - [`folder`]: rosbag2 folders (`metadata.yaml` and its storage files).
//!
//! On top of them, [`messages`] decodes `sensor_msgs/LaserScan`, `nav_msgs/Odometry` and
//! `tf2_msgs/TFMessage` by hand ([`wire`]: ROS 1 serialization and CDR in both byte orders),
//! [`tf`] keeps the transforms of `/tf` and `/tf_static` as a tree to look up, [`scans`] turns
//! a laser topic into [`RangeScan`](polymap::scan::RangeScan)s with the laser's mounting from tf
//! and odometry interpolated to each scan's stamp, and [`survey()`] counts what a file holds.
//! [`record`] writes scans as MCAP files and bags, with tf (the simulator's ROS output).

pub mod error;
pub mod folder;
pub(crate) mod mcap_chunk;
pub mod mcap_file;
pub mod mcap_indexed;
pub mod messages;
pub mod record;
pub mod ros1;
mod scan_tf;
pub mod scans;
pub mod source;
#[cfg(feature = "sqlite")]
pub mod sqlite;
pub mod survey;
pub mod tf;
mod typedefs;
pub mod wire;

use std::path::Path;

pub use error::{MessageProblem, RosError};
pub use folder::parse_metadata;
pub use messages::{LaserScanMsg, OdometryMsg, RosTime, TfMessage, TransformStampedMsg};
pub use record::{
    LASER_FRAME, ODOM_TOPIC, RecordOptions, SCAN_TOPIC, float32_scan, write_bag, write_bag_with,
    write_mcap, write_mcap_with,
};
pub use scan_tf::{
    BASE_FOOTPRINT, BASE_LINK, MAX_LEVEL_TILT_RAD, ODOM_FRAME, TF_STATIC_TOPIC, TF_TOPIC,
    TfOdometry,
};
pub use scans::{FrameMiss, RosScanOptions, RosScanReader, RosStats, TfStats};
pub use source::{Connection, Encoding, MessageSource, Place, RawMessage, ReadLimits};
pub use survey::{LaserGeometry, TopicSummary, survey};
pub use wire::Flavor;

/// The ROS container formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RosFormat {
    /// A ROS 1 bag, format 2.0.
    Bag1,
    /// An MCAP file.
    Mcap,
    /// A rosbag2 sqlite3 file (`.db3`).
    Sqlite,
    /// A rosbag2 folder with `metadata.yaml`.
    Folder,
}

/// Opens the reader of one container.
pub fn open_source(
    path: &Path,
    format: RosFormat,
    limits: ReadLimits,
    skip_bad: bool,
) -> Result<Box<dyn MessageSource>, RosError> {
    match format {
        RosFormat::Bag1 => Ok(Box::new(ros1::BagReader::open(path, limits, skip_bad)?)),
        RosFormat::Mcap => Ok(Box::new(mcap_file::McapReader::open(
            path, limits, skip_bad,
        )?)),
        RosFormat::Sqlite => open_sqlite(path, limits),
        RosFormat::Folder => {
            let parts = folder::folder_files(path)?;
            let open = move |p: &Path| match sniff(p)? {
                Some(RosFormat::Folder) | None => Err(RosError::Unsupported {
                    path: p.to_path_buf(),
                    what: "not an MCAP or sqlite3 storage file".into(),
                }),
                Some(f) => open_source(p, f, limits, skip_bad),
            };
            Ok(Box::new(folder::Chain::new(parts, Box::new(open))?))
        }
    }
}

/// Opens the reader of one container for the messages of `topics` only. Where the format
/// allows (an MCAP file with chunk indexes), chunks holding none of them are skipped without
/// being read; otherwise this is [`open_source`] (the caller filters).
pub fn open_source_for_topics(
    path: &Path,
    format: RosFormat,
    limits: ReadLimits,
    skip_bad: bool,
    topics: &[String],
) -> Result<Box<dyn MessageSource>, RosError> {
    if format == RosFormat::Mcap {
        return match mcap_indexed::McapIndexedReader::open(path, limits, skip_bad, topics)? {
            mcap_indexed::Indexed::Reader(reader) => Ok(reader),
            mcap_indexed::Indexed::Linear(None) => open_source(path, format, limits, skip_bad),
            // A damaged summary is read past: the linear reader checks every chunk itself.
            mcap_indexed::Indexed::Linear(Some(problem)) => {
                let mut reader = mcap_file::McapReader::open(path, limits, skip_bad)?;
                reader.warn(format!(
                    "{}: {problem}: read without it, every chunk in file order",
                    path.display()
                ));
                Ok(Box::new(reader))
            }
        };
    }
    open_source(path, format, limits, skip_bad)
}

#[cfg(feature = "sqlite")]
fn open_sqlite(path: &Path, limits: ReadLimits) -> Result<Box<dyn MessageSource>, RosError> {
    Ok(Box::new(sqlite::SqliteReader::open(path, limits)?))
}

#[cfg(not(feature = "sqlite"))]
fn open_sqlite(path: &Path, _limits: ReadLimits) -> Result<Box<dyn MessageSource>, RosError> {
    Err(RosError::Unsupported {
        path: path.to_path_buf(),
        what: "rosbag2 sqlite3 storage needs polymap built with the `sqlite` feature".into(),
    })
}

/// The fewest bytes of a recording's header that name it when the file ends there.
const MIN_CUT_HEAD: usize = 4;

/// The ROS format of a file or folder by its content; `None` for anything else. A file that
/// ends inside a recording's header (at least its first 4 bytes) is an error naming the format.
pub fn sniff(path: &Path) -> Result<Option<RosFormat>, RosError> {
    if path.is_dir() {
        return Ok(path
            .join("metadata.yaml")
            .is_file()
            .then_some(RosFormat::Folder));
    }
    let mut head = [0u8; 16];
    let n = read_head(path, &mut head)?;
    let head = &head[..n];
    // A file cut inside the header of a recording is that recording, cut, not a text log.
    let magics: [(&[u8], &str); 3] = [
        (b"#ROSBAG V", "a ROS 1 bag"),
        (mcap_file::MCAP_MAGIC, "an MCAP file"),
        (b"SQLite format 3\0", "a rosbag2 sqlite3 file"),
    ];
    if let Some((_, what)) = magics.iter().find(|(magic, _)| {
        head.len() >= MIN_CUT_HEAD && head.len() < magic.len() && magic.starts_with(head)
    }) {
        return Err(RosError::Unsupported {
            path: path.to_path_buf(),
            what: format!(
                "{what} cut off: the file is {n} bytes, shorter than the format's header"
            ),
        });
    }
    Ok(if head.starts_with(b"#ROSBAG V") {
        Some(RosFormat::Bag1)
    } else if head.starts_with(mcap_file::MCAP_MAGIC) {
        Some(RosFormat::Mcap)
    } else if head.starts_with(b"SQLite format 3\0") {
        Some(RosFormat::Sqlite)
    } else {
        None
    })
}

fn read_head(path: &Path, head: &mut [u8]) -> Result<usize, RosError> {
    use std::io::Read;
    let mut file = std::fs::File::open(path).map_err(|e| RosError::io(path, e))?;
    let mut n = 0;
    while n < head.len() {
        match file.read(&mut head[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(RosError::io(path, e)),
        }
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ROS file shorter than its header was read as a CARMEN log ("no FLASER lines").
    #[test]
    fn a_recording_cut_inside_its_header_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let cases: [(&[u8], &str); 3] = [
            (b"#ROSBA", "a ROS 1 bag cut off: the file is 6 bytes"),
            (
                &mcap_file::MCAP_MAGIC[..5],
                "an MCAP file cut off: the file is 5 bytes",
            ),
            (b"SQLite for", "a rosbag2 sqlite3 file cut off"),
        ];
        for (bytes, message) in cases {
            let path = dir.path().join("cut");
            std::fs::write(&path, bytes).unwrap();
            let e = sniff(&path).unwrap_err().to_string();
            assert!(e.contains(message), "{e}");
        }
        // Text that merely starts like a header is no recording.
        for text in [&b"#RO"[..], b"# a comment\n", b""] {
            let path = dir.path().join("text");
            std::fs::write(&path, text).unwrap();
            assert_eq!(sniff(&path).unwrap(), None);
        }
    }
}
