//! The global map counts photons stored: a scene that stores them reaches the count; one that
//! cannot stops at the emission cap, says so on standard error and in the statistics, and
//! still renders a finite image.

use photondiff::photons::map::PathClass;
use photondiff::photons::trace::{emission_cap, max_emissions, GLOBAL_EMISSIONS_PER_PHOTON};
use photondiff::render::film::Film;
use std::path::Path;
use std::process::Command;

const HEAD: &str = r#"
[camera]
eye = [0.0, 1.0, 3.0]
look_at = [0.0, 0.5, 0.0]
up = [0.0, 1.0, 0.0]
fov_y = 60.0
width = 24
height = 16

[materials.white]
type = "diffuse"
albedo = [0.8, 0.8, 0.8]

[[lights]]
type = "point"
position = [0.0, 1.0, 0.0]
intensity = [10.0, 10.0, 10.0]

[[shapes]]
type = "quad"
corner = [-2.0, 0.0, 2.0]
edge_u = [4.0, 0.0, 0.0]
edge_v = [0.0, 0.0, -4.0]
material = "white"
"#;

/// A ceiling facing the floor: light bounces between them, so global photons are stored.
const CEILING: &str = r#"
[[shapes]]
type = "quad"
corner = [-2.0, 2.0, -2.0]
edge_u = [4.0, 0.0, 0.0]
edge_v = [0.0, 0.0, 4.0]
material = "white"
"#;

/// Renders `scene` with `--photons photons` (or the default count for `None`); returns standard
/// error, the global map's statistics and the image.
fn render(dir: &Path, scene: &str, photons: Option<usize>) -> (String, serde_json::Value, Film) {
    let file = dir.join("scene.toml");
    std::fs::write(&file, scene).unwrap();
    let exr = dir.join("img.exr");
    let stats = dir.join("stats.json");
    let out = Command::new(env!("CARGO_BIN_EXE_photondiff"))
        .args(["render", "--quiet", "--estimator", "pd", "--threads", "1"])
        .args(
            photons
                .map(|n| ["--photons".to_string(), n.to_string()])
                .into_iter()
                .flatten(),
        )
        .args(["--caustic-photons", "100"])
        .arg("-o")
        .arg(&exr)
        .arg("--stats-json")
        .arg(&stats)
        .arg(&file)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{stderr}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    let global = json["photon_maps"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["class"] == "Global")
        .unwrap()
        .clone();
    (stderr, global, Film::read_exr(&exr).unwrap())
}

