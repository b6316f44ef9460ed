//! `photondiff reference`: the reference image of a scene (direct light supersampled, the rest
//! light-traced; see `photondiff::reference::cache`), with its two halves and its noise.

use super::create_parent;
use photondiff::reference::cache::{make_stoppable, merge, Reference, ReferenceSettings};
use photondiff::reference::light_tracer::MAX_PATHS;
use photondiff::reference::metrics::Regions;
use photondiff::render::film::Film;
use photondiff::render::part::{read_part, Part};
use photondiff::render::stats::{MemoryStats, RegionNoise, Stats};
use photondiff::scene::hash::hex;
use photondiff::scene::Scene;
use std::path::{Path, PathBuf};

/// The EXR attribute holding the settings a reference was made with.
const META_KEY: &str = "photondiff/reference";

#[derive(clap::Args)]
pub struct ReferenceArgs {
    /// The scene file.
    scene: PathBuf,
    /// Output EXR; the halves go to OUT-a.exr and OUT-b.exr beside it.
    #[arg(short = 'o', long = "output", value_name = "OUT.exr")]
    output: PathBuf,
    /// Image size in pixels, WIDTHxHEIGHT (such as 320x240), instead of the scene file's: the
    /// same eye, view and vertical field of view (another aspect ratio widens or narrows the
    /// view across), for a preview or a test at a fraction of the final size without an
    /// edited copy of the scene.
    #[arg(long, value_name = "WxH", value_parser = super::resolution::parse)]
    resolution: Option<super::resolution::Resolution>,
    /// Light paths leaving the lights in every direction (light that bounced at least once);
    /// at most 10^11, rounded up to an even number of whole chunks of 65536 (at least two: one
    /// for each half).
    #[arg(long, value_name = "N", default_value_t = 1_000_000_000, conflicts_with = "merge",
          value_parser = clap::value_parser!(u64).range(..=MAX_PATHS))]
    light_paths: u64,
    /// Light paths aimed at the mirror and glass meshes (caustics); at most 10^11, rounded up
    /// as --light-paths.
    #[arg(long, value_name = "N", default_value_t = 1_000_000_000, conflicts_with = "merge",
          value_parser = clap::value_parser!(u64).range(..=MAX_PATHS))]
    caustic_paths: u64,
    /// Camera rays per pixel along each axis for the direct light of half A and half B.
    // `default_value` as typed: `default_values_t` showed "[default: 16 17]", which the
    // parser refuses.
    #[arg(long, value_name = "A,B", value_delimiter = ',', default_value = "16,17",
          conflicts_with = "merge", action = clap::ArgAction::Set,
          value_parser = clap::value_parser!(u32).range(1..=64))]
    direct_grids: Vec<u32>,
    /// Worker threads and Embree's BVH build threads (0 = one per core; at most 1024).
    #[arg(long, value_name = "N", default_value_t = 0, value_parser = super::thread_count)]
    threads: usize,
    /// Seed of the light paths. References of one scene made with the same settings and
    /// different seeds are independent, and `--merge` averages them into one with their paths
    /// summed: a long reference made in parts, on several machines or over several days.
    #[arg(long, value_name = "S", default_value_t = 0, conflicts_with = "merge",
          value_parser = super::whole::<u64>)]
    seed: u64,
    /// Instead of tracing, write the mean of these references (each with its -a and -b halves
    /// beside it), which must have been made with the same settings and different seeds. A
    /// reference merged before counts as the parts it is the mean of: their seeds must differ
    /// from the others', and it weighs as many.
    #[arg(long, value_name = "PART.exr", num_args = 1..)]
    merge: Vec<PathBuf>,
    #[command(flatten)]
    bvh: super::bvh::BvhArgs,
    /// Write the run's statistics as JSON to FILE, in `render --stats-json`'s shape: times per
    /// stage (each half's direct light, the light tracing), rays, light paths, memory, and the
    /// noise per region that standard output prints (`reference_regions`). With --merge, the
    /// light paths and rays are the parts' sum (0 if a part was written before references
    /// recorded them), and no direct-light rays are counted (none are traced).
    #[arg(long, value_name = "FILE")]
    stats_json: Option<PathBuf>,
    /// Also write the regions it prints as masks for `compare --mask`, beside the output:
    /// OUT-floor.exr (the pixels seen on diffuse surfaces over their whole area, the only ones
    /// the reference holds whole), OUT-caustic.exr, OUT-contour.exr and OUT-shadow.exr (1 in
    /// the region, 0 elsewhere).
    #[arg(long)]
    masks: bool,
    /// Write a trace for profiling to FILE: Chrome trace-event JSON with spans per stage, per
    /// tile of the direct light and per chunk of light paths; open it in Perfetto
    /// (ui.perfetto.dev) or chrome://tracing.
    #[arg(long, value_name = "FILE")]
    trace: Option<PathBuf>,
    /// No stage messages and no progress (standard output still reports the noise).
    #[arg(short, long)]
    quiet: bool,
}

