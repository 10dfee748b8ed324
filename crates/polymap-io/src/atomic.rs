//! Atomic file writes: every output goes to a temporary file in the same folder, is flushed and
//! synced, and only then renamed over its final name. A reader (or a run killed mid-write)
//! therefore sees either the old file or the whole new one, never a cut one.
//!
//! The temporary file is named `.NAME.tmp-PID` beside `NAME`; a write that fails removes it.
//!
//! ```
//! let dir = std::env::temp_dir().join(format!("polymap-atomic-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir).unwrap();
//! let path = dir.join("a.txt");
//! polymap_io::atomic::write_atomic(&path, |out| {
//!     use std::io::Write;
//!     out.write_all(b"hello")
//! })
//! .unwrap();
//! assert_eq!(std::fs::read(&path).unwrap(), b"hello");
//! # std::fs::remove_dir_all(&dir).unwrap();
//! ```
//!
//! For the tests of the command-line tool, the environment variable
//! `POLYMAP_TEST_FAULT=NAME:KIND` injects a fault into the write of the file called `NAME`:
//! `KIND` = `enospc` fails it as a full disk would, `abort` aborts the whole process (as
//! `kill -9` would) after half of the file's bytes are written to the temporary file.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

/// The environment variable that injects a write fault (for tests; see the module docs).
pub const FAULT_ENV: &str = "POLYMAP_TEST_FAULT";

/// Writes `path` atomically: `fill` writes the contents into a buffered temporary file in the
/// same folder, which is then flushed, synced and renamed over `path`. On any error the
/// temporary file is removed and `path` is left as it was.
pub fn write_atomic(
    path: &Path,
    fill: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> io::Result<()> {
    let mut file = AtomicFile::create(path)?;
    fill(&mut file)?;
    file.commit()
}

/// [`write_atomic`] for a writer with its own error type: `fill`'s error is returned as is
/// (the temporary file removed), I/O errors of creating and committing go through `on_io`.
pub fn write_atomic_with<E>(
    path: &Path,
    fill: impl FnOnce(&mut dyn Write) -> Result<(), E>,
    on_io: impl Fn(io::Error) -> E,
) -> Result<(), E> {
    let mut file = AtomicFile::create(path).map_err(&on_io)?;
    fill(&mut file)?;
    file.commit().map_err(on_io)
}

/// Writes `bytes` to `path` atomically (see [`write_atomic`]).
pub fn write_bytes_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    write_atomic(path, |out| out.write_all(bytes))
}

/// A file being written atomically: a temporary file until [`AtomicFile::commit`] renames it
/// into place. Dropped without a commit, it removes the temporary file.
#[derive(Debug)]
pub struct AtomicFile {
    path: PathBuf,
    temp: PathBuf,
    out: Option<BufWriter<File>>,
    fault: Option<Fault>,
    written: u64,
    /// True once renamed into place; until then dropping removes the temporary file.
    committed: bool,
}

/// An injected fault (see [`FAULT_ENV`]).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Fault {
    /// Fail as a full disk would.
    NoSpace,
    /// Abort the process after this many bytes.
    AbortAfter(u64),
}

impl AtomicFile {
    /// Creates the temporary file beside `path`.
    pub fn create(path: &Path) -> io::Result<AtomicFile> {
        let name = path.file_name().ok_or_else(|| {
            io::Error::new(
                io::ErrorKind::InvalidInput,
                "not a file name (ends in `..` or `/`)",
            )
        })?;
        let temp = path.with_file_name(format!(
            ".{}.tmp-{}",
            name.to_string_lossy(),
            std::process::id()
        ));
        let file = File::create(&temp)?;
        Ok(AtomicFile {
            fault: injected_fault(&name.to_string_lossy()),
            path: path.to_path_buf(),
            temp,
            out: Some(BufWriter::with_capacity(1 << 16, file)),
            written: 0,
            committed: false,
        })
    }

