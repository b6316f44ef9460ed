//! Speed against accuracy: every method at the default photon counts and at 4x and 16x them,
//! rendering time against caustic error, charted (SVG and PNG, with an embedded font), and a
//! crop of the caustic per method beside the reference.
//!
//! Run: `cargo bench --bench speed_vs_error`. Writes `out/speed_vs_error.{csv,svg,png}` and
//! `out/caustic_crops.png`. Environment as for the timing table (`PHOTONDIFF_REFERENCE_PATHS`,
//! default 2*10^8, `PHOTONDIFF_REFERENCE_LIGHT_PATHS`, default 2*10^9: the same cached reference,
//! `PHOTONDIFF_THREADS`, `PHOTONDIFF_REPEATS`: timed renders per point, default 3, the methods
//! alternated within each repetition and the median charted, so that no Pareto mark rests on
//! one timing on a shared machine).

use photondiff::embree::Device;
use photondiff::photons::options::PhotonOptions;
use photondiff::reference::experiment::Method;
use photondiff::reference::metrics::{rel_rmse, ssim, Regions};
use photondiff::render::film::{linear_to_srgb, Film};
use photondiff::render::stats::Stats;
use photondiff::render::trace_photon_maps;
use photondiff::scene::file::load_scene;
use plotters::prelude::*;
use std::path::Path;

#[path = "common/mod.rs"]
mod common;

fn env(name: &str, default: u64) -> u64 {
    common::env_or(name, default)
}

