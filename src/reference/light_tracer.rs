//! The reference: an unbiased light tracer. Particles leave the lights and follow any chain of
//! specular and diffuse bounces; every diffuse vertex is connected to the pinhole camera and
//! splatted into the film with the same box pixel filter as the renderer.
//!
//! It is exact (up to noise) for every pixel whose camera ray first hits a diffuse surface —
//! where the estimators are judged. It cannot see lights directly or diffuse surfaces through
//! mirrors and glass (a pinhole cannot be hit by a particle), so such pixels hold only what
//! reaches them directly.
//!
//! Splatting: a particle of power `Phi` at a diffuse point `x` seen from the eye at distance `d`
//! under angle `theta_c` from the view axis adds
//! `Phi * albedo / pi * |n . w| / (A_pixel * d^2 * cos^3 theta_c)` to the pixel `x` projects
//! into, `A_pixel` being a pixel's area on the image plane at unit distance: the pixel's value
//! is the average radiance over its area, as with the renderer's box filter.
//!
//! Paths are traced in fixed chunks, alternately counted in two independent halves, so the
//! reference's noise can be estimated from their difference. Chunks are summed in order: the
//! result does not depend on the number of threads.
//!
//! Two options make a sharper reference for a given time (see [`crate::reference::cache`]):
//! - `caustic_paths`: paths aimed at the specular meshes' bounding spheres (the caustic photon
//!   emitter), for which a light's isotropic emission would spend ~1-2% of its paths. Global paths
//!   whose direction falls in those cones are then skipped, so every direction is counted once:
//!   the two sets partition the lights' emission and their sum stays unbiased.
//! - `direct: false`: vertices reached straight from a light are not splatted; the caller adds
//!   the renderer's exact direct light instead, which has no noise.

use crate::embree::{self, Ray};
use crate::photons::emission::Emitter;
use crate::photons::light_path::LightPaths;
use crate::render::film::Film;
use crate::scene::Scene;
use crate::util::rng::Rng;
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::FRAC_1_PI;
use std::time::{Duration, Instant};

/// Paths per chunk (the unit of parallel work and of the two halves).
pub const CHUNK: u64 = 1 << 16;

/// The most light paths of one set a run takes: 10^11, hours of tracing on this machine's two
/// cores (the split reference's 2.2 * 10^9 take 14 minutes), and few enough chunks that their
/// schedule fits in memory (2^64 paths tried to allocate 6.7 PB for it). `--time-budget`
/// stops a run earlier.
pub const MAX_PATHS: u64 = 100_000_000_000;

/// The paths traced for `n` asked: whole chunks, and an even number of them, so that the two
/// halves (even and odd chunks) trace as many paths each; 0 for 0. One chunk left half B without
/// light-traced paths, and a reference of it came out a fifth too dark with no sign of it.
pub fn traced_paths(n: u64) -> u64 {
    n.div_ceil(2 * CHUNK) * 2 * CHUNK
}

/// Settings of the light tracer.
#[derive(Debug, Clone, PartialEq)]
pub struct LightTraceOptions {
    /// Light paths to trace (rounded up to an even number of chunks, [`traced_paths`]). Default
    /// 20 million.
    pub paths: u64,
    /// Stop early after this much time, if set.
    pub time_budget: Option<Duration>,
    /// Maximum number of bounces of a path. Default 1024: paths end by Russian roulette on
    /// the albedo, and the cap is only there so that a scene that loses no light (albedo 1,
    /// light trapped in glass) ends. It was 32, which cut a closed diffuse sphere of albedo
    /// 0.95 to 1 - 0.95^32 = 0.81 of its light (0.97 at 0.9): the reference was dark where
    /// light bounces long.
    pub max_bounces: u32,
    /// Seed. Default 0.
    pub seed: u64,
    /// Paths aimed at the specular meshes (see the module's doc). Default 0: none, every path
    /// leaves the lights isotropically (a point light's within the cone that holds the scene's
    /// box, [`crate::photons::emission::scene_cone`]: the other directions meet nothing).
    pub caustic_paths: u64,
    /// Whether to splat vertices lit directly by a light (no bounce before them). Default true.
    pub direct: bool,
    /// Whether a stop requested through [`crate::util::interrupt`] (Ctrl-C at the command
    /// line) ends the tracing after the chunks under way, as the time budget does: the image is
    /// then that of the paths traced. Default false.
    pub on_interrupt: bool,
}

