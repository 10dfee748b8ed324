//! # polymap-eval — trajectory and map accuracy against ground truth
//!
//! Metrics over in-memory data (reading logs and trajectory files is `polymap-io`'s job).
//! Metres and radians inside; degrees only in reported figures, named `_deg`.
//! A trajectory is a slice of `(stamp_s, map_from_robot)` pairs, in any order.
//!
//! Conventions used throughout:
//! - stamps match when they differ by at most 1 ms ([`stamp_index::DEFAULT_STAMP_TOLERANCE_S`]),
//!   a relation's by at most 5 µs, the same scan's ([`stamp_index::RELATION_STAMP_TOLERANCE_S`]);
//!   the nearest wins, and among poses sharing a stamp the first in the input;
//! - spreads are population standard deviations ([`stats::ErrorStats`]);
//! - results are named structs deriving `Serialize`; metrics that need at least one sample
//!   return `Option` rather than NaN.
//!
//! Trajectory against ground truth:
//!
//! - [`relations`]: read `.relations` files (Kümmerle et al. 2009 ground-truth relative poses).
//! - [`relation_error`]: the relations metric: mean ± std of relative pose errors.
//! - [`align`]: closed-form least-squares SE(2) alignment of two point sets (2D Kabsch/Umeyama).
//! - [`trajectory`]: estimate vs. true trajectory: association by stamp, ATE, RPE.
//!
//! Map quality:
//!
//! - [`map_quality`]: map against the scan points (share within 5/10 cm, RMS distance) and
//!   against true walls (precision, recall).
//!
//! Support:
//!
//! - [`stamp_index`]: matching time stamps in unsorted trajectories.
//! - [`stats`]: mean, population std, RMS, median, max of a list of errors.
//! - [`report`]: benchmark table rows and the published reference figures.

#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod align;
pub mod map_quality;
pub mod relation_error;
pub mod relations;
pub mod report;
pub mod stamp_index;
pub mod stats;
pub mod trajectory;