#[test]
fn the_global_map_holds_the_photons_asked_for_or_says_why_not() {
    let dir = tempfile::tempdir().unwrap();

    // Floor and ceiling: every emission that reaches the floor may bounce to the ceiling.
    let (stderr, global, _) = render(dir.path(), &format!("{HEAD}{CEILING}"), Some(2000));
    assert!(global["stored"].as_u64().unwrap() >= 2000, "{global}");
    assert_eq!(global["asked"], 2000);
    assert_eq!(global["cap_reached"], false);
    assert!(global["emitted"].as_u64().unwrap() < max_emissions(PathClass::Global, 2000));
    assert!(!stderr.contains("warning"), "{stderr}");

    // A floor alone: light leaves after its one diffuse bounce, nothing is ever stored. The
    // light, 1 above the middle of a floor 4 across, draws its photons from the cone out to
    // the floor's corners (cos 1/3): a third of its sphere, and a third of the cap.
    let (stderr, global, film) = render(dir.path(), HEAD, Some(6000));
    let share = floor_alone_share(dir.path());
    assert!((share - 1.0 / 3.0).abs() < 1e-8, "{share}");
    assert_eq!(
        max_emissions(PathClass::Global, 6000),
        6000 * GLOBAL_EMISSIONS_PER_PHOTON
    );
    let cap = emission_cap(PathClass::Global, 6000, share);
    assert!((8000..=8001).contains(&cap), "{cap}");
    assert_eq!(global["stored"], 0);
    assert_eq!(global["emitted"], cap);
    assert_eq!(global["cap_reached"], true);
    assert_eq!(
        stderr.trim(),
        format!(
            "photondiff: warning: {}: global map: 0 of 6000 photons stored: emission stopped at \
             its cap of {cap} emissions; this scene rarely stores such photons",
            dir.path().join("scene.toml").display()
        )
    );
    // Over passes the counts are totals, and the warning says so.
    let out = Command::new(env!("CARGO_BIN_EXE_photondiff"))
        .args([
            "render",
            "--quiet",
            "--passes",
            "2",
            "--photons",
            "2000",
            "--threads",
            "1",
        ])
        .args(["--caustic-photons", "100", "-o"])
        .arg(dir.path().join("two.exr"))
        .arg(dir.path().join("scene.toml"))
        .output()
        .unwrap();
    let two = String::from_utf8_lossy(&out.stderr);
    assert!(
        two.contains("global map: 0 of 4000 photons stored: ")
            && two
                .trim_end()
                .ends_with("this scene rarely stores such photons (totals over 2 passes)"),
        "{two}"
    );
    // The render completed with the floor's direct light, and nothing is NaN.
    assert!(film.pixels.iter().all(|p| p.is_finite()));
    assert!(film.pixels.iter().any(|p| p.max_element() > 0.0));
    // A count the user did not give is an "up to" count: the statistics tell of the cap, but
    // nothing is said on standard error (the canonical scene's default render ends there too).
    let (stderr, global, _) = render(dir.path(), HEAD, None);
    let asked = global["asked"].as_u64().unwrap();
    assert_eq!(global["stored"], 0);
    assert_eq!(
        global["emitted"],
        emission_cap(PathClass::Global, asked as usize, share)
    );
    assert_eq!(global["cap_reached"], true);
    assert_eq!(stderr.trim(), "");
}

/// The share of its whole emission that the floor-alone scene's light draws its global
/// photons from (the scene written in `dir` by `render`; the render uses no aimed emission).
fn floor_alone_share(dir: &Path) -> f64 {
    use photondiff::photons::emission::Emitter;
    let scene = photondiff::scene::file::load_scene(&dir.join("scene.toml")).unwrap();
    Emitter::global(&scene, 6000, 1.0, 0).share()
}

/// The canonical scene's global map from 2,000,000 emissions with a share `bounce_aim` of its
/// diffuse bounces and `emission_aim` of its emissions aimed at the glass: its photon count,
/// the total power and that total's standard error (each emission adds its photons' powers;
/// with few photons per emission the variance of the sum is about the sum of their squares).
fn canonical_global_map(bounce_aim: f64, emission_aim: f64) -> (usize, f64, f64) {
    use photondiff::embree::Device;
    use photondiff::photons::emission::Emitter;
    use photondiff::photons::options::PhotonOptions;
    use photondiff::photons::trace::{PhotonTracer, StopRule};
    let scene = photondiff::scene::file::load_scene(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/caustic-sphere.toml"
    )))
    .unwrap();
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let emissions = 2_000_000;
    let options = PhotonOptions {
        global_aim: bounce_aim,
        ..PhotonOptions::default()
    };
    let tracer = PhotonTracer::new(&scene, &embree, &options);
    let (photons, overlap) = (options.global_photons, options.overlap);
    let emitter = Emitter::global_aimed(&scene, photons, overlap, 0, emission_aim);
    let (map, counts) = tracer
        .build_map(
            &emitter,
            PathClass::Global,
            StopRule::Emitted(emissions),
            &indicatif::ProgressBar::hidden(),
        )
        .unwrap();
    assert_eq!(counts.emitted, emissions as u64);
    let power: Vec<f64> = map.photons().iter().map(|p| f64::from(p.power.y)).collect();
    let total: f64 = power.iter().sum();
    let error = power.iter().map(|p| p * p).sum::<f64>().sqrt();
    (map.len(), total, error)
}

