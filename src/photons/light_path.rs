//! Paths of light from the lights through the scene: shared by photon tracing and the
//! light-tracing reference. Glass chooses reflection or refraction with the Fresnel probability,
//! mirrors and diffuse surfaces use Russian roulette on their reflectance, diffuse bounces
//! sample the cosine lobe; the ray differential is carried along with the same code as camera
//! rays.

use crate::embree::{self, Hit, Ray};
use crate::geometry::differential::{GlassInterface, RayDifferential};
use crate::geometry::sampling::sample_cosine;
use crate::geometry::surface::{continuation, mirror_frame, surface_frame, transfer_to};
use crate::photons::emission::{round_beam, Emission, Launch};
use crate::photons::targets::DiffuseAim;
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

/// Mirror and glass surfaces a light path meets in a row at most (the path ends at the last):
/// light caught by total internal reflection (a point light just inside a glass sphere) or in
/// a closed mirror box goes on without end, as Russian roulette on a perfect reflector never
/// ends it. Its paths took up to the whole surface cap each (1,024; tracing a map 80 times
/// as long as the same light outside the sphere at 64). Diffuse bounces, which roulette ends,
/// are bounded by `max_bounces` alone.
pub const MAX_SPECULAR_RUN: u32 = 64;

/// Follows light paths through one scene.
#[derive(Clone)]
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
    /// Where diffuse bounces are drawn from a mixture aimed at the specular objects (global
    /// photons); `None` draws them from the cosine lobe alone (the other maps, the reference).
    pub aim: Option<DiffuseAim>,
}

/// A light path between two queries: what [`LightPaths::advance`] needs to go on. Paths are
/// resumable so that many can be traced side by side in 16-wide packets
/// ([`LightPaths::walk_packets`]) with exactly the steps of [`LightPaths::walk`].
#[derive(Debug, Clone)]
pub struct PathState {
    ray: RayDifferential,
    power: DVec3,
    specular: u32,
    diffuse: u32,
    path_length: f64,
    /// Start of the next query: the scene's epsilon, which [`LightPaths`] sets before the
    /// first query too (a quad light's photons leave its own surface, which a robust BVH
    /// reports hit at `t = 0`: every path ended there).
    tnear: f64,
    /// Surfaces met so far.
    bounces: u32,
    /// Mirror and glass surfaces met in a row since the light or the last diffuse surface.
    specular_run: u32,
    /// A round beam the emission or the last diffuse bounce left to spell out ([`Launch`]):
    /// `ray.dd` is set from it at the next hit, before anything reads it.
    spread: Option<f64>,
}

impl PathState {
    /// The path of `emission`, before its first query.
    pub fn new(emission: Emission) -> Self {
        PathState {
            ray: emission.ray,
            power: emission.power,
            specular: 0,
            diffuse: 0,
            path_length: 0.0,
            tnear: 0.0,
            bounces: 0,
            specular_run: 0,
            spread: None,
        }
    }

    /// Starts the path of `launch` in place (field by field: a lane's state is rewritten at
    /// every emission, and a whole-struct move goes through `memcpy`).
    #[inline]
    pub fn start(&mut self, launch: &Launch) {
        // Every field named, so that a field added to the state cannot be left stale here
        // (`new` builds the same state as a literal).
        let PathState {
            ray,
            power,
            specular,
            diffuse,
            path_length,
            tnear,
            bounces,
            specular_run,
            spread,
        } = self;
        let e = &launch.emission.ray;
        (ray.p, ray.d, ray.dp, ray.dd) = (e.p, e.d, e.dp, e.dd);
        *power = launch.emission.power;
        *spread = launch.spread;
        (*specular, *diffuse, *bounces, *specular_run) = (0, 0, 0, 0);
        (*path_length, *tnear) = (0.0, 0.0);
    }

    /// The next ray to trace.
    pub fn query(&self) -> Ray {
        continuation(&self.ray, self.tnear)
    }

