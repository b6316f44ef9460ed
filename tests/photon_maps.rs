//! Photon tracing, photon maps and the photon-differential estimate: kernel normalisation,
//! irradiance against an analytic point light, differentials against finite differences through
//! the glass sphere, path classes, thread independence, and the caustic's energy.

mod common;

use glam::DVec3;
use photondiff::embree::{self, Device};
use photondiff::estimate::{
    photon_kernel, EstimatorKind, GatherCounts, GatherQuery, PhotonDifferentialEstimate,
    RadianceEstimator,
};
use photondiff::geometry::differential::RayDifferential;
use photondiff::geometry::sampling::tangent_frame;
use photondiff::photons::emission::{Emission, Emitter};
use photondiff::photons::footprint::{footprint, FootprintLimits, Guards};
use photondiff::photons::map::{PathClass, Photon, PhotonMap};
use photondiff::photons::options::PhotonOptions;
use photondiff::photons::trace::{PhotonTracer, StopRule, TracedPhoton};
use photondiff::scene::file::{load_scene, parse_scene};
use photondiff::scene::{Material, Scene};
use photondiff::util::rng::Rng;
use std::f64::consts::PI;
use std::path::Path;

fn canonical() -> Scene {
    load_scene(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/caustic-sphere.toml"
    )))
    .unwrap()
}

fn hidden() -> indicatif::ProgressBar {
    indicatif::ProgressBar::hidden()
}

#[test]
fn one_photons_kernel_integrates_to_its_power() {
    let n = DVec3::new(0.3, 1.0, 0.2).normalize();
    let (t1, t2) = tangent_frame(n);
    // A sheared, anisotropic footprint.
    let a = t1 * 0.04 + t2 * 0.01;
    let b = t1 * -0.015 + t2 * 0.02;
    let limits = FootprintLimits {
        min_radius: 1e-6,
        max_radius: 1.0,
        max_anisotropy: 100.0,
    };
    let f = footprint(a, b, n, &limits, 0.01, &mut Guards::default());
    let centre = DVec3::new(1.0, 2.0, 3.0);
    let power = DVec3::new(0.5, 1.0, 2.0);
    let photon = Photon::new(centre, n, -n, power, &f);
    // Midpoint rule over the tangent plane, fine enough for 0.5%.
    let (steps, half) = (600, 0.06);
    let h = 2.0 * half / steps as f64;
    let mut sum = DVec3::ZERO;
    for i in 0..steps {
        for j in 0..steps {
            let s = -half + (i as f64 + 0.5) * h;
            let t = -half + (j as f64 + 0.5) * h;
            let x = centre + t1 * s + t2 * t;
            if let Some(c) = photon_kernel(&photon, (x - centre).as_vec3(), n.as_vec3()) {
                sum += c.as_dvec3() * h * h;
            }
        }
    }
    for (got, want) in sum.to_array().iter().zip(power.to_array()) {
        assert!((got - want).abs() < 0.005 * want, "{got} vs {want}");
    }
}

