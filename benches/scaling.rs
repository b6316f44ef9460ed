//! Growth exponents: how the stages' times grow with the scene's size, fitted as `t ~ n^k`
//! (least squares on log t against log n), one run, one process, 2 cores.
//!
//! - Against triangles (10^4 to 1.6 x 10^7, a tessellated sphere written as binary PLY): loading
//!   the file, building Embree's BVH (default settings), and tracing 307,200 camera rays (16-wide
//!   coherent packets, a 640 x 480 pinhole view of the sphere).
//! - Against caustic photons (2 x 10^4 to 1.28 x 10^6, the canonical scene): tracing them,
//!   building the photon map over them, and rendering one pass with the default estimator
//!   (`integrated`).
//!
//! Ideal exponents: load and BVH build 1 (n log n reads as ~1.05-1.1), camera rays ~0 (log n
//! traversal), photon tracing 1, map build ~1, render ~0 (what covers a pixel stays near
//! `--overlap` photons whatever their number; a query structure that visits more grows).
//!
//! Run: `cargo bench --bench scaling` (env PHOTONDIFF_SCALING_MAX_TRIANGLES caps the triangle
//! sweep, PHOTONDIFF_SCALING_MAX_PHOTONS the photon sweep).

use glam::DVec3;
use photondiff::embree::{Device, Ray, SceneBuilder};
use photondiff::estimate::{EstimatorKind, EstimatorSettings};
use photondiff::photons::map::PhotonMap;
use photondiff::photons::options::PhotonOptions;
use photondiff::render::stats::Stats;
use photondiff::render::trace_photon_maps;
use photondiff::scene::file::load_scene;
use photondiff::scene::mesh_file::load_mesh;
use photondiff::scene::mesh_file::ply::write::write_binary;
use photondiff::scene::shapes::sphere;
use std::io::BufWriter;
use std::path::Path;
use std::time::Instant;

mod common;
use common::render_in_process;

fn seconds<T>(f: impl FnOnce() -> T) -> (f64, T) {
    let start = Instant::now();
    let out = f();
    (start.elapsed().as_secs_f64(), out)
}

