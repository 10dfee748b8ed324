//! Where scans come from: the [`ScanSource`] trait that the mapping pipeline reads, and
//! [`open_log`], which opens a log file (or standard input, `-`) and decompresses it on the fly
//! when it is gzip or bzip2 (found by the magic bytes, not the file name).
//!
//! ```
//! use polymap_io::carmen::ReaderOptions;
//! use polymap_io::source::{Compression, ScanSource, open_log};
//! let dir = std::env::temp_dir().join(format!("polymap-source-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir).unwrap();
//! let path = dir.join("tiny.clf");
//! std::fs::write(&path, "FLASER 2 1.0 2.0 0 0 0 0 0 0 5.5 host 0\n").unwrap();
//! let mut log = open_log(&path, ReaderOptions::default()).unwrap();
//! assert_eq!(log.compression(), Compression::None);
//! assert_eq!(log.next_scan().unwrap().unwrap().stamp.text, "5.5");
//! assert!(log.next_scan().unwrap().is_none());
//! # std::fs::remove_dir_all(&dir).unwrap();
//! ```

use std::fs::File;
use std::io::{self, BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use polymap::scan::RangeScan;

use crate::carmen::{CarmenError, CarmenReader, CarmenStats, ReaderOptions};

/// A source of scans in log order, read on the pipeline's reading thread.
pub trait ScanSource: Send {
    /// Why reading failed (naming the file and line).
    type Error: std::error::Error + Send + Sync + 'static;

    /// The next scan, `Ok(None)` at the end.
    fn next_scan(&mut self) -> Result<Option<RangeScan>, Self::Error>;

    /// Bytes of the input consumed so far (compressed bytes for a compressed log), for
    /// progress; 0 when unknown.
    fn bytes_read(&self) -> u64 {
        0
    }
}

impl<R: BufRead + Send> ScanSource for CarmenReader<R> {
    type Error = CarmenError;

    fn next_scan(&mut self) -> Result<Option<RangeScan>, CarmenError> {
        CarmenReader::next_scan(self)
    }
}

/// The compression a log was found to have.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Compression {
    /// Plain text.
    None,
    /// gzip (`1f 8b`), possibly several members.
    Gzip,
    /// bzip2 (`BZh1`..`BZh9`), possibly several streams.
    Bzip2,
}

/// A CARMEN log opened by [`open_log`]: a file or standard input, decompressed if needed.
pub struct LogSource {
    reader: CarmenReader<Box<dyn BufRead + Send>>,
    bytes_read: Arc<AtomicU64>,
    size_bytes: Option<u64>,
    compression: Compression,
    is_regular_file: bool,
}

impl std::fmt::Debug for LogSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LogSource")
            .field("path", &self.reader.path())
            .field("size_bytes", &self.size_bytes)
            .field("compression", &self.compression)
            .finish_non_exhaustive()
    }
}

/// The name standard input goes by in messages.
pub const STDIN_NAME: &str = "<stdin>";

/// Opens `path` (`-` is standard input) as a CARMEN log; gzip and bzip2 logs are decompressed
/// as they are read. Other compressions (xz, zstd, zip) are refused with a message naming them.
pub fn open_log(path: &Path, options: ReaderOptions) -> Result<LogSource, CarmenError> {
    let is_stdin = path.as_os_str() == "-";
    let name = if is_stdin {
        PathBuf::from(STDIN_NAME)
    } else {
        path.to_path_buf()
    };
    let io_error = |source| CarmenError::Io {
        path: name.clone(),
        source,
    };
    let (raw, meta): (Box<dyn Read + Send>, Option<std::fs::Metadata>) = if is_stdin {
        (Box::new(io::stdin()), None)
    } else {
        let file = File::open(path).map_err(io_error)?;
        let meta = file.metadata().ok();
        if meta.as_ref().is_some_and(|m| m.is_dir()) {
            return Err(io_error(io::Error::new(
                io::ErrorKind::IsADirectory,
                "is a folder, not a log",
            )));
        }
        (Box::new(file), meta)
    };
    let is_regular_file = meta.as_ref().is_some_and(|m| m.is_file());
    let size_bytes = meta.filter(|m| m.is_file()).map(|m| m.len());
    let bytes_read = Arc::new(AtomicU64::new(0));
    let mut counted = BufReader::with_capacity(
        1 << 16,
        CountingReader {
            inner: raw,
            count: Arc::clone(&bytes_read),
        },
    );
    let compression = sniff(&mut counted, &name)?;
    let input: Box<dyn BufRead + Send> = match compression {
        Compression::None => Box::new(counted),
        Compression::Gzip => Box::new(BufReader::with_capacity(
            1 << 16,
            flate2::bufread::MultiGzDecoder::new(counted),
        )),
        Compression::Bzip2 => Box::new(BufReader::with_capacity(
            1 << 16,
            bzip2::bufread::MultiBzDecoder::new(counted),
        )),
    };
    Ok(LogSource {
        reader: CarmenReader::from_reader(input, name, options),
        bytes_read,
        size_bytes,
        compression,
        is_regular_file,
    })
}

