//! Accuracy against a reference: the image regions the estimators are judged on, the relative
//! RMS error, and SSIM on tone-mapped images.
//!
//! `relRMSE = sqrt(mean over pixels and channels of (I - R)^2) / mean(R)` over a region.

use crate::embree::{self, Hit, Ray};
use crate::render::film::{linear_to_srgb, Film};
use crate::scene::{Light, Material, Scene};
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::FRAC_1_PI;

/// What a diffuse pixel is judged as besides the floor.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Class {
    Caustic,
    Shadow,
    Other,
}

/// The regions of an image where estimators are judged.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Regions {
    /// Pixels seen directly on diffuse surfaces over their whole area: every camera ray of a
    /// [`COVER_LATTICE`] x [`COVER_LATTICE`] lattice spanning the pixel (its corners included)
    /// first hits a diffuse surface. A pixel partly covered by a mirror or glass is left out:
    /// the light tracer connects only diffuse vertices to the camera, so the reference holds
    /// nothing for the part of the pixel that shows a specular surface (what is seen through
    /// it), and judging a render there would count the reference's gap as the render's error.
    pub diffuse: Vec<usize>,
    /// Diffuse pixels the reference lights (any channel above zero): where image energy is
    /// compared.
    pub lit: Vec<usize>,
    /// Diffuse pixels where the reference exceeds 1.5 times the direct radiance the point and
    /// spot lights would give there if nothing blocked them (the caustic). Quad lights are not
    /// in that threshold: a scene lit by quad lights alone has no caustic region, and one that
    /// mixes them with point lights counts the floor the quad lights light as caustic. (Stop 56
    /// tried them in it, with their exact unblocked irradiance: `cornell-glass`'s walls reflect
    /// about as much light as the light gives directly, and 49,090 of its 66,319 floor pixels
    /// came out a caustic. Telling a caustic apart there needs the reference's caustic paths in
    /// an image of their own.)
    pub caustic: Vec<usize>,
    /// The tenth of the caustic pixels with the largest reference gradient (its contour).
    pub contour: Vec<usize>,
    /// Diffuse pixels outside the caustic where every point and spot light is blocked at the
    /// pixel's centre, though some would light it unblocked: the shadows, dim and easy to
    /// overlook, where streaks show. (Empty in a scene lit by quad lights alone. Stop 56 counted
    /// a quad light's umbra, every point of a lattice over it blocked, and dropped it: with no
    /// caustic region to take it out, a glass sphere's caustic, the image's brightest pixels,
    /// fell in the "shadow", and a light flush with the ceiling speckled it with lit pixels.)
    pub shadow: Vec<usize>,
}

/// Rays per side (odd: the pixel's centre is one of them) of the lattice that decides whether a
/// pixel is seen on diffuse surfaces over its whole area ([`Regions::diffuse`]): a specular
/// sliver narrower than about 1/8 of a pixel can slip between its rays.
pub const COVER_LATTICE: usize = 9;

/// Pixel `(x, y)`'s centre ray direction, its first hit and the albedo there, when every ray
/// of a [`COVER_LATTICE`]-square lattice spanning the pixel (corners included) first hits a
/// diffuse surface. The centre, one of the lattice's points, is traced first: it settles most
/// pixels that do not count.
fn seen_on_diffuse(
    scene: &Scene,
    embree: &embree::Scene,
    x: usize,
    y: usize,
) -> Option<(DVec3, Hit, DVec3)> {
    let diffuse_hit = |px: f64, py: f64| {
        let r = scene.camera.ray(px, py, 1.0);
        let hit = embree.intersect(&Ray::new(r.p, r.d))?;
        match *scene.material(hit.geom_id) {
            Material::Diffuse { albedo } => Some((r.d, hit, albedo)),
            _ => None,
        }
    };
    let (x, y) = (x as f64, y as f64);
    let centre = diffuse_hit(x + 0.5, y + 0.5)?;
    let (mid, step) = (COVER_LATTICE / 2, 1.0 / (COVER_LATTICE - 1) as f64);
    (0..COVER_LATTICE)
        .all(|j| {
            (0..COVER_LATTICE).all(|i| {
                (i, j) == (mid, mid)
                    || diffuse_hit(x + i as f64 * step, y + j as f64 * step).is_some()
            })
        })
        .then_some(centre)
}

/// Radiance the point and spot lights would reflect at a diffuse point `x` (normal `n` facing
/// the eye, albedo `albedo`) towards the eye if nothing blocked them.
fn unblocked_direct(scene: &Scene, x: DVec3, n: DVec3, albedo: DVec3) -> DVec3 {
    let mut sum = DVec3::ZERO;
    for light in &scene.lights {
        if let Light::Point { position, .. } | Light::Spot { position, .. } = *light {
            let to = position - x;
            let d2 = to.length_squared();
            let w = to / d2.sqrt();
            let cos = n.dot(w).max(0.0);
            sum += light.intensity_towards(-w) * (cos / d2);
        }
    }
    sum * albedo * FRAC_1_PI
}

