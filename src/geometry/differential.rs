//! Ray differentials (Igehy 1999), one type for camera rays and photons.
//!
//! A ray carries its origin `P`, unit direction `D` and their derivatives with respect to two
//! parameters `(u, v)`: pixel coordinates for camera rays, emission parameters for photons.
//! Transfer, reflection and refraction are written once here and tested against finite
//! differences of traced rays.

use glam::DVec3;

/// A ray with its first-order differentials.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayDifferential {
    /// Origin (after a transfer: the hit point).
    pub p: DVec3,
    /// Unit direction.
    pub d: DVec3,
    /// `dP/du`, `dP/dv`.
    pub dp: [DVec3; 2],
    /// `dD/du`, `dD/dv`.
    pub dd: [DVec3; 2],
}

/// The surface at a hit as the differential formulas need it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceFrame {
    /// Unit (shading) normal at the hit, either orientation.
    pub n: DVec3,
    /// Derivatives of `n` with respect to the ray's `(u, v)`.
    pub dn: [DVec3; 2],
}

/// The result of refracting a differential: either transmitted, or totally internally reflected.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Refraction {
    /// The transmitted ray.
    Transmitted(RayDifferential),
    /// Total internal reflection: the reflected ray.
    TotalInternalReflection(RayDifferential),
}

impl RayDifferential {
    /// A ray with zero differentials.
    pub fn new(p: DVec3, d: DVec3) -> Self {
        RayDifferential {
            p,
            d,
            dp: [DVec3::ZERO; 2],
            dd: [DVec3::ZERO; 2],
        }
    }

    /// Moves the ray to distance `t` along `D`, onto a surface with normal `n` (the plane
    /// tangent at the hit): `dP' = dP + t dD + dt D`, `dt = -((dP + t dD) . n) / (D . n)`,
    /// `dD' = dD`. The new differentials lie in the tangent plane.
    pub fn transfer(&self, t: f64, n: DVec3) -> Self {
        let dn = self.d.dot(n);
        let dp = [DVec3::ZERO; 2];
        let mut out = RayDifferential {
            p: self.p + self.d * t,
            d: self.d,
            dp,
            dd: self.dd,
        };
        for k in 0..2 {
            let moved = self.dp[k] + self.dd[k] * t;
            let dt = -moved.dot(n) / dn;
            out.dp[k] = moved + self.d * dt;
        }
        out
    }

    /// Where the ray through the centre of a view-grid cell would have met this ray's surface,
    /// to first order, for a ray jittered to `jitter` within its cell (`(0.5, 0.5)` its centre)
    /// and transferred to its hit `hit`: `hit - dP/du (jx - 1/2) - dP/dv (jy - 1/2)`, `hit`
    /// itself when centred. Progressive passes jitter camera rays; estimates and footprint
    /// shadow rays that integrate over the cell start from its centre, so that the box filter
    /// does not widen into a tent.
    pub fn cell_centre(&self, hit: DVec3, jitter: [f64; 2]) -> DVec3 {
        let [jx, jy] = jitter;
        if [jx, jy] == [0.5, 0.5] {
            return hit;
        }
        hit - (self.dp[0] * (jx - 0.5) + self.dp[1] * (jy - 0.5))
    }

    /// Mirror reflection about `frame.n` at the current origin:
    /// `R = D - 2 (D.n) n`, `dR = dD - 2 [ (D.n) dn + d(D.n) n ]`, `d(D.n) = dD.n + D.dn`.
    pub fn reflect(&self, frame: &SurfaceFrame) -> Self {
        let n = frame.n;
        let d_dot_n = self.d.dot(n);
        let mut out = *self;
        out.d = (self.d - n * (2.0 * d_dot_n)).normalize();
        for k in 0..2 {
            let d_ddotn = self.dd[k].dot(n) + self.d.dot(frame.dn[k]);
            out.dd[k] = self.dd[k] - (frame.dn[k] * d_dot_n + n * d_ddotn) * 2.0;
        }
        out
    }

    /// Refraction from index `n_from` into index `n_to` through a surface with normal
    /// `frame.n` (either orientation; it is turned to face the incoming ray).
    ///
    /// With `eta = n_from / n_to` and `n` oriented so that `D.n < 0`: `T = eta D - mu n`,
    /// `mu = eta (D.n) - (T.n)`, `T.n = -sqrt(1 - eta^2 (1 - (D.n)^2))`,
    /// `dT = eta dD - (mu dn + dmu n)`, `dmu = [eta - eta^2 (D.n) / (T.n)] d(D.n)`.
    /// Total internal reflection gives the reflected ray.
    pub fn refract(&self, frame: &SurfaceFrame, n_from: f64, n_to: f64) -> Refraction {
        let facing = if self.d.dot(frame.n) > 0.0 {
            SurfaceFrame {
                n: -frame.n,
                dn: [-frame.dn[0], -frame.dn[1]],
            }
        } else {
            *frame
        };
        let n = facing.n;
        let eta = n_from / n_to;
        let d_dot_n = self.d.dot(n);
        let radicand = 1.0 - eta * eta * (1.0 - d_dot_n * d_dot_n);
        if radicand <= 0.0 {
            return Refraction::TotalInternalReflection(self.reflect(&facing));
        }
        let t_dot_n = -radicand.sqrt();
        let mu = eta * d_dot_n - t_dot_n;
        let mut out = *self;
        out.d = (self.d * eta - n * mu).normalize();
        for k in 0..2 {
            let d_ddotn = self.dd[k].dot(n) + self.d.dot(facing.dn[k]);
            let dmu = (eta - eta * eta * d_dot_n / t_dot_n) * d_ddotn;
            out.dd[k] = self.dd[k] * eta - (facing.dn[k] * mu + n * dmu);
        }
        Refraction::Transmitted(out)
    }

