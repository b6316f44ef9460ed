//! The comparison every accuracy figure rests on: an image against a reference over a region.
//!
//! Over the region's pixels and the measured channels (all but alpha):
//! - `relRMSE = sqrt(mean((I - R)^2)) / mean(R)` (undefined when `mean(R)` is 0);
//! - `RMSE = sqrt(mean((I - R)^2))`;
//! - `PSNR = 10 log10(peak^2 / mean((I - R)^2))` dB with `peak` the reference's largest value in
//!   the region (HDR images have no fixed white; infinite for identical images, reported as
//!   undefined);
//! - mean ratio `mean(I) / mean(R)` (image energy against the reference's);
//! - SSIM on sRGB luminance ([`metrics::mean_ssim`]): the 8 x 8 windows (stride 4) holding at
//!   least one pixel of the region, so the whole image gives [`metrics::ssim`]'s value.

use super::channels::ChannelImage;
use super::metrics::{self, srgb_luminance};
use serde::Serialize;
use std::path::Path;

/// The figures of one region.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RegionMetrics {
    /// The region's name (`image`, or a mask's file stem).
    pub name: String,
    /// Pixels in the region.
    pub pixels: usize,
    /// `sqrt(mean((I - R)^2)) / mean(R)`; `None` when `mean(R)` is 0.
    pub rel_rmse: Option<f64>,
    /// `sqrt(mean((I - R)^2))`.
    pub rmse: f64,
    /// `10 log10(peak^2 / MSE)` in dB; `None` when the images agree exactly or the peak is 0.
    pub psnr_db: Option<f64>,
    /// The PSNR's peak: the reference's largest value in the region.
    pub peak: f64,
    /// `mean(I) / mean(R)`; `None` when `mean(R)` is 0.
    pub mean_ratio: Option<f64>,
    /// Mean SSIM over the windows touching the region; `None` when the image is smaller than a
    /// window.
    pub ssim: Option<f64>,
}

/// Checks that `image` and `reference` can be compared: same size, same channels.
pub fn check_same_shape(
    image: &ChannelImage,
    image_path: &Path,
    reference: &ChannelImage,
    reference_path: &Path,
) -> Result<(), String> {
    if (image.width, image.height) != (reference.width, reference.height) {
        return Err(format!(
            "{} is {} x {} pixels but the reference {} is {} x {}",
            image_path.display(),
            image.width,
            image.height,
            reference_path.display(),
            reference.width,
            reference.height
        ));
    }
    if image.names != reference.names {
        return Err(format!(
            "{} has channels {} but the reference {} has channels {}",
            image_path.display(),
            image.names.join(","),
            reference_path.display(),
            reference.names.join(",")
        ));
    }
    Ok(())
}

/// Reads a mask for images of `width` x `height`: a pixel counts when any channel is above 0.
/// A value that is not finite is refused, as in the images: NaN is above nothing, and its pixel
/// was left out of the region without a word.
pub fn read_mask(path: &Path, width: usize, height: usize) -> Result<Vec<bool>, String> {
    let mask = ChannelImage::read(path)?;
    mask.check_finite(path)?;
    if (mask.width, mask.height) != (width, height) {
        return Err(format!(
            "mask {} is {} x {} pixels but the images are {width} x {height}",
            path.display(),
            mask.width,
            mask.height
        ));
    }
    let pixels = mask.mask();
    if !pixels.contains(&true) {
        return Err(format!(
            "mask {} selects no pixel (no value above 0)",
            path.display()
        ));
    }
    Ok(pixels)
}

/// The luminance SSIM compares: Rec. 709 weights of sRGB-encoded R, G, B when the image has
/// them, else the mean of the measured channels' sRGB encodings.
fn luminance(image: &ChannelImage) -> Vec<f64> {
    let n = image.width * image.height;
    if let (Some(r), Some(g), Some(b)) = (image.plane("R"), image.plane("G"), image.plane("B")) {
        return (0..n).map(|i| srgb_luminance(r[i], g[i], b[i])).collect();
    }
    let channels = image.measured_channels();
    (0..n)
        .map(|i| {
            channels
                .iter()
                .map(|&c| crate::render::film::linear_to_srgb(image.planes[c][i]))
                .sum::<f64>()
                / channels.len() as f64
        })
        .collect()
}

