//! Ray throughput on the canonical scene: camera rays (single and 16-wide) and shadow rays,
//! through photondiff's safe layer beside Embree's raw calls on the same rays, measured
//! alternately in one run (median of several repetitions) and reported as ratios.
//!
//! Run: `cargo bench --bench rays`

use glam::DVec3;
use photondiff::embree::{Device, RawRays, Ray, Scene};
use photondiff::scene::file::load_scene;
use std::path::Path;
use std::time::Instant;

const REPEATS: usize = 7;

/// A named measurement: runs the queries once, returns a checksum.
type Case<'a> = (&'static str, Box<dyn FnMut() -> usize + 'a>);

/// Camera rays of the whole image, one per pixel, in 4 x 4 pixel blocks (coherent packets).
fn camera_rays(scene: &photondiff::scene::Scene) -> Vec<Ray> {
    let c = &scene.camera;
    let mut rays = Vec::new();
    for by in (0..c.height).step_by(4) {
        for bx in (0..c.width).step_by(4) {
            for y in by..(by + 4).min(c.height) {
                for x in bx..(bx + 4).min(c.width) {
                    let r = c.ray(x as f64 + 0.5, y as f64 + 0.5, 1.0);
                    rays.push(Ray::new(r.p, r.d));
                }
            }
        }
    }
    rays
}

/// Shadow rays from every camera hit towards the point light, in the same order.
fn shadow_rays(embree: &Scene, camera: &[Ray], light: DVec3) -> Vec<Ray> {
    camera
        .iter()
        .filter_map(|r| embree.intersect(r))
        .map(|hit| {
            let origin = hit.position + hit.geometric_normal * 3e-4;
            let to = light - origin;
            Ray::segment(origin, to.normalize(), to.length())
        })
        .collect()
}

/// Median seconds of `f` over the repetitions, with every measurement interleaved with the
/// others (`fs` run round-robin) so that machine noise hits all alike.
fn measure(fs: &mut [Case<'_>]) -> Vec<f64> {
    let mut times = vec![Vec::new(); fs.len()];
    let mut checksum = 0;
    for _ in 0..REPEATS {
        for (k, (_, f)) in fs.iter_mut().enumerate() {
            let start = Instant::now();
            checksum += f();
            times[k].push(start.elapsed().as_secs_f64());
        }
    }
    std::hint::black_box(checksum);
    times
        .into_iter()
        .map(|mut t| {
            t.sort_by(f64::total_cmp);
            t[t.len() / 2]
        })
        .collect()
}

fn report(title: &str, n: usize, names: &[&str], times: &[f64], pairs: &[(usize, usize, &str)]) {
    println!("\n## {title} ({n} rays, one thread, median of {REPEATS})\n");
    println!("| query | M rays/s |");
    println!("|---|---|");
    for (name, t) in names.iter().zip(times) {
        println!("| {name} | {:.2} |", n as f64 / t / 1e6);
    }
    println!();
    for &(a, b, what) in pairs {
        println!("- {what}: {:.2}", times[b] / times[a]);
    }
}

fn main() {
    let path = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/caustic-sphere.toml"
    ));
    let scene = load_scene(path).expect("canonical scene");
    let device = Device::new().expect("Embree device");
    let embree = scene.build_embree(&device).expect("Embree scene");
    let light = match scene.lights[0] {
        photondiff::scene::Light::Point { position, .. } => position,
        _ => unreachable!("the canonical scene has a point light"),
    };

    let camera = camera_rays(&scene);
    let raw_camera = RawRays::new(&camera);
    let mut hits = vec![None; 16];
    let mut fs: Vec<Case> = vec![
        (
            "Embree rtcIntersect1 (raw)",
            Box::new(|| embree.raw_intersect1(&raw_camera)),
        ),
        (
            "photondiff intersect (single)",
            Box::new(|| {
                camera
                    .iter()
                    .filter(|r| embree.intersect(r).is_some())
                    .count()
            }),
        ),
        (
            "Embree rtcIntersect16 (raw, coherent)",
            Box::new(|| embree.raw_intersect16(&raw_camera, true)),
        ),
        (
            "photondiff intersect16 (coherent)",
            Box::new(|| {
                let mut n = 0;
                for chunk in camera.chunks(16) {
                    embree.intersect16(chunk, true, &mut hits);
                    n += hits[..chunk.len()].iter().filter(|h| h.is_some()).count();
                }
                n
            }),
        ),
    ];
    let names: Vec<&str> = fs.iter().map(|f| f.0).collect();
    let times = measure(&mut fs);
    drop(fs);
    report(
        "Camera rays, canonical scene, 640 x 480",
        camera.len(),
        &names,
        &times,
        &[
            (
                1,
                0,
                "photondiff single / Embree raw single (throughput ratio)",
            ),
            (3, 2, "photondiff 16-wide / Embree raw 16-wide"),
            (2, 0, "Embree raw: 16-wide / single"),
            (3, 1, "photondiff: 16-wide / single"),
        ],
    );

    let shadow = shadow_rays(&embree, &camera, light);
    let raw_shadow = RawRays::new(&shadow);
    let mut blocked = vec![false; 16];
    let mut fs: Vec<Case> = vec![
        (
            "Embree rtcOccluded1 (raw)",
            Box::new(|| embree.raw_occluded1(&raw_shadow)),
        ),
        (
            "photondiff occluded (single)",
            Box::new(|| shadow.iter().filter(|r| embree.occluded(r)).count()),
        ),
        (
            "Embree rtcOccluded16 (raw, coherent)",
            Box::new(|| embree.raw_occluded16(&raw_shadow, true)),
        ),
        (
            "photondiff occluded16 (coherent)",
            Box::new(|| {
                let mut n = 0;
                for chunk in shadow.chunks(16) {
                    embree.occluded16(chunk, true, &mut blocked);
                    n += blocked[..chunk.len()].iter().filter(|b| **b).count();
                }
                n
            }),
        ),
    ];
    let names: Vec<&str> = fs.iter().map(|f| f.0).collect();
    let times = measure(&mut fs);
    drop(fs);
    report(
        "Shadow rays to the point light from every camera hit",
        shadow.len(),
        &names,
        &times,
        &[
            (
                1,
                0,
                "photondiff single / Embree raw single (throughput ratio)",
            ),
            (3, 2, "photondiff 16-wide / Embree raw 16-wide"),
            (2, 0, "Embree raw: 16-wide / single"),
            (3, 1, "photondiff: 16-wide / single"),
        ],
    );
}