/// The regions a reference's noise is printed for (and `--masks` writes), in order.
const REGIONS: [&str; 4] = ["floor", "caustic", "contour", "shadow"];

/// The path of a reference's half `s` (`a` or `b`): `OUT-s.exr` beside `OUT.exr`.
fn half_path(output: &Path, s: &str) -> PathBuf {
    PathBuf::from(format!("{}-{s}.exr", output.with_extension("").display()))
}

/// The settings a reference was made with, from its metadata, split into its seeds and the
/// rest: one seed for a reference traced once (a reference made before seeds existed has seed
/// 0), its parts' for one merged before ("mean of N references with seeds [..], each ...", as
/// [`read_parts`] writes it).
fn settings_of(part: &Part) -> Result<(String, Vec<u64>), String> {
    let path = part.path.display();
    let text = part
        .metadata
        .get(META_KEY)
        .ok_or_else(|| format!("{path}: not a reference (no {META_KEY} attribute)"))?;
    if let Some(rest) = text.strip_prefix("mean of ") {
        let merged = rest
            .split_once(" references with seeds [")
            .and_then(|(n, rest)| Some((n.parse::<usize>().ok()?, rest.split_once("], each ")?)))
            .and_then(|(n, (list, settings))| {
                let seeds: Vec<u64> = list
                    .split(", ")
                    .map(str::parse)
                    .collect::<Result<_, _>>()
                    .ok()?;
                (seeds.len() == n && n > 0).then(|| (settings.to_string(), seeds))
            });
        return merged
            .ok_or_else(|| format!("{path}: cannot read the merged parts' seeds in {text:?}"));
    }
    match text.rsplit_once("-seed") {
        Some((rest, seed)) => {
            let seed = seed
                .parse()
                .map_err(|_| format!("{path}: cannot read the seed in {text:?}"))?;
            Ok((rest.to_string(), vec![seed]))
        }
        None => Ok((text.clone(), vec![0])),
    }
}

/// The attribute naming the scene a reference was made of (its content hash,
/// [`photondiff::scene::hash::scene_hash`]).
const SCENE_KEY: &str = "photondiff/scene_hash";

/// The attribute counting the light paths and rays a reference traced ("P paths, R rays"):
/// a merge's statistics report its parts' sum, which its own attribute carries on.
const LIGHT_KEY: &str = "photondiff/light_tracing";

/// [`LIGHT_KEY`]'s value.
fn light_tracing(paths: u64, rays: u64) -> String {
    format!("{paths} paths, {rays} rays")
}

/// The light paths and rays a part's [`LIGHT_KEY`] counts; `None` for a reference written
/// before references carried it.
fn light_tracing_of(part: &Part) -> Result<Option<(u64, u64)>, String> {
    let Some(text) = part.metadata.get(LIGHT_KEY) else {
        return Ok(None);
    };
    text.strip_suffix(" rays")
        .and_then(|t| t.split_once(" paths, "))
        .and_then(|(p, r)| Some((p.parse().ok()?, r.parse().ok()?)))
        .map(Some)
        .ok_or_else(|| {
            format!(
                "{}: cannot read the light paths and rays in {LIGHT_KEY} {text:?}",
                part.path.display()
            )
        })
}

