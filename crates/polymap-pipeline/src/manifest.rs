//! What ties a run folder's files together: `manifest.json`, written last, lists each file the
//! run wrote with its size and CRC-32; and `.polymap.lock`, locked while a run writes the folder.
//!
//! Each file is written atomically, but a run killed (or failing on a full disk) in its write
//! phase would leave new files beside old ones. So the write phase opens by writing a manifest
//! that says the folder is being written (`"complete": false`), and ends with the complete one.
//! A command that reads a run folder ([`check_files`]) refuses a folder whose manifest is not
//! complete, or one of whose files is not the one listed (a mixed folder); a folder without a
//! manifest (written before it existed, or by another tool) is read with a note.
//!
//! ```json
//! {"version": 1, "run": "1733130000.123456789-4242", "complete": true,
//!  "files": {"map.json": {"bytes": 12345, "crc32": "1a2b3c4d"}, ...}}
//! ```

use std::collections::BTreeMap;
use std::fs::{File, OpenOptions};
use std::io::{self, Read};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

/// The manifest's name in a run folder.
pub const MANIFEST_FILE: &str = "manifest.json";
/// The lock file's name in a run folder (it stays; the lock is what a run holds).
pub const LOCK_FILE: &str = ".polymap.lock";
/// The format version written, and the newest read.
const VERSION: u32 = 1;
/// The most a manifest may weigh (a run lists about a dozen files).
const MAX_MANIFEST_BYTES: u64 = 1 << 20;

/// `manifest.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// Format version.
    pub version: u32,
    /// The run that wrote the folder: the wall-clock time it started writing and its process.
    pub run: String,
    /// False while the run writes the folder: its files may be of two runs.
    pub complete: bool,
    /// The files the run wrote, by name.
    pub files: BTreeMap<String, FileEntry>,
}

/// One file of a [`Manifest`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct FileEntry {
    /// Its size, bytes.
    pub bytes: u64,
    /// Its CRC-32 (IEEE), 8 hexadecimal digits.
    #[serde(with = "hex32")]
    pub crc32: u32,
}

mod hex32 {
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(v: &u32, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&format!("{v:08x}"))
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
        let text = String::deserialize(d)?;
        u32::from_str_radix(&text, 16).map_err(serde::de::Error::custom)
    }
}

/// Why a run folder's files cannot be taken as one run's.
#[derive(Debug, thiserror::Error)]
pub enum ManifestError {
    /// Another polymap run holds the folder's lock for writing.
    #[error(
        "{}: another polymap run is writing this folder (it holds {LOCK_FILE}); wait for it, or \
         name another folder",
        dir.display()
    )]
    Busy {
        /// The folder.
        dir: PathBuf,
    },
    /// Another polymap run holds the folder's lock for reading: it reads the folder's files
    /// or uses them as its saved map.
    #[error(
        "{}: another polymap run is reading this folder or using it as its map (it holds \
         {LOCK_FILE} shared); wait for it, or name another folder",
        dir.display()
    )]
    InUse {
        /// The folder.
        dir: PathBuf,
    },
    /// The manifest says the folder is being written, and no run is writing it.
    #[error(
        "{}: the run that wrote this folder did not finish writing it (killed, or a write \
         failed): its files may be of two runs; map again",
        dir.display()
    )]
    Unfinished {
        /// The folder.
        dir: PathBuf,
    },
    /// A file is not the one the manifest lists.
    #[error(
        "{}: {problem}: the folder mixes files of two runs; map again",
        dir.join(name).display()
    )]
    Mixed {
        /// The folder.
        dir: PathBuf,
        /// The file.
        name: String,
        /// How it differs.
        problem: String,
    },
    /// The manifest or the lock cannot be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: io::Error,
    },
}