impl Default for LightTraceOptions {
    fn default() -> Self {
        LightTraceOptions {
            paths: 20_000_000,
            time_budget: None,
            max_bounces: 1024,
            seed: 0,
            caustic_paths: 0,
            direct: true,
            on_interrupt: false,
        }
    }
}

/// The reference image and its two independent halves.
pub struct LightTraceResult {
    /// The reference: all paths.
    pub film: Film,
    /// The even chunks alone.
    pub half_a: Film,
    /// The odd chunks alone.
    pub half_b: Film,
    /// Paths traced (global and caustic).
    pub paths: u64,
    /// Of those, the global paths and the caustic ones (fewer than planned where a time
    /// budget or an interrupt stopped the tracing).
    pub set_paths: [u64; 2],
    /// Rays traced (path segments and camera connections).
    pub rays: u64,
}

impl LightTraceResult {
    /// Estimated standard deviation of the reference over `pixels` as a fraction of its mean:
    /// `sqrt(mean((A - B)^2) / 4) / mean(R)` over pixels and channels (`(A - B) / 2` estimates
    /// the noise of the mean of two halves).
    pub fn relative_noise(&self, pixels: &[usize]) -> f64 {
        relative_noise(&self.film, &self.half_a, &self.half_b, pixels)
    }
}

/// The relative noise of an image `film` over `pixels`, from its two independent halves:
/// `sqrt(mean((A - B)^2) / 4) / mean(R)` over pixels and channels.
pub fn relative_noise(film: &Film, half_a: &Film, half_b: &Film, pixels: &[usize]) -> f64 {
    let (mut d2, mut r, mut n) = (0.0, 0.0, 0.0);
    for &i in pixels {
        let d = half_a.pixels[i] - half_b.pixels[i];
        d2 += d.length_squared();
        r += film.pixels[i].x + film.pixels[i].y + film.pixels[i].z;
        n += 3.0;
    }
    if r <= 0.0 {
        return f64::INFINITY;
    }
    (d2 / n / 4.0).sqrt() / (r / n)
}

struct Splat {
    pixel: u32,
    value: [f32; 3],
}

/// Traces light paths and splats them into a film.
pub struct LightTracer<'a> {
    scene: &'a Scene,
    embree: &'a embree::Scene,
    options: &'a LightTraceOptions,
    emitter: Emitter,
    caustic: Emitter,
    epsilon: f64,
    pixel_area: f64,
    paths: LightPaths<'a>,
}

impl<'a> LightTracer<'a> {
    /// A light tracer for `scene`.
    pub fn new(
        scene: &'a Scene,
        embree: &'a embree::Scene,
        options: &'a LightTraceOptions,
    ) -> Self {
        let c = &scene.camera;
        let aspect = c.width as f64 / c.height as f64;
        let epsilon = scene.ray_epsilon();
        let pixel_area = (2.0 * c.tan_half_fov * aspect / c.width as f64)
            * (2.0 * c.tan_half_fov / c.height as f64);
        LightTracer {
            scene,
            embree,
            options,
            // Overlap is irrelevant here: the differentials are not used.
            emitter: Emitter::global(scene, options.paths as usize, 1.0, options.seed)
                .with_random_samples(),
            caustic: Emitter::caustic(
                scene,
                options.caustic_paths.max(1) as usize,
                1.0,
                options.seed,
            )
            .with_random_samples(),
            epsilon,
            pixel_area,
            paths: LightPaths {
                scene,
                embree,
                max_bounces: options.max_bounces,
                diffuse_spread: 0.0,
                epsilon,
                aim: None,
            },
        }
    }

    /// Connects a diffuse vertex to the camera; returns the number of rays traced.
    fn splat(&self, x: DVec3, n_in: DVec3, value: DVec3, out: &mut Vec<Splat>) -> u64 {
        let c = &self.scene.camera;
        let to_eye = c.eye - x;
        let d = to_eye.length();
        let w = to_eye / d;
        let cos_x = n_in.dot(w);
        if cos_x <= 0.0 {
            return 0;
        }
        let cos_c = c.forward.dot(-w);
        if cos_c <= 0.0 {
            return 0;
        }
        let Some((px, py)) = c.project(x) else {
            return 0;
        };
        if !(px >= 0.0 && py >= 0.0 && px < c.width as f64 && py < c.height as f64) {
            return 0;
        }
        let origin = x + n_in * self.epsilon;
        if self.embree.occluded(&Ray::segment(
            origin,
            w,
            (c.eye - origin).length() * (1.0 - 1e-9),
        )) {
            return 1;
        }
        let v = value * (cos_x / (self.pixel_area * d * d * cos_c * cos_c * cos_c));
        out.push(Splat {
            pixel: py as u32 * c.width + px as u32,
            value: v.as_vec3().to_array(),
        });
        1
    }