const PLANE: &str = r#"
[camera]
eye = [0.0, 5.0, 5.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov_y = 40.0
width = 16
height = 16

[materials.white]
type = "diffuse"
albedo = [0.5, 0.5, 0.5]

[[lights]]
type = "point"
position = [0.0, 2.0, 0.0]
intensity = [10.0, 10.0, 10.0]

[[shapes]]
type = "quad"
corner = [-20.0, 0.0, 20.0]
edge_u = [40.0, 0.0, 0.0]
edge_v = [0.0, 0.0, -40.0]
material = "white"
"#;

#[test]
fn photon_differential_irradiance_matches_a_point_light() {
    let scene = parse_scene(PLANE, Path::new(".")).unwrap();
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    // The estimate's noise is set by the number of footprints over a point (the overlap), its
    // blur by the footprints' size: 800,000 photons at overlap 128 give footprints about 0.05
    // across under the light and about 130 of them over each point.
    let options = PhotonOptions {
        global_photons: 800_000,
        overlap: 128.0,
        ..PhotonOptions::default()
    };
    let tracer = PhotonTracer::new(&scene, &embree, &options);
    let emitter = Emitter::global(&scene, options.global_photons, options.overlap, 1);
    let (map, counts) = tracer
        .build_map(
            &emitter,
            PathClass::Direct,
            StopRule::Emitted(800_000),
            &hidden(),
        )
        .unwrap();
    // The plane's share of the sphere of directions: a square of half-side a at distance h
    // subtends 4 asin(a^2 / (a^2 + h^2)). The emissions are drawn from the cone out to its
    // corners (cos = h / sqrt(h^2 + 2 a^2)), the emitter's share of the sphere.
    let fraction = 4.0 * (400.0f64 / 404.0).asin() / (4.0 * PI);
    let cone = (1.0 - 2.0 / 804.0f64.sqrt()) / 2.0;
    assert!((emitter.share() - cone).abs() < 1e-8, "{}", emitter.share());
    let expected = 800_000.0 * fraction / emitter.share();
    assert!(
        (counts.stored as f64 / expected - 1.0).abs() < 0.002,
        "{} vs {expected}",
        counts.stored
    );
    let estimate = PhotonDifferentialEstimate { map: &map };
    let mut gathers = GatherCounts::default();
    let mut worst: f64 = 0.0;
    for i in 0..9 {
        for j in 0..9 {
            let x = DVec3::new(-2.0 + 0.5 * i as f64, 0.0, -2.0 + 0.5 * j as f64);
            let d2 = x.length_squared() + 4.0;
            let analytic = 10.0 * (2.0 / d2.sqrt()) / d2;
            // Albedo pi turns the reflected radiance (albedo / pi) E into the irradiance E.
            let query = GatherQuery {
                position: x,
                normal: DVec3::Y,
                albedo: DVec3::splat(PI),
                footprint: [DVec3::ZERO; 2],
                exact: None,
            };
            let e = estimate.radiance(&query, &mut gathers);
            eprintln!("{x:?} {:.4}", e.x / analytic - 1.0);
            for c in e.to_array() {
                worst = worst.max((c / analytic - 1.0).abs());
            }
        }
    }
    assert!(worst < 0.03, "worst relative error {worst}");
    assert!(gathers.photons_used > 81 * 10);
}

/// A point-light emission along `normalize(d0 + u c + v e)`, with its exact direction differentials.
fn emission(origin: DVec3, d0: DVec3, c: DVec3, e: DVec3, u: f64, v: f64) -> Emission {
    let d = d0 + c * u + e * v;
    let len = d.length();
    let unit = d / len;
    let dd = |w: DVec3| (w - unit * unit.dot(w)) / len;
    let mut ray = RayDifferential::new(origin, unit);
    ray.dd = [dd(c), dd(e)];
    Emission {
        ray,
        power: DVec3::ONE,
    }
}

fn trace_caustic(tracer: &PhotonTracer, e: Emission, seed: u64) -> Option<TracedPhoton> {
    let mut out = Vec::new();
    tracer.trace(e, PathClass::Caustic, &mut Rng::new(seed, 0), &mut out);
    out.first().copied()
}

#[test]
fn refracted_photon_differentials_match_finite_differences_of_neighbours() {
    let scene = canonical();
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let options = PhotonOptions::default();
    let tracer = PhotonTracer::new(&scene, &embree, &options);
    let light = DVec3::new(-4.0, 4.0, -1.0);
    let axis = (DVec3::new(0.0, 1.0, 0.0) - light).normalize();
    let (t1, t2) = tangent_frame(axis);
    let (c, e) = (t1 * 0.01, t2 * 0.01);
    let h = 1e-5;
    let mut checked = 0;
    for (k, offset) in [
        (0.05, 0.02),
        (-0.08, 0.06),
        (0.1, -0.1),
        (0.0, 0.13),
        (-0.12, -0.04),
    ]
    .into_iter()
    .enumerate()
    {
        let d0 = axis + t1 * offset.0 + t2 * offset.1;
        // The same random stream for the photon and its neighbours: the same Fresnel choices.
        for seed in 0..8u64 {
            let seed = seed + 100 * k as u64;
            let Some(centre) = trace_caustic(&tracer, emission(light, d0, c, e, 0.0, 0.0), seed)
            else {
                continue;
            };
            // Straight through the glass (in, out), onto the floor.
            if centre.specular_bounces != 2 {
                continue;
            }
            for (du, dv, axis_k) in [(h, 0.0, 0), (0.0, h, 1)] {
                let plus = trace_caustic(&tracer, emission(light, d0, c, e, du, dv), seed).unwrap();
                let minus =
                    trace_caustic(&tracer, emission(light, d0, c, e, -du, -dv), seed).unwrap();
                assert_eq!(plus.specular_bounces, 2);
                assert_eq!(minus.specular_bounces, 2);
                let fd = (plus.ray.p - minus.ray.p) / (2.0 * h);
                let dp = centre.ray.dp[axis_k];
                assert!(
                    (fd - dp).length() < 1e-3 * fd.length(),
                    "direction {k}: differential {dp:?}, finite difference {fd:?}"
                );
            }
            checked += 1;
            break;
        }
    }
    assert!(checked >= 4, "only {checked} photons went straight through");
}

fn caustic_map(scene: &Scene, embree: &embree::Scene, threads: usize, photons: usize) -> PhotonMap {
    let options = PhotonOptions {
        caustic_photons: photons,
        ..PhotonOptions::default()
    };
    let tracer = PhotonTracer::new(scene, embree, &options);
    let emitter = Emitter::caustic(scene, photons, options.overlap, options.seed);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        tracer
            .build_map(
                &emitter,
                PathClass::Caustic,
                StopRule::Stored(photons),
                &hidden(),
            )
            .unwrap()
            .0
    })
}

