//! The per-scan diagnostics file, written as the run goes and renamed into place at the end;
//! the check of a run folder read as input.

use std::io::Write;
use std::path::Path;

use anyhow::{Context, Result};
use polymap_io::atomic::AtomicFile;

/// Writes one JSON object per scan: `{"scan": i, "stamp": "...", "pose": {...}, ...diagnostics}`,
/// into a temporary file that [`DiagnosticsWriter::finish`] renames into place.
pub struct DiagnosticsWriter {
    out: AtomicFile,
}

impl DiagnosticsWriter {
    pub fn create(path: &Path) -> Result<Self> {
        let out = AtomicFile::create(path)
            .with_context(|| format!("{}: cannot create", path.display()))?;
        Ok(DiagnosticsWriter { out })
    }

    pub fn write(&mut self, stamp: &str, update: &polymap::mapper::Update) -> std::io::Result<()> {
        let line = serde_json::json!({
            "scan": update.scan_index,
            "stamp": stamp,
            "pose": update.map_from_robot,
            "diagnostics": update.diagnostics,
        });
        writeln!(self.out, "{line}")
    }

    pub fn finish(self) -> Result<()> {
        let path = self.out.path().to_path_buf();
        self.out
            .commit()
            .with_context(|| format!("{}: cannot write", path.display()))
    }
}

/// Writes a file atomically, naming it in the error.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    polymap_io::atomic::write_bytes_atomic(path, bytes)
        .with_context(|| format!("{}: cannot write", path.display()))
}

/// Checks that the files `names` of the run folder `dir`, read as input, are one run's (see
/// `polymap_pipeline::manifest`): refuses a folder a run is writing, one a run did not finish
/// writing, or one that mixes two runs' files; a folder without a manifest gets a note.
/// Returns the folder's lock for reading: hold it while the files are read, so that no run
/// writes them after the check.
pub fn check_run_folder(
    dir: &Path,
    names: &[&str],
) -> Result<Option<polymap_pipeline::manifest::FolderLock>> {
    let (check, lock) = polymap_pipeline::manifest::check_files(dir, names)?;
    note_unknown(dir, &check);
    Ok(lock)
}

/// [`check_run_folder`] for a command that holds the folder's lock for writing already.
pub fn check_locked_run_folder(dir: &Path, names: &[&str]) -> Result<()> {
    let check = polymap_pipeline::manifest::check_listed(dir, names)?;
    note_unknown(dir, &check);
    Ok(())
}

fn note_unknown(dir: &Path, check: &polymap_pipeline::manifest::FolderCheck) {
    use polymap_pipeline::manifest::{FolderCheck, MANIFEST_FILE};
    if *check == FolderCheck::Unknown {
        eprintln!(
            "polymap: note: {} has no {MANIFEST_FILE} (written by an older polymap, or by hand): \
             its files cannot be checked to be of one run",
            crate::quote::quoted(&dir.display().to_string())
        );
    }
}
