//! Total least squares line fit.

use crate::geometry::Vec2;

/// A line fitted to points by total least squares (orthogonal regression).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineFit {
    /// Centroid of the points; the line passes through it.
    pub centroid: Vec2,
    /// Unit direction of the line.
    pub direction: Vec2,
    /// RMS orthogonal distance of the points from the line, metres.
    pub rms_m: f64,
}

impl LineFit {
    /// Orthogonal projection of `p` onto the line.
    pub fn project(&self, p: Vec2) -> Vec2 {
        self.centroid + self.direction * (p - self.centroid).dot(self.direction)
    }
}

/// Fits a line minimising the sum of squared orthogonal distances; `None` for fewer than two
/// distinct points.
///
/// ```
/// use polymap::extract::fit_line;
/// use polymap::geometry::Vec2;
/// let fit = fit_line(&[Vec2::new(0.0, 1.0), Vec2::new(1.0, 2.0), Vec2::new(2.0, 3.0)]).unwrap();
/// assert!(fit.rms_m < 1e-12);
/// assert!((fit.direction.y / fit.direction.x - 1.0).abs() < 1e-12);
/// ```
pub fn fit_line(points: &[Vec2]) -> Option<LineFit> {
    if points.len() < 2 {
        return None;
    }
    let n = points.len() as f64;
    let centroid = points.iter().copied().sum::<Vec2>() / n;
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for p in points {
        let d = *p - centroid;
        sxx += d.x * d.x;
        sxy += d.x * d.y;
        syy += d.y * d.y;
    }
    if sxx + syy <= 0.0 {
        return None;
    }
    // Principal axis of the 2x2 scatter matrix.
    let angle = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let direction = Vec2::new(angle.cos(), angle.sin());
    let normal = direction.perp();
    let ss: f64 = points
        .iter()
        .map(|p| (*p - centroid).dot(normal).powi(2))
        .sum();
    Some(LineFit {
        centroid,
        direction,
        rms_m: (ss / n).sqrt(),
    })
}
