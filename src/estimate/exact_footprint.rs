//! A view footprint's exact quadrilateral, prepared once per gather for the estimators that
//! integrate over the view footprint (`integrated`).
//!
//! Why a weight over it: a pixel's value is the mean radiance over the pixel's square *on the
//! image*, and a perspective view does not map that square onto the surface with a constant
//! Jacobian. Seen through a pinhole, a plane's area element maps to image area in proportion to
//! `depth^-3` (`dA_image = |h| dA / depth^3`, `h` the eye's distance from the plane, `depth`
//! along the viewing axis), so the near side of a pixel's quadrilateral stands for more image
//! area per square metre than its far side; across one pixel the ratio varies by 0.5-2% on the
//! canonical 640 x 480 view's floor and 2-7% at the stress scenes' 160 x 120. Averaging over
//! surface area instead puts light that lies off the pixel's centre into it with the wrong
//! weight: invisible in smooth light, but a focus a fraction of a pixel from a pixel boundary
//! (`scenes/stress/focal-caustic.toml`) came out 1.2% too bright in the row beside it, against
//! the light tracer (which splats each path with that very Jacobian) and against the photons
//! themselves binned the same way.

use crate::geometry::disc_integral::general_lanes::Placements;
use crate::geometry::disc_integral::quad_frame::{FrameNumbers, QuadFrame};
use crate::geometry::disc_integral::rows::{Wide, LANES};
use crate::geometry::lanes::splat3;
use crate::geometry::lanes::Lane;
use glam::{DVec2, DVec3};

mod prepare;
pub use prepare::FootprintRequest;
use prepare::{Basis, Weights};

/// The exact view footprint of a gather: the quadrilateral of the pixel's (or cell's) corner
/// rays on the hit's tangent plane, in the coordinates of the first-order parallelogram
/// `x +- f[0]/2 +- f[1]/2` (corners near `(+-1/2, +-1/2)`), with the growth of that
/// parallelogram that holds it (for the photon map's range query), and the weight of image
/// area per surface area over it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExactFootprint {
    /// The quadrilateral in the basis `(f[0], f[1])`, about the query point.
    pub frame: QuadFrame,
    /// The least `g >= 1` (rounded up) such that `x +- g f[0]/2 +- g f[1]/2` holds it.
    pub grow: f64,
    /// The weight `w[0] + w[1] alpha + w[2] beta` of image area per surface area at the point
    /// `x + alpha f[0] + beta f[1]`, scaled so that its mean over the quadrilateral is 1
    /// (`[1, 0, 0]`, uniform, unless [`ExactFootprint::seen_from`] set it).
    pub weight: [f64; 3],
    /// [`ExactFootprint::weighted_inside`] prepared: the weight at the frame's centre, and the
    /// weight's gradient against each of the frame's centred moments (`QuadFrame::
    /// kernel_centroid`'s sums, combined over `alpha` and `beta` once per gather).
    inside: [f64; 7],
}

impl ExactFootprint {
    /// The footprint with `corners` (in order around it, in the plane of `footprint`) for the
    /// query point `x`, weighted uniformly over surface area, or `None` for a degenerate
    /// parallelogram, or a quadrilateral that is not convex or reaches past twice the
    /// parallelogram (a perspective quadrilateral differs from the first-order parallelogram
    /// to second order). [`ExactFootprint::prepare_many`] prepares many at once.
    pub fn new(corners: &[DVec3; 4], x: DVec3, footprint: &[DVec3; 2]) -> Option<Self> {
        let basis = Basis::of(
            corners.map(|c| c.to_array()),
            x.to_array(),
            footprint.map(|f| f.to_array()),
        );
        let grow = basis.grow()?;
        let numbers = FrameNumbers::of(basis.alpha, basis.beta);
        let frame = QuadFrame::from_numbers(basis.alpha, basis.beta, &numbers)?;
        Some(ExactFootprint::uniform(frame, grow))
    }

