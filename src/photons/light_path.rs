//! Paths of light from the lights through the scene: shared by photon tracing and the
//! light-tracing reference. Glass chooses reflection or refraction with the Fresnel probability,
//! mirrors and diffuse surfaces use Russian roulette on their reflectance, diffuse bounces
//! sample the cosine lobe; the ray differential is carried along with the same code as camera
//! rays.

use crate::embree::{self, Hit, Ray};
use crate::geometry::differential::{fresnel_dielectric, RayDifferential, Refraction};
use crate::geometry::sampling::{sample_cosine, tangent_frame};
use crate::geometry::surface::{continuation, surface_frame, transfer_to};
use crate::photons::emission::Emission;
use crate::scene::{Material, Scene};
use crate::util::rng::Rng;
use glam::DVec3;

/// Where a light path meets a diffuse surface.
#[derive(Debug, Clone, Copy)]
pub struct DiffuseHit<'a> {
    /// The hit.
    pub hit: &'a Hit,
    /// The ray differential transferred to the hit.
    pub ray: &'a RayDifferential,
    /// Geometric normal facing the incoming light.
    pub normal: DVec3,
    /// The surface's albedo.
    pub albedo: DVec3,
    /// Power arriving (for a single emission).
    pub power: DVec3,
    /// Length of the path from the light.
    pub path_length: f64,
    /// Specular bounces before this hit.
    pub specular_bounces: u32,
    /// Diffuse bounces before this hit.
    pub diffuse_bounces: u32,
}

/// Follows light paths through one scene.
pub struct LightPaths<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// Its Embree scene.
    pub embree: &'a embree::Scene,
    /// Maximum number of surfaces a path meets.
    pub max_bounces: u32,
    /// Radius of the angular differentials given to light leaving a diffuse surface.
    pub diffuse_spread: f64,
    /// Length skipped at the start of rays leaving a surface (see [`continuation`]);
    /// [`Scene::ray_epsilon`], computed once: it walks every vertex.
    pub epsilon: f64,
}

impl LightPaths<'_> {
    /// Follows `emission`, calling `visit` at every diffuse hit; the path goes on past it only
    /// when `visit` answers `true`. Returns the number of rays traced.
    pub fn walk(
        &self,
        emission: Emission,
        rng: &mut Rng,
        mut visit: impl FnMut(&DiffuseHit) -> bool,
    ) -> u64 {
        let mut ray = emission.ray;
        let mut power = emission.power;
        let (mut specular, mut diffuse) = (0u32, 0u32);
        let mut path_length = 0.0;
        // The first segment leaves the light itself.
        let mut tnear = 0.0;
        let mut rays = 0;
        for _ in 0..self.max_bounces {
            rays += 1;
            let query = Ray {
                tnear,
                ..continuation(&ray, 0.0)
            };
            tnear = self.epsilon;
            let Some(hit) = self.embree.intersect(&query) else {
                break;
            };
            let at = transfer_to(&ray, &hit);
            path_length += (hit.position - ray.p).length();
            let (frame, ng) = surface_frame(&hit, &at);
            match *self.scene.material(hit.geom_id) {
                Material::Emitter { .. } => break,
                Material::Diffuse { albedo } => {
                    let go_on = visit(&DiffuseHit {
                        hit: &hit,
                        ray: &at,
                        normal: ng,
                        albedo,
                        power,
                        path_length,
                        specular_bounces: specular,
                        diffuse_bounces: diffuse,
                    });
                    // Russian roulette on the largest albedo channel.
                    let q = albedo.max_element();
                    if !go_on || q <= 0.0 || rng.uniform() >= q {
                        break;
                    }
                    power *= albedo / q;
                    let n = if frame.n.dot(ng) > 0.0 { frame.n } else { ng };
                    let d = sample_cosine(n, rng.uniform(), rng.uniform());
                    let (t1, t2) = tangent_frame(d);
                    ray = RayDifferential {
                        p: at.p,
                        d,
                        dp: at.dp,
                        dd: [t1 * self.diffuse_spread, t2 * self.diffuse_spread],
                    };
                    diffuse += 1;
                }
                Material::Mirror { reflectance } => {
                    let q = reflectance.max_element();
                    if q <= 0.0 || rng.uniform() >= q {
                        break;
                    }
                    power *= reflectance / q;
                    ray = at.reflect(&frame);
                    specular += 1;
                }
                Material::Glass { ior } => {
                    let entering = at.d.dot(hit.geometric_normal) < 0.0;
                    let (n_from, n_to) = if entering { (1.0, ior) } else { (ior, 1.0) };
                    let f = fresnel_dielectric(-at.d.dot(frame.n), n_from, n_to);
                    // Reflect with probability F, refract otherwise: the power is unchanged.
                    ray = if rng.uniform() < f {
                        at.reflect(&frame)
                    } else {
                        match at.refract(&frame, n_from, n_to) {
                            Refraction::Transmitted(t) => t,
                            Refraction::TotalInternalReflection(r) => r,
                        }
                    };
                    specular += 1;
                }
            }
        }
        rays
    }
}
