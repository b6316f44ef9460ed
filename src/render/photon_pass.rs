//! The photon pass of a render: traces the caustic and global maps, timed and counted in the
//! statistics.

use super::stats::{MapStats, Stats};
use crate::embree;
use crate::photons::emission::Emitter;
use crate::photons::map::PathClass;
use crate::photons::trace::{PhotonOptions, PhotonTracer, StopRule};
use crate::photons::PhotonMaps;
use crate::scene::Scene;

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
    let bar = crate::util::progress::bar(progress, total, "photons");
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