/// One measured point.
struct Point {
    curve: String,
    label: String,
    scale: u32,
    seconds: f64,
    caustic: f64,
    floor: f64,
    contour: f64,
    ssim: f64,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = root.join("out");
    std::fs::create_dir_all(&out)?;
    let scene = load_scene(&root.join("scenes/caustic-sphere.toml"))?;
    let device = Device::new()?;
    let embree = scene.build_embree(&device)?;
    let threads = env("PHOTONDIFF_THREADS", 0) as usize;
    let repeats = env("PHOTONDIFF_REPEATS", 3).max(1) as usize;
    // The reference the timing table, `default_render` and `convergence` use (one cache).
    let paths = env("PHOTONDIFF_REFERENCE_PATHS", 200_000_000);
    let light_paths = env("PHOTONDIFF_REFERENCE_LIGHT_PATHS", 2_000_000_000);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    let reference = pool.install(|| {
        photondiff::reference::cache::load_or_make(
            &scene,
            &embree,
            &out.join("reference"),
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

    let families: Vec<(&str, Vec<Method>)> = vec![
        ("Regular", (1..=4).map(Method::regular).collect()),
        (
            "Multi-sampled",
            [1, 2, 4, 8, 16]
                .into_iter()
                .map(Method::multisampled)
                .collect(),
        ),
        ("Coplanar", vec![Method::coplanar()]),
        ("Jensen", vec![Method::jensen(1), Method::jensen(3)]),
        (
            "Footprint-integrated",
            vec![Method::integrated(), Method::integrated_default()],
        ),
    ];
    let mut points = Vec::new();
    let mut crops: Vec<(String, Film)> = Vec::new();
    for scale in [1u32, 4, 16] {
        let options = PhotonOptions {
            global_photons: 100_000 * scale as usize,
            caustic_photons: 20_000 * scale as usize,
            ..PhotonOptions::default()
        };
        let maps = trace_photon_maps(
            &scene,
            &embree,
            &options,
            threads,
            false,
            &mut Stats::default(),
        )?;
        // One untimed render first, so that no point pays for cold caches.
        Method::regular(1).render(&scene, &embree, &maps, &options, threads)?;
        // Every method once a repetition, in turn: a slow spell of the machine then falls on
        // all of them alike. Renders are deterministic: the last film stands for them all.
        let mut times: Vec<Vec<f64>> = Vec::new();
        let mut films: Vec<Option<Film>> = Vec::new();
        for rep in 0..repeats {
            let all = families.iter().flat_map(|(_, methods)| methods);
            for (k, method) in all.enumerate() {
                let (film, seconds) = method.render(&scene, &embree, &maps, &options, threads)?;
                eprintln!(
                    "photons x{scale}, repetition {}/{repeats}: {} {seconds:.3} s",
                    rep + 1,
                    method.label()
                );
                if rep == 0 {
                    times.push(Vec::new());
                    films.push(None);
                }
                times[k].push(seconds);
                films[k] = Some(film);
            }
        }
        let mut measured = times.into_iter().zip(films);
        for (family, methods) in &families {
            for method in methods {
                let (times, film) = measured.next().expect("one entry a method");
                let film = film.expect("rendered");
                points.push(Point {
                    curve: format!("{family}, photons x{scale}"),
                    label: method.label(),
                    scale,
                    seconds: common::median(times),
                    caustic: rel_rmse(&film, &reference.film, &regions.caustic),
                    floor: rel_rmse(&film, &reference.film, &regions.diffuse),
                    contour: rel_rmse(&film, &reference.film, &regions.contour),
                    ssim: ssim(&film, &reference.film),
                });
                let shown = [
                    Method::regular(1),
                    Method::regular(3),
                    Method::coplanar(),
                    Method::multisampled(8),
                    Method::jensen(1),
                    Method::integrated_default(),
                ];
                if scale == 1 && shown.contains(method) {
                    crops.push((method.label(), film));
                }
            }
        }
    }

    // Table and CSV.
    let mut csv = String::from(
        "method,photon_scale,seconds,relrmse_caustic,relrmse_floor,relrmse_contour,ssim\n",
    );
    println!(
        "\n## Speed against error: canonical scene, 640 x 480, {} threads, render time the median of {repeats}\n",
        pool.current_num_threads()
    );
    println!("relRMSE = sqrt(mean over pixels and channels of (I - R)^2) / mean(R), against a reference of direct light on 16x16 and 17x17 rays per pixel plus {light_paths} + {paths} caustic light paths for the rest (noise: caustic {:.4}, floor {:.4}, contour {:.4}).\n",
        reference.relative_noise(&regions.caustic), reference.relative_noise(&regions.diffuse), reference.relative_noise(&regions.contour));
    println!("| method | photons | render s | relRMSE caustic | relRMSE floor | relRMSE contour | SSIM | Pareto |");
    println!("|---|---|---|---|---|---|---|---|");
    let pareto: Vec<bool> = points
        .iter()
        .map(|p| {
            !points.iter().any(|q| {
                // Dominated: another point at least as fast and strictly more accurate.
                q.seconds <= p.seconds && q.caustic < p.caustic
            })
        })
        .collect();
    let noise = [&regions.caustic, &regions.diffuse, &regions.contour]
        .map(|px| reference.relative_noise(px));
    let mut resolution = common::Resolution::default();
    for (p, front) in points.iter().zip(&pareto) {
        let [caustic, floor, contour] = [p.caustic, p.floor, p.contour]
            .iter()
            .zip(noise)
            .map(|(&e, n)| resolution.cell(e, n, 4, false))
            .collect::<Vec<_>>()
            .try_into()
            .expect("three regions");
        println!(
            "| {} | x{} | {:.3} | {caustic} | {floor} | {contour} | {:.4} | {} |",
            p.label,
            p.scale,
            p.seconds,
            p.ssim,
            if *front { "yes" } else { "" }
        );
        csv += &format!(
            "{},{},{:.6},{:.6},{:.6},{:.6},{:.6}\n",
            p.label, p.scale, p.seconds, p.caustic, p.floor, p.contour, p.ssim
        );
    }
    if resolution.any() {
        println!(
            "\n{}",
            resolution.note("PHOTONDIFF_REFERENCE_PATHS, PHOTONDIFF_REFERENCE_LIGHT_PATHS")
        );
    }
    std::fs::write(out.join("speed_vs_error.csv"), csv)?;

    // The chart, twice: SVG and PNG. The PNG's text uses DejaVu Sans, embedded: no system fonts.
    plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
        .map_err(|_| "cannot register the embedded font")?;
    let svg = out.join("speed_vs_error.svg");
    let png = out.join("speed_vs_error.png");
    chart(
        SVGBackend::new(&svg, (1000, 700)).into_drawing_area(),
        &points,
        &pareto,
    )?;
    chart(
        BitMapBackend::new(&png, (1000, 700)).into_drawing_area(),
        &points,
        &pareto,
    )?;

    // Crops of the caustic, one tile per method, beside the reference.
    crops.insert(
        0,
        (
            "Reference (light tracing)".to_string(),
            reference.film.clone(),
        ),
    );
    montage(
        &out.join("caustic_crops.png"),
        &crops,
        &regions,
        scene.camera.width,
    )?;
    println!(
        "\nWrote {}, {}, {} and {}.",
        out.join("speed_vs_error.csv").display(),
        svg.display(),
        png.display(),
        out.join("caustic_crops.png").display()
    );
    Ok(())
}

fn chart<DB: DrawingBackend>(
    area: DrawingArea<DB, plotters::coord::Shift>,
    points: &[Point],
    pareto: &[bool],
) -> Result<(), Box<dyn std::error::Error>>
where
    DB::ErrorType: 'static,
{
    area.fill(&WHITE)?;
    // The key beside the plot, not on it: inside, it covered the slowest points (Jensen's
    // and coplanar's at 16 times the photons).
    let (width, _) = area.dim_in_pixel();
    let (area, key) = area.split_horizontally(width.saturating_sub(250));
    let mut entries: Vec<(String, ShapeStyle)> = Vec::new();
    let (tmin, tmax) = points.iter().fold((f64::MAX, 0.0f64), |(a, b), p| {
        (a.min(p.seconds), b.max(p.seconds))
    });
    let (emin, emax) = points
        .iter()
        .filter(|p| p.caustic.is_finite())
        .fold((f64::MAX, 0.0f64), |(a, b), p| {
            (a.min(p.caustic), b.max(p.caustic))
        });
    let mut chart = ChartBuilder::on(&area)
        .caption(
            "Canonical scene: rendering time against caustic error",
            ("sans-serif", 22),
        )
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(65)
        .build_cartesian_2d(
            (tmin * 0.8..tmax * 1.25)
                .log_scale()
                .with_key_points(one_two_five(tmin * 0.8, tmax * 1.25)),
            (emin * 0.8..emax * 1.25)
                .log_scale()
                .with_key_points(one_two_five(emin * 0.8, emax * 1.25)),
        )?;
    chart
        .configure_mesh()
        .x_desc("rendering time (s), log scale")
        .y_desc("caustic relRMSE, log scale")
        .x_label_formatter(&|v| log_tick(*v))
        .y_label_formatter(&|v| log_tick(*v))
        .label_style(("sans-serif", 14))
        .draw()?;
    let mut curves: Vec<&str> = Vec::new();
    for p in points {
        if !curves.contains(&p.curve.as_str()) {
            curves.push(&p.curve);
        }
    }
    for (k, curve) in curves.iter().enumerate() {
        let color = Palette99::pick(k).to_rgba();
        // In the order measured: increasing N along each curve.
        let series: Vec<(f64, f64)> = points
            .iter()
            .filter(|p| p.curve == *curve)
            .map(|p| (p.seconds, p.caustic))
            .collect();
        chart.draw_series(LineSeries::new(series.clone(), color.stroke_width(2)))?;
        entries.push((curve.to_string(), color.stroke_width(2)));
        chart.draw_series(
            series
                .iter()
                .map(|&(x, y)| Circle::new((x, y), 4, color.filled())),
        )?;
    }
    let mut front: Vec<(f64, f64)> = points
        .iter()
        .zip(pareto)
        .filter(|(_, f)| **f)
        .map(|(p, _)| (p.seconds, p.caustic))
        .collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0));
    chart.draw_series(LineSeries::new(front, BLACK.stroke_width(1)))?;
    entries.push(("Pareto front".into(), BLACK.stroke_width(1)));
    for (k, (label, style)) in entries.into_iter().enumerate() {
        let y = 60 + 19 * k as i32;
        key.draw(&PathElement::new(vec![(5, y), (29, y)], style))?;
        key.draw(&Text::new(label, (36, y - 7), ("sans-serif", 13)))?;
    }
    area.present()?;
    Ok(())
}

fn montage(
    path: &Path,
    tiles: &[(String, Film)],
    regions: &Regions,
    width: u32,
) -> Result<(), Box<dyn std::error::Error>> {
    // 160 x 120 pixels around the brightest caustic pixel of the reference (images of at
    // least that size).
    let film = &tiles[0].1;
    let Some(&brightest) = regions
        .caustic
        .iter()
        .max_by(|&&a, &&b| film.pixels[a].x.total_cmp(&film.pixels[b].x))
    else {
        return Ok(());
    };
    let (cx, cy) = (brightest as u32 % width, brightest as u32 / width);
    let x0 = cx.saturating_sub(60).min(film.width.saturating_sub(160));
    let y0 = cy.saturating_sub(40).min(film.height.saturating_sub(120));
    let (x1, y1) = (
        (x0 + 159).min(film.width - 1),
        (y0 + 119).min(film.height - 1),
    );
    let (cw, ch) = (x1 - x0 + 1, y1 - y0 + 1);
    let scale = 3;
    let label_h = 24;
    let (tw, th) = (cw * scale, ch * scale + label_h);
    let (w, h) = (tw * tiles.len() as u32, th);
    let mut buffer = vec![255u8; (w * h * 3) as usize];
    for (k, (_, film)) in tiles.iter().enumerate() {
        for y in 0..ch * scale {
            for x in 0..cw * scale {
                let p = film.pixel(x0 + x / scale, y0 + y / scale);
                let o = ((y * w + k as u32 * tw + x) * 3) as usize;
                for (c, v) in p.to_array().iter().enumerate() {
                    buffer[o + c] = (linear_to_srgb(*v) * 255.0 + 0.5) as u8;
                }
            }
        }
    }
    {
        let area = BitMapBackend::with_buffer(&mut buffer, (w, h)).into_drawing_area();
        for (k, (label, _)) in tiles.iter().enumerate() {
            area.draw(&Text::new(
                label.clone(),
                (k as i32 * tw as i32 + 4, (ch * scale) as i32 + 4),
                ("sans-serif", 13).into_font().color(&BLACK),
            ))?;
        }
        area.present()?;
    }
    image::save_buffer(path, &buffer, w, h, image::ExtendedColorType::Rgb8)?;
    Ok(())
}

/// The ticks of a log axis from `lo` to `hi`: 1, 2 and 5 times the powers of ten between
/// (plotters' own start at the first power of ten, so an axis from 0.16 to 1 had none).
fn one_two_five(lo: f64, hi: f64) -> Vec<f64> {
    let mut ticks = Vec::new();
    let mut decade = 10f64.powf(lo.log10().floor());
    while decade <= hi {
        for m in [1.0, 2.0, 5.0] {
            let v = m * decade;
            if (lo..=hi).contains(&v) {
                ticks.push(v);
            }
        }
        decade *= 10.0;
    }
    ticks
}

/// A log axis's label at `v` (a tick of [`one_two_five`]), as short as it reads: "0.05", "2",
/// "20".
fn log_tick(v: f64) -> String {
    let places = (-v.log10().floor()).max(0.0) as usize;
    format!("{v:.places$}")
}
