//! Photon tracing and gathering throughput on the canonical scene, beside Embree's raw
//! incoherent ray throughput, measured alternately in one run (median of several repetitions,
//! one thread) and reported with ratios.
//!
//! Run: `cargo bench --bench photons`

use glam::DVec3;
use photondiff::embree::{Device, RawRays, Ray};
use photondiff::estimate::{
    GatherCounts, GatherQuery, JensenEstimate, PhotonDifferentialEstimate, RadianceEstimator,
};
use photondiff::geometry::sampling::sample_cosine;
use photondiff::photons::emission::Emitter;
use photondiff::photons::map::PathClass;
use photondiff::photons::trace::{PhotonOptions, PhotonTracer, StopRule};
use photondiff::scene::file::load_scene;
use photondiff::util::rng::Rng;
use std::path::Path;
use std::time::Instant;

const REPEATS: usize = 5;

fn median(mut t: Vec<f64>) -> f64 {
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

fn main() {
    let path = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/caustic-sphere.toml"
    ));
    let scene = load_scene(path).expect("canonical scene");
    let device = Device::new().expect("Embree device");
    let embree = scene.build_embree(&device).expect("Embree scene");
    let options = PhotonOptions::default();
    let tracer = PhotonTracer::new(&scene, &embree, &options);
    let caustic = Emitter::caustic(&scene, options.caustic_photons, options.overlap, 0);
    let global = Emitter::global(&scene, options.global_photons, options.overlap, 0);
    let hidden = indicatif::ProgressBar::hidden();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();

    // Incoherent rays like the photons', in random order. Caustic: from the light into the
    // sphere's cone (through the 262,144-triangle sphere). Global: from the light in all
    // directions and from random floor points in cosine-distributed directions.
    let light = DVec3::new(-4.0, 4.0, -1.0);
    let mut rng = Rng::new(7, 0);
    let to = DVec3::new(0.0, 1.0, 0.0) - light;
    let cos_max = (1.0 - 1.0 / to.length_squared()).sqrt();
    let (t1, t2) = photondiff::geometry::sampling::tangent_frame(to.normalize());
    let mut cone_rays = Vec::new();
    let mut global_rays = Vec::new();
    for _ in 0..100_000 {
        let cos = 1.0 - rng.uniform() * (1.0 - cos_max);
        let sin = (1.0 - cos * cos).sqrt();
        let phi = 2.0 * std::f64::consts::PI * rng.uniform();
        let d = to.normalize() * cos + t1 * (sin * phi.cos()) + t2 * (sin * phi.sin());
        cone_rays.push(Ray::new(light, d));
        let d = sample_cosine(DVec3::NEG_Y, rng.uniform(), rng.uniform());
        global_rays.push(Ray::new(light, d));
        let p = DVec3::new(rng.uniform() * 12.0 - 6.0, 0.0, rng.uniform() * 12.0 - 6.0);
        global_rays.push(Ray::new(
            p,
            sample_cosine(DVec3::Y, rng.uniform(), rng.uniform()),
        ));
    }
    let raw_cone = RawRays::new(&cone_rays);
    let raw_global = RawRays::new(&global_rays);

    let (mut t_caustic, mut t_global) = (vec![], vec![]);
    let (mut t_raw_cone, mut t_raw_global) = (vec![], vec![]);
    let (mut caustic_counts, mut global_counts) = (Default::default(), Default::default());
    let mut maps = None;
    for _ in 0..REPEATS {
        let start = Instant::now();
        let (cmap, c) = pool.install(|| {
            tracer.build_map(
                &caustic,
                PathClass::Caustic,
                StopRule::Stored(options.caustic_photons),
                &hidden,
            )
        });
        t_caustic.push(start.elapsed().as_secs_f64());
        let start = Instant::now();
        let (gmap, g) = pool.install(|| {
            tracer.build_map(
                &global,
                PathClass::Global,
                StopRule::Emitted(options.global_photons),
                &hidden,
            )
        });
        t_global.push(start.elapsed().as_secs_f64());
        let start = Instant::now();
        std::hint::black_box(embree.raw_intersect1(&raw_cone));
        t_raw_cone.push(start.elapsed().as_secs_f64());
        let start = Instant::now();
        std::hint::black_box(embree.raw_intersect1(&raw_global));
        t_raw_global.push(start.elapsed().as_secs_f64());
        caustic_counts = c;
        global_counts = g;
        maps = Some((cmap, gmap));
    }
    let (cmap, gmap) = maps.unwrap();
    let (tc, tg) = (median(t_caustic), median(t_global));
    let raw_cone_rate = raw_cone.len() as f64 / median(t_raw_cone);
    let raw_global_rate = raw_global.len() as f64 / median(t_raw_global);
    println!("\n## Photon tracing, canonical scene (one thread, median of {REPEATS})\n");
    println!("| map | emissions | stored | rays | seconds | emissions/s | rays/s | raw Embree rays/s, similar rays | ratio |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for (name, c, t, raw_rate) in [
        ("caustic", caustic_counts, tc, raw_cone_rate),
        ("global", global_counts, tg, raw_global_rate),
    ] {
        println!(
            "| {name} | {} | {} | {} | {:.3} | {:.0} | {:.0} | {:.0} | {:.2} |",
            c.emitted,
            c.stored,
            c.rays,
            t,
            c.emitted as f64 / t,
            c.rays as f64 / t,
            raw_rate,
            c.rays as f64 / t / raw_rate
        );
    }

    // Gathers at the floor points the camera sees.
    let camera = &scene.camera;
    let mut queries = Vec::new();
    for y in (0..camera.height).step_by(2) {
        for x in (0..camera.width).step_by(2) {
            let r = camera.ray(x as f64 + 0.5, y as f64 + 0.5, 1.0);
            if let Some(hit) = embree.intersect(&Ray::new(r.p, r.d)) {
                if hit.geom_id == 0 {
                    queries.push(GatherQuery {
                        position: hit.position,
                        normal: DVec3::Y,
                        albedo: DVec3::splat(0.75),
                        footprint: [DVec3::ZERO; 2],
                    });
                }
            }
        }
    }
    let max_radius = options.limits(&scene).max_radius;
    let estimators: Vec<(&str, &str, Box<dyn RadianceEstimator>)> = vec![
        (
            "jensen k=50",
            "caustic",
            Box::new(JensenEstimate {
                map: &cmap,
                k: 50,
                max_radius,
            }),
        ),
        (
            "pd",
            "caustic",
            Box::new(PhotonDifferentialEstimate { map: &cmap }),
        ),
        (
            "jensen k=50",
            "global",
            Box::new(JensenEstimate {
                map: &gmap,
                k: 50,
                max_radius,
            }),
        ),
        (
            "pd",
            "global",
            Box::new(PhotonDifferentialEstimate { map: &gmap }),
        ),
    ];
    let mut times = vec![Vec::new(); estimators.len()];
    let mut counts = vec![GatherCounts::default(); estimators.len()];
    for _ in 0..REPEATS {
        for (k, (_, _, e)) in estimators.iter().enumerate() {
            let mut c = GatherCounts::default();
            let start = Instant::now();
            let mut sum = DVec3::ZERO;
            for q in &queries {
                sum += e.radiance(q, &mut c);
            }
            times[k].push(start.elapsed().as_secs_f64());
            std::hint::black_box(sum);
            counts[k] = c;
        }
    }
    println!(
        "\n## Gathers at {} floor points (one thread, median of {REPEATS})\n",
        queries.len()
    );
    println!("| estimate | map | gathers/s | photons found per gather | used per gather |");
    println!("|---|---|---|---|---|");
    for (k, (name, map, _)) in estimators.iter().enumerate() {
        let t = median(times[k].clone());
        let c = counts[k];
        println!(
            "| {name} | {map} | {:.0} | {:.1} | {:.1} |",
            c.gathers as f64 / t,
            c.photons_found as f64 / c.gathers as f64,
            c.photons_used as f64 / c.gathers as f64
        );
    }
}
