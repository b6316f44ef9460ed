//! Error against time: how each method converges as it is given more time, per region, on the
//! canonical scene and each stress scene (`cargo bench --bench convergence`).
//!
//! Methods: `integrated` with progressive passes (the default), multi-sampled 8x8 with passes,
//! Regular (photon differentials) 3x3 with passes, and the light tracer itself. A progressive
//! method runs once, pass after pass, up to the largest budget; its image at budget `B` is the
//! running mean after the last pass that ended within `B` - exactly what `--time-budget B`
//! renders, measured in one run instead of seven. The light tracer runs once per budget.
//!
//! Error: relRMSE = sqrt(mean over pixels and channels of (I - R)^2) / mean(R) per region,
//! against the split reference (`photondiff reference`; cached in `out/reference/`), whose own
//! noise per region is printed beside: an error below three times it is marked `~`.
//! Environment: `PHOTONDIFF_BUDGETS` (seconds, comma-separated; default 0.5,1,2,4,8,16,32),
//! `PHOTONDIFF_REFERENCE_PATHS` (paths per set of the canonical reference, default 2*10^8),
//! `PHOTONDIFF_STRESS_REFERENCE_PATHS` (default 5*10^7), `PHOTONDIFF_DIRECT_GRIDS` (the
//! reference's two direct-light grids, default 16,17), `PHOTONDIFF_SCENES` (`canonical`,
//! `stress` or `all`, default all), `PHOTONDIFF_THREADS` (default all cores).
//!
//! Asserted in the output (exit status 1 otherwise): the progressive `integrated` error falls
//! monotonically over the budgets in every region whose error is above the reference's noise.

use photondiff::embree::Device;
use photondiff::estimate::{EstimatorKind, EstimatorSettings};
use photondiff::photons::trace::PhotonOptions;
use photondiff::reference::cache::{load_or_make, Reference, ReferenceSettings};
use photondiff::reference::light_tracer::{LightTraceOptions, LightTracer};
use photondiff::reference::metrics::{rel_rmse, Regions};
use photondiff::render::film::Film;
use photondiff::render::pass_sum::PassSum;
use photondiff::render::passes::{Progressive, DEFAULT_ALPHA};
use photondiff::render::stats::Stats;
use photondiff::render::RenderOptions;
use photondiff::scene::file::load_scene;
use photondiff::scene::Scene;
use plotters::prelude::*;
use std::path::Path;
use std::time::{Duration, Instant};