#[test]
fn caustic_map_holds_only_specular_then_diffuse_paths_and_ignores_threads() {
    let scene = canonical();
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let one = caustic_map(&scene, &embree, 1, 3000);
    let two = caustic_map(&scene, &embree, 2, 3000);
    assert_eq!(one.len(), 3000);
    assert!(
        one.photons() == two.photons(),
        "maps differ between 1 and 2 threads"
    );
    assert_eq!(one.emitted, two.emitted);
    // Refracted light lands in the sphere's shadow, which direct light cannot reach; only
    // light reflected off the outside (a few percent: Fresnel at grazing angles) lands elsewhere.
    let light = DVec3::new(-4.0, 4.0, -1.0);
    let in_shadow = one
        .photons()
        .iter()
        .filter(|p| {
            let x = p.position.as_dvec3();
            let d = (x - light).normalize();
            let oc = light - DVec3::new(0.0, 1.0, 0.0);
            let b = oc.dot(d);
            b * b - (oc.length_squared() - 1.0) > 0.0
        })
        .count();
    assert!(
        in_shadow as f64 > 0.85 * one.len() as f64,
        "{in_shadow} of {}",
        one.len()
    );
    // The tracer's classes: caustic photons have one or more specular bounces and no diffuse one.
    let options = PhotonOptions::default();
    let tracer = PhotonTracer::new(&scene, &embree, &options);
    let emitter = Emitter::caustic(&scene, 1000, options.overlap, 0);
    for i in 0..1000 {
        let mut rng = Rng::new(5, i);
        let mut out = Vec::new();
        if let Some(e) = emitter.emit(i, &mut rng) {
            tracer.trace(e, PathClass::Caustic, &mut rng, &mut out);
        }
        for t in out {
            assert!(t.specular_bounces >= 1 && t.diffuse_bounces == 0, "{t:?}");
        }
    }
    // With a diffuse sphere there is no caustic at all.
    let mut matte = scene.clone();
    matte.meshes[1].material = Material::Diffuse {
        albedo: DVec3::splat(0.5),
    };
    let matte_embree = matte.build_embree(&device).unwrap();
    assert!(caustic_map(&matte, &matte_embree, 2, 100).is_empty());
}

/// The power reaching the floor quad of the canonical scene through the exact glass sphere,
/// following every specular branch with its Fresnel weight, for unit intensity along `d`.
fn transmitted_fraction(origin: DVec3, d: DVec3, inside: bool, depth: u32) -> f64 {
    const C: DVec3 = DVec3::new(0.0, 1.0, 0.0);
    if depth > 16 {
        return 0.0;
    }
    let oc = origin - C;
    let b = oc.dot(d);
    let disc = b * b - (oc.length_squared() - 1.0);
    let t_sphere = if disc > 0.0 {
        [-b - disc.sqrt(), -b + disc.sqrt()]
            .into_iter()
            .find(|&t| t > 1e-9)
    } else {
        None
    };
    let t_floor = (d.y < 0.0).then(|| -origin.y / d.y).filter(|&t| t > 1e-9);
    match (t_sphere, t_floor) {
        (Some(ts), tf) if tf.is_none_or(|tf| ts < tf) => {
            let p = origin + d * ts;
            let n_out = p - C;
            let n = if inside { -n_out } else { n_out };
            let cos_i = -d.dot(n);
            let (n1, n2) = if inside { (1.5, 1.0) } else { (1.0, 1.5) };
            let f = photondiff::geometry::differential::fresnel_dielectric(cos_i, n1, n2);
            let r = d - n * (2.0 * d.dot(n));
            let mut total = f * transmitted_fraction(p, r, inside, depth + 1);
            if f < 1.0 {
                let eta = n1 / n2;
                let k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
                let t = (d * eta + n * (eta * cos_i - k.sqrt())).normalize();
                total += (1.0 - f) * transmitted_fraction(p, t, !inside, depth + 1);
            }
            total
        }
        (_, Some(tf)) if depth > 0 => {
            let p = origin + d * tf;
            f64::from(u8::from(p.x.abs() <= 6.0 && p.z.abs() <= 6.0))
        }
        _ => 0.0,
    }
}

