//! The run folder: checked before mapping, written in a fixed order, every file atomically.
//!
//! Order: `map.json`, `trajectory.tum`, `summary.json` (the small contract files, so a full
//! disk or a kill loses the big ones first), then `map.svg`, `history.json`, then the
//! requested exports. Each file goes to a temporary file in the folder and is renamed into
//! place ([`polymap_io::atomic`]): a file is either the old one or the whole new one.

use std::io;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use polymap::config::Config;
use polymap_export::ExportError;
use polymap_export::formats::{ExportInput, Format, export};
use polymap_export::report::ReportData;
use polymap_export::svg::{SvgStyle, write_svg};
use polymap_io::atomic::{check_writable_dir, write_bytes_atomic};
use polymap_io::loop_nodes::{LOOP_NODES_FILE, write_loop_nodes};
use polymap_io::map_json::{MapJsonError, write_map_json};
use polymap_io::snapshot::{MapSnapshot, ScanPoints};
use polymap_io::tum::{TumError, write_tum};
use serde_json::json;

use crate::manifest::{
    FolderLock, MANIFEST_FILE, Manifest, ManifestError, manifest_of, new_run_id, write_manifest,
};
use crate::pipeline::RunRecord;

/// The files every run writes, in the order written.
pub const RUN_FILES: [&str; 6] = [
    "map.json",
    "trajectory.tum",
    "summary.json",
    "loop_nodes.json",
    "map.svg",
    "history.json",
];
/// The per-scan diagnostics file (`--diagnostics`).
pub const DIAGNOSTICS_FILE: &str = "diagnostics.jsonl";

/// Every file name a run may write (the manifest lists those a run wrote).
pub fn ours() -> Vec<&'static str> {
    RUN_FILES
        .iter()
        .copied()
        .chain([DIAGNOSTICS_FILE, MANIFEST_FILE])
        .chain(Format::ALL.iter().flat_map(|f| f.files().iter().copied()))
        .collect()
}

