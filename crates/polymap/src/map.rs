//! The global map's element type.

use serde::{Deserialize, Serialize};

use crate::geometry::Segment;

/// One segment of the global map, in the map frame, with its provenance.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MapSegment {
    /// The segment, metres, map frame.
    pub segment: Segment,
    /// Index (0-based, in processing order) of the scan whose merge created this segment.
    pub born_scan: u32,
}
