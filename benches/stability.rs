//! How each method degrades where photon differentials break: a table of method x stress scene
//! (relRMSE against a light-traced reference, worst pixel ratio, energy, guards, time) and a
//! chart of error against the light's elevation, 90 down to 1 degree.
//!
//! Run: `cargo bench --bench stability`. Writes `out/stability_elevation.{svg,png}`. References
//! (160 x 120, `PHOTONDIFF_STRESS_REFERENCE_PATHS` paths, default 100,000,000) are cached in
//! `out/reference/`.

use glam::DVec3;
use photondiff::embree::Device;
use photondiff::photons::options::PhotonOptions;
use photondiff::reference::experiment::Method;
use photondiff::reference::metrics::{rel_rmse, Regions};
use photondiff::reference::stability::{energy_error, worst_pixel_ratio};
use photondiff::render::stats::Stats;
use photondiff::render::trace_photon_maps;
use photondiff::scene::file::load_scene;
use photondiff::scene::{Light, Scene};
use plotters::prelude::*;
use std::path::Path;

#[path = "common/mod.rs"]
mod common;

fn env(name: &str, default: u64) -> u64 {
    common::env_or(name, default)
}

fn methods() -> Vec<Method> {
    vec![
        Method::jensen(1),
        Method::regular(1),
        Method::regular(3),
        Method::coplanar(),
        Method::multisampled(8),
        Method::integrated_default(),
    ]
}

/// One scene measured with every method: `(label, relRMSE, worst ratio, energy, guards, seconds)`.
type Row = (String, f64, f64, f64, u64, f64);

/// A scene's rows, and its reference's relative noise over the lit pixels (from its halves).
type Measured = (Vec<Row>, f64);

fn measure(
    scene: &Scene,
    name: &str,
    photons: (usize, usize),
    paths: u64,
) -> Result<Measured, Box<dyn std::error::Error>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let device = Device::new()?;
    let embree = scene.build_embree(&device)?;
    let reference = photondiff::reference::cache::load_or_make(
        scene,
        &embree,
        &root.join("out/reference"),
        name,
        &photondiff::reference::cache::ReferenceSettings {
            light_paths: paths,
            caustic_paths: paths,
            ..Default::default()
        },
        &mut |m| eprintln!("{m}"),
    )?;
    let regions = Regions::new(scene, &embree, &reference.film);
    let lit = &regions.lit;
    let options = PhotonOptions {
        global_photons: photons.0,
        caustic_photons: photons.1,
        ..PhotonOptions::default()
    };
    let mut stats = Stats::default();
    let maps = trace_photon_maps(scene, &embree, &options, 0, false, &mut stats)?;
    let guards = maps.caustic.guards.total() + maps.global.guards.total();
    let mut rows = Vec::new();
    for method in methods() {
        let (film, seconds) = method.render(scene, &embree, &maps, &options, 0)?;
        rows.push((
            method.label(),
            rel_rmse(&film, &reference.film, lit),
            worst_pixel_ratio(&film, &reference.film, lit),
            energy_error(&film, &reference.film, lit),
            guards,
            seconds,
        ));
    }
    Ok((rows, reference.relative_noise(lit)))
}

