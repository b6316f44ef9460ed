//! Direct light against analytic values, and bit-identical images on any thread count.

mod common;

use glam::DVec3;
use photondiff::embree::Device;
use photondiff::render::stats::Stats;
use photondiff::render::{render, RenderOptions};
use photondiff::scene::camera::Camera;
use photondiff::scene::file::{load_scene, parse_scene};
use photondiff::scene::Scene;
use std::f64::consts::PI;
use std::path::Path;

fn canonical() -> Scene {
    load_scene(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/caustic-sphere.toml"
    )))
    .unwrap()
}

/// Radiance of the floor at `p` lit by a point light of intensity `i` at `light`, unblocked:
/// `I cos(theta) / d^2 * albedo / pi`.
fn floor_radiance(p: DVec3, light: DVec3, i: f64, albedo: f64) -> f64 {
    let to = light - p;
    let d2 = to.length_squared();
    i * (to.y / d2.sqrt()) / d2 * albedo / PI
}

/// The pixel's box-filtered average of `f` over the floor points it sees, with `n` x `n` samples.
fn pixel_average(camera: &Camera, px: u32, py: u32, n: u32, f: impl Fn(DVec3) -> f64) -> f64 {
    let mut sum = 0.0;
    for j in 0..n {
        for i in 0..n {
            let x = px as f64 + (i as f64 + 0.5) / n as f64;
            let y = py as f64 + (j as f64 + 0.5) / n as f64;
            let ray = camera.ray(x, y, 1.0);
            let t = -ray.p.y / ray.d.y;
            sum += f(ray.p + ray.d * t);
        }
    }
    sum / (n * n) as f64
}

#[test]
fn floor_pixel_seeing_0_0_3_matches_the_analytic_direct_light() {
    let scene = canonical();
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let camera = &scene.camera;
    let (x, y) = camera.project(DVec3::new(0.0, 0.0, 3.0)).unwrap();
    let (px, py) = (x.floor() as u32, y.floor() as u32);
    let light = DVec3::new(-4.0, 4.0, -1.0);
    let expected = pixel_average(camera, px, py, 64, |p| floor_radiance(p, light, 60.0, 0.75));
    for grid in [1, 3] {
        let film = render(
            &scene,
            &embree,
            &[],
            &RenderOptions::default().with_view_grid(grid),
            &mut Stats::default(),
        )
        .unwrap();
        let got = film.pixel(px, py);
        for c in got.to_array() {
            assert!(
                (c - expected).abs() <= 0.01 * expected,
                "view grid {grid}: pixel ({px}, {py}) = {c}, analytic {expected}"
            );
        }
    }
    // And the value is not trivially right: the neighbourhood varies more than the tolerance.
    let far = pixel_average(camera, px, py.saturating_sub(60), 4, |p| {
        floor_radiance(p, light, 60.0, 0.75)
    });
    assert!((far - expected).abs() > 0.05 * expected);
}

