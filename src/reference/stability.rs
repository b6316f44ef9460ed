//! What must hold for every method on every scene, however hard: finite, non-negative pixels no
//! brighter than a bound derived from the scene's power, and image energy close to the
//! reference's. Shared by the stability tests and the stability benchmark.

use crate::render::film::Film;
use crate::scene::{Light, Scene};
use glam::DVec3;
use std::f64::consts::PI;

/// The closest point to `p` on the triangle `a b c` (Ericson, Real-Time Collision Detection 5.1.5).
fn closest_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// The largest radiance any pixel may hold: what point and spot lights give the nearest surface
/// point straight on (`I / d^2 / pi` with albedo 1), plus all of the scene's light power
/// gathered into one photon footprint of the smallest area the guards allow (`min_radius^2`)
/// at the kernel's peak (`2 / pi`), plus the brightest area light's radiance.
pub fn radiance_bound(scene: &Scene, min_radius: f64) -> f64 {
    let mut direct = 0.0;
    let mut power = 0.0;
    let mut emitted: f64 = 0.0;
    for light in &scene.lights {
        power += crate::photons::emission::light_power(light) * 3.0; // mean over channels -> any channel
        match *light {
            Light::Point {
                position,
                intensity,
            }
            | Light::Spot {
                position,
                intensity,
                ..
            } => {
                let d = scene
                    .meshes
                    .iter()
                    .flat_map(|m| m.world_triangles())
                    .map(|[a, b, c]| (closest_on_triangle(position, a, b, c) - position).length())
                    .fold(f64::INFINITY, f64::min);
                direct += intensity.max_element() / (d * d).max(1e-12) / PI;
            }
            Light::Quad { radiance, .. } => emitted = emitted.max(radiance.max_element()),
        }
    }
    direct + power * (2.0 / PI) / (min_radius * min_radius) / PI + emitted
}

/// Pixels that break the basic promises: not finite, negative, or above `bound`.
pub fn bad_pixels(film: &Film, bound: f64) -> usize {
    film.pixels
        .iter()
        .filter(|p| !p.is_finite() || p.min_element() < 0.0 || p.max_element() > bound)
        .count()
}

/// `sum(I) / sum(R) - 1` over `pixels`, all channels.
pub fn energy_error(image: &Film, reference: &Film, pixels: &[usize]) -> f64 {
    let sum = |f: &Film| {
        pixels
            .iter()
            .map(|&i| f.pixels[i].x + f.pixels[i].y + f.pixels[i].z)
            .sum::<f64>()
    };
    sum(image) / sum(reference) - 1.0
}

/// The largest `I / R` over `pixels` where the reference is at least a tenth of its mean there
/// (darker pixels make the ratio meaningless).
pub fn worst_pixel_ratio(image: &Film, reference: &Film, pixels: &[usize]) -> f64 {
    let mean =
        pixels.iter().map(|&i| reference.pixels[i].x).sum::<f64>() / pixels.len().max(1) as f64;
    pixels
        .iter()
        .filter(|&&i| reference.pixels[i].x >= 0.1 * mean)
        .map(|&i| image.pixels[i].x / reference.pixels[i].x)
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closest_points_on_a_triangle() {
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        let near = |p: DVec3, q: DVec3| (p - q).length() < 1e-12;
        let cases = [
            (DVec3::new(0.2, 0.2, 5.0), DVec3::new(0.2, 0.2, 0.0)),
            (DVec3::new(-1.0, -1.0, 0.0), a),
            (DVec3::new(0.5, -2.0, 1.0), DVec3::new(0.5, 0.0, 0.0)),
            (DVec3::new(1.0, 1.0, 0.0), DVec3::new(0.5, 0.5, 0.0)),
            (DVec3::new(3.0, -1.0, 0.0), b),
        ];
        for (p, expected) in cases {
            assert!(near(closest_on_triangle(p, a, b, c), expected), "{p}");
        }
    }
}
