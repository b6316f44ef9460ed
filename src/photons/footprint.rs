//! Photon footprints: the ellipse a photon differential covers on the surface where it is stored,
//! its filter matrix and area, and the guards against degenerate footprints.
//!
//! Convention (used everywhere in photondiff): the differentials `a = dP/du`, `b = dP/dv` are
//! the *radius* vectors of the footprint: the footprint is `{x_p + s a + t b : s^2 + t^2 <= 1}`,
//! an ellipse of area `pi |a x b|`. The filter matrix `M` maps it onto the unit disc, and kernels
//! are normalised over the unit disc, so a photon's contribution
//! `Phi / A * K(|M (x - x_p)|)` with `A = |a x b|` integrates to exactly `Phi` over the plane.

use crate::geometry::sampling::tangent_frame;
use glam::DVec3;

/// Bounds applied to every footprint. Each clamp is counted ([`Guards`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FootprintLimits {
    /// Smallest semi-axis: footprints at caustic focal points collapse to a point and their
    /// `Phi / A` would grow without bound.
    pub min_radius: f64,
    /// Largest semi-axis: grazing photons make long needles that would blur the image and make
    /// every range query return the whole map.
    pub max_radius: f64,
    /// Largest ratio of the semi-axes.
    pub max_anisotropy: f64,
}

/// Counts of guarded footprints.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct Guards {
    /// Footprints whose short axis was raised to the minimum radius.
    pub clamped_min: u64,
    /// Footprints whose long axis was cut to the maximum radius.
    pub clamped_max: u64,
    /// Footprints whose short axis was raised to bound the anisotropy.
    pub clamped_anisotropy: u64,
    /// Non-finite or zero-area footprints replaced by a round footprint of the nominal radius
    /// (a regular photon).
    pub fallback: u64,
    /// Mirror photons made for footprints that run into a wall or off an edge: one beyond the
    /// wall, three in an inner corner ([`crate::photons::walls`]; the map holds the mirrors
    /// besides the photons stored).
    pub mirrored: u64,
}

impl Guards {
    /// Adds `other` into `self`.
    pub fn add(&mut self, other: &Guards) {
        self.clamped_min += other.clamped_min;
        self.clamped_max += other.clamped_max;
        self.clamped_anisotropy += other.clamped_anisotropy;
        self.fallback += other.fallback;
        self.mirrored += other.mirrored;
    }

    /// Total number of guarded footprints (a footprint may count under several guards; the
    /// mirrored ones are not guarded and do not count).
    pub fn total(&self) -> u64 {
        self.clamped_min + self.clamped_max + self.clamped_anisotropy + self.fallback
    }
}

/// A footprint ready for kernel evaluation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Footprint {
    /// The rows of the filter matrix `M` (world space): `M v = (m[0].v, m[1].v)`.
    pub m: [DVec3; 2],
    /// `A = |a x b|` after guards (the product of the semi-axes).
    pub area: f64,
    /// The long semi-axis (the footprint's circumradius).
    pub radius: f64,
}

impl Footprint {
    /// The round footprint of `radius` on a surface of unit normal `n`.
    pub fn round(n: DVec3, radius: f64) -> Self {
        let (t1, t2) = tangent_frame(n);
        Footprint {
            m: [t1 / radius, t2 / radius],
            area: radius * radius,
            radius,
        }
    }
}

