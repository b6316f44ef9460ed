//! Memory you can see and control: the scene's meshes are shared with Embree (not copied), the
//! statistics account for meshes, Embree's BVH and the process's peak, and the BVH settings
//! change memory but not what the rays hit.

mod common;
use common::render_file;

use photondiff::embree::Device;
use photondiff::scene::file::load_scene;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The canonical scene at 96 x 72, plus a mesh file (a PLY written by photondiff) so that a
/// loaded mesh is part of it.
fn scene(dir: &Path) -> PathBuf {
    scene_with_ball(dir, 64)
}

/// [`scene`] with a ball of about `segments`^2 triangles.
fn scene_with_ball(dir: &Path, segments: u32) -> PathBuf {
    let mesh = photondiff::scene::shapes::sphere(glam::DVec3::ZERO, 0.3, segments);
    let ply = dir.join("ball.ply");
    photondiff::scene::mesh_file::ply::write::write_binary(
        &mesh,
        std::io::BufWriter::new(std::fs::File::create(&ply).unwrap()),
    )
    .unwrap();
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/caustic-sphere.toml"
    ))
    .unwrap()
    .replace("width = 640", "width = 96")
    .replace("height = 480", "height = 72")
        + "\n[[shapes]]\ntype = \"mesh\"\nfile = \"ball.ply\"\nmaterial = \"floor\"\n";
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn the_embree_scene_shares_the_meshes_instead_of_copying_them() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load_scene(&scene(dir.path())).unwrap();
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    // Loaded and generated meshes are padded for Embree, so the Embree scene holds a second
    // reference to the same buffers; a copy would leave the count at 1.
    for m in &scene.meshes {
        if m.name.contains("quad light") {
            continue;
        }
        assert_eq!(Arc::strong_count(&m.mesh), 2, "{}", m.name);
    }
    drop(embree);
    assert!(scene.meshes.iter().all(|m| Arc::strong_count(&m.mesh) == 1));
}

/// Renders `scene` with `extra` options, writing NAME.exr and NAME.json beside it; returns the
/// statistics JSON and the pixels.
fn render(scene: &Path, name: &str, extra: &[&str]) -> (serde_json::Value, Vec<glam::DVec3>) {
    let mut args = vec!["-q", "--photons", "5000", "--caustic-photons", "5000"];
    args.extend_from_slice(extra);
    render_file(scene, &scene.parent().unwrap().join(name), &args)
}

#[test]
fn statistics_account_for_meshes_and_the_bvh_and_bvh_settings_keep_the_hits() {
    let dir = tempfile::tempdir().unwrap();
    let path = scene(dir.path());
    let scene = load_scene(&path).unwrap();
    let triangles: u64 = scene
        .meshes
        .iter()
        .map(|m| m.mesh.triangles.len() as u64)
        .sum();
    let mesh_bytes: u64 = scene
        .meshes
        .iter()
        .map(|m| {
            let normals = m.mesh.normals.as_ref().map_or(0, Vec::len);
            12 * (m.mesh.positions.len() + normals + m.mesh.triangles.len()) as u64
        })
        .sum();
    let (high, high_pixels) = render(&path, "high", &["--bvh-quality", "high"]);
    let (compact, compact_pixels) = render(
        &path,
        "compact",
        &["--bvh-quality", "medium", "--bvh-compact"],
    );
    let (default, default_pixels) = render(&path, "default", &[]);
    let get = |s: &serde_json::Value, k: &str| s["memory"][k].as_f64().unwrap();
    // The settings each run built with: the default is Embree's binned SAH (`medium`).
    let settings = |s: &serde_json::Value| s["memory"]["bvh"].clone();
    let expected = |quality: &str, compact: bool| serde_json::json!({"quality": quality, "compact": compact, "robust": false});
    assert_eq!(settings(&default), expected("medium", false));
    assert_eq!(settings(&high), expected("high", false));
    assert_eq!(settings(&compact), expected("medium", true));
    for s in [&high, &compact, &default] {
        assert_eq!(get(s, "triangles") as u64, triangles);
        assert_eq!(get(s, "mesh_bytes") as u64, mesh_bytes);
        // Embree's BVH for 2.6e5 triangles takes megabytes, and its build needs at least that.
        assert!(get(s, "bvh_bytes") > 16.0 * triangles as f64, "{s}");
        assert!(get(s, "bvh_build_peak_bytes") >= get(s, "bvh_bytes"));
        assert!(get(s, "peak_resident_bytes") >= get(s, "mesh_bytes") + get(s, "bvh_bytes"));
        // What the process holds of it: resident pages added by the build, no more than the
        // peak holds beside the meshes, and at most what the build added at its peak.
        let resident = get(s, "bvh_resident_bytes");
        assert!(resident > 8.0 * triangles as f64, "{s}");
        assert!(get(s, "peak_resident_bytes") >= get(s, "mesh_bytes") + resident);
        assert!(get(s, "bvh_build_resident_peak_bytes") >= resident, "{s}");
        let per_triangle = get(s, "peak_resident_bytes") / triangles as f64;
        assert!((get(s, "peak_bytes_per_triangle") - per_triangle).abs() < 1e-6 * per_triangle);
    }
    // The compact, medium-quality BVH is smaller and builds with less memory...
    assert!(get(&compact, "bvh_bytes") < 0.75 * get(&high, "bvh_bytes"));
    assert!(get(&compact, "bvh_build_peak_bytes") < get(&high, "bvh_build_peak_bytes"));
    // ...and every BVH finds the same hits: the same image.
    assert_same_image(&high_pixels, &compact_pixels, "compact");
    assert_same_image(&high_pixels, &default_pixels, "default");
}

