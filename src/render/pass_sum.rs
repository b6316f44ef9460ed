//! The sum of progressive passes: per pixel, the sum of the passes' radiance, of its square
//! (for the noise estimate, [`crate::render::noise`]), and whether the caustic estimate reached
//! the pixel in any pass.
//!
//! Sums of passes must not depend on how the passes were grouped: a range of passes rendered
//! alone and merged with the rest must give the image of one run bit for bit. Floating-point
//! addition is not associative, so radiance is summed in fixed point: an `i128` count of
//! 2^-80, exact for every `f64` from 2^-28 (4e-9) up to the 2^32 (4e9) allowed per pass, and
//! within 2^-81 below (2^15 passes of the largest values still fit). Integer addition is
//! associative, so any grouping of the same passes gives the same sums. A one-pass image is
//! therefore the pass's image exactly wherever it is 0 or at least 4e-9, and within 2^-20 of
//! it down to 2^-60 (9e-19). A value outside that range (non-finite, above 4e9, or not 0 but
//! below 9e-19) makes its pixel fall back to the plain floating-point sum, which is kept beside
//! it. (Below 9e-19 the fixed point kept too few bits: a light of 1e-22 W/sr lit the canonical
//! scene in three grey levels, at 1e-24 not at all.)

use crate::render::film::Film;
use crate::render::image::RenderedImage;
use glam::DVec3;

/// Fixed-point units per unit of radiance.
const SCALE: f64 = (1u128 << 80) as f64;
/// Largest magnitude a pass may add to the fixed-point sum (2^32).
const LIMIT: f64 = (1u64 << 32) as f64;
/// Smallest magnitude other than 0 a pass may add to the fixed-point sum (2^-60: 20 bits).
const LEAST: f64 = 1.0 / (1u64 << 60) as f64;

/// The accumulated passes of a progressive render.
#[derive(Debug, Clone, PartialEq)]
pub struct PassSum {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Passes summed.
    pub passes: u64,
    /// Per pixel and channel, the sum in units of 2^-80.
    pub(crate) fixed: Vec<[i128; 3]>,
    /// Per pixel, the floating-point sum (used where `exact` is false).
    pub(crate) float: Vec<DVec3>,
    /// Per pixel, the sum of squares (floating point: a statistic, not the image).
    pub squares: Vec<DVec3>,
    /// Per pixel, whether every value summed fitted the fixed point.
    pub(crate) exact: Vec<bool>,
    /// Per pixel, whether the caustic estimate was non-zero in any pass.
    pub reach: Vec<bool>,
    /// Per pixel, whether a camera ray saw a light in any pass.
    pub lights: Vec<bool>,
}

impl PassSum {
    /// No passes yet.
    pub fn new(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        PassSum {
            width,
            height,
            passes: 0,
            fixed: vec![[0; 3]; n],
            float: vec![DVec3::ZERO; n],
            squares: vec![DVec3::ZERO; n],
            exact: vec![true; n],
            reach: vec![false; n],
            lights: vec![false; n],
        }
    }

    /// Adds one pass.
    pub fn add(&mut self, pass: &RenderedImage) {
        assert_eq!(
            pass.film.pixels.len(),
            self.fixed.len(),
            "pass of another size"
        );
        for (i, &p) in pass.film.pixels.iter().enumerate() {
            let c = p.to_array();
            if c.iter()
                .all(|v| v.is_finite() && v.abs() <= LIMIT && (*v == 0.0 || v.abs() >= LEAST))
            {
                for (f, v) in self.fixed[i].iter_mut().zip(c) {
                    *f += (v * SCALE).round() as i128;
                }
            } else {
                self.exact[i] = false;
            }
            self.float[i] += p;
            self.squares[i] += p * p;
            self.reach[i] |= pass.reach[i];
            self.lights[i] |= pass.lights[i];
        }
        self.passes += 1;
    }

