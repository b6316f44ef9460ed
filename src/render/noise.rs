//! The noise of a progressive render's running mean, estimated from its passes.
//!
//! Passes are independent (fresh photons, their own seeds), so per pixel and channel the sample
//! variance across the `K` passes, `s^2 = (sum x^2 - K m^2) / (K - 1)`, divided by `K` estimates
//! the variance of the mean `m`. Over a region the relative standard error is
//! `sqrt(mean over pixels and channels of s^2 / K) / mean over pixels and channels of m`: the
//! relRMSE (as `reference::metrics` defines it) that the noise alone gives against the image's
//! expected value. Two caveats: footprints shrink from pass to pass, so later passes are noisier
//! and their means drift by the (vanishing) bias; the estimate averages over both. And the
//! camera jitter follows one low-discrepancy sequence (not random), so at edges the spread
//! between passes overstates the error of their mean.
//!
//! Pixels where a camera ray saw a light are left out of both regions: a light is usually many
//! times brighter than what it lights, and its outline, lit in one pass and not in the next as
//! the jitter moves, swamped the estimate (8 such pixels of a quad light read 264% over a floor
//! whose error against its reference was 8.1%, so `--target-noise` could never stop). The
//! light's own pixels are exact but for that anti-aliasing; the estimate is of what the photons
//! and the direct light leave.

use crate::render::pass_sum::PassSum;
use serde::Serialize;

/// The noise estimate of the regions a render reports.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct NoiseEstimate {
    /// Relative standard error of the mean over the whole image but the pixels that see a
    /// light (`None` before two passes or for a black image).
    pub whole: Option<f64>,
    /// The same over the caustic map's reach: pixels where the caustic estimate was non-zero
    /// (and no light is seen).
    pub caustic: Option<f64>,
    /// Pixels in the caustic map's reach (and no light seen).
    pub caustic_pixels: usize,
}

impl NoiseEstimate {
    /// The estimate for `sum`.
    pub fn of(sum: &PassSum) -> Self {
        let unlit: Vec<usize> = (0..sum.reach.len()).filter(|&i| !sum.lights[i]).collect();
        let reach: Vec<usize> = unlit.iter().copied().filter(|&i| sum.reach[i]).collect();
        NoiseEstimate {
            whole: relative_standard_error(sum, unlit.iter().copied()),
            caustic: relative_standard_error(sum, reach.iter().copied()),
            caustic_pixels: reach.len(),
        }
    }

    /// The larger of the regions' estimates: what `--target-noise` compares.
    pub fn worst(&self) -> Option<f64> {
        match (self.whole, self.caustic) {
            (Some(a), Some(b)) => Some(a.max(b)),
            (a, b) => a.or(b),
        }
    }

    /// Its EXR attributes (`photondiff/noise_whole`, `.._caustic`, `.._caustic_pixels`): a
    /// render's, and a merge's of pass ranges.
    pub fn attributes(&self) -> Vec<(String, String)> {
        let opt = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{v:.6}"));
        [
            ("noise_whole", opt(self.whole)),
            ("noise_caustic", opt(self.caustic)),
            ("noise_caustic_pixels", self.caustic_pixels.to_string()),
        ]
        .into_iter()
        .map(|(name, value)| (format!("photondiff/{name}"), value))
        .collect()
    }

    /// E.g. "1.23% (caustic 3.40%)", or "n/a" before two passes.
    pub fn describe(&self) -> String {
        let pct = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{:.2}%", 100.0 * v));
        format!("{} (caustic {})", pct(self.whole), pct(self.caustic))
    }
}

/// The relative standard error of `sum`'s mean over `pixels` (see the module's doc).
pub fn relative_standard_error(sum: &PassSum, pixels: impl Iterator<Item = usize>) -> Option<f64> {
    let k = sum.passes as f64;
    if sum.passes < 2 {
        return None;
    }
    let (mut variance, mut mean, mut n) = (0.0, 0.0, 0usize);
    for i in pixels {
        let m = sum.sum(i) / k;
        let s2 = ((sum.squares[i] - m * m * k) / (k - 1.0)).max(glam::DVec3::ZERO);
        variance += (s2.x + s2.y + s2.z) / k;
        mean += m.x + m.y + m.z;
        n += 3;
    }
    (n > 0 && mean > 0.0).then(|| (variance / n as f64).sqrt() / (mean / n as f64))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::film::Film;
    use crate::render::image::RenderedImage;
    use crate::util::rng::Rng;
    use glam::DVec3;

    #[test]
    fn estimates_the_standard_error_of_a_mean_of_uniform_noise() {
        // Pixels of mean 1 with uniform noise of variance w^2 / 12: after K passes the relative
        // standard error of the mean is w / sqrt(12 K).
        let (w, k) = (0.5, 16);
        let mut rng = Rng::new(3, 0);
        let mut sum = PassSum::new(64, 64);
        for _ in 0..k {
            let mut film = Film::new(64, 64);
            for p in &mut film.pixels {
                *p = DVec3::splat(1.0 + w * (rng.uniform() - 0.5));
            }
            let reach = (0..film.pixels.len()).map(|i| i < 100).collect();
            let lights = vec![false; film.pixels.len()];
            sum.add(&RenderedImage {
                film,
                reach,
                lights,
            });
        }
        let e = NoiseEstimate::of(&sum);
        let expected = w / (12.0 * k as f64).sqrt();
        let whole = e.whole.unwrap();
        assert!(
            (whole / expected - 1.0).abs() < 0.02,
            "{whole} vs {expected}"
        );
        assert_eq!(e.caustic_pixels, 100);
        assert!((e.caustic.unwrap() / expected - 1.0).abs() < 0.15);
        assert_eq!(e.worst(), Some(whole.max(e.caustic.unwrap())));
        let mut one = PassSum::new(1, 1);
        one.add(&RenderedImage {
            film: Film::new(1, 1),
            reach: vec![false],
            lights: vec![false],
        });
        assert_eq!(NoiseEstimate::of(&one).worst(), None);
    }

    /// A light's outline, 0 in one pass and 60 in the next, is left out: the estimate is the
    /// one of the image without it; counted, it would be many times that.
    #[test]
    fn pixels_that_see_a_light_are_left_out() {
        let estimate = |lights: bool| {
            let mut sum = PassSum::new(32, 32);
            let mut rng = Rng::new(5, 0);
            for k in 0..8 {
                let mut film = Film::new(32, 32);
                for p in &mut film.pixels {
                    *p = DVec3::splat(1.0 + 0.2 * (rng.uniform() - 0.5));
                }
                // Eight pixels on the outline of a light of radiance 60.
                for i in 0..8 {
                    film.pixels[i] = DVec3::splat(if (k + i) % 2 == 0 { 60.0 } else { 0.0 });
                }
                let n = film.pixels.len();
                sum.add(&RenderedImage {
                    film,
                    reach: vec![true; n],
                    lights: (0..n).map(|i| lights && i < 8).collect(),
                });
            }
            NoiseEstimate::of(&sum)
        };
        let (left_out, counted) = (estimate(true), estimate(false));
        let expected = 0.2 / (12.0f64 * 8.0).sqrt();
        for e in [left_out.whole.unwrap(), left_out.caustic.unwrap()] {
            assert!((e / expected - 1.0).abs() < 0.1, "{e} vs {expected}");
        }
        assert_eq!(left_out.caustic_pixels, 32 * 32 - 8);
        assert!(counted.whole.unwrap() > 10.0 * expected, "{counted:?}");
    }
}
