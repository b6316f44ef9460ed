//! Camera paths through mirror and glass to their diffuse hits, with ray differentials.
//!
//! Reflection and refraction are both followed, weighted by Fresnel: deterministic, no random
//! choice, up to [`ViewPaths::split_depth`] mirror and glass bounces (by default at every
//! glass surface); beyond it a glass surface takes one branch, chosen with Fresnel's
//! probability. A branch ends at a diffuse surface, a light, a miss, the depth limit, or when
//! its weight drops below [`MIN_BRANCH_WEIGHT`].
//!
//! Why a choice at all: splitting doubles a path at every glass surface it meets, so a path
//! through many glass objects (the production scene's hundred balls) grows into a tree of
//! hundreds of rays, most of them carrying little. One branch chosen with its Fresnel
//! probability carries the path's whole weight (the branch's weight `F` over its probability
//! `F`), so the image's expectation is the split one's; each pass is noisier, and cheaper.

use crate::embree::{self, Hit};
use crate::geometry::differential::{GlassInterface, RayDifferential, Refraction};
use crate::geometry::surface::{continuation, mirror_frame, surface_frame, transfer_to};
use crate::render::stats::RayCounts;
use crate::scene::{Material, Scene};
use crate::util::rng::Rng;
use glam::DVec3;

/// Branches whose largest channel weight falls below this are dropped: they would change a
/// pixel by less than 0.1% of what the same path contributes at full weight.
pub const MIN_BRANCH_WEIGHT: f64 = 1e-3;

/// Where a camera path meets a diffuse surface.
#[derive(Debug, Clone, Copy)]
pub struct DiffuseVertex {
    /// The hit.
    pub hit: Hit,
    /// The ray differential transferred to the hit (its footprint at the hit).
    pub ray: RayDifferential,
    /// Path weight: product of specular reflectances and Fresnel factors, times the sample's
    /// share of its pixel.
    pub weight: DVec3,
    /// The diffuse albedo.
    pub albedo: DVec3,
    /// Which camera sample of the tile this vertex belongs to.
    pub sample: usize,
    /// Mirror and glass bounces between the camera and this hit (0: seen directly).
    pub depth: u32,
}

/// Follows camera paths; shared by all the samples of a tile.
pub struct ViewPaths<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// Its Embree scene.
    pub embree: &'a embree::Scene,
    /// Maximum number of specular bounces.
    pub max_depth: u32,
    /// Mirror and glass bounces after which a glass surface takes one branch (reflected with
    /// probability `F`, Fresnel's reflectance, else refracted) rather than both; `None`: both
    /// at every glass surface. `Some(0)` chooses at every one.
    pub split_depth: Option<u32>,
    /// Length skipped at the start of rays leaving a surface (`tnear`: the ray starts on the
    /// surface, see `geometry::surface::continuation`).
    pub epsilon: f64,
}

/// What following one path produced besides diffuse vertices.
#[derive(Debug, Default, Clone, Copy)]
pub struct PathTally {
    /// Rays traced after a specular bounce.
    pub rays: RayCounts,
    /// Branches cut by the depth limit.
    pub cut_at_max_depth: u64,
}

impl ViewPaths<'_> {
    /// Processes the first hit of `ray` (already traced): collects diffuse vertices into
    /// `vertices`, adds directly seen emission into `radiance`, follows specular branches.
    #[allow(clippy::too_many_arguments)]
    pub fn follow(
        &self,
        ray: &RayDifferential,
        hit: Option<Hit>,
        weight: DVec3,
        depth: u32,
        sample: usize,
        vertices: &mut Vec<DiffuseVertex>,
        radiance: &mut DVec3,
        tally: &mut PathTally,
        rng: &mut Rng,
    ) {
        let Some(hit) = hit else { return };
        let at_hit = transfer_to(ray, &hit);
        let d = ray.d;
        let (frame, ng) = surface_frame(&hit, &at_hit);
        match *self.scene.material(hit.geom_id) {
            Material::Diffuse { albedo } => vertices.push(DiffuseVertex {
                hit,
                ray: at_hit,
                weight,
                albedo,
                sample,
                depth,
            }),
            Material::Emitter { radiance: le } => {
                if d.dot(hit.geometric_normal) < 0.0 {
                    *radiance += weight * le;
                }
            }
            Material::Mirror { reflectance } => {
                let reflected = at_hit.reflect(&mirror_frame(frame, ng, d));
                self.branch(
                    reflected,
                    weight * reflectance,
                    depth,
                    sample,
                    vertices,
                    radiance,
                    tally,
                    rng,
                );
            }
            Material::Glass { ior } => {
                let glass = GlassInterface::new(d, hit.geometric_normal, frame.n, ior);
                let f = glass.reflectance;
                match at_hit.refract(&frame, glass.n_from, glass.n_to) {
                    Refraction::Transmitted(t) => {
                        let reflected = at_hit.reflect(&frame);
                        if self.split_depth.is_some_and(|n| depth >= n) {
                            // The chosen branch's weight `F` (or `1 - F`) over its probability.
                            let ray = if rng.uniform() < f { reflected } else { t };
                            self.branch(ray, weight, depth, sample, vertices, radiance, tally, rng);
                            return;
                        }
                        self.branch(
                            reflected,
                            weight * f,
                            depth,
                            sample,
                            vertices,
                            radiance,
                            tally,
                            rng,
                        );
                        self.branch(
                            t,
                            weight * (1.0 - f),
                            depth,
                            sample,
                            vertices,
                            radiance,
                            tally,
                            rng,
                        );
                    }
                    Refraction::TotalInternalReflection(r) => {
                        self.branch(r, weight, depth, sample, vertices, radiance, tally, rng);
                    }
                }
            }
        }
    }

    /// Traces a specular continuation.
    #[allow(clippy::too_many_arguments)]
    fn branch(
        &self,
        ray: RayDifferential,
        weight: DVec3,
        depth: u32,
        sample: usize,
        vertices: &mut Vec<DiffuseVertex>,
        radiance: &mut DVec3,
        tally: &mut PathTally,
        rng: &mut Rng,
    ) {
        if weight.max_element() < MIN_BRANCH_WEIGHT {
            return;
        }
        if depth + 1 > self.max_depth {
            tally.cut_at_max_depth += 1;
            return;
        }
        tally.rays.specular += 1;
        let hit = self.embree.intersect(&continuation(&ray, self.epsilon));
        self.follow(
            &ray,
            hit,
            weight,
            depth + 1,
            sample,
            vertices,
            radiance,
            tally,
            rng,
        );
    }
}
