//! References for the experiments, cached on disk: a reference at the scene's resolution costs
//! minutes, so it is made once per scene, size and settings and reused.
//!
//! A reference is split in two parts, each made the way it converges fastest:
//! - **direct light** (light -> diffuse surface -> camera) from the renderer's own direct
//!   estimate, supersampled on two different camera-ray grids (`direct_grids`, e.g. 16 x 16 and
//!   17 x 17 rays per pixel): point and spot lights are exact per ray, so what remains is the
//!   pixel integral's discretisation, which the two grids expose in the halves;
//! - **everything that bounced at least once** before the vertex seen by the camera, from the
//!   light tracer with direct vertices left out ([`LightTraceOptions::direct`] = false), its
//!   caustic part aimed at the specular meshes ([`LightTraceOptions::caustic_paths`]).
//!
//! Half A is grid 0's direct light plus the light tracer's even chunks, half B grid 1's plus its
//! odd chunks; the reference is their mean, and half their difference estimates its noise.

use crate::embree;
use crate::reference::light_tracer::{relative_noise, LightTraceOptions, LightTracer};
use crate::render::film::Film;
use crate::render::stats::Stats;
use crate::render::{render, RenderOptions};
use crate::scene::Scene;
use std::path::{Path, PathBuf};

/// A reference image and its two independent halves (for its noise).
pub struct Reference {
    /// The mean of the halves.
    pub film: Film,
    /// Grid 0's direct light and the light tracer's even chunks.
    pub half_a: Film,
    /// Grid 1's direct light and the light tracer's odd chunks.
    pub half_b: Film,
}

impl Reference {
    /// The estimated noise of the reference over `pixels`, relative to its mean there.
    pub fn relative_noise(&self, pixels: &[usize]) -> f64 {
        relative_noise(&self.film, &self.half_a, &self.half_b, pixels)
    }
}

/// How a reference is made.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReferenceSettings {
    /// Light paths leaving the lights isotropically (indirect light).
    pub light_paths: u64,
    /// Light paths aimed at the specular meshes (caustics and what follows them).
    pub caustic_paths: u64,
    /// Camera rays per pixel along each axis of the two halves' direct light.
    pub direct_grids: [u32; 2],
    /// Seed of the light paths: references made with different seeds are independent, so their
    /// mean ([`merge`]) is a reference with their paths summed.
    pub seed: u64,
}

impl ReferenceSettings {
    /// The settings in a few characters, as in cached references' names and metadata:
    /// `{light paths}-{caustic paths}-{grid A}x{grid B}`, then `-seed{S}` unless the seed is 0.
    pub fn tag(&self) -> String {
        let mut tag = format!(
            "{}-{}-{}x{}",
            self.light_paths, self.caustic_paths, self.direct_grids[0], self.direct_grids[1]
        );
        if self.seed != 0 {
            tag += &format!("-seed{}", self.seed);
        }
        tag
    }
}

impl Default for ReferenceSettings {
    /// The experiments' reference: 10^9 + 10^9 light paths, direct light on 16 x 16 and 17 x 17
    /// grids.
    fn default() -> Self {
        ReferenceSettings {
            light_paths: 1_000_000_000,
            caustic_paths: 1_000_000_000,
            direct_grids: [16, 17],
            seed: 0,
        }
    }
}

/// Makes the reference of `scene` (on the current rayon pool). `log` receives a message as each
/// stage starts; `progress` reports the light tracing's progress as it goes
/// ([`crate::util::progress::bar`]: it takes most of the time). `stats` gets a stage for each
/// half's direct light and one for the light tracing, the rays of all three, the light paths
/// and the threads.
pub fn make(
    scene: &Scene,
    embree: &embree::Scene,
    settings: &ReferenceSettings,
    progress: bool,
    log: &mut dyn FnMut(&str),
    stats: &mut Stats,
) -> Result<Reference, String> {
    make_stoppable(scene, embree, settings, false, progress, log, stats).map(|(r, _)| r)
}

/// [`make`], whose light tracing stops early (after the chunks of paths under way) when
/// `on_interrupt` and [`crate::util::interrupt`] asks it to: a reference of hours is not lost
/// to a Ctrl-C. Returns the settings as traced too: the light paths of each set counted as
/// traced, which is what the reference is of (those asked when it ran to its end).
pub fn make_stoppable(
    scene: &Scene,
    embree: &embree::Scene,
    settings: &ReferenceSettings,
    on_interrupt: bool,
    progress: bool,
    log: &mut dyn FnMut(&str),
    stats: &mut Stats,
) -> Result<(Reference, ReferenceSettings), String> {
    let mut direct = Vec::new();
    for (&grid, half) in settings.direct_grids.iter().zip(["A", "B"]) {
        log(&format!(
            "reference: direct light, {grid} x {grid} rays per pixel"
        ));
        let options = RenderOptions::default()
            .with_view_grid(grid)
            .with_area_strata(8)
            .with_threads(rayon::current_num_threads());
        let mut own = Stats::default();
        let stage = format!("direct light, half {half}");
        direct.push(stats.time(&stage, || render(scene, embree, &[], &options, &mut own))?);
        stats.rays.add(&own.rays);
        stats.invalid_rays += own.invalid_rays;
    }
    stats.threads = rayon::current_num_threads();
    let options = LightTraceOptions {
        paths: settings.light_paths,
        caustic_paths: settings.caustic_paths,
        direct: false,
        seed: settings.seed,
        on_interrupt,
        ..LightTraceOptions::default()
    };
    let tracer = LightTracer::new(scene, embree, &options);
    if on_interrupt {
        // From here a stop keeps the paths traced; before, there was nothing to keep.
        crate::util::interrupt::begin();
    }
    // As many as the tracer traces: an even number of whole chunks of each set.
    let (global, caustic) = tracer.planned_paths();
    log(&format!(
        "reference: light tracing {global} + {caustic} caustic paths"
    ));
    let bar = crate::util::progress::bar(progress, global + caustic, "light");
    let traced = stats.time("light tracing", || tracer.run(&bar));
    bar.finish_and_clear();
    let as_traced = match crate::util::interrupt::honoured() && on_interrupt {
        true => ReferenceSettings {
            light_paths: traced.set_paths[0],
            caustic_paths: traced.set_paths[1],
            ..*settings
        },
        false => *settings,
    };
    stats.light_paths = traced.paths;
    stats.light_rays = traced.rays;
    let sum = |a: &Film, b: &Film| Film {
        width: a.width,
        height: a.height,
        pixels: a
            .pixels
            .iter()
            .zip(&b.pixels)
            .map(|(x, y)| *x + *y)
            .collect(),
    };
    let half_a = sum(&direct[0], &traced.half_a);
    let half_b = sum(&direct[1], &traced.half_b);
    let film = Film {
        width: half_a.width,
        height: half_a.height,
        pixels: half_a
            .pixels
            .iter()
            .zip(&half_b.pixels)
            .map(|(a, b)| (*a + *b) * 0.5)
            .collect(),
    };
    Ok((
        Reference {
            film,
            half_a,
            half_b,
        },
        as_traced,
    ))
}

