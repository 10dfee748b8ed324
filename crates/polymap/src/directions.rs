//! Main directions (section 2.2): significant peaks of a cyclic, length-weighted histogram of
//! segment directions over the recently born part of the map.
//!
//! The paper leaves "significant peak" open. Here a peak is a cyclic local maximum of the
//! smoothed histogram that holds at least `min_peak_fraction` of the highest peak and at least
//! `min_peak_length_m` of segment length, and that lies more than `min_separation_deg` from any
//! stronger peak. Its angle is refined below one bin: the length-weighted circular mean (on
//! doubled angles, as directions are undirected) of the segments within `refine_half_width_deg`
//! of the peak's bin.

use std::f64::consts::PI;

use serde::{Deserialize, Serialize};

use crate::check::{Checks, InvalidParam};
use crate::geometry::{Segment, angle_between_directions_rad, undirected_angle_rad};
use crate::map::GlobalMap;

/// Parameters of the direction histogram and its peaks.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DirectionParams {
    /// Number of histogram bins over 180° (the paper: 180, one degree each).
    pub bins: usize,
    /// Width of the cyclic box smoothing window, in bins (the paper: 5).
    pub window_bins: usize,
    /// `tm`: only segments born in the last this many scans vote.
    pub time_memory_scans: u32,
    /// A peak must reach this share of the highest peak.
    pub min_peak_fraction: f64,
    /// A peak must carry at least this much segment length (smoothed), metres.
    pub min_peak_length_m: f64,
    /// Peaks closer than this to a stronger peak are suppressed, degrees.
    pub min_separation_deg: f64,
    /// Segments within this angle of a peak's bin refine its direction, degrees.
    pub refine_half_width_deg: f64,
}

impl Default for DirectionParams {
    fn default() -> Self {
        DirectionParams {
            bins: 180,
            window_bins: 5,
            time_memory_scans: 30,
            min_peak_fraction: 0.15,
            min_peak_length_m: 1.0,
            min_separation_deg: 10.0,
            refine_half_width_deg: 3.0,
        }
    }
}

impl DirectionParams {
    /// Checks every key's range; the error names the first key out of range.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        Checks::new()
            .within("bins", self.bins, 1, 3600)
            .within("window_bins", self.window_bins, 1, self.bins.max(1))
            .within("time_memory_scans", self.time_memory_scans, 1, u32::MAX)
            .share("min_peak_fraction", self.min_peak_fraction)
            .within("min_peak_length_m", self.min_peak_length_m, 0.0, 1e6)
            .within("min_separation_deg", self.min_separation_deg, 0.0, 90.0)
            .within(
                "refine_half_width_deg",
                self.refine_half_width_deg,
                0.0,
                90.0,
            )
            .done()
    }
}

/// A histogram of undirected directions and the main directions found in it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MainDirections {
    /// The main directions, radians in `[0, π)`, strongest first.
    pub directions_rad: Vec<f64>,
    /// The smoothed histogram: metres of segment length per bin (bin `i` covers
    /// `[i, i+1) · 180°/bins`).
    pub histogram_m: Vec<f64>,
}

/// The main directions for scan `t`: those of `G_{t-1}(tm)`, the map's segments born in the
/// last `params.time_memory_scans` scans (the paper's `tm`).
pub fn recent_main_directions(
    map: &mut GlobalMap,
    t: u32,
    params: &DirectionParams,
) -> MainDirections {
    let recent = map.born_since(t.saturating_sub(params.time_memory_scans));
    main_directions(recent.iter(), params)
}

/// Computes the main directions of a set of segments (already restricted to `G_{t-1}(tm)`).
///
/// ```
/// use polymap::directions::{main_directions, DirectionParams};
/// use polymap::geometry::{Segment, Vec2};
/// let walls = [
///     Segment::new(Vec2::new(0.0, 0.0), Vec2::new(5.0, 0.02)),
///     Segment::new(Vec2::new(0.0, 2.0), Vec2::new(5.0, 1.98)),
///     Segment::new(Vec2::new(0.0, 0.0), Vec2::new(0.0, 2.0)),
/// ];
/// let md = main_directions(walls.iter(), &DirectionParams::default());
/// assert_eq!(md.directions_rad.len(), 2);
/// assert!(md.directions_rad[0].min(std::f64::consts::PI - md.directions_rad[0]) < 0.01);
/// assert!((md.directions_rad[1] - std::f64::consts::FRAC_PI_2).abs() < 0.01);
/// ```
pub fn main_directions<'a>(
    segments: impl Iterator<Item = &'a Segment> + Clone,
    params: &DirectionParams,
) -> MainDirections {
    let bins = params.bins.max(1);
    let bin_width = PI / bins as f64;
    let mut raw = vec![0.0; bins];
    for s in segments.clone() {
        raw[bin_of(s.direction_rad(), bin_width, bins)] += s.length();
    }
    let histogram_m = smooth_cyclic(&raw, params.window_bins);
    let peaks = significant_peaks(&histogram_m, params);
    let directions_rad = peaks
        .into_iter()
        .map(|b| {
            refine_peak(
                (b as f64 + 0.5) * bin_width,
                segments.clone(),
                params
                    .refine_half_width_deg
                    .to_radians()
                    .max(bin_width / 2.0),
            )
        })
        .collect();
    MainDirections {
        directions_rad,
        histogram_m,
    }
}

fn bin_of(direction_rad: f64, bin_width: f64, bins: usize) -> usize {
    ((undirected_angle_rad(direction_rad) / bin_width) as usize).min(bins - 1)
}