const AREA_SCENE: &str = r#"
[camera]
eye = [0.0, 3.0, 6.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov_y = 45.0
width = 64
height = 48

[materials.white]
type = "diffuse"
albedo = [0.5, 0.5, 0.5]

[materials.mirror]
type = "mirror"
reflectance = [0.9, 0.9, 0.9]

[materials.glass]
type = "glass"
ior = 1.5

[[lights]]
type = "quad"
corner = [-0.05, 4.0, -0.05]
edge_u = [0.1, 0.0, 0.0]
edge_v = [0.0, 0.0, 0.1]
radiance = [2000.0, 1000.0, 500.0]

[[lights]]
type = "spot"
position = [2.0, 3.0, 0.0]
direction = [-1.0, -1.5, 0.0]
intensity = [5.0, 5.0, 5.0]
cone_angle = 25.0
falloff_start = 15.0

[[shapes]]
type = "quad"
corner = [-5.0, 0.0, 5.0]
edge_u = [10.0, 0.0, 0.0]
edge_v = [0.0, 0.0, -10.0]
material = "white"

[[shapes]]
type = "sphere"
center = [-1.5, 0.7, 0.0]
radius = 0.7
material = "mirror"
segments = 64

[[shapes]]
type = "sphere"
center = [1.5, 0.7, 0.5]
radius = 0.7
material = "glass"
segments = 64
"#;

#[test]
fn small_quad_light_matches_its_point_light_limit() {
    // A 0.1 x 0.1 light at height 4 facing down acts, to well under 1%, as a point light of
    // intensity L A cos(theta_light): E = L A cos_l cos_x / d^2.
    let scene = parse_scene(AREA_SCENE, Path::new(".")).unwrap();
    let scene = Scene {
        lights: scene.lights[..1].to_vec(),
        ..scene
    };
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let film = render(
        &scene,
        &embree,
        &[],
        &RenderOptions::default().with_view_grid(2),
        &mut Stats::default(),
    )
    .unwrap();
    let light = DVec3::new(0.0, 4.0, 0.0);
    let p = DVec3::new(0.3, 0.0, 2.0);
    let (x, y) = scene.camera.project(p).unwrap();
    let (px, py) = (x as u32, y as u32);
    let expected = pixel_average(&scene.camera, px, py, 32, |q| {
        let to = light - q;
        let d2 = to.length_squared();
        let cos = to.y / d2.sqrt();
        0.01 * cos * cos / d2 * 0.5 / PI
    });
    let got = film.pixel(px, py);
    for (c, l) in got.to_array().iter().zip([2000.0, 1000.0, 500.0]) {
        assert!(
            (c - l * expected).abs() < 0.01 * l * expected,
            "{c} vs {}",
            l * expected
        );
    }
}

#[test]
fn images_are_bit_identical_whatever_the_thread_count() {
    let scene = parse_scene(AREA_SCENE, Path::new(".")).unwrap();
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let options = RenderOptions::default().with_view_grid(2).with_seed(42);
    let mut stats = Stats::default();
    let one = render(
        &scene,
        &embree,
        &[],
        &options.clone().with_threads(1),
        &mut stats,
    )
    .unwrap();
    let two = render(
        &scene,
        &embree,
        &[],
        &options.clone().with_threads(2),
        &mut Stats::default(),
    )
    .unwrap();
    assert!(one == two, "images differ between 1 and 2 threads");
    // The scene exercises every path: shadow rays, specular rays, and a non-black image.
    assert!(stats.rays.specular > 0 && stats.rays.shadow > 0);
    assert!(one
        .pixels
        .iter()
        .all(|p| p.is_finite() && p.min_element() >= 0.0));
    let lit = one.pixels.iter().filter(|p| p.max_element() > 0.0).count();
    assert!(lit > one.pixels.len() / 2, "only {lit} pixels lit");
    // Another seed moves the area-light samples.
    let other = render(
        &scene,
        &embree,
        &[],
        &options.with_seed(7),
        &mut Stats::default(),
    )
    .unwrap();
    assert!(one != other, "the seed changes nothing");
}

/// Pixels across the edge of the sphere's shadow on the floor of the canonical scene: their
/// direct light is the lit fraction of their footprint times the falloff. One shadow ray per
/// pixel calls each pixel lit or dark; `N x N` footprint shadow rays sample the fraction.
#[test]
fn footprint_shadow_rays_sample_a_shadow_edge_within_the_pixel() {
    use photondiff::embree::Ray;
    let scene = canonical();
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let camera = &scene.camera;
    let light = DVec3::new(-4.0, 4.0, -1.0);
    let lit = |p: DVec3| {
        let from = p + DVec3::Y * 1e-4;
        let to = light - from;
        let d = to.length();
        !embree.occluded(&Ray::segment(from, to / d, d))
    };
    // Rays through the pixel that all meet the floor before anything else.
    let sees_floor_only = |px: u32, py: u32| {
        [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0), (0.5, 0.5)]
            .iter()
            .all(|&(a, b)| {
                let r = camera.ray(px as f64 + a, py as f64 + b, 1.0);
                embree
                    .intersect(&Ray::new(r.p, r.d))
                    .is_some_and(|h| h.geom_id == 0)
            })
    };
    // The row through the shadow's centre (the sphere's centre projected from the light).
    let (_, y) = camera
        .project(DVec3::new(4.0 / 3.0, 0.0, 1.0 / 3.0))
        .unwrap();
    let py = y.floor() as u32;
    let mut edge = Vec::new();
    for px in 0..camera.width {
        if !sees_floor_only(px, py) {
            continue;
        }
        let fraction = pixel_average(camera, px, py, 4, |p| f64::from(u8::from(lit(p))));
        if fraction > 0.1 && fraction < 0.9 {
            let expected = pixel_average(camera, px, py, 48, |p| {
                floor_radiance(p, light, 60.0, 0.75) * f64::from(u8::from(lit(p)))
            });
            let unblocked =
                pixel_average(camera, px, py, 8, |p| floor_radiance(p, light, 60.0, 0.75));
            edge.push((px, expected, unblocked));
        }
    }
    assert!(edge.len() >= 2, "the row crosses the shadow's edge twice");
    let worst = |strata: u32| {
        let film = render(
            &scene,
            &embree,
            &[],
            &RenderOptions::default().with_footprint_strata(strata),
            &mut Stats::default(),
        )
        .unwrap();
        edge.iter()
            .map(|&(px, expected, unblocked)| (film.pixel(px, py).x - expected).abs() / unblocked)
            .fold(0.0, f64::max)
    };
    // 8 x 8 points on a straight edge miss at most a strip of about one point's cell.
    let (one, eight) = (worst(1), worst(8));
    assert!(
        eight <= 0.08,
        "8 x 8 footprint shadow rays: worst error {eight}"
    );
    assert!(one >= 0.2, "one shadow ray: worst error only {one}");
}