    /// Through glass `g` at this hit (`frame` its surface): reflected when `u` (uniform in
    /// [0, 1)) falls below the Fresnel reflectance, refracted otherwise, so that the carried
    /// power needs no weight.
    pub fn through_glass(&self, frame: &SurfaceFrame, g: &GlassInterface, u: f64) -> Self {
        if u < g.reflectance {
            self.reflect(frame)
        } else {
            match self.refract(frame, g.n_from, g.n_to) {
                Refraction::Transmitted(t) => t,
                Refraction::TotalInternalReflection(r) => r,
            }
        }
    }
}

/// A glass surface of index `ior` (outside 1) met by a ray: the indices the ray goes from and
/// into and the Fresnel reflectance there. Shared by camera paths (which follow both branches),
/// light paths and gather rays (which choose one, [`RayDifferential::through_glass`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GlassInterface {
    /// Index on the ray's side.
    pub n_from: f64,
    /// Index on the other side.
    pub n_to: f64,
    /// Fresnel reflectance (1 under total internal reflection).
    pub reflectance: f64,
}

impl GlassInterface {
    /// Glass of index `ior` met along `d`, entering when `d` opposes the geometric normal
    /// `ng`; the reflectance is taken about the shading normal `n` facing the ray.
    pub fn new(d: DVec3, ng: DVec3, n: DVec3, ior: f64) -> Self {
        let entering = d.dot(ng) < 0.0;
        let (n_from, n_to) = if entering { (1.0, ior) } else { (ior, 1.0) };
        GlassInterface {
            n_from,
            n_to,
            reflectance: fresnel_dielectric(-d.dot(n), n_from, n_to),
        }
    }
}

/// Fresnel reflectance of an unpolarised wave at a dielectric interface, for the cosine
/// `cos_i` (> 0) of the incident angle, going from index `n_from` into `n_to`. 1 under total
/// internal reflection.
pub fn fresnel_dielectric(cos_i: f64, n_from: f64, n_to: f64) -> f64 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let eta = n_from / n_to;
    let sin_t2 = eta * eta * (1.0 - cos_i * cos_i);
    if sin_t2 >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin_t2).sqrt();
    let r_par = (n_to * cos_i - n_from * cos_t) / (n_to * cos_i + n_from * cos_t);
    let r_perp = (n_from * cos_i - n_to * cos_t) / (n_from * cos_i + n_to * cos_t);
    0.5 * (r_par * r_par + r_perp * r_perp)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ray without direction differentials (parallel rays) meets a plane at points linear
    /// in the cell's coordinates, so the first-order cell centre of a jittered ray is exactly
    /// where the centre's ray meets it.
    #[test]
    fn a_jittered_rays_cell_centre_is_where_the_centres_ray_hits() {
        let d = DVec3::new(0.1, -1.0, 0.2).normalize();
        let n = DVec3::new(0.3, 1.0, -0.4).normalize();
        let cell = RayDifferential {
            dp: [DVec3::new(0.01, 0.0, 0.0), DVec3::new(0.0, 0.002, 0.013)],
            ..RayDifferential::new(DVec3::new(0.2, 3.0, -0.1), d)
        };
        // A plane through the origin with normal n: t = -(p . n) / (d . n).
        let hit = |p: DVec3| p + d * (-p.dot(n) / d.dot(n));
        let centre_hit = hit(cell.p);
        for jitter in [[0.5, 0.5], [0.1, 0.9], [0.97, 0.03], [0.5, 0.2]] {
            let p = cell.p + cell.dp[0] * (jitter[0] - 0.5) + cell.dp[1] * (jitter[1] - 0.5);
            let ray = RayDifferential { p, ..cell };
            let at = hit(p);
            let t = (at - p).dot(d);
            let moved = ray.transfer(t, n);
            let back = moved.cell_centre(at, jitter);
            assert!(
                (back - centre_hit).length() < 1e-12,
                "{jitter:?}: {back} {centre_hit}"
            );
        }
        assert_eq!(cell.cell_centre(DVec3::ONE, [0.5, 0.5]), DVec3::ONE);
    }

    #[test]
    fn fresnel_at_normal_incidence_is_the_textbook_value() {
        let r = fresnel_dielectric(1.0, 1.0, 1.5);
        assert!((r - 0.04).abs() < 1e-12, "{r}");
        assert_eq!(fresnel_dielectric(0.1, 1.5, 1.0), 1.0);
        // Reciprocity of the reflectance across the interface at matching angles.
        let cos_i: f64 = 0.8;
        let sin_t = (1.0 - cos_i * cos_i).sqrt() / 1.5;
        let cos_t = (1.0 - sin_t * sin_t).sqrt();
        let a = fresnel_dielectric(cos_i, 1.0, 1.5);
        let b = fresnel_dielectric(cos_t, 1.5, 1.0);
        assert!((a - b).abs() < 1e-12);
    }
}