/// The footprint of differentials `a`, `b` on a surface of unit normal `n`, guarded by `limits`;
/// `nominal_radius` is the round footprint used when `a`, `b` are degenerate.
pub fn footprint(
    a: DVec3,
    b: DVec3,
    n: DVec3,
    limits: &FootprintLimits,
    nominal_radius: f64,
    guards: &mut Guards,
) -> Footprint {
    let (t1, t2) = tangent_frame(n);
    // F = [a b] in the tangent frame; the footprint is F(unit disc) = U S (unit disc) with
    // F = U S V^T, so only S and U matter: the eigen-decomposition of F F^T.
    let (a1, a2, b1, b2) = (a.dot(t1), a.dot(t2), b.dot(t1), b.dot(t2));
    let (sxx, sxy, syy) = (a1 * a1 + b1 * b1, a1 * a2 + b1 * b2, a2 * a2 + b2 * b2);
    let mean = 0.5 * (sxx + syy);
    let diff = (0.25 * (sxx - syy) * (sxx - syy) + sxy * sxy).sqrt();
    let det = (a1 * b2 - a2 * b1).abs();
    // The smaller eigenvalue from the product of both (det F^2), not `mean - diff`, which
    // cancels to zero or below once the short axis is under about 1e-8 of the long one: such
    // a needle (near a focal line) took the round fallback of the nominal radius.
    let l1 = mean + diff;
    let l2 = det / l1 * det;
    let (mut s1, mut s2, e1) = if l1.is_finite() && l2.is_finite() && det > 0.0 && l2 > 0.0 {
        // Eigenvector of the larger eigenvalue.
        let e = if sxy.abs() > 1e-300 {
            glam::DVec2::new(l1 - syy, sxy).normalize()
        } else if sxx >= syy {
            glam::DVec2::X
        } else {
            glam::DVec2::Y
        };
        (l1.sqrt(), l2.sqrt(), e)
    } else {
        guards.fallback += 1;
        (nominal_radius, nominal_radius, glam::DVec2::X)
    };
    if s1 > limits.max_radius {
        s1 = limits.max_radius;
        s2 = s2.min(s1);
        guards.clamped_max += 1;
    }
    if s2 < limits.min_radius {
        s2 = limits.min_radius;
        s1 = s1.max(s2);
        guards.clamped_min += 1;
    }
    if s1 > limits.max_anisotropy * s2 {
        s2 = s1 / limits.max_anisotropy;
        guards.clamped_anisotropy += 1;
    }
    let axis1 = t1 * e1.x + t2 * e1.y;
    let axis2 = n.cross(axis1);
    Footprint {
        m: [axis1 / s1, axis2 / s2],
        area: s1 * s2,
        radius: s1,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LOOSE: FootprintLimits = FootprintLimits {
        min_radius: 1e-9,
        max_radius: 1e9,
        max_anisotropy: 1e9,
    };

    #[test]
    fn filter_matrix_maps_the_differentials_onto_the_unit_circle() {
        let n = DVec3::new(0.2, 1.0, -0.1).normalize();
        let (t1, t2) = tangent_frame(n);
        let a = t1 * 0.3 + t2 * 0.1;
        let b = t1 * -0.05 + t2 * 0.2;
        let f = footprint(a, b, n, &LOOSE, 1.0, &mut Guards::default());
        for v in [a, b, (a + b) / 2f64.sqrt(), (a - b) / 2f64.sqrt()] {
            let r = (f.m[0].dot(v).powi(2) + f.m[1].dot(v).powi(2)).sqrt();
            assert!((r - 1.0).abs() < 1e-12, "{r}");
        }
        assert!((f.area - a.cross(b).length()).abs() < 1e-12);
    }

    /// A round footprint maps every tangent vector of its radius onto the unit circle, and
    /// the normal onto the origin.
    #[test]
    fn round_footprints_map_their_radius_onto_the_unit_circle() {
        let n = DVec3::new(0.3, -0.8, 0.5).normalize();
        let (t1, t2) = tangent_frame(n);
        let f = Footprint::round(n, 0.25);
        let filter = |v: DVec3| (f.m[0].dot(v).powi(2) + f.m[1].dot(v).powi(2)).sqrt();
        for k in 0..12 {
            let (sin, cos) = (k as f64 * 0.5).sin_cos();
            let r = filter((t1 * cos + t2 * sin) * 0.25);
            assert!((r - 1.0).abs() < 1e-12, "{r}");
        }
        assert!(filter(n) < 1e-12);
        assert_eq!((f.radius, f.area), (0.25, 0.0625));
    }

    #[test]
    fn degenerate_footprints_are_guarded_and_counted() {
        let limits = FootprintLimits {
            min_radius: 0.01,
            max_radius: 1.0,
            max_anisotropy: 10.0,
        };
        let mut g = Guards::default();
        let f = footprint(
            DVec3::X * 5.0,
            DVec3::Z * 1e-6,
            DVec3::Y,
            &limits,
            0.1,
            &mut g,
        );
        assert!((f.radius - 1.0).abs() < 1e-12 && (f.area - 0.1).abs() < 1e-12);
        assert_eq!(
            (
                g.clamped_max,
                g.clamped_min,
                g.clamped_anisotropy,
                g.fallback
            ),
            (1, 1, 1, 0)
        );
        // A needle whose short axis is 3e-9 of its long one, askew in the tangent frame: the
        // smaller eigenvalue cancelled to zero and took the fallback; it is a needle, clamped.
        let (a, b) = (
            DVec3::new(0.6, 0.0, 0.8) * 0.5,
            DVec3::new(-0.8, 0.0, 0.6) * 1.5e-9,
        );
        let mut needle = Guards::default();
        let f = footprint(a, b, DVec3::Y, &limits, 0.1, &mut needle);
        assert_eq!((needle.fallback, needle.clamped_min), (0, 1), "{needle:?}");
        assert!((f.radius - 0.5).abs() < 1e-12, "{}", f.radius);
        assert!((f.area - 0.5 * 0.05).abs() < 1e-12, "{}", f.area);
        let f = footprint(DVec3::X, DVec3::X, DVec3::Y, &limits, 0.1, &mut g);
        assert_eq!(g.fallback, 1);
        assert!((f.area - 0.01).abs() < 1e-12);
        let f = footprint(DVec3::NAN, DVec3::X, DVec3::Y, &limits, 0.1, &mut g);
        assert_eq!(g.fallback, 2);
        assert!(f.area.is_finite());
    }
}
