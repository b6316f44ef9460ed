//! Camera paths through glass: splitting at every glass surface against one branch chosen with
//! Fresnel's probability (`--split-depth`): the same image in expectation, the same image to
//! the bit where no path goes deep enough to choose, and fewer rays where it does.

use photondiff::embree::{Device, Ray};
use photondiff::render::film::Film;
use photondiff::render::stats::Stats;
use photondiff::render::{render, RenderOptions};
use photondiff::scene::file::parse_scene;
use photondiff::scene::Scene;
use std::path::Path;
use std::process::Command;

/// Two glass balls side by side over a floor under a point light, seen from above at an angle:
/// camera paths enter one ball, leave it, and some meet the other (several glass surfaces a
/// path, each splitting it in two). Direct light only, from a point light, so that the only
/// random numbers of a render are the glass branches chosen.
const BALLS: &str = r#"
[camera]
eye = [0.0, 2.5, 4.0]
look_at = [0.0, 0.5, 0.0]
up = [0.0, 1.0, 0.0]
fov_y = 40.0
width = 64
height = 48

[materials.floor]
type = "diffuse"
albedo = [0.7, 0.7, 0.7]

[materials.glass]
type = "glass"
ior = 1.5

[[lights]]
type = "point"
position = [1.0, 4.0, 2.0]
intensity = [20.0, 20.0, 20.0]

[[shapes]]
type = "quad"
corner = [-4.0, 0.0, 4.0]
edge_u = [8.0, 0.0, 0.0]
edge_v = [0.0, 0.0, -8.0]
material = "floor"

[[shapes]]
type = "sphere"
center = [-0.55, 0.5, 0.0]
radius = 0.5
material = "glass"
segments = 48

[[shapes]]
type = "sphere"
center = [0.55, 0.5, -0.3]
radius = 0.5
material = "glass"
segments = 48
"#;

fn scene() -> Scene {
    parse_scene(BALLS, Path::new(".")).unwrap()
}

fn render_with(scene: &Scene, options: &RenderOptions) -> (Film, Stats) {
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let mut stats = Stats::default();
    let film = render(scene, &embree, &[], options, &mut stats).unwrap();
    (film, stats)
}

/// The pixels whose camera ray meets a glass ball first (the rest see the floor directly,
/// the same in every render).
fn glass_pixels(scene: &Scene) -> Vec<usize> {
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let camera = &scene.camera;
    (0..camera.height)
        .flat_map(|y| (0..camera.width).map(move |x| (x, y)))
        .filter(|&(x, y)| {
            let r = camera.ray(x as f64 + 0.5, y as f64 + 0.5, 1.0);
            embree
                .intersect(&Ray::new(r.p, r.d))
                .is_some_and(|hit| hit.geom_id > 0)
        })
        .map(|(x, y)| (y * camera.width + x) as usize)
        .collect()
}

/// The sum of the image's red channel over `pixels`.
fn total(film: &Film, pixels: &[usize]) -> f64 {
    pixels.iter().map(|&k| film.pixels[k].x).sum()
}

#[test]
fn a_split_depth_no_path_reaches_changes_nothing() {
    let scene = scene();
    let options = RenderOptions::default().with_seed(3);
    let (split, split_stats) = render_with(&scene, &options);
    // A path takes at most `max_depth` (10) bounces: a split depth of 10 is never reached.
    let (beyond, beyond_stats) = render_with(&scene, &options.clone().with_split_depth(Some(10)));
    assert!(split == beyond, "the images differ");
    assert_eq!(split_stats.rays, beyond_stats.rays);
    assert!(split_stats.rays.specular > 0);
}

