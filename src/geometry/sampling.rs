//! Directions and points from uniform numbers: a tangent frame, the concentric disc, cones, the
//! cosine lobe, and the R2 low-discrepancy sequence. Shared by photon emission and light paths.

use glam::DVec3;
use std::f64::consts::PI;

/// Any unit vector orthogonal to unit `n`, and the third vector of the right-handed frame.
pub fn tangent_frame(n: DVec3) -> (DVec3, DVec3) {
    let t1 = n.any_orthonormal_vector();
    (t1, n.cross(t1))
}

/// Shirley and Chiu's concentric map of the unit square onto the unit disc (equal-area and
/// continuous, without the clustering a polar map makes at the centre), as a signed radius `r`
/// and the cosine and sine of an angle: the disc point is `r (cos, sin)`. `None` at the centre.
#[inline]
pub fn concentric_disc_polar(u: f64, v: f64) -> Option<(f64, f64, f64)> {
    let (a, b) = (2.0 * u - 1.0, 2.0 * v - 1.0);
    if a == 0.0 && b == 0.0 {
        return None;
    }
    Some(if a.abs() > b.abs() {
        let (sin, cos) = quarter_sin_cos(PI / 4.0 * (b / a));
        (a, cos, sin)
    } else {
        // The angle is pi/2 - x: its cosine is sin x, its sine cos x.
        let (sin, cos) = quarter_sin_cos(PI / 4.0 * (a / b));
        (b, sin, cos)
    })
}

/// `(sin x, cos x)` for `|x| <= pi / 4`, by their Taylor series to the 17th and 16th powers
/// (truncation below 5e-17 there): a fixed run of multiply-adds instead of a call into libm's
/// `sincos`, whose range reduction the concentric map never needs. Emission draws one per
/// photon, and most global photons leave the scene at once, so this is a good share of them.
#[inline]
pub fn quarter_sin_cos(x: f64) -> (f64, f64) {
    // 1/k! for the odd and even k.
    const S: [f64; 8] = [
        -1.0 / 6.0,
        1.0 / 120.0,
        -1.0 / 5040.0,
        1.0 / 362_880.0,
        -1.0 / 39_916_800.0,
        1.0 / 6_227_020_800.0,
        -1.0 / 1_307_674_368_000.0,
        1.0 / 355_687_428_096_000.0,
    ];
    const C: [f64; 8] = [
        -1.0 / 2.0,
        1.0 / 24.0,
        -1.0 / 720.0,
        1.0 / 40_320.0,
        -1.0 / 3_628_800.0,
        1.0 / 479_001_600.0,
        -1.0 / 87_178_291_200.0,
        1.0 / 20_922_789_888_000.0,
    ];
    // Estrin's scheme (pairs, then pairs of pairs): a dependency chain of four steps rather
    // than Horner's eight. Not `mul_add`: without FMA in the target's baseline (x86-64) it
    // is a libm call.
    let x2 = x * x;
    let x4 = x2 * x2;
    let x8 = x4 * x4;
    let estrin = |k: &[f64; 8]| {
        let (p0, p1) = (k[0] + k[1] * x2, k[2] + k[3] * x2);
        let (p2, p3) = (k[4] + k[5] * x2, k[6] + k[7] * x2);
        (p0 + p1 * x4) + (p2 + p3 * x4) * x8
    };
    (x + x * x2 * estrin(&S), 1.0 + x2 * estrin(&C))
}

/// A cone of directions, uniform in solid angle, with its axis's tangent frame computed once:
/// emission draws every photon of a light's cone from one of these.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cone {
    /// Unit axis.
    pub axis: DVec3,
    /// Cosine of the half-angle (-1: the whole sphere).
    pub cos_max: f64,
    t1: DVec3,
    t2: DVec3,
}

impl Cone {
    /// The cone of unit axis `axis` and half-angle cosine `cos_max`.
    pub fn new(axis: DVec3, cos_max: f64) -> Self {
        let (t1, t2) = tangent_frame(axis);
        Cone {
            axis,
            cos_max,
            t1,
            t2,
        }
    }

    /// Its solid angle (sr).
    pub fn solid_angle(&self) -> f64 {
        2.0 * PI * (1.0 - self.cos_max)
    }

