//! `photondiff reference`: the reference image of a scene (direct light supersampled, the rest
//! light-traced; see `photondiff::reference::cache`), with its two halves and its noise.

use super::create_parent;
use photondiff::reference::cache::{make, merge, Reference, ReferenceSettings};
use photondiff::reference::light_tracer::MAX_PATHS;
use photondiff::reference::metrics::Regions;
use photondiff::render::film::Film;
use photondiff::render::part::{read_part, Part};
use photondiff::render::stats::MemoryStats;
use photondiff::scene::hash::{hex, scene_hash};
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
    #[arg(long, value_name = "A,B", value_delimiter = ',', default_values_t = [16, 17],
          conflicts_with = "merge", action = clap::ArgAction::Set)]
    direct_grids: Vec<u32>,
    /// Worker threads (0 = one per core; at most 1024).
    #[arg(long, value_name = "N", default_value_t = 0)]
    threads: usize,
    /// Seed of the light paths. References of one scene made with the same settings and
    /// different seeds are independent, and `--merge` averages them into one with their paths
    /// summed: a long reference made in parts, on several machines or over several days.
    #[arg(long, value_name = "S", default_value_t = 0, conflicts_with = "merge")]
    seed: u64,
    /// Instead of tracing, write the mean of these references (each with its -a and -b halves
    /// beside it), which must have been made with the same settings and different seeds.
    #[arg(long, value_name = "PART.exr", num_args = 1..)]
    merge: Vec<PathBuf>,
    #[command(flatten)]
    bvh: super::bvh::BvhArgs,
    /// No stage messages and no progress (standard output still reports the noise).
    #[arg(short, long)]
    quiet: bool,
}

/// The path of a reference's half `s` (`a` or `b`): `OUT-s.exr` beside `OUT.exr`.
fn half_path(output: &Path, s: &str) -> PathBuf {
    PathBuf::from(format!("{}-{s}.exr", output.with_extension("").display()))
}

/// The settings a reference was made with, from its metadata, split into the seed and the rest
/// (a reference made before seeds existed has seed 0).
fn settings_of(part: &Part) -> Result<(String, u64), String> {
    let path = part.path.display();
    let text = part
        .metadata
        .get(META_KEY)
        .ok_or_else(|| format!("{path}: not a reference (no {META_KEY} attribute)"))?;
    match text.rsplit_once("-seed") {
        Some((rest, seed)) => {
            let seed = seed
                .parse()
                .map_err(|_| format!("{path}: cannot read the seed in {text:?}"))?;
            Ok((rest.to_string(), seed))
        }
        None => Ok((text.clone(), 0)),
    }
}

/// The attribute naming the scene a reference was made of (its [`scene_hash`]).
const SCENE_KEY: &str = "photondiff/scene_hash";

/// The references of `--merge`, read and checked to be averageable before the scene is read
/// (which can take seconds), with the scene each names, if it does ([`Parts::check_scene`]).
struct Parts {
    references: Vec<Reference>,
    /// Each part's [`SCENE_KEY`], with its path.
    scenes: Vec<(PathBuf, Option<String>)>,
    /// What the merged reference's [`META_KEY`] says.
    meta: String,
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
}

/// Reads the references of `--merge` and checks that they can be averaged: the same
/// settings, different seeds.
fn read_parts(parts: &[PathBuf]) -> Result<Parts, String> {
    let mut seeds = Vec::new();
    let mut common: Option<String> = None;
    let mut references = Vec::new();
    let mut scenes = Vec::new();
    for path in parts {
        // The image and its settings in one read.
        let part = read_part(path)?;
        let (settings, seed) = settings_of(&part)?;
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
        if seeds.contains(&seed) {
            return Err(format!(
                "{}: seed {seed} appears twice among the parts: they would not be independent",
                path.display()
            ));
        }
        seeds.push(seed);
        common = Some(settings);
        references.push(Reference {
            film: part.film,
            half_a: Film::read_exr(&half_path(path, "a"))?,
            half_b: Film::read_exr(&half_path(path, "b"))?,
        });
    }
    let meta = format!(
        "mean of {} references with seeds {seeds:?}, each {}",
        parts.len(),
        common.unwrap_or_default()
    );
    Ok(Parts {
        references,
        scenes,
        meta,
    })
}