/// The size and CRC-32 of a file.
pub fn file_entry(path: &Path) -> io::Result<FileEntry> {
    let mut file = polymap_io::input_file::open_regular(path)?;
    let mut hasher = crc32fast::Hasher::new();
    let mut buf = vec![0u8; 1 << 16];
    let mut bytes = 0u64;
    loop {
        let n = file.read(&mut buf)?;
        if n == 0 {
            break;
        }
        hasher.update(&buf[..n]);
        bytes += n as u64;
    }
    Ok(FileEntry {
        bytes,
        crc32: hasher.finalize(),
    })
}

/// A run identifier: the time (seconds since 1970, to the nanosecond) and the process.
pub fn new_run_id() -> String {
    let since = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap_or_default();
    format!(
        "{}.{:09}-{}",
        since.as_secs(),
        since.subsec_nanos(),
        std::process::id()
    )
}

/// Reads `dir/manifest.json`; `None` when there is none.
pub fn read_manifest(dir: &Path) -> Result<Option<Manifest>, ManifestError> {
    let path = dir.join(MANIFEST_FILE);
    if !path.exists() {
        return Ok(None);
    }
    let io = |source| ManifestError::Io {
        path: path.clone(),
        source,
    };
    let text =
        polymap_io::input_file::read_regular_to_string(&path, MAX_MANIFEST_BYTES).map_err(io)?;
    let manifest: Manifest = serde_json::from_str(&text)
        .map_err(|e| io(io::Error::new(io::ErrorKind::InvalidData, e)))?;
    if manifest.version == 0 || manifest.version > VERSION {
        return Err(io(io::Error::new(
            io::ErrorKind::InvalidData,
            format!(
                "manifest version {} is not one this polymap reads (1 to {VERSION})",
                manifest.version
            ),
        )));
    }
    Ok(Some(manifest))
}

/// Writes `manifest` to `dir/manifest.json` atomically.
pub fn write_manifest(dir: &Path, manifest: &Manifest) -> Result<(), ManifestError> {
    let path = dir.join(MANIFEST_FILE);
    let mut text = serde_json::to_string_pretty(manifest).map_err(|e| ManifestError::Io {
        path: path.clone(),
        source: io::Error::other(e),
    })?;
    text.push('\n');
    polymap_io::atomic::write_bytes_atomic(&path, text.as_bytes())
        .map_err(|source| ManifestError::Io { path, source })
}

/// The manifest of the files `names` of `dir` as they are now (those that exist).
pub fn manifest_of(dir: &Path, run: &str, names: &[&str]) -> Result<Manifest, ManifestError> {
    let mut files = BTreeMap::new();
    for name in names {
        let path = dir.join(name);
        if path.is_file() {
            let entry = file_entry(&path).map_err(|source| ManifestError::Io {
                path: path.clone(),
                source,
            })?;
            files.insert((*name).to_owned(), entry);
        }
    }
    Ok(Manifest {
        version: VERSION,
        run: run.to_owned(),
        complete: true,
        files,
    })
}

/// What [`check_files`] found.
#[derive(Debug, Clone, PartialEq)]
pub enum FolderCheck {
    /// The manifest is complete and lists each file read, unchanged.
    OneRun(Manifest),
    /// No manifest: a folder written before manifests, or by another tool.
    Unknown,
}

/// Checks that the files `names` of the run folder `dir` that exist are the ones its run
/// wrote: no run is writing the folder (its lock is free), the manifest is complete, and each
/// such file is listed with its size and CRC-32. Returns the folder's lock taken for reading
/// (where the folder has a lock file): the caller holds it while it reads the files, so that
/// no run writes them between the check and the read.
pub fn check_files(
    dir: &Path,
    names: &[&str],
) -> Result<(FolderCheck, Option<FolderLock>), ManifestError> {
    let lock = FolderLock::try_shared(dir)?;
    Ok((check_listed(dir, names)?, lock))
}

