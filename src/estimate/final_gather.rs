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
//! A gather ray that lands close by is traced one bounce further (Jensen's remedy,
//! [`NearGather`]): the radiance map's value at a point is an average over a disc of photons, and
//! where that disc reaches over an edge onto another wall (whose photons face away and do not
//! count) it is too dark. From afar such a disc subtends a sliver of the hemisphere; from close
//! by, in a corner, it fills half of it. So where the path to the diffuse hit is shorter than a
//! few times the disc's radius, the light leaving the hit is computed there instead: direct
//! light by shadow rays (the renderer's, through [`DirectAt`]), caustics from the caustic map,
//! and indirect light from a few gather rays of its own that read the radiance map.
//!
//! Gather directions are stratified: ray `i` of `N` takes the `i`-th of `N` strata of the
//! cosine map's first coordinate and a golden-ratio (rank-1 lattice) step in the second, both
//! shifted by a random offset per hit. The offset's random stream is seeded by the run's seed
//! and the hit's position, so an image is the same on any number of threads.

use super::{GatherCounts, GatherQuery, PhotonDifferentialEstimate, RadianceEstimator};
use crate::embree;
use crate::geometry::differential::{GlassInterface, RayDifferential};
use crate::geometry::sampling::sample_cosine;
use crate::geometry::surface::{continuation, facing, mirror_frame, surface_frame, transfer_to};
use crate::photons::map::PhotonMap;
use crate::photons::radiance_map::RadianceMap;
use crate::scene::{Material, Scene};
use crate::util::rng::Rng;
use glam::DVec3;

/// Most gather rays per diffuse hit (`--gather-rays`).
pub const MAX_GATHER_RAYS: u32 = 4096;

/// The default of `--gather-near`: gather rays whose path to their diffuse hit is shorter than
/// this many radii of the radiance map's disc there go a bounce further ([`NearGather`]).
/// Measured on `cornell-glass` (`cargo bench --bench closed_scene`): 2 and 4 gave the same
/// errors on every wall (within 0.03 points), both below 0 (off) by 0.16-0.35 points.
pub const NEAR_REACH: f64 = 2.0;

/// Largest `--gather-near`.
pub const MAX_NEAR_REACH: f64 = 1000.0;

/// Gather rays of the bounce further, per ray that lands close by.
pub const NEAR_RAYS: u32 = 2;

/// `(sqrt(5) - 1) / 2`: the golden-ratio step of the second coordinate.
const GOLDEN: f64 = 0.618_033_988_749_894_9;

/// Direct light leaving a diffuse hit, for gather rays traced a bounce further: the renderer's
/// shadow rays (`render::direct_light`), behind an interface because direct light belongs to the
/// stage above the estimates.
pub trait DirectAt: Sync {
    /// Radiance leaving `hit` (diffuse, `albedo`) back along `ray` from the lights directly.
    fn reflected(
        &self,
        hit: &embree::Hit,
        ray: &RayDifferential,
        albedo: DVec3,
        rng: &mut Rng,
    ) -> DVec3;
}

/// How gather rays that land close by are traced one bounce further (see the module
/// documentation).
pub struct NearGather<'a> {
    /// Direct light at their hits.
    pub direct: &'a dyn DirectAt,
    /// The caustic map, for caustics at their hits (the photon-differential point estimate).
    pub caustic: &'a PhotonMap,
    /// A gather ray goes a bounce further where its path to the diffuse hit is shorter than
    /// this many radii of the radiance map's disc there (positive: `--gather-near 0` leaves
    /// [`FinalGather::near`] empty).
    pub reach: f64,
    /// Gather rays of the bounce further (at least 1; they read the radiance map).
    pub rays: u32,
}

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
    /// Gather rays that land close by go a bounce further; `None` (`--gather-near 0`): every
    /// one reads the map.
    pub near: Option<NearGather<'a>>,
}