/// The references of `--merge`, read and checked to be averageable before the scene is read
/// (which can take seconds), with the scene each names, if it does ([`Parts::check_scene`]).
struct Parts {
    references: Vec<Reference>,
    /// How many references traced once each part is the mean of.
    weights: Vec<u64>,
    /// Each part's [`SCENE_KEY`], with its path.
    scenes: Vec<(PathBuf, Option<String>)>,
    /// What the merged reference's [`META_KEY`] says.
    meta: String,
    /// The light paths and rays the parts traced, summed; `None` where a part does not tell
    /// (written before references carried [`LIGHT_KEY`]).
    light: Option<(u64, u64)>,
}

impl Parts {
    /// Refuses a part of another scene than the one of hash `hash` (references written before
    /// they carried the scene's hash are taken as they are).
    fn check_scene(&self, hash: &str) -> Result<(), String> {
        for (path, scene) in &self.scenes {
            if let Some(other) = scene.as_ref().filter(|h| *h != hash) {
                return Err(format!(
                    "{}: a reference of another scene ({SCENE_KEY} {other}, this scene's {hash})",
                    path.display()
                ));
            }
        }
        Ok(())
    }

    /// Refuses a part of another size than the camera's, `width` x `height` (the scene file's
    /// or `--resolution`'s): the regions and the masks are found on the camera's pixels.
    fn check_size(&self, width: u32, height: u32) -> Result<(), String> {
        for ((path, _), reference) in self.scenes.iter().zip(&self.references) {
            let (w, h) = (reference.film.width, reference.film.height);
            if (w, h) != (width, height) {
                return Err(format!(
                    "{}: a {w} x {h} reference, but the camera renders {width} x {height} \
                     (made with --resolution? give the same --resolution {w}x{h} to merge it)",
                    path.display()
                ));
            }
        }
        Ok(())
    }
}

/// Reads the references of `--merge` and checks that they can be averaged: the same
/// settings, different seeds (a reference merged before brings all of its parts' seeds).
fn read_parts(parts: &[PathBuf]) -> Result<Parts, String> {
    let mut seeds = Vec::new();
    let mut weights = Vec::new();
    let mut common: Option<String> = None;
    let mut references = Vec::new();
    let mut scenes = Vec::new();
    let mut light = Some((0u64, 0u64));
    for path in parts {
        // The image and its settings in one read.
        let part = read_part(path)?;
        let (settings, part_seeds) = settings_of(&part)?;
        light = match (light, light_tracing_of(&part)?) {
            (Some((p, r)), Some((dp, dr))) => Some((p.saturating_add(dp), r.saturating_add(dr))),
            _ => None,
        };
        scenes.push((path.clone(), part.metadata.get(SCENE_KEY).cloned()));
        if let Some(c) = &common {
            if *c != settings {
                return Err(format!(
                    "{}: made with {settings}, but {} with {c}: only references made with the \
                     same settings can be merged",
                    path.display(),
                    parts[0].display()
                ));
            }
        }
        if let Some(seed) = part_seeds.iter().find(|s| seeds.contains(*s)) {
            return Err(format!(
                "{}: seed {seed} appears twice among the parts: they would not be independent",
                path.display()
            ));
        }
        weights.push(part_seeds.len() as u64);
        seeds.extend(part_seeds);
        common = Some(settings);
        // A half is a file the user did not name: the message says whose it is.
        let half = |s: &str| {
            Film::read_exr(&half_path(path, s))
                .map_err(|e| format!("{e} (half {s} of {}, being merged)", path.display()))
        };
        let reference = Reference {
            film: part.film,
            half_a: half("a")?,
            half_b: half("b")?,
        };
        check_halves(path, &reference)?;
        references.push(reference);
    }
    let meta = format!(
        "mean of {} references with seeds {seeds:?}, each {}",
        seeds.len(),
        common.unwrap_or_default()
    );
    Ok(Parts {
        references,
        weights,
        scenes,
        meta,
        light,
    })
}

