//! `photondiff photons`: traces a scene's photon maps once and writes them to a file that
//! `render --photon-maps` reads (format: `photondiff::photons::file`).

use super::create_parent;
use super::render::reads::{reads_id, Run};
use photondiff::estimate::EstimatorKind;
use photondiff::photons::file;
use photondiff::photons::options::PhotonOptions;
use photondiff::photons::trace::TraceCounts;
use photondiff::render::defaults::RenderDefaults;
use photondiff::render::stats::{MemoryStats, Stats};
use photondiff::render::trace_photon_maps;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct PhotonsArgs {
    /// The scene file.
    scene: PathBuf,
    /// The photon-map file to write.
    #[arg(short = 'o', long = "output", value_name = "MAPS")]
    output: PathBuf,
    /// The estimator whose render will read the maps: the maps take that render's defaults
    /// (as `render --estimator`): `integrated`, the default render's, or the thesis's for
    /// `jensen`, `pd`, `coplanar` and `multisampled`. The options below override them.
    #[arg(long, value_enum, default_value = "integrated")]
    estimator: EstimatorKind,
    #[command(flatten)]
    photons: super::photon_args::PhotonArgs,
    /// Seed of the photons' random streams (as `render --seed`).
    #[arg(long, value_name = "S", default_value_t = 0, value_parser = super::whole::<u64>)]
    seed: u64,
    /// Worker threads and Embree's BVH build threads (0 = one per core; at most 1024); the
    /// maps are identical for any count.
    #[arg(long, value_name = "N", default_value_t = 0, value_parser = super::thread_count)]
    threads: usize,
    #[command(flatten)]
    bvh: super::bvh::BvhArgs,
    /// Write the run's statistics (times per stage, each map's emissions, photons and rays,
    /// memory) as JSON to FILE, in `render --stats-json`'s shape.
    #[arg(long, value_name = "FILE")]
    stats_json: Option<PathBuf>,
    /// Write a trace for profiling to FILE: Chrome trace-event JSON with spans per stage and
    /// per map; open it in Perfetto (ui.perfetto.dev) or chrome://tracing.
    #[arg(long, value_name = "FILE")]
    trace: Option<PathBuf>,
    /// No progress bar and no memory line.
    #[arg(short, long)]
    quiet: bool,
}

/// Runs `photondiff photons`.
pub fn run(args: &PhotonsArgs) -> Result<(), String> {
    super::check_threads(args.threads)?;
    let mut outputs = vec![("-o", args.output.as_path())];
    outputs.extend(args.stats_json.as_deref().map(|p| ("--stats-json", p)));
    outputs.extend(args.trace.as_deref().map(|p| ("--trace", p)));
    super::check_outputs(&outputs, &[("scene", &args.scene)])?;
    if !args.estimator.reads_maps() {
        return Err(format!(
            "--estimator {} uses no photon maps",
            args.estimator.name()
        ));
    }
    let defaults = RenderDefaults::for_estimator(args.estimator);
    let options = args.photons.options(&defaults, args.seed)?;
    // The render that reads the maps (never final gathering's: it traces its own) refuses an
    // --overlap it does not read (`jensen` without probed walls), so it could read no file of
    // an overlap other than its default (the file's settings must be the render's).
    let render = Run {
        kind: args.estimator,
        gather_rays: 0,
        probe_walls: options.probe_walls,
        one_pass: false,
        passes_given: false,
    };
    if !reads_id(&render, "overlap") && options.overlap != PhotonOptions::default().overlap {
        let name = args.estimator.name();
        return Err(format!(
            "--overlap does not apply to --estimator {name} without --probe-walls (its k \
             nearest photons have no footprints, and a {name} render could not read these maps)"
        ));
    }
    super::start_trace(args.trace.as_deref())?;
    let mut stats = Stats::of_this_build();
    let (scene, hash) = stats.time("load scene", || {
        super::load_scene(&args.scene, !args.quiet, &outputs, None)
    })?;
    let mark = photondiff::util::memory::ResidentMark::now();
    let (device, embree, bvh) = stats.time("build BVH", || {
        args.bvh
            .build(&scene, &args.scene, args.threads, !args.quiet)
    })?;
    stats.memory = MemoryStats::after_build(&scene, &device, bvh, mark);
    super::check_photon_memory(&args.scene, &scene, &options)?;
    let progress = !args.quiet;
    let maps = trace_photon_maps(
        &scene,
        &embree,
        &options,
        args.threads,
        progress,
        &mut stats,
    )?;
    super::render::warn_shortfalls(
        &args.scene,
        &stats,
        args.photons.caustic_photons.is_some(),
        args.photons.global_photons.is_some(),
    );
    let counts: [TraceCounts; 2] = [0, 1].map(|i| {
        let m = &stats.photon_maps[i];
        TraceCounts {
            emitted: m.emitted,
            stored: m.stored,
            rays: m.rays,
        }
    });
    stats.time("write photon maps", || {
        create_parent(&args.output)?;
        file::write(&args.output, &maps, &counts, hash, &options)
    })?;
    stats.memory.record_peak();
    super::write_trace_and_stats(
        args.trace.as_deref(),
        args.stats_json.as_deref(),
        &stats,
        &[&args.output],
    )?;
    // Stored photons, as the statistics count them; mirror photons at walls apart.
    let mirrors = maps.caustic.guards.mirrored + maps.global.guards.mirrored;
    out!(
        "wrote {}: {} caustic and {} global photons{}",
        args.output.display(),
        counts[0].stored,
        counts[1].stored,
        if mirrors > 0 {
            format!(" (and {mirrors} mirror photons at walls and edges)")
        } else {
            String::new()
        }
    );
    super::print_memory(&mut stats.memory, args.quiet);
    Ok(())
}