    /// A unit vector in the cone, uniform in solid angle: the concentric disc lifted onto the
    /// spherical cap by the equal-area (Lambert) projection, so that well-stratified `(u, v)`
    /// give well-stratified directions, also around the axis.
    #[inline]
    pub fn sample(&self, u: f64, v: f64) -> DVec3 {
        let Some((r, cos_phi, sin_phi)) = concentric_disc_polar(u, v) else {
            return self.axis;
        };
        // A disc point at radius |r| lifts to the cap's cosine 1 - w, w = r^2 (1 - cos_max),
        // whose sine is sqrt(w (2 - w)) (no cancellation near the axis); the point's angle is
        // the direction's azimuth (r's sign turns it by pi). Unit up to rounding, as a sum
        // of orthonormal vectors with cos^2 + sin^2 = 1.
        let w = r * r * (1.0 - self.cos_max);
        let sin = (w * (2.0 - w)).max(0.0).sqrt().copysign(r);
        self.axis * (1.0 - w) + self.t1 * (sin * cos_phi) + self.t2 * (sin * sin_phi)
    }
}

/// [`Cone::sample`] for `N` lanes at once, lane `l` in `cones[l]` at `(u[l], v[l])`: the
/// same operations in the same order, bit for bit the same directions, but without its
/// branches, in loops over the lanes that compile to vector instructions. Photon emission
/// draws one direction per photon, and one at a time the division and the square root on
/// each direction's dependency chain were a tenth of the global map's tracing time.
pub fn sample_cones<const N: usize>(cones: [&Cone; N], u: &[f64; N], v: &[f64; N]) -> [DVec3; N] {
    // The cones' parts lane by lane (gathered once, so that the loops below only stream).
    let part = |f: fn(&Cone) -> f64| -> [f64; N] { std::array::from_fn(|l| f(cones[l])) };
    let (ax, ay, az) = (part(|c| c.axis.x), part(|c| c.axis.y), part(|c| c.axis.z));
    let (t1x, t1y, t1z) = (part(|c| c.t1.x), part(|c| c.t1.y), part(|c| c.t1.z));
    let (t2x, t2y, t2z) = (part(|c| c.t2.x), part(|c| c.t2.y), part(|c| c.t2.z));
    let cos_max = part(|c| c.cos_max);
    let (mut r, mut cos_phi, mut sin_phi) = ([0.0; N], [0.0; N], [0.0; N]);
    for l in 0..N {
        // `concentric_disc_polar`: the signed radius is the larger of `a`, `b` in magnitude,
        // the divisor of the angle's tangent; it is 0 only at the centre.
        let (a, b) = (2.0 * u[l] - 1.0, 2.0 * v[l] - 1.0);
        let wide = a.abs() > b.abs();
        let (num, den) = if wide { (b, a) } else { (a, b) };
        let (sin, cos) = quarter_sin_cos(PI / 4.0 * (num / den));
        r[l] = den;
        (cos_phi[l], sin_phi[l]) = if wide { (cos, sin) } else { (sin, cos) };
    }
    let mut out = [[0.0; 3]; N];
    for l in 0..N {
        let w = r[l] * r[l] * (1.0 - cos_max[l]);
        let sin = (w * (2.0 - w)).max(0.0).sqrt().copysign(r[l]);
        let (s1, s2, lift) = (sin * cos_phi[l], sin * sin_phi[l], 1.0 - w);
        let centre = r[l] == 0.0;
        let d = [
            ax[l] * lift + t1x[l] * s1 + t2x[l] * s2,
            ay[l] * lift + t1y[l] * s1 + t2y[l] * s2,
            az[l] * lift + t1z[l] * s1 + t2z[l] * s2,
        ];
        out[l] = if centre { [ax[l], ay[l], az[l]] } else { d };
    }
    out.map(DVec3::from_array)
}

/// A unit vector in the cone of axis `w` and half-angle cosine `cos_max`, uniform in solid angle
/// ([`Cone::sample`]; a [`Cone`] kept for many samples saves the tangent frame).
pub fn sample_cone(w: DVec3, cos_max: f64, u: f64, v: f64) -> DVec3 {
    Cone::new(w, cos_max).sample(u, v)
}