/// `pixels` (named `name`) are `reference`'s to a millionth of its total.
fn assert_same_image(reference: &[glam::DVec3], pixels: &[glam::DVec3], name: &str) {
    let total: f64 = reference.iter().map(|p| p.element_sum()).sum::<f64>();
    let diff: f64 = reference
        .iter()
        .zip(pixels)
        .map(|(a, b)| (*a - *b).abs().element_sum())
        .sum();
    assert!(
        diff <= 1e-6 * total,
        "{name}: images differ by {diff} (sum {total})"
    );
}

/// A compact and robust BVH renders, and as the robust one alone does. Debian's Embree 3.13.5
/// loops forever on the coherent shadow packets of such a scene, so photondiff sends its
/// packets there without the coherent flag; the render is given two minutes (it takes a
/// fraction of a second) and killed after them, so that a regression fails instead of hanging.
#[test]
fn a_compact_and_robust_bvh_renders_as_the_robust_one_does() {
    let dir = tempfile::tempdir().unwrap();
    let path = scene(dir.path());
    let exr = dir.path().join("compact-robust.exr");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_photondiff"))
        .arg("render")
        .arg(&path)
        .args(["-q", "--photons", "5000", "--caustic-photons", "5000"])
        .args(["--bvh-compact", "--bvh-robust", "-o"])
        .arg(&exr)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let status = common::wait_at_most(&mut child, std::time::Duration::from_secs(120))
        .expect("a compact and robust BVH: the render did not finish in two minutes");
    assert!(status.success());
    let compact = photondiff::render::part::read_part(&exr)
        .unwrap()
        .film
        .pixels;
    let (_, robust) = render(&path, "robust", &["--bvh-robust"]);
    assert_same_image(&robust, &compact, "compact and robust");
}

