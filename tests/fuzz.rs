//! Fuzzing the inputs: random bytes as scene files and mesh files, and random structured
//! scenes (with hostile numbers) through load, Embree and a tiny render. No input may panic or
//! abort: each gives an image or a clear error.

use photondiff::embree::Device;
use photondiff::estimate::RadianceEstimator;
use photondiff::estimate::{EstimatorKind, EstimatorSettings};
use photondiff::photons::options::PhotonOptions;
use photondiff::render::stats::Stats;
use photondiff::render::trace_photon_maps;
use photondiff::render::{render, RenderOptions};
use photondiff::scene::file::parse_scene;
use photondiff::scene::mesh_file::load_mesh;
use proptest::prelude::*;
use std::path::Path;

/// A number in `[lo, hi)` most of the time, and now and then one that breaks careless code.
fn num(lo: f64, hi: f64) -> impl Strategy<Value = String> {
    prop_oneof![
        120 => (lo..hi).prop_map(|x| format!("{x:.3}")),
        1 => Just("0.0".to_string()),
        1 => Just("-1.0".to_string()),
        1 => Just("nan".to_string()),
        1 => Just("inf".to_string()),
        1 => Just("-inf".to_string()),
        1 => Just("1e30".to_string()),
        1 => Just("1e-30".to_string()),
    ]
}

fn number() -> impl Strategy<Value = String> {
    num(-5.0, 5.0)
}

fn vec3() -> impl Strategy<Value = String> {
    (number(), number(), number()).prop_map(|(a, b, c)| format!("[{a}, {b}, {c}]"))
}

fn colour() -> impl Strategy<Value = String> {
    (num(0.0, 1.0), num(0.0, 1.0), num(0.0, 1.0)).prop_map(|(a, b, c)| format!("[{a}, {b}, {c}]"))
}

fn size() -> impl Strategy<Value = String> {
    prop_oneof![
        20 => (1u32..12).prop_map(|n| n.to_string()),
        1 => Just("0".to_string()),
        1 => Just("-3".to_string()),
        1 => Just("99999".to_string()),
    ]
}

prop_compose! {
    fn camera()(eye in vec3(), look in vec3(), up in vec3(), fov in num(5.0, 120.0), w in size(), h in size()) -> String {
        format!("[camera]\neye = {eye}\nlook_at = {look}\nup = {up}\nfov_y = {fov}\nwidth = {w}\nheight = {h}\n")
    }
}

prop_compose! {
    fn materials()(albedo in colour(), ior in num(1.0, 2.5), refl in colour()) -> String {
        format!(
            "[materials.white]\ntype = \"diffuse\"\nalbedo = {albedo}\n\
             [materials.glass]\ntype = \"glass\"\nior = {ior}\n\
             [materials.mirror]\ntype = \"mirror\"\nreflectance = {refl}\n"
        )
    }
}

prop_compose! {
    fn light()(kind in 0..3usize, p in vec3(), i in (num(0.0, 50.0), num(0.0, 50.0), num(0.0, 50.0)).prop_map(|(a, b, c)| format!("[{a}, {b}, {c}]")), cone in num(1.0, 90.0), d in vec3(), e in vec3()) -> String {
        let body = match kind {
            0 => format!("type = \"point\"\nposition = {p}\nintensity = {i}"),
            1 => format!("type = \"spot\"\nposition = {p}\ndirection = {d}\nintensity = {i}\ncone_angle = {cone}"),
            _ => format!("type = \"quad\"\ncorner = {p}\nedge_u = {d}\nedge_v = {e}\nradiance = {i}"),
        };
        format!("[[lights]]\n{body}\n")
    }
}

prop_compose! {
    fn shapes()(
        corner in vec3(), eu in vec3(), ev in vec3(), centre in vec3(), radius in num(0.1, 2.0),
        segments in prop_oneof![Just(3u32), Just(8), Just(2), Just(16)],
        material in prop_oneof![6 => Just("white"), 6 => Just("glass"), 6 => Just("mirror"), 1 => Just("nothing")],
    ) -> String {
        format!(
            "[[shapes]]\ntype = \"quad\"\ncorner = {corner}\nedge_u = {eu}\nedge_v = {ev}\nmaterial = \"white\"\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = {centre}\nradius = {radius}\nmaterial = \"{material}\"\nsegments = {segments}\n"
        )
    }
}

prop_compose! {
    /// A scene file from plausible pieces with hostile values.
    fn scene_text()(
        camera in camera(), materials in materials(), light in light(), shapes in shapes(),
        extra in prop_oneof![18 => Just(""), 1 => Just("bogus = 1\n"), 1 => Just("[camera]\n")],
    ) -> String {
        format!("{camera}{materials}{light}{shapes}{extra}")
    }
}

prop_compose! {
    /// Two placements of one small glass mesh (a tetrahedron, `ball.obj`), with hostile
    /// transforms: a scale of 1e-30 made Embree abort on the rays mapped into the instance.
    fn instances()(
        t in vec3(), r in vec3(),
        scale in prop_oneof![
            3 => num(0.1, 3.0),
            1 => num(-3.0, -0.1),
            1 => (num(-3.0, 3.0), num(-3.0, 3.0), num(-3.0, 3.0)).prop_map(|(a, b, c)| format!("[{a}, {b}, {c}]")),
            1 => prop_oneof![Just("1e-30"), Just("1e-20"), Just("[1.0, 1e-30, 1.0]"), Just("1e17")].prop_map(String::from),
        ],
    ) -> String {
        format!(
            "[meshes.ball]\nfile = \"ball.obj\"\n\
             [[instances]]\nmesh = \"ball\"\nmaterial = \"glass\"\ntranslate = {t}\nrotate = {r}\nscale = {scale}\n\
             [[instances]]\nmesh = \"ball\"\nmaterial = \"white\"\n"
        )
    }
}

