//! Photon tracing: photons leave the lights, follow mirrors and glass (Fresnel-chosen reflection
//! or refraction) and diffuse bounces (cosine sampling, Russian roulette), carrying photon
//! differentials propagated with the same code as camera rays, and are stored with their
//! footprints in the map of their path class.
//!
//! Every emission has its own random stream (seeded by the run's seed, the map and the emission
//! index), and emissions are collected in index order, so the maps are identical whatever the
//! number of threads.

use crate::embree::{self, Ray};
use crate::geometry::differential::RayDifferential;
use crate::photons::emission::batch::Drawn;
use crate::photons::emission::{Emission, Emitter};
use crate::photons::footprint::{footprint, Footprint, FootprintLimits, Guards};
use crate::photons::light_path::{DiffuseHit, LightPaths};
use crate::photons::map::{PathClass, Photon, PhotonMap, BUILD_BYTES_PER_PHOTON};
use crate::photons::options::PhotonOptions;
use crate::photons::radiance_map::RadianceSample;
use crate::photons::targets::{specular_targets, DiffuseAim};
use crate::photons::walls::Walls;
use crate::scene::Scene;
use crate::util::reserve;
use crate::util::rng::Rng;
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::PI;

/// A photon as the tracer stores it, before it is reduced to a [`Photon`]: with its full
/// differential, for tests and diagnostics.
#[derive(Debug, Clone, Copy)]
pub struct TracedPhoton {
    /// The class of its path.
    pub class: PathClass,
    /// The ray differential transferred to the hit (its position differentials are the
    /// footprint's radius vectors).
    pub ray: RayDifferential,
    /// Geometric normal at the hit, facing the incoming photon.
    pub normal: DVec3,
    /// Power for a single emission.
    pub power: DVec3,
    /// Albedo of the diffuse surface hit.
    pub albedo: DVec3,
    /// Length of the path from the light.
    pub path_length: f64,
    /// Specular bounces before the hit.
    pub specular_bounces: u32,
    /// Diffuse bounces before the hit.
    pub diffuse_bounces: u32,
}

/// Traced photons reduced to the map's photons: theirs and their mirrors', in order, with
/// each one's power for a single emission (the photons' own powers are set once the number of
/// emissions is known), where the mirrors are among them, and the guards they tripped.
#[derive(Default)]
struct Footprinted {
    photons: Vec<Photon>,
    powers: Vec<DVec3>,
    /// Indices of the mirror photons in `photons`, in order.
    mirrors: Vec<u32>,
    guards: Guards,
}

impl Footprinted {
    /// `next`'s photons after these, or an error where there is no room for them: a map of
    /// ten million photons under a 1.5 GB limit aborted here, growing its photons to 1.3 GB.
    fn append(&mut self, next: Footprinted) -> Result<(), String> {
        let n = next.photons.len();
        reserve::make_room(&mut self.photons, n, "photons stored")?;
        reserve::make_room(&mut self.powers, n, "photons stored")?;
        reserve::make_room(
            &mut self.mirrors,
            next.mirrors.len(),
            "mirror photons stored",
        )?;
        let base = self.photons.len() as u32;
        self.photons.extend_from_slice(&next.photons);
        self.powers.extend_from_slice(&next.powers);
        self.mirrors.extend(next.mirrors.iter().map(|i| i + base));
        self.guards.add(&next.guards);
        Ok(())
    }
}

/// Traces photons through one scene.
pub struct PhotonTracer<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// Its Embree scene.
    pub embree: &'a embree::Scene,
    /// Settings.
    pub options: &'a PhotonOptions,
    /// Radius of the angular differentials given to photons leaving a diffuse surface.
    /// Light leaving a diffuse surface spreads over the hemisphere (2 pi sr), shared by the
    /// global photons.
    diffuse_spread: f64,
    paths: LightPaths<'a>,
    /// As `paths`, with diffuse bounces aimed at the specular objects: for the global map.
    aimed_paths: LightPaths<'a>,
    /// The walls footprints are probed for ([`PhotonOptions::probe_walls`]).
    walls: Option<Walls<'a>>,
}