/// Why the run folder cannot be used or written.
#[derive(Debug, thiserror::Error)]
pub enum FolderError {
    /// The path exists and is not a folder.
    #[error("{}: not a folder (it is a file); name a folder for the outputs", path.display())]
    NotAFolder {
        /// The path given.
        path: PathBuf,
    },
    /// The folder cannot be created or written.
    #[error("{}: cannot write outputs there: {source}", path.display())]
    NotWritable {
        /// The folder.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: io::Error,
    },
    /// Writing a file failed.
    #[error("{}: cannot write: {source}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: io::Error,
    },
    /// `map.json` could not be written.
    #[error(transparent)]
    MapJson(#[from] MapJsonError),
    /// `trajectory.tum` could not be written.
    #[error(transparent)]
    Tum(#[from] TumError),
    /// A picture or export could not be written.
    #[error(transparent)]
    Export(#[from] ExportError),
    /// The folder's lock or manifest.
    #[error(transparent)]
    Manifest(#[from] ManifestError),
    /// The output folder is one of the command's inputs, which writing would change.
    #[error(
        "{}: the output folder is an input ({what}), which writing there would change; name \
         another folder with -o",
        path.display()
    )]
    IsAnInput {
        /// The output folder given.
        path: PathBuf,
        /// The input it is (`saved map`, `log`, …).
        what: String,
    },
}

/// Refuses an output folder that is one of `inputs` (each with what it is, e.g. `("saved
/// map", dir)`), compared after following links: writing the run there would change an input
/// the command promises to read only. An output that does not exist yet is no input.
pub fn check_output_apart(output: &Path, inputs: &[(&str, &Path)]) -> Result<(), FolderError> {
    let Ok(out) = output.canonicalize() else {
        return Ok(());
    };
    match inputs
        .iter()
        .find(|(_, input)| input.canonicalize().is_ok_and(|i| i == out))
    {
        Some((what, _)) => Err(FolderError::IsAnInput {
            path: output.to_path_buf(),
            what: (*what).to_owned(),
        }),
        None => Ok(()),
    }
}

/// A checked run folder, locked for this run until dropped.
#[derive(Debug, Clone)]
pub struct RunFolder {
    dir: PathBuf,
    /// This run's identifier, in the manifest.
    run: String,
    _lock: Arc<FolderLock>,
}

impl RunFolder {
    /// Creates `dir` if missing and checks that it is a folder where files can be written (by
    /// writing and removing a probe file): a read-only or wrong output is found before mapping.
    /// Takes the folder's lock ([`FolderLock::exclusive`]): a second run writing the same
    /// folder is refused ([`ManifestError::Busy`]) before it maps.
    pub fn prepare(dir: &Path) -> Result<RunFolder, FolderError> {
        if dir.exists() && !dir.is_dir() {
            return Err(FolderError::NotAFolder {
                path: dir.to_path_buf(),
            });
        }
        let not_writable = |source| FolderError::NotWritable {
            path: dir.to_path_buf(),
            source,
        };
        std::fs::create_dir_all(dir).map_err(not_writable)?;
        check_writable_dir(dir).map_err(not_writable)?;
        let lock = FolderLock::exclusive(dir)?;
        let folder = RunFolder {
            dir: dir.to_path_buf(),
            run: new_run_id(),
            _lock: Arc::new(lock),
        };
        folder.remove_temporaries().map_err(not_writable)?;
        Ok(folder)
    }

    /// Removes the temporary files a killed run left (`.NAME.tmp-PID` of polymap's own names).
    fn remove_temporaries(&self) -> io::Result<()> {
        let ours = ours();
        for entry in std::fs::read_dir(&self.dir)? {
            let name = entry?.file_name().to_string_lossy().into_owned();
            let is_ours = ours.iter().any(|n| name.starts_with(&format!(".{n}.tmp-")));
            if is_ours {
                std::fs::remove_file(self.dir.join(&name))?;
            }
        }
        Ok(())
    }

    /// The folder.
    pub fn path(&self) -> &Path {
        &self.dir
    }

    /// Removes the outputs of an earlier run that this run will not write (exports not asked
    /// for now, diagnostics without `--diagnostics`), so none is left beside the new map.
    /// Returns the names removed. Only polymap's own file names are touched.
    pub fn remove_stale(&self, formats: &[Format], diagnostics: bool) -> io::Result<Vec<String>> {
        let mut removed = Vec::new();
        let unrequested = Format::ALL.into_iter().filter(|f| !formats.contains(f));
        let mut names: Vec<&str> = unrequested
            .flat_map(|f| f.files().iter().copied())
            .collect();
        if !diagnostics {
            names.push(DIAGNOSTICS_FILE);
        }
        for name in names {
            let path = self.dir.join(name);
            if path.is_file() {
                std::fs::remove_file(&path)?;
                removed.push(name.to_owned());
            }
        }
        Ok(removed)
    }

    /// Opens the write phase: the manifest says the folder is being written, so that a run
    /// killed or failing before [`RunFolder::finish_writing`] leaves a folder that readers
    /// refuse rather than take for one run.
    pub fn begin_writing(&self) -> Result<(), FolderError> {
        let manifest = Manifest {
            complete: false,
            ..manifest_of(&self.dir, &self.run, &[])?
        };
        Ok(write_manifest(&self.dir, &manifest)?)
    }

    /// Closes the write phase: the manifest lists the files `names` (those present) with their
    /// size and CRC-32, written last.
    pub fn finish_writing(&self, names: &[&str]) -> Result<(), FolderError> {
        let files: Vec<&str> = names
            .iter()
            .copied()
            .filter(|n| *n != MANIFEST_FILE)
            .collect();
        Ok(write_manifest(
            &self.dir,
            &manifest_of(&self.dir, &self.run, &files)?,
        )?)
    }

    /// Writes a finished run (after [`RunFolder::begin_writing`]): the contract files first,
    /// then the picture, the history, the `formats` asked for, and the manifest. Returns the
    /// export files written.
    pub fn write_run(&self, run: &RunFiles<'_>) -> Result<Vec<PathBuf>, FolderError> {
        self.begin_writing()?;
        let d = &self.dir;
        write_map_json(d.join("map.json"), &run.snapshot.map_json())?;
        write_tum(d.join("trajectory.tum"), &run.snapshot.trajectory)?;
        self.write_json(&d.join("summary.json"), run.summary, true)?;
        write_loop_nodes(d.join(LOOP_NODES_FILE), &run.snapshot.frame, run.loop_nodes)?;
        write_svg(&d.join("map.svg"), run.snapshot, &SvgStyle::default())?;
        self.write_json(&d.join("history.json"), run.history, false)?;
        let input = ExportInput {
            dir: d,
            snapshot: run.snapshot,
            rays: run.rays,
            history: Some(run.history),
            resolution_m: run.resolution_m,
        };
        let written = export(run.formats, &input)?;
        self.finish_writing(&ours())?;
        Ok(written)
    }

    fn write_json(
        &self,
        path: &Path,
        value: &impl serde::Serialize,
        pretty: bool,
    ) -> Result<(), FolderError> {
        let write = |source| FolderError::Write {
            path: path.to_path_buf(),
            source,
        };
        let text = if pretty {
            serde_json::to_string_pretty(value)
        } else {
            serde_json::to_string(value)
        }
        .map_err(|e| write(io::Error::other(e)))?;
        write_bytes_atomic(path, text.as_bytes()).map_err(write)
    }
}

/// Everything [`RunFolder::write_run`] writes.
#[derive(Debug, Clone, Copy)]
pub struct RunFiles<'a> {
    /// The final map and trajectory (and points for the pictures).
    pub snapshot: &'a MapSnapshot,
    /// `summary.json`.
    pub summary: &'a serde_json::Value,
    /// `history.json`, and the report's data.
    pub history: &'a ReportData,
    /// `loop_nodes.json`: the loop-closure nodes, for a run that continues the map.
    pub loop_nodes: &'a [polymap::loops::SavedNode],
    /// The exports asked for.
    pub formats: &'a [Format],
    /// The run's rays for the occupancy grid.
    pub rays: Option<&'a ScanPoints>,
    /// Cell size of the occupancy grid, metres.
    pub resolution_m: f64,
}