/// Runs `photondiff reference`.
pub fn run(args: &ReferenceArgs) -> Result<(), String> {
    super::check_threads(args.threads)?;
    // The reference and its two halves, none of them the scene or a part being merged (or a
    // part's halves, which are read too).
    let (a, b) = (half_path(&args.output, "a"), half_path(&args.output, "b"));
    let outputs = [
        ("-o", args.output.as_path()),
        ("-o's half a", &a),
        ("-o's half b", &b),
    ];
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
    // What needs no scene is checked (and the parts read) before the scene is read: a large
    // one takes seconds to load and build.
    let parts = match args.merge.is_empty() {
        true if args.light_paths == 0 && args.caustic_paths == 0 => {
            return Err("--light-paths and --caustic-paths cannot both be 0".into());
        }
        true => None,
        false => Some(read_parts(&args.merge)?),
    };
    let scene = super::load_scene(&args.scene, !args.quiet)?;
    let (device, embree, bvh) = args.bvh.build(&scene, &args.scene, !args.quiet)?;
    let memory = MemoryStats::after_build(&scene, &device, bvh);
    let hash = hex(scene_hash(&args.scene)?);
    if let Some(parts) = parts {
        parts.check_scene(&hash)?;
        let reference = merge(&parts.references)?;
        let meta = vec![
            (META_KEY.to_string(), parts.meta),
            (SCENE_KEY.to_string(), hash),
        ];
        return write(args, &scene, &embree, &reference, &meta, None, memory);
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads)
        .build()
        .map_err(|e| format!("cannot start worker threads: {e}"))?;
    let settings = ReferenceSettings {
        light_paths: args.light_paths,
        caustic_paths: args.caustic_paths,
        direct_grids: grids,
        seed: args.seed,
    };
    let start = std::time::Instant::now();
    let reference = pool.install(|| {
        make(&scene, &embree, &settings, !args.quiet, &mut |m| {
            if !args.quiet {
                eprintln!("{m}")
            }
        })
    })?;
    let seconds = start.elapsed().as_secs_f64();
    let meta = vec![
        (META_KEY.to_string(), settings.tag()),
        (SCENE_KEY.to_string(), hash),
    ];
    write(
        args,
        &scene,
        &embree,
        &reference,
        &meta,
        Some(seconds),
        memory,
    )
}

/// Writes the reference and its halves and prints its noise per region, then (unless
/// `--quiet`) the run's `memory`.
fn write(
    args: &ReferenceArgs,
    scene: &Scene,
    embree: &photondiff::embree::Scene,
    reference: &Reference,
    meta: &[(String, String)],
    seconds: Option<f64>,
    mut memory: MemoryStats,
) -> Result<(), String> {
    let regions = Regions::new(scene, embree, &reference.film);
    create_parent(&args.output)?;
    let half = |s: &str| half_path(&args.output, s);
    reference.film.write_exr(&args.output, meta)?;
    reference.half_a.write_exr(&half("a"), meta)?;
    reference.half_b.write_exr(&half("b"), meta)?;
    match seconds {
        Some(s) => {
            println!("reference made in {s:.1} s; relative noise per pixel (from its halves):")
        }
        None => println!("references merged; relative noise per pixel (from its halves):"),
    }
    for (name, pixels) in [
        ("floor", &regions.diffuse),
        ("caustic", &regions.caustic),
        ("contour", &regions.contour),
        ("shadow", &regions.shadow),
    ] {
        // An empty region has no noise to tell (its mean is 0): said so, not "inf".
        let noise = if pixels.is_empty() {
            "n/a (no pixels)".to_string()
        } else {
            format!("{:.4}", reference.relative_noise(pixels))
        };
        println!("  {name:8} {:7} px  {noise}", pixels.len());
    }
    println!(
        "wrote {} and its halves {}, {}",
        args.output.display(),
        half("a").display(),
        half("b").display()
    );
    super::print_memory(&mut memory, args.quiet);
    Ok(())
}