/// The power the light at `light`, of intensity `intensity(d)` along `d`, sends to the floor
/// through the canonical scene's sphere: a midpoint rule over the cone of directions to the
/// sphere, uniform in solid angle (`n` x `n` cells).
fn caustic_power(light: DVec3, intensity: impl Fn(DVec3) -> f64, n: usize) -> f64 {
    let to = DVec3::new(0.0, 1.0, 0.0) - light;
    let cos_max = (1.0 - 1.0 / to.length_squared()).sqrt();
    let axis = to.normalize();
    let (t1, t2) = tangent_frame(axis);
    let mut sum = 0.0;
    for i in 0..n {
        for j in 0..n {
            let cos = 1.0 - (i as f64 + 0.5) / n as f64 * (1.0 - cos_max);
            let sin = (1.0 - cos * cos).sqrt();
            let phi = 2.0 * PI * (j as f64 + 0.5) / n as f64;
            let d = axis * cos + t1 * (sin * phi.cos()) + t2 * (sin * phi.sin());
            let i = intensity(d);
            if i > 0.0 {
                sum += i * transmitted_fraction(light, d, false, 0);
            }
        }
    }
    2.0 * PI * (1.0 - cos_max) * sum / (n * n) as f64
}

#[test]
fn caustic_map_power_matches_an_independent_integration() {
    let scene = canonical();
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let map = caustic_map(&scene, &embree, 2, 20_000);
    let stored = map.total_power().x;
    let expected = caustic_power(DVec3::new(-4.0, 4.0, -1.0), |_| 60.0, 500);
    assert!(
        (stored / expected - 1.0).abs() < 0.02,
        "caustic map {stored} W, independent integration {expected} W"
    );
}

/// Spot lights on the canonical sphere: one whose cone holds only the sphere's rim (the
/// sphere's centre lies outside it: the photons were shared out by the intensity towards the
/// centre, 0, and the caustic was left out without a word), one narrower than the sphere (its
/// photons were drawn over the sphere's cone and most carried nothing) and one wider. Each
/// caustic map holds the power the spot sends through the sphere, and photons of no power are
/// not stored.
#[test]
fn a_spots_caustic_holds_what_its_cone_sends_through_the_sphere() {
    let position = DVec3::new(-4.0, 4.0, -1.0);
    let centre = (DVec3::new(0.0, 1.0, 0.0) - position).normalize();
    // The sphere's cone is 11.3 degrees wide (half-angle); axes tilted about the vertical plane.
    let side = centre.cross(DVec3::Y).normalize();
    let tilted = |deg: f64| {
        let a = deg.to_radians();
        centre * a.cos() + centre.cross(side) * a.sin()
    };
    for (tilt, cone, falloff) in [
        (8.0f64, 5.0f64, 3.0f64),
        (14.0, 5.0, 4.0),
        (0.0, 5.0, 2.0),
        (2.0, 30.0, 10.0),
    ] {
        let mut scene = canonical();
        let (cos_cone, cos_falloff_start) =
            (f64::cos(cone.to_radians()), f64::cos(falloff.to_radians()));
        let spot = photondiff::scene::Light::Spot {
            position,
            direction: tilted(tilt),
            intensity: DVec3::splat(60.0),
            cos_cone,
            cos_falloff_start,
        };
        scene.lights = vec![spot];
        let device = Device::new().unwrap();
        let embree = scene.build_embree(&device).unwrap();
        let map = caustic_map(&scene, &embree, 2, 20_000);
        let stored = map.total_power().x;
        let expected = caustic_power(position, |d| spot.intensity_towards(d).x, 600);
        assert!(expected > 0.01, "{expected}");
        assert!(
            (stored / expected - 1.0).abs() < 0.02,
            "tilt {tilt}, cone {cone}: caustic map {stored} W, independent integration {expected} W"
        );
        assert_eq!(map.len(), 20_000);
        assert!(
            map.photons().iter().all(|p| p.power.x > 0.0),
            "tilt {tilt}, cone {cone}: photons of no power stored"
        );
    }
}

/// A quad light facing away from every specular object aims no caustic photon (each was drawn,
/// refused and counted up to the emission cap: 20 million emissions, 6.6 s, for nothing);
/// turned over, it aims at the sphere.
#[test]
fn a_quad_light_facing_away_aims_no_caustic_photons() {
    let mut scene = canonical();
    let quad = |edge_v: DVec3| photondiff::scene::Light::Quad {
        corner: DVec3::new(-0.5, 3.0, 0.5),
        edge_u: DVec3::X,
        edge_v,
        radiance: DVec3::splat(20.0),
    };
    scene.lights = vec![quad(DVec3::NEG_Z)]; // edge_u x edge_v = +y: away from the sphere
    assert!(Emitter::caustic(&scene, 1000, 32.0, 0).is_empty());
    scene.lights = vec![quad(DVec3::Z)];
    assert!(!Emitter::caustic(&scene, 1000, 32.0, 0).is_empty());
}