/// `(sin, cos)` of the angle `2 pi v` for `v` in `[0, 1]`: the nearest quarter turn taken out
/// exactly (`v - q/4` is exact near `q/4`), the rest by [`quarter_sin_cos`], then turned back
/// by `q` quarter turns. libm's `sincos` without its general range reduction.
#[inline]
pub fn turn_sin_cos(v: f64) -> (f64, f64) {
    let q = (4.0 * v + 0.5) as i64; // v >= 0: truncation rounds to nearest
    let (s, c) = quarter_sin_cos(2.0 * PI * (v - 0.25 * q as f64));
    match q & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// A cosine-distributed unit vector about `n`.
pub fn sample_cosine(n: DVec3, u: f64, v: f64) -> DVec3 {
    let r = u.sqrt();
    let (sin, cos) = turn_sin_cos(v);
    let (t1, t2) = tangent_frame(n);
    (n * (1.0 - u).max(0.0).sqrt() + t1 * (r * cos) + t2 * (r * sin)).normalize()
}

/// The steps of [`r2`]: 1 / the plastic number, and its square.
const A1: f64 = 0.754_877_666_246_692_8;
const A2: f64 = 0.569_840_290_998_053_3;

/// The plastic-number (R2) low-discrepancy sequence: every prefix is well stratified in 2D,
/// so emission directions are even whatever number of photons ends up emitted.
pub fn r2(index: u64, shift: [f64; 2]) -> (f64, f64) {
    let i = index as f64;
    // The fractional part of a non-negative x below 2^64, as `fract` gives it but without
    // its `trunc`, a libm call on the x86-64 baseline (no SSE4.1 rounding instruction).
    let fract = |x: f64| x - (x as u64) as f64;
    (fract(shift[0] + i * A1), fract(shift[1] + i * A2))
}

/// [`r2`] for the indices `first + l`, `l < N`: the same numbers, in a loop over the indices
/// that compiles to vector instructions where the CPU can round to an integer (SSE4.1): there
/// the fractional part is `x - x.trunc()`, equal to `r2`'s for every `x` in `[0, 2^64)`,
/// rather than a conversion to an integer and back (a dozen scalar instructions each, for
/// the conversion's saturation).
pub fn r2_many<const N: usize>(first: u64, shift: [f64; 2]) -> ([f64; N], [f64; N]) {
    if !cfg!(target_feature = "sse4.1") {
        let mut uv = ([0.0; N], [0.0; N]);
        for l in 0..N {
            (uv.0[l], uv.1[l]) = r2(first.wrapping_add(l as u64), shift);
        }
        return uv;
    }
    let fract = |x: f64| x - x.trunc();
    let (mut u, mut v) = ([0.0; N], [0.0; N]);
    for l in 0..N {
        let i = first.wrapping_add(l as u64) as f64;
        (u[l], v[l]) = (fract(shift[0] + i * A1), fract(shift[1] + i * A2));
    }
    (u, v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cones_sampled_sixteen_at_a_time_are_sampled_one_at_a_time() {
        let cones: Vec<Cone> = (0..7)
            .map(|k| {
                let t = k as f64;
                let axis = DVec3::new(t.sin(), (1.3 * t).cos(), 0.4 - 0.1 * t).normalize();
                Cone::new(axis, [-1.0, -0.3, 0.0, 0.5, 0.9, 0.999, 1.0][k])
            })
            .collect();
        // The disc's centre, its edges and diagonals (where the concentric map changes
        // branch), and points in between.
        let mut points = vec![
            (0.5, 0.5),
            (0.0, 0.0),
            (1.0 - 1e-16, 0.5),
            (0.25, 0.25),
            (0.75, 0.25),
        ];
        points.extend((0..200).map(|k| {
            let t = k as f64;
            (((t * 0.618) % 1.0), ((t * 0.754) % 1.0))
        }));
        let mut checked = 0;
        for group in points.chunks(16) {
            let mut u = [0.5; 16];
            let mut v = [0.5; 16];
            for (l, &(a, b)) in group.iter().enumerate() {
                (u[l], v[l]) = (a, b);
            }
            let lanes: [&Cone; 16] = std::array::from_fn(|l| &cones[(l + checked) % cones.len()]);
            let many = sample_cones(lanes, &u, &v);
            for l in 0..16 {
                let one = lanes[l].sample(u[l], v[l]);
                assert_eq!(
                    many[l].to_array().map(f64::to_bits),
                    one.to_array().map(f64::to_bits),
                    "lane {l}: ({}, {})",
                    u[l],
                    v[l]
                );
            }
            checked += 16;
        }
        assert!(checked >= points.len());
    }

    #[test]
    fn quarter_sin_cos_matches_libm_to_rounding() {
        let mut worst = 0.0f64;
        for i in 0..=100_000 {
            let x = (i as f64 / 50_000.0 - 1.0) * PI / 4.0;
            let (s, c) = quarter_sin_cos(x);
            worst = worst.max((s - x.sin()).abs()).max((c - x.cos()).abs());
        }
        assert!(worst <= 4.0 * f64::EPSILON, "{worst:e}");
    }

    #[test]
    fn turn_sin_cos_matches_libm_to_rounding() {
        let mut worst = 0.0f64;
        for i in 0..=100_000 {
            let v = i as f64 / 100_000.0;
            let (s, c) = turn_sin_cos(v);
            let phi = 2.0 * PI * v;
            worst = worst.max((s - phi.sin()).abs()).max((c - phi.cos()).abs());
        }
        assert!(worst <= 8.0 * f64::EPSILON, "{worst:e}");
    }

    /// The steps are the plastic number's reciprocal and its square: the plastic number is the
    /// real root of `x^3 = x + 1`, found here by Newton's method.
    #[test]
    fn r2_steps_come_from_the_plastic_number() {
        let mut rho = 1.5_f64;
        for _ in 0..50 {
            rho -= (rho * rho * rho - rho - 1.0) / (3.0 * rho * rho - 1.0);
        }
        assert!((rho * rho * rho - rho - 1.0).abs() < 1e-15, "{rho}");
        let ulp = |x: f64| f64::EPSILON * x;
        assert!((A1 - 1.0 / rho).abs() <= ulp(A1), "{A1} {}", 1.0 / rho);
        assert!(
            (A2 - 1.0 / (rho * rho)).abs() <= ulp(A2),
            "{A2} {}",
            1.0 / (rho * rho)
        );
    }

    #[test]
    fn r2_is_the_fractional_part_of_the_plastic_numbers_multiples() {
        let shift = [0.37, 0.91];
        for index in (0..10_000u64).chain([1 << 20, (1 << 40) + 7, u32::MAX as u64 * 3]) {
            let i = index as f64;
            let (u, v) = r2(index, shift);
            assert_eq!(u, (shift[0] + i * A1).fract(), "{index}");
            assert_eq!(v, (shift[1] + i * A2).fract(), "{index}");
            assert!((0.0..1.0).contains(&u) && (0.0..1.0).contains(&v));
        }
        for first in [0, 1 << 20, 1 << 40, u32::MAX as u64 * 3] {
            let (us, vs) = r2_many::<16>(first, shift);
            for l in 0..16 {
                assert_eq!((us[l], vs[l]), r2(first + l as u64, shift), "{first} + {l}");
            }
        }
    }

    /// The concentric map as Shirley and Chiu write it (the angle, then its cosine and sine),
    /// and the cone's direction built from it and normalised: what `Cone::sample` computes
    /// without the angle, the division and the normalisation.
    fn cone_sample_by_the_book(cone: &Cone, u: f64, v: f64) -> DVec3 {
        let (a, b) = (2.0 * u - 1.0, 2.0 * v - 1.0);
        if a == 0.0 && b == 0.0 {
            return cone.axis;
        }
        let (r, phi) = if a.abs() > b.abs() {
            (a, PI / 4.0 * (b / a))
        } else {
            (b, PI / 2.0 - PI / 4.0 * (a / b))
        };
        let (x, y) = (r * phi.cos(), r * phi.sin());
        let r2 = x * x + y * y;
        let cos = 1.0 - r2 * (1.0 - cone.cos_max);
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        let s = sin / r2.sqrt();
        (cone.axis * cos + cone.t1 * (s * x) + cone.t2 * (s * y)).normalize()
    }

    #[test]
    fn cone_samples_are_unit_inside_the_cone_and_the_concentric_maps_directions() {
        let axis = DVec3::new(0.3, -1.0, 0.2).normalize();
        for cos_max in [-1.0, 0.0, 0.9, 0.999_999] {
            let cone = Cone::new(axis, cos_max);
            for i in 0..20_000 {
                let (u, v) = r2(i, [0.17, 0.61]);
                let d = cone.sample(u, v);
                assert!((d.length() - 1.0).abs() < 1e-14, "{cos_max} {i}");
                assert!(d.dot(axis) >= cos_max - 1e-14, "{cos_max} {i}");
                // The book's 1 - cos^2 cancels in a narrow cone (it is the less accurate).
                let tolerance = 1e-12 + 1e-15 / (1.0 - cos_max);
                let book = cone_sample_by_the_book(&cone, u, v);
                assert!((d - book).length() < tolerance, "{cos_max} {i}: {d} {book}");
            }
            assert_eq!(cone.sample(0.5, 0.5), axis);
        }
    }
}