    /// Whether caustic paths are traced apart (and skipped among the global ones).
    fn split(&self) -> bool {
        self.options.caustic_paths > 0 && !self.caustic.is_empty()
    }

    /// Traces path `index` of the global (`caustic == false`) or caustic set, appending its
    /// splats (unnormalised: as if it were the only path of its set).
    fn trace(&self, index: u64, caustic: bool, out: &mut Vec<Splat>) -> u64 {
        let stream = if caustic { 0x18 << 56 } else { 0x17 << 56 };
        let mut rng = Rng::new(self.options.seed ^ stream, index);
        let emitter = if caustic {
            &self.caustic
        } else {
            &self.emitter
        };
        let Some((emission, light)) = emitter.emit_from_light(index, &mut rng) else {
            return 0;
        };
        if !caustic && self.split() && self.caustic.covers(light, emission.ray.p, emission.ray.d) {
            return 0;
        }
        let mut connections = 0;
        let rays = self.paths.walk(emission, &mut rng, |v| {
            if self.options.direct || v.specular_bounces + v.diffuse_bounces > 0 {
                connections += self.splat(v.ray.p, v.normal, v.power * v.albedo * FRAC_1_PI, out);
            }
            true
        });
        rays + connections
    }

    /// Traces the paths (in rounds of chunks on the current rayon pool), advancing `progress`
    /// by the paths traced.
    pub fn run(&self, progress: &indicatif::ProgressBar) -> LightTraceResult {
        let (w, h) = (self.scene.camera.width, self.scene.camera.height);
        let n = (w * h) as usize;
        // sums[set][half], counts[set][half]; set 0 = global paths, 1 = caustic paths.
        let mut sums = [
            [vec![DVec3::ZERO; n], vec![DVec3::ZERO; n]],
            [Vec::new(), Vec::new()],
        ];
        let mut counts = [[0u64; 2]; 2];
        let jobs = self.jobs();
        if self.split() {
            sums[1] = [vec![DVec3::ZERO; n], vec![DVec3::ZERO; n]];
        }
        if self.options.on_interrupt {
            // A stop waits for the first round of paths, which it then keeps.
            crate::util::interrupt::keep();
        }
        let start = Instant::now();
        let round = 2 * rayon::current_num_threads();
        let mut next = 0;
        let mut rays = 0;
        while next < jobs.len() {
            if let Some(budget) = self.options.time_budget {
                if next > 0 && start.elapsed() >= budget {
                    break;
                }
            }
            if self.options.on_interrupt && next > 0 && crate::util::interrupt::requested() {
                crate::util::interrupt::honour();
                break;
            }
            let end = (next + round).min(jobs.len());
            let results: Vec<(Vec<Splat>, u64)> = jobs[next..end]
                .par_iter()
                .map(|&(set, chunk)| {
                    let _span = crate::util::trace::span_with("light paths", || {
                        let set = if set == 1 { "caustic" } else { "global" };
                        serde_json::json!({"set": set, "chunk": chunk, "paths": CHUNK})
                    });
                    let mut splats = Vec::new();
                    let mut rays = 0;
                    for index in chunk * CHUNK..(chunk + 1) * CHUNK {
                        rays += self.trace(index, set == 1, &mut splats);
                    }
                    progress.inc(CHUNK);
                    (splats, rays)
                })
                .collect();
            for (&(set, chunk), (splats, r)) in jobs[next..end].iter().zip(results) {
                let half = (chunk % 2) as usize;
                counts[set][half] += CHUNK;
                rays += r;
                for s in splats {
                    sums[set][half][s.pixel as usize] += glam::Vec3::from(s.value).as_dvec3();
                }
            }
            next = end;
            crate::util::trace::counter(
                "light paths",
                || serde_json::json!({"traced": counts.iter().flatten().sum::<u64>(), "rays": rays}),
            );
        }
        let film_of = |f: &dyn Fn(usize) -> DVec3| Film {
            width: w,
            height: h,
            pixels: (0..n).map(f).collect(),
        };
        let sets = if self.split() { 2 } else { 1 };
        let film = film_of(&|i| {
            (0..sets)
                .map(|s| {
                    (sums[s][0][i] + sums[s][1][i]) / (counts[s][0] + counts[s][1]).max(1) as f64
                })
                .sum()
        });
        let half = |k: usize| {
            film_of(&|i| {
                (0..sets)
                    .map(|s| sums[s][k][i] / counts[s][k].max(1) as f64)
                    .sum()
            })
        };
        LightTraceResult {
            film,
            half_a: half(0),
            half_b: half(1),
            paths: counts.iter().flatten().sum(),
            set_paths: [counts[0][0] + counts[0][1], counts[1][0] + counts[1][1]],
            rays,
        }
    }