/// [`check_files`] for a caller that holds the folder's lock already (for writing).
pub fn check_listed(dir: &Path, names: &[&str]) -> Result<FolderCheck, ManifestError> {
    let Some(manifest) = read_manifest(dir)? else {
        return Ok(FolderCheck::Unknown);
    };
    if !manifest.complete {
        return Err(ManifestError::Unfinished {
            dir: dir.to_path_buf(),
        });
    }
    for name in names {
        let path = dir.join(name);
        if !path.exists() {
            continue;
        }
        let mixed = |problem: String| ManifestError::Mixed {
            dir: dir.to_path_buf(),
            name: (*name).to_owned(),
            problem,
        };
        let Some(listed) = manifest.files.get(*name) else {
            return Err(mixed(format!(
                "not among the files of run {} ({MANIFEST_FILE})",
                manifest.run
            )));
        };
        let found = file_entry(&path).map_err(|source| ManifestError::Io {
            path: path.clone(),
            source,
        })?;
        if found != *listed {
            return Err(mixed(format!(
                "not the file run {} wrote ({} bytes, CRC-32 {:08x}; {MANIFEST_FILE} lists {} \
                 bytes, {:08x})",
                manifest.run, found.bytes, found.crc32, listed.bytes, listed.crc32
            )));
        }
    }
    Ok(FolderCheck::OneRun(manifest))
}

/// A run folder's lock, held until dropped.
#[derive(Debug)]
pub struct FolderLock {
    _file: File,
}

impl FolderLock {
    /// Takes the folder's lock for writing, creating the lock file; [`ManifestError::Busy`]
    /// when another run holds it.
    pub fn exclusive(dir: &Path) -> Result<FolderLock, ManifestError> {
        let path = dir.join(LOCK_FILE);
        check_lock_file(&path)?;
        let file = OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&path)
            .map_err(|source| ManifestError::Io {
                path: path.clone(),
                source,
            })?;
        match file.try_lock() {
            Ok(()) => Ok(FolderLock { _file: file }),
            // Held for reading where a shared lock can still be taken.
            Err(std::fs::TryLockError::WouldBlock) => {
                match File::open(&path).is_ok_and(|f| f.try_lock_shared().is_ok()) {
                    true => Err(ManifestError::InUse {
                        dir: dir.to_path_buf(),
                    }),
                    false => Err(ManifestError::Busy {
                        dir: dir.to_path_buf(),
                    }),
                }
            }
            Err(std::fs::TryLockError::Error(source)) => Err(ManifestError::Io { path, source }),
        }
    }

    /// Takes the folder's lock for reading where the folder has a lock file (`None` where it
    /// has none: nothing is created in a folder only read); [`ManifestError::Busy`] while a run
    /// writes it.
    pub fn try_shared(dir: &Path) -> Result<Option<FolderLock>, ManifestError> {
        let path = dir.join(LOCK_FILE);
        if std::fs::symlink_metadata(&path).is_err() {
            return Ok(None);
        }
        check_lock_file(&path)?;
        let Ok(file) = File::open(&path) else {
            return Ok(None);
        };
        match file.try_lock_shared() {
            Ok(()) => Ok(Some(FolderLock { _file: file })),
            Err(std::fs::TryLockError::WouldBlock) => Err(ManifestError::Busy {
                dir: dir.to_path_buf(),
            }),
            Err(std::fs::TryLockError::Error(source)) => Err(ManifestError::Io { path, source }),
        }
    }
}