/// Whether every point and spot light is blocked from `x` (normal `n`, facing the eye).
fn blocked(scene: &Scene, embree: &embree::Scene, x: DVec3, n: DVec3, epsilon: f64) -> bool {
    let origin = x + n * epsilon;
    scene.lights.iter().all(|light| match *light {
        Light::Point { position, .. } | Light::Spot { position, .. } => {
            let to = position - origin;
            let d = to.length();
            n.dot(to) <= 0.0 || embree.occluded(&Ray::segment(origin, to / d, d * (1.0 - 1e-9)))
        }
        Light::Quad { .. } => true,
    })
}

impl Regions {
    /// The regions of `scene`'s image given the `reference`.
    pub fn new(scene: &Scene, embree: &embree::Scene, reference: &Film) -> Self {
        let c = &scene.camera;
        let (w, h) = (c.width as usize, c.height as usize);
        let epsilon = scene.ray_epsilon();
        // Each pixel: whether it is diffuse over its whole area, and if so whether it is in the
        // caustic or the shadow (rows in parallel: the lattice costs 81 rays a pixel).
        let classes: Vec<Vec<(usize, Class)>> = (0..h)
            .into_par_iter()
            .map(|y| {
                let mut row = Vec::new();
                for x in 0..w {
                    let Some((d, hit, albedo)) = seen_on_diffuse(scene, embree, x, y) else {
                        continue;
                    };
                    let i = y * w + x;
                    let n = crate::geometry::surface::facing(hit.geometric_normal, d);
                    let direct = unblocked_direct(scene, hit.position, n, albedo);
                    let value = reference.pixels[i];
                    let class = if direct.max_element() > 0.0
                        && (value.x + value.y + value.z) > 1.5 * (direct.x + direct.y + direct.z)
                    {
                        Class::Caustic
                    } else if direct.max_element() > 0.0
                        && blocked(scene, embree, hit.position, n, epsilon)
                    {
                        Class::Shadow
                    } else {
                        Class::Other
                    };
                    row.push((i, class));
                }
                row
            })
            .collect();
        let pixels = || classes.iter().flatten();
        let diffuse: Vec<usize> = pixels().map(|&(i, _)| i).collect();
        let of = |class: Class| -> Vec<usize> {
            pixels().filter(|p| p.1 == class).map(|&(i, _)| i).collect()
        };
        let (caustic, shadowed) = (of(Class::Caustic), of(Class::Shadow));
        let luminance = |i: usize| {
            let p = reference.pixels[i];
            (p.x + p.y + p.z) / 3.0
        };
        let mut gradients: Vec<(f64, usize)> = caustic
            .iter()
            .map(|&i| {
                let (x, y) = (i % w, i / w);
                let gx =
                    luminance(y * w + (x + 1).min(w - 1)) - luminance(y * w + x.saturating_sub(1));
                let gy =
                    luminance((y + 1).min(h - 1) * w + x) - luminance(y.saturating_sub(1) * w + x);
                ((gx * gx + gy * gy).sqrt(), i)
            })
            .collect();
        gradients.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let mut contour: Vec<usize> = gradients
            .iter()
            .take(caustic.len().div_ceil(10))
            .map(|g| g.1)
            .collect();
        contour.sort_unstable();
        let lit = diffuse
            .iter()
            .copied()
            .filter(|&i| reference.pixels[i].max_element() > 0.0)
            .collect();
        Regions {
            diffuse,
            lit,
            caustic,
            contour,
            shadow: shadowed,
        }
    }
}

/// `sqrt(mean over pixels and channels of (I - R)^2) / mean(R)` over `pixels`.
pub fn rel_rmse(image: &Film, reference: &Film, pixels: &[usize]) -> f64 {
    let (mut e2, mut r, mut n) = (0.0, 0.0, 0.0);
    for &i in pixels {
        let d = image.pixels[i] - reference.pixels[i];
        e2 += d.length_squared();
        let p = reference.pixels[i];
        r += p.x + p.y + p.z;
        n += 3.0;
    }
    if n == 0.0 || r <= 0.0 {
        return f64::NAN;
    }
    (e2 / n).sqrt() / (r / n)
}

/// Mean SSIM (Wang et al. 2004; 8 x 8 windows with a stride of 4, the usual constants) between
/// the sRGB-tone-mapped luminances of two images, in `[-1, 1]`, 1 for identical images.
pub fn ssim(image: &Film, reference: &Film) -> f64 {
    let luma = |f: &Film| -> Vec<f64> {
        f.pixels
            .iter()
            .map(|p| srgb_luminance(p.x, p.y, p.z))
            .collect()
    };
    let (w, h) = (image.width as usize, image.height as usize);
    mean_ssim(&luma(image), &luma(reference), w, h, |_, _| true).unwrap_or(1.0)
}

/// Rec. 709 luminance of the sRGB-encoded (clamped) channels: what SSIM compares.
pub fn srgb_luminance(r: f64, g: f64, b: f64) -> f64 {
    0.2126 * linear_to_srgb(r) + 0.7152 * linear_to_srgb(g) + 0.0722 * linear_to_srgb(b)
}