    /// The paths this tracer will trace, global and caustic: [`traced_paths`] of those asked
    /// (the caustic ones only where the scene has mirror or glass meshes to aim at).
    pub fn planned_paths(&self) -> (u64, u64) {
        let jobs = self.jobs();
        let count = |set| jobs.iter().filter(|j| j.0 == set).count() as u64 * CHUNK;
        (count(0), count(1))
    }

    /// The chunks to trace, as (set, chunk index): the global paths' chunks and, when caustic
    /// paths are traced apart, theirs interleaved in proportion, so that a time budget stops
    /// both sets at the same fraction.
    fn jobs(&self) -> Vec<(usize, u64)> {
        let caustic = if self.split() {
            self.options.caustic_paths
        } else {
            0
        };
        let global = if caustic > 0 {
            self.options.paths
        } else {
            self.options.paths.max(1)
        };
        let (global, caustic) = (traced_paths(global) / CHUNK, traced_paths(caustic) / CHUNK);
        let mut jobs: Vec<(f64, usize, u64)> = (0..global)
            .map(|c| ((c as f64 + 0.5) / global as f64, 0, c))
            .chain((0..caustic).map(|c| ((c as f64 + 0.5) / caustic as f64, 1, c)))
            .collect();
        jobs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        jobs.into_iter().map(|(_, set, c)| (set, c)).collect()
    }
}

/// The pixels whose centre ray first meets a mirror or glass surface: light tracing connects
/// only diffuse surfaces to the camera, so it leaves them dark (or holds only the part of the
/// pixel that is diffuse), however many paths it traces.
pub fn pixels_seeing_specular(scene: &Scene, embree: &embree::Scene) -> u64 {
    use rayon::prelude::*;
    let c = &scene.camera;
    (0..c.height)
        .into_par_iter()
        .map(|y| {
            (0..c.width)
                .filter(|&x| {
                    let r = c.ray(x as f64 + 0.5, y as f64 + 0.5, 1.0);
                    embree
                        .intersect(&Ray::new(r.p, r.d))
                        .is_some_and(|hit| scene.material(hit.geom_id).is_specular())
                })
                .count() as u64
        })
        .sum()
}

/// The name of the glass mesh the camera is inside, if any: light tracing reaches the camera
/// only along straight segments through open space, so such a camera sees nothing of it (its
/// image is black without a word). Along each axis and the view direction, the first glass
/// surface met from its inside (the geometric normal, which the winding sets, along the ray)
/// says so, unless a direction leaves the scene (the glass does not close around the camera:
/// a single glass sheet seen from behind was taken for it, and its traced image was not black)
/// or meets that glass from outside; a direction whose first hit is not glass says nothing.
pub fn camera_in_glass(scene: &Scene, embree: &embree::Scene) -> Option<String> {
    let c = &scene.camera;
    let epsilon = scene.ray_epsilon();
    let directions = [
        c.forward,
        DVec3::X,
        DVec3::NEG_X,
        DVec3::Y,
        DVec3::NEG_Y,
        DVec3::Z,
        DVec3::NEG_Z,
    ];
    let hits: Vec<(u32, bool)> = directions
        .iter()
        .map(|&d| {
            let hit = embree.intersect(&Ray::new(c.eye, d))?;
            let from_inside = hit.geometric_normal.dot(d) > 0.0 && hit.t > epsilon;
            Some((hit.geom_id, from_inside))
        })
        .collect::<Option<_>>()?;
    let glass = |id: u32| {
        matches!(
            scene.meshes[id as usize].material,
            crate::scene::Material::Glass { .. }
        )
    };
    let &(id, _) = hits.iter().find(|&&(id, inside)| inside && glass(id))?;
    hits.iter()
        .all(|&(other, inside)| other != id || inside)
        .then(|| scene.meshes[id as usize].name.clone())
}