/// Refuses a lock file that is there and not a regular file, before opening it: opening a
/// FIFO waits for a writer, so one planted as `.polymap.lock` would hang the run.
fn check_lock_file(path: &Path) -> Result<(), ManifestError> {
    if std::fs::symlink_metadata(path).is_err() {
        return Ok(());
    }
    polymap_io::input_file::check_regular(path)
        .map(drop)
        .map_err(|source| ManifestError::Io {
            path: path.to_path_buf(),
            source,
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_folder_is_one_run_unfinished_or_mixed() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::write(d.join("map.json"), "new map").unwrap();
        std::fs::write(d.join("summary.json"), "new summary").unwrap();
        assert_eq!(
            check_files(d, &["map.json"]).unwrap().0,
            FolderCheck::Unknown
        );
        let manifest = manifest_of(d, "run-1", &["map.json", "summary.json", "gone"]).unwrap();
        assert_eq!(manifest.files.len(), 2);
        write_manifest(d, &manifest).unwrap();
        assert!(matches!(
            check_files(d, &["map.json", "summary.json"]).unwrap().0,
            FolderCheck::OneRun(_)
        ));
        // An older run's file beside the listed ones.
        std::fs::write(d.join("summary.json"), "old summary").unwrap();
        let e = check_files(d, &["map.json", "summary.json"]).unwrap_err();
        assert!(
            e.to_string()
                .contains("summary.json: not the file run run-1 wrote"),
            "{e}"
        );
        std::fs::write(d.join("history.json"), "{}").unwrap();
        let e = check_files(d, &["history.json"]).unwrap_err();
        assert!(
            e.to_string().contains("not among the files of run run-1"),
            "{e}"
        );
        let unfinished = Manifest {
            complete: false,
            ..manifest
        };
        write_manifest(d, &unfinished).unwrap();
        let e = check_files(d, &["map.json"]).unwrap_err();
        assert!(e.to_string().contains("did not finish writing it"), "{e}");
    }

    #[test]
    fn a_locked_folder_is_busy_for_writers_and_readers() {
        let dir = tempfile::tempdir().unwrap();
        let lock = FolderLock::exclusive(dir.path()).unwrap();
        assert!(matches!(
            FolderLock::exclusive(dir.path()),
            Err(ManifestError::Busy { .. })
        ));
        assert!(matches!(
            check_files(dir.path(), &[]),
            Err(ManifestError::Busy { .. })
        ));
        drop(lock);
        assert!(FolderLock::exclusive(dir.path()).is_ok());
        assert!(FolderLock::try_shared(dir.path()).unwrap().is_some());
    }

    /// The check used to take the shared lock and drop it at once, so a run could write the
    /// folder between the check and the read. The lock comes back to be held while reading,
    /// and a writer meets a reader, said as such.
    #[test]
    fn a_reader_holds_the_folder_until_it_has_read_it() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        drop(FolderLock::exclusive(d).unwrap());
        std::fs::write(d.join("map.json"), "map").unwrap();
        write_manifest(d, &manifest_of(d, "run-1", &["map.json"]).unwrap()).unwrap();
        let (check, lock) = check_files(d, &["map.json"]).unwrap();
        assert!(matches!(check, FolderCheck::OneRun(_)));
        assert!(lock.is_some());
        let e = FolderLock::exclusive(d).unwrap_err();
        assert!(
            e.to_string()
                .contains("another polymap run is reading this folder"),
            "{e}"
        );
        // Another reader may read beside it.
        assert!(check_files(d, &["map.json"]).is_ok());
        drop(lock);
        assert!(FolderLock::exclusive(d).is_ok());
    }

    /// A FIFO planted as the lock file hung `localize --map D` (opening it waits for a
    /// writer): readers and writers now refuse it, saying what it is.
    #[cfg(unix)]
    #[test]
    fn a_lock_file_that_is_not_a_file_is_refused_without_opening_it() {
        let dir = tempfile::tempdir().unwrap();
        let made = std::process::Command::new("mkfifo")
            .arg(dir.path().join(LOCK_FILE))
            .status()
            .unwrap();
        assert!(made.success());
        let e = check_files(dir.path(), &[]).unwrap_err().to_string();
        assert!(e.contains(".polymap.lock: a FIFO (named pipe)"), "{e}");
        let e = FolderLock::exclusive(dir.path()).unwrap_err().to_string();
        assert!(e.contains(".polymap.lock: a FIFO (named pipe)"), "{e}");
    }
}