/// Cyclic box filter: the sum over a window of `window` bins centred on each bin.
fn smooth_cyclic(raw: &[f64], window: usize) -> Vec<f64> {
    let n = raw.len() as isize;
    let half = (window.max(1) / 2) as isize;
    let odd_extra = if window.max(1).is_multiple_of(2) {
        1
    } else {
        0
    };
    (0..n)
        .map(|i| {
            (i - half + odd_extra..=i + half)
                .map(|j| raw[j.rem_euclid(n) as usize])
                .sum()
        })
        .collect()
}

/// Bins of significant peaks, strongest first.
fn significant_peaks(h: &[f64], params: &DirectionParams) -> Vec<usize> {
    let n = h.len();
    let top = h.iter().copied().fold(0.0, f64::max);
    let floor = (params.min_peak_fraction * top).max(params.min_peak_length_m);
    if top <= 0.0 || top < floor {
        return Vec::new();
    }
    // A plateau counts once: strictly above the left neighbour, not below the right one.
    let mut peaks: Vec<usize> = (0..n)
        .filter(|&i| h[i] >= floor && h[i] > h[(i + n - 1) % n] && h[i] >= h[(i + 1) % n])
        .collect();
    // A flat top (one segment smoothed over the window) is found at its left edge; take its
    // middle, so the refinement window is centred on it.
    for p in peaks.iter_mut() {
        let width = (1..n).take_while(|k| h[(*p + k) % n] == h[*p]).count();
        *p = (*p + width / 2) % n;
    }
    peaks.sort_by(|&a, &b| h[b].total_cmp(&h[a]).then(a.cmp(&b)));
    let bin_width = PI / n as f64;
    let min_sep = params.min_separation_deg.to_radians();
    let mut kept: Vec<usize> = Vec::new();
    for p in peaks {
        let far = kept.iter().all(|&k| {
            angle_between_directions_rad(p as f64 * bin_width, k as f64 * bin_width) > min_sep
        });
        if far {
            kept.push(p);
        }
    }
    kept
}

/// Length-weighted circular mean (on doubled angles) of the directions near `centre_rad`.
fn refine_peak<'a>(
    centre_rad: f64,
    segments: impl Iterator<Item = &'a Segment>,
    half_width_rad: f64,
) -> f64 {
    let (mut c, mut s) = (0.0, 0.0);
    for seg in segments {
        let a = seg.direction_rad();
        if angle_between_directions_rad(a, centre_rad) <= half_width_rad {
            let w = seg.length();
            c += w * (2.0 * a).cos();
            s += w * (2.0 * a).sin();
        }
    }
    if c == 0.0 && s == 0.0 {
        undirected_angle_rad(centre_rad)
    } else {
        undirected_angle_rad(0.5 * s.atan2(c))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Vec2;

    fn at(deg: f64, len: f64) -> Segment {
        let a = deg.to_radians();
        Segment::new(Vec2::ZERO, Vec2::new(a.cos(), a.sin()) * len)
    }

    #[test]
    fn histogram_is_cyclic() {
        // Directions 179.5° and 0.5° are one degree apart and form one peak.
        let segs = [at(179.5, 3.0), at(0.5, 3.0)];
        let md = main_directions(segs.iter(), &DirectionParams::default());
        assert_eq!(md.directions_rad.len(), 1);
        let d = md.directions_rad[0];
        assert!(
            angle_between_directions_rad(d, 0.0) < 1e-9,
            "{}",
            d.to_degrees()
        );
        // The window of 5 around bin 1 holds bins 179, 0, 1, 2, 3; around bin 177 only 179.
        assert!(
            (md.histogram_m[1] - 6.0).abs() < 1e-12 && (md.histogram_m[177] - 3.0).abs() < 1e-12
        );
    }

    #[test]
    fn peaks_are_refined_below_a_degree() {
        let segs = [at(60.3, 4.0), at(60.5, 4.0), at(60.1, 2.0)];
        let md = main_directions(segs.iter(), &DirectionParams::default());
        let expect = (60.3f64 * 4.0 + 60.5 * 4.0 + 60.1 * 2.0) / 10.0;
        assert!((md.directions_rad[0].to_degrees() - expect).abs() < 0.01);
    }

    #[test]
    fn weak_and_near_peaks_are_suppressed() {
        let params = DirectionParams::default();
        // 0.5 m at 45° is below min_peak_length_m; 8° from the main wall is within separation.
        let segs = [at(0.0, 10.0), at(90.0, 5.0), at(45.0, 0.5), at(8.0, 4.0)];
        let md = main_directions(segs.iter(), &params);
        let degs: Vec<f64> = md.directions_rad.iter().map(|d| d.to_degrees()).collect();
        assert_eq!(degs.len(), 2, "{degs:?}");
        assert!((degs[1] - 90.0).abs() < 0.5);
    }

    /// A flat-topped peak is taken at its middle: taken at its left edge, with a 9-bin window a
    /// wall at 30.5° comes out at 26.5°.
    #[test]
    fn wide_windows_still_find_the_wall() {
        let params = DirectionParams {
            window_bins: 9,
            ..DirectionParams::default()
        };
        let md = main_directions([at(30.5, 3.0)].iter(), &params);
        assert!(
            (md.directions_rad[0].to_degrees() - 30.5).abs() < 1e-6,
            "{:?}",
            md.directions_rad
        );
    }

    #[test]
    fn empty_input_has_no_directions() {
        let md = main_directions([].iter(), &DirectionParams::default());
        assert!(md.directions_rad.is_empty());
        assert_eq!(md.histogram_m.len(), 180);
    }
}