/// Issue 12's target: a 10M-triangle mesh renders with `--bvh-quality medium` within 100 bytes
/// per unique triangle at peak (meshes, BVH, photon maps, film and all). From 4M unique
/// triangles the BVH is compact unless `--no-bvh-compact` says otherwise; Embree's ordinary
/// BVH peaks at about twice the memory there.
#[test]
fn a_ten_million_triangle_mesh_takes_at_most_100_bytes_a_triangle_at_peak() {
    let dir = tempfile::tempdir().unwrap();
    let path = scene_with_ball(dir.path(), 3200);
    let (auto, _) = render(&path, "auto", &["--bvh-quality", "medium"]);
    let (ordinary, _) = render(&path, "ordinary", &["--no-bvh-compact"]);
    // In a folder of its own: `scene` writes its own ball.ply and scene.toml.
    let small_dir = dir.path().join("small");
    std::fs::create_dir(&small_dir).unwrap();
    let (small, _) = render(&scene(&small_dir), "small", &[]);
    let get = |s: &serde_json::Value, k: &str| s["memory"][k].as_f64().unwrap();
    let triangles = get(&auto, "triangles");
    assert!(triangles >= 1e7, "{triangles} triangles");
    assert!(triangles as u64 >= photondiff::embree::COMPACT_FROM_TRIANGLES);
    assert_eq!(auto["memory"]["bvh"]["compact"], true);
    assert_eq!(ordinary["memory"]["bvh"]["compact"], false);
    assert_eq!(small["memory"]["bvh"]["compact"], false, "a small scene");
    let per_triangle = get(&auto, "peak_bytes_per_triangle");
    assert!(
        per_triangle <= 100.0,
        "{per_triangle} bytes a triangle at peak"
    );
    assert!(
        get(&ordinary, "peak_resident_bytes") > 1.5 * get(&auto, "peak_resident_bytes"),
        "{ordinary} against {auto}"
    );
    // The BVH as the process holds it is about half the ordinary one's. Embree's own count of
    // what it allocated (its memory monitor: blocks reserved, not written) said 560 MB and
    // 573 MB for an 8.4M-triangle sphere, where the build kept 296 MB and 575 MB resident.
    let resident = |s: &serde_json::Value| get(s, "bvh_resident_bytes");
    assert!(
        resident(&auto) < 0.7 * resident(&ordinary),
        "{auto} against {ordinary}"
    );
    assert!(get(&auto, "peak_resident_bytes") >= get(&auto, "mesh_bytes") + resident(&auto));
}

/// `photons` and `reference` take `render`'s BVH options, build the BVH they ask for (as their
/// memory line says), and what they trace does not depend on them: the same photon maps to the
/// byte, the same reference to rounding.
#[test]
fn photons_and_reference_take_the_bvh_options_and_trace_the_same() {
    let dir = tempfile::tempdir().unwrap();
    let path = scene(dir.path());
    // The BVH each run built, from its memory line (`... Embree BVH 0.1 MB (high, compact;
    // build peak ...)`), which only a run without --quiet prints.
    let run = |args: &[&str]| {
        let out = common::run_ok(args.iter().copied().chain([path.to_str().unwrap()]));
        let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
        let memory = stderr
            .lines()
            .find(|l| l.starts_with("memory: peak resident "))
            .unwrap_or_else(|| panic!("no memory line in {stderr}"));
        let settings = memory.split("Embree BVH ").nth(1).unwrap();
        settings[settings.find('(').unwrap() + 1..settings.find(';').unwrap()].to_string()
    };
    let file = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let options = ["--bvh-quality", "high", "--bvh-compact"];
    let (plain, other) = (file("plain.pdm"), file("other.pdm"));
    assert_eq!(run(&["photons", "-o", &plain]), "medium");
    assert_eq!(
        run(&[&["photons", "-o", &other][..], &options].concat()),
        "high, compact"
    );
    let (a, b) = (
        std::fs::read(&plain).unwrap(),
        std::fs::read(&other).unwrap(),
    );
    if photondiff::embree::API_VERSION == 3 {
        assert!(a == b);
    } else {
        // Embree 4's compact BVH answers a few rays in a million with the other triangle of a
        // shared edge (its 16-wide and single-ray queries agree with each other, not with the
        // ordinary BVH's; Embree 3's 16-wide compact queries happen to agree with the ordinary
        // BVH's): a photon path may end otherwise and the maps shift by an emission, with the
        // same photon counts (the same file size) and the same settings.
        assert_eq!(a.len(), b.len(), "photon counts differ");
        let header = |m: &[u8]| {
            m[..16 + u32::from_le_bytes(m[12..16].try_into().unwrap()) as usize].to_vec()
        };
        assert!(header(&a) == header(&b));
    }
    let paths = ["--light-paths", "131072", "--caustic-paths", "131072"];
    let (plain, other) = (file("plain.exr"), file("other.exr"));
    assert_eq!(
        run(&[&["reference", "-o", &plain][..], &paths].concat()),
        "medium"
    );
    assert_eq!(
        run(&[&["reference", "-o", &other][..], &paths, &options].concat()),
        "high, compact"
    );
    let pixels = |f: &str| {
        photondiff::render::part::read_part(Path::new(f))
            .unwrap()
            .film
            .pixels
    };
    let (a, b) = (pixels(&plain), pixels(&other));
    assert!(
        a.iter().any(|p| p.x > 0.0),
        "a black reference proves nothing"
    );
    // To rounding: a ray through a shared edge may hit either triangle, and the BVHs need not
    // pick the same one (one pixel of 6,912 differed by 2e-7 of its value).
    let worst = a
        .iter()
        .zip(&b)
        .map(|(p, q)| (*p - *q).abs().max_element() / p.max_element().max(1e-12))
        .fold(0.0, f64::max);
    if photondiff::embree::API_VERSION == 3 {
        assert!(
            worst < 1e-6,
            "the references differ by {worst} of a pixel's value"
        );
    } else {
        // Embree 4's compact BVH (see the photon maps above): a light path that took the other
        // triangle of a shared edge moves its pixels' values; the image as a whole stays put.
        let mean = a.iter().map(|p| p.element_sum()).sum::<f64>() / (3 * a.len()) as f64;
        let rms = (a
            .iter()
            .zip(&b)
            .map(|(p, q)| (*p - *q).length_squared())
            .sum::<f64>()
            / (3 * a.len()) as f64)
            .sqrt();
        println!("worst pixel {worst}, relRMSE {}", rms / mean);
        assert!(
            rms / mean < 1e-4,
            "the references differ by relRMSE {} (worst pixel {worst})",
            rms / mean
        );
    }
}

