//! Helpers shared by test files (each takes them with `mod common;`).

// Each test file is its own crate and uses some of these only.
#![allow(dead_code)]

use glam::DVec3;
use photondiff::photons::footprint::{footprint, FootprintLimits, Guards};
use photondiff::photons::map::Photon;
use photondiff::render::part::read_part;
use std::f64::consts::PI;
use std::path::Path;

/// Gauss-Legendre nodes and weights on [-1, 1], 5 points.
const GL5: [(f64, f64); 5] = [
    (0.0, 0.568_888_888_888_888_9),
    (-0.538_469_310_105_683_1, 0.478_628_670_499_366_5),
    (0.538_469_310_105_683_1, 0.478_628_670_499_366_5),
    (-0.906_179_845_938_664, 0.236_926_885_056_189_1),
    (0.906_179_845_938_664, 0.236_926_885_056_189_1),
];

/// The integral of `f` from the first of `cuts` (sorted) to the last, piece by piece between
/// consecutive cuts (where `f` has kinks), each by composite Gauss-Legendre on `panels` panels
/// in the variable `theta` of `x = c0 + (c1 - c0)(1 - cos theta)/2`: an integrand that behaves
/// like `(x - c0)^(3/2)` at an end (a line becoming tangent to the unit circle) is smooth in
/// `theta`.
pub fn integrate_between_cuts(cuts: &[f64], panels: usize, f: impl Fn(f64) -> f64) -> f64 {
    let mut sum = 0.0;
    for w in cuts.windows(2) {
        let h = PI / panels as f64;
        for k in 0..panels {
            let mid = (k as f64 + 0.5) * h;
            for (x, wt) in GL5 {
                let theta = mid + 0.5 * h * x;
                let at = w[0] + (w[1] - w[0]) * 0.5 * (1.0 - theta.cos());
                let jacobian = (w[1] - w[0]) * 0.5 * theta.sin();
                sum += wt * 0.5 * h * jacobian * f(at);
            }
        }
    }
    sum
}

/// A photon at `position` on the floor (normal +y) with footprint radius vectors `a`, `b` in
/// it, arriving straight down, with no guard on its footprint's size or shape.
pub fn floor_photon(position: DVec3, a: DVec3, b: DVec3, power: f64) -> Photon {
    let limits = FootprintLimits {
        min_radius: 1e-12,
        max_radius: 1e9,
        max_anisotropy: 1e9,
    };
    let f = footprint(a, b, DVec3::Y, &limits, 1.0, &mut Guards::default());
    Photon::new(position, DVec3::Y, -DVec3::Y, DVec3::splat(power), &f)
}

/// Renders the scene file `scene` through the command line with `args`, writing `STEM.exr` and
/// its statistics `STEM.json`, and asserts that it succeeded (showing its stderr otherwise):
/// the statistics JSON and the image's pixels.
pub fn render_file(scene: &Path, stem: &Path, args: &[&str]) -> (serde_json::Value, Vec<DVec3>) {
    let (exr, json) = (stem.with_extension("exr"), stem.with_extension("json"));
    let mut all: Vec<&std::ffi::OsStr> = vec!["render".as_ref(), scene.as_ref(), "-o".as_ref()];
    all.extend([exr.as_os_str(), "--stats-json".as_ref(), json.as_os_str()]);
    all.extend(args.iter().map(std::ffi::OsStr::new));
    run_ok(all);
    let stats = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    (stats, read_part(&exr).unwrap().film.pixels)
}

/// Renders `scene` (TOML text) with `args` through the command line; the statistics JSON.
pub fn render_stats(scene: &str, args: &[&str]) -> serde_json::Value {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, scene).unwrap();
    render_file(&path, &dir.path().join("image"), args).0
}

