//! The photon pass of a render: traces the caustic and global maps and picks the estimator the
//! rendering loop calls at diffuse hits.

use crate::embree;
use crate::emission::Emitter;
use crate::estimate::{JensenEstimate, PhotonDifferentialEstimate, RadianceEstimator};
use crate::photon_map::{PathClass, PhotonMap};
use crate::photon_trace::{PhotonOptions, PhotonTracer, StopRule};
use crate::scene::Scene;
use crate::stats::{MapStats, Stats};

/// Which radiance estimate renders the photon maps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
pub enum EstimatorKind {
    /// Direct light only: no photon maps.
    Direct,
    /// The regular estimate: k nearest photons, normalised kernel (Jensen).
    Jensen,
    /// The photon-differential estimate: each photon's own footprint (Schjoth et al.).
    Pd,
}

/// The caustic and global photon maps of a scene.
pub struct PhotonMaps {
    /// Light -> specular+ -> diffuse.
    pub caustic: PhotonMap,
    /// After at least one diffuse bounce.
    pub global: PhotonMap,
}

/// Traces both maps on `threads` threads (0 = all), recording a "trace photons" stage and the
/// maps' statistics in `stats`.
pub fn trace_photon_maps(
    scene: &Scene,
    embree: &embree::Scene,
    options: &PhotonOptions,
    threads: usize,
    progress: bool,
    stats: &mut Stats,
) -> Result<PhotonMaps, String> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| format!("cannot start worker threads: {e}"))?;
    let tracer = PhotonTracer::new(scene, embree, options);
    let total = (options.caustic_photons + options.global_photons) as u64;
    let bar = crate::progress::bar(progress, total, "photons");
    let (maps, counts) = stats.time("trace photons", || {
        pool.install(|| {
            let caustic_emitter = Emitter::caustic(
                scene,
                options.caustic_photons,
                options.overlap,
                options.seed,
            );
            let (caustic, c) = tracer.build_map(
                &caustic_emitter,
                PathClass::Caustic,
                StopRule::Stored(options.caustic_photons),
                &bar,
            );
            let global_emitter =
                Emitter::global(scene, options.global_photons, options.overlap, options.seed);
            let (global, g) = tracer.build_map(
                &global_emitter,
                PathClass::Global,
                StopRule::Emitted(options.global_photons),
                &bar,
            );
            (PhotonMaps { caustic, global }, [c, g])
        })
    });
    bar.finish_and_clear();
    for (map, c) in [&maps.caustic, &maps.global].into_iter().zip(counts) {
        let p = map.total_power();
        stats.photon_maps.push(MapStats {
            class: map.class,
            emitted: c.emitted,
            stored: c.stored,
            rays: c.rays,
            power: (p.x + p.y + p.z) / 3.0,
            guards: map.guards,
        });
    }
    Ok(maps)
}

impl PhotonMaps {
    /// The estimators of `kind` over both maps; `k` and `max_radius` configure the regular
    /// estimate.
    pub fn estimators(
        &self,
        kind: EstimatorKind,
        k: usize,
        max_radius: f64,
    ) -> Vec<Box<dyn RadianceEstimator + '_>> {
        let maps = [&self.caustic, &self.global];
        match kind {
            EstimatorKind::Direct => Vec::new(),
            EstimatorKind::Jensen => maps
                .into_iter()
                .map(|map| {
                    Box::new(JensenEstimate { map, k, max_radius }) as Box<dyn RadianceEstimator>
                })
                .collect(),
            EstimatorKind::Pd => maps
                .into_iter()
                .map(|map| {
                    Box::new(PhotonDifferentialEstimate { map }) as Box<dyn RadianceEstimator>
                })
                .collect(),
        }
    }
}