/// In the canonical (open) scene global photons are light that went floor -> glass sphere ->
/// floor. Aiming half the diffuse bounces at the sphere stores many more of them for the same
/// emissions, and the map carries the same power (the weights undo the aim): the two totals
/// agree within four of their combined standard errors.
#[test]
fn aimed_bounces_store_more_global_photons_carrying_the_same_light() {
    let map = |aim: f64| canonical_global_map(aim, 0.0);
    let (plain_count, plain, plain_error) = map(0.0);
    let (aimed_count, aimed, aimed_error) = map(0.5);
    assert!(plain_count > 100, "{plain_count} photons without aim");
    assert!(
        aimed_count > 10 * plain_count,
        "{aimed_count} aimed photons against {plain_count}"
    );
    let sigma = (plain_error * plain_error + aimed_error * aimed_error).sqrt();
    assert!(
        (aimed - plain).abs() <= 4.0 * sigma,
        "aimed {aimed} against {plain} (standard error {sigma})"
    );
    assert!(
        aimed_error < 0.6 * plain_error,
        "{aimed_error} {plain_error}"
    );
}

/// An aimed global emitter stands for the same light: over many emissions from the canonical
/// scene's point light the mean emitted power is the light's into the cone that holds the
/// scene (`I` times its solid angle: directions outside it meet nothing and are not drawn)
/// and the power sent into the glass sphere's cone is `I` times its solid angle, while far
/// more of its emissions go there (the aimed share plus the isotropic part's); with no aim it
/// is the plain global emitter, emission for emission.
#[test]
fn aimed_emissions_carry_the_lights_power_and_favour_the_specular_objects() {
    use photondiff::photons::emission::scene_cone::scene_cone;
    use photondiff::photons::emission::Emitter;
    use photondiff::photons::targets::{cone, cone_solid_angle, specular_targets};
    use photondiff::util::rng::Rng;
    let scene = photondiff::scene::file::load_scene(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/caustic-sphere.toml"
    )))
    .unwrap();
    let light = glam::DVec3::new(-4.0, 4.0, -1.0);
    let intensity = 60.0;
    let target = specular_targets(&scene)[0];
    let (axis, cos_max) = cone(light, &target);
    let omega = cone_solid_angle(cos_max);
    let n = 400_000u64;
    let sums = |emitter: &Emitter| {
        let (mut total, mut into, mut count) = (0.0, 0.0, 0u64);
        for i in 0..n {
            let mut rng = Rng::new(7, i);
            if let Some(e) = emitter.emit(i, &mut rng) {
                assert_eq!(e.ray.p, light);
                total += e.power.y;
                if e.ray.d.dot(axis) >= cos_max {
                    into += e.power.y;
                    count += 1;
                }
            }
        }
        (total / n as f64, into / n as f64, count as f64 / n as f64)
    };
    // Both emitters draw from the cone that holds the scene's box, of solid angle
    // `scene_omega`: their mean power is the power the light sends into it.
    let scene_cone = scene_cone(light, scene.bounds().unwrap()).expect("the light is outside");
    let scene_omega = scene_cone.solid_angle();
    let whole = scene_omega / (4.0 * std::f64::consts::PI);
    assert!(whole > 0.3 && whole < 0.6, "{whole}");
    let aim = 0.3;
    let aimed = Emitter::global_aimed(&scene, 1000, 32.0, 0, aim);
    let (total, into, share) = sums(&aimed);
    let power = scene_omega * intensity;
    assert!(
        (total / power - 1.0).abs() < 0.005,
        "{total} against {power}"
    );
    assert!(
        (into / (intensity * omega) - 1.0).abs() < 0.005,
        "{into} into the cone against {}",
        intensity * omega
    );
    // The aimed part is drawn whole and the isotropic part narrowed to the scene's cone (the
    // emitter's `share` of the light's whole emission), so of the emissions the aimed part
    // is `aim / share` and the isotropic part's `(1 - aim) whole / share` falls in the sphere's
    // cone by its share of the scene's cone.
    let emitter_share = aim + (1.0 - aim) * whole;
    assert!(
        (aimed.share() - emitter_share).abs() < 1e-12,
        "{}",
        aimed.share()
    );
    let expected = (aim + (1.0 - aim) * whole * omega / scene_omega) / emitter_share;
    assert!(
        (share - expected).abs() < 0.01,
        "{share} against {expected}"
    );
    // Unaimed, a few emissions in a hundred go there.
    let plain = Emitter::global(&scene, 1000, 32.0, 0);
    let (plain_total, _, plain_share) = sums(&plain);
    assert!((plain_total / power - 1.0).abs() < 0.005, "{plain_total}");
    assert!(
        plain_share < 0.05 && share > 5.0 * plain_share,
        "{plain_share} {share}"
    );
    // Aim 0 is the plain emitter, emission for emission.
    let zero = Emitter::global_aimed(&scene, 1000, 32.0, 0, 0.0);
    for i in 0..100 {
        let (a, b) = (
            zero.emit(i, &mut Rng::new(3, i)).unwrap(),
            plain.emit(i, &mut Rng::new(3, i)).unwrap(),
        );
        assert_eq!((a.ray.d, a.power, a.ray.dd), (b.ray.d, b.power, b.ray.dd));
    }
}