    /// Adds the passes summed in `other` (disjoint from this sum's passes, same image size).
    /// The image of the merged sum is the same whatever the grouping.
    pub fn merge(&mut self, other: &PassSum) {
        assert_eq!(
            (self.width, self.height),
            (other.width, other.height),
            "sums of another size"
        );
        for i in 0..self.fixed.len() {
            for c in 0..3 {
                self.fixed[i][c] += other.fixed[i][c];
            }
            self.float[i] += other.float[i];
            self.squares[i] += other.squares[i];
            self.exact[i] &= other.exact[i];
            self.reach[i] |= other.reach[i];
            self.lights[i] |= other.lights[i];
        }
        self.passes += other.passes;
    }

    /// The sum of pixel `i`'s passes.
    pub fn sum(&self, i: usize) -> DVec3 {
        if self.exact[i] {
            let [r, g, b] = self.fixed[i];
            DVec3::new(r as f64, g as f64, b as f64) / SCALE
        } else {
            self.float[i]
        }
    }

    /// The image: the mean of the passes (black without passes).
    pub fn mean(&self) -> Film {
        let mut film = Film::new(self.width, self.height);
        let n = self.passes.max(1) as f64;
        for (i, p) in film.pixels.iter_mut().enumerate() {
            *p = self.sum(i) / n;
        }
        film
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pass(values: &[f64]) -> RenderedImage {
        let mut film = Film::new(values.len() as u32, 1);
        for (p, &v) in film.pixels.iter_mut().zip(values) {
            *p = DVec3::new(v, 0.1 * v, 3.0 * v);
        }
        RenderedImage {
            reach: values.iter().map(|&v| v > 1.0).collect(),
            lights: values.iter().map(|&v| v > 2.0).collect(),
            film,
        }
    }

    #[test]
    fn one_pass_is_kept_exactly_and_grouping_does_not_change_the_sum() {
        let passes: Vec<RenderedImage> = (0..7)
            .map(|k| {
                let k = k as f64;
                pass(&[
                    0.1 + k * 1e-3,
                    1.0 / (3.0 + k),
                    7.3e5 * (1.0 + k),
                    1e-3 / 7.0,
                    0.0,
                ])
            })
            .collect();
        let mut one = PassSum::new(5, 1);
        one.add(&passes[0]);
        assert_eq!(one.mean(), passes[0].film);
        let mut all = PassSum::new(5, 1);
        for p in &passes {
            all.add(p);
        }
        for split in 1..passes.len() {
            let (mut a, mut b) = (PassSum::new(5, 1), PassSum::new(5, 1));
            passes[..split].iter().for_each(|p| a.add(p));
            passes[split..].iter().for_each(|p| b.add(p));
            b.merge(&a);
            assert_eq!(b.mean(), all.mean(), "split at {split}");
            assert_eq!((b.passes, &b.reach), (7, &all.reach));
        }
        // The fixed point is the exact sum: compare with a sum far from rounding trouble.
        let exact: f64 = (0..7).map(|k| 7.3e5 * (1.0 + k as f64)).sum();
        assert_eq!(all.sum(2).x, exact);
    }

    #[test]
    fn values_beyond_the_fixed_point_fall_back_to_floating_point() {
        let mut s = PassSum::new(5, 1);
        s.add(&pass(&[1e13, f64::NAN, 1.0, 1.0, 1.0]));
        s.add(&pass(&[1e13, 1.0, 1.0, 1.0, 1.0]));
        let m = s.mean();
        assert_eq!(m.pixels[0].x, 1e13);
        assert!(m.pixels[1].x.is_nan());
        assert_eq!(m.pixels[2].x, 1.0);
        // A dim scene's values: below 2^-60 in floating point, exactly; from there the fixed
        // point within 2^-20 (1e-22 read 8.3e-25 steps: 0, 8.3e-25, 1.65e-24).
        let mut s = PassSum::new(5, 1);
        let tiny = [1e-22, 3.7e-30, 2f64.powi(-60), 1e-300, 0.0];
        s.add(&pass(&tiny));
        let m = s.mean();
        for (p, v) in m.pixels.iter().zip(tiny) {
            assert!((p.x - v).abs() <= v * 2f64.powi(-20), "{} for {v}", p.x);
        }
        assert_eq!((m.pixels[0].x, m.pixels[3].x), (1e-22, 1e-300));
    }
}
