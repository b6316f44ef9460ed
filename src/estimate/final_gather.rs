//! Final gathering (Jensen's two-pass method): indirect diffuse light at a camera path's diffuse
//! hit from `N` stratified cosine-distributed gather rays instead of the global map seen
//! directly.
//!
//! Each gather ray passes through mirrors and glass (glass chooses reflection or refraction with
//! the Fresnel probability, so the weight stays that of the mirrors) to its first diffuse hit,
//! and there reads the radiance leaving that point from the radiance map
//! ([`crate::photons::radiance_map`]): all the light leaving it, direct, caustic and indirect.
//! A gather ray that meets a light adds nothing: light that reaches the camera hit from a light,
//! directly or through mirrors and glass, is the direct estimate's and the caustic map's.
//!
//! With cosine sampling, `f_r L cos(theta) / pdf = (albedo / pi) L cos / (cos / pi)`, so the
//! estimate is `albedo * mean(L)` over the gather rays.
//!
//! Gather directions are stratified: ray `i` of `N` takes the `i`-th of `N` strata of the
//! cosine map's first coordinate and a golden-ratio (rank-1 lattice) step in the second, both
//! shifted by a random offset per hit. The offset's random stream is seeded by the run's seed
//! and the hit's position, so an image is the same on any number of threads.

use super::{GatherCounts, GatherQuery, RadianceEstimator};
use crate::embree;
use crate::geometry::differential::{GlassInterface, RayDifferential};
use crate::geometry::sampling::sample_cosine;
use crate::geometry::surface::{continuation, facing, surface_frame, transfer_to};
use crate::photons::radiance_map::RadianceMap;
use crate::scene::{Material, Scene};
use crate::util::rng::Rng;
use glam::DVec3;

/// Most gather rays per diffuse hit (`--gather-rays`).
pub const MAX_GATHER_RAYS: u32 = 4096;

/// `(sqrt(5) - 1) / 2`: the golden-ratio step of the second coordinate.
const GOLDEN: f64 = 0.618_033_988_749_894_9;

/// The final-gather estimate of indirect diffuse light.
pub struct FinalGather<'a> {
    /// The scene (materials).
    pub scene: &'a Scene,
    /// Its Embree scene.
    pub embree: &'a embree::Scene,
    /// Radiance leaving diffuse surfaces.
    pub map: &'a RadianceMap,
    /// Gather rays per estimate (at least 1).
    pub rays: u32,
    /// Most mirror and glass bounces of a gather ray.
    pub max_depth: u32,
    /// Seed of the gather directions' random streams.
    pub seed: u64,
    /// Length skipped at the start of rays leaving a surface.
    pub epsilon: f64,
}

impl FinalGather<'_> {
    /// Radiance arriving at `origin` from direction `d`: leaving the first diffuse surface
    /// met through mirrors and glass, times the mirrors' reflectance.
    fn incoming(&self, origin: DVec3, d: DVec3, rng: &mut Rng, counts: &mut GatherCounts) -> DVec3 {
        let mut ray = RayDifferential::new(origin, d);
        let mut weight = DVec3::ONE;
        for _ in 0..=self.max_depth {
            counts.gather_rays += 1;
            let Some(hit) = self.embree.intersect(&continuation(&ray, self.epsilon)) else {
                return DVec3::ZERO;
            };
            let at_hit = transfer_to(&ray, &hit);
            let (frame, _) = surface_frame(&hit, &at_hit);
            match *self.scene.material(hit.geom_id) {
                Material::Diffuse { .. } => {
                    let n = facing(hit.geometric_normal, ray.d);
                    return weight * self.map.radiance(hit.position, n);
                }
                Material::Emitter { .. } => return DVec3::ZERO,
                Material::Mirror { reflectance } => {
                    weight *= reflectance;
                    ray = at_hit.reflect(&frame);
                }
                Material::Glass { ior } => {
                    let glass = GlassInterface::new(ray.d, hit.geometric_normal, frame.n, ior);
                    ray = at_hit.through_glass(&frame, &glass, rng.uniform());
                }
            }
            if weight.max_element() <= 0.0 {
                return DVec3::ZERO;
            }
        }
        DVec3::ZERO
    }
}

/// A random-stream index from a position's bits: the same hit gathers the same directions
/// whichever thread renders it.
fn position_index(x: DVec3) -> u64 {
    let [a, b, c] = x.to_array().map(f64::to_bits);
    a ^ b.rotate_left(21) ^ c.rotate_left(42)
}

impl RadianceEstimator for FinalGather<'_> {
    fn radiance(&self, q: &GatherQuery, counts: &mut GatherCounts) -> DVec3 {
        counts.final_gathers += 1;
        let n = self.rays.max(1);
        let mut rng = Rng::new(self.seed, position_index(q.position));
        let (s0, s1) = (rng.uniform(), rng.uniform());
        let mut sum = DVec3::ZERO;
        for i in 0..n {
            let u = (i as f64 + s0) / n as f64;
            let v = (i as f64 * GOLDEN + s1).fract();
            let d = sample_cosine(q.normal, u, v);
            sum += self.incoming(q.position, d, &mut rng, counts);
        }
        q.albedo * sum / n as f64
    }
}
