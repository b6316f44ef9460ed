//! `photondiff render`: a scene file to an EXR, a PNG preview and statistics.

use super::create_parent;
use photondiff::estimate::final_gather::{MAX_GATHER_RAYS, NEAR_REACH};
use photondiff::estimate::{EstimatorKind, EstimatorSettings};
use photondiff::photons::map::PathClass;
use photondiff::photons::options::PhotonOptions;
use photondiff::reference::light_tracer::{LightTraceOptions, LightTracer, MAX_PATHS};
use photondiff::render::defaults::RenderDefaults;
use photondiff::render::film::{self, Film};
use photondiff::render::pass_part::write_pass_part;
use photondiff::render::passes::{pass_photons, StopReason, DEFAULT_ALPHA, DEFAULT_GLOBAL_ALPHA};
use photondiff::render::stats::{MemoryStats, Stats};
use photondiff::render::{load_photon_maps, Progressive, RenderOptions, Window};
use photondiff::scene::Scene;
use std::path::{Path, PathBuf};

mod checks;
mod metadata;
pub(super) mod reads;

/// The longest `--time-budget` taken, in seconds: 365 days.
const MAX_TIME_BUDGET: f64 = 31_536_000.0;

/// The most mirror/glass bounces a camera path may take (`--max-depth`). Each bounce is a level
/// of recursion on a worker thread's stack (about 1.4 KB a level: 1,500 overflowed the default
/// 2 MiB stack and aborted the process); 256 leaves a wide margin, and a path whose weight falls
/// below 1e-3 ends well before it in any scene that absorbs light.
pub const MAX_DEPTH: u32 = 256;

/// Specular rays a camera ray above which a render without `--split-depth` says that option
/// exists: one glass object takes about half a ray (the canonical scene 0.54), the stress scene
/// of glass behind glass 8.8, the production scene's hundred balls 14.4.
const SPLIT_NOTE_RAYS: u64 = 4;