/// What a stored photon costs at the peak of `photondiff photons`: the slope of the peak
/// resident memory between 20,000 and 400,000 caustic photons stays within the 250 bytes a
/// photon that the memory warning assumes (`cli::PEAK_BYTES_PER_PHOTON`; 179 measured at stop
/// 47, 690 before), and above the 84 bytes the finished map alone holds (the cover test's
/// table 52, its flux 16, its direction and radius 16): a slope below that would mean the peak
/// was taken before the map was built.
#[test]
fn a_stored_photon_takes_at_most_250_bytes_at_the_peak_of_photons() {
    let dir = tempfile::tempdir().unwrap();
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/caustic-sphere.toml");
    let peak = |n: u64| {
        let (maps, json) = (dir.path().join("maps.pdm"), dir.path().join("stats.json"));
        common::run_ok([
            "photons",
            scene,
            "--caustic-photons",
            &n.to_string(),
            "--photons",
            "0",
            "-q",
            "-o",
            maps.to_str().unwrap(),
            "--stats-json",
            json.to_str().unwrap(),
        ]);
        let stats: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        assert_eq!(stats["photon_maps"][0]["stored"], n, "{stats}");
        stats["memory"]["peak_resident_bytes"].as_f64().unwrap()
    };
    let (small, large) = (peak(20_000), peak(400_000));
    let per_photon = (large - small) / 380_000.0;
    assert!(
        (84.0..=250.0).contains(&per_photon),
        "{per_photon} bytes a photon at peak ({small} -> {large})"
    );
}

/// Photons leave a quad light from its own surface, which a robust BVH reports hit at `t = 0`
/// (the ordinary one does not): every path ended there, and `--bvh-robust` stored no photon
/// in a box lit by a quad light. The maps of the robust and the ordinary BVH are the same to
/// the byte.
#[test]
fn a_robust_bvh_traces_a_quad_lights_photons_as_the_ordinary_one_does() {
    let dir = tempfile::tempdir().unwrap();
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-glass.toml");
    let photons = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let mut args = vec![
            "photons",
            scene,
            "-q",
            "--threads",
            "2",
            "--photons",
            "3000",
        ];
        args.extend(["--caustic-photons", "2000", "-o", out.to_str().unwrap()]);
        common::run_ok(args.iter().chain(extra));
        std::fs::read(out).unwrap()
    };
    let ordinary = photons("ordinary.bin", &[]);
    let robust = photons("robust.bin", &["--bvh-robust"]);
    // Two maps' worth of photons (80 bytes each), not an empty file's few hundred bytes.
    assert!(ordinary.len() > 5000 * 80, "{} bytes", ordinary.len());
    assert!(robust == ordinary, "the robust BVH's maps differ");
}