/// The global map from aimed emissions holds the same light as from isotropic ones (their
/// totals within four combined standard errors, as for aimed bounces above) with more photons
/// through the glass: the canonical scene's caustic reflected off the floor into the sphere
/// and back (L S+ D S+ D) rides on them.
#[test]
fn aimed_emissions_store_more_global_photons_carrying_the_same_light() {
    let map = |aim: f64| canonical_global_map(0.0, aim);
    let (plain_count, plain, plain_error) = map(0.0);
    let (aimed_count, aimed, aimed_error) = map(0.3);
    eprintln!(
        "plain: {plain_count} photons, {plain:.5} +- {plain_error:.5}; aimed: {aimed_count} \
         photons, {aimed:.5} +- {aimed_error:.5}"
    );
    assert!(plain_count > 100, "{plain_count} photons without aim");
    assert!(
        aimed_count as f64 > 1.3 * plain_count as f64,
        "{aimed_count} photons from aimed emissions against {plain_count}"
    );
    let sigma = (plain_error * plain_error + aimed_error * aimed_error).sqrt();
    assert!(
        (aimed - plain).abs() <= 4.0 * sigma,
        "aimed {aimed} against {plain} (standard error {sigma})"
    );
}

/// The solid angle of triangle `abc` seen from the origin (Van Oosterom and Strackee).
fn triangle_solid_angle(a: glam::DVec3, b: glam::DVec3, c: glam::DVec3) -> f64 {
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let numerator = a.dot(b.cross(c)).abs();
    let denominator = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    2.0 * numerator.atan2(denominator)
}