/// The cap of [`StopRule::Stored`] for the caustic map: emissions per photon asked for.
/// Caustic photons are aimed at the specular objects, so a scene where fewer than one
/// emission in this many stores one has (almost) no caustics.
pub const EMISSIONS_PER_PHOTON: u64 = 1000;

/// A caustic map with no photon stored after this share of its cap stops there: its light
/// cannot reach the specular objects (a point light under the floor drew 60 million emissions
/// a pass for none, 28 s for a black image). A map that stores one photon in the cap's worth
/// of emissions for each asked would hold 1% of them here: nothing worth the rest.
pub const EMPTY_CAUSTIC_SHARE: u64 = 100;

/// Whether emission for `class` stopped at [`emission_cap`] for `asked` photons (drawn by an
/// emitter of [`Emitter::share`] `share`), or early
/// with none stored ([`EMPTY_CAUSTIC_SHARE`]), short of what was asked.
pub fn emission_stopped(class: PathClass, asked: usize, share: f64, counts: &TraceCounts) -> bool {
    let cap = emission_cap(class, asked, share);
    counts.stored < asked as u64
        && (counts.emitted >= cap || empty_so_far(class, cap, counts.stored, counts.emitted))
}

/// Whether a map of `class` whose emission is capped at `cap` stops with `stored` photons
/// after `emitted` emissions: a caustic map with none after [`EMPTY_CAUSTIC_SHARE`] of its cap.
/// The tracer's loop and [`emission_stopped`] (what the statistics say) both ask this.
fn empty_so_far(class: PathClass, cap: u64, stored: u64, emitted: u64) -> bool {
    class == PathClass::Caustic && stored == 0 && emitted >= cap / EMPTY_CAUSTIC_SHARE
}

/// The cap of [`StopRule::Stored`] for the global map: emissions per photon asked for. Global
/// photons are stored at every diffuse bounce after the first, so a closed scene stores one or
/// more per emission; an open scene stores few (the canonical scene about 1 in 1,700: its
/// 100,000 photons would take 170 million emissions) and ends at this cap with fewer photons
/// than asked for, which the statistics and the command line report. It keeps the default
/// render of an open scene fast: 200,000 emissions for the default render's 50,000 global
/// photons, 400,000 for the other estimators' default of 100,000.
pub const GLOBAL_EMISSIONS_PER_PHOTON: u64 = 4;

/// When a map is complete.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StopRule {
    /// After this many photons are stored, or after [`max_emissions`] emissions.
    Stored(usize),
    /// After this many emissions.
    Emitted(usize),
}

/// What tracing one map cost, for the statistics.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct TraceCounts {
    /// Emissions.
    pub emitted: u64,
    /// Photons stored.
    pub stored: u64,
    /// Rays traced.
    pub rays: u64,
}

/// Emissions after which [`StopRule::Stored`]`(n)` stops for a map of `class`:
/// [`GLOBAL_EMISSIONS_PER_PHOTON`] per photon for the global map, [`EMISSIONS_PER_PHOTON`]
/// for the others, and at least 4096.
pub fn max_emissions(class: PathClass, n: usize) -> u64 {
    let per = match class {
        PathClass::Global | PathClass::AllDiffuse => GLOBAL_EMISSIONS_PER_PHOTON,
        _ => EMISSIONS_PER_PHOTON,
    };
    (n as u64).saturating_mul(per).max(4096)
}

/// [`max_emissions`] for a map of `class` drawn by an emitter standing for `share` of the
/// lights' whole emission ([`Emitter::share`]: a point light's global photons go only where
/// they can meet the scene): the cap times that share, so that it counts the emissions that
/// can reach the scene, as many as when every direction was drawn; at least 4096, as
/// `max_emissions` is.
pub fn emission_cap(class: PathClass, n: usize, share: f64) -> u64 {
    let whole = max_emissions(class, n);
    let scaled = (whole as f64 * share.clamp(0.0, 1.0)).ceil() as u64;
    scaled.clamp(4096, whole)
}