/// A small quad light's caustic photons leave it in beams as wide as a point light's at its
/// place: each emission stands for a share of the light's directions as well as of its area.
/// With the area's share alone (parallel beams a few millimetres across), the sphere focused
/// them to footprints a hundredth of the point light's, and the photon-differential estimates
/// of a quad light's caustic were fireflies (a tilted 0.4 m quad's floor relRMSE 5.9 against
/// 2.3 now, `pd`, 160 x 120).
#[test]
fn a_small_quad_lights_caustic_footprints_are_a_point_lights() {
    let mut scene = canonical();
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let median_area = |scene: &Scene| {
        let map = caustic_map(scene, &embree, 2, 4000);
        let mut areas: Vec<f64> = map
            .photons()
            .iter()
            .map(|p| 1.0 / f64::from(p.inv_area))
            .collect();
        areas.sort_by(f64::total_cmp);
        areas[areas.len() / 2]
    };
    let point = median_area(&scene);
    // 10 cm across at the point light's place, facing down: its light on the sphere is the
    // point light's to within a few degrees.
    let position = DVec3::new(-4.0, 4.0, -1.0);
    scene.lights = vec![photondiff::scene::Light::Quad {
        corner: position - DVec3::new(0.05, 0.0, 0.05),
        edge_u: DVec3::X * 0.1,
        edge_v: DVec3::Z * 0.1,
        radiance: DVec3::splat(6000.0),
    }];
    let quad = median_area(&scene);
    assert!(
        (0.5..2.0).contains(&(quad / point)),
        "median caustic footprint area: quad {quad:.3e}, point {point:.3e}"
    );
}

/// Photon tracing traces its paths 16 to a packet, refilling lanes as paths end; every path
/// must be the one the same emission traced alone, ray by ray, gives (same photons, same
/// rays), for caustic and global maps and whatever the thread count.
#[test]
fn packets_trace_the_paths_single_rays_trace() {
    let scene = canonical();
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let options = PhotonOptions::default();
    let tracer = PhotonTracer::new(&scene, &embree, &options);
    for (class, emitter, stop) in [
        (
            PathClass::Caustic,
            Emitter::caustic(&scene, 2000, options.overlap, 0),
            StopRule::Stored(2000),
        ),
        (
            PathClass::Global,
            Emitter::global(&scene, 100, options.overlap, 0),
            StopRule::Emitted(20_000),
        ),
    ] {
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let (packed, counts) =
                pool.install(|| tracer.trace_photons(&emitter, class, stop, &hidden()));
            let mut single = Vec::new();
            let mut rays = 0;
            for index in 0..counts.emitted {
                rays += tracer.trace_emission(&emitter, class, index, &mut single);
            }
            assert!(counts.stored > 0, "{class:?}: no photons");
            assert_eq!(counts.stored as usize, packed.len());
            assert_eq!(packed.len(), single.len(), "{class:?}, {threads} threads");
            assert_eq!(counts.rays, rays, "{class:?}, {threads} threads");
            for (a, b) in packed.iter().zip(&single) {
                // Embree's packet and single-ray kernels may round a hit's distance apart;
                // the hit is refined in double precision on the same triangle.
                assert!(
                    (a.ray.p - b.ray.p).length() < 1e-9
                        && (a.power - b.power).length() < 1e-12
                        && a.specular_bounces == b.specular_bounces
                        && a.diffuse_bounces == b.diffuse_bounces,
                    "{class:?}: {a:?} != {b:?}"
                );
            }
        }
    }
}

/// The canonical scene (segments 32, 64 x 48) with every length times `s` and the light's
/// intensity times `s^2`: the same image in any unit.
fn scaled_scene(s: f64) -> String {
    let mut table: toml::Table = include_str!("../scenes/caustic-sphere.toml")
        .parse()
        .unwrap();
    let scale = |v: &mut toml::Value, f: f64| match v {
        toml::Value::Array(a) => a
            .iter_mut()
            .for_each(|x| *x = toml::Value::Float(x.as_float().unwrap() * f)),
        toml::Value::Float(x) => *x *= f,
        _ => unreachable!(),
    };
    let camera = table["camera"].as_table_mut().unwrap();
    for key in ["eye", "look_at"] {
        scale(camera.get_mut(key).unwrap(), s);
    }
    camera.insert("width".into(), 64.into());
    camera.insert("height".into(), 48.into());
    for light in table["lights"].as_array_mut().unwrap() {
        let light = light.as_table_mut().unwrap();
        scale(light.get_mut("position").unwrap(), s);
        scale(light.get_mut("intensity").unwrap(), s * s);
    }
    for shape in table["shapes"].as_array_mut().unwrap() {
        let shape = shape.as_table_mut().unwrap();
        for key in ["corner", "edge_u", "edge_v", "center", "radius"] {
            if let Some(v) = shape.get_mut(key) {
                scale(v, s);
            }
        }
        if shape["type"].as_str() == Some("sphere") {
            shape.insert("segments".into(), 32.into());
        }
    }
    toml::to_string(&table).unwrap()
}

