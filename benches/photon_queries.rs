//! Photon queries against the photon count: for 2 x 10^4 to 1.28 x 10^6 caustic photons on the
//! canonical scene, the footprint BVH's build time and, for `pd`, multi-sampled 8x8,
//! `integrated` and coplanar, one pass's render stage and the photons the queries found and used per gather.
//!
//! Targets (issue 12): found at most 2x used; the render stage at 1.28M photons at most 3x its
//! time at 20k (same settings, one pass); the build of 1.28M photons well under 0.5 s.
//! Last, per estimator, the render stage's cost per photon used beyond the 20k map's, beside
//! what the 3x target allows.
//!
//! Run: `cargo bench --bench photon_queries` (env PHOTONDIFF_QUERIES_MAX_PHOTONS caps the sweep;
//! PHOTONDIFF_REPEATS, default 3, renders per estimator and count, every count's and
//! estimator's render made in turn within each repetition, the median reported, and the ratio
//! to 20k within each repetition: one render of each was too noisy to compare runs by, and
//! counts rendered one after the other put minutes of the machine's changing load between a
//! ratio's two sides).

mod common;
use common::{env_or, median, ratio_spread, render_in_process};

use photondiff::estimate::{EstimatorKind, EstimatorSettings};
use photondiff::photons::map::PhotonMap;
use photondiff::photons::options::PhotonOptions;
use photondiff::render::stats::Stats;
use photondiff::render::trace_photon_maps;
use photondiff::scene::file::load_scene;
use std::path::Path;
use std::time::Instant;

fn main() {
    let max: f64 = env_or("PHOTONDIFF_QUERIES_MAX_PHOTONS", 1.28e6);
    let path = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/caustic-sphere.toml"
    ));
    let repeats: usize = env_or("PHOTONDIFF_REPEATS", 3).max(1);
    let scene = load_scene(path).unwrap();
    let device = photondiff::embree::Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let kinds = [
        ("pd", EstimatorKind::Pd),
        ("multisampled 8x8", EstimatorKind::Multisampled),
        ("integrated", EstimatorKind::Integrated),
        ("coplanar", EstimatorKind::Coplanar),
    ];
    let counts: Vec<usize> = [20_000usize, 80_000, 320_000, 1_280_000]
        .into_iter()
        .filter(|&count| count as f64 <= max * 1.05)
        .collect();
    // Every count's maps first, then each repetition renders every count and estimator in
    // turn: a ratio to 20k compares renders made minutes apart otherwise, and the shared
    // machine's load moved it by 10% between runs.
    let mut builds = Vec::new();
    let maps: Vec<_> = counts
        .iter()
        .map(|&count| {
            let options = PhotonOptions {
                caustic_photons: count,
                ..PhotonOptions::default()
            };
            let mut stats = Stats::default();
            let maps = trace_photon_maps(&scene, &embree, &options, 0, false, &mut stats).unwrap();
            // The caustic map's build alone, from the same photons (best of three).
            let c = &maps.caustic;
            let build = (0..3)
                .map(|_| {
                    let photons = c.photons();
                    let start = Instant::now();
                    let map = PhotonMap::new(c.class, photons, c.emitted, c.guards);
                    let t = start.elapsed().as_secs_f64();
                    drop(map);
                    t
                })
                .fold(f64::INFINITY, f64::min);
            builds.push(build);
            (maps, options.limits(&scene).max_radius)
        })
        .collect();
    let estimators: Vec<Vec<_>> = maps
        .iter()
        .map(|(maps, max_radius)| {
            kinds
                .iter()
                .map(|(_, kind)| maps.estimators(&EstimatorSettings::new(*kind, *max_radius)))
                .collect()
        })
        .collect();
    // times[count][estimator][repetition]
    let mut times = vec![vec![Vec::new(); kinds.len()]; counts.len()];
    let mut gathers = vec![vec![Default::default(); kinds.len()]; counts.len()];
    for _ in 0..repeats {
        for (c, estimators) in estimators.iter().enumerate() {
            for (k, estimators) in estimators.iter().enumerate() {
                let render_stats = render_in_process(&scene, &embree, estimators);
                times[c][k].push(render_stats.seconds("render"));
                gathers[c][k] = render_stats.gathers;
            }
        }
    }
    println!("## Photon queries against caustic photons (canonical scene, one pass, 2 threads)\n");
    println!("| caustic photons | map build s | estimator | render s | x 20k | x 20k within repetitions: lowest / median / highest | found / used per gather | found / used |");
    println!("|---|---|---|---|---|---|---|---|");
    for (c, count) in counts.iter().enumerate() {
        for (k, (name, _)) in kinds.iter().enumerate() {
            let render = median(times[c][k].clone());
            let (lowest, middle, highest) = ratio_spread(&times[c][k], &times[0][k]);
            let g = &gathers[c][k];
            let per = |n: u64| n as f64 / g.gathers.max(1) as f64;
            println!(
                "| {count} | {:.3} | {name} | {render:.3} | {:.2} | {lowest:.2} / {middle:.2} / {highest:.2} | {:.1} / {:.1} | {:.2} |",
                builds[c],
                render / median(times[0][k].clone()),
                per(g.photons_found),
                per(g.photons_used),
                g.photons_found as f64 / g.photons_used.max(1) as f64
            );
        }
    }
    // What the render stage pays for each photon a gather uses beyond the 20k map's, and what
    // the 3x target (issue 12) allows: the extra time at most twice the 20k render, spread over
    // the extra photons used. Found is within a few percent of used for `integrated` and
    // coplanar, so for them this is the cost of the estimate's own work, not of the search.
    let last = counts.len() - 1;
    if last > 0 {
        println!();
        for (k, (name, _)) in kinds.iter().enumerate() {
            let (first, end) = (&gathers[0][k], &gathers[last][k]);
            let extra = end.photons_used.saturating_sub(first.photons_used).max(1) as f64;
            let (t0, t1) = (median(times[0][k].clone()), median(times[last][k].clone()));
            println!(
                "{name}: {:.1} ns of render stage per extra photon used ({} -> {} caustic photons); 3x needs at most {:.1} ns",
                (t1 - t0) / extra * 1e9,
                counts[0],
                counts[last],
                2.0 * t0 / extra * 1e9
            );
        }
    }
}