impl<'a> PhotonTracer<'a> {
    /// A tracer for `scene`.
    pub fn new(scene: &'a Scene, embree: &'a embree::Scene, options: &'a PhotonOptions) -> Self {
        let n = options.global_photons.max(1) as f64;
        // Only paths that go on past a diffuse hit use it: the global map's (and the
        // reference's), so it follows the global map's overlap.
        let diffuse_spread = (options.global_overlap() * 2.0 * PI / (PI * n)).sqrt();
        let paths = LightPaths {
            scene,
            embree,
            max_bounces: options.max_bounces,
            diffuse_spread,
            epsilon: scene.ray_epsilon(),
            aim: None,
        };
        let aimed_paths = LightPaths {
            aim: DiffuseAim::new(specular_targets(scene), options.global_aim),
            ..paths.clone()
        };
        PhotonTracer {
            scene,
            embree,
            options,
            diffuse_spread,
            paths,
            aimed_paths,
            walls: options.probe_walls.then(|| Walls::new(embree)),
        }
    }

    /// Follows one emission, appending the photons of class `class` it stores to `out`;
    /// returns the number of rays traced. Caustic and direct photons end the path at their
    /// first diffuse hit (nothing after it belongs to their class).
    pub fn trace(
        &self,
        emission: Emission,
        class: PathClass,
        rng: &mut Rng,
        out: &mut Vec<TracedPhoton>,
    ) -> u64 {
        self.paths_for(class)
            .walk(emission, rng, |v| store(class, v, |p| out.push(p)))
    }

    /// Traces emissions `range` of `emitter` in 16-wide packets: the photons of class `class`,
    /// each with its emission's index, their order by emission, and the rays of every
    /// emission. The same photons as [`PhotonTracer::trace`] on each emission in turn.
    fn trace_range(
        &self,
        emitter: &Emitter,
        class: PathClass,
        range: std::ops::Range<u64>,
    ) -> RangePhotons {
        let mut photons = Vec::new();
        let mut rays = vec![0u32; (range.end - range.start) as usize];
        let mut indices = range.clone();
        // Emissions are drawn 16 at a time (their directions in vector instructions).
        let mut drawn = Drawn::default();
        self.paths_for(class).walk_packets(
            |state, rng| loop {
                match emitter.launch_drawn(&mut drawn, rng, |l| state.start(l)) {
                    Some((index, Some(()))) => return Some(index),
                    Some((_, None)) => {}
                    None if indices.is_empty() => return None,
                    None => {
                        let end = (indices.start + 16).min(indices.end);
                        emitter.draw(indices.start..end, self.seed(class), &mut drawn);
                        indices.start = end;
                    }
                }
            },
            |&index, v| store(class, v, |p| photons.push((index, p))),
            |index, n| rays[(index - range.start) as usize] = n as u32,
        );
        // A lane's photons come in path order; lanes finish out of order. Sorted by key, and
        // gathered in that order only where they are taken (a sort of the photons themselves
        // moves each a few hundred bytes at a time, several times, and gathering them here
        // would copy each once more).
        let mut keys: Vec<(u64, u32)> = photons
            .iter()
            .enumerate()
            .map(|(k, &(index, _))| (index, k as u32))
            .collect();
        keys.sort_unstable();
        let order = keys.into_iter().map(|(_, k)| k).collect();
        RangePhotons {
            photons,
            order,
            rays,
        }
    }

    /// Traces emissions from `emitter` in index order until `stop` is met: the photons of
    /// `class` (powers for a single emission) and the counts. `progress` is advanced by the
    /// photons stored or the emissions, as `stop` counts.
    pub fn trace_photons(
        &self,
        emitter: &Emitter,
        class: PathClass,
        stop: StopRule,
        progress: &indicatif::ProgressBar,
    ) -> (Vec<TracedPhoton>, TraceCounts) {
        let mut traced = Vec::new();
        let counts = self.trace_photons_into(emitter, class, stop, progress, |batch| {
            traced.extend_from_slice(batch);
            Ok(())
        });
        (traced, counts.expect("collecting the photons refuses none"))
    }

