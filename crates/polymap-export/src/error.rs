//! The one error type of the exporters: every variant names the file or the limit involved.

use std::path::PathBuf;

/// Why an export failed.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// Reading or writing a file failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The occupancy grid would exceed [`crate::pgm::GridParams::max_cells`].
    #[error(
        "occupancy grid of {width_cells} x {height_cells} cells at {resolution_m} m/cell exceeds \
         the cap of {max_cells} cells: use a coarser resolution"
    )]
    GridTooLarge {
        /// Columns the map would need (may be huge or non-finite input rounded).
        width_cells: f64,
        /// Rows the map would need.
        height_cells: f64,
        /// The grid's cell size, metres.
        resolution_m: f64,
        /// The cap in force.
        max_cells: usize,
    },
    /// A parameter is out of its documented range.
    #[error("invalid parameter {name}: {reason}")]
    InvalidParameter {
        /// The parameter, e.g. `resolution_m`.
        name: &'static str,
        /// What is wrong with it.
        reason: String,
    },
    /// A format needs an input the run does not have.
    #[error("{}: cannot write without {what}", path.display())]
    Missing {
        /// The file that was to be written.
        path: PathBuf,
        /// What is missing.
        what: String,
    },
    /// Encoding a PNG picture failed.
    #[error("{}: PNG encoding failed: {message}", path.display())]
    Png {
        /// The picture's file (empty when rendering to memory).
        path: PathBuf,
        /// The encoder's message.
        message: String,
    },
    /// The report data could not be serialised to JSON.
    #[error("{}: report data could not be serialised: {source}", path.display())]
    Json {
        /// The report's file (empty when writing to a stream).
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: serde_json::Error,
    },
}

impl ExportError {
    /// An [`ExportError::Io`] for `path`.
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        ExportError::Io {
            path: path.into(),
            source,
        }
    }
}
