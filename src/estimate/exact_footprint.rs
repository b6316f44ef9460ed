//! A view footprint's exact quadrilateral, prepared once per gather for the estimators that
//! integrate over the view footprint (`integrated`).

use crate::geometry::disc_integral::quad::QuadFrame;
use glam::{DVec2, DVec3};

/// The exact view footprint of a gather: the quadrilateral of the pixel's (or cell's) corner
/// rays on the hit's tangent plane, in the coordinates of the first-order parallelogram
/// `x +- f[0]/2 +- f[1]/2` (corners near `(+-1/2, +-1/2)`), with the growth of that
/// parallelogram that holds it (for the photon map's range query).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExactFootprint {
    /// The quadrilateral in the basis `(f[0], f[1])`, about the query point.
    pub frame: QuadFrame,
    /// The least `g >= 1` (rounded up) such that `x +- g f[0]/2 +- g f[1]/2` holds it.
    pub grow: f64,
}

impl ExactFootprint {
    /// The footprint with `corners` (in order around it, in the plane of `footprint`) for the
    /// query point `x`, or `None` for a degenerate parallelogram, or a quadrilateral that is
    /// not convex or reaches past twice the parallelogram (a perspective quadrilateral differs
    /// from the first-order parallelogram to second order).
    pub fn new(corners: &[DVec3; 4], x: DVec3, footprint: &[DVec3; 2]) -> Option<Self> {
        let f = footprint;
        // Coordinates in the basis (f0, f1) from the Gram system.
        let (g00, g01, g11) = (f[0].dot(f[0]), f[0].dot(f[1]), f[1].dot(f[1]));
        let det = g00 * g11 - g01 * g01;
        if det.is_nan() || det <= 1e-12 * g00 * g11 || !det.is_finite() {
            return None;
        }
        let coordinates = corners.map(|c| {
            let w = c - x;
            let (b0, b1) = (w.dot(f[0]), w.dot(f[1]));
            DVec2::new((g11 * b0 - g01 * b1) / det, (g00 * b1 - g01 * b0) / det)
        });
        let grow = coordinates
            .iter()
            .fold(1.0f64, |g, c| g.max(2.0 * c.x.abs().max(c.y.abs())));
        // A little over, for rounding.
        let grow = grow * (1.0 + 1e-4);
        if grow.is_nan() || grow >= 4.0 {
            return None;
        }
        Some(ExactFootprint {
            frame: QuadFrame::new(coordinates)?,
            grow,
        })
    }
}