    /// [`PhotonTracer::trace_photons`], giving the photons to `take` in order as they come, a
    /// batch of emissions' worth at a time, rather than holding them all: a map's builder
    /// keeps what it needs of each (a traced photon, its whole differential in `f64`, is 232
    /// bytes). Tracing stops at the first error `take` returns (no room for the photons), and
    /// returns it.
    pub fn trace_photons_into(
        &self,
        emitter: &Emitter,
        class: PathClass,
        stop: StopRule,
        progress: &indicatif::ProgressBar,
        mut take: impl FnMut(&[TracedPhoton]) -> Result<(), String>,
    ) -> Result<TraceCounts, String> {
        // Emissions are traced in batches (each split into fixed chunks, one per task, so the
        // packets and hence the results do not depend on the number of threads) and taken in
        // index order until the map is complete.
        const BATCH: u64 = 4096;
        const CHUNK: u64 = 256;
        let (target, max_emissions) = match stop {
            // A cap for scenes where the class is rare (it is reported in the statistics).
            StopRule::Stored(n) => (n, emission_cap(class, n, emitter.share())),
            StopRule::Emitted(n) => (usize::MAX, n as u64),
        };
        // A batch's photons, and the count of all taken.
        let mut traced: Vec<TracedPhoton> = Vec::new();
        let mut stored = 0;
        let mut counts = TraceCounts::default();
        // Photons land only on diffuse surfaces: without one (a closed room of mirrors) every
        // emission would bounce to the cap and store nothing (minutes for a black image).
        if target > 0 && !emitter.is_empty() && self.scene.has_diffuse_surface() {
            while counts.emitted < max_emissions {
                // A stop requested: the map is left as it is and its pass dropped.
                if crate::util::interrupt::cut_short() {
                    break;
                }
                let start = counts.emitted;
                let end = (start + BATCH).min(max_emissions);
                let chunks: Vec<u64> = (start..end).step_by(CHUNK as usize).collect();
                let batch: Vec<RangePhotons> = chunks
                    .into_par_iter()
                    .map(|a| self.trace_range(emitter, class, a..(a + CHUNK).min(end)))
                    .collect();
                let mut index = start;
                let stored_before = stored;
                let complete = 'batch: {
                    for range in batch {
                        // By position, not a peekable iterator: peeking moves a whole photon
                        // in and out of the iterator at every emission (most store none).
                        let (photons, order) = (&range.photons, &range.order);
                        let mut next = 0;
                        for n in range.rays {
                            counts.emitted += 1;
                            counts.rays += u64::from(n);
                            while let Some(&k) = order.get(next) {
                                let (i, photon) = &photons[k as usize];
                                if *i != index {
                                    break;
                                }
                                traced.push(*photon);
                                stored += 1;
                                next += 1;
                            }
                            index += 1;
                            if stored >= target {
                                break 'batch true;
                            }
                        }
                    }
                    false
                };
                take(&traced)?;
                traced.clear();
                // The progress bar moves once per batch: it reads the clock on every move.
                progress.inc(match stop {
                    StopRule::Stored(_) => (stored - stored_before) as u64,
                    StopRule::Emitted(_) => counts.emitted - start,
                });
                if complete {
                    break;
                }
                let empty = empty_so_far(class, max_emissions, stored as u64, counts.emitted);
                if StopRule::Stored(target) == stop && empty {
                    break;
                }
            }
        }
        counts.stored = stored as u64;
        Ok(counts)
    }

    /// Traces emission `index` of `emitter` alone, with the random stream [`trace_photons`]
    /// gives it, ray by ray: the photons of `class` it stores go to `out`; returns its rays.
    /// `trace_photons` traces the same paths in packets (tested).
    ///
    /// [`trace_photons`]: PhotonTracer::trace_photons
    pub fn trace_emission(
        &self,
        emitter: &Emitter,
        class: PathClass,
        index: u64,
        out: &mut Vec<TracedPhoton>,
    ) -> u64 {
        let mut rng = self.stream(class, index);
        match emitter.emit(index, &mut rng) {
            Some(e) => self.trace(e, class, &mut rng, out),
            None => 0,
        }
    }

    /// The light paths photons of `class` follow: aimed diffuse bounces for the global map.
    fn paths_for(&self, class: PathClass) -> &LightPaths<'a> {
        match class {
            PathClass::Global => &self.aimed_paths,
            _ => &self.paths,
        }
    }

    /// The random stream of emission `index` of the map of `class`.
    fn stream(&self, class: PathClass, index: u64) -> Rng {
        Rng::new(self.seed(class), index)
    }

    /// The seed of the random streams of the map of `class`'s emissions.
    fn seed(&self, class: PathClass) -> u64 {
        self.options.seed ^ (salt(class) << 56)
    }

    /// The rays that tracing the first `emissions` emissions of `emitter` for `class` queries,
    /// in emission order, one path after another: for benchmarks, to time Embree alone on
    /// the very rays photon tracing traces. (Traced one at a time here; packets may answer a
    /// ray whose hit is a tie differently, which changes nothing measurable.)
    pub fn queries(&self, emitter: &Emitter, class: PathClass, emissions: u64) -> Vec<Ray> {
        let mut rays = Vec::new();
        for index in 0..emissions {
            let mut rng = self.stream(class, index);
            if let Some(e) = emitter.emit(index, &mut rng) {
                let intersect = |q: &Ray| {
                    rays.push(*q);
                    self.embree.intersect(q)
                };
                self.paths_for(class)
                    .walk_with(e, &mut rng, intersect, |v| store(class, v, |_| ()));
            }
        }
        rays
    }

    /// [`PhotonTracer::trace_photons`], then the photons' powers divided by the number of
    /// emissions and their footprints, in the map of `class` (with a mirror photon beyond each
    /// wall or edge a footprint runs into, with [`PhotonOptions::probe_walls`]).
    ///
    /// Each batch's photons are reduced to the map's as they come, so that the traced photons
    /// (232 bytes each) are never all held: at 1.28M photons they were 300 MB at the peak of
    /// `photondiff photons`. The powers are divided by the number of emissions, known only at
    /// the end, then: each photon keeps its power for a single emission (`f64`) until then.
    pub fn build_map(
        &self,
        emitter: &Emitter,
        class: PathClass,
        stop: StopRule,
        progress: &indicatif::ProgressBar,
    ) -> Result<(PhotonMap, TraceCounts), String> {
        let limits = self.options.class_limits(self.scene, class);
        let mut all = Footprinted::default();
        let counts = self.trace_photons_into(emitter, class, stop, progress, |batch| {
            // On the worker threads, a block of photons per task, in order.
            let blocks: Vec<Footprinted> = batch
                .par_chunks(1 << 9)
                .map(|block| self.footprints(block, &limits))
                .collect();
            blocks.into_iter().try_for_each(|block| all.append(block))
        });
        let counts = counts.map_err(|e| format!("{} map: {e}", class.name()))?;
        let scale = 1.0 / counts.emitted.max(1) as f64;
        let Footprinted {
            mut photons,
            powers,
            mirrors,
            guards,
        } = all;
        photons
            .par_iter_mut()
            .zip(powers)
            .for_each(|(p, power)| p.power = (power * scale).as_vec3());
        // The mirrors' power summed in the photons' order, as one thread would.
        let mirror_power = mirrors
            .iter()
            .map(|&i| photons[i as usize].power.as_dvec3())
            .sum();
        let what = format!(
            "{} map: the columns and tree of its {} photons",
            class.name(),
            photons.len()
        );
        reserve::check(photons.len() as u64 * BUILD_BYTES_PER_PHOTON, &what)?;
        let mut map = PhotonMap::new(class, photons, counts.emitted, guards);
        map.mirror_power = mirror_power;
        Ok((map, counts))
    }

    /// The footprint of traced photon `t` under `limits`, counting the guards it trips.
    fn footprint_of(
        &self,
        t: &TracedPhoton,
        limits: &FootprintLimits,
        guards: &mut Guards,
    ) -> Footprint {
        // A photon whose differential degenerated is given the footprint its beam would have
        // had without focusing: its angular spread times the distance travelled.
        let nominal =
            (self.diffuse_spread * t.path_length).clamp(limits.min_radius, limits.max_radius);
        footprint(t.ray.dp[0], t.ray.dp[1], t.normal, limits, nominal, guards)
    }

    /// The mirror images of the traced photons `block` beyond the walls and edges within the
    /// radiance map's reach of them ([`PhotonOptions::probe_walls`]; none without): for the
    /// radiance map, whose estimates near a wall are discs hanging past it. Each photon is
    /// probed over a round disc of the radiance estimates' largest radius
    /// ([`PhotonOptions::radiance_max_radius`]), the farthest past a wall a disc can reach.
    /// (Probed over its own footprint, as the global map's photons are, a photon's mirrors
    /// reached only as far as that footprint, which the passes shrink while the estimates'
    /// discs keep their largest radius: in a closed cube the map next to an edge read x0.90 of
    /// a light-traced reference at the footprints of about the sixteenth pass, x0.97 at the
    /// first's, and reads x0.99 now at any pass.) Only the photons whose index in `block` `keep` accepts are
    /// probed (the radiance map reads the images of the photons its estimates read, not of its
    /// points).
    pub fn mirror_samples(
        &self,
        block: &[TracedPhoton],
        keep: impl Fn(usize) -> bool,
    ) -> Vec<RadianceSample> {
        let Some(walls) = self.walls.as_ref() else {
            return Vec::new();
        };
        let reach = self.options.radiance_max_radius(self.scene);
        let mut out = Vec::new();
        let kept = block.iter().enumerate().filter(|&(j, _)| keep(j));
        for t in kept.map(|(_, t)| t) {
            let f = Footprint::round(t.normal, reach);
            let p = t.ray.p;
            if let Some(pair) = walls.nearest(p, t.normal, &f, self.paths.epsilon) {
                for image in pair.images() {
                    out.push(RadianceSample {
                        position: image.point(p, p).as_vec3(),
                        ..RadianceSample::of(t)
                    });
                }
            }
        }
        out
    }

    /// The map's photons of the traced photons `block`, in order, each followed by its mirror
    /// images (one beyond a wall, three in an inner corner), with the guards they tripped; their
    /// powers are for a single emission, beside them.
    fn footprints(&self, block: &[TracedPhoton], limits: &FootprintLimits) -> Footprinted {
        let mut out = Footprinted::default();
        for t in block {
            let f = self.footprint_of(t, limits, &mut out.guards);
            let (p, d) = (t.ray.p, t.ray.d);
            out.photons
                .push(Photon::new(p, t.normal, d, DVec3::ZERO, &f));
            out.powers.push(t.power);
            let walls = self.walls.as_ref();
            if let Some(pair) = walls.and_then(|w| w.nearest(p, t.normal, &f, self.paths.epsilon)) {
                for image in pair.images() {
                    out.guards.mirrored += 1;
                    let (at, f) = (image.point(p, p), image.footprint(&f));
                    out.mirrors.push(out.photons.len() as u32);
                    out.photons
                        .push(Photon::new(at, t.normal, image.vector(d), DVec3::ZERO, &f));
                    out.powers.push(t.power);
                }
            }
        }
        out
    }
}

