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

use crate::render::pass_sum::PassSum;
use serde::Serialize;

/// The noise estimate of the regions a render reports.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct NoiseEstimate {
    /// Relative standard error of the mean over the whole image (`None` before two passes or
    /// for a black image).
    pub whole: Option<f64>,
    /// The same over the caustic map's reach: pixels where the caustic estimate was non-zero.
    pub caustic: Option<f64>,
    /// Pixels in the caustic map's reach.
    pub caustic_pixels: usize,
}

impl NoiseEstimate {
    /// The estimate for `sum`.
    pub fn of(sum: &PassSum) -> Self {
        let all = 0..sum.reach.len();
        let reach: Vec<usize> = all.clone().filter(|&i| sum.reach[i]).collect();
        NoiseEstimate {
            whole: relative_standard_error(sum, all),
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
            sum.add(&RenderedImage { film, reach });
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
        });
        assert_eq!(NoiseEstimate::of(&one).worst(), None);
    }
}
