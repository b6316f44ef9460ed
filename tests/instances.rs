//! Instancing: `[meshes.NAME]` + `[[instances]]` in scene files. An instance renders as the
//! same mesh placed directly would (hits, photons, gathers), memory stays flat in the number
//! of instances, and bad instances are one-line errors.

mod common;
use common::render_file;

use std::path::{Path, PathBuf};
use std::process::Command;

const EXE: &str = env!("CARGO_BIN_EXE_photondiff");

/// The canonical scene at 96 x 72 without its sphere; `rest` appended.
fn scene(dir: &Path, name: &str, rest: &str) -> PathBuf {
    let canonical = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/caustic-sphere.toml"
    ))
    .unwrap()
    .replace("width = 640", "width = 96")
    .replace("height = 480", "height = 72");
    let floor = canonical
        .split("[[shapes]]\ntype = \"sphere\"")
        .next()
        .unwrap();
    let path = dir.join(name);
    std::fs::write(&path, format!("{floor}{rest}")).unwrap();
    path
}

/// A unit sphere at the origin as binary PLY, tessellated as the scene's `sphere` shape is.
fn write_ball(dir: &Path) {
    let mesh = photondiff::scene::shapes::sphere(
        glam::DVec3::ZERO,
        1.0,
        photondiff::scene::shapes::DEFAULT_SPHERE_SEGMENTS,
    );
    photondiff::scene::mesh_file::ply::write::write_binary(
        &mesh,
        std::io::BufWriter::new(std::fs::File::create(dir.join("ball.ply")).unwrap()),
    )
    .unwrap();
}

/// Renders `scene`, writing NAME.exr and NAME.json beside it; returns the statistics JSON and
/// the pixels.
fn render(scene: &Path, name: &str) -> (serde_json::Value, Vec<glam::DVec3>) {
    let args = ["-q", "--photons", "5000", "--caustic-photons", "5000"];
    render_file(scene, &scene.parent().unwrap().join(name), &args)
}

const MESHES: &str = "[meshes.ball]\nfile = \"ball.ply\"\n";

/// Renders the glass ball placed by `placement` (lines of an `[[instances]]` entry) and the
/// sphere placed directly, and checks that they agree.
fn renders_as_the_sphere_placed_directly(placement: &str) {
    let dir = tempfile::tempdir().unwrap();
    write_ball(dir.path());
    let direct = scene(
        dir.path(),
        "direct.toml",
        "[[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 1.0, 0.0]\nradius = 1.0\nmaterial = \"glass\"\n",
    );
    let instanced = scene(
        dir.path(),
        "instanced.toml",
        &format!("{MESHES}[[instances]]\nmesh = \"ball\"\nmaterial = \"glass\"\n{placement}"),
    );
    let (a, direct_pixels) = render(&direct, "direct");
    let (b, instanced_pixels) = render(&instanced, "instanced");
    // The same photons: the caustic map stores the same number from nearly the same emissions
    // (the target sphere is the same), and the image agrees but for f32 vertex rounding and
    // the rotated tessellation.
    let stored = |s: &serde_json::Value| s["photon_maps"][0]["stored"].as_u64().unwrap();
    assert_eq!(stored(&a), stored(&b));
    let caustic_power = |s: &serde_json::Value| s["photon_maps"][0]["power"].as_f64().unwrap();
    assert!((caustic_power(&a) / caustic_power(&b) - 1.0).abs() < 0.02);
    let sum = |p: &[glam::DVec3]| p.iter().map(|x| x.element_sum()).sum::<f64>();
    let se: f64 = direct_pixels
        .iter()
        .zip(&instanced_pixels)
        .map(|(x, y)| (*x - *y).length_squared())
        .sum();
    let n = direct_pixels.len() as f64 * 3.0;
    let rel_rmse = (se / n).sqrt() / (sum(&direct_pixels) / n);
    // Measured 2.2e-4 for the rotation (the same photons; vertices rounded to f32 after it).
    assert!(rel_rmse < 0.005, "{placement}: relRMSE {rel_rmse}");
    assert!((sum(&instanced_pixels) / sum(&direct_pixels) - 1.0).abs() < 0.002);
}