#[derive(clap::Args)]
pub struct RenderArgs {
    /// The scene file (TOML; see README.md for the format).
    scene: PathBuf,
    /// Output EXR (linear float RGB, with settings and times in its metadata).
    /// Default: out/<scene name>.exr.
    #[arg(short = 'o', long = "output", value_name = "OUT.exr")]
    output: Option<PathBuf>,
    /// Output PNG preview (sRGB, clamped). Default: the EXR path with a .png extension (none
    /// where -o is a device or pipe, such as /dev/null).
    #[arg(long, value_name = "OUT.png")]
    png: Option<PathBuf>,
    /// Image size in pixels, WIDTHxHEIGHT (such as 320x240), instead of the scene file's: the
    /// same eye, view and vertical field of view (another aspect ratio widens or narrows the
    /// view across), for a preview or a test at a fraction of the final size without an
    /// edited copy of the scene.
    #[arg(long, value_name = "WxH", value_parser = super::resolution::parse)]
    resolution: Option<super::resolution::Resolution>,
    /// Camera rays per pixel along each axis: N x N on a regular grid, each ray's differential
    /// spanning 1/N of the pixel, box-filtered.
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=64))]
    view_grid: u32,
    /// Cells per axis of a pixel on a geometric edge (where the rays through its corners meet
    /// different surfaces: an outline, two walls meeting): such pixels alone are rendered on an
    /// N x N grid, each cell with its own footprint, so that an estimate over the footprint
    /// does not spread one surface's light over the part of the pixel another hides; final
    /// gathering spends the pixel's --gather-rays over its cells. Costs one corner ray per pixel
    /// (once a run) plus the edge pixels' cells. Default 4 with final gathering (--gather-rays
    /// above 0), where the gather rays dominate and it costs a few percent; 8 for a long run of
    /// `integrated` (--time-budget, --target-noise or more than 2 passes), where it removes a
    /// bias at occluding edges that the passes never would (8 rather than 4: every cell takes
    /// the pass's jitter, and finer cells halve the pass-to-pass wobble that grid gives edge
    /// pixels); 1 (off) otherwise; at most --view-grid is off.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=64))]
    edge_grid: Option<u32>,
    /// Worker threads and Embree's BVH build threads (0 = one per core; at most 1024).
    #[arg(long, value_name = "N", default_value_t = 0, value_parser = super::thread_count)]
    threads: usize,
    /// Seed of every random stream; the same seed gives a bit-identical image on any thread count.
    #[arg(long, value_name = "S", default_value_t = 0, value_parser = super::whole::<u64>)]
    seed: u64,
    /// Write the run's statistics (times per stage, rays by kind) as JSON to FILE.
    #[arg(long, value_name = "FILE")]
    stats_json: Option<PathBuf>,
    /// Maximum number of mirror/glass bounces of a camera path, at most 256 (a path's bounces
    /// are followed recursively, and glass splits each one in two; photon paths meet at most 1,024
    /// surfaces, 64 mirror or glass surfaces in a row).
    #[arg(long, value_name = "N", default_value_t = 10,
          value_parser = clap::value_parser!(u32).range(0..=MAX_DEPTH as i64))]
    max_depth: u32,
    /// Mirror and glass bounces after which a camera path's glass surfaces take one branch,
    /// reflected or refracted with Fresnel's probability, instead of both (0: one at every glass
    /// surface; without it, both at every one): for scenes of many glass objects, where split
    /// paths grow into trees of rays; each pass is noisier and cheaper, the image's expectation
    /// the same.
    #[arg(long, value_name = "N",
          value_parser = clap::value_parser!(u32).range(0..=MAX_DEPTH as i64))]
    split_depth: Option<u32>,
    /// Area-light samples per shading point along each axis (N x N stratified).
    #[arg(long, value_name = "N", default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=64))]
    area_samples: u32,
    /// Shadow rays to each point and spot light at a camera ray's first diffuse hit seen
    /// directly, along each axis: N x N rays from points spread over the pixel's footprint on
    /// the surface (anti-aliasing shadow edges and steep falloff within a pixel); hits seen
    /// through mirrors and glass keep one. Quad lights' --area-samples strata are spread over
    /// the same points, at least N x N of them. Default 2 for `integrated` (the default
    /// estimator), 1 (the hit alone) for the others.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=16))]
    footprint_shadow_rays: Option<u32>,
    /// Radiance estimate of the photon maps: `direct` (no photon maps, direct light only),
    /// `jensen` (k nearest photons), `pd` (photon differentials), `coplanar` (photon
    /// differentials weighted by their intersection with the view footprint), `multisampled`
    /// (photon differentials averaged over N x N points of the view footprint) or `integrated`
    /// (photon differentials averaged over the whole view footprint, exactly); or
    /// `lighttrace`, the unbiased light-tracing reference (no photon maps; see --light-paths).
    /// Default: `integrated` with progressive passes (see --passes).
    #[arg(long, value_enum)]
    estimator: Option<EstimatorKind>,
    #[command(flatten)]
    photons: super::photon_args::PhotonArgs,
    /// Final gathering: indirect diffuse light at the first diffuse hit of each camera path
    /// from N stratified cosine-distributed gather rays, which pass through mirrors and glass
    /// and read radiance precomputed from photons at every diffuse hit (--photons of them);
    /// 0 views the global map directly. At most 4096.
    #[arg(long, value_name = "N", default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=MAX_GATHER_RAYS as i64))]
    gather_rays: u32,
    /// Final gathering: a gather ray whose path to its diffuse hit is shorter than R radii of
    /// the radiance map's photon disc there (where that disc's blur, at an edge or in a
    /// corner, fills much of the hemisphere) goes a bounce further: direct light by shadow
    /// rays, caustics and two gather rays of its own at the hit. 0 never; at most 1000.
    #[arg(long, value_name = "R", default_value_t = NEAR_REACH)]
    gather_near: f64,
    /// Nearest photons per regular (jensen) estimate [default: 50]; `--estimator jensen` only.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=10_000))]
    k: Option<u32>,
    /// Sample grid side N of the multisampled estimate (N x N points per view footprint)
    /// [default: 8]; `--estimator multisampled` only.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=32))]
    ms_grid: Option<u32>,
    /// Vertices of the polygon standing for a photon's elliptical footprint [default: 16];
    /// `--estimator coplanar` only.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(3..=1024))]
    coplanar_vertices: Option<u32>,
    /// Light paths traced by `--estimator lighttrace`: at most 10^11, rounded up to an even
    /// number of whole chunks of 65536 (at least two).
    #[arg(long, value_name = "N", default_value_t = 20_000_000,
          value_parser = clap::value_parser!(u64).range(..=MAX_PATHS))]
    light_paths: u64,
    /// Progressive passes: the image is the mean of N independent passes (fresh photons with
    /// shrinking footprints, jittered camera rays). Default 2 for `integrated` (the default
    /// estimator) and 1 for the others (the thesis's methods as they were), or no limit with
    /// --time-budget or --target-noise. Ctrl-C stops the passes after the one under way (and
    /// `lighttrace` after the paths under way) and writes the image of what was done (exit
    /// status 130; SIGTERM the same, status 143); a second Ctrl-C exits at once. At most
    /// 1,000,000.
    #[arg(long, value_name = "N")]
    passes: Option<String>,
    /// Photon estimates and `direct`: stop after the last whole pass that fits in SECONDS (at
    /// least one pass). `lighttrace`: stop after SECONDS even if fewer paths are traced. At
    /// most 31536000 (a year).
    #[arg(long, value_name = "SECONDS")]
    time_budget: Option<f64>,
    /// Stop the passes once the estimated relative standard error of the mean (the larger of
    /// the whole image's and the caustic's) falls below X, e.g. 0.01.
    #[arg(long, value_name = "X")]
    target_noise: Option<f64>,
    /// Footprint schedule of the passes for the caustic map (and jensen's gathers): pass i+1's
    /// footprint area is (i + ALPHA) / (i + 1) times pass i's (i from 1), ALPHA in (0, 1). The
    /// default 0.5 suits a bias of first order in the radius: caustics' peaks and contours,
    /// light against walls and over edges.
    #[arg(long, value_name = "ALPHA", default_value_t = DEFAULT_ALPHA)]
    alpha: f64,
    /// Footprint schedule of the passes for the global map, as --alpha. 0.667 suits a scene
    /// whose global light is smooth (no walls or edges where it is bright).
    #[arg(long, value_name = "ALPHA", default_value_t = DEFAULT_GLOBAL_ALPHA)]
    global_alpha: f64,
    /// Read the photon maps from MAPS (written by `photondiff photons` for this scene with the
    /// same photon settings) instead of tracing them (for the first pass; later passes trace
    /// their own).
    #[arg(long, value_name = "MAPS")]
    photon_maps: Option<PathBuf>,
    /// Render only passes A to B - 1 (counting from 0) of the --passes N render, writing their
    /// exact sums for `photondiff merge` to add to the other ranges'.
    #[arg(long, value_name = "A..B")]
    pass_range: Option<String>,
    /// Render only tile I of N (I counts from 0): horizontal bands of whole 16-pixel tile rows,
    /// written as an EXR whose data window is the band; `photondiff merge` joins them.
    #[arg(long, value_name = "I/N")]
    tile: Option<String>,
    #[command(flatten)]
    bvh: super::bvh::BvhArgs,
    /// Write a trace for profiling to FILE: Chrome trace-event JSON with spans per stage, pass
    /// and tile and counter tracks (rays, photons, noise); open it in Perfetto
    /// (ui.perfetto.dev) or chrome://tracing.
    #[arg(long, value_name = "FILE")]
    trace: Option<PathBuf>,
    /// No progress (a bar on a terminal; elsewhere, as in a batch job's log, a line a pass or
    /// every 15 s of a long stage) and no statistics summary.
    #[arg(short, long)]
    quiet: bool,
    /// The ids of the options given on the command line (not their defaults), which `main`
    /// fills from clap's matches: an option the run would not read is refused only where it
    /// was given ([`checks::options`]).
    #[arg(skip)]
    pub given: Vec<String>,
}