/// What a pixel costs at the peak of a render: the slope of the peak resident memory from
/// 1000 x 1000 to 2000 x 2000 pixels stays within what the image checks assume
/// (`PEAK_BYTES_PER_PIXEL`, 175; 167 measured at stop 57, where 150 was assumed and a tile
/// passed the check and aborted), and above the 72 bytes of the film and the running sums
/// (three `f64` RGB images): a slope below that would mean the peak was taken before the
/// image was.
#[test]
fn a_pixel_takes_at_most_what_the_image_checks_assume() {
    let dir = tempfile::tempdir().unwrap();
    let peak = |side: u32| {
        let scene = dir.path().join("scene.toml");
        std::fs::write(
            &scene,
            format!(
                "[camera]\neye = [0.0, 2.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\n\
                 up = [0.0, 1.0, 0.0]\nfov_y = 40.0\nwidth = {side}\nheight = {side}\n\
                 [materials.white]\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n\
                 [[lights]]\ntype = \"point\"\nposition = [0.0, 4.0, 0.0]\n\
                 intensity = [10.0, 10.0, 10.0]\n[[shapes]]\ntype = \"quad\"\n\
                 corner = [-2.0, 0.0, 2.0]\nedge_u = [4.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -4.0]\n\
                 material = \"white\"\n"
            ),
        )
        .unwrap();
        let json = dir.path().join("stats.json");
        common::run_ok([
            "render",
            scene.to_str().unwrap(),
            "--estimator",
            "direct",
            "-q",
            "--footprint-shadow-rays",
            "1",
            "-o",
            dir.path().join("x.exr").to_str().unwrap(),
            "--stats-json",
            json.to_str().unwrap(),
        ]);
        let stats: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        stats["memory"]["peak_resident_bytes"].as_f64().unwrap()
    };
    let (small, large) = (peak(1000), peak(2000));
    let per_pixel = (large - small) / 3e6;
    let assumed = photondiff::render::film::PEAK_BYTES_PER_PIXEL as f64;
    assert!(
        (72.0..=assumed).contains(&per_pixel),
        "{per_pixel} bytes a pixel at peak ({small} -> {large})"
    );
}

/// Runs `photondiff` with `args` under an address-space limit of `kib` KiB (`ulimit -v`).
fn run_limited(kib: u64, args: &str) -> std::process::Output {
    let exe = env!("CARGO_BIN_EXE_photondiff");
    std::process::Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v {kib}; exec '{exe}' {args}"))
        .output()
        .unwrap()
}

/// The canonical scene at `width` x `height` with a second, diffuse sphere of 4,257,122
/// triangles (2000 segments): its ordinary BVH needs about 1 GB of address space, its compact
/// one about 650 MB.
fn scene_with_big_sphere(dir: &Path, width: u32, height: u32) -> PathBuf {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/caustic-sphere.toml"
    ))
    .unwrap()
    .replace("width = 640", &format!("width = {width}"))
    .replace("height = 480", &format!("height = {height}"))
        + "\n[[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.3, 0.0]\nradius = 0.3\n\
           material = \"floor\"\nsegments = 2000\n";
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, text).unwrap();
    scene
}

/// A BVH that cannot be built in the memory the process may use is a clear error that says
/// what needs less, and what it says works. Under an 800 MB address-space limit the ordinary
/// BVH of a 4.3M-triangle sphere runs out (Embree's "error 4: out of memory" was all a user
/// read; it needs about 1 GB of address space here), and the compact one it advises fits
/// (about 650 MB).
#[test]
fn a_bvh_beyond_the_process_memory_is_a_clear_error_and_its_advice_fits() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene_with_big_sphere(dir.path(), 96, 72);
    let render = |bvh: &str| {
        run_limited(
            800_000,
            &format!(
                "render '{}' -o '{}' -q --estimator direct --threads 2 {bvh}",
                scene.display(),
                dir.path().join("x.exr").display()
            ),
        )
    };
    let out = render("--no-bvh-compact");
    assert_eq!(
        String::from_utf8_lossy(&out.stderr),
        format!(
            "photondiff: error: {}: building the BVH of 4257122 triangles ran out of memory \
             within the 0.82 GB this process may use; --bvh-compact builds one in about half \
             the memory\n",
            scene.display()
        )
    );
    assert_eq!(out.status.code(), Some(1));
    let out = render("--bvh-compact");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// An image that fits beside the scene but not beside its BVH is refused once the BVH is