#[test]
fn an_instanced_glass_sphere_renders_as_the_sphere_placed_directly() {
    // Rotated about y, so the transform matters (a sphere looks the same, its triangles don't).
    renders_as_the_sphere_placed_directly(
        "translate = [0.0, 1.0, 0.0]\nrotate = [0.0, 30.0, 0.0]\nscale = 1.0\n",
    );
}

/// A mirroring scale reverses the triangles' winding; the geometric normal must still point
/// out of the glass (it pointed in: the caustic vanished and the image filled with speckle).
#[test]
fn a_mirrored_glass_sphere_keeps_its_inside_in() {
    renders_as_the_sphere_placed_directly(
        "translate = [0.0, 1.0, 0.0]\nrotate = [0.0, 30.0, 0.0]\nscale = [1.0, -1.0, 1.0]\n",
    );
}

#[test]
fn photons_are_stored_and_gathered_on_an_instanced_diffuse_floor() {
    let dir = tempfile::tempdir().unwrap();
    // A unit quad in the xz plane facing +y, written as PLY, placed as the 12 x 12 floor by a
    // per-axis scale and a translation; the glass sphere stays a shape.
    let quad = photondiff::scene::shapes::quad(
        glam::DVec3::new(-0.5, 0.0, 0.5),
        glam::DVec3::new(1.0, 0.0, 0.0),
        glam::DVec3::new(0.0, 0.0, -1.0),
    );
    photondiff::scene::mesh_file::ply::write::write_binary(
        &quad,
        std::io::BufWriter::new(std::fs::File::create(dir.path().join("tile.ply")).unwrap()),
    )
    .unwrap();
    let sphere = "[[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 1.0, 0.0]\nradius = 1.0\nmaterial = \"glass\"\n";
    let direct = scene(dir.path(), "direct.toml", sphere);
    // The canonical floor is the first shape: drop it, place the instance instead.
    let text = std::fs::read_to_string(&direct).unwrap();
    let floor_start = text.find("[[shapes]]\ntype = \"quad\"").unwrap();
    let floor_end = floor_start
        + text[floor_start..].find("material = \"floor\"\n").unwrap()
        + "material = \"floor\"\n".len();
    let instanced_text = format!(
        "{}{}[meshes.tile]\nfile = \"tile.ply\"\n[[instances]]\nmesh = \"tile\"\n\
         material = \"floor\"\nscale = [12.0, 1.0, 12.0]\n",
        &text[..floor_start],
        &text[floor_end..]
    );
    let instanced = dir.path().join("instanced.toml");
    std::fs::write(&instanced, instanced_text).unwrap();
    let (a, direct_pixels) = render(&direct, "direct");
    let (b, instanced_pixels) = render(&instanced, "instanced");
    // The caustic map's photons land on the instanced floor and are gathered there.
    let stored = |s: &serde_json::Value| s["photon_maps"][0]["stored"].as_u64().unwrap();
    assert_eq!(stored(&a), stored(&b));
    assert!(
        b["gathers"]["photons_used"].as_u64().unwrap() > 1000,
        "{}",
        b["gathers"]
    );
    let sum = |p: &[glam::DVec3]| p.iter().map(|x| x.element_sum()).sum::<f64>();
    let se: f64 = direct_pixels
        .iter()
        .zip(&instanced_pixels)
        .map(|(x, y)| (*x - *y).length_squared())
        .sum();
    let n = direct_pixels.len() as f64 * 3.0;
    let rel_rmse = (se / n).sqrt() / (sum(&direct_pixels) / n);
    // Measured 0: scaled by 12, the tile's vertices are exactly the canonical floor's.
    assert!(rel_rmse < 1e-6, "relRMSE {rel_rmse}");
}