/// The figures of `image` against `reference` (checked by [`check_same_shape`]) over the pixels
/// of `mask`, or the whole image.
pub fn measure(
    name: &str,
    image: &ChannelImage,
    reference: &ChannelImage,
    mask: Option<&[bool]>,
) -> RegionMetrics {
    let (w, h) = (reference.width, reference.height);
    let inside = |i: usize| mask.is_none_or(|m| m[i]);
    let channels = reference.measured_channels();
    let (mut e2, mut sum_i, mut sum_r, mut peak, mut pixels) = (0.0, 0.0, 0.0, 0.0f64, 0);
    for i in (0..w * h).filter(|&i| inside(i)) {
        pixels += 1;
        for &c in &channels {
            let (a, r) = (image.planes[c][i], reference.planes[c][i]);
            e2 += (a - r) * (a - r);
            sum_i += a;
            sum_r += r;
            peak = peak.max(r);
        }
    }
    let n = (pixels * channels.len()) as f64;
    let mse = if n > 0.0 { e2 / n } else { 0.0 };
    let mean_r = if n > 0.0 { sum_r / n } else { 0.0 };
    let defined = |v: f64| v.is_finite().then_some(v);
    let psnr = if peak > 0.0 {
        defined(10.0 * (peak * peak / mse).log10())
    } else {
        None
    };
    let ssim = metrics::mean_ssim(&luminance(image), &luminance(reference), w, h, |x0, y0| {
        mask.is_none_or(|m| (y0..y0 + 8).any(|y| (x0..x0 + 8).any(|x| m[y * w + x])))
    });
    RegionMetrics {
        name: name.to_string(),
        pixels,
        rel_rmse: (mean_r > 0.0).then(|| mse.sqrt() / mean_r),
        rmse: mse.sqrt(),
        psnr_db: psnr,
        peak,
        mean_ratio: (sum_r > 0.0).then(|| sum_i / sum_r),
        ssim,
    }
}

/// What an error map's values are.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorScale {
    /// Over the reference's mean.
    Relative,
    /// As they are: the reference is zero everywhere, and has no mean to divide by.
    Absolute,
}

impl ErrorScale {
    /// The colour bar's title.
    pub fn title(self) -> &'static str {
        match self {
            ErrorScale::Relative => "relative error",
            ErrorScale::Absolute => "absolute error",
        }
    }
}

/// Per-pixel relative error, the error map's quantity: `sqrt(mean over channels (I - R)^2)`
/// divided by the reference's mean over the whole image, so that the region's relRMSE is the
/// root mean square of these values when the region is the whole image; undivided (and said
/// so) where that mean is not positive.
pub fn relative_error_per_pixel(
    image: &ChannelImage,
    reference: &ChannelImage,
) -> (Vec<f64>, ErrorScale) {
    let channels = reference.measured_channels();
    let n = reference.width * reference.height;
    let mean_r = (0..n)
        .flat_map(|i| channels.iter().map(move |&c| (c, i)))
        .map(|(c, i)| reference.planes[c][i])
        .sum::<f64>()
        / (n * channels.len()).max(1) as f64;
    let errors = (0..n)
        .map(|i| {
            let e2 = channels
                .iter()
                .map(|&c| (image.planes[c][i] - reference.planes[c][i]).powi(2))
                .sum::<f64>()
                / channels.len() as f64;
            if mean_r > 0.0 {
                e2.sqrt() / mean_r
            } else {
                e2.sqrt()
            }
        })
        .collect();
    let scale = if mean_r > 0.0 {
        ErrorScale::Relative
    } else {
        ErrorScale::Absolute
    };
    (errors, scale)
}