/// Near a light that grazes the floor (the grazing-light stress scene: 2 degrees above it) the
/// falloff changes by 10-15% from one pixel to the next. Every pass's footprint shadow rays
/// sit at that pass's jitter within their sub-cells, mirrored in the far half, so each pass
/// (not only the centred pass 0) averages the pixel to second order: a plain shifted 2 x 2
/// grid put pass 1 about 10% over the pixel's mean there.
#[test]
fn every_passs_footprint_shadow_rays_average_a_steep_falloff_to_second_order() {
    use photondiff::render::passes::jitter;
    let scene = load_scene(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/stress/grazing-light.toml"
    )))
    .unwrap();
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let camera = &scene.camera;
    let light = DVec3::new(-5.99634, 0.20940, 0.0);
    // Pixels at the image's left edge, where it sees the floor just beside the light.
    let pixels: Vec<(u32, u32, f64)> = [(0, 46), (0, 47), (1, 47), (0, 48)]
        .iter()
        .map(|&(px, py)| {
            let expected = pixel_average(camera, px, py, 64, |p| {
                floor_radiance(p, light, 600.0, 0.75)
            });
            (px, py, expected)
        })
        .collect();
    // The falloff is steep there: neighbouring pixels differ by more than 10%.
    let (left, right) = (pixels[1].2, pixels[2].2);
    assert!(left / right > 1.1, "{left} {right}");
    let mut worst = 0.0f64;
    for pass in 0..8 {
        let film = render(
            &scene,
            &embree,
            &[],
            &RenderOptions::default()
                .with_footprint_strata(2)
                .with_jitter(jitter(pass)),
            &mut Stats::default(),
        )
        .unwrap();
        for &(px, py, expected) in &pixels {
            worst = worst.max((film.pixel(px, py).x / expected - 1.0).abs());
        }
    }
    assert!(worst <= 0.01, "worst pass's error {worst}");
}