#[test]
fn memory_stays_flat_in_the_number_of_instances() {
    let dir = tempfile::tempdir().unwrap();
    write_ball(dir.path());
    let place = |count: usize| -> String {
        let mut s = MESHES.to_string();
        for i in 0..count {
            let (x, z) = ((i % 10) as f64 * 0.5 - 2.5, (i / 10) as f64 * 0.5 - 2.5);
            s += &format!(
                "[[instances]]\nmesh = \"ball\"\nmaterial = \"glass\"\n\
                 translate = [{x}, 0.2, {z}]\nscale = [0.2, 0.15, 0.2]\n"
            );
        }
        s
    };
    let (one, _) = render(&scene(dir.path(), "one.toml", &place(1)), "one");
    let (hundred, _) = render(&scene(dir.path(), "hundred.toml", &place(100)), "hundred");
    let m = |s: &serde_json::Value, k: &str| s["memory"][k].as_f64().unwrap();
    assert_eq!(m(&one, "mesh_bytes"), m(&hundred, "mesh_bytes"));
    assert_eq!(m(&one, "triangles"), m(&hundred, "triangles"));
    // The floor is 2 triangles; each instance places the whole ball.
    let ball = m(&one, "placed_triangles") - 2.0;
    assert_eq!(m(&hundred, "placed_triangles"), 2.0 + 100.0 * ball);
    // One BVH for the ball whatever the count; 99 more instances add a top-level BVH of a few
    // kilobytes, not 99 copies of the ball's (megabytes).
    assert!(
        m(&hundred, "bvh_bytes") < m(&one, "bvh_bytes") + 1e6,
        "{} vs {}",
        m(&hundred, "bvh_bytes"),
        m(&one, "bvh_bytes")
    );
}

/// Two `[meshes]` names for one file (spelt two ways) read it once and hold it once: it was
/// read, and held, once per name.
#[test]
fn two_names_for_one_mesh_file_hold_it_once() {
    let dir = tempfile::tempdir().unwrap();
    write_ball(dir.path());
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    let rest = "[meshes.a]\nfile = \"ball.ply\"\n[meshes.b]\nfile = \"sub/../ball.ply\"\n\
        [[instances]]\nmesh = \"a\"\nmaterial = \"glass\"\ntranslate = [-1.0, 1.0, 0.0]\n\
        [[instances]]\nmesh = \"b\"\nmaterial = \"glass\"\ntranslate = [1.0, 1.0, 0.0]\n";
    let path = scene(dir.path(), "twice.toml", rest);
    let loaded = photondiff::scene::file::load_scene(&path).unwrap();
    let balls: Vec<_> = loaded
        .meshes
        .iter()
        .filter(|m| m.transform.is_some())
        .collect();
    assert_eq!(balls.len(), 2);
    assert!(std::sync::Arc::ptr_eq(&balls[0].mesh, &balls[1].mesh));
    assert_eq!(
        loaded.mesh_bytes(),
        loaded.meshes[0].mesh.bytes() + balls[0].mesh.bytes()
    );
}