/// Latency percentiles in milliseconds: p50, p99, max.
pub fn percentiles_ms(latencies: &[Duration]) -> [f64; 3] {
    let mut ms: Vec<f64> = latencies.iter().map(|d| d.as_secs_f64() * 1e3).collect();
    ms.sort_by(f64::total_cmp);
    let at = |q: f64| {
        ms.get(((ms.len() as f64 - 1.0) * q).round() as usize)
            .copied()
            .unwrap_or(0.0)
    };
    [at(0.5), at(0.99), ms.last().copied().unwrap_or(0.0)]
}

/// The `summary.json` document of a run: `log` names the log (`-` for standard input),
/// `every` the scans picked (`[k, offset]`), `reader` holds the source's own counts, `points`
/// the valid returns read.
pub fn summary_json(
    log: &str,
    config: &Config,
    run: &RunRecord,
    every: [u64; 2],
    points: u64,
    reader: serde_json::Value,
) -> serde_json::Value {
    let t = &run.timings;
    let scans = run.trajectory.len();
    let elapsed_s = t.elapsed.as_secs_f64();
    let [p50, p99, max] = percentiles_ms(&t.latencies);
    let mut summary = json!({
        "log": log,
        "scans": scans,
        "points": points,
        "segments": run.mapper.segments().len(),
        "polylines": run.mapper.polylines().len(),
        "elapsed_s": elapsed_s,
        "scans_per_s": if elapsed_s > 0.0 { scans as f64 / elapsed_s } else { 0.0 },
        "read_s": t.read.as_secs_f64(),
        "map_s": t.map.as_secs_f64(),
        "wait_s": t.wait.as_secs_f64(),
        "latency_ms": { "p50": p50, "p99": p99, "max": max },
        "icp_not_converged": run.icp_not_converged,
        "loop_closures": run.mapper.loop_closures(),
        "every": { "k": every[0], "offset": every[1] },
        "tracking": run.mapper.tracking_summary(),
        "map_role": run.mapper.role(),
        "placed": run.mapper.placed(),
        "scans_before": run.mapper.first_scan(),
        "stage_s": t.stages,
        "final_main_directions_deg": run.last.main_directions_deg,
        "reader": reader,
        "config": serde_json::to_value(config).unwrap_or(serde_json::Value::Null),
    });
    if run.interrupted {
        summary["interrupted"] = json!(true);
    }
    summary
}