/// Refuses a reference (read from `path`) that is not the mean of its halves: a half of
/// another size, or one replaced (by another reference written over `OUT-a.exr`, say), would
/// be averaged into the merge as if it were this reference's.
fn check_halves(path: &Path, r: &Reference) -> Result<(), String> {
    let size = |f: &Film| (f.width, f.height);
    for (half, film) in [("a", &r.half_a), ("b", &r.half_b)] {
        if size(film) != size(&r.film) {
            return Err(format!(
                "{}: {}x{} pixels, but its reference {} has {}x{}",
                half_path(path, half).display(),
                film.width,
                film.height,
                path.display(),
                r.film.width,
                r.film.height
            ));
        }
    }
    // Written as f32, each of the three is within 2^-24 of its value: the mean of the halves
    // as read is within about 2^-23 of their largest.
    let apart = |(m, (a, b)): (&glam::DVec3, (&glam::DVec3, &glam::DVec3))| {
        let bound = 1e-6 * (a.abs() + b.abs()) + glam::DVec3::splat(1e-30);
        (*m - (*a + *b) * 0.5).abs().cmpgt(bound).any()
    };
    let halves = r.half_a.pixels.iter().zip(&r.half_b.pixels);
    if let Some(i) = r.film.pixels.iter().zip(halves).position(apart) {
        let (x, y) = (i as u32 % r.film.width, i as u32 / r.film.width);
        return Err(format!(
            "{}: pixel ({x}, {y}) is not the mean of its halves {} and {}: a half was replaced \
             or belongs to another reference",
            path.display(),
            half_path(path, "a").display(),
            half_path(path, "b").display()
        ));
    }
    Ok(())
}

/// Runs `photondiff reference`.
/// What `reference` holds per pixel at its peak (the film, its halves, the direct light's and
/// the light tracer's sums, the EXRs): measured 216 bytes (2000 x 2000, stop 56); with some
/// margin. At a render's 150 a 4200 x 4200 reference under a 3 GB limit was let through and
/// aborted after its light tracing.
const REFERENCE_PEAK_BYTES_PER_PIXEL: u64 = 250;