/// The pixels of one pass of `estimator` on the scene `text`, written into `dir` as `name`,
/// with `extra` options.
fn one_pass(dir: &Path, name: &str, text: &str, estimator: &str, extra: &[&str]) -> Vec<DVec3> {
    let scene = dir.join(format!("{name}.toml"));
    std::fs::write(&scene, text).unwrap();
    let out = dir.join(format!("{name}.exr"));
    let (scene_arg, out_arg) = (scene.to_str().unwrap(), out.to_str().unwrap());
    let mut args = vec![
        "render",
        scene_arg,
        "-q",
        "--passes",
        "1",
        "--estimator",
        estimator,
    ];
    args.extend(["-o", out_arg]);
    args.extend(extra);
    common::run_ok(args);
    photondiff::render::film::Film::read_exr(&out)
        .unwrap()
        .pixels
}

/// A scene a micrometre across renders as in metres, with every photon estimator. Its extent was
/// taken as at least 1e-3, which set its ray offsets and footprint limits for a scene a
/// millimetre across (relRMSE 0.0142 against the unscaled image at 1e-6, the caustic lost at
/// 1e-12, without a word). Then two absolute lengths were found: the aimed global photons'
/// target was 1e-9 wider than the sphere (at 1e-12 the global map held 45 photons for 346),
/// and `jensen`'s squared gather radius was at least 1e-12 (relRMSE 0.42 at 1e-6).
#[test]
fn a_scene_renders_alike_in_any_unit() {
    let dir = tempfile::tempdir().unwrap();
    let render = |s: f64, estimator: &str| {
        let photons = [
            "--threads",
            "1",
            "--photons",
            "20000",
            "--caustic-photons",
            "20000",
        ];
        let name = format!("{estimator}-{s:e}");
        one_pass(dir.path(), &name, &scaled_scene(s), estimator, &photons)
    };
    // Every estimate over photon maps, by its command-line name: a new one is in the test.
    let names: Vec<String> = EstimatorKind::over_maps()
        .map(EstimatorKind::name)
        .collect();
    for estimator in names.iter().map(String::as_str) {
        let metres = render(1.0, estimator);
        let mean = metres.iter().map(|p| p.element_sum()).sum::<f64>() / (3 * metres.len()) as f64;
        for s in [1e-12, 1e-9, 1e-6, 1e3] {
            let other = render(s, estimator);
            let squares: f64 = other
                .iter()
                .zip(&metres)
                .map(|(a, b)| (*a - *b).length_squared())
                .sum();
            let rel_rmse = (squares / (3 * metres.len()) as f64).sqrt() / mean;
            // Measured at 1e-12, 1e-9 and 1e-6: 1.4e-4 (integrated), 9e-5 (jensen), 2e-5
            // (pd), 1.7e-4 (coplanar), 1.5e-4 (multisampled); before the fixes 0.26, 0.030
            // and 0.0027 (integrated), 0.42 at 1e-6 (jensen), 0.28 at 1e-9 (multisampled).
            assert!(
                rel_rmse < 0.001,
                "{estimator} at scale {s}: relRMSE {rel_rmse:.6}"
            );
        }
    }
}

/// A dim light lights the scene as a bright one scaled: the passes' fixed-point sum kept 2^-80
/// steps, so a light of 1e-22 W/sr lit the canonical scene in three grey levels and one of
/// 1e-24 left it black, without a word. Values under 2^-60 are now summed in floating point.
#[test]
fn a_dim_light_renders_as_a_bright_one_scaled() {
    let dir = tempfile::tempdir().unwrap();
    let render = |intensity: f64, estimator: &str| {
        let mut table: toml::Table = scaled_scene(1.0).parse().unwrap();
        table["lights"][0]["intensity"] = toml::Value::Array(vec![intensity.into(); 3]);
        let text = toml::to_string(&table).unwrap();
        let name = format!("{estimator}-{intensity:e}");
        one_pass(dir.path(), &name, &text, estimator, &[])
    };
    for estimator in ["direct", "pd"] {
        let bright = render(60.0, estimator);
        let dim = render(6e-29, estimator);
        let lit = bright.iter().filter(|p| p.x > 0.0).count();
        assert!(lit > bright.len() / 2, "{estimator}: {lit} lit pixels");
        for (d, b) in dim.iter().zip(&bright) {
            // The EXR's f32 and the photons' f32 powers round the two apart by up to 4e-7.
            let scaled = *d * 1e30;
            assert!(
                (scaled - *b).abs().max_element() <= 2e-6 * b.max_element(),
                "{estimator}: {scaled} for {b}"
            );
        }
    }
}