/// The mean of references made with the same settings and different seeds: a reference with
/// their light paths summed (each part's direct light is the same, so it stays as it is).
/// Part `k` is itself the mean of `weights[k]` such references (1 for a reference traced
/// once, more for one merged before), so the result is the mean of all of theirs.
pub fn merge(parts: &[Reference], weights: &[u64]) -> Result<Reference, String> {
    let first = parts.first().ok_or("no references to merge")?;
    if weights.len() != parts.len() || weights.contains(&0) {
        return Err(format!(
            "{} references to merge with {} weights, which must be positive",
            parts.len(),
            weights.len()
        ));
    }
    let (w, h) = (first.film.width, first.film.height);
    if let Some(p) = parts
        .iter()
        .find(|p| (p.film.width, p.film.height) != (w, h))
    {
        return Err(format!(
            "references of different sizes: {w}x{h} and {}x{}",
            p.film.width, p.film.height
        ));
    }
    let mean = |film: fn(&Reference) -> &Film| {
        let mut sum = Film::new(w, h);
        for (part, &weight) in parts.iter().zip(weights) {
            for (s, p) in sum.pixels.iter_mut().zip(&film(part).pixels) {
                *s += *p * weight as f64;
            }
        }
        let n = weights.iter().sum::<u64>() as f64;
        sum.pixels.iter_mut().for_each(|p| *p /= n);
        sum
    };
    Ok(Reference {
        film: mean(|r| &r.film),
        half_a: mean(|r| &r.half_a),
        half_b: mean(|r| &r.half_b),
    })
}

/// The attribute naming the scene a cached reference was made of
/// ([`crate::scene::hash::content_hash`]).
pub const CONTENT_KEY: &str = "photondiff/scene_content";

/// Loads the reference cached as `{dir}/{name}-{w}x{h}-{settings}.exr` (with `-a`/`-b`
/// halves), or makes it ([`make`]) and caches it.
pub fn load_or_make(
    scene: &Scene,
    embree: &embree::Scene,
    dir: &Path,
    name: &str,
    settings: &ReferenceSettings,
    log: &mut dyn FnMut(&str),
) -> Result<Reference, String> {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let tag = settings.tag();
    let file = |suffix: &str| -> PathBuf { dir.join(format!("{name}-{w}x{h}-{tag}{suffix}.exr")) };
    // What the reference was made of: a scene edited under the same name is made anew.
    let content = format!("{:016x}", crate::scene::hash::content_hash(scene));
    if file("").exists() && file("-a").exists() && file("-b").exists() {
        log(&format!("reference: reading {}", file("").display()));
        let whole = crate::render::part::read_part(&file(""))?;
        let same_size = whole.film.width == w && whole.film.height == h;
        let reuse = match whole.metadata.get(CONTENT_KEY) {
            Some(made_of) if *made_of != content => {
                log(&format!(
                    "reference: {} was made of another scene of that name (content \
                     {made_of}, the scene's {content})",
                    file("").display()
                ));
                false
            }
            None if same_size => {
                log(&format!(
                    "reference: {} does not record what scene it was made of (made before \
                     stop 50): delete it if the scene has changed since",
                    file("").display()
                ));
                true
            }
            _ => same_size,
        };
        // The halves are read only for a reference that is used.
        if reuse {
            return Ok(Reference {
                film: whole.film,
                half_a: Film::read_exr(&file("-a"))?,
                half_b: Film::read_exr(&file("-b"))?,
            });
        }
    }
    log(&format!(
        "reference: making it (cached in {})",
        dir.display()
    ));
    // With its progress (a bar, or a line every 15 s in a log): the benchmarks' references
    // take minutes, and their light tracing said nothing for all of them.
    let reference = make(scene, embree, settings, true, log, &mut Stats::default())?;
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let meta = vec![
        ("photondiff/reference".to_string(), tag.clone()),
        (CONTENT_KEY.to_string(), content),
    ];
    reference.film.write_exr(&file(""), &meta)?;
    reference.half_a.write_exr(&file("-a"), &meta)?;
    reference.half_b.write_exr(&file("-b"), &meta)?;
    Ok(reference)
}