impl FinalGather<'_> {
    /// Radiance arriving at `origin` from direction `d`: leaving the first diffuse surface
    /// met through mirrors and glass, times the mirrors' reflectance. `further`: whether a path
    /// that lands close by may go a bounce further ([`NearGather`]).
    fn incoming(
        &self,
        origin: DVec3,
        d: DVec3,
        further: bool,
        rng: &mut Rng,
        counts: &mut GatherCounts,
    ) -> DVec3 {
        let mut ray = RayDifferential::new(origin, d);
        let mut weight = DVec3::ONE;
        let mut length = 0.0;
        for _ in 0..=self.max_depth {
            counts.gather_rays += 1;
            let Some(hit) = self.embree.intersect(&continuation(&ray, self.epsilon)) else {
                return DVec3::ZERO;
            };
            // The ray starts at `ray.p` (its offset is `tnear`): `t` is the segment's length.
            length += hit.t;
            let at_hit = transfer_to(&ray, &hit);
            let (frame, ng) = surface_frame(&hit, &at_hit);
            match *self.scene.material(hit.geom_id) {
                Material::Diffuse { albedo } => {
                    let n = facing(hit.geometric_normal, ray.d);
                    let Some((radiance, radius2)) = self.map.lookup(hit.position, n) else {
                        return DVec3::ZERO;
                    };
                    return match &self.near {
                        Some(near) if further && length * length < near.reach.powi(2) * radius2 => {
                            counts.near_gathers += 1;
                            weight * self.leaving(near, &hit, &at_hit, albedo, rng, counts)
                        }
                        _ => weight * radiance,
                    };
                }
                Material::Emitter { .. } => return DVec3::ZERO,
                Material::Mirror { reflectance } => {
                    weight *= reflectance;
                    ray = at_hit.reflect(&mirror_frame(frame, ng, ray.d));
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

    /// Radiance leaving the diffuse hit of a gather ray that landed close by, computed there:
    /// direct light, caustics, and indirect light from `near.rays` cosine rays reading the map.
    fn leaving(
        &self,
        near: &NearGather,
        hit: &embree::Hit,
        at_hit: &RayDifferential,
        albedo: DVec3,
        rng: &mut Rng,
        counts: &mut GatherCounts,
    ) -> DVec3 {
        let n = facing(hit.geometric_normal, at_hit.d);
        let direct = near.direct.reflected(hit, at_hit, albedo, rng);
        let query = GatherQuery {
            position: hit.position,
            normal: n,
            albedo,
            footprint: [DVec3::ZERO; 2],
            exact: None,
        };
        let caustic = PhotonDifferentialEstimate { map: near.caustic }.radiance(&query, counts);
        let m = near.rays.max(1);
        let mut indirect = DVec3::ZERO;
        for i in 0..m {
            let u = (i as f64 + rng.uniform()) / m as f64;
            let d = sample_cosine(n, u, rng.uniform());
            indirect += self.incoming(hit.position, d, false, rng, counts);
        }
        direct + caustic + albedo * indirect / m as f64
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
        self.radiance_share(q, 1.0, counts)
    }

    /// `share` of the gather rays (rounded up, at least one).
    fn radiance_share(&self, q: &GatherQuery, share: f64, counts: &mut GatherCounts) -> DVec3 {
        counts.final_gathers += 1;
        let n = ((self.rays as f64 * share.clamp(0.0, 1.0)).ceil() as u32).max(1);
        let mut rng = Rng::new(self.seed, position_index(q.position));
        let (s0, s1) = (rng.uniform(), rng.uniform());
        let mut sum = DVec3::ZERO;
        for i in 0..n {
            let u = (i as f64 + s0) / n as f64;
            let v = (i as f64 * GOLDEN + s1).fract();
            let d = sample_cosine(q.normal, u, v);
            sum += self.incoming(q.position, d, true, &mut rng, counts);
        }
        q.albedo * sum / n as f64
    }
}