fn env_u64(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// One method's curve: the error per region at each budget.
struct Curve {
    method: String,
    /// Per budget: seconds actually used and the errors (floor, caustic, contour, shadow).
    points: Vec<(f64, [f64; 4])>,
}

const REGIONS: [&str; 4] = ["floor", "caustic", "contour", "shadow"];

fn errors(image: &Film, reference: &Reference, regions: &Regions) -> [f64; 4] {
    let r = [
        &regions.diffuse,
        &regions.caustic,
        &regions.contour,
        &regions.shadow,
    ];
    r.map(|px| {
        if px.is_empty() {
            f64::NAN
        } else {
            rel_rmse(image, &reference.film, px)
        }
    })
}

/// A progressive method, pass after pass up to the largest budget.
fn progressive(
    scene: &Scene,
    embree: &photondiff::embree::Scene,
    kind: EstimatorKind,
    view_grid: u32,
    budgets: &[f64],
    threads: usize,
    (reference, regions): (&Reference, &Regions),
) -> Result<Vec<(f64, [f64; 4])>, String> {
    let photons = PhotonOptions::default();
    let estimator = EstimatorSettings {
        kind,
        k: 50,
        max_radius: photons.limits(scene).max_radius,
        ms_grid: 8,
        ellipse_vertices: 16,
    };
    let run = Progressive {
        scene,
        embree,
        photons,
        estimator,
        render: RenderOptions::default()
            .with_view_grid(view_grid)
            .with_threads(threads),
        alpha: DEFAULT_ALPHA,
    };
    let last = budgets.iter().cloned().fold(0.0, f64::max);
    let mut sum = PassSum::new(scene.camera.width, scene.camera.height);
    let start = Instant::now();
    // (seconds at the end of the pass, errors of the mean after it)
    let mut snapshots: Vec<(f64, [f64; 4])> = Vec::new();
    while start.elapsed().as_secs_f64() < last {
        sum.add(&run.render_pass(sum.passes, false, &mut Stats::default())?);
        let t = start.elapsed().as_secs_f64();
        snapshots.push((t, errors(&sum.mean(), reference, regions)));
    }
    Ok(budgets
        .iter()
        .map(|&b| {
            snapshots
                .iter()
                .rev()
                .find(|s| s.0 <= b)
                .copied()
                .unwrap_or(snapshots[0])
        })
        .collect())
}

fn light_tracer(
    scene: &Scene,
    embree: &photondiff::embree::Scene,
    budgets: &[f64],
    reference: &Reference,
    regions: &Regions,
) -> Vec<(f64, [f64; 4])> {
    budgets
        .iter()
        .map(|&b| {
            let options = LightTraceOptions {
                // More than any budget allows: the budget stops it.
                paths: 20_000_000_000,
                time_budget: Some(Duration::from_secs_f64(b)),
                seed: 11,
                ..LightTraceOptions::default()
            };
            let start = Instant::now();
            let result =
                LightTracer::new(scene, embree, &options).run(&indicatif::ProgressBar::hidden());
            (
                start.elapsed().as_secs_f64(),
                errors(&result.film, reference, regions),
            )
        })
        .collect()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = root.join("out");
    std::fs::create_dir_all(&out)?;
    let budgets: Vec<f64> = std::env::var("PHOTONDIFF_BUDGETS")
        .unwrap_or_else(|_| "0.5,1,2,4,8,16,32".into())
        .split(',')
        .map(|s| s.trim().parse::<f64>())
        .collect::<Result<_, _>>()?;
    let threads = env_u64("PHOTONDIFF_THREADS", 0) as usize;
    let which = std::env::var("PHOTONDIFF_SCENES").unwrap_or_else(|_| "all".into());
    let paths = env_u64("PHOTONDIFF_REFERENCE_PATHS", 200_000_000);
    let stress_paths = env_u64("PHOTONDIFF_STRESS_REFERENCE_PATHS", 50_000_000);
    let grids: Vec<u32> = std::env::var("PHOTONDIFF_DIRECT_GRIDS")
        .unwrap_or_else(|_| "16,17".into())
        .split(',')
        .map(|s| s.trim().parse::<u32>())
        .collect::<Result<_, _>>()?;
    let grids: [u32; 2] = grids
        .try_into()
        .map_err(|_| "PHOTONDIFF_DIRECT_GRIDS takes two numbers")?;
    let scenes_dir = root.join("scenes");
    let mut cases: Vec<(&str, Scene, u64)> = Vec::new();
    if which == "all" || which == "canonical" {
        cases.push((
            "caustic-sphere",
            load_scene(&scenes_dir.join("caustic-sphere.toml"))?,
            paths,
        ));
    }
    if which == "all" || which == "stress" {
        for name in [
            "grazing-light",
            "focal-caustic",
            "over-an-edge",
            "glass-through-glass",
        ] {
            let mut scene = load_scene(&scenes_dir.join(format!("stress/{name}.toml")))?;
            scene.camera = scene.camera.with_resolution(160, 120);
            cases.push((name, scene, stress_paths));
        }
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    let device = Device::new()?;
    let mut csv = String::from("scene,method,budget_s,seconds,region,relrmse,reference_noise\n");
    let mut failed = Vec::new();
    plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
        .map_err(|_| "cannot register the embedded font")?;
    for (name, scene, paths) in &cases {
        let embree = scene.build_embree(&device)?;
        let settings = ReferenceSettings {
            light_paths: *paths,
            caustic_paths: *paths,
            direct_grids: grids,
        };
        let reference = pool.install(|| {
            load_or_make(
                scene,
                &embree,
                &out.join("reference"),
                name,
                &settings,
                &mut |m| eprintln!("{m}"),
            )
        })?;
        let regions = Regions::new(scene, &embree, &reference.film);
        let sets = [
            &regions.diffuse,
            &regions.caustic,
            &regions.contour,
            &regions.shadow,
        ];
        let noise = sets.map(|px| {
            if px.is_empty() {
                f64::NAN
            } else {
                reference.relative_noise(px)
            }
        });
        let mut curves = Vec::new();
        for (method, kind, grid) in [
            ("integrated, passes", EstimatorKind::Integrated, 1),
            ("multi-sampled 8x8, passes", EstimatorKind::Multisampled, 1),
            ("Regular 3x3, passes", EstimatorKind::Pd, 3),
        ] {
            eprintln!("{name}: {method}");
            let points = pool.install(|| {
                progressive(
                    scene,
                    &embree,
                    kind,
                    grid,
                    &budgets,
                    threads,
                    (&reference, &regions),
                )
            })?;
            curves.push(Curve {
                method: method.into(),
                points,
            });
        }
        eprintln!("{name}: light tracer");
        let points = pool.install(|| light_tracer(scene, &embree, &budgets, &reference, &regions));
        curves.push(Curve {
            method: "light tracer".into(),
            points,
        });

        println!(
            "\n#### {name} ({} x {})\n",
            scene.camera.width, scene.camera.height
        );
        println!(
            "Reference: direct light on {}x{0} and {}x{1} rays per pixel plus {paths} + {paths} caustic light paths; its noise (from its halves): {}.\n",
            grids[0],
            grids[1],
            REGIONS
                .iter()
                .zip(noise)
                .map(|(r, n)| format!("{r} {:.4}", n))
                .collect::<Vec<_>>()
                .join(", ")
        );
        let header: Vec<String> = budgets.iter().map(|b| format!("{b} s")).collect();
        println!("| method | region | {} |", header.join(" | "));
        println!("|---|---|{}", "---|".repeat(budgets.len()));
        for curve in &curves {
            for (k, region) in REGIONS.iter().enumerate() {
                if sets[k].is_empty() {
                    continue;
                }
                let cells: Vec<String> = curve
                    .points
                    .iter()
                    .map(|p| {
                        let mark = if p.1[k] < 3.0 * noise[k] { "~" } else { "" };
                        format!("{mark}{:.4}", p.1[k])
                    })
                    .collect();
                println!("| {} | {region} | {} |", curve.method, cells.join(" | "));
                for (b, p) in budgets.iter().zip(&curve.points) {
                    csv += &format!(
                        "{name},{},{b},{:.3},{region},{:.6},{:.6}\n",
                        curve.method, p.0, p.1[k], noise[k]
                    );
                }
            }
        }
        // The progressive default must fall monotonically wherever the reference can tell.
        let ours = &curves[0];
        for (k, region) in REGIONS.iter().enumerate() {
            if sets[k].is_empty() {
                continue;
            }
            for w in ours.points.windows(2) {
                let (a, b) = (w[0].1[k], w[1].1[k]);
                if b > a * 1.0001 && b > 3.0 * noise[k] && w[1].0 > w[0].0 {
                    failed.push(format!(
                        "{name}: integrated {region} error rose from {a:.4} to {b:.4}"
                    ));
                }
            }
        }
        for (file, backend_png) in [("svg", false), ("png", true)] {
            let path = out.join(format!("convergence-{name}.{file}"));
            if backend_png {
                chart(
                    BitMapBackend::new(&path, (1000, 700)).into_drawing_area(),
                    name,
                    &curves,
                    &sets,
                )?;
            } else {
                chart(
                    SVGBackend::new(&path, (1000, 700)).into_drawing_area(),
                    name,
                    &curves,
                    &sets,
                )?;
            }
        }
    }
    std::fs::write(out.join("convergence.csv"), csv)?;
    println!(
        "\nWrote {} and out/convergence-<scene>.{{svg,png}}.",
        out.join("convergence.csv").display()
    );
    if failed.is_empty() {
        println!("ASSERT monotonic: the progressive integrated error falls at every budget in every region: yes");
        Ok(())
    } else {
        for f in &failed {
            println!("ASSERT monotonic FAILED: {f}");
        }
        std::process::exit(1)
    }
}

fn chart<DB: DrawingBackend>(
    area: DrawingArea<DB, plotters::coord::Shift>,
    name: &str,
    curves: &[Curve],
    sets: &[&Vec<usize>; 4],
) -> Result<(), Box<dyn std::error::Error>>
where
    DB::ErrorType: 'static,
{
    area.fill(&WHITE)?;
    let finite = |v: f64| v.is_finite() && v > 0.0;
    let all: Vec<(f64, f64)> = curves
        .iter()
        .flat_map(|c| {
            c.points
                .iter()
                .flat_map(|p| p.1.iter().map(move |e| (p.0, *e)))
        })
        .filter(|p| finite(p.0) && finite(p.1))
        .collect();
    let (tmin, tmax) = all
        .iter()
        .fold((f64::MAX, 0.0f64), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let (emin, emax) = all
        .iter()
        .fold((f64::MAX, 0.0f64), |(a, b), p| (a.min(p.1), b.max(p.1)));
    let mut chart = ChartBuilder::on(&area)
        .caption(format!("{name}: error against time"), ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(65)
        .build_cartesian_2d(
            (tmin * 0.8..tmax * 1.25).log_scale(),
            (emin * 0.8..emax * 1.25).log_scale(),
        )?;
    chart
        .configure_mesh()
        .x_desc("seconds, log scale")
        .y_desc("relRMSE, log scale")
        .x_label_formatter(&|v| format!("{v:.2}"))
        .y_label_formatter(&|v| format!("{v:.3}"))
        .label_style(("sans-serif", 14))
        .draw()?;
    for (ci, curve) in curves.iter().enumerate() {
        for (ri, region) in REGIONS.iter().enumerate() {
            if sets[ri].is_empty() || *region == "contour" {
                continue;
            }
            let color = Palette99::pick(ci).to_rgba();
            let series: Vec<(f64, f64)> = curve
                .points
                .iter()
                .map(|p| (p.0, p.1[ri]))
                .filter(|p| finite(p.0) && finite(p.1))
                .collect();
            let width = if ri == 1 { 3 } else { 1 };
            chart
                .draw_series(LineSeries::new(series.clone(), color.stroke_width(width)))?
                .label(format!("{} - {region}", curve.method))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(width))
                });
            chart.draw_series(series.iter().map(|p| Circle::new(*p, 3, color.filled())))?;
        }
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 12))
        .draw()?;
    area.present()?;
    Ok(())
}