/// A glass sphere on a floor under a point light at 32 x 24 pixels: small enough that a pass
/// takes a fraction of a second, for the command-line tests.
pub const SMALL_SCENE: &str = r#"
[camera]
eye = [0.0, 2.0, 5.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov_y = 40.0
width = 32
height = 24

[materials.white]
type = "diffuse"
albedo = [0.5, 0.5, 0.5]

[materials.glass]
type = "glass"
ior = 1.5

[[lights]]
type = "point"
position = [0.0, 4.0, 0.0]
intensity = [10.0, 10.0, 10.0]

[[shapes]]
type = "quad"
corner = [-2.0, 0.0, 2.0]
edge_u = [4.0, 0.0, 0.0]
edge_v = [0.0, 0.0, -4.0]
material = "white"

[[shapes]]
type = "sphere"
center = [0.0, 1.0, 0.0]
radius = 0.5
segments = 32
material = "glass"
"#;

/// `photondiff reference` options for a reference made in a moment, for tests that check what
/// the command writes rather than how little noise it has: 2^17 paths of each kind and the
/// coarsest direct-light grids whose halves still differ.
pub const QUICK_REFERENCE: [&str; 6] = [
    "--light-paths",
    "131072",
    "--caustic-paths",
    "131072",
    "--direct-grids",
    "1,2",
];

/// Runs photondiff with `args` and checks that it succeeded (its standard error the message
/// where it did not); its output.
pub fn run_ok<S: AsRef<std::ffi::OsStr>>(
    args: impl IntoIterator<Item = S>,
) -> std::process::Output {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_photondiff"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Waits for `child` (a process the test started) at most `limit`: its exit status, or `None`
/// once it has been killed (by its handle, nothing else) for running past the limit, so that a
/// hang fails the test instead of holding the whole suite.
pub fn wait_at_most(
    child: &mut std::process::Child,
    limit: std::time::Duration,
) -> Option<std::process::ExitStatus> {
    let start = std::time::Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return Some(status);
        }
        if start.elapsed() > limit {
            child.kill().unwrap();
            child.wait().unwrap();
            return None;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

/// The variable that lets a test which needs a real component (Chromium, a Slurm cluster) pass
/// without it where the component cannot be installed (no root, no password-less sudo).
pub const SKIP_COMPONENTS: &str = "PHOTONDIFF_SKIP_COMPONENTS";

/// A component a test needs cannot be had here (`why`): the test fails, saying so, unless
/// [`SKIP_COMPONENTS`] is set to 1, when it is skipped (returns) with the reason on stderr. A
/// test that passed silently without its component could not fail.
pub fn unavailable(why: &str) {
    if std::env::var(SKIP_COMPONENTS).is_ok_and(|v| v == "1") {
        eprintln!("SKIPPED ({SKIP_COMPONENTS}=1): {why}");
        return;
    }
    panic!("{why}; set {SKIP_COMPONENTS}=1 to skip this test where it cannot be installed");
}

/// A closed sphere of radius 1 at the origin, of material `material` (its TOML fields, e.g.
/// `type = "diffuse"\nalbedo = [0.95, 0.95, 0.95]`), with a point light of 10 W/sr and the
/// camera inside: light that never leaves, for the paths' caps.
pub fn closed_sphere(material: &str, segments: u32) -> String {
    format!(
        "[camera]\neye = [0.0, 0.0, 0.5]\nlook_at = [0.0, 0.0, -1.0]\nup = [0.0, 1.0, 0.0]\n\
         fov_y = 60.0\nwidth = 8\nheight = 6\n[materials.w]\n{material}\n[[lights]]\n\
         type = \"point\"\nposition = [0.3, 0.2, -0.1]\nintensity = [10.0, 10.0, 10.0]\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\n\
         material = \"w\"\nsegments = {segments}\n"
    )
}

/// The caustic map of `photons` stored photons (default options otherwise, seed 0) of `scene`.
pub fn caustic_map(
    scene: &photondiff::scene::Scene,
    embree: &photondiff::embree::Scene,
    photons: usize,
) -> photondiff::photons::map::PhotonMap {
    use photondiff::photons::trace::{PhotonTracer, StopRule};
    use photondiff::photons::{emission::Emitter, map::PathClass, options::PhotonOptions};
    let options = PhotonOptions {
        caustic_photons: photons,
        ..PhotonOptions::default()
    };
    let tracer = PhotonTracer::new(scene, embree, &options);
    let emitter = Emitter::caustic(scene, photons, options.overlap, 0);
    let hidden = indicatif::ProgressBar::hidden();
    let (map, _) = tracer
        .build_map(
            &emitter,
            PathClass::Caustic,
            StopRule::Stored(photons),
            &hidden,
        )
        .unwrap();
    map
}
