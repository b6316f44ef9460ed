//! The photon pass of a render: traces the caustic and global maps and picks the estimator the
//! rendering loop calls at diffuse hits.

use crate::coplanar::CoplanarEstimate;
use crate::embree;
use crate::emission::Emitter;
use crate::estimate::{JensenEstimate, PhotonDifferentialEstimate, RadianceEstimator};
use crate::multisampled::MultiSampledEstimate;
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
    /// Coplanar intersection-weighted photon differentials: the view footprint intersected with
    /// each photon's footprint (Pedersen).
    Coplanar,
    /// Multi-sampled photon differentials: each kernel averaged over N x N points of the view
    /// footprint (Pedersen).
    Multisampled,
    /// Not a photon map estimate: the light-tracing reference ([`crate::lighttrace`]).
    Lighttrace,
}

/// How the photon maps are estimated.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct EstimatorSettings {
    /// Which estimate.
    pub kind: EstimatorKind,
    /// Nearest photons per `jensen` estimate.
    pub k: usize,
    /// Largest `jensen` gather radius.
    pub max_radius: f64,
    /// Sample grid side of the `multisampled` estimate (1 to 32).
    pub ms_grid: u32,
    /// Vertices of the polygon standing for a photon footprint in the `coplanar` estimate.
    pub ellipse_vertices: usize,
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
    /// The estimators over both maps (none for [`EstimatorKind::Direct`]).
    pub fn estimators(&self, settings: &EstimatorSettings) -> Vec<Box<dyn RadianceEstimator + '_>> {
        [&self.caustic, &self.global]
            .into_iter()
            .filter_map(|map| -> Option<Box<dyn RadianceEstimator>> {
                Some(match settings.kind {
                    EstimatorKind::Direct | EstimatorKind::Lighttrace => return None,
                    EstimatorKind::Jensen => Box::new(JensenEstimate {
                        map,
                        k: settings.k,
                        max_radius: settings.max_radius,
                    }),
                    EstimatorKind::Pd => Box::new(PhotonDifferentialEstimate { map }),
                    EstimatorKind::Coplanar => Box::new(CoplanarEstimate {
                        map,
                        ellipse_vertices: settings.ellipse_vertices,
                    }),
                    EstimatorKind::Multisampled => {
                        Box::new(MultiSampledEstimate::new(map, settings.ms_grid))
                    }
                })
            })
            .collect()
    }
}