    /// Writes [`PathState::query`] into `out` field by field: a query built whole is
    /// assembled on the stack and copied from there, a copy that waits for those stores.
    #[inline]
    fn write_query(&self, out: &mut Ray) {
        let Ray {
            origin,
            direction,
            tnear,
            tfar,
        } = out;
        let q = self.query();
        (*origin, *direction, *tnear, *tfar) = (q.origin, q.direction, q.tnear, q.tfar);
    }
}

impl LightPaths<'_> {
    /// Follows `emission`, calling `visit` at every diffuse hit; the path goes on past it only
    /// when `visit` answers `true`. Returns the number of rays traced.
    pub fn walk(
        &self,
        emission: Emission,
        rng: &mut Rng,
        visit: impl FnMut(&DiffuseHit) -> bool,
    ) -> u64 {
        self.walk_with(emission, rng, |q| self.embree.intersect(q), visit)
    }

    /// [`LightPaths::walk`] with its queries answered by `intersect` (which may, say, record
    /// them before asking Embree).
    pub fn walk_with(
        &self,
        emission: Emission,
        rng: &mut Rng,
        mut intersect: impl FnMut(&Ray) -> Option<Hit>,
        mut visit: impl FnMut(&DiffuseHit) -> bool,
    ) -> u64 {
        let mut state = PathState::new(emission);
        state.tnear = self.epsilon;
        let mut rays = 0;
        while state.bounces < self.max_bounces {
            rays += 1;
            let hit = intersect(&state.query());
            if !self.advance(&mut state, hit.as_ref(), rng, &mut visit) {
                break;
            }
        }
        rays
    }

    /// Follows many paths at once, 16 to a packet: `next` starts a new path in a lane that fell
    /// free (it starts the lane's state with [`PathState::start`], sets its random stream and
    /// answers the path's tag, a value of the caller's; `None` when no path is left), `visit` is called at
    /// every diffuse hit with the path's tag (as in [`LightPaths::walk`]), and `done` receives
    /// each finished path's tag and its number of rays. Every path takes exactly the steps
    /// `walk` would take with the same random stream: only the grouping of its queries into
    /// Embree calls differs, which lets Embree trace 16 rays per call and lets the hits' mesh
    /// data be fetched for 16 lanes at once (their cache misses overlap).
    pub fn walk_packets<T>(
        &self,
        mut next: impl FnMut(&mut PathState, &mut Rng) -> Option<T>,
        mut visit: impl FnMut(&T, &DiffuseHit) -> bool,
        mut done: impl FnMut(T, u64),
    ) {
        const WIDTH: usize = embree::PACKET_WIDTH;
        // The lanes' parts in separate arrays, written in place: paths start and end at
        // every step, and moving whole lanes about would copy hundreds of bytes each time.
        let mut tags: [Option<T>; WIDTH] = std::array::from_fn(|_| None);
        let mut states: [PathState; WIDTH] = std::array::from_fn(|_| {
            PathState::new(Emission {
                ray: RayDifferential::new(DVec3::ZERO, DVec3::X),
                power: DVec3::ZERO,
            })
        });
        let mut rngs: [Rng; WIDTH] = std::array::from_fn(|_| Rng::new(0, 0));
        let mut rays = [0u64; WIDTH];
        let mut exhausted = false;
        let mut queries = [Ray::new(DVec3::ZERO, DVec3::X); WIDTH];
        let mut active = [0usize; WIDTH];
        loop {
            // Lanes are refilled first and their queries gathered after: a query read back
            // right after its lane's emission was written waits for those stores to land.
            for k in 0..WIDTH {
                if tags[k].is_none() && !exhausted {
                    match next(&mut states[k], &mut rngs[k]) {
                        Some(tag) => {
                            tags[k] = Some(tag);
                            rays[k] = 0;
                            states[k].tnear = self.epsilon;
                        }
                        None => exhausted = true,
                    }
                }
            }
            let mut n = 0;
            for k in 0..WIDTH {
                if tags[k].is_some() {
                    if states[k].bounces < self.max_bounces {
                        states[k].write_query(&mut queries[n]);
                        active[n] = k;
                        n += 1;
                    } else {
                        done(tags[k].take().expect("checked"), rays[k]);
                    }
                }
            }
            if n == 0 {
                if exhausted {
                    return;
                }
                continue;
            }
            // Each lane moves on as its answer comes (a hit is used where it was made).
            self.embree
                .intersect16_each(&queries[..n], false, |j, hit| {
                    let k = active[j];
                    rays[k] += 1;
                    let tag = tags[k].as_ref().expect("active lane");
                    let go_on = self.advance(&mut states[k], hit, &mut rngs[k], |v| visit(tag, v));
                    if !go_on {
                        done(tags[k].take().expect("active lane"), rays[k]);
                    }
                });
        }
    }

    /// Moves `state` on by the answer `hit` to its query; `visit` as in [`LightPaths::walk`].
    /// Returns whether the path goes on.
    pub fn advance(
        &self,
        state: &mut PathState,
        hit: Option<&Hit>,
        rng: &mut Rng,
        mut visit: impl FnMut(&DiffuseHit) -> bool,
    ) -> bool {
        state.bounces += 1;
        state.tnear = self.epsilon;
        let Some(hit) = hit else {
            return false;
        };
        if let Some(spread) = state.spread.take() {
            state.ray.dd = round_beam(state.ray.d, spread);
        }
        let ray = &state.ray;
        let at = transfer_to(ray, hit);
        state.path_length += (hit.position - ray.p).length();
        let (frame, ng) = surface_frame(hit, &at);
        match *self.scene.material(hit.geom_id) {
            Material::Emitter { .. } => false,
            Material::Diffuse { albedo } => {
                let go_on = visit(&DiffuseHit {
                    hit,
                    ray: &at,
                    normal: ng,
                    albedo,
                    power: state.power,
                    path_length: state.path_length,
                    specular_bounces: state.specular,
                    diffuse_bounces: state.diffuse,
                });
                // Russian roulette on the largest albedo channel.
                let q = albedo.max_element();
                if !go_on || q <= 0.0 || rng.uniform() >= q {
                    return false;
                }
                state.power *= albedo / q;
                let n = if frame.n.dot(ng) > 0.0 { frame.n } else { ng };
                let (d, spread) = match &self.aim {
                    None => (
                        sample_cosine(n, rng.uniform(), rng.uniform()),
                        self.diffuse_spread,
                    ),
                    Some(aim) => {
                        let u = [rng.uniform(), rng.uniform(), rng.uniform()];
                        let Some(bounce) = aim.sample(at.p, n, u) else {
                            return false;
                        };
                        state.power *= bounce.weight;
                        // Where the mixture draws more densely than the cosine lobe does on
                        // average (1 / (2 pi) per steradian), the photons' beams are narrower
                        // in proportion, as emission differentials are for a denser emission.
                        let denser = bounce.pdf * (2.0 * std::f64::consts::PI);
                        (
                            bounce.direction,
                            self.diffuse_spread / denser.max(1.0).sqrt(),
                        )
                    }
                };
                // The bounce's round beam is spelled out at the next hit, as an emission's:
                // most bounces of an open scene leave it without meeting anything.
                state.ray = RayDifferential {
                    p: at.p,
                    d,
                    dp: at.dp,
                    dd: [DVec3::ZERO; 2],
                };
                state.spread = Some(spread);
                state.diffuse += 1;
                state.specular_run = 0;
                true
            }
            Material::Mirror { reflectance } => {
                let q = reflectance.max_element();
                if q <= 0.0 || rng.uniform() >= q {
                    return false;
                }
                state.power *= reflectance / q;
                state.ray = at.reflect(&mirror_frame(frame, ng, at.d));
                state.specular += 1;
                state.specular_run += 1;
                state.specular_run < MAX_SPECULAR_RUN
            }
            Material::Glass { ior } => {
                let glass = GlassInterface::new(at.d, hit.geometric_normal, frame.n, ior);
                state.ray = at.through_glass(&frame, &glass, rng.uniform());
                state.specular += 1;
                state.specular_run += 1;
                state.specular_run < MAX_SPECULAR_RUN
            }
        }
    }
}
