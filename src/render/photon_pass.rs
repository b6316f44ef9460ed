//! The photon pass of a render: traces the caustic and global maps (or the radiance map of
//! final gathering in the global map's place), timed and counted in the statistics.

use super::stats::{MapStats, Stats};
use crate::embree;
use crate::photons::emission::Emitter;
use crate::photons::footprint::Guards;
use crate::photons::map::{PathClass, PhotonMap};
use crate::photons::options::PhotonOptions;
use crate::photons::radiance_map::{self, RadianceMap, RadianceSample};
use crate::photons::trace::{emission_stopped, PhotonTracer, StopRule, TraceCounts};
use crate::photons::PhotonMaps;
use crate::scene::Scene;
use crate::util::reserve;
use rayon::prelude::*;

/// What the global photons were traced into: the global map, or what the radiance map of
/// final gathering reads of each photon and of its mirrors (the map is made after).
enum Global {
    Map(Box<PhotonMap>),
    Radiance(Vec<RadianceSample>, Vec<RadianceSample>),
}

/// Traces both maps on `threads` threads (0 = all), recording a "trace photons" stage (and a
/// "radiance map" stage with final gathering) and the maps' statistics in `stats`.
pub fn trace_photon_maps(
    scene: &Scene,
    embree: &embree::Scene,
    options: &PhotonOptions,
    threads: usize,
    progress: bool,
    stats: &mut Stats,
) -> Result<PhotonMaps, String> {
    let pool = crate::util::pool::workers(threads)?;
    // (`photons` wrote 0; a render's image sets it again, to the same count.)
    stats.threads = pool.current_num_threads();
    let tracer = PhotonTracer::new(scene, embree, options);
    let total = (options.caustic_photons + options.global_photons) as u64;
    let bar = crate::util::progress::bar(progress, total, "photons");
    // With final gathering the global photons go to the radiance map, whose precomputation is
    // a stage of its own ("radiance map"), so that its cost shows.
    let (caustic, global, counts, global_share) = stats.time("trace photons", || {
        pool.install(|| {
            // Each map a span of its own in the trace (`--trace`): they differ in cost by
            // orders of magnitude from scene to scene.
            let span = crate::util::trace::span("caustic map");
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
            )?;
            drop(span);
            let _span = crate::util::trace::span("global map");
            // Built here, in the stage and the span it serves: it finds the scene's box and
            // the specular objects' spheres, reading every mesh's vertices.
            let global_emitter = global_emitter(scene, options);
            let share = global_emitter.share();
            let stop = StopRule::Stored(options.global_photons);
            if options.radiance_map {
                // Only what the radiance map reads of each photon is kept.
                let (mut samples, mut mirrors) = (Vec::new(), Vec::new());
                let g = tracer.trace_photons_into(
                    &global_emitter,
                    PathClass::AllDiffuse,
                    stop,
                    &bar,
                    |batch| {
                        let what = "photons stored for the radiance map";
                        reserve::make_room(&mut samples, batch.len(), what)?;
                        let first = samples.len();
                        samples.extend(batch.iter().map(RadianceSample::of));
                        // The images of the photons the estimates read (not of the points).
                        const BLOCK: usize = 1 << 9;
                        let images: Vec<Vec<RadianceSample>> = batch
                            .par_chunks(BLOCK)
                            .enumerate()
                            .map(|(b, block)| {
                                let at = first + b * BLOCK;
                                let read = |j: usize| !radiance_map::is_point(at + j);
                                tracer.mirror_samples(block, read)
                            })
                            .collect();
                        let more = images.iter().map(Vec::len).sum();
                        reserve::make_room(&mut mirrors, more, "mirror photons stored")?;
                        mirrors.extend(images.into_iter().flatten());
                        Ok(())
                    },
                )?;
                Ok((caustic, Global::Radiance(samples, mirrors), [c, g], share))
            } else {
                let (global, g) =
                    tracer.build_map(&global_emitter, PathClass::Global, stop, &bar)?;
                Ok::<_, String>((caustic, Global::Map(Box::new(global)), [c, g], share))
            }
        })
    })?;
    let maps = match global {
        Global::Map(global) => PhotonMaps {
            caustic,
            global: *global,
            radiance: None,
        },
        Global::Radiance(traced, mirrors) => {
            let max_radius = options.radiance_max_radius(scene);
            let emitted = counts[1].emitted;
            let radiance = stats.time("radiance map", || {
                pool.install(|| RadianceMap::with_mirrors(&traced, &mirrors, emitted, max_radius))
            });
            PhotonMaps {
                caustic,
                global: PhotonMap::new(PathClass::Global, Vec::new(), 0, Guards::default()),
                radiance: Some(radiance),
            }
        }
    };
    bar.finish_and_clear();
    record(&maps, &counts, options, global_share, stats);
    Ok(maps)
}

/// The global map's emitter for `options` (aimed at the specular objects by
/// [`PhotonOptions::emission_aim`]).
fn global_emitter(scene: &Scene, options: &PhotonOptions) -> Emitter {
    Emitter::global_aimed(
        scene,
        options.global_photons,
        options.global_overlap(),
        options.seed,
        options.emission_aim(),
    )
}

/// Reads photon maps traced earlier (`photondiff photons`) from `path` instead of tracing
/// them, recording a "load photons" stage; the file must be for the scene with content hash
/// `scene_hash` and traced with `options` (see [`crate::photons::file`]).
pub fn load_photon_maps(
    path: &std::path::Path,
    scene: &Scene,
    scene_hash: u64,
    options: &PhotonOptions,
    stats: &mut Stats,
) -> Result<PhotonMaps, String> {
    let (maps, counts) = stats.time("load photons", || {
        crate::photons::file::read(path, scene_hash, options)
    })?;
    // The share the global map's cap was scaled by when it was traced.
    let share = global_emitter(scene, options).share();
    record(&maps, &counts, options, share, stats);
    Ok(maps)
}

/// Records the maps' statistics (the radiance map's in the global map's place when there is
/// one).
fn record(
    maps: &PhotonMaps,
    counts: &[TraceCounts; 2],
    options: &PhotonOptions,
    global_share: f64,
    stats: &mut Stats,
) {
    let asked = [options.caustic_photons, options.global_photons];
    // The caps the tracer applied: the global map's scaled by its emitter's share.
    let shares = [1.0, global_share];
    let mean = |p: glam::DVec3| (p.x + p.y + p.z) / 3.0;
    let second = match &maps.radiance {
        Some(r) => (
            PathClass::AllDiffuse,
            mean(r.power),
            Guards {
                mirrored: r.mirrors as u64,
                ..Guards::default()
            },
        ),
        None => (
            PathClass::Global,
            mean(maps.global.total_power()),
            maps.global.guards,
        ),
    };
    let entries = [
        (
            PathClass::Caustic,
            mean(maps.caustic.total_power()),
            maps.caustic.guards,
        ),
        second,
    ];
    for ((((class, power, guards), c), asked), share) in
        entries.into_iter().zip(counts).zip(asked).zip(shares)
    {
        stats.photon_maps.push(MapStats {
            class,
            emitted: c.emitted,
            stored: c.stored,
            rays: c.rays,
            power,
            guards,
            asked: asked as u64,
            cap_reached: emission_stopped(class, asked, share, c),
        });
    }
}
