//! Reproduces the thesis's timing table (METHOD.md section 5) on the canonical scene, with each
//! row's error against a light-traced reference.
//!
//! Run: `cargo bench --bench timing_table`. Environment: `PHOTONDIFF_REFERENCE_PATHS` (aimed
//! caustic paths of the reference, default 2*10^8), `PHOTONDIFF_REFERENCE_LIGHT_PATHS` (its
//! isotropic paths, default 2*10^9; the reference `default_render` and `convergence` use, cached
//! under `out/reference/`),
//! `PHOTONDIFF_REPEATS` (default 3), `PHOTONDIFF_THREADS` (default: all cores).
//!
//! Also writes an HTML report of the run (`photondiff report`'s page) to
//! `out/timing_table/index.html`: every row's image beside the reference, error maps, crops of
//! the floor, caustic, contour and shadow, the table and a chart of time against caustic error;
//! the table as `out/timing_table/table.json` (for `photondiff report --table`).

use photondiff::embree::Device;
use photondiff::photons::options::PhotonOptions;
use photondiff::reference::chart::{scatter_svg, Point};
use photondiff::reference::experiment::Method;
use photondiff::reference::metrics::{rel_rmse, ssim, Regions};
use photondiff::reference::report::{self, Chart, Render, Report, Table};
use photondiff::render::stats::Stats;
use photondiff::render::trace_photon_maps;
use photondiff::scene::file::load_scene;
use std::path::Path;

fn env(name: &str, default: u64) -> u64 {
    common::env_or(name, default)
}

#[path = "common/mod.rs"]
mod common;
use common::median;