/// built, before the photons and the render: the production mesh at 2400 x 1800 under a 1.6 GB
/// limit passed the check made when the scene was read and aborted 24 s later. Here a 4.3M
/// triangle sphere's compact BVH leaves about 0.3 GB of a 1 GB limit, the image needs 0.5.
#[test]
fn an_image_is_checked_again_with_the_bvh_held() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene_with_big_sphere(dir.path(), 2000, 1500);
    let out = run_limited(
        1_000_000,
        &format!(
            "render '{}' -o '{}' -q --estimator direct --threads 2 --bvh-compact",
            scene.display(),
            dir.path().join("x.exr").display()
        ),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    let left: f64 = stderr
        .strip_prefix(&format!(
            "photondiff: error: {}: camera: 2000 x 1500 pixels need about 0.53 GB to render \
             (about 175 bytes each), more than the ",
            scene.display()
        ))
        .and_then(|rest| {
            rest.strip_suffix(
                " GB left of the 1.0 GB this process may use (with the scene and its BVH held)\n",
            )
        })
        .unwrap_or_else(|| panic!("{stderr}"))
        .parse()
        .unwrap();
    assert!(left < 0.5, "{stderr}");
    assert_eq!(out.status.code(), Some(1));
}

/// A mesh file whose buffers cannot fit in the memory the process may use is refused, not
/// aborted: a 10M-triangle PLY under a 250 MB limit aborted with "memory allocation of
/// 61401636 bytes failed". A binary PLY's header gives the whole need at once; an OBJ's
/// buffers grow as it is read, and are refused when they can grow no more.
#[test]
fn a_mesh_beyond_the_process_memory_is_refused_with_what_it_needs() {
    let dir = tempfile::tempdir().unwrap();
    // 10,000,000 vertices (120 MB of positions) and two triangles, under a 100 MB limit.
    let vertices = 10_000_000u32;
    let ply = dir.path().join("points.ply");
    let mut data = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {vertices}\nproperty float x\n\
         property float y\nproperty float z\nelement face 2\n\
         property list uchar int vertex_indices\nend_header\n"
    )
    .into_bytes();
    for i in 0..vertices {
        for c in [i as f32 * 1e-6, (i % 7) as f32, 0.0] {
            data.extend_from_slice(&c.to_le_bytes());
        }
    }
    for face in [[0i32, 1, 2], [0, 2, 3]] {
        data.push(3);
        face.iter()
            .for_each(|k| data.extend_from_slice(&k.to_le_bytes()));
    }
    std::fs::write(&ply, &data).unwrap();
    drop(data);
    let out = run_limited(100_000, &format!("info '{}'", ply.display()));
    let stderr = String::from_utf8_lossy(&out.stderr);
    let prefix = format!(
        "photondiff: error: {}: its 10000000 vertices and 2 faces need 0.12 GB, more than the ",
        ply.display()
    );
    assert!(
        stderr.starts_with(&prefix)
            && stderr.ends_with(" GB left of the 0.10 GB this process may use\n"),
        "{stderr}"
    );
    assert_eq!(out.status.code(), Some(1));

    // 7,000,000 vertices of an OBJ: 112 MB of buffers (positions and their normals' slots),
    // under a 150 MB limit (about 90 MB left when the file is opened).
    let obj = dir.path().join("points.obj");
    let mut text = String::with_capacity(7_000_000 * 10);
    for i in 0..7_000_000u32 {
        text.push_str(if i % 2 == 0 { "v 0 0 0\n" } else { "v 1 0 0\n" });
    }
    text.push_str("f 1 2 3\n");
    std::fs::write(&obj, text).unwrap();
    let out = run_limited(150_000, &format!("info '{}'", obj.display()));
    let stderr = String::from_utf8_lossy(&out.stderr);
    let read: u64 = stderr
        .strip_prefix(&format!("photondiff: error: {}: line ", obj.display()))
        .and_then(|rest| {
            rest.split_once(": ")?
                .1
                .split_once(" vertices read; ")?
                .0
                .parse()
                .ok()
        })
        .unwrap_or_else(|| panic!("{stderr}"));
    assert!(read >= 1024, "{stderr}");
    assert!(
        stderr.contains(" vertices read; room for more would need ")
            && (stderr.ends_with(" GB this process may use\n")
                || stderr.ends_with(" kept for the run's small allocations\n")
                || stderr.ends_with(" GB, which the system refused\n")),
        "{stderr}"
    );
    assert_eq!(out.status.code(), Some(1));
}