    /// Weighted uniformly over surface area.
    fn uniform(frame: QuadFrame, grow: f64) -> Self {
        ExactFootprint {
            frame,
            grow,
            weight: [1.0, 0.0, 0.0],
            inside: [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        }
    }

    /// The same footprint seen through a pinhole at `eye` looking along unit `forward`, from
    /// the query point `x` with the footprint's edges `footprint`: weighted by image area per
    /// surface area, `depth^-3` to first order about `x` (`1 - 3 forward . (y - x) / depth(x)`;
    /// the second-order term is ~1e-5 of a pixel's weight at a pixel's size). Unchanged where
    /// the depth is not positive and finite.
    pub fn seen_from(self, eye: DVec3, forward: DVec3, x: DVec3, footprint: &[DVec3; 2]) -> Self {
        let frame = &self.frame;
        let weights = Weights::of(
            splat3(eye),
            splat3(forward),
            x.to_array(),
            footprint.map(|f| f.to_array()),
            frame.centroid().to_array(),
            frame.centre().to_array(),
            frame.centred_moments(),
        );
        self.weighted(&weights)
    }

    /// With `weights` where they hold (a positive, finite depth and mean).
    fn weighted(mut self, weights: &Weights<f64>) -> Self {
        if weights.depth > 0.0 && weights.mean > 0.0 && weights.mean.is_finite() {
            self.weight = weights.weight;
            self.inside = weights.inside;
        }
        self
    }

    /// The weight as a function of a photon's filter space, where the footprint is
    /// `s + alpha a + beta b`: `k[0] + k[1] u_x + k[2] u_y` (`a`, `b` independent). `k[0]` is
    /// the weight at the photon's centre (`u = 0`).
    #[inline]
    pub fn weight_in_filter_space(&self, s: DVec2, a: DVec2, b: DVec2) -> [f64; 3] {
        weight_in_filter_space(self.weight, s.to_array(), a.to_array(), b.to_array())
    }

    /// [`ExactFootprint::weight_in_filter_space`] for each lane of `p`: `k[0]`, `k[1]`, `k[2]`
    /// as columns.
    #[inline]
    pub fn weights_in_filter_space(&self, p: &Placements) -> [[f64; LANES]; 3] {
        weight_in_filter_space(self.weight, p.s, p.a, p.b).map(Wide::to_array)
    }

    /// `mean` weighted at the kernel's centroid over the quadrilateral `s + alpha a + beta b`
    /// when it lies inside the disc and `mean` is the kernel's mean over it: `mean` times the
    /// weight at `QuadFrame::kernel_centroid`, a few multiplications a photon. (The weight at
    /// the centroid is `base + sum / mean`, the first moment over the mean; times the mean,
    /// no division is left.) Where `mean <= 0` (no contribution), `mean` times the weight at
    /// the centre.
    #[inline]
    pub fn weighted_inside(&self, s: DVec2, a: DVec2, b: DVec2, mean: f64) -> f64 {
        let [base, k1, ka, kb, kaa, kab, kbb] = self.inside;
        if mean <= 0.0 {
            return mean * base;
        }
        let centre = self.frame.centre();
        let c = s + a * centre.x + b * centre.y;
        let sum = (1.0 - c.length_squared()) * k1
            - 2.0 * c.dot(a) * ka
            - 2.0 * c.dot(b) * kb
            - a.length_squared() * kaa
            - 2.0 * a.dot(b) * kab
            - b.length_squared() * kbb;
        mean * base + sum
    }

    /// The weight at `(alpha, beta)`: what a photon whose kernel's mass in the footprint has
    /// its centroid there contributes, relative to one spread evenly over it (exact for a
    /// weight linear over the footprint).
    #[inline]
    pub fn weight_at(&self, at: DVec2) -> f64 {
        self.weight[0] + self.weight[1] * at.x + self.weight[2] * at.y
    }
}

/// The weight `w[0] + w[1] alpha + w[2] beta` where the footprint is `s + alpha a + beta b`, as
/// `k[0] + k[1] u_x + k[2] u_y` (for one lane or many).
#[inline(always)]
fn weight_in_filter_space<T: Lane>(w: [f64; 3], s: [T; 2], a: [T; 2], b: [T; 2]) -> [T; 3] {
    // (alpha, beta) = [a b]^-1 (u - s).
    let inv_det = T::splat(1.0) / (a[0] * b[1] - a[1] * b[0]);
    let [w0, wa, wb] = w.map(T::splat);
    let kx = (wa * b[1] - wb * a[1]) * inv_det;
    let ky = (wb * a[0] - wa * b[0]) * inv_det;
    [w0 - kx * s[0] - ky * s[1], kx, ky]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_weight_inside_is_the_weight_at_the_kernels_centroid() {
        // A pixel's quadrilateral on a floor seen obliquely, and photons far larger than it.
        let corners = [
            DVec3::new(-0.5, 0.0, -0.45),
            DVec3::new(0.5, 0.0, -0.45),
            DVec3::new(0.55, 0.0, 0.55),
            DVec3::new(-0.55, 0.0, 0.55),
        ]
        .map(|c| c * 0.02);
        let f = [DVec3::X * 0.02, DVec3::Z * 0.02];
        let x = DVec3::new(0.0, 0.0, 0.001);
        let e = ExactFootprint::new(&corners, x, &f).unwrap().seen_from(
            DVec3::new(0.0, 2.0, 3.0),
            DVec3::new(0.0, -2.0, -3.0).normalize(),
            x,
            &f,
        );
        assert!(e.weight[2].abs() > 1e-3, "{:?}", e.weight);
        for k in 0..10 {
            let t = k as f64 * 0.7;
            let (s, a, b) = (
                DVec2::new(0.4 * t.cos(), 0.3 * t.sin()),
                DVec2::new(0.2, 0.03 * t.sin()),
                DVec2::new(-0.02, 0.25),
            );
            let crate::geometry::disc_integral::quad::QuadOverlap::Mean(mean) =
                e.frame.classify(s, a, b)
            else {
                panic!("{k}: not inside");
            };
            let expected = e.weight_at(e.frame.kernel_centroid(s, a, b, mean));
            let got = e.weighted_inside(s, a, b, mean) / mean;
            assert!((got - expected).abs() <= 1e-12, "{k}: {got} vs {expected}");
            assert!((got - 1.0).abs() > 1e-5, "{k}: {got}");
        }
    }
}