#[test]
fn one_branch_chosen_by_fresnel_keeps_the_mean_with_fewer_rays() {
    let scene = scene();
    let base = RenderOptions::default().with_threads(2);
    let (split, split_stats) = render_with(&scene, &base);
    let glass = glass_pixels(&scene);
    assert!(glass.len() > 200, "{} pixels see glass", glass.len());
    let expected = total(&split, &glass);
    // Every glass surface chooses (`Some(0)`): the image's sum over many seeds against the
    // split image's, within four standard errors of the seeds' mean.
    let sums: Vec<f64> = (0..48)
        .map(|seed| {
            let options = base.clone().with_split_depth(Some(0)).with_seed(seed);
            let (film, stats) = render_with(&scene, &options);
            assert!(
                stats.rays.specular < split_stats.rays.specular / 2,
                "{} specular rays against {} split",
                stats.rays.specular,
                split_stats.rays.specular
            );
            total(&film, &glass)
        })
        .collect();
    let n = sums.len() as f64;
    let mean = sums.iter().sum::<f64>() / n;
    let variance = sums.iter().map(|s| (s - mean).powi(2)).sum::<f64>() / (n - 1.0);
    let standard_error = (variance / n).sqrt();
    // The choice is random (each seed's image differs), and the test sharp enough to see a
    // wrong probability: choosing reflection half the time read 17.41 against 15.56, twelve
    // standard errors off (the split and chosen sums read 15.56 and 15.53 +- 0.09).
    assert!(variance > 0.0, "every seed gave the same image");
    assert!(
        standard_error < 0.01 * expected,
        "standard error {standard_error} of {expected}"
    );
    assert!(
        (mean - expected).abs() < 4.0 * standard_error,
        "mean over seeds {mean} against the split image's {expected} (standard error {standard_error})"
    );
}

#[test]
fn chosen_branches_are_the_same_on_any_thread_count() {
    let scene = scene();
    let options = RenderOptions::default()
        .with_split_depth(Some(1))
        .with_seed(11);
    let (one, _) = render_with(&scene, &options.clone().with_threads(1));
    let (two, _) = render_with(&scene, &options.clone().with_threads(2));
    assert!(one == two, "images differ between 1 and 2 threads");
    let (other, _) = render_with(&scene, &options.with_seed(12));
    assert!(one != other, "the seed chooses nothing");
}

/// A render whose camera paths split into many rays says `--split-depth` exists, once, with the
/// rays a camera ray; one that chose its branches, or met little glass, or `--quiet`, does not.
#[test]
fn a_render_of_many_glass_surfaces_notes_the_split_depth() {
    let exe = env!("CARGO_BIN_EXE_photondiff");
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let run = |scene: &str, extra: &[&str]| {
        let out = Command::new(exe)
            .arg("render")
            .arg(root.join(scene))
            .arg("-o")
            .arg(dir.path().join("o.exr"))
            .args(["--estimator", "direct", "--threads", "2"])
            .args(extra)
            .output()
            .unwrap();
        assert!(out.status.success());
        String::from_utf8(out.stderr).unwrap()
    };
    let notes = |text: &str| {
        text.lines()
            .filter(|l| l.starts_with("photondiff: note:"))
            .map(str::to_string)
            .collect::<Vec<_>>()
    };
    // Glass behind glass: 8.8 specular rays a camera ray.
    let glass = run("scenes/stress/glass-through-glass.toml", &[]);
    assert_eq!(
        notes(&glass),
        ["photondiff: note: 8.8 specular rays a camera ray: every glass surface splits a camera \
          path in two; --split-depth 1 takes one branch, chosen by Fresnel, past the first (the \
          same image in expectation, noisier and cheaper a pass)"]
    );
    let chosen = run(
        "scenes/stress/glass-through-glass.toml",
        &["--split-depth", "3"],
    );
    assert!(notes(&chosen).is_empty(), "{chosen}");
    let quiet = run("scenes/stress/glass-through-glass.toml", &["--quiet"]);
    assert!(notes(&quiet).is_empty(), "{quiet}");
    // One glass sphere: about half a ray.
    let canonical = run("scenes/caustic-sphere.toml", &[]);
    assert!(notes(&canonical).is_empty(), "{canonical}");
}
