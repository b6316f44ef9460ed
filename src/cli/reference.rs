//! `photondiff reference`: the reference image of a scene (direct light supersampled, the rest
//! light-traced; see `photondiff::reference::cache`), with its two halves and its noise.

use super::create_parent;
use photondiff::embree::Device;
use photondiff::reference::cache::{make, ReferenceSettings};
use photondiff::reference::metrics::Regions;
use photondiff::scene::file::load_scene;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct ReferenceArgs {
    /// The scene file.
    scene: PathBuf,
    /// Output EXR; the halves go to OUT-a.exr and OUT-b.exr beside it.
    #[arg(short = 'o', long = "output", value_name = "OUT.exr")]
    output: PathBuf,
    /// Light paths leaving the lights in every direction (light that bounced at least once).
    #[arg(long, value_name = "N", default_value_t = 1_000_000_000)]
    light_paths: u64,
    /// Light paths aimed at the mirror and glass meshes (caustics).
    #[arg(long, value_name = "N", default_value_t = 1_000_000_000)]
    caustic_paths: u64,
    /// Camera rays per pixel along each axis for the direct light of half A and half B.
    #[arg(long, value_name = "A,B", value_delimiter = ',', default_values_t = [16, 17])]
    direct_grids: Vec<u32>,
    /// Worker threads (0 = one per core).
    #[arg(long, value_name = "N", default_value_t = 0)]
    threads: usize,
}

/// Runs `photondiff reference`.
pub fn run(args: &ReferenceArgs) -> Result<(), String> {
    let grids = match args.direct_grids[..] {
        [a, b] if a != b && (1..=64).contains(&a) && (1..=64).contains(&b) => [a, b],
        _ => {
            return Err(format!(
                "--direct-grids must be two different numbers in 1..=64, got {:?}",
                args.direct_grids
            ))
        }
    };
    if args.light_paths == 0 && args.caustic_paths == 0 {
        return Err("--light-paths and --caustic-paths cannot both be 0".into());
    }
    let scene = load_scene(&args.scene).map_err(|e| e.to_string())?;
    let device = Device::new().map_err(|e| e.to_string())?;
    let embree = scene
        .build_embree(&device)
        .map_err(|e| format!("{}: {e}", args.scene.display()))?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads)
        .build()
        .map_err(|e| format!("cannot start worker threads: {e}"))?;
    let settings = ReferenceSettings {
        light_paths: args.light_paths,
        caustic_paths: args.caustic_paths,
        direct_grids: grids,
    };
    let start = std::time::Instant::now();
    let reference = pool.install(|| make(&scene, &embree, &settings, &mut |m| eprintln!("{m}")))?;
    let seconds = start.elapsed().as_secs_f64();
    let regions = Regions::new(&scene, &embree, &reference.film);
    create_parent(&args.output)?;
    let stem = args.output.with_extension("");
    let half = |s: &str| PathBuf::from(format!("{}-{s}.exr", stem.display()));
    let meta = vec![("photondiff/reference".to_string(), format!("{settings:?}"))];
    reference.film.write_exr(&args.output, &meta)?;
    reference.half_a.write_exr(&half("a"), &meta)?;
    reference.half_b.write_exr(&half("b"), &meta)?;
    println!("reference made in {seconds:.1} s; relative noise per pixel (from its halves):");
    for (name, pixels) in [
        ("floor", &regions.diffuse),
        ("caustic", &regions.caustic),
        ("contour", &regions.contour),
        ("shadow", &regions.shadow),
    ] {
        println!(
            "  {name:8} {:7} px  {:.4}",
            pixels.len(),
            reference.relative_noise(pixels)
        );
    }
    println!(
        "wrote {} and its halves {}, {}",
        args.output.display(),
        half("a").display(),
        half("b").display()
    );
    Ok(())
}
