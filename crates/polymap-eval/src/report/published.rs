//! Published figures of the relations metric on Intel, ACES and FR079, as listed in the
//! datasets' `PROVENANCE.md`.
//!
//! The scan-matching and RBPF columns come from a secondary transcription of Kümmerle et al.
//! 2009; the graph-mapping column agrees with the figures Hess et al. 2016 quote from it.
//! Cartographer's wall-clock times were measured on a Xeon E5-1650 at 3.2 GHz.

use super::{MeanStd, PublishedFigure};

/// Scans (FLASER lines) in each benchmark log.
pub const LOG_SCANS: [(&str, usize); 3] = [("intel", 13_631), ("aces", 7_374), ("fr079", 4_934)];

const KUMMERLE: &str = "Kümmerle et al. 2009";
const HESS: &str = "Hess et al. 2016";
const SCAN_MATCHING: &str = "scan matching";
const RBPF: &str = "RBPF, GMapping-type";
const GRAPH: &str = "graph mapping";
const CARTOGRAPHER: &str = "Cartographer";

const fn ms(mean: f64, std: f64) -> MeanStd {
    MeanStd { mean, std }
}

const fn fig(
    log: &'static str,
    method: &'static str,
    source: &'static str,
    translation_m: MeanStd,
    rotation_deg: Option<MeanStd>,
    wall_clock_s: Option<f64>,
) -> PublishedFigure {
    PublishedFigure {
        log,
        method,
        source,
        translation_m,
        rotation_deg,
        wall_clock_s,
    }
}

/// Every published figure: per log (intel, aces, fr079) scan matching, RBPF, graph mapping
/// (Kümmerle et al. 2009) and Cartographer (Hess et al. 2016). Translations in metres,
/// rotations in degrees, mean ± std.
pub const PUBLISHED_FIGURES: [PublishedFigure; 12] = [
    fig(
        "intel",
        SCAN_MATCHING,
        KUMMERLE,
        ms(0.220, 0.296),
        None,
        None,
    ),
    fig("intel", RBPF, KUMMERLE, ms(0.070, 0.083), None, None),
    fig(
        "intel",
        GRAPH,
        KUMMERLE,
        ms(0.031, 0.026),
        Some(ms(1.3, 4.7)),
        None,
    ),
    fig(
        "intel",
        CARTOGRAPHER,
        HESS,
        ms(0.0229, 0.0239),
        Some(ms(0.453, 1.335)),
        Some(179.0),
    ),
    fig(
        "aces",
        SCAN_MATCHING,
        KUMMERLE,
        ms(0.173, 0.614),
        None,
        None,
    ),
    fig("aces", RBPF, KUMMERLE, ms(0.060, 0.049), None, None),
    fig(
        "aces",
        GRAPH,
        KUMMERLE,
        ms(0.044, 0.044),
        Some(ms(0.4, 0.4)),
        None,
    ),
    fig(
        "aces",
        CARTOGRAPHER,
        HESS,
        ms(0.0375, 0.0426),
        Some(ms(0.373, 0.469)),
        Some(41.0),
    ),
    fig(
        "fr079",
        SCAN_MATCHING,
        KUMMERLE,
        ms(0.258, 0.427),
        None,
        None,
    ),
    fig("fr079", RBPF, KUMMERLE, ms(0.061, 0.044), None, None),
    fig(
        "fr079",
        GRAPH,
        KUMMERLE,
        ms(0.056, 0.042),
        Some(ms(0.6, 0.6)),
        None,
    ),
    fig(
        "fr079",
        CARTOGRAPHER,
        HESS,
        ms(0.0452, 0.0354),
        Some(ms(0.538, 0.718)),
        Some(62.0),
    ),
];