/// A folder holding `ball.obj`, the instanced mesh of [`instances`].
fn mesh_folder() -> &'static Path {
    static DIR: std::sync::OnceLock<tempfile::TempDir> = std::sync::OnceLock::new();
    DIR.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("ball.obj"),
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n",
        )
        .unwrap();
        dir
    })
    .path()
}

/// Loads, builds and renders `text` at its (tiny) size with photon maps, and tells whether it
/// rendered; panics only on a bug. `FUZZ_DEBUG=1` prints the first line of each load error.
fn load_and_render(text: &str) -> bool {
    let scene = match parse_scene(text, mesh_folder()) {
        Ok(scene) => scene,
        Err(e) => {
            if std::env::var_os("FUZZ_DEBUG").is_some() {
                eprintln!("ERR {}", e.lines().next().unwrap_or(""));
            }
            return false;
        }
    };
    let c = &scene.camera;
    assert!(c.width >= 1 && c.height >= 1 && c.width as u64 * c.height as u64 <= 99_999 * 99_999);
    if c.width as u64 * c.height as u64 > 4096 {
        return false; // a valid but large image: nothing new to learn from rendering it
    }
    let device = Device::new().unwrap();
    let Ok(embree) = scene.build_embree(&device) else {
        return false;
    };
    let options = PhotonOptions {
        global_photons: 200,
        caustic_photons: 50,
        ..PhotonOptions::default()
    };
    let mut stats = Stats::default();
    let maps = trace_photon_maps(&scene, &embree, &options, 1, false, &mut stats).unwrap();
    // Every estimate over photon maps, unnamed: a new one is fuzzed too.
    for kind in EstimatorKind::over_maps() {
        let settings = EstimatorSettings {
            kind,
            k: 10,
            max_radius: options.limits(&scene).max_radius,
            ms_grid: 2,
            ellipse_vertices: 8,
            gather_rays: 0,
            gather_near: 0.0,
        };
        let estimators = maps.estimators(&settings);
        let refs: Vec<&dyn RadianceEstimator> = estimators.iter().map(|e| e.as_ref()).collect();
        let film = render(
            &scene,
            &embree,
            &refs,
            &RenderOptions::default().with_threads(1),
            &mut stats,
        )
        .unwrap();
        assert!(
            film.pixels
                .iter()
                .all(|p| p.is_finite() && p.min_element() >= 0.0),
            "{kind:?}: {text}"
        );
    }
    true
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn random_bytes_are_never_a_panic(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        let text = String::from_utf8_lossy(&bytes);
        let _ = parse_scene(&text, Path::new("."));
    }

    #[test]
    fn random_structured_scenes_give_an_image_or_an_error(text in scene_text()) {
        let _ = load_and_render(&text);
    }

    #[test]
    fn random_instances_give_an_image_or_an_error(scene in scene_text(), placed in instances()) {
        let _ = load_and_render(&format!("{scene}{placed}"));
    }

    #[test]
    fn random_mesh_files_give_a_mesh_or_an_error(
        bytes in prop::collection::vec(any::<u8>(), 0..300),
        header in prop_oneof![
            Just(""),
            Just("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
            Just("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"),
            Just("ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"),
        ],
        ext in prop_oneof![Just("obj"), Just("ply")],
    ) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(format!("m.{ext}"));
        let mut content = header.as_bytes().to_vec();
        content.extend_from_slice(&bytes);
        std::fs::write(&path, &content).unwrap();
        if let Ok(mesh) = load_mesh(&path) {
            prop_assert!(mesh.validate().is_ok());
        }
    }
}

#[test]
fn a_structured_scene_that_renders() {
    // The generator's pieces can make a valid scene: make sure one renders end to end.
    let text = "[camera]\neye = [0.0, 2.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\nup = [0.0, 1.0, 0.0]\nfov_y = 40.0\nwidth = 8\nheight = 6\n\
        [materials.white]\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n\
        [materials.glass]\ntype = \"glass\"\nior = 1.5\n\
        [[lights]]\ntype = \"point\"\nposition = [0.0, 3.0, 0.0]\nintensity = [10.0, 10.0, 10.0]\n\
        [[shapes]]\ntype = \"quad\"\ncorner = [-2.0, 0.0, 2.0]\nedge_u = [4.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -4.0]\nmaterial = \"white\"\n\
        [[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 1.0, 0.0]\nradius = 0.5\nmaterial = \"glass\"\nsegments = 8\n";
    assert!(parse_scene(text, Path::new(".")).is_ok());
    assert!(load_and_render(text));
}

#[test]
fn the_structured_generator_reaches_the_renderer() {
    // Fuzzing that only ever meets parse errors tests little: count what renders.
    use proptest::strategy::ValueTree;
    use proptest::test_runner::TestRunner;
    let mut runner = TestRunner::deterministic();
    let strategy = scene_text();
    let rendered = (0..300)
        .filter(|_| load_and_render(&strategy.new_tree(&mut runner).unwrap().current()))
        .count();
    assert!(
        rendered >= 20,
        "only {rendered} of 300 generated scenes rendered"
    );
}