/// The EXR and PNG paths of a render: `-o` (default `out/SCENE.exr`) and `--png` (default
/// the EXR's path with `.png`; none beside a device or pipe: [`super::preview_path`]).
fn output_paths(args: &RenderArgs) -> (PathBuf, Option<PathBuf>) {
    let stem = args
        .scene
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "render".into());
    let exr = args
        .output
        .clone()
        .unwrap_or_else(|| Path::new("out").join(format!("{stem}.exr")));
    let png = super::preview_path(&exr, args.png.as_deref());
    (exr, png)
}

/// Runs `photondiff render`.
pub fn run(args: &RenderArgs) -> Result<(), String> {
    super::check_threads(args.threads)?;
    let kind = estimator_kind(args);
    let defaults = RenderDefaults::for_estimator(kind);
    let stop = checks::stop_rules(args)?;
    let pass_range = super::pass_range::check(
        args.pass_range.as_deref(),
        args.passes.is_some(),
        &stop,
        kind,
    )?;
    if pass_range.is_none() {
        // From the start, so that a Ctrl-C while the scene loads is not lost either.
        super::stop_on_ctrl_c(if kind == EstimatorKind::Lighttrace {
            "finishing the light paths under way, then writing the image of the paths traced"
        } else {
            "dropping the pass under way, then writing the mean of the passes done"
        });
    }
    if stop.target_noise.is_some() && !kind.converges_with_passes() {
        // Measured: multisampled 8x8 stayed 0.29 from the reference from 1 to 64 passes (two
        // seeds alike) while its noise fell to 1.6%, and coplanar stopped "at 2%" 255% off.
        photondiff::stderr_line!(
            "photondiff: warning: --target-noise measures the noise between passes, not the \
             bias: --estimator {} does not converge to the reference with passes (README, \
             \"What passes do not mend\"); --estimator integrated does",
            kind.name()
        );
    }
    let (exr, png) = output_paths(args);
    if let Some(png) = &png {
        super::check_image_names(&exr, png)?;
    }
    let png_flag = if args.png.is_some() {
        "--png"
    } else {
        "the PNG preview (-o with .png)"
    };
    let mut outputs = vec![("-o", exr.as_path())];
    outputs.extend(png.as_deref().map(|p| (png_flag, p)));
    outputs.extend(args.stats_json.as_deref().map(|p| ("--stats-json", p)));
    outputs.extend(args.trace.as_deref().map(|p| ("--trace", p)));
    let mut inputs = vec![("scene", args.scene.as_path())];
    inputs.extend(
        args.photon_maps
            .as_deref()
            .map(|p| ("--photon-maps file", p)),
    );
    super::check_outputs(&outputs, &inputs)?;
    // Every option on its own and against the others before the scene is read: a large
    // scene takes seconds to load and build.
    let tile = checks::tile(args, kind)?;
    let run = reads::Run::of(args, kind, stop.passes);
    checks::options(args, &run, pass_range.as_ref())?;
    if let Some(n) = args.edge_grid.filter(|&n| n > 1 && n <= args.view_grid) {
        // Off as documented, but a user who asked for it should hear so.
        photondiff::stderr_line!(
            "photondiff: warning: --edge-grid {n} is no finer than --view-grid {}: edge pixels \
             are rendered on the view grid (an edge grid above the view grid refines them)",
            args.view_grid
        );
    }
    let photon_options = PhotonOptions {
        radiance_map: args.gather_rays > 0,
        ..args.photons.options(&defaults, args.seed)?
    };
    if let Some(path) = &args.photon_maps {
        // The file's header against pass 0's settings now; its photons once the scene is read
        // (and hashed, which the file must match too).
        let pass0 = pass_photons(&photon_options, args.alpha, args.global_alpha, 0);
        photondiff::photons::file::check(path, &pass0)?;
        if stop.time_budget.is_some() && !args.quiet {
            photondiff::stderr_line!(
                "photondiff: warning: --time-budget with --photon-maps: pass 0 reads its photons \
                 and the passes after it trace their own, so the time of a traced pass is known \
                 only once one has run: the second pass may end past the budget"
            );
        }
    }
    let mut range_sum = None;
    super::start_trace(args.trace.as_deref())?;
    let mut stats = Stats::of_this_build();
    let (scene, hash) = stats.time("load scene", || {
        super::load_scene(&args.scene, !args.quiet, &outputs, args.resolution)
    })?;
    let (width, height) = (scene.camera.width, scene.camera.height);
    let window = match &tile {
        Some(tile) => Some(tile.window(width, height)?),
        None => None,
    };
    // The part this run renders, before anything is allocated for it: a tile of an image too
    // large for this machine's memory may fit.
    let w = window.unwrap_or(Window::full(width, height));
    let part_pixels = u64::from(w.x1 - w.x0) * u64::from(w.y1 - w.y0);
    let check_part = || {
        if pass_range.is_some() {
            check_part_memory(part_pixels, tile.is_some())
        } else {
            let what = match &tile {
                Some(_) => format!("--tile: its {part_pixels} pixels"),
                None => super::resolution::describe(&args.scene, args.resolution, (width, height)),
            };
            film::check_image_memory(&what, "to render", part_pixels, film::PEAK_BYTES_PER_PIXEL)
        }
    };
    check_part()?;
    // Once per mesh, whatever --quiet says: the scene is not quite what its files say.
    for warning in scene.warnings() {
        photondiff::stderr_line!("photondiff: warning: {}: {warning}", args.scene.display());
    }
    stats.mesh_repairs = scene.mesh_report();
    let mark = photondiff::util::memory::ResidentMark::now();
    let (device, embree, bvh) = stats.time("build BVH", || {
        args.bvh
            .build(&scene, &args.scene, args.threads, !args.quiet)
    })?;
    stats.memory = MemoryStats::after_build(&scene, &device, bvh, mark);
    // Again with the BVH held: an image of the production mesh that fitted beside the mesh
    // (2400 x 1800 under a 1.6 GB limit) found the BVH had taken its room, and aborted 24 s
    // later. (Address-space limits still see more than these checks count: every thread's
    // allocator reserves its own arena.)
    check_part().map_err(|e| format!("{e} (with the scene and its BVH held)"))?;
    let options = RenderOptions::default()
        .with_view_grid(args.view_grid)
        .with_edge_grid(
            args.edge_grid
                .unwrap_or(defaults.edge_grid(args.gather_rays, &stop)),
        )
        .with_threads(args.threads)
        .with_seed(args.seed)
        .with_max_depth(args.max_depth)
        .with_split_depth(args.split_depth)
        .with_area_strata(args.area_samples)
        .with_footprint_strata(
            args.footprint_shadow_rays
                .unwrap_or(defaults.footprint_strata),
        )
        .with_progress(!args.quiet)
        .with_window(window);
    if kind.reads_maps() {
        super::check_photon_memory(&args.scene, &scene, &photon_options)?;
    }
    let settings = EstimatorSettings {
        kind,
        k: args.k.map_or(EstimatorSettings::DEFAULT_K, |k| k as usize),
        max_radius: photon_options.limits(&scene).max_radius,
        ms_grid: args.ms_grid.unwrap_or(EstimatorSettings::DEFAULT_MS_GRID),
        ellipse_vertices: args
            .coplanar_vertices
            .map_or(EstimatorSettings::DEFAULT_ELLIPSE_VERTICES, |n| n as usize),
        gather_rays: args.gather_rays,
        gather_near: args.gather_near,
    };
    // From here a Ctrl-C keeps what is done; before, it exits at once
    // (`super::stop_on_ctrl_c`).
    photondiff::util::interrupt::begin();
    let film = if kind == EstimatorKind::Lighttrace {
        light_trace(args, &scene, &embree, options.progress, &mut stats)?
    } else {
        let progressive = Progressive {
            scene: &scene,
            embree: &embree,
            photons: photon_options.clone(),
            estimator: settings,
            render: options.clone(),
            alpha: args.alpha,
            global_alpha: args.global_alpha,
        };
        // Photon maps from a file stand for pass 0's, whose settings they must match.
        let maps = match (&args.photon_maps, kind) {
            (Some(path), kind) if kind != EstimatorKind::Direct => {
                let (pass0, _, _) = progressive.pass_settings(0);
                Some(load_photon_maps(path, &scene, hash, &pass0, &mut stats)?)
            }
            _ => None,
        };
        match &pass_range {
            Some(range) => {
                let total = stop.passes.unwrap_or(1);
                let sum = super::pass_range::render(
                    &progressive,
                    range.clone(),
                    total,
                    maps,
                    &mut stats,
                )?;
                let film = sum.mean();
                range_sum = Some(sum);
                film
            }
            None => progressive
                .run_with_maps(&stop, maps, options.progress, &mut stats)?
                .mean(),
        }
    };

    // Only a count the user gave: the defaults are "up to" counts, and an open scene such as
    // the canonical one stores few global photons by design (the statistics still say so).
    warn_shortfalls(
        &args.scene,
        &stats,
        args.photons.caustic_photons.is_some(),
        args.photons.global_photons.is_some(),
    );
    // The EXR's statistics hold the peak so far (the images' writing is not in it); the
    // JSON and the summary, the run's.
    stats.memory.record_peak();
    let mut metadata = metadata::exr_metadata(
        args,
        &run,
        hash,
        &options,
        &photon_options,
        &settings,
        &stats,
    );
    if let Some(tile) = &tile {
        metadata.push(("photondiff/tile".to_string(), tile.to_string()));
    }
    if let Some(range) = &pass_range {
        metadata.push((
            "photondiff/pass_range".to_string(),
            format!("{}..{}", range.start, range.end),
        ));
    }
    let window = options.window.unwrap_or(Window::full(width, height));
    create_parent(&exr)?;
    if let Some(png) = &png {
        create_parent(png)?;
    }
    stats.time("write images", || -> Result<(), String> {
        let origin = (window.x0, window.y0);
        match &range_sum {
            Some(sum) => write_pass_part(&exr, sum, &metadata, origin, (width, height))?,
            None => film.write_exr_window(&exr, &metadata, origin, (width, height))?,
        }
        png.as_deref().map_or(Ok(()), |png| film.write_png(png))
    })?;
    stats.memory.record_peak();
    let mut written = vec![exr.as_path()];
    written.extend(png.as_deref());
    super::write_trace_and_stats(
        args.trace.as_deref(),
        args.stats_json.as_deref(),
        &stats,
        &written,
    )?;
    if !args.quiet {
        photondiff::stderr_text!("{}", stats.summary());
        // Glass splits every camera path in two: through many glass surfaces each path grows
        // into a tree of rays, and a user would not find the option that stops it.
        let rays = &stats.rays;
        if args.split_depth.is_none() && rays.specular > SPLIT_NOTE_RAYS * rays.camera {
            photondiff::stderr_line!(
                "photondiff: note: {:.1} specular rays a camera ray: every glass surface splits a \
                 camera path in two; --split-depth 1 takes one branch, chosen by Fresnel, past the \
                 first (the same image in expectation, noisier and cheaper a pass)",
                rays.specular as f64 / rays.camera as f64
            );
        }
    }
    match &png {
        Some(png) => out!("wrote {} and {}", exr.display(), png.display()),
        None => out!(
            "wrote {} (no preview beside a device or pipe: --png for one)",
            exr.display()
        ),
    }
    // Whatever --quiet says: the image is not what the options asked for.
    if let Some(p) = stats.progressive.as_ref() {
        if p.stop == StopReason::Interrupted {
            photondiff::stderr_line!(
                "photondiff: interrupted: the image is the mean of the {} passes done",
                p.passes
            );
        }
    }
    if kind == EstimatorKind::Lighttrace && photondiff::util::interrupt::honoured() {
        photondiff::stderr_line!(
            "photondiff: interrupted: the image is of the {} light paths traced",
            stats.light_paths
        );
    }
    Ok(())
}