/// One face of ten million corners (a thousand vertices on a circle, gone round ten thousand
/// times) under a 150 or 200 MB limit: the memory to read it and to triangulate it (its indices as
/// read, as numbers, as points in its plane, its triangles: about 360 MB) is checked before
/// it is taken, in a binary PLY and in an OBJ. Unchecked, both aborted ("memory allocation of 14336 bytes
/// failed").
#[test]
fn a_face_of_millions_of_corners_beyond_the_process_memory_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (n, corners) = (1000u32, 10_000_000u32);
    let circle = |i: u32| {
        let a = f64::from(i) / f64::from(n) * std::f64::consts::TAU;
        [a.cos() as f32, a.sin() as f32, 0.0]
    };
    let ply = dir.path().join("star.ply");
    let mut data = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {n}\nproperty float x\n\
         property float y\nproperty float z\nelement face 1\n\
         property list int int vertex_indices\nend_header\n"
    )
    .into_bytes();
    for i in 0..n {
        circle(i)
            .iter()
            .for_each(|c| data.extend_from_slice(&c.to_le_bytes()));
    }
    data.extend_from_slice(&corners.to_le_bytes());
    for k in 0..corners {
        data.extend_from_slice(&(k % n).to_le_bytes());
    }
    std::fs::write(&ply, &data).unwrap();
    drop(data);
    let obj = dir.path().join("star.obj");
    let mut text: String = (0..n)
        .map(|i| format!("v {} {} 0\n", circle(i)[0], circle(i)[1]))
        .collect();
    text.push('f');
    for k in 0..corners {
        text += &format!(" {}", k % n + 1);
    }
    text.push('\n');
    std::fs::write(&obj, text).unwrap();
    // The limits under which each aborted before its checks.
    for (path, kib, limit) in [(&ply, 150_000, "0.15 GB"), (&obj, 200_000, "0.20 GB")] {
        let out = run_limited(kib, &format!("info '{}'", path.display()));
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{stderr}");
        let message = stderr
            .strip_prefix(&format!("photondiff: error: {}: ", path.display()))
            .unwrap_or_else(|| panic!("{stderr}"));
        // Which check refuses depends on what the process has mapped by then (the face's 0.08
        // GB of corners fitted on one machine, and its 0.12 GB of triangles then did not): any
        // of them, saying what is left of the limit, never an abort.
        let at = if path == &ply { "" } else { "line 1001: " };
        assert!(
            message.starts_with(at) && message.contains(&format!(" GB left of the {limit}")),
            "{stderr}"
        );
    }
}