/// A small quad light facing down just above the floor beside the grazing-light scene's left
/// edge, where its light falls off as `d^-4`: every pass's direct light, its strata taking
/// turns over the footprint's symmetric points, averages the pixel to second order. From the
/// hit alone (as quad lights were lit until stop 50, and as one footprint point still does),
/// a pass's jitter moved the whole pixel's light off its centre (a floor under a quad light:
/// 2 passes read relRMSE 0.022 against the reference, 1 pass 0.006).
#[test]
fn every_passs_area_light_samples_average_a_steep_falloff_to_second_order() {
    use photondiff::render::passes::jitter;
    use photondiff::scene::Light;
    let mut scene = load_scene(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/stress/grazing-light.toml"
    )))
    .unwrap();
    let (h, side, radiance) = (0.2094, 0.08, 100.0);
    let corner = DVec3::new(-5.99634 - side / 2.0, h, -side / 2.0);
    scene.lights = vec![Light::Quad {
        corner,
        edge_u: DVec3::new(side, 0.0, 0.0),
        edge_v: DVec3::new(0.0, 0.0, side), // edge_u x edge_v = -y: facing the floor
        radiance: DVec3::splat(radiance),
    }];
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let camera = &scene.camera;
    // The quad as 16 x 16 point lights of intensity L dA cos towards the floor point.
    let radiance_at = |p: DVec3| {
        let n = 16;
        let da = side * side / (n * n) as f64;
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                let y = corner
                    + DVec3::new(
                        (i as f64 + 0.5) / n as f64 * side,
                        0.0,
                        (j as f64 + 0.5) / n as f64 * side,
                    );
                let to = y - p;
                let d2 = to.length_squared();
                let cos = to.y / d2.sqrt(); // at the floor and at the light alike
                sum += radiance * da * cos * cos / d2;
            }
        }
        sum * 0.75 / PI
    };
    let pixels: Vec<(u32, u32, f64)> = [(0, 46), (0, 47), (1, 47), (0, 48)]
        .iter()
        .map(|&(px, py)| (px, py, pixel_average(camera, px, py, 48, radiance_at)))
        .collect();
    let (left, right) = (pixels[1].2, pixels[2].2);
    assert!(left / right > 1.1, "steep: {left} {right}");
    let worst = |strata: u32| {
        let mut worst = 0.0f64;
        for pass in 0..8 {
            let options = RenderOptions::default()
                .with_footprint_strata(strata)
                .with_area_strata(8)
                .with_jitter(jitter(pass));
            let film = render(&scene, &embree, &[], &options, &mut Stats::default()).unwrap();
            for &(px, py, expected) in &pixels {
                worst = worst.max((film.pixel(px, py).x / expected - 1.0).abs());
            }
        }
        worst
    };
    // Measured: 0.7% over the footprint's 2 x 2 points, 16% from the hit alone (8 x 8 samples
    // on the light keep their own noise under 1%; with the default 4 x 4, 1.5%).
    let (spread, alone) = (worst(2), worst(1));
    assert!(spread <= 0.01, "worst pass's error {spread}");
    assert!(alone > 0.03, "the hit alone: {alone}");
}

