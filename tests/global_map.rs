//! The global map counts photons stored: a scene that stores them reaches the count; one that
//! cannot stops at the emission cap, says so on standard error and in the statistics, and
//! still renders a finite image.

use photondiff::photons::map::PathClass;
use photondiff::photons::trace::{max_emissions, GLOBAL_EMISSIONS_PER_PHOTON};
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

/// Renders `scene` with `--photons photons`; returns standard error, the global map's
/// statistics and the image.
fn render(dir: &Path, scene: &str, photons: usize) -> (String, serde_json::Value, Film) {
    let file = dir.join("scene.toml");
    std::fs::write(&file, scene).unwrap();
    let exr = dir.join("img.exr");
    let stats = dir.join("stats.json");
    let out = Command::new(env!("CARGO_BIN_EXE_photondiff"))
        .args(["render", "--quiet", "--estimator", "pd", "--threads", "1"])
        .args([
            "--photons",
            &photons.to_string(),
            "--caustic-photons",
            "100",
        ])
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
    let (stderr, global, _) = render(dir.path(), &format!("{HEAD}{CEILING}"), 2000);
    assert!(global["stored"].as_u64().unwrap() >= 2000, "{global}");
    assert_eq!(global["asked"], 2000);
    assert_eq!(global["cap_reached"], false);
    assert!(global["emitted"].as_u64().unwrap() < max_emissions(PathClass::Global, 2000));
    assert!(!stderr.contains("warning"), "{stderr}");

    // A floor alone: light leaves after its one diffuse bounce, nothing is ever stored.
    let (stderr, global, film) = render(dir.path(), HEAD, 2000);
    let cap = 2000 * GLOBAL_EMISSIONS_PER_PHOTON;
    assert_eq!(max_emissions(PathClass::Global, 2000), cap);
    assert_eq!(global["stored"], 0);
    assert_eq!(global["emitted"], cap);
    assert_eq!(global["cap_reached"], true);
    assert_eq!(
        stderr.trim(),
        format!(
            "photondiff: warning: {}: global map: 0 of 2000 photons stored: emission stopped at \
             its cap of {cap} emissions; this scene rarely stores such photons",
            dir.path().join("scene.toml").display()
        )
    );
    // The render completed with the floor's direct light, and nothing is NaN.
    assert!(film.pixels.iter().all(|p| p.is_finite()));
    assert!(film.pixels.iter().any(|p| p.max_element() > 0.0));
}

/// In the canonical (open) scene global photons are light that went floor -> glass sphere ->
/// floor. Aiming half the diffuse bounces at the sphere stores many more of them for the same
/// emissions, and the map carries the same power (the weights undo the aim): the two totals
/// agree within four of their combined standard errors.
#[test]
fn aimed_bounces_store_more_global_photons_carrying_the_same_light() {
    use photondiff::embree::Device;
    use photondiff::photons::emission::Emitter;
    use photondiff::photons::trace::{PhotonOptions, PhotonTracer, StopRule};
    let scene = photondiff::scene::file::load_scene(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/caustic-sphere.toml"
    )))
    .unwrap();
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let emissions = 2_000_000;
    let map = |aim: f64| {
        let options = PhotonOptions {
            global_aim: aim,
            ..PhotonOptions::default()
        };
        let tracer = PhotonTracer::new(&scene, &embree, &options);
        let emitter = Emitter::global(&scene, options.global_photons, options.overlap, 0);
        let (map, counts) = tracer.build_map(
            &emitter,
            PathClass::Global,
            StopRule::Emitted(emissions),
            &indicatif::ProgressBar::hidden(),
        );
        assert_eq!(counts.emitted, emissions as u64);
        // The total and its standard error: each emission adds its photons' powers; with few
        // photons per emission the variance of the sum is about the sum of their squares.
        let power: Vec<f64> = map.photons.iter().map(|p| f64::from(p.power.y)).collect();
        let total: f64 = power.iter().sum();
        let error = power.iter().map(|p| p * p).sum::<f64>().sqrt();
        (map.len(), total, error)
    };
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