pub fn run(args: &ReferenceArgs) -> Result<(), String> {
    super::check_threads(args.threads)?;
    // Three OpenEXR files: `-o ref.png` held EXR bytes under a PNG's name, beside
    // `ref-a.exr` and `ref-b.exr`; `-o p1` wrote `p1-a.exr` and `p1-b.exr`, the halves of
    // another reference `p1.exr`.
    if args
        .output
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        != Some("exr".into())
    {
        return Err(format!(
            "-o {}: a reference is written as OpenEXR (with its halves); give it a .exr name",
            args.output.display()
        ));
    }
    // The reference and its two halves, none of them the scene or a part being merged (or a
    // part's halves, which are read too).
    let (a, b) = (half_path(&args.output, "a"), half_path(&args.output, "b"));
    let mut outputs = vec![
        ("-o", args.output.as_path()),
        ("-o's half a", &a),
        ("-o's half b", &b),
    ];
    outputs.extend(args.stats_json.as_deref().map(|p| ("--stats-json", p)));
    outputs.extend(args.trace.as_deref().map(|p| ("--trace", p)));
    let masks: Vec<PathBuf> = match args.masks {
        true => REGIONS.map(|r| half_path(&args.output, r)).to_vec(),
        false => Vec::new(),
    };
    outputs.extend(masks.iter().map(|p| ("--masks", p.as_path())));
    let halves: Vec<PathBuf> = args
        .merge
        .iter()
        .flat_map(|p| [half_path(p, "a"), half_path(p, "b")])
        .collect();
    let mut inputs = vec![("scene", args.scene.as_path())];
    inputs.extend(
        args.merge
            .iter()
            .map(|p| ("reference being merged", p.as_path())),
    );
    inputs.extend(
        halves
            .iter()
            .map(|p| ("half of a reference being merged", p.as_path())),
    );
    super::check_outputs(&outputs, &inputs)?;
    let grids = match args.direct_grids[..] {
        [a, b] if a != b && (1..=64).contains(&a) && (1..=64).contains(&b) => [a, b],
        _ => {
            return Err(format!(
                "--direct-grids must be two different numbers in 1..=64, got {:?}",
                args.direct_grids
            ))
        }
    };
    if args.merge.is_empty() && args.light_paths == 0 && args.caustic_paths == 0 {
        return Err("--light-paths and --caustic-paths cannot both be 0".into());
    }
    // From the start, so that a Ctrl-C while the scene loads is not lost either.
    super::stop_on_ctrl_c(
        "finishing the light paths under way, then writing the reference of the paths traced",
    );
    super::start_trace(args.trace.as_deref())?;
    // Every stage runs on this pool, a merge's too (its noise per region is computed in
    // parallel): `--threads 1` holds for the whole run.
    let pool = photondiff::util::pool::workers(args.threads)?;
    let mut stats = Stats::of_this_build();
    stats.threads = pool.current_num_threads();
    // What needs no scene is checked (and the parts read) before the scene is read: a large
    // one takes seconds to load and build.
    let parts = match args.merge.is_empty() {
        true => None,
        false => Some(stats.time("read references", || read_parts(&args.merge))?),
    };
    let (scene, hash) = stats.time("load scene", || {
        super::load_scene(&args.scene, !args.quiet, &outputs, args.resolution)
    })?;
    let (width, height) = (scene.camera.width, scene.camera.height);
    if let Some(parts) = &parts {
        parts.check_size(width, height)?;
    }
    photondiff::render::film::check_image_memory(
        &super::resolution::describe(&args.scene, args.resolution, (width, height)),
        "to render",
        u64::from(width) * u64::from(height),
        REFERENCE_PEAK_BYTES_PER_PIXEL,
    )?;
    let mark = photondiff::util::memory::ResidentMark::now();
    let (device, embree, bvh) = stats.time("build BVH", || {
        args.bvh
            .build(&scene, &args.scene, args.threads, !args.quiet)
    })?;
    stats.memory = MemoryStats::after_build(&scene, &device, bvh, mark);
    let hash = hex(hash);
    if let Some(parts) = parts {
        parts.check_scene(&hash)?;
        let reference = stats.time("merge", || merge(&parts.references, &parts.weights))?;
        let mut meta = vec![
            (META_KEY.to_string(), parts.meta),
            (SCENE_KEY.to_string(), hash),
        ];
        if let Some((paths, rays)) = parts.light {
            (stats.light_paths, stats.light_rays) = (paths, rays);
            meta.push((LIGHT_KEY.to_string(), light_tracing(paths, rays)));
        }
        let made = Made {
            reference,
            meta,
            seconds: None,
        };
        return pool.install(|| write(args, &scene, &embree, &made, stats));
    }
    let mut settings = ReferenceSettings {
        light_paths: args.light_paths,
        caustic_paths: args.caustic_paths,
        direct_grids: grids,
        seed: args.seed,
    };
    super::warn_camera_in_glass(&args.scene, &scene, &embree);
    super::warn_specular_pixels(&args.scene, &scene, &embree);
    let start = std::time::Instant::now();
    let reference = pool.install(|| {
        let mut log = |m: &str| {
            if !args.quiet {
                photondiff::stderr_line!("{m}")
            }
        };
        make_stoppable(
            &scene,
            &embree,
            &settings,
            true,
            !args.quiet,
            &mut log,
            &mut stats,
        )
    })?;
    // An interrupted reference is of the paths traced, and says so in its attribute.
    let (reference, asked) = (reference.0, std::mem::replace(&mut settings, reference.1));
    let made = Made {
        reference,
        meta: vec![
            (META_KEY.to_string(), settings.tag()),
            (SCENE_KEY.to_string(), hash),
            (
                LIGHT_KEY.to_string(),
                light_tracing(stats.light_paths, stats.light_rays),
            ),
        ],
        seconds: Some(start.elapsed().as_secs_f64()),
    };
    pool.install(|| write(args, &scene, &embree, &made, stats))?;
    if photondiff::util::interrupt::honoured() {
        photondiff::stderr_line!(
            "photondiff: interrupted: the reference is of the {} light paths and {} caustic \
             paths traced (of {} and {} asked; its attribute says so: {META_KEY} {})",
            settings.light_paths,
            settings.caustic_paths,
            asked.light_paths,
            asked.caustic_paths,
            settings.tag()
        );
    }
    Ok(())
}

