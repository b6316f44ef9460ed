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

/// Settings of the light tracer.
#[derive(Debug, Clone, PartialEq)]
pub struct LightTraceOptions {
    /// Light paths to trace (rounded up to whole chunks). Default 20 million.
    pub paths: u64,
    /// Stop early after this much time, if set.
    pub time_budget: Option<Duration>,
    /// Maximum number of bounces of a path. Default 32.
    pub max_bounces: u32,
    /// Seed. Default 0.
    pub seed: u64,
}

impl Default for LightTraceOptions {
    fn default() -> Self {
        LightTraceOptions {
            paths: 20_000_000,
            time_budget: None,
            max_bounces: 32,
            seed: 0,
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
    /// Paths traced.
    pub paths: u64,
    /// Rays traced (path segments and camera connections).
    pub rays: u64,
}

impl LightTraceResult {
    /// Estimated standard deviation of the reference over `pixels` as a fraction of its mean:
    /// `sqrt(mean((A - B)^2) / 4) / mean(R)` over pixels and channels (`(A - B) / 2` estimates
    /// the noise of the mean of two halves).
    pub fn relative_noise(&self, pixels: &[usize]) -> f64 {
        let (mut d2, mut r, mut n) = (0.0, 0.0, 0.0);
        for &i in pixels {
            let d = self.half_a.pixels[i] - self.half_b.pixels[i];
            d2 += d.length_squared();
            r += self.film.pixels[i].x + self.film.pixels[i].y + self.film.pixels[i].z;
            n += 3.0;
        }
        if r <= 0.0 {
            return f64::INFINITY;
        }
        (d2 / n / 4.0).sqrt() / (r / n)
    }
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
            epsilon,
            pixel_area,
            paths: LightPaths {
                scene,
                embree,
                max_bounces: options.max_bounces,
                diffuse_spread: 0.0,
                epsilon,
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

    /// Traces path `index`, appending its splats (unnormalised: as if it were the only path).
    fn trace(&self, index: u64, out: &mut Vec<Splat>) -> u64 {
        let mut rng = Rng::new(self.options.seed ^ (0x17 << 56), index);
        let Some(emission) = self.emitter.emit(index, &mut rng) else {
            return 0;
        };
        let mut connections = 0;
        let rays = self.paths.walk(emission, &mut rng, |v| {
            connections += self.splat(v.ray.p, v.normal, v.power * v.albedo * FRAC_1_PI, out);
            true
        });
        rays + connections
    }

    /// Traces the paths (in rounds of chunks on the current rayon pool), advancing `progress`
    /// by the paths traced.
    pub fn run(&self, progress: &indicatif::ProgressBar) -> LightTraceResult {
        let (w, h) = (self.scene.camera.width, self.scene.camera.height);
        let mut sums = [
            vec![DVec3::ZERO; (w * h) as usize],
            vec![DVec3::ZERO; (w * h) as usize],
        ];
        let mut counts = [0u64; 2];
        let chunks = self.options.paths.div_ceil(CHUNK).max(1);
        let start = Instant::now();
        let round = (2 * rayon::current_num_threads()) as u64;
        let mut next = 0;
        let mut rays = 0;
        while next < chunks {
            if let Some(budget) = self.options.time_budget {
                if next > 0 && start.elapsed() >= budget {
                    break;
                }
            }
            let end = (next + round).min(chunks);
            let results: Vec<(Vec<Splat>, u64)> = (next..end)
                .into_par_iter()
                .map(|chunk| {
                    let mut splats = Vec::new();
                    let mut rays = 0;
                    for index in chunk * CHUNK..(chunk + 1) * CHUNK {
                        rays += self.trace(index, &mut splats);
                    }
                    progress.inc(CHUNK);
                    (splats, rays)
                })
                .collect();
            for (chunk, (splats, r)) in (next..end).zip(results) {
                let half = (chunk % 2) as usize;
                counts[half] += CHUNK;
                rays += r;
                for s in splats {
                    sums[half][s.pixel as usize] += glam::Vec3::from(s.value).as_dvec3();
                }
            }
            next = end;
        }
        let total = counts[0] + counts[1];
        let film_of = |sum: &[DVec3], n: u64| Film {
            width: w,
            height: h,
            pixels: sum.iter().map(|s| *s / n.max(1) as f64).collect(),
        };
        let film = Film {
            width: w,
            height: h,
            pixels: sums[0]
                .iter()
                .zip(&sums[1])
                .map(|(a, b)| (*a + *b) / total.max(1) as f64)
                .collect(),
        };
        LightTraceResult {
            film,
            half_a: film_of(&sums[0], counts[0]),
            half_b: film_of(&sums[1], counts[1]),
            paths: total,
            rays,
        }
    }
}
