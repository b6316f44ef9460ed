//! Directions and points from uniform numbers: a tangent frame, the concentric disc, cones, the
//! cosine lobe, and the R2 low-discrepancy sequence. Shared by photon emission and light paths.

use glam::DVec3;
use std::f64::consts::PI;

/// Any unit vector orthogonal to unit `n`, and the third vector of the right-handed frame.
pub fn tangent_frame(n: DVec3) -> (DVec3, DVec3) {
    let t1 = n.any_orthonormal_vector();
    (t1, n.cross(t1))
}

/// Shirley and Chiu's concentric map of the unit square onto the unit disc: equal-area and
/// continuous, without the clustering a polar map makes at the centre.
pub fn concentric_disc(u: f64, v: f64) -> (f64, f64) {
    let (a, b) = (2.0 * u - 1.0, 2.0 * v - 1.0);
    if a == 0.0 && b == 0.0 {
        return (0.0, 0.0);
    }
    let (r, phi) = if a.abs() > b.abs() {
        (a, PI / 4.0 * (b / a))
    } else {
        (b, PI / 2.0 - PI / 4.0 * (a / b))
    };
    (r * phi.cos(), r * phi.sin())
}

/// A unit vector in the cone of axis `w` and half-angle cosine `cos_max`, uniform in solid angle:
/// the concentric disc lifted onto the spherical cap by the equal-area (Lambert) projection, so
/// that well-stratified `(u, v)` give well-stratified directions, also around the axis.
pub fn sample_cone(w: DVec3, cos_max: f64, u: f64, v: f64) -> DVec3 {
    let (x, y) = concentric_disc(u, v);
    let r2 = x * x + y * y;
    let cos = 1.0 - r2 * (1.0 - cos_max);
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let (t1, t2) = tangent_frame(w);
    if r2 == 0.0 {
        return w;
    }
    // (x, y) / r is the unit vector at the disc point's angle: no need to compute the angle.
    let s = sin / r2.sqrt();
    (w * cos + t1 * (s * x) + t2 * (s * y)).normalize()
}

/// A cosine-distributed unit vector about `n`.
pub fn sample_cosine(n: DVec3, u: f64, v: f64) -> DVec3 {
    let r = u.sqrt();
    let phi = 2.0 * PI * v;
    let (t1, t2) = tangent_frame(n);
    (n * (1.0 - u).max(0.0).sqrt() + t1 * (r * phi.cos()) + t2 * (r * phi.sin())).normalize()
}

/// The plastic-number (R2) low-discrepancy sequence: every prefix is well stratified in 2D,
/// so emission directions are even whatever number of photons ends up emitted.
pub fn r2(index: u64, shift: [f64; 2]) -> (f64, f64) {
    const A1: f64 = 0.754_877_666_246_692_8; // 1 / plastic number
    const A2: f64 = 0.569_840_290_998_053_3; // 1 / plastic number^2
    let i = index as f64;
    ((shift[0] + i * A1).fract(), (shift[1] + i * A2).fract())
}
