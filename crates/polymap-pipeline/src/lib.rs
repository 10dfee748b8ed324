//! # polymap-pipeline — a mapping run as a library
//!
//! The `polymap map` command is this crate plus argument parsing and a progress bar:
//!
//! - [`pipeline`]: read → prepare → push → record. Scans come from any
//!   [`ScanSource`](polymap_io::source::ScanSource); reading and preparation (ranges to points,
//!   once; segment extraction) run ahead on a second thread, mapping stays in log order; a stop
//!   flag ends a run early keeping what was mapped.
//! - [`folder`]: the run folder. Checked (a folder, writable) before mapping; written in a fixed
//!   order, the small contract files first (`map.json`, `trajectory.tum`, `summary.json`),
//!   every file atomically; outputs of an earlier run that this run does not write are
//!   removed, and said so.
//! - [`manifest`]: what ties the folder's files together: `manifest.json`, written last (each
//!   file's size and CRC-32), checked by the commands that read a run folder; and the folder's
//!   lock, held while a run writes it.
//!
//! Everything is in metres and radians, map frame unless a name says otherwise.

#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod folder;
pub mod manifest;
pub mod pipeline;

/// The README's Rust example, compiled as a doctest so that the guide cannot rot (its shell
/// commands are run by `polymap-cli`'s end-to-end test `readme`).
#[cfg(doctest)]
#[doc = include_str!("../../../README.md")]
pub struct ReadmeExample;