/// A light split into two alike at one place (30 + 30 W/sr for 60) emits what the one light
/// does: each emission carries the same power, caustic and aimed global. The emitter's density
/// matched a light's sources by value, so each of the two counted the other's cones too, and
/// caustics and aimed photons carried half their light (the caustic's mean ratio to the
/// reference 0.50).
#[test]
fn two_lights_alike_at_one_place_emit_what_one_of_twice_the_intensity_does() {
    let one = canonical();
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/caustic-sphere.toml"
    ))
    .unwrap()
    .replace(
        "intensity = [60.0, 60.0, 60.0]",
        "intensity = [30.0, 30.0, 30.0]\n[[lights]]\ntype = \"point\"\n\
         position = [-4.0, 4.0, -1.0]\nintensity = [30.0, 30.0, 30.0]",
    );
    let two = parse_scene(&text, Path::new(".")).unwrap();
    assert_eq!((one.lights.len(), two.lights.len()), (1, 2));
    // The least and the most power an emission carries (a caustic emission's is one value;
    // an aimed global one's two: inside and outside the sphere's cone).
    let range = |e: &Emitter| {
        let mut rng = Rng::new(7, 0);
        (0..4000u64)
            .filter_map(|i| e.emit_from_light(i, &mut rng))
            .map(|(emission, _)| emission.power.x)
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), p| {
                (lo.min(p), hi.max(p))
            })
    };
    let close = |a: (f64, f64), b: (f64, f64)| {
        (a.0 / b.0 - 1.0).abs() < 1e-9 && (a.1 / b.1 - 1.0).abs() < 1e-9
    };
    let (c1, c2) = (
        range(&Emitter::caustic(&one, 20_000, 32.0, 0)),
        range(&Emitter::caustic(&two, 20_000, 32.0, 0)),
    );
    assert!(close(c1, c2), "caustic: one light {c1:?}, two {c2:?}");
    let (g1, g2) = (
        range(&Emitter::global_aimed(&one, 20_000, 32.0, 0, 0.15)),
        range(&Emitter::global_aimed(&two, 20_000, 32.0, 0, 0.15)),
    );
    assert!(g1.0 < g1.1, "two values: {g1:?}");
    assert!(close(g1, g2), "aimed global: one light {g1:?}, two {g2:?}");
}

/// Photon paths end by Russian roulette, not by a cap that cuts light off: in a closed diffuse
/// sphere of albedo 0.95 a path meets the wall 1 / (1 - 0.95) = 20 times on average, each
/// meeting a photon of the light's whole power (the survivors' powers are not scaled), where
/// the former cap of 64 surfaces allowed (1 - 0.95^64) / 0.05 = 19.25: 3.7% of the light gone.
#[test]
fn photon_paths_in_a_closed_bright_sphere_are_not_cut_short() {
    let text = common::closed_sphere("type = \"diffuse\"\nalbedo = [0.95, 0.95, 0.95]", 64);
    let scene = parse_scene(&text, Path::new(".")).unwrap();
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let options = PhotonOptions::default();
    let tracer = PhotonTracer::new(&scene, &embree, &options);
    let emitter = Emitter::global(&scene, 1000, 1.0, 0);
    let n = 60_000u64;
    let mut stored = Vec::new();
    let (mut emitted, mut power) = (DVec3::ZERO, DVec3::ZERO);
    for i in 0..n {
        let mut rng = Rng::new(5, i);
        let (emission, _) = emitter.emit_from_light(i, &mut rng).unwrap();
        emitted += emission.power;
        stored.clear();
        tracer.trace(emission, PathClass::AllDiffuse, &mut rng, &mut stored);
        power += stored.iter().map(|p| p.power).sum::<DVec3>();
    }
    // A geometric count of mean 20 and standard deviation 19.5: its mean over 60,000 paths
    // is within 0.08 of 20.
    let meetings = power.x / emitted.x;
    assert!(
        (meetings - 20.0).abs() < 0.4,
        "{meetings} wall meetings a path"
    );
}