/// The ray offset does not grow with the scene past its objects: under a floor 10^5 across
/// (offset 2e-5 of the extent, 2.8, before), the glass sphere of radius 1 vanished with its
/// shadow. The same view over the canonical 12 x 12 floor must agree wherever that floor is
/// seen (beyond it, the huge floor goes on where the small one ends).
#[test]
fn a_small_object_keeps_its_shadow_under_a_huge_floor() {
    let dir = tempfile::tempdir().unwrap();
    let render = |half: f64, name: &str| {
        let text = include_str!("../scenes/caustic-sphere.toml")
            .replace("width = 640", "width = 64")
            .replace("height = 480", "height = 48")
            .replace(
                "corner = [-6.0, 0.0, 6.0]",
                &format!("corner = [{}, 0.0, {half}]", -half),
            )
            .replace(
                "edge_u = [12.0, 0.0, 0.0]",
                &format!("edge_u = [{}, 0.0, 0.0]", 2.0 * half),
            )
            .replace(
                "edge_v = [0.0, 0.0, -12.0]",
                &format!("edge_v = [0.0, 0.0, {}]", -2.0 * half),
            );
        let scene = dir.path().join(format!("{name}.toml"));
        std::fs::write(&scene, text).unwrap();
        let args = ["--estimator", "direct", "-q"];
        common::render_file(&scene, &dir.path().join(name), &args).1
    };
    let (small, huge) = (render(6.0, "small"), render(5e4, "huge"));
    // Where the small floor is seen (beyond it the huge one goes on): the same light to within
    // 2% (shadow rays start the offset, 0.025 here, above the floor, and their light falls off
    // from there: about 1% at this light's distance), but at a few pixels on the sphere's
    // silhouette, whose grazing chords through the glass are shorter than that offset.
    let seen: Vec<_> = small
        .iter()
        .zip(&huge)
        .filter(|(a, _)| a.max_element() > 0.0)
        .collect();
    let differ = seen
        .iter()
        .filter(|(a, b)| (**a - **b).abs().max_element() > 2e-2 * a.max_element())
        .count();
    // The sphere's shadow is there in both (it was gone from the huge floor).
    let shadow = seen
        .iter()
        .filter(|(a, b)| a.max_element() < 0.02 && b.max_element() < 0.02)
        .count();
    assert!(
        seen.len() > 1000 && shadow >= 10,
        "{} seen, {shadow} in shadow",
        seen.len()
    );
    assert!(
        differ * 100 < seen.len(),
        "{differ} of {} differ",
        seen.len()
    );
}

/// Inside a closed diffuse sphere every footprint point in the hit's tangent plane lies
/// outside the sphere, where the sphere itself blocks its shadow ray: the default 2 x 2
/// footprint rays read 0.72 of the light at 120 x 90 and 0.17 at 40 x 30 (worst pixel 0.37).
/// A blocked point behind the surface now takes its light sample from the hit: point and quad
/// lights alike, each pass's jitter, within 1% of one ray from the hit over the image.
#[test]
fn footprint_shadow_rays_inside_a_concave_surface_are_not_blocked_by_it() {
    use photondiff::render::passes::jitter;
    let lights = [
        "type = \"point\"\nposition = [0.3, 0.2, -0.1]\nintensity = [10.0, 10.0, 10.0]",
        "type = \"quad\"\ncorner = [-0.2, 0.7, -0.2]\nedge_u = [0.4, 0.0, 0.0]\n\
         edge_v = [0.0, 0.0, 0.4]\nradiance = [20.0, 20.0, 20.0]",
    ];
    for light in lights {
        let text = format!(
            "[camera]\neye = [0.0, -0.2, 0.5]\nlook_at = [0.0, 0.0, -1.0]\nup = [0.0, 1.0, 0.0]\n\
             fov_y = 70.0\nwidth = 40\nheight = 30\n[materials.w]\ntype = \"diffuse\"\n\
             albedo = [0.5, 0.5, 0.5]\n[[lights]]\n{light}\n[[shapes]]\ntype = \"sphere\"\n\
             center = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"w\"\nsegments = 256\n"
        );
        let scene = parse_scene(&text, Path::new(".")).unwrap();
        let device = Device::new().unwrap();
        let embree = scene.build_embree(&device).unwrap();
        let image = |strata: u32, pass: u64| {
            let options = RenderOptions::default()
                .with_footprint_strata(strata)
                .with_area_strata(4)
                .with_jitter(jitter(pass));
            render(&scene, &embree, &[], &options, &mut Stats::default()).unwrap()
        };
        for pass in 0..2 {
            let (one, four) = (image(1, pass), image(2, pass));
            let sum =
                |f: &photondiff::render::film::Film| -> f64 { f.pixels.iter().map(|p| p.x).sum() };
            let ratio = sum(&four) / sum(&one);
            assert!((ratio - 1.0).abs() < 0.01, "{light}: pass {pass}: {ratio}");
        }
    }
}