    /// The final path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Flushes and syncs the temporary file and renames it over the final path. On an error
    /// (a flush, a sync or the rename failing) the temporary file is removed.
    pub fn commit(mut self) -> io::Result<()> {
        if let Some(Fault::AbortAfter(_)) = self.fault {
            // The fault aborts at half the bytes; a file shorter than that aborts here.
            std::process::abort();
        }
        let out = self.out.take().ok_or_else(closed)?;
        let file = out.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        drop(file);
        std::fs::rename(&self.temp, &self.path)?;
        self.committed = true;
        if let Some(dir) = self.path.parent() {
            // Make the rename itself durable; a folder that cannot be opened (some platforms)
            // only loses that guarantee.
            if let Ok(d) = File::open(if dir.as_os_str().is_empty() {
                Path::new(".")
            } else {
                dir
            }) {
                let _ = d.sync_all();
            }
        }
        Ok(())
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match self.fault {
            Some(Fault::NoSpace) => {
                return Err(io::Error::new(
                    io::ErrorKind::StorageFull,
                    "No space left on device (injected by POLYMAP_TEST_FAULT)",
                ));
            }
            Some(Fault::AbortAfter(n)) if self.written >= n => {
                let _ = self.out.as_mut().map(BufWriter::flush);
                std::process::abort();
            }
            _ => {}
        }
        let out = self.out.as_mut().ok_or_else(closed)?;
        let n = out.write(buf)?;
        self.written += n as u64;
        Ok(n)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.out.as_mut().ok_or_else(closed)?.flush()
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        // Close the file before removing it.
        drop(self.out.take());
        if !self.committed {
            let _ = std::fs::remove_file(&self.temp);
        }
    }
}

fn closed() -> io::Error {
    io::Error::other("the file was already committed")
}

/// The fault injected for the file called `name`, if [`FAULT_ENV`] names it.
fn injected_fault(name: &str) -> Option<Fault> {
    let spec = std::env::var(FAULT_ENV).ok()?;
    let (file, kind) = spec.split_once(':')?;
    if file != name {
        return None;
    }
    match kind {
        "enospc" => Some(Fault::NoSpace),
        // Half of a typical output: small enough to hit every file the tests write.
        "abort" => Some(Fault::AbortAfter(256)),
        _ => None,
    }
}

/// Checks that files can be created in `dir` (which must exist and be a folder), by creating
/// and removing a temporary file there: a read-only or full folder is found before any work.
pub fn check_writable_dir(dir: &Path) -> io::Result<()> {
    let meta = std::fs::metadata(dir)?;
    if !meta.is_dir() {
        return Err(io::Error::new(io::ErrorKind::NotADirectory, "not a folder"));
    }
    let probe = dir.join(format!(".polymap-probe-{}", std::process::id()));
    let mut file = File::create(&probe)?;
    let written = file.write_all(b"probe").and_then(|()| file.sync_all());
    drop(file);
    let removed = std::fs::remove_file(&probe);
    written.and(removed)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_dir(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("polymap-atomic-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn entries(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn a_failing_writer_leaves_the_old_file_and_no_temporary() {
        let dir = temp_dir("fail");
        let path = dir.join("map.json");
        std::fs::write(&path, "old").unwrap();
        let err = write_atomic(&path, |out| {
            out.write_all(b"new, half")?;
            Err(io::Error::new(io::ErrorKind::StorageFull, "disk full"))
        })
        .unwrap_err();
        assert_eq!(err.kind(), io::ErrorKind::StorageFull);
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "old");
        assert_eq!(entries(&dir), ["map.json"]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A folder in the way of the final name (`mkdir D/map.json`) fails the rename; the
    /// temporary file was left behind beside it.
    #[test]
    fn a_failed_rename_removes_the_temporary() {
        let dir = temp_dir("rename");
        let path = dir.join("map.json");
        std::fs::create_dir(&path).unwrap();
        std::fs::write(path.join("inside"), "x").unwrap();
        assert!(write_bytes_atomic(&path, b"new").is_err());
        assert_eq!(entries(&dir), ["map.json"]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_commit_replaces_the_file_whole() {
        let dir = temp_dir("ok");
        let path = dir.join("a.txt");
        std::fs::write(&path, "old contents, longer").unwrap();
        write_bytes_atomic(&path, b"new").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "new");
        assert_eq!(entries(&dir), ["a.txt"]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn writable_check_refuses_files_and_missing_folders() {
        let dir = temp_dir("check");
        assert!(check_writable_dir(&dir).is_ok());
        assert_eq!(entries(&dir), Vec::<String>::new());
        std::fs::write(dir.join("f"), "x").unwrap();
        let e = check_writable_dir(&dir.join("f")).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::NotADirectory);
        assert!(check_writable_dir(&dir.join("missing")).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