/// Peak bytes a pixel of a pass-range part: its exact sums (fixed point, floating point and
/// squares: 96 bytes) are held beside the film and written as 24 channels of 32 bits. Measured:
/// 327 bytes (4096 x 3072, passes 0..1 of 2) and 378 (passes 0..2 of 3), where the scene's
/// check assumes 175 for a whole render ([`photondiff::render::film::PEAK_BYTES_PER_PIXEL`]): a
/// part under a 3 GB limit was let through and aborted 21 s later.
const PART_PEAK_BYTES_PER_PIXEL: u64 = 400;

/// Refuses a pass-range part of `pixels` pixels (of a tile where `tiled`) that needs more
/// memory than this process may use, before any work.
fn check_part_memory(pixels: u64, tiled: bool) -> Result<(), String> {
    let more = if tiled {
        "split the image into more tiles (--tile)"
    } else {
        "split the image into tiles too (--tile)"
    };
    film::check_image_memory(
        &format!("--pass-range: {pixels} pixels (and a part's exact sums)"),
        "to render",
        pixels,
        PART_PEAK_BYTES_PER_PIXEL,
    )
    .map_err(|e| format!("{e}: {more}"))
}

/// The image of `--estimator lighttrace`: the light-tracing reference's paths on the worker
/// threads, with their count, rays and noise in `stats`.
fn light_trace(
    args: &RenderArgs,
    scene: &Scene,
    embree: &photondiff::embree::Scene,
    progress: bool,
    stats: &mut Stats,
) -> Result<Film, String> {
    let lt_options = LightTraceOptions {
        paths: args.light_paths,
        time_budget: args.time_budget.map(std::time::Duration::from_secs_f64),
        seed: args.seed,
        on_interrupt: true,
        ..LightTraceOptions::default()
    };
    let pool = photondiff::util::pool::workers(args.threads)?;
    stats.threads = pool.current_num_threads();
    super::warn_camera_in_glass(&args.scene, scene, embree);
    super::warn_specular_pixels(&args.scene, scene, embree);
    let tracer = LightTracer::new(scene, embree, &lt_options);
    let (paths, _) = tracer.planned_paths();
    let bar = photondiff::util::progress::bar(progress, paths, "light");
    let result = stats.time("render", || pool.install(|| tracer.run(&bar)));
    bar.finish_and_clear();
    // Whatever --quiet says: the image is not what the options asked for (an interrupt says
    // so itself, after the image is written).
    if result.paths < paths && !photondiff::util::interrupt::honoured() {
        photondiff::stderr_line!(
            "photondiff: the time budget stopped light tracing after {} of {paths} light paths",
            result.paths
        );
    }
    stats.light_paths = result.paths;
    stats.light_rays = result.rays;
    stats.reference_noise = result.relative_noise(&result.film.lit_pixels());
    Ok(result.film)
}