/// Mean SSIM over the 8 x 8 windows (stride 4, from the top-left, and one more flush with the
/// right and with the bottom edge where the stride does not end there) of two `w` x `h`
/// luminance planes whose top-left corner `(x0, y0)` passes `include`; `None` when no window
/// does.
pub fn mean_ssim(
    a: &[f64],
    b: &[f64],
    w: usize,
    h: usize,
    include: impl Fn(usize, usize) -> bool,
) -> Option<f64> {
    let (c1, c2) = ((0.01f64).powi(2), (0.03f64).powi(2));
    let (mut sum, mut count) = (0.0, 0.0);
    for y0 in window_starts(h) {
        for x0 in window_starts(w) {
            if !include(x0, y0) {
                continue;
            }
            let (mut ma, mut mb, mut va, mut vb, mut cov) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for y in y0..y0 + 8 {
                for x in x0..x0 + 8 {
                    ma += a[y * w + x];
                    mb += b[y * w + x];
                }
            }
            ma /= 64.0;
            mb /= 64.0;
            for y in y0..y0 + 8 {
                for x in x0..x0 + 8 {
                    let (da, db) = (a[y * w + x] - ma, b[y * w + x] - mb);
                    va += da * da;
                    vb += db * db;
                    cov += da * db;
                }
            }
            let (va, vb, cov) = (va / 63.0, vb / 63.0, cov / 63.0);
            sum += ((2.0 * ma * mb + c1) * (2.0 * cov + c2))
                / ((ma * ma + mb * mb + c1) * (va + vb + c2));
            count += 1.0;
        }
    }
    (count > 0.0).then(|| sum / count)
}

/// Where the 8-pixel windows along a side of `n` pixels start: every 4 pixels, and flush with
/// the far edge where that stride stops short of it (a 41-pixel row's last column was in no
/// window: two black rows at the bottom of a 41 x 30 image read SSIM 1).
fn window_starts(n: usize) -> Vec<usize> {
    let mut starts: Vec<usize> = (0..n.saturating_sub(7)).step_by(4).collect();
    if let Some(&last) = starts.last() {
        if last + 8 < n {
            starts.push(n - 8);
        }
    }
    starts
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every pixel is in a window, however the size divides; sizes the stride ends on keep
    /// their windows as they were.
    #[test]
    fn ssim_windows_reach_the_far_edges() {
        assert_eq!(window_starts(16), vec![0, 4, 8]);
        assert_eq!(window_starts(17), vec![0, 4, 8, 9]);
        assert_eq!(window_starts(8), vec![0]);
        assert_eq!(window_starts(7), Vec::<usize>::new());
        // 12 x 10 planes, different only in their last two rows: not SSIM 1.
        let a = vec![0.5; 120];
        let mut b = a.clone();
        b[100..].iter_mut().for_each(|v| *v = 0.0);
        let s = mean_ssim(&a, &b, 12, 10, |_, _| true).unwrap();
        assert!(s < 0.99, "{s}");
    }

    #[test]
    fn errors_of_known_images() {
        let mut r = Film::new(16, 16);
        for (i, p) in r.pixels.iter_mut().enumerate() {
            *p = DVec3::splat(0.2 + 0.001 * i as f64);
        }
        let all: Vec<usize> = (0..256).collect();
        assert_eq!(rel_rmse(&r, &r, &all), 0.0);
        assert!((ssim(&r, &r) - 1.0).abs() < 1e-12);
        let mut i = r.clone();
        for p in &mut i.pixels {
            *p *= 1.1;
        }
        // A uniform 10% excess: relRMSE = 0.1 * rms(R) / mean(R). With R_i = 0.2 + 0.001 i,
        // i < 256: mean(R) = 0.3275, mean(R^2) = 0.04 + 0.051 + 1e-6 * 255 * 511 / 6.
        let e = rel_rmse(&i, &r, &all);
        let expected = 0.1 * (0.04 + 0.051 + 1e-6 * 255.0 * 511.0 / 6.0_f64).sqrt() / 0.3275;
        assert!((e - expected).abs() <= 1e-12 * expected, "{e} {expected}");
        // Two flat planes: every window's variances and covariance are 0, so its SSIM is the
        // luminance term (2 a b + c1) / (a^2 + b^2 + c1), c1 = 0.01^2.
        let (a, b) = (vec![0.5; 256], vec![0.6; 256]);
        let c1 = 1e-4;
        let flat = (2.0 * 0.5 * 0.6 + c1) / (0.25 + 0.36 + c1);
        let m = mean_ssim(&a, &b, 16, 16, |_, _| true).unwrap();
        assert!((m - flat).abs() < 1e-12, "{m} {flat}");
        assert_eq!(mean_ssim(&a, &b, 16, 16, |_, _| false), None);
        let mut noisy = r.clone();
        for (k, p) in noisy.pixels.iter_mut().enumerate() {
            *p += DVec3::splat(if k % 2 == 0 { 0.1 } else { -0.1 });
        }
        assert!(ssim(&noisy, &r) < 0.9);
    }
}