/// A scene file of 100,000 instances (10 MB of text) under a 300 MB limit: the memory its
/// parse takes is checked before it starts (it aborted, "memory allocation of 704 bytes
/// failed"); with room for it the same scene is read.
#[test]
fn a_scene_file_beyond_the_process_memory_is_refused_before_it_is_parsed() {
    let dir = tempfile::tempdir().unwrap();
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
               property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
               end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    std::fs::write(dir.path().join("tri.ply"), ply).unwrap();
    let mut text = String::from(
        "[camera]\neye = [0, 5, 10]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\nfov_y = 40\n\
         width = 16\nheight = 12\n[materials.white]\ntype = \"diffuse\"\n\
         albedo = [0.5, 0.5, 0.5]\n[[lights]]\ntype = \"point\"\nposition = [0, 4, 0]\n\
         intensity = [10, 10, 10]\n[meshes.tri]\nfile = \"tri.ply\"\n",
    );
    for k in 0..100_000 {
        text += &format!(
            "[[instances]]\nmesh = \"tri\"\nmaterial = \"white\"\nscale = 0.01\n\
             translate = [{}, 0, {}]\n",
            k % 300,
            k / 300
        );
    }
    let scene = dir.path().join("many.toml");
    std::fs::write(&scene, &text).unwrap();
    let out = run_limited(300_000, &format!("info '{}'", scene.display()));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    let need = text.len() as u64 * photondiff::scene::file::PARSE_BYTES_PER_BYTE;
    assert!(
        stderr.starts_with(&format!(
            "photondiff: error: {}: its {} bytes of text (about 48 bytes each while parsed) \
             need {:.2} GB, more than the ",
            scene.display(),
            text.len(),
            need as f64 / 1e9
        )),
        "{stderr}"
    );
    let out = run_limited(2_000_000, &format!("info '{}'", scene.display()));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && stdout.contains("100000"),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Caustic photons that cannot fit even at the least a stored one takes while its map is traced
/// (104 bytes) are refused before tracing, by `render` and `photons`: 2 * 10^7 under a 1.5 GB
/// limit traced for 15 s and aborted. A scene without caustics stores none, and is not refused.
#[test]
fn caustic_photons_beyond_the_process_memory_are_refused_before_tracing() {
    let dir = tempfile::tempdir().unwrap();
    let canonical = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/caustic-sphere.toml");
    let out_file = dir.path().join("x.exr");
    for command in ["render", "photons"] {
        let out = run_limited(
            1_500_000,
            &format!(
                "{command} '{canonical}' -o '{}' -q --threads 2 --caustic-photons 20000000",
                out_file
                    .with_extension(if command == "render" { "exr" } else { "pdm" })
                    .display()
            ),
        );
        let stderr = String::from_utf8_lossy(&out.stderr);
        let prefix = format!(
            "photondiff: error: {canonical}: --caustic-photons 20000000: the caustic map needs at \
             least 2.1 GB while it is traced (104 bytes a photon), more than the "
        );
        assert!(
            stderr.starts_with(&prefix)
                && stderr.ends_with(" GB left of the 1.5 GB this process may use\n"),
            "{command}: {stderr}"
        );
        assert_eq!(out.status.code(), Some(1));
    }
    // The canonical scene with its glass sphere made diffuse: no caustics, so none stored.
    let text = std::fs::read_to_string(canonical)
        .unwrap()
        .replace("material = \"glass\"", "material = \"floor\"");
    assert!(
        !text.contains("material = \"glass\""),
        "the sphere is diffuse now"
    );
    let scene = dir.path().join("diffuse.toml");
    std::fs::write(&scene, text).unwrap();
    let out = run_limited(
        1_500_000,
        &format!(
            "photons '{}' -o '{}' -q --threads 2 --caustic-photons 20000000 --photons 1000",
            scene.display(),
            dir.path().join("x.pdm").display()
        ),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A photon map that outgrows the memory the process may use is an error naming the map, not
/// an abort: 7 * 10^6 caustic photons under a 1.2 GB limit pass the check before tracing (their
/// least, 0.73 GB, and the headroom fit in about 0.86 GB) and run out while their map grows
/// (10^7 under 1.5 GB aborted with "memory allocation of 1342177280 bytes failed").
#[test]
fn a_photon_map_outgrowing_the_process_memory_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let canonical = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/caustic-sphere.toml");
    let out = run_limited(
        1_200_000,
        &format!(
            "render '{canonical}' -o '{}' -q --threads 2 --passes 1 --caustic-photons 7000000 \
             --photons 1000",
            dir.path().join("x.exr").display()
        ),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    let error = stderr
        .lines()
        .find_map(|l| l.strip_prefix("photondiff: error: caustic map: "))
        .unwrap_or_else(|| panic!("{stderr}"));
    assert!(
        (error.contains(" photons stored; room for more would need ")
            || error.starts_with("the columns and tree of its "))
            && (error.ends_with(" GB left of the 1.2 GB this process may use")
                || error.ends_with(" GB kept for the run's small allocations")),
        "{stderr}"
    );
    assert_eq!(out.status.code(), Some(1));
    assert!(!dir.path().join("x.exr").exists());
}