/// A point light's global photons are drawn only towards the scene (the cone that holds its
/// box), and stand for the same light there: from the canonical scene's light, the power its
/// emissions carry onto the floor is `I` times the floor's solid angle (exact, from two
/// triangles), within 0.5%, with well under half of the light's sphere drawn from. Where the
/// box holds the light (a speck far above it) the whole sphere is drawn, and the floor gets
/// the same power.
#[test]
fn global_photons_are_drawn_towards_the_scene_and_carry_its_light() {
    use glam::DVec3;
    use photondiff::photons::emission::Emitter;
    use photondiff::util::rng::Rng;
    let path = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/caustic-sphere.toml"
    ));
    let text = std::fs::read_to_string(path).unwrap();
    let light = DVec3::new(-4.0, 4.0, -1.0);
    let intensity = 60.0;
    assert!(text.contains("position = [-4.0, 4.0, -1.0]") && text.contains("60.0, 60.0, 60.0"));
    // The floor: y = 0, x and z in [-6, 6].
    let corners = [
        DVec3::new(-6.0, 0.0, -6.0),
        DVec3::new(6.0, 0.0, -6.0),
        DVec3::new(6.0, 0.0, 6.0),
        DVec3::new(-6.0, 0.0, 6.0),
    ]
    .map(|c| c - light);
    let floor_omega = triangle_solid_angle(corners[0], corners[1], corners[2])
        + triangle_solid_angle(corners[0], corners[2], corners[3]);
    let onto_floor = |emitter: &Emitter| {
        let n = 400_000u64;
        let mut power = 0.0;
        for i in 0..n {
            let e = emitter.emit(i, &mut Rng::new(5, i)).unwrap();
            let d = e.ray.d;
            if d.y < 0.0 {
                let p = light + d * (-light.y / d.y);
                if p.x.abs() <= 6.0 && p.z.abs() <= 6.0 {
                    power += e.power.y;
                }
            }
        }
        power / n as f64
    };
    let expected = intensity * floor_omega;
    let scene = photondiff::scene::file::load_scene(path).unwrap();
    let narrowed = Emitter::global(&scene, 1000, 1.0, 0);
    assert!(
        narrowed.share() > 0.3 && narrowed.share() < 0.5,
        "{}",
        narrowed.share()
    );
    let power = onto_floor(&narrowed);
    assert!(
        (power / expected - 1.0).abs() < 0.005,
        "{power} against {expected}"
    );

    // A speck far above the light puts it inside the scene's box: the whole sphere.
    let dir = tempfile::tempdir().unwrap();
    let speck = dir.path().join("speck.toml");
    std::fs::write(
        &speck,
        format!(
            "{text}\n[[shapes]]\ntype = \"quad\"\ncorner = [0.0, 50.0, 0.0]\n\
             edge_u = [0.001, 0.0, 0.0]\nedge_v = [0.0, 0.0, 0.001]\nmaterial = \"floor\"\n"
        ),
    )
    .unwrap();
    let speck = photondiff::scene::file::load_scene(&speck).unwrap();
    let whole = Emitter::global(&speck, 1000, 1.0, 0);
    assert_eq!(whole.share(), 1.0);
    let power = onto_floor(&whole);
    assert!(
        (power / expected - 1.0).abs() < 0.005,
        "{power} against {expected}"
    );

    // The narrowed cone holds its photons as densely per steradian as the whole sphere held
    // them (the cap shrinks with it), so their beams are as wide: the footprints, and what
    // the estimates blur and average, stay as they were. Plain emitters, and the aimed ones'
    // emissions outside the sphere's cone (where only the isotropic part draws).
    let beam = |e: &Emitter, i: u64| {
        let e = e.emit(i, &mut Rng::new(5, i)).unwrap();
        (e.ray.d, e.ray.dd[0].length())
    };
    let (narrow, wide) = (beam(&narrowed, 0).1, beam(&whole, 0).1);
    assert!((narrow / wide - 1.0).abs() < 1e-12, "{narrow} {wide}");
    let target = photondiff::photons::targets::specular_targets(&scene)[0];
    let (axis, cos_max) = photondiff::photons::targets::cone(light, &target);
    let outside = |e: &Emitter| {
        (0..1000)
            .map(|i| beam(e, i))
            .find(|(d, _)| d.dot(axis) < cos_max)
            .unwrap()
            .1
    };
    let (narrow, wide) = (
        outside(&Emitter::global_aimed(&scene, 1000, 32.0, 0, 0.3)),
        outside(&Emitter::global_aimed(&speck, 1000, 32.0, 0, 0.3)),
    );
    assert!((narrow / wide - 1.0).abs() < 1e-12, "{narrow} {wide}");
}