/// The estimator asked for, `integrated` by default.
fn estimator_kind(args: &RenderArgs) -> EstimatorKind {
    args.estimator.unwrap_or(EstimatorKind::Integrated)
}

/// Tells, once per map class and whatever --quiet says, that a photon map holds fewer photons
/// than asked for (the statistics say so too), where the user gave its count: the caustic map's
/// (`caustic_given`), or the global or final-gathering map's (`global_given`).
pub(crate) fn warn_shortfalls(
    scene: &Path,
    stats: &photondiff::render::stats::Stats,
    caustic_given: bool,
    global_given: bool,
) {
    let given = |class| match class {
        PathClass::Caustic => caustic_given,
        _ => global_given,
    };
    // The counts are totals over the passes: said so, as the user asked for a pass's worth.
    let passes = stats.progressive.as_ref().map_or(1, |p| p.rendered());
    let over = if passes > 1 {
        format!(" (totals over {passes} passes)")
    } else {
        String::new()
    };
    let mut told = Vec::new();
    for m in &stats.photon_maps {
        if let Some(message) = m.shortfall().filter(|_| given(m.class)) {
            if !told.contains(&m.class) {
                told.push(m.class);
                photondiff::stderr_line!(
                    "photondiff: warning: {}: {message}{over}",
                    scene.display()
                );
            }
        }
    }
}