/// A reference made or merged, ready to be written.
struct Made {
    reference: Reference,
    /// Its EXR attributes.
    meta: Vec<(String, String)>,
    /// How long making it took (`None` for a merge).
    seconds: Option<f64>,
}

/// Writes the reference and its halves, prints its noise per region, writes `--trace` and
/// `--stats-json` (with the noise in `stats`), then (unless `--quiet`) the run's memory.
fn write(
    args: &ReferenceArgs,
    scene: &Scene,
    embree: &photondiff::embree::Scene,
    made: &Made,
    mut stats: Stats,
) -> Result<(), String> {
    let (reference, meta) = (&made.reference, &made.meta);
    // 81 rays a pixel: a third of a small reference's run, which no stage showed before.
    let regions = stats.time("find regions", || {
        Regions::new(scene, embree, &reference.film)
    });
    let half = |s: &str| half_path(&args.output, s);
    let sets = [
        &regions.diffuse,
        &regions.caustic,
        &regions.contour,
        &regions.shadow,
    ];
    stats.time("write images", || -> Result<(), String> {
        create_parent(&args.output)?;
        reference.film.write_exr(&args.output, meta)?;
        reference.half_a.write_exr(&half("a"), meta)?;
        reference.half_b.write_exr(&half("b"), meta)?;
        // Masks carry none of the reference's attributes: they are not references.
        for (name, pixels) in REGIONS.iter().zip(sets).filter(|_| args.masks) {
            let mut mask = Film::new(reference.film.width, reference.film.height);
            for &i in pixels {
                mask.pixels[i] = glam::DVec3::ONE;
            }
            mask.write_exr(&half(name), &[])?;
        }
        Ok(())
    })?;
    stats.reference_noise = reference.relative_noise(&reference.film.lit_pixels());
    stats.reference_regions = REGIONS
        .iter()
        .zip(sets)
        .map(|(name, pixels)| RegionNoise {
            name: name.to_string(),
            pixels: pixels.len() as u64,
            // An empty region has no noise to tell, nor a black one (its mean is 0: `inf` was
            // printed where the JSON said `null`).
            relative_noise: Some(reference.relative_noise(pixels))
                .filter(|n| !pixels.is_empty() && n.is_finite()),
        })
        .collect();
    match made.seconds {
        Some(s) => {
            out!("reference made in {s:.1} s; relative noise per pixel (from its halves):")
        }
        None => out!("references merged; relative noise per pixel (from its halves):"),
    }
    for r in &stats.reference_regions {
        // An empty region: said so, not "inf".
        let noise = match (r.relative_noise, r.pixels) {
            (Some(n), _) => format!("{n:.4}"),
            (None, 0) => "n/a (no pixels)".to_string(),
            (None, _) => "n/a (no light)".to_string(),
        };
        out!("  {:8} {:7} px  {noise}", r.name, r.pixels);
    }
    out!(
        "wrote {} and its halves {}, {}",
        args.output.display(),
        half("a").display(),
        half("b").display()
    );
    if args.masks {
        let names: Vec<String> = REGIONS
            .iter()
            .map(|r| half(r).display().to_string())
            .collect();
        out!("wrote the regions' masks {}", names.join(", "));
    }
    stats.memory.record_peak();
    let (a, b) = (half("a"), half("b"));
    super::write_trace_and_stats(
        args.trace.as_deref(),
        args.stats_json.as_deref(),
        &stats,
        &[&args.output, &a, &b],
    )?;
    super::print_memory(&mut stats.memory, args.quiet);
    Ok(())
}