/// The slope of log y against log x.
fn exponent(points: &[(f64, f64)]) -> f64 {
    let logs: Vec<(f64, f64)> = points.iter().map(|(x, y)| (x.ln(), y.ln())).collect();
    let n = logs.len() as f64;
    let (mx, my) = (
        logs.iter().map(|p| p.0).sum::<f64>() / n,
        logs.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxy: f64 = logs.iter().map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = logs.iter().map(|(x, _)| (x - mx) * (x - mx)).sum();
    sxy / sxx
}

fn cap(var: &str, default: f64) -> f64 {
    common::env_or(var, default)
}

/// 640 x 480 camera rays from (0, 0, 4) towards a unit sphere at the origin (40 degrees).
fn camera_rays() -> Vec<Ray> {
    let (w, h) = (640, 480);
    let tan = (20f64).to_radians().tan();
    let mut rays = Vec::with_capacity(w * h);
    // 4 x 4 pixel blocks, so that each packet of 16 is coherent (as the renderer traces them).
    for by in (0..h).step_by(4) {
        for bx in (0..w).step_by(4) {
            for y in by..by + 4 {
                for x in bx..bx + 4 {
                    let px = (2.0 * (x as f64 + 0.5) / w as f64 - 1.0) * tan * w as f64 / h as f64;
                    let py = (1.0 - 2.0 * (y as f64 + 0.5) / h as f64) * tan;
                    rays.push(Ray {
                        origin: DVec3::new(0.0, 0.0, 4.0),
                        direction: DVec3::new(px, py, -1.0).normalize(),
                        tnear: 0.0,
                        tfar: f64::INFINITY,
                    });
                }
            }
        }
    }
    rays
}

fn triangles_sweep() {
    let max = cap("PHOTONDIFF_SCALING_MAX_TRIANGLES", 1.6e7);
    let dir = tempfile::tempdir().unwrap();
    let device = Device::new().unwrap();
    let rays = camera_rays();
    let mut rows = Vec::new();
    println!("\n## Against triangles\n");
    println!("| triangles | load s | BVH build s | camera rays s |");
    println!("|---|---|---|---|");
    // sphere(s) has s^2 - 2s triangles: 9,800 to 15,992,000.
    for segments in [100u32, 200, 400, 800, 1600, 4000] {
        let mesh = sphere(DVec3::ZERO, 1.0, segments);
        let n = mesh.triangles.len() as f64;
        if n > max * 1.05 {
            break;
        }
        let path = dir.path().join("sphere.ply");
        write_binary(&mesh, BufWriter::new(std::fs::File::create(&path).unwrap())).unwrap();
        drop(mesh);
        let (load, mesh) = seconds(|| load_mesh(Path::new(&path)).unwrap());
        let (build, scene) = seconds(|| {
            let mut b = SceneBuilder::new(&device);
            b.add_mesh(mesh).unwrap();
            b.commit().unwrap()
        });
        let mut hits = vec![None; 16];
        let (trace, hit_count) = seconds(|| {
            let mut count = 0;
            for chunk in rays.chunks(16) {
                scene.intersect16(chunk, true, &mut hits);
                count += hits[..chunk.len()].iter().filter(|h| h.is_some()).count();
            }
            count
        });
        assert!(hit_count > 50_000, "the sphere fills part of the view");
        println!("| {n:.0} | {load:.4} | {build:.4} | {trace:.4} |");
        rows.push((n, load, build, trace));
    }
    let fit = |k: usize| {
        exponent(
            &rows
                .iter()
                .map(|r| (r.0, [r.1, r.2, r.3][k]))
                .collect::<Vec<_>>(),
        )
    };
    println!(
        "\nexponents against triangles: load {:.2}, BVH build {:.2}, camera rays {:.2}",
        fit(0),
        fit(1),
        fit(2)
    );
}

fn photons_sweep() {
    let max = cap("PHOTONDIFF_SCALING_MAX_PHOTONS", 1.28e6);
    let path = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/caustic-sphere.toml"
    ));
    let scene = load_scene(path).unwrap();
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let mut rows = Vec::new();
    println!("\n## Against caustic photons (canonical scene, one pass of `integrated`)\n");
    println!("| caustic photons | tracing s | map build s | render s | photons found / used per gather |");
    println!("|---|---|---|---|---|");
    for count in [20_000usize, 80_000, 320_000, 1_280_000] {
        if count as f64 > max * 1.05 {
            break;
        }
        let options = PhotonOptions {
            caustic_photons: count,
            ..PhotonOptions::default()
        };
        let mut stats = Stats::default();
        let maps = trace_photon_maps(&scene, &embree, &options, 0, false, &mut stats).unwrap();
        let traced = stats.seconds("trace photons");
        // The map build alone (the stage above includes it): rebuilt from the same photons.
        let c = &maps.caustic;
        let (build, _) = seconds(|| PhotonMap::new(c.class, c.photons(), c.emitted, c.guards));
        let settings =
            EstimatorSettings::new(EstimatorKind::Integrated, options.limits(&scene).max_radius);
        let render_stats = render_in_process(&scene, &embree, &maps.estimators(&settings));
        let render = render_stats.seconds("render");
        let g = render_stats.gathers;
        println!(
            "| {count} | {:.3} | {build:.3} | {render:.3} | {:.1} / {:.1} |",
            traced - build,
            g.photons_found as f64 / g.gathers.max(1) as f64,
            g.photons_used as f64 / g.gathers.max(1) as f64
        );
        rows.push((count as f64, (traced - build).max(1e-6), build, render));
    }
    let fit = |k: usize| {
        exponent(
            &rows
                .iter()
                .map(|r| (r.0, [r.1, r.2, r.3][k]))
                .collect::<Vec<_>>(),
        )
    };
    println!(
        "\nexponents against caustic photons: tracing {:.2}, map build {:.2}, render {:.2}",
        fit(0),
        fit(1),
        fit(2)
    );
}

fn main() {
    triangles_sweep();
    photons_sweep();
}