/// The footprint limits are fractions of the scene's size, but a ground plane reaching far
/// away does not make the caustic's footprints larger: the canonical sphere on a floor 10^5
/// across clamped 119,655 of 120,000 caustic photons to its smallest footprint (1.4 units,
/// wider than the sphere) and the caustic kept 16% of its light. The shipped scenes keep their
/// extent (their figures stand).
#[test]
fn a_far_reaching_floor_does_not_blur_the_caustic() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes");
    let mut shipped: Vec<std::path::PathBuf> = ["", "stress"]
        .iter()
        .flat_map(|sub| std::fs::read_dir(Path::new(dir).join(sub)).unwrap())
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    shipped.sort();
    assert!(shipped.len() >= 6, "{shipped:?}");
    for path in &shipped {
        let scene = load_scene(path).unwrap();
        assert_eq!(
            scene.footprint_extent(),
            scene.extent(),
            "{}",
            path.display()
        );
    }
    let text = std::fs::read_to_string(Path::new(dir).join("caustic-sphere.toml")).unwrap();
    let far = text
        .replace(
            "corner = [-6.0, 0.0, 6.0]",
            "corner = [-50000.0, 0.0, 50000.0]",
        )
        .replace("edge_u = [12.0, 0.0, 0.0]", "edge_u = [100000.0, 0.0, 0.0]")
        .replace(
            "edge_v = [0.0, 0.0, -12.0]",
            "edge_v = [0.0, 0.0, -100000.0]",
        );
    let clamped_small = |text: &str| {
        let scene = parse_scene(text, Path::new(dir)).unwrap();
        let device = Device::new().unwrap();
        let embree = scene.build_embree(&device).unwrap();
        let options = PhotonOptions::default();
        let tracer = PhotonTracer::new(&scene, &embree, &options);
        let emitter = Emitter::caustic(&scene, 4000, options.overlap, 0);
        let (map, counts) = tracer
            .build_map(
                &emitter,
                PathClass::Caustic,
                StopRule::Stored(4000),
                &hidden(),
            )
            .unwrap();
        (
            scene.extent(),
            map.guards.clamped_min as f64 / counts.stored as f64,
        )
    };
    let (near_extent, near) = clamped_small(&text);
    let (far_extent, far) = clamped_small(&far);
    assert!(
        far_extent > 1e5 && near_extent < 20.0,
        "{near_extent} {far_extent}"
    );
    // About 3% on the canonical floor; all but a few on the far one before.
    assert!(near < 0.06 && far < 0.06, "{near} {far}");
}

/// Light caught between perfect reflectors never ends by Russian roulette: a path meets at most
/// 64 mirror or glass surfaces in a row, not the 1,024 surfaces any path may meet (a point light
/// just inside a glass sphere traced its maps 80 times as long as outside it at 64 surfaces).
#[test]
fn light_caught_in_a_closed_mirror_ends_after_64_reflections() {
    use photondiff::photons::light_path::MAX_SPECULAR_RUN;
    let text = common::closed_sphere("type = \"mirror\"\nreflectance = [1.0, 1.0, 1.0]", 32);
    let scene = parse_scene(&text, Path::new(".")).unwrap();
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let options = PhotonOptions::default();
    assert_eq!((options.max_bounces, MAX_SPECULAR_RUN), (1024, 64));
    let tracer = PhotonTracer::new(&scene, &embree, &options);
    let emitter = Emitter::global(&scene, 100, 1.0, 0);
    let mut stored = Vec::new();
    for i in 0..100 {
        let mut rng = Rng::new(5, i);
        let (emission, _) = emitter.emit_from_light(i, &mut rng).unwrap();
        let rays = tracer.trace(emission, PathClass::AllDiffuse, &mut rng, &mut stored);
        assert_eq!(rays, 64, "emission {i}");
    }
    assert!(stored.is_empty());
}

/// A caustic map none of whose photons can land (the light under the floor, which hides the
/// sphere from it) stops after 1% of its emission cap, not at the cap: 60 million emissions a
/// pass took 28 s for a black image. The statistics say it stopped with none stored.
#[test]
fn a_caustic_map_that_stores_nothing_stops_early() {
    use photondiff::photons::trace::{emission_stopped, max_emissions, EMPTY_CAUSTIC_SHARE};
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/caustic-sphere.toml"
    ))
    .unwrap();
    let under = text.replace(
        "position = [-4.0, 4.0, -1.0]",
        "position = [-4.0, -4.0, -1.0]",
    );
    assert_ne!(under, text);
    let asked = 2000;
    let counts = |text: &str| {
        let scene = parse_scene(text, Path::new(".")).unwrap();
        let device = Device::new().unwrap();
        let embree = scene.build_embree(&device).unwrap();
        let options = PhotonOptions::default();
        let tracer = PhotonTracer::new(&scene, &embree, &options);
        let emitter = Emitter::caustic(&scene, asked, options.overlap, 0);
        let stop = StopRule::Stored(asked);
        tracer
            .build_map(&emitter, PathClass::Caustic, stop, &hidden())
            .unwrap()
            .1
    };
    let cap = max_emissions(PathClass::Caustic, asked);
    let hidden_light = counts(&under);
    assert_eq!(hidden_light.stored, 0);
    // Whole batches of 4,096 emissions: the first past 1% of the cap.
    let early = cap / EMPTY_CAUSTIC_SHARE;
    assert!(
        hidden_light.emitted >= early && hidden_light.emitted < early + 4096,
        "{hidden_light:?}"
    );
    assert!(emission_stopped(
        PathClass::Caustic,
        asked,
        1.0,
        &hidden_light
    ));
    let canonical = counts(&text);
    assert_eq!(canonical.stored, asked as u64);
    assert!(!emission_stopped(
        PathClass::Caustic,
        asked,
        1.0,
        &canonical
    ));
}