fn error(scene: &Path) -> String {
    let out = Command::new(EXE)
        .arg("render")
        .arg(scene)
        .arg("-o")
        .arg(scene.with_extension("exr"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(!scene.with_extension("exr").exists());
    stderr.trim_end().to_string()
}

#[test]
fn bad_instances_are_one_line_errors_naming_the_element() {
    let dir = tempfile::tempdir().unwrap();
    write_ball(dir.path());
    let unknown = scene(
        dir.path(),
        "unknown.toml",
        &format!("{MESHES}[[instances]]\nmesh = \"bunny\"\nmaterial = \"glass\"\n"),
    );
    let e = error(&unknown);
    assert!(
        e.ends_with("instances[0].mesh: unknown mesh 'bunny' (defined in [meshes]: ball)"),
        "{e}"
    );
    let singular = scene(
        dir.path(),
        "singular.toml",
        &format!("{MESHES}[[instances]]\nmesh = \"ball\"\nmaterial = \"glass\"\nscale = [1.0, 0.0, 1.0]\n"),
    );
    let e = error(&singular);
    assert!(
        e.ends_with(
            "instances[0].scale: a zero scale makes the transform singular, got [1.0, 0.0, 1.0]"
        ),
        "{e}"
    );
    // Embree maps rays into the instance's space: a scale of 1e-30 made them huge and
    // Debian's Embree aborted the process.
    let tiny = scene(
        dir.path(),
        "tiny.toml",
        &format!("{MESHES}[[instances]]\nmesh = \"ball\"\nmaterial = \"glass\"\nscale = 1e-30\n"),
    );
    assert!(
        error(&tiny).ends_with(
            "instances[0].scale: each component's magnitude must be in [1e-6, 1e6], got [1e-30, 1e-30, 1e-30]"
        ),
        "{}",
        error(&tiny)
    );
    // Placed beyond the coordinates Embree takes, it used to vanish without a word.
    let far = scene(
        dir.path(),
        "far.toml",
        &format!("{MESHES}[[instances]]\nmesh = \"ball\"\nmaterial = \"glass\"\ntranslate = [2e18, 0.0, 0.0]\n"),
    );
    assert!(
        error(&far).ends_with(
            "instances[0]: the placed mesh reaches 2e18, beyond the coordinates Embree takes (|x| < 1e18)"
        ),
        "{}",
        error(&far)
    );
    // Three numbers exactly: a fourth was read past without a word.
    for field in ["translate", "rotate"] {
        let four = scene(
            dir.path(),
            "four.toml",
            &format!("{MESHES}[[instances]]\nmesh = \"ball\"\nmaterial = \"glass\"\n{field} = [1.0, 0.0, 0.0, 5.0]\n"),
        );
        // A TOML parse error: several lines, the one at fault shown.
        let e = photondiff::scene::file::load_scene(&four)
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.contains(&format!("| {field} = [1.0, 0.0, 0.0, 5.0]"))
                && e.ends_with("invalid length 4, expected an array of three numbers [x, y, z]"),
            "{e}"
        );
    }
    let missing = scene(
        dir.path(),
        "missing.toml",
        "[meshes.gone]\nfile = \"gone.ply\"\n[[instances]]\nmesh = \"gone\"\nmaterial = \"glass\"\n",
    );
    let e = error(&missing);
    assert!(
        e.contains("meshes.gone.file: ") && e.contains("gone.ply"),
        "{e}"
    );
}

#[test]
fn info_counts_unique_and_placed_triangles() {
    let dir = tempfile::tempdir().unwrap();
    write_ball(dir.path());
    let path = scene(
        dir.path(),
        "two.toml",
        &format!(
            "{MESHES}[[instances]]\nmesh = \"ball\"\nmaterial = \"glass\"\n\
             [[instances]]\nmesh = \"ball\"\nmaterial = \"glass\"\ntranslate = [3.0, 0.0, 0.0]\n"
        ),
    );
    let out = Command::new(EXE).arg("info").arg(&path).output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    let scene = photondiff::scene::file::load_scene(&path).unwrap();
    let ball = scene.meshes[1].mesh.triangles.len();
    let line = format!("  triangles  {} unique, {} placed", 2 + ball, 2 + 2 * ball);
    assert!(text.contains(&line), "no '{line}' in\n{text}");
}

/// A mesh stored far from its own origin (georeferenced or CAD exports) and placed back near
/// the world's: Embree intersects it in its own frame, where single precision is coarse, so
/// rays must leave it by that frame's offset. With the world's, the lit side of a tilted
/// quad stored 10^5 off came out in bands of acne: relRMSE 0.94 against the quad stored at
/// the origin, mean ratio 0.55.
#[test]
fn a_mesh_stored_far_off_and_placed_back_is_lit_as_one_stored_near() {
    let dir = tempfile::tempdir().unwrap();
    // A 12 x 12 quad tilted about all three axes, centred on `c`, in the file's coordinates.
    let quad = |c: f64| {
        let (u, v) = (
            glam::DVec3::new(6.0, 1.5, 0.5).normalize() * 6.0,
            glam::DVec3::new(-0.5, 1.0, 6.0).normalize() * 6.0,
        );
        // Counter-clockwise seen from above (its normal up, towards the light).
        let corners = [-u - v, -u + v, u + v, u - v].map(|p| p + glam::DVec3::splat(c));
        let mut obj: String = corners
            .iter()
            .map(|p| format!("v {} {} {}\n", p.x, p.y, p.z))
            .collect();
        obj += "f 1 2 3 4\n";
        obj
    };
    std::fs::write(dir.path().join("near.obj"), quad(0.0)).unwrap();
    std::fs::write(dir.path().join("far.obj"), quad(1e5)).unwrap();
    let scene = |name: &str, file: &str, shift: f64| {
        let text = format!(
            "[camera]\neye = [2.5, 14.5, 17.0]\nlook_at = [0.0, 0.0, 0.0]\nup = [0.0, 1.0, 0.0]\n\
             fov_y = 40.0\nwidth = 64\nheight = 48\n\n[materials.white]\ntype = \"diffuse\"\n\
             albedo = [0.75, 0.75, 0.75]\n\n[[lights]]\ntype = \"point\"\n\
             position = [-4.0, 14.0, 6.0]\nintensity = [600.0, 600.0, 600.0]\n\n\
             [meshes.quad]\nfile = \"{file}\"\n\n[[instances]]\nmesh = \"quad\"\n\
             material = \"white\"\ntranslate = [{shift}, {shift}, {shift}]\n"
        );
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        path
    };
    let args = ["-q", "--estimator", "direct"];
    let (_, near) = render_file(
        &scene("near.toml", "near.obj", 0.0),
        &dir.path().join("near"),
        &args,
    );
    let (_, far) = render_file(
        &scene("far.toml", "far.obj", -1e5),
        &dir.path().join("far"),
        &args,
    );
    let sum = |p: &[glam::DVec3]| p.iter().map(|x| x.element_sum()).sum::<f64>();
    // The quad's inside: pixels whose eight neighbours are lit too (its edges move with the
    // far file's vertices, rounded to f32 at 10^5 in steps of 0.008).
    let (w, h) = (64, 48);
    let lit = |x: usize, y: usize| near[y * w + x].element_sum() > 0.0;
    let inside: Vec<usize> = (1..h - 1)
        .flat_map(|y| (1..w - 1).map(move |x| (x, y)))
        .filter(|&(x, y)| (0..9).all(|k| lit(x + k % 3 - 1, y + k / 3 - 1)))
        .map(|(x, y)| y * w + x)
        .collect();
    assert!(inside.len() > 300, "{} pixels inside", inside.len());
    let pick = |p: &[glam::DVec3]| inside.iter().map(|&i| p[i]).collect::<Vec<_>>();
    let (near_in, far_in) = (pick(&near), pick(&far));
    let se: f64 = near_in
        .iter()
        .zip(&far_in)
        .map(|(x, y)| (*x - *y).length_squared())
        .sum();
    let n = inside.len() as f64 * 3.0;
    let rel_rmse = (se / n).sqrt() / (sum(&near_in) / n);
    assert!(rel_rmse < 0.01, "relRMSE {rel_rmse} inside the quad");
    // The whole image's light, edges and all.
    assert!(
        (sum(&far) / sum(&near) - 1.0).abs() < 0.01,
        "{}",
        sum(&far) / sum(&near)
    );
}

/// A glass pane thinner than the ray offset was stepped through (rays leaving its near side
/// started past its far side: its shadow black in a grid, relRMSE 0.325 against a pane 100
/// times thicker where two such differ by 0.06): the offset is at most 1e-2 of the thinnest
/// side of a glass mesh's box. A diffuse box as thin keeps the scene's offset.
#[test]
fn the_ray_offset_fits_inside_a_thin_glass_pane() {
    let dir = tempfile::tempdir().unwrap();
    let cube =
        "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n\
                f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 3 4 8 7\nf 2 3 7 6\nf 1 5 8 4\n";
    std::fs::write(dir.path().join("cube.obj"), cube).unwrap();
    let pane = |material: &str| {
        let path = scene(
            dir.path(),
            &format!("{material}.toml"),
            &format!(
                "[meshes.cube]\nfile = \"cube.obj\"\n[[instances]]\nmesh = \"cube\"\n\
                 material = \"{material}\"\ntranslate = [0.0, 1.5, 0.0]\n\
                 scale = [1.0, 0.0001, 1.0]\n"
            ),
        );
        photondiff::scene::file::load_scene(&path).unwrap()
    };
    let glass = pane("glass");
    // 1e-2 of it, or ten single-precision steps of the largest coordinate where those are
    // more (3e-6 here): far inside the pane either way (it was 3.4e-4).
    assert!(
        glass.ray_epsilon() <= 0.02 * 2e-4,
        "{} for a pane 2e-4 thick",
        glass.ray_epsilon()
    );
    let floor = pane("floor");
    assert_eq!(floor.ray_epsilon(), 2e-5 * floor.extent());
}