/// Hands the photon of `class` at diffuse hit `v` (if it is one) to `keep`; answers whether
/// the path goes on (only global and all-diffuse paths go past a diffuse hit).
fn store(class: PathClass, v: &DiffuseHit, keep: impl FnOnce(TracedPhoton)) -> bool {
    let here = match (v.specular_bounces, v.diffuse_bounces) {
        (_, d) if d > 0 => PathClass::Global,
        (s, _) if s > 0 => PathClass::Caustic,
        _ => PathClass::Direct,
    };
    if here == class || class == PathClass::AllDiffuse {
        keep(TracedPhoton {
            class,
            ray: *v.ray,
            normal: v.normal,
            power: v.power,
            albedo: v.albedo,
            path_length: v.path_length,
            specular_bounces: v.specular_bounces,
            diffuse_bounces: v.diffuse_bounces,
        });
    }
    matches!(class, PathClass::Global | PathClass::AllDiffuse)
}

/// What [`PhotonTracer::trace_range`] returns.
struct RangePhotons {
    /// The photons with their emissions' indices, in the order the lanes stored them.
    photons: Vec<(u64, TracedPhoton)>,
    /// Positions in `photons` in emission order (a photon's path order within its emission).
    order: Vec<u32>,
    /// Every emission's rays.
    rays: Vec<u32>,
}

/// Mixed into the seed of every emission's random stream: each map class has its own.
fn salt(class: PathClass) -> u64 {
    match class {
        PathClass::Direct => 0xD1,
        PathClass::Caustic => 0xCA,
        PathClass::Global => 0x61,
        PathClass::AllDiffuse => 0xA1,
    }
}