fn at_160x120(mut scene: Scene) -> Scene {
    scene.camera = scene.camera.with_resolution(160, 120);
    scene
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = root.join("out");
    std::fs::create_dir_all(&out)?;
    let paths = env("PHOTONDIFF_STRESS_REFERENCE_PATHS", 100_000_000);
    let scenes = root.join("scenes");
    let cases: Vec<(&str, Scene, (usize, usize))> = vec![
        (
            "grazing light (2 deg)",
            load_scene(&scenes.join("stress/grazing-light.toml"))?,
            (100_000, 20_000),
        ),
        (
            "focal caustic",
            load_scene(&scenes.join("stress/focal-caustic.toml"))?,
            (100_000, 20_000),
        ),
        (
            "over an edge",
            load_scene(&scenes.join("stress/over-an-edge.toml"))?,
            (100_000, 20_000),
        ),
        (
            "glass through glass",
            load_scene(&scenes.join("stress/glass-through-glass.toml"))?,
            (100_000, 20_000),
        ),
        (
            "1,000 photons",
            at_160x120(load_scene(&scenes.join("caustic-sphere.toml"))?),
            (1_000, 1_000),
        ),
        (
            "5,000,000 photons",
            at_160x120(load_scene(&scenes.join("caustic-sphere.toml"))?),
            (5_000_000, 5_000_000),
        ),
    ];
    println!("\n## Stability: every method on every stress scene, 160 x 120\n");
    println!("relRMSE = sqrt(mean over pixels and channels of (I - R)^2) / mean(R) over the pixels the reference lights (first hit diffuse, R > 0), against a reference of direct light on 16x16 and 17x17 rays per pixel plus {paths} + {paths} caustic light paths for the rest; worst = the largest I/R where R is at least a tenth of its mean; energy = sum(I)/sum(R) - 1 over the same pixels; guards = clamped or fallback footprints in both maps.\n");
    println!("| scene | method | relRMSE | worst I/R | energy | guards | render s |");
    println!("|---|---|---|---|---|---|---|");
    let mut resolution = common::Resolution::default();
    for (k, (name, scene, photons)) in cases.iter().enumerate() {
        let file = format!("stress-{k}");
        let (rows, noise) = measure(scene, &file, *photons, paths)?;
        for (label, e, worst, energy, guards, seconds) in rows {
            let e = resolution.cell(e, noise, 4, false);
            println!(
                "| {name} | {label} | {e} | {worst:.2} | {energy:+.4} | {guards} | {seconds:.3} |"
            );
        }
    }

    // Error against the light's elevation.
    let base = load_scene(&scenes.join("stress/grazing-light.toml"))?;
    let elevations = [90.0, 60.0, 40.0, 25.0, 15.0, 10.0, 6.0, 3.0, 2.0, 1.0];
    let mut curves: Vec<(String, Vec<(f64, f64)>)> =
        methods().iter().map(|m| (m.label(), Vec::new())).collect();
    println!("\n### relRMSE against the light's elevation (grazing-light scene)\n");
    println!(
        "| elevation (deg) | {} |",
        curves
            .iter()
            .map(|c| c.0.clone())
            .collect::<Vec<_>>()
            .join(" | ")
    );
    println!("|---|{}", "---|".repeat(curves.len()));
    for e in elevations {
        let mut scene = base.clone();
        let r: f64 = e;
        let position = DVec3::new(-r.to_radians().cos(), r.to_radians().sin(), 0.0) * 6.0;
        scene.lights[0] = Light::Point {
            position,
            intensity: DVec3::splat(600.0),
        };
        let (rows, noise) = measure(
            &scene,
            &format!("elevation-{e}"),
            (100_000, 20_000),
            paths / 2,
        )?;
        let mut line = format!("| {e} |");
        for (curve, row) in curves.iter_mut().zip(&rows) {
            curve.1.push((e, row.1));
            line += &format!(" {} |", resolution.cell(row.1, noise, 4, false));
        }
        println!("{line}");
    }
    if resolution.any() {
        println!("\n{}", resolution.note("PHOTONDIFF_STRESS_REFERENCE_PATHS"));
    }
    plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
        .map_err(|_| "cannot register the embedded font")?;
    let svg = out.join("stability_elevation.svg");
    let png = out.join("stability_elevation.png");
    chart(
        SVGBackend::new(&svg, (900, 600)).into_drawing_area(),
        &curves,
    )?;
    chart(
        BitMapBackend::new(&png, (900, 600)).into_drawing_area(),
        &curves,
    )?;
    println!("\nWrote {} and {}.", svg.display(), png.display());
    Ok(())
}

fn chart<DB: DrawingBackend>(
    area: DrawingArea<DB, plotters::coord::Shift>,
    curves: &[(String, Vec<(f64, f64)>)],
) -> Result<(), Box<dyn std::error::Error>>
where
    DB::ErrorType: 'static,
{
    area.fill(&WHITE)?;
    let values = curves
        .iter()
        .flat_map(|c| c.1.iter().map(|p| p.1))
        .filter(|v| v.is_finite() && *v > 0.0);
    let (lo, hi) = values.fold((f64::MAX, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    let mut chart = ChartBuilder::on(&area)
        .caption(
            "Grazing light: error against the light's elevation",
            ("sans-serif", 22),
        )
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(65)
        .build_cartesian_2d(
            (0.8f64..100.0).log_scale(),
            (lo * 0.8..hi * 1.25).log_scale(),
        )?;
    chart
        .configure_mesh()
        .x_desc("light elevation (degrees), log scale")
        .y_desc("relRMSE over lit pixels, log scale")
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(&|v| format!("{v:.2}"))
        .label_style(("sans-serif", 14))
        .draw()?;
    for (k, (label, points)) in curves.iter().enumerate() {
        let color = Palette99::pick(k).to_rgba();
        chart
            .draw_series(LineSeries::new(points.clone(), color.stroke_width(2)))?
            .label(label.clone())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
            });
        chart.draw_series(points.iter().map(|&p| Circle::new(p, 4, color.filled())))?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 13))
        .position(SeriesLabelPosition::UpperLeft)
        .draw()?;
    area.present()?;
    Ok(())
}
