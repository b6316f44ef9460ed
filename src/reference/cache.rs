//! Light-traced references for the experiments, cached on disk: a reference at the scene's
//! resolution costs minutes, so it is made once per scene, size and path count and reused.

use crate::embree;
use crate::reference::light_tracer::{LightTraceOptions, LightTraceResult, LightTracer};
use crate::render::film::Film;
use crate::scene::Scene;
use std::path::{Path, PathBuf};

/// A reference image and its two independent halves (for its noise).
pub struct Reference {
    /// All paths.
    pub film: Film,
    /// Even chunks.
    pub half_a: Film,
    /// Odd chunks.
    pub half_b: Film,
}

impl Reference {
    /// The estimated noise of the reference over `pixels`, relative to its mean there.
    pub fn relative_noise(&self, pixels: &[usize]) -> f64 {
        LightTraceResult {
            film: self.film.clone(),
            half_a: self.half_a.clone(),
            half_b: self.half_b.clone(),
            paths: 0,
            rays: 0,
        }
        .relative_noise(pixels)
    }
}

/// Loads the reference cached as `{dir}/{name}-{w}x{h}-{paths}.exr` (with `-a`/`-b` halves),
/// or light-traces it with `paths` paths (on the current rayon pool) and caches it. `log`
/// receives progress messages.
pub fn load_or_make(
    scene: &Scene,
    embree: &embree::Scene,
    dir: &Path,
    name: &str,
    paths: u64,
    log: &mut dyn FnMut(&str),
) -> Result<Reference, String> {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let file =
        |suffix: &str| -> PathBuf { dir.join(format!("{name}-{w}x{h}-{paths}{suffix}.exr")) };
    if file("").exists() && file("-a").exists() && file("-b").exists() {
        log(&format!("reference: reading {}", file("").display()));
        let reference = Reference {
            film: Film::read_exr(&file(""))?,
            half_a: Film::read_exr(&file("-a"))?,
            half_b: Film::read_exr(&file("-b"))?,
        };
        if reference.film.width == w && reference.film.height == h {
            return Ok(reference);
        }
    }
    log(&format!(
        "reference: light tracing {paths} paths (cached in {})",
        dir.display()
    ));
    let options = LightTraceOptions {
        paths,
        ..LightTraceOptions::default()
    };
    let tracer = LightTracer::new(scene, embree, &options);
    let result = tracer.run(&indicatif::ProgressBar::hidden());
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let meta = vec![(
        "photondiff/light_paths".to_string(),
        result.paths.to_string(),
    )];
    result.film.write_exr(&file(""), &meta)?;
    result.half_a.write_exr(&file("-a"), &meta)?;
    result.half_b.write_exr(&file("-b"), &meta)?;
    Ok(Reference {
        film: result.film,
        half_a: result.half_a,
        half_b: result.half_b,
    })
}