fn main() -> Result<(), String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene = load_scene(&root.join("scenes/caustic-sphere.toml")).map_err(|e| e.to_string())?;
    let device = Device::new().map_err(|e| e.to_string())?;
    let embree = scene.build_embree(&device).map_err(|e| e.to_string())?;
    let repeats = env("PHOTONDIFF_REPEATS", 3).max(1) as usize;
    let threads = env("PHOTONDIFF_THREADS", 0) as usize;
    let paths = env("PHOTONDIFF_REFERENCE_PATHS", 200_000_000);
    let light_paths = env("PHOTONDIFF_REFERENCE_LIGHT_PATHS", 2_000_000_000);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| e.to_string())?;

    let reference = pool.install(|| {
        photondiff::reference::cache::load_or_make(
            &scene,
            &embree,
            &root.join("out/reference"),
            "caustic-sphere",
            &photondiff::reference::cache::ReferenceSettings {
                light_paths,
                caustic_paths: paths,
                ..Default::default()
            },
            &mut |m| eprintln!("{m}"),
        )
    })?;
    let regions = Regions::new(&scene, &embree, &reference.film);

    // The same photon maps for every method; tracing timed on its own.
    let options = PhotonOptions::default();
    let mut trace_times = Vec::new();
    let mut maps = None;
    for _ in 0..repeats {
        let mut stats = Stats::default();
        maps = Some(trace_photon_maps(
            &scene, &embree, &options, threads, false, &mut stats,
        )?);
        trace_times.push(stats.seconds("trace photons"));
    }
    let maps = maps.expect("at least one repetition");

    let rows: Vec<(Method, Option<f64>)> = vec![
        (Method::regular(1), Some(1.00)),
        (Method::regular(3), Some(8.88)),
        (Method::coplanar(), Some(18.42)),
        (Method::multisampled(8), Some(3.09)),
        (Method::integrated(), None),
        (Method::integrated_default(), None),
        (Method::jensen(1), None),
        (Method::jensen(3), None),
        (Method::multisampled(1), None),
        (Method::multisampled(2), None),
        (Method::multisampled(4), None),
        (Method::multisampled(16), None),
    ];
    // One untimed render first, so that no row pays for cold caches and page faults.
    rows[0]
        .0
        .render(&scene, &embree, &maps, &options, threads)?;
    // Methods alternate within each repetition, so that machine noise hits all alike.
    let mut times = vec![Vec::new(); rows.len()];
    let mut films = vec![None; rows.len()];
    for rep in 0..repeats {
        for (k, (method, _)) in rows.iter().enumerate() {
            let (film, seconds) = method.render(&scene, &embree, &maps, &options, threads)?;
            eprintln!(
                "repetition {}/{repeats}: {} {seconds:.3} s",
                rep + 1,
                method.label()
            );
            times[k].push(seconds);
            films[k] = Some(film);
        }
    }
    let base = median(times[0].clone());
    println!("\n## Timing table: canonical scene, 640 x 480, {} global + {} caustic photon differentials\n",
        options.global_photons, options.caustic_photons);
    println!("Photon tracing (shared by every row): {:.3} s (median of {repeats}). Rendering: median of {repeats}, methods alternated, {} threads.", median(trace_times), pool.current_num_threads());
    println!("Error: relRMSE = sqrt(mean over pixels and channels of (I - R)^2) / mean(R) against a reference of direct light on 16x16 and 17x17 rays per pixel plus {light_paths} + {paths} caustic light paths for the rest, over the floor ({} px), the caustic ({} px: reference > 1.5 x unblocked direct light) and its contour ({} px: the tenth of the caustic with the largest reference gradient); SSIM on sRGB luminance over the whole image.", regions.diffuse.len(), regions.caustic.len(), regions.contour.len());
    println!("Reference noise (relative, from its two halves): floor {:.4}, caustic {:.4}, contour {:.4}.\n",
        reference.relative_noise(&regions.diffuse), reference.relative_noise(&regions.caustic), reference.relative_noise(&regions.contour));
    let noise = [&regions.diffuse, &regions.caustic, &regions.contour]
        .map(|px| reference.relative_noise(px));
    let mut resolution = common::Resolution::default();
    let mut table_rows = Vec::new();
    let mut points = Vec::new();
    for (k, (method, thesis)) in rows.iter().enumerate() {
        let t = median(times[k].clone());
        let film = films[k].as_ref().expect("rendered");
        let errors = [
            rel_rmse(film, &reference.film, &regions.diffuse),
            rel_rmse(film, &reference.film, &regions.caustic),
            rel_rmse(film, &reference.film, &regions.contour),
            ssim(film, &reference.film),
        ];
        let thesis = thesis.map_or("".to_string(), |r| format!("{r:.2}"));
        let mut row = vec![
            method.label().into(),
            format!("{t:.3}").into(),
            format!("{:.2}", t / base).into(),
            thesis.into(),
        ];
        row.extend(
            errors[..3]
                .iter()
                .zip(noise)
                .map(|(&e, n)| resolution.cell(e, n, 4, false).into()),
        );
        row.push(format!("{:.4}", errors[3]).into());
        table_rows.push(row);
        points.push(Point {
            label: method.label(),
            x: t,
            y: errors[1],
        });
    }

    // The run as a report page.
    let unresolved =
        resolution.note("PHOTONDIFF_REFERENCE_PATHS, PHOTONDIFF_REFERENCE_LIGHT_PATHS");
    let table = Table {
        title: "Timing table".into(),
        columns: ["method", "rendering time (s)", "ratio to regular 1x1", "thesis ratio", "relRMSE floor", "relRMSE caustic", "relRMSE contour", "SSIM"]
            .map(String::from).to_vec(),
        rows: table_rows,
        notes: vec![format!(
            "Canonical scene, {} global + {} caustic photons; rendering time: median of {repeats}, methods alternated, {} threads; reference: {light_paths} + {paths} caustic light paths.",
            options.global_photons, options.caustic_photons, pool.current_num_threads()
        ), unresolved.clone()]
        .into_iter()
        .filter(|n| !n.is_empty())
        .collect(),
    };
    print!("{}", table.markdown());
    if resolution.any() {
        println!("\n{unresolved}");
    }
    let page = report::write_with_tables(
        &Report {
            title: "Timing table: canonical scene".into(),
            notes: vec![format!("Reference: direct light on 16x16 and 17x17 rays per pixel plus {light_paths} + {paths} caustic light paths."), report::REGIONS_NOTE.to_string()],
            reference: Render { label: "reference".into(), film: reference.film.clone() },
            renders: rows
                .iter()
                .zip(&films)
                .map(|((m, _), f)| Render { label: m.label(), film: f.clone().expect("rendered") })
                .collect(),
            regions: report::scene_regions(&regions, reference.film.pixels.len()),
            tables: vec![table],
            charts: vec![Chart::Svg {
                name: "rendering time against caustic error".into(),
                svg: scatter_svg("Rendering time against caustic error", "rendering time (s)", "relRMSE caustic", &points),
            }],
            exposure: 0.0,
        },
        &root.join("out/timing_table"),
    )?;
    eprintln!("report: {}", page.display());

    // Scaling with threads: one thread against all, alternated.
    let all = pool.current_num_threads();
    if all > 1 {
        println!("\nThread scaling (rendering time on 1 thread over time on {all}, median of {repeats}, alternated):\n");
        println!("| method | 1 thread (s) | {all} threads (s) | speed-up |");
        println!("|---|---|---|---|");
        for method in [
            Method::regular(1),
            Method::multisampled(8),
            Method::coplanar(),
        ] {
            let (mut one, mut many) = (Vec::new(), Vec::new());
            for _ in 0..repeats {
                one.push(method.render(&scene, &embree, &maps, &options, 1)?.1);
                many.push(method.render(&scene, &embree, &maps, &options, all)?.1);
            }
            let (a, b) = (median(one), median(many));
            println!("| {} | {a:.3} | {b:.3} | {:.2} |", method.label(), a / b);
        }
    }
    Ok(())
}