/// Reads the first bytes (without consuming them) and names the compression.
fn sniff(input: &mut impl BufRead, name: &Path) -> Result<Compression, CarmenError> {
    let head = input.fill_buf().map_err(|source| CarmenError::Io {
        path: name.to_path_buf(),
        source,
    })?;
    let refuse = |what: &str| {
        Err(CarmenError::Io {
            path: name.to_path_buf(),
            source: io::Error::new(
                io::ErrorKind::InvalidData,
                format!(
                    "the log is compressed with {what}, which polymap does not read: decompress it first (gzip and bzip2 are read directly)"
                ),
            ),
        })
    };
    match head {
        [0x1f, 0x8b, ..] => Ok(Compression::Gzip),
        [b'B', b'Z', b'h', b'1'..=b'9', ..] => Ok(Compression::Bzip2),
        [0xfd, b'7', b'z', b'X', b'Z', 0, ..] => refuse("xz"),
        [0x28, 0xb5, 0x2f, 0xfd, ..] => refuse("zstd"),
        [b'P', b'K', 3, 4, ..] => refuse("zip"),
        _ => Ok(Compression::None),
    }
}

impl LogSource {
    /// What the reader has seen so far.
    pub fn stats(&self) -> &CarmenStats {
        self.reader.stats()
    }

    /// The name used in messages (`<stdin>` for standard input).
    pub fn path(&self) -> &Path {
        self.reader.path()
    }

    /// Size of the file in bytes, `None` for standard input, pipes and other streams.
    pub fn size_bytes(&self) -> Option<u64> {
        self.size_bytes
    }

    /// The compression found.
    pub fn compression(&self) -> Compression {
        self.compression
    }

    /// True for a regular file (which can be read again), false for standard input, a pipe,
    /// a FIFO or a device.
    pub fn is_regular_file(&self) -> bool {
        self.is_regular_file
    }
}

impl ScanSource for LogSource {
    type Error = CarmenError;

    fn next_scan(&mut self) -> Result<Option<RangeScan>, CarmenError> {
        self.reader.next_scan()
    }

    fn bytes_read(&self) -> u64 {
        self.bytes_read.load(Ordering::Relaxed)
    }
}

/// Counts the bytes read through it.
struct CountingReader<R> {
    inner: R,
    count: Arc<AtomicU64>,
}

impl<R: Read> Read for CountingReader<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.count.fetch_add(n as u64, Ordering::Relaxed);
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use std::io::Write;

    use super::*;

    const LOG: &str = "FLASER 3 1.0 2.0 3.0 0 0 0 0 0 0 1.5 host 0\n\
                       FLASER 3 1.0 2.0 3.0 0 0 0 0 0 0 1.6 host 0\n";

    fn stamps(path: &Path) -> Vec<String> {
        let mut log = open_log(path, ReaderOptions::default()).unwrap();
        let mut out = Vec::new();
        while let Some(scan) = log.next_scan().unwrap() {
            out.push(scan.stamp.text);
        }
        out
    }

    fn temp(name: &str, bytes: &[u8]) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("polymap-source-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    }

    #[test]
    fn gzip_and_bzip2_logs_read_like_the_plain_one() {
        let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        gz.write_all(LOG.as_bytes()).unwrap();
        // The name says nothing: the magic bytes decide.
        let gz = temp("log-gz.clf", &gz.finish().unwrap());
        let mut bz = bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::default());
        bz.write_all(LOG.as_bytes()).unwrap();
        let bz = temp("log.bz2", &bz.finish().unwrap());
        let plain = temp("log.clf", LOG.as_bytes());
        assert_eq!(stamps(&plain), ["1.5", "1.6"]);
        assert_eq!(stamps(&gz), ["1.5", "1.6"]);
        assert_eq!(stamps(&bz), ["1.5", "1.6"]);
        assert_eq!(
            open_log(&gz, ReaderOptions::default())
                .unwrap()
                .compression(),
            Compression::Gzip
        );
    }

    #[test]
    fn other_compressions_are_named() {
        let xz = temp("log.xz", &[0xfd, b'7', b'z', b'X', b'Z', 0, 1, 2]);
        let e = open_log(&xz, ReaderOptions::default()).unwrap_err();
        assert!(e.to_string().contains("compressed with xz"), "{e}");
    }

    #[test]
    fn a_cut_gzip_log_is_an_error_not_an_end() {
        let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        gz.write_all(LOG.repeat(50).as_bytes()).unwrap();
        let bytes = gz.finish().unwrap();
        let cut = temp("cut.gz", &bytes[..bytes.len() / 2]);
        let mut log = open_log(&cut, ReaderOptions::default()).unwrap();
        let end = std::iter::from_fn(|| log.next_scan().transpose()).find(Result::is_err);
        assert!(end.is_some(), "a cut gzip log must end in an error");
    }
}
