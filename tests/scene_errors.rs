//! Every kind of bad scene input gives a clear message naming the file and the field or line,
//! and the command line exits non-zero without panicking.

mod common;
use common::render_file;

use photondiff::scene::file::load_scene;
use std::path::Path;
use std::process::Command;

const CAMERA: &str = r#"
[camera]
eye = [0.0, 2.0, 5.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov_y = 40.0
width = 32
height = 24
"#;

const REST: &str = r#"
[materials.white]
type = "diffuse"
albedo = [0.5, 0.5, 0.5]

[[lights]]
type = "point"
position = [0.0, 4.0, 0.0]
intensity = [10.0, 10.0, 10.0]
"#;

/// Writes `scene` (and extra files) into a temporary folder and returns the load error.
fn error_of(scene: &str, files: &[(&str, &str)]) -> String {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in files {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, scene).unwrap();
    let message = load_scene(&path).unwrap_err().to_string();
    let prefix = format!("{}: ", path.display());
    assert!(message.starts_with(&prefix), "{message}");
    // Make the message independent of the temporary folder.
    message[prefix.len()..].replace(&format!("{}/", dir.path().display()), "")
}

fn with_shape(shape: &str) -> String {
    format!("{CAMERA}{REST}\n[[shapes]]\n{shape}\n")
}

/// Writes a scene of one white ball of radius 1 into `dir`; its path.
fn sphere_scene(dir: &Path) -> std::path::PathBuf {
    let scene = dir.join("scene.toml");
    let ball = "type = \"sphere\"\ncenter = [0.0, 1.0, 0.0]\nradius = 1.0\nmaterial = \"white\"";
    std::fs::write(&scene, with_shape(ball)).unwrap();
    scene
}

#[test]
fn unknown_keys_are_named_with_their_line() {
    let e = error_of(&format!("{CAMERA}fov = 3\n{REST}"), &[]);
    assert!(e.starts_with("TOML parse error at line 9, column 1"), "{e}");
    assert!(e.contains("unknown field `fov`"), "{e}");
    let e = error_of(&with_shape("type = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"white\"\ncolour = 1"), &[]);
    assert!(e.contains("unknown field `colour`"), "{e}");
    let e = error_of(
        &format!("{CAMERA}{REST}\n[[shapes]]\ntype = \"cone\"\n"),
        &[],
    );
    assert!(
        e.contains("unknown variant `cone`, expected one of `mesh`, `quad`, `sphere`"),
        "{e}"
    );
}

/// The camera's vectors hold three numbers exactly: `eye = [x, y, z, w]` was read as its first
/// three (serde leaves the rest of a fixed-size array unread).
#[test]
fn camera_vectors_hold_three_numbers() {
    for (field, line) in [("eye", 3), ("look_at", 4), ("up", 5)] {
        for (value, n) in [("[0.0, 2.0, 5.0, 1.0]", 4), ("[1.0, 2.0]", 2)] {
            let mut camera = CAMERA.to_string();
            let start = camera.find(&format!("\n{field} = ")).unwrap() + 1;
            let end = start + camera[start..].find('\n').unwrap();
            camera.replace_range(start..end, &format!("{field} = {value}"));
            let e = error_of(&format!("{camera}{REST}"), &[]);
            assert!(
                e.starts_with(&format!("TOML parse error at line {line}, column "))
                    && e.ends_with(&format!(
                        "invalid length {n}, expected an array of three numbers [x, y, z]"
                    )),
                "{e}"
            );
        }
    }
}

/// A scene has one camera, a table: `[[camera]]` was refused as "expected an array of three
/// numbers [x, y, z]", about no vector the user wrote.
#[test]
fn a_camera_is_one_table() {
    let e = error_of(
        &format!("{}{REST}", CAMERA.replace("[camera]", "[[camera]]")),
        &[],
    );
    assert!(
        e.starts_with("TOML parse error at line 2, column 1")
            && e.ends_with(
                "a scene has one camera: write [camera], not [[camera]] (an array of tables)"
            ),
        "{e}"
    );
    let e = error_of(
        &format!(
            "camera = 5
{REST}"
        ),
        &[],
    );
    assert!(
        e.ends_with("invalid type: integer `5`, expected one [camera] table"),
        "{e}"
    );
}

#[test]
fn syntax_errors_name_the_line() {
    let e = error_of(&format!("{CAMERA}{REST}\n[[shapes]\n"), &[]);
    assert!(
        e.starts_with("TOML parse error at line 19, column 9"),
        "{e}"
    );
    assert!(e.contains("19 | [[shapes]"), "{e}");
}

#[test]
fn missing_and_unreadable_mesh_files() {
    let e = error_of(
        &with_shape("type = \"mesh\"\nfile = \"nowhere.obj\"\nmaterial = \"white\""),
        &[],
    );
    assert!(
        e.starts_with("shapes[0].file: nowhere.obj: cannot read OBJ: "),
        "{e}"
    );
    let e = error_of(
        &with_shape("type = \"mesh\"\nfile = \"bad.ply\"\nmaterial = \"white\""),
        &[("bad.ply", "this is not a ply file\n")],
    );
    assert!(
        e.starts_with("shapes[0].file: bad.ply: cannot parse PLY: "),
        "{e}"
    );
    let e = error_of(
        &with_shape("type = \"mesh\"\nfile = \"model.stl\"\nmaterial = \"white\""),
        &[("model.stl", "solid\n")],
    );
    assert_eq!(
        e,
        "shapes[0].file: model.stl: unsupported mesh format (expected a .obj or .ply file)"
    );
}

#[test]
fn malformed_meshes_name_the_element_and_line() {
    // One degenerate triangle is dropped (tests/mesh_files.rs); a mesh of nothing else is refused.
    let obj = "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n";
    let e = error_of(
        &with_shape("type = \"mesh\"\nfile = \"flat.obj\"\nmaterial = \"white\""),
        &[("flat.obj", obj)],
    );
    assert_eq!(
        e,
        "shapes[0].file: flat.obj: the mesh has no triangles: all 1 are degenerate (zero area)"
    );
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
               property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
               0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n";
    let e = error_of(
        &with_shape("type = \"mesh\"\nfile = \"tri.ply\"\nmaterial = \"white\""),
        &[("tri.ply", ply)],
    );
    assert_eq!(
        e,
        "shapes[0].file: tri.ply: line 13: face 0 uses vertex 7, but the file has 3 vertices"
    );
    let e = error_of(
        &with_shape("type = \"mesh\"\nfile = \"nan.obj\"\nmaterial = \"white\""),
        &[("nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n")],
    );
    assert_eq!(
        e,
        "shapes[0].file: nan.obj: line 2: vertex 2 is not finite: [NaN, 0.0, 0.0]"
    );
}

#[test]
fn non_finite_numbers_are_rejected() {
    let e = error_of(
        &with_shape(
            "type = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = inf\nmaterial = \"white\"",
        ),
        &[],
    );
    assert_eq!(e, "shapes[0].radius: must be a finite number, got inf");
    let e = error_of(
        &with_shape(
            "type = \"sphere\"\ncenter = [0.0, nan, 0.0]\nradius = 1.0\nmaterial = \"white\"",
        ),
        &[],
    );
    assert_eq!(
        e,
        "shapes[0].center: every component must be a finite number, got [0.0, NaN, 0.0]"
    );
    let e = error_of(
        &format!("{CAMERA}{REST}").replace(
            "intensity = [10.0, 10.0, 10.0]",
            "intensity = [10.0, -inf, 10.0]",
        ),
        &[],
    );
    assert_eq!(
        e,
        "lights[0].intensity: every component must be a finite number, got [10.0, -inf, 10.0]"
    );
}

#[test]
fn invalid_values_are_explained() {
    let glass = format!("{CAMERA}{REST}\n[materials.glass]\ntype = \"glass\"\nior = 0.0\n");
    assert_eq!(
        error_of(&glass, &[]),
        "materials.glass.ior: must be > 0, got 0"
    );
    let up = format!("{CAMERA}{REST}").replace("up = [0.0, 1.0, 0.0]", "up = [0.0, 2.0, 5.0]");
    assert_eq!(
        error_of(&up, &[]),
        "camera.up: must not be zero or parallel to the view direction (look_at - eye)"
    );
    // A look_at so far that the view direction's length overflows was blamed on `up`.
    let far = format!("{CAMERA}{REST}")
        .replace("look_at = [0.0, 0.0, 0.0]", "look_at = [1e200, 0.0, 1e200]");
    assert_eq!(
        error_of(&far, &[]),
        "camera.look_at: too far from the eye: the view direction's length overflows (got \
         [1e200, 0.0, 1e200]; only the direction matters, so a nearer point on it will do)"
    );
    let e = error_of(&with_shape("type = \"quad\"\ncorner = [0.0, 0.0, 0.0]\nedge_u = [1.0, 0.0, 0.0]\nedge_v = [2.0, 0.0, 0.0]\nmaterial = \"white\""), &[]);
    assert_eq!(
        e,
        "shapes[0]: edge_u and edge_v must be non-zero and not parallel"
    );
    let e = error_of(
        &with_shape(
            "type = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"gold\"",
        ),
        &[],
    );
    assert_eq!(
        e,
        "shapes[0].material: unknown material 'gold' (defined: white)"
    );
    let e = error_of(
        &format!("{CAMERA}{REST}").replace("width = 32", "width = 0"),
        &[],
    );
    assert_eq!(e, "camera.width: must be in 1..=32768, got 0");
}

/// Points rays start from, beyond what Embree takes, and lights too strong for single
/// precision: each used to render a black or infinite image without a word.
#[test]
fn unrenderable_eyes_lights_and_intensities_are_refused() {
    let scene = format!("{CAMERA}{REST}");
    let cases = [
        (
            ("eye = [0.0, 2.0, 5.0]", "eye = [0.0, 2.0, 1e30]"),
            "camera.eye: must lie within the coordinates Embree takes (|x| < 1e18), got [0.0, 2.0, 1e30]",
        ),
        (
            ("position = [0.0, 4.0, 0.0]", "position = [0.0, -2e18, 0.0]"),
            "lights[0].position: must lie within the coordinates Embree takes (|x| < 1e18), got [0.0, -2e18, 0.0]",
        ),
        (
            ("width = 32\nheight = 24", "width = 32768\nheight = 32768"),
            "camera: width x height must be at most 134217728 pixels (20 GB to render), got 32768 x 32768 = 1073741824",
        ),
        (
            ("intensity = [10.0, 10.0, 10.0]", "intensity = [10.0, 1e300, 10.0]"),
            "lights[0].intensity: components must be at most 1e20, got [10.0, 1e300, 10.0]",
        ),
        (
            ("intensity = [10.0, 10.0, 10.0]", "intensity = [6e-100, 0.0, 6e-100]"),
            "lights[0].intensity: components must be 0 or at least 1e-30 (photon powers are \
             single precision; scale every light up and the image scales with them), got \
             [6e-100, 0.0, 6e-100]",
        ),
    ];
    for ((from, to), message) in cases {
        assert!(scene.contains(from), "{from}");
        assert_eq!(error_of(&scene.replace(from, to), &[]), message);
    }
    // Shapes beyond those coordinates are named by the fields written, whatever the size: the
    // mesh's vertex was blamed (and "not finite" past 3.4e38, "parallel" edges near 1e160).
    for (edge, reach) in [("1e19", "1e19"), ("1e100", "1e100"), ("1e200", "1e200")] {
        let quad = format!(
            "type = \"quad\"\ncorner = [0.0, 0.0, 0.0]\nedge_u = [{edge}, 0.0, 0.0]\n\
             edge_v = [0.0, 0.0, 1.0]\nmaterial = \"white\""
        );
        assert_eq!(
            error_of(&with_shape(&quad), &[]),
            format!(
                "shapes[0]: corner, edge_u and edge_v reach {reach}, beyond the coordinates \
                 Embree takes (|x| < 1e18)"
            )
        );
        let light = format!(
            "{CAMERA}[[lights]]\ntype = \"quad\"\ncorner = [0.0, 3.0, 0.0]\nedge_u = [1.0, 0.0, 0.0]\n\
             edge_v = [0.0, 0.0, -{edge}]\nradiance = [1.0, 1.0, 1.0]\n"
        );
        assert_eq!(
            error_of(&light, &[]),
            format!(
                "lights[0]: corner, edge_u and edge_v reach {reach}, beyond the coordinates \
                 Embree takes (|x| < 1e18)"
            )
        );
    }
    for (radius, reach) in [("1e19", "1e19"), ("1e300", "1e300")] {
        let ball = format!(
            "type = \"sphere\"\ncenter = [0.0, 1.0, 0.0]\nradius = {radius}\nmaterial = \"white\""
        );
        assert_eq!(
            error_of(&with_shape(&ball), &[]),
            format!(
                "shapes[0]: center and radius reach {reach}, beyond the coordinates Embree \
                 takes (|x| < 1e18)"
            )
        );
    }
    let quad = format!(
        "{CAMERA}[[lights]]\ntype = \"quad\"\ncorner = [0.0, 3.0, 0.0]\nedge_u = [1.0, 0.0, 0.0]\n\
         edge_v = [0.0, 0.0, 1.0]\nradiance = [1e21, 0.0, 0.0]\n"
    );
    assert_eq!(
        error_of(&quad, &[]),
        "lights[0].radiance: components must be at most 1e20, got [1e21, 0.0, 0.0]"
    );
    // The largest and the smallest accepted still load.
    for accepted in ["[1e20, 0.0, 0.0]", "[1e-30, 0.0, 0.0]"] {
        let light = scene.replace(
            "intensity = [10.0, 10.0, 10.0]",
            &format!("intensity = {accepted}"),
        );
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("scene.toml");
        std::fs::write(&path, light).unwrap();
        assert!(load_scene(&path).is_ok(), "{accepted}");
    }
}

#[test]
fn a_missing_scene_file_is_an_error() {
    let e = load_scene(Path::new("/nonexistent/scene.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("/nonexistent/scene.toml: cannot read: "),
        "{e}"
    );
}

#[test]
fn the_command_line_fails_cleanly_and_renders_good_scenes() {
    let exe = env!("CARGO_BIN_EXE_photondiff");
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.toml");
    std::fs::write(
        &bad,
        format!("{CAMERA}{REST}").replace("fov_y = 40.0", "fov_y = 200.0"),
    )
    .unwrap();
    let out = Command::new(exe).arg("render").arg(&bad).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert_eq!(
        stderr.trim(),
        format!(
            "photondiff: error: {}: camera.fov_y: must be in (0, 180) degrees, got 200",
            bad.display()
        )
    );

    let good = dir.path().join("good.toml");
    std::fs::write(
        &good,
        format!("{CAMERA}{REST}\n[[shapes]]\ntype = \"quad\"\ncorner = [-2.0, 0.0, 2.0]\nedge_u = [4.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -4.0]\nmaterial = \"white\"\n"),
    )
    .unwrap();
    let exr = dir.path().join("o/img.exr");
    let (json, _) = render_file(
        &good,
        &exr.with_extension(""),
        &["--quiet", "--view-grid", "2", "--threads", "1"],
    );
    assert!(exr.exists() && exr.with_extension("png").exists());
    // The default estimate (integrated) renders two progressive passes.
    assert_eq!(json["progressive"]["passes"], 2);
    assert_eq!(json["rays"]["camera"], 2 * 32 * 24 * 4);
    assert_eq!(json["threads"], 1);
}

/// Outputs that would land on the scene, on a part being merged or on one another are refused
/// before any work, and the files are left as they were (the scene used to become an EXR).
#[test]
fn outputs_may_not_overwrite_inputs_or_each_other() {
    let exe = env!("CARGO_BIN_EXE_photondiff");
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    let text = format!("{CAMERA}{REST}");
    std::fs::write(&scene, &text).unwrap();
    let at = |name: &str| dir.path().join(name).display().to_string();
    let scene_path = scene.display().to_string();
    // A link to an output not yet written: the PNG went through it onto the EXR.
    std::os::unix::fs::symlink("out.exr", dir.path().join("p.png")).unwrap();
    let cases: Vec<(Vec<String>, String)> = vec![
        (
            vec![
                "render".into(),
                scene_path.clone(),
                "-o".into(),
                scene_path.clone(),
            ],
            format!("-o names the scene ({scene_path}): the run would overwrite it"),
        ),
        (
            vec![
                "render".into(),
                scene_path.clone(),
                "-o".into(),
                at("out.exr"),
                "--png".into(),
                at("p.png"),
            ],
            format!(
                "--png and -o name the same file ({}): each output needs its own",
                at("p.png")
            ),
        ),
        (
            vec![
                "render".into(),
                scene_path.clone(),
                "-o".into(),
                at("x.png"),
            ],
            format!(
                "-o {}: the image is written as OpenEXR; give it a .exr name (the PNG preview \
                 goes to --png)",
                at("x.png")
            ),
        ),
        (
            vec![
                "render".into(),
                scene_path.clone(),
                "-o".into(),
                at("x.exr"),
                "--png".into(),
                at("y.exr"),
            ],
            format!(
                "--png {}: the preview is written as PNG; give it a .png name",
                at("y.exr")
            ),
        ),
        (
            vec![
                "merge".into(),
                at("p0.exr"),
                "-o".into(),
                at("m.exr"),
                "--png".into(),
                at("m.EXR"),
            ],
            format!(
                "--png {}: the preview is written as PNG; give it a .png name",
                at("m.EXR")
            ),
        ),
        (
            vec![
                "render".into(),
                scene_path.clone(),
                "-o".into(),
                at("y.exr"),
                "--stats-json".into(),
                at("y.exr"),
            ],
            format!(
                "--stats-json and -o name the same file ({}): each output needs its own",
                at("y.exr")
            ),
        ),
        (
            vec![
                "photons".into(),
                scene_path.clone(),
                "-o".into(),
                scene_path.clone(),
            ],
            format!("-o names the scene ({scene_path}): the run would overwrite it"),
        ),
        (
            vec![
                "merge".into(),
                at("p0.exr"),
                at("p1.exr"),
                "-o".into(),
                at("p1.exr"),
            ],
            format!(
                "-o names the part being merged ({}): the run would overwrite it",
                at("p1.exr")
            ),
        ),
        (
            vec![
                "reference".into(),
                scene_path.clone(),
                "-o".into(),
                at("r.exr"),
                "--merge".into(),
                at("r.exr"),
                at("s.exr"),
            ],
            format!(
                "-o names the reference being merged ({}): the run would overwrite it",
                at("r.exr")
            ),
        ),
    ];
    for (args, message) in cases {
        let out = Command::new(exe).args(&args).output().unwrap();
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        assert_eq!(
            String::from_utf8_lossy(&out.stderr),
            format!("photondiff: error: {message}\n"),
            "{args:?}"
        );
    }
    assert_eq!(std::fs::read_to_string(&scene).unwrap(), text);
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(names.len(), 2, "only the scene and the link: {names:?}");
}

/// Writes into `dir` a scene of an 11585 x 11585 camera (2^27 pixels, 23.5 GB to render) with
/// `shapes` (TOML) and returns its path.
fn huge_image_scene(dir: &Path, shapes: &str) -> std::path::PathBuf {
    let scene = dir.join("scene.toml");
    let camera = CAMERA
        .replace("width = 32", "width = 11585")
        .replace("height = 24", "height = 11585");
    std::fs::write(&scene, format!("{camera}{REST}{shapes}")).unwrap();
    scene
}

/// An image whose pixels cannot fit in the memory the process may use is refused before
/// anything is allocated: at the 2^27-pixel limit a render under a 6 GB limit aborted. The
/// refusal is the render's, not the scene file's: a tile of it that fits renders, and
/// `photons`, which holds no image, runs (both were refused when the scene was read, until
/// stop 56).
#[test]
fn an_image_beyond_the_process_memory_is_refused_at_once() {
    let exe = env!("CARGO_BIN_EXE_photondiff");
    let dir = tempfile::tempdir().unwrap();
    let scene = huge_image_scene(dir.path(), "");
    let run = |args: &str| {
        Command::new("sh")
            .arg("-c")
            .arg(format!("ulimit -v 3000000; exec '{exe}' {args}",))
            .output()
            .unwrap()
    };
    let render = |extra: &str| {
        run(&format!(
            "render '{}' -o '{}' --estimator direct {extra}",
            scene.display(),
            dir.path().join("x.exr").display()
        ))
    };
    let out = render("");
    // (After the warning of a scene without shapes.)
    let stderr = left_masked(&out.stderr);
    assert!(
        stderr.ends_with(&format!(
            "\nphotondiff: error: {}: camera: 11585 x 11585 pixels need about 23.5 GB to \
             render (about 175 bytes each), more than the N GB left of the 3.1 GB this process \
             may use\n",
            scene.display()
        )),
        "{stderr}"
    );
    assert_eq!(out.status.code(), Some(1));
    // A quarter does not fit either (5.9 GB), nor a seventh (3.3 GB: it passed the check at
    // 150 bytes a pixel, 2.9 GB, and aborted), ...
    for (tile, pixels, gb) in [("0/4", 33550160, "5.9"), ("0/7", 19092080, "3.3")] {
        let out = render(&format!("-q --tile {tile}"));
        let stderr = left_masked(&out.stderr);
        assert!(
            stderr.ends_with(&format!(
                "\nphotondiff: error: --tile: its {pixels} pixels need about {gb} GB to render \
                 (about 175 bytes each), more than the N GB left of the 3.1 GB this process may \
                 use\n"
            )),
            "{stderr}"
        );
    }
    // ... a sixteenth does (1.5 GB).
    let out = render("-q --tile 0/16 --footprint-shadow-rays 1");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // Merging the tiles holds them all at once: refused before reading any (it aborted).
    let out = run(&format!(
        "merge '{}' -o '{}'",
        dir.path().join("x.exr").display(),
        dir.path().join("whole.exr").display()
    ));
    assert_eq!(
        left_masked(&out.stderr),
        "photondiff: error: the whole image's 134212225 pixels need about 8.6 GB to merge \
         (about 64 bytes each), more than the N GB left of the 3.1 GB this process may use\n"
    );
    assert_eq!(out.status.code(), Some(1));
    let out = run(&format!(
        "photons '{}' -o '{}' -q --threads 1 --photons 1000 --caustic-photons 0",
        scene.display(),
        dir.path().join("maps.pdm").display()
    ));
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A memory refusal's message with the gigabytes left (the limit less what the process held
/// then, which varies from run to run by a few hundredths) written `N`.
fn left_masked(stderr: &[u8]) -> String {
    let text = String::from_utf8_lossy(stderr);
    let Some(end) = text.find(" GB left of the ") else {
        return text.into_owned();
    };
    let start = text[..end]
        .rfind("the ")
        .expect("\"more than the X GB left\"")
        + 4;
    assert!(text[start..end].parse::<f64>().is_ok(), "{text}");
    format!("{}N{}", &text[..start], &text[end..])
}

/// The refusal counts what the process holds already, not only its limit: a tile that needs
/// 2.9 GB, under a 3.07 GB limit, of a scene whose sphere holds 0.9 GB of mesh buffers is
/// refused before the BVH is built.
#[test]
fn memory_already_held_counts_against_the_image() {
    let exe = env!("CARGO_BIN_EXE_photondiff");
    let dir = tempfile::tempdir().unwrap();
    let ball = "[[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 1.0, 0.0]\nradius = 1.0\n\
                material = \"white\"\nsegments = 6000\n";
    let scene = huge_image_scene(dir.path(), ball);
    let out = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -v 3000000; exec '{exe}' render '{}' -o '{}' --estimator direct -q \
             --tile 0/8",
            scene.display(),
            dir.path().join("x.exr").display()
        ))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let prefix = "photondiff: error: --tile: its 16682400 pixels need about 2.9 GB to render \
                  (about 175 bytes each), more than the ";
    let left: f64 = stderr
        .strip_prefix(prefix)
        .and_then(|rest| rest.strip_suffix(" GB left of the 3.1 GB this process may use\n"))
        .unwrap_or_else(|| panic!("{stderr}"))
        .parse()
        .unwrap();
    // The sphere's 0.86 GB of buffers (and the tessellation's) are held.
    assert!(left < 2.3, "{stderr}");
    assert_eq!(out.status.code(), Some(1));
    assert!(!dir.path().join("x.exr").exists());
}

/// A pass-range part holds its exact sums beside the film, more than twice a whole render's
/// bytes a pixel: one whose pixels cannot fit is refused before any work (4096 x 3072 under a
/// 3 GB limit passed the whole render's check and aborted 21 s later), and its tile may fit.
#[test]
fn a_pass_range_part_beyond_the_process_memory_is_refused_at_once() {
    let exe = env!("CARGO_BIN_EXE_photondiff");
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    let camera = CAMERA
        .replace("width = 32", "width = 4096")
        .replace("height = 24", "height = 3072");
    std::fs::write(&scene, format!("{camera}{REST}")).unwrap();
    let run = |extra: &str| {
        Command::new("sh")
            .arg("-c")
            .arg(format!(
                "ulimit -v 3000000; exec '{exe}' render '{}' -o '{}' --estimator direct -q \
                 --passes 2 --pass-range 0..1 {extra}",
                scene.display(),
                dir.path().join("sub/x.exr").display()
            ))
            .output()
            .unwrap()
    };
    let out = run("");
    // (After the warning of a scene without shapes.)
    let stderr = left_masked(&out.stderr);
    assert!(
        stderr.ends_with(
            "\nphotondiff: error: --pass-range: 12582912 pixels (and a part's exact sums) need \
             about 5.0 GB to render (about 400 bytes each), more than the N GB left of the 3.1 \
             GB this process may use: split the image into tiles too (--tile)\n"
        ),
        "{stderr}"
    );
    assert_eq!(out.status.code(), Some(1));
    assert!(!dir.path().join("sub").exists());
    // A quarter of it (12 of 48 rows of 64-pixel tiles) fits.
    let out = run("--tile 0/4 --view-grid 1 --footprint-shadow-rays 1");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Outputs that name one of the scene's mesh files (a shape's, a placed `[meshes.NAME]`'s or
/// an unplaced one's) are refused once the scene is read, before anything is written: every
/// command replaced the mesh and exited 0, and the next run could not read it.
#[test]
fn outputs_may_not_overwrite_the_scenes_mesh_files() {
    let exe = env!("CARGO_BIN_EXE_photondiff");
    let dir = tempfile::tempdir().unwrap();
    let triangle = "v -1 0 -1\nv 1 0 -1\nv 0 0 1\nf 1 3 2\n";
    std::fs::create_dir(dir.path().join("meshes")).unwrap();
    for name in ["tri.obj", "meshes/placed.obj", "meshes/spare.obj"] {
        std::fs::write(dir.path().join(name), triangle).unwrap();
    }
    let scene = dir.path().join("scene.toml");
    std::fs::write(
        &scene,
        format!(
            "{CAMERA}{REST}\n[[shapes]]\ntype = \"mesh\"\nfile = \"tri.obj\"\nmaterial = \"white\"\n\
             [meshes.placed]\nfile = \"meshes/placed.obj\"\n[meshes.spare]\nfile = \"meshes/spare.obj\"\n\
             [[instances]]\nmesh = \"placed\"\nmaterial = \"white\"\ntranslate = [0.0, 1.0, 0.0]\n"
        ),
    )
    .unwrap();
    let at = |name: &str| dir.path().join(name).display().to_string();
    let cases: [(&[&str], &str, &str); 4] = [
        (
            &["render", "-o", "x.exr", "--stats-json"],
            "tri.obj",
            "--stats-json",
        ),
        (&["photons", "-o"], "meshes/../tri.obj", "-o"),
        (
            &["reference", "-o", "r.exr", "--trace"],
            "meshes/placed.obj",
            "--trace",
        ),
        (
            &["render", "-o", "x.exr", "--png"],
            "meshes/spare.obj",
            "--png",
        ),
    ];
    for (args, mesh, flag) in cases {
        let out = Command::new(exe)
            .arg(args[0])
            .arg(&scene)
            .args(args[1..].iter().map(|a| {
                if a.ends_with(".exr") {
                    at(a)
                } else {
                    a.to_string()
                }
            }))
            .arg(at(mesh))
            .args(["--quiet"])
            .output()
            .unwrap();
        let named = at(mesh.trim_start_matches("meshes/../"));
        assert_eq!(
            String::from_utf8_lossy(&out.stderr),
            format!("photondiff: error: {flag} names a mesh file of the scene ({named}): the run would overwrite it\n"),
            "{args:?}"
        );
        assert_eq!(out.status.code(), Some(1), "{args:?}");
    }
    for name in ["tri.obj", "meshes/placed.obj", "meshes/spare.obj"] {
        assert_eq!(
            std::fs::read_to_string(dir.path().join(name)).unwrap(),
            triangle
        );
    }
    for name in ["x.exr", "x.png", "r.exr", "r-a.exr"] {
        assert!(!dir.path().join(name).exists(), "{name}");
    }
}

/// Path counts past the cap are refused by the option parser (2^64 - 1 paths tried to
/// allocate petabytes for their schedule and aborted).
#[test]
fn light_path_counts_past_the_cap_are_refused_at_once() {
    let exe = env!("CARGO_BIN_EXE_photondiff");
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    std::fs::write(&scene, format!("{CAMERA}{REST}")).unwrap();
    let out = dir.path().join("x.exr");
    let cases: [&[&str]; 3] = [
        &[
            "render",
            "--estimator",
            "lighttrace",
            "--light-paths",
            "18446744073709551615",
        ],
        &["reference", "--light-paths", "100000000001"],
        &["reference", "--caustic-paths", "18446744073709551615"],
    ];
    for args in cases {
        let run = Command::new(exe)
            .args(&args[..1])
            .arg(&scene)
            .arg("-o")
            .arg(&out)
            .args(&args[1..])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{args:?}: {stderr}");
        let flag = args[args.len() - 2];
        let value = args[args.len() - 1];
        assert!(
            stderr.starts_with(&format!(
                "error: invalid value '{value}' for '{flag} <N>': {value} is not in 0..=100000000000"
            )),
            "{args:?}: {stderr}"
        );
    }
    assert!(!out.exists());
}

/// Photon counts past 32-bit indices are refused by the option parser; a count whose maps may
/// not fit in memory is warned about before tracing starts (a run asked for 4 * 10^9 grew by
/// 11 MB/s for minutes without a word), or refused where they are caustic photons that cannot
/// fit at all.
#[test]
fn photon_counts_are_bounded_and_a_count_beyond_memory_is_warned_about() {
    use std::io::{BufRead, BufReader};
    let exe = env!("CARGO_BIN_EXE_photondiff");
    let dir = tempfile::tempdir().unwrap();
    let scene = sphere_scene(dir.path());
    let out = dir.path().join("maps.bin");
    for flag in ["--photons", "--caustic-photons"] {
        let run = Command::new(exe)
            .arg("photons")
            .arg(&scene)
            .arg("-o")
            .arg(&out)
            .args([flag, "4294967296"])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{stderr}");
        assert!(
            stderr.starts_with(&format!(
                "error: invalid value '4294967296' for '{flag} <N>': must be at most 2147483648 \
                 (photon indices are 32-bit), got 4294967296"
            )),
            "{stderr}"
        );
    }
    // 2 * 10^9 photons: 500 GB at 250 bytes each, beyond any machine this runs on.
    // The warning comes before the tracing; the run is stopped there. (On the canonical scene,
    // whose glass sphere stores caustic photons, so that the tracing outlasts the test: on a
    // scene that stores none the run finished, and wrote its maps, before the kill could
    // land, now and then.)
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/caustic-sphere.toml");
    let mut child = Command::new(exe)
        .arg("photons")
        .arg(&scene)
        .arg("-o")
        .arg(&out)
        .args(["--photons", "2000000000", "--caustic-photons", "0", "-q"])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Should the warning never come, the tracing would run for hours: a watchdog stops it
    // after a minute (and the assertion below then fails), unless told the line came.
    let (done, wait) = std::sync::mpsc::channel::<()>();
    let pid = child.id().to_string();
    let watchdog = std::thread::spawn(move || {
        if wait
            .recv_timeout(std::time::Duration::from_secs(60))
            .is_err()
        {
            let _ = Command::new("kill").arg(&pid).status();
        }
    });
    let mut line = String::new();
    BufReader::new(child.stderr.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let _ = done.send(());
    watchdog.join().unwrap();
    child.kill().unwrap();
    child.wait().unwrap();
    let expected = format!(
        "photondiff: warning: {}: 2000000000 photons may need up to 500.0 GB while their maps \
         are built (about 250 bytes a photon); this process may use ",
        scene.display()
    );
    assert!(line.starts_with(&expected), "{line}");
    assert!(!out.exists());
    // Caustic photons, which a scene with caustics stores every one of, are refused when even
    // their least (104 bytes each) is more than the process may take.
    let run = Command::new(exe)
        .arg("photons")
        .arg(&scene)
        .arg("-o")
        .arg(&out)
        .args(["--caustic-photons", "2000000000", "--photons", "0", "-q"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(photondiff::util::memory::total_bytes().unwrap() < 208_000_000_000);
    assert!(
        stderr.starts_with(&format!(
            "photondiff: error: {}: --caustic-photons 2000000000: the caustic map needs at \
             least 208.0 GB while it is traced (104 bytes a photon), more than the ",
            scene.display()
        )),
        "{stderr}"
    );
    assert_eq!(run.status.code(), Some(1));
    assert!(!out.exists());
}

/// A scene that renders black says so (it used to exit 0 in silence).
#[test]
fn a_scene_without_lights_renders_with_a_warning() {
    let exe = env!("CARGO_BIN_EXE_photondiff");
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    let unlit = format!("{CAMERA}{REST}").replace("[[lights]]", "[[unused]]");
    let unlit = unlit.split("[[unused]]").next().unwrap().to_string();
    std::fs::write(
        &scene,
        format!("{unlit}[[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"white\"\n"),
    )
    .unwrap();
    let run = Command::new(exe)
        .arg("render")
        .arg(&scene)
        .arg("-o")
        .arg(dir.path().join("x.exr"))
        .args(["--estimator", "direct", "-q"])
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(0));
    assert_eq!(
        String::from_utf8_lossy(&run.stderr),
        format!(
            "photondiff: warning: {}: the scene has no lights: the image will be black\n",
            scene.display()
        )
    );
}

/// Messages that named the wrong reason or said too little.
#[test]
fn messages_give_the_right_reason_and_the_value() {
    let base = format!("{CAMERA}{REST}");
    // Huge and tiny directions are directions (they were "zero or parallel").
    for up in ["[0.0, 1e300, 0.0]", "[0.0, 1e-300, 0.0]"] {
        let text = base.replace("up = [0.0, 1.0, 0.0]", &format!("up = {up}"));
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("scene.toml");
        std::fs::write(&path, &text).unwrap();
        assert!(load_scene(&path).is_ok(), "{up}");
    }
    let spot = base.replace(
        "type = \"point\"\nposition = [0.0, 4.0, 0.0]",
        "type = \"spot\"\nposition = [0.0, 4.0, 0.0]\ndirection = [1e300, -1e300, 0.0]\ncone_angle = 30.0",
    );
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("spot.toml"), &spot).unwrap();
    assert!(load_scene(&dir.path().join("spot.toml")).is_ok());
    assert_eq!(
        error_of(
            &base.replace("albedo = [0.5, 0.5, 0.5]", "albedo = [1.5, 0.5, 0.5]"),
            &[]
        ),
        "materials.white.albedo: components must be <= 1, got [1.5, 0.5, 0.5]"
    );
    let e = error_of(
        &format!("{base}[meshes.m]\nfile = \"m.obj\"\n[[instances]]\nmesh = \"m\"\nmaterial = \"white\"\nscale = [1.0, 1.0]\n"),
        &[],
    );
    assert!(e.ends_with("a number or three numbers [sx, sy, sz]"), "{e}");
}

/// A quad light too small for single precision is refused by its field, with its size (it was
/// an "invalid mesh" with a degenerate triangle, once said twice with f32 vertices printed
/// with f64's digits).
#[test]
fn a_degenerate_light_is_named_once() {
    let light = "[[lights]]\ntype = \"quad\"\ncorner = [-0.3, 1.99, 0.0]\nedge_u = [1e-12, 0.0, 0.0]\nedge_v = [0.0, 0.0, 0.6]\nradiance = [1.0, 1.0, 1.0]\n";
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, format!("{CAMERA}{light}")).unwrap();
    // Named by its field when the scene loads (it was an 'invalid mesh' with a degenerate
    // triangle when the Embree scene was built).
    let e = load_scene(&path).unwrap_err().message;
    assert_eq!(
        e,
        "lights[0]: too small for single precision where it stands (edges 1.000e-12 and \
         6.000e-1 long, 2.012e0 from the origin): its corners round together"
    );
}

/// A scene, mesh or photon-map file that is a device (here a link to `/dev/zero`, which never
/// ends) is refused at once: `info` and `render` used to read it until memory ran out.
#[test]
fn inputs_that_are_devices_are_refused_at_once() {
    let exe = env!("CARGO_BIN_EXE_photondiff");
    let dir = tempfile::tempdir().unwrap();
    let zero = |name: &str| {
        let path = dir.path().join(name);
        std::os::unix::fs::symlink("/dev/zero", &path).unwrap();
        path
    };
    let (scene, mesh, maps) = (zero("zero.toml"), zero("zero.obj"), zero("zero.maps"));
    let good = dir.path().join("good.toml");
    std::fs::write(
        &good,
        format!("{CAMERA}{REST}\n[[shapes]]\ntype = \"mesh\"\nfile = \"zero.obj\"\nmaterial = \"white\"\n"),
    )
    .unwrap();
    let run = |args: &[&std::ffi::OsStr]| {
        let out = Command::new(exe).args(args).output().unwrap();
        assert_eq!(out.status.code(), Some(1));
        String::from_utf8_lossy(&out.stderr).trim().to_string()
    };
    let os = |s: &'static str| std::ffi::OsStr::new(s);
    let out = dir.path().join("out.exr");
    assert_eq!(
        run(&[os("info"), scene.as_os_str()]),
        format!(
            "photondiff: error: {}: cannot read: is a device, not a file",
            scene.display()
        )
    );
    assert_eq!(
        run(&[os("render"), scene.as_os_str(), os("-o"), out.as_os_str()]),
        format!(
            "photondiff: error: {}: cannot read: is a device, not a file",
            scene.display()
        )
    );
    assert_eq!(
        run(&[os("info"), mesh.as_os_str()]),
        format!(
            "photondiff: error: {}: cannot read OBJ: is a device, not a file",
            mesh.display()
        )
    );
    let e = run(&[os("render"), good.as_os_str(), os("-o"), out.as_os_str()]);
    assert!(e.ends_with("is a device, not a file"), "{e}");
    let canonical = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/caustic-sphere.toml");
    let e = run(&[
        os("render"),
        canonical.as_os_str(),
        os("--photon-maps"),
        maps.as_os_str(),
        os("-o"),
        out.as_os_str(),
        os("--quiet"),
    ]);
    assert_eq!(
        e,
        format!(
            "photondiff: error: {}: cannot read photon maps: is a device, not a file",
            maps.display()
        )
    );
    assert!(!out.exists());
}

/// A value of the wrong type in a material, light or shape names its field (it named only the
/// table's header line: `segments = -4` gave "invalid value: integer `-4`, expected u32").
#[test]
fn a_wrong_type_in_a_typed_table_names_the_field() {
    let sphere = "type = \"sphere\"\ncenter = [0.0, 1.0, 0.0]\nmaterial = \"white\"\n";
    let e = error_of(
        &with_shape(&format!("{sphere}radius = 1.0\nsegments = -4")),
        &[],
    );
    assert!(
        e.starts_with("TOML parse error at line 19, column 1"),
        "{e}"
    );
    assert!(
        e.ends_with("\nsegments: invalid value: integer `-4`, expected u32 (type \"sphere\")"),
        "{e:?}"
    );
    let e = error_of(&with_shape(&format!("{sphere}radius = \"big\"")), &[]);
    assert!(
        e.contains("\nradius: invalid type: string \"big\", expected f64"),
        "{e}"
    );
    let e = error_of(
        &with_shape(&format!("{sphere}radius = 1.0"))
            .replace("albedo = [0.5, 0.5, 0.5]", "albedo = [0.5, 0.5]"),
        &[],
    );
    assert!(e.contains("[materials.white]"), "{e}");
    assert!(
        e.contains("\nalbedo: invalid length 2, expected an array of length 3 (type \"diffuse\")"),
        "{e}"
    );
    let e = error_of(
        &with_shape(&format!("{sphere}radius = 1.0"))
            .replace("intensity = [10.0, 10.0, 10.0]", "intensity = 10"),
        &[],
    );
    assert!(e.contains("\nintensity: invalid type: integer `10`, expected an array of length 3 (type \"point\")"), "{e}");
}

/// `--max-depth` is at most 256: a camera path's bounces are followed recursively, and 100,000
/// overflowed a worker's stack and aborted the process (exit status 134) in the canonical
/// scene, where light circles inside the glass sphere by total internal reflection.
#[test]
fn max_depth_is_bounded_and_its_bound_renders() {
    let exe = env!("CARGO_BIN_EXE_photondiff");
    let dir = tempfile::tempdir().unwrap();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/caustic-sphere.toml");
    let out = dir.path().join("deep.exr");
    let run = |depth: &str| {
        Command::new(exe)
            .arg("render")
            .arg(&scene)
            .arg("-o")
            .arg(&out)
            .args([
                "--estimator",
                "direct",
                "--threads",
                "2",
                "--quiet",
                "--max-depth",
                depth,
            ])
            .output()
            .unwrap()
    };
    let refused = run("257");
    assert_eq!(refused.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&refused.stderr)
        .starts_with("error: invalid value '257' for '--max-depth <N>': 257 is not in 0..=256"));
    // `--split-depth` counts the same bounces, within the same bound.
    let refused = Command::new(exe)
        .arg("render")
        .arg(&scene)
        .args(["-o", "x.exr", "--split-depth", "257"])
        .output()
        .unwrap();
    assert_eq!(refused.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&refused.stderr)
        .starts_with("error: invalid value '257' for '--split-depth <N>': 257 is not in 0..=256"));
    let deep = run("256");
    assert!(
        deep.status.success(),
        "{}",
        String::from_utf8_lossy(&deep.stderr)
    );
    assert!(out.exists());
}

/// A closed room of mirrors has nothing photons can land on: it is warned about and traces no
/// photon (it bounced every emission to the cap, 256 million rays and 39 s for 2,000 photons,
/// to store none and render black).
#[test]
fn a_scene_without_a_diffuse_surface_traces_no_photons() {
    let mirrors = with_shape(
        "type = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 8.0\nmaterial = \"mirror\"",
    )
    .replace(
        "[materials.white]",
        "[materials.mirror]\ntype = \"mirror\"\nreflectance = [1.0, 1.0, 1.0]\n\n[materials.white]",
    );
    let json = common::render_stats(&mirrors, &["--quiet", "--threads", "2"]);
    for map in json["photon_maps"].as_array().unwrap() {
        assert_eq!(
            (map["emitted"].as_u64(), map["stored"].as_u64()),
            (Some(0), Some(0)),
            "{map}"
        );
    }
    let scene = photondiff::scene::file::parse_scene(&mirrors, Path::new(".")).unwrap();
    assert_eq!(
        photondiff::scene::warnings::warnings(&scene),
        ["no shape is diffuse: light lands on nothing that scatters it, no photon is stored, and \
          the image shows only the lights, directly or through mirrors and glass"]
    );
}

/// An estimator's own option given to another estimator is an error: `--estimator jensen
/// --ms-grid 4` rendered as if `--ms-grid` had not been given.
#[test]
fn an_option_of_another_estimator_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let scene = sphere_scene(dir.path());
    let out = dir.path().join("o.exr");
    for (args, message) in [
        (
            &["--estimator", "jensen", "--ms-grid", "4"][..],
            "--ms-grid applies to --estimator multisampled only",
        ),
        (&["--k", "4"][..], "--k applies to --estimator jensen only"),
        (
            &["--estimator", "pd", "--coplanar-vertices", "8"][..],
            "--coplanar-vertices applies to --estimator coplanar only",
        ),
        // Options with defaults, given where nothing reads them (each rendered as if absent).
        (
            &["--light-paths", "1000"][..],
            "--light-paths applies to --estimator lighttrace only",
        ),
        (
            &["--estimator", "direct", "--photons", "1000"][..],
            "--photons does not apply to --estimator direct (it uses no photon maps)",
        ),
        (
            &["--estimator", "lighttrace", "--caustic-photons", "10"][..],
            "--caustic-photons does not apply to --estimator lighttrace (it uses no photon maps)",
        ),
        (
            &["--estimator", "direct", "--overlap", "32"][..],
            "--overlap does not apply to --estimator direct (it uses no photon maps)",
        ),
        (
            &["--estimator", "direct", "--global-aim", "0.1"][..],
            "--global-aim does not apply to --estimator direct (it uses no photon maps)",
        ),
        (
            &["--estimator", "direct", "--probe-walls", "true"][..],
            "--probe-walls does not apply to --estimator direct (it uses no photon maps)",
        ),
        (
            &["--estimator", "direct", "--alpha", "0.5"][..],
            "--alpha does not apply to --estimator direct (it uses no photon maps)",
        ),
        (
            &["--estimator", "lighttrace", "--global-alpha", "0.5"][..],
            "--global-alpha does not apply to --estimator lighttrace (it uses no photon maps)",
        ),
        (
            &["--estimator", "jensen", "--overlap", "8"][..],
            "--overlap does not apply to --estimator jensen without --gather-rays or \
             --probe-walls (its k nearest photons have no footprints)",
        ),
        (
            &[
                "--estimator",
                "jensen",
                "--global-alpha",
                "0.9",
                "--passes",
                "2",
            ][..],
            "--global-alpha does not apply to --estimator jensen without --gather-rays or \
             --probe-walls (its k nearest photons have no footprints)",
        ),
        (
            &["--estimator", "pd", "--alpha", "0.1"][..],
            "--alpha does not apply to a one-pass render (one pass is the default of \
             --estimator pd): it shrinks the footprints from one pass to the next; give \
             --passes, --time-budget or --target-noise for more",
        ),
        (
            &["--global-alpha", "0.5", "--passes", "1"][..],
            "--global-alpha does not apply to a one-pass render (--passes 1): it shrinks the \
             footprints from one pass to the next; give --passes, --time-budget or \
             --target-noise for more",
        ),
        (
            &["--estimator", "lighttrace", "--split-depth", "2"][..],
            "--split-depth does not apply to --estimator lighttrace (its paths reach the camera \
             from the lights: it traces no camera rays)",
        ),
        (
            &["--estimator", "lighttrace", "--view-grid", "2"][..],
            "--view-grid does not apply to --estimator lighttrace (its paths reach the camera \
             from the lights: it traces no camera rays)",
        ),
        (
            &["--estimator", "lighttrace", "--edge-grid", "2"][..],
            "--edge-grid does not apply to --estimator lighttrace (its paths reach the camera \
             from the lights: it traces no camera rays)",
        ),
        (
            &["--estimator", "lighttrace", "--max-depth", "3"][..],
            "--max-depth does not apply to --estimator lighttrace (its paths reach the camera \
             from the lights: it traces no camera rays)",
        ),
        (
            &["--estimator", "lighttrace", "--area-samples", "2"][..],
            "--area-samples does not apply to --estimator lighttrace (its paths reach the \
             camera from the lights: it traces no camera rays)",
        ),
        (
            &["--estimator", "lighttrace", "--footprint-shadow-rays", "2"][..],
            "--footprint-shadow-rays does not apply to --estimator lighttrace (its paths reach \
             the camera from the lights: it traces no camera rays)",
        ),
        (
            &["--gather-near", "0.1"][..],
            "--gather-near applies with --gather-rays only (final gathering)",
        ),
    ] {
        assert_eq!(
            command_line("render", &scene, &out, args),
            (Some(1), format!("photondiff: error: {message}\n")),
            "{args:?}"
        );
    }
    assert!(!out.exists());
    // Given to their own estimator, they render.
    let (json, _) = render_file(
        &scene,
        &dir.path().join("ms"),
        &["--quiet", "--estimator", "multisampled", "--ms-grid", "4"],
    );
    assert_eq!(json["progressive"]["passes"], 1);
    // Options at their defaults, given to an estimator that reads them, render.
    let (json, _) = render_file(
        &scene,
        &dir.path().join("lt"),
        &[
            "--quiet",
            "--estimator",
            "lighttrace",
            "--light-paths",
            "131072",
        ],
    );
    assert_eq!(json["light_paths"], 131072);
    let (json, _) = render_file(
        &scene,
        &dir.path().join("pd"),
        &[
            "--quiet",
            "--estimator",
            "pd",
            "--overlap",
            "32",
            "--alpha",
            "0.5",
            "--passes",
            "2",
        ],
    );
    assert_eq!(json["progressive"]["passes"], 2);
}

/// An option the run cannot honour is refused before the scene is read: a large scene takes
/// seconds to load and build its BVH (the 10M-triangle production mesh 3.8 s), and `--k 3` used
/// to be refused only after that. Here the scene does not exist, so an option's own error can
/// only come first; a negative number reaches its option's check (clap read `--overlap -1` as
/// an unknown flag `-1`).
#[test]
fn options_are_refused_before_the_scene_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.toml");
    let out = dir.path().join("o.exr");
    let maps = dir.path().join("m.pm");
    let cases: [(&str, &[&str], &str); 12] = [
        (
            "render",
            &["--k", "3"],
            "--k applies to --estimator jensen only",
        ),
        (
            "render",
            &["--overlap", "-1"],
            "--overlap must be a positive number, got -1",
        ),
        (
            "render",
            &["--global-aim", "1"],
            "--global-aim must be at least 0 and less than 1, got 1",
        ),
        (
            "render",
            &["--gather-near", "-2"],
            "--gather-near must be at least 0 and at most 1000, got -2",
        ),
        (
            "render",
            &["--estimator", "lighttrace", "--tile", "0/2"],
            "--tile cannot split --estimator lighttrace (its paths reach any pixel)",
        ),
        (
            "render",
            &["--tile", "0/2", "--target-noise", "0.1"],
            "--tile cannot take --target-noise: each part would stop after its own number of \
             passes; give the parts --passes N",
        ),
        (
            "render",
            &["--tile", "0/2", "--time-budget", "60"],
            "--tile cannot take --time-budget: each part would stop after its own number of \
             passes; give the parts --passes N",
        ),
        (
            "render",
            &["--tile", "2/2"],
            "--tile \"2/2\": tile I must be below N = 2 (tiles count from 0)",
        ),
        (
            "render",
            &["--estimator", "direct", "--gather-rays", "4"],
            "--gather-rays does not apply to --estimator direct (it uses no photon maps)",
        ),
        (
            "photons",
            &["--overlap", "-1"],
            "--overlap must be a positive number, got -1",
        ),
        (
            "photons",
            &["--global-aim", "-0.5"],
            "--global-aim must be at least 0 and less than 1, got -0.5",
        ),
        (
            "photons",
            &["--estimator", "jensen", "--overlap", "8"],
            "--overlap does not apply to --estimator jensen without --probe-walls (its k \
             nearest photons have no footprints, and a jensen render could not read these maps)",
        ),
    ];
    for (command, args, message) in cases {
        let output = if command == "render" { &out } else { &maps };
        assert_eq!(
            command_line(command, &missing, output, args),
            (Some(1), format!("photondiff: error: {message}\n")),
            "{command} {args:?}"
        );
    }
    // A folder given as photon maps (refused only once the scene was read), and a reference
    // named .png (written as EXR under that name).
    let folder = dir.path().to_str().unwrap();
    assert_eq!(
        command_line("render", &missing, &out, &["--photon-maps", folder]),
        (
            Some(1),
            format!("photondiff: error: {folder}: cannot read photon maps: is a folder\n")
        )
    );
    // Nor one with no extension: `-o p1` wrote `p1-a.exr` and `p1-b.exr`, the halves of
    // another reference `p1.exr`.
    for name in ["ref.png", "p1"] {
        let named = dir.path().join(name);
        assert_eq!(
            command_line("reference", &missing, &named, &[]),
            (
                Some(1),
                format!(
                    "photondiff: error: -o {}: a reference is written as OpenEXR (with its halves); \
                     give it a .exr name\n",
                    named.display()
                )
            )
        );
    }
    // With good options, the missing scene is what is refused.
    let (status, stderr) = command_line("render", &missing, &out, &[]);
    assert_eq!(status, Some(1));
    assert_eq!(
        stderr,
        format!(
            "photondiff: error: {}: cannot read: No such file or directory (os error 2)\n",
            missing.display()
        )
    );
    assert!(!out.exists() && !maps.exists());
}

/// Runs `photondiff COMMAND SCENE -o OUT ARGS...`: its exit status and standard error.
fn command_line(command: &str, scene: &Path, out: &Path, args: &[&str]) -> (Option<i32>, String) {
    let run = Command::new(env!("CARGO_BIN_EXE_photondiff"))
        .arg(command)
        .arg(scene)
        .arg("-o")
        .arg(out)
        .args(args)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr).into_owned();
    (run.status.code(), stderr)
}

/// A sphere far from the origin loses the triangles near its poles to single precision: they
/// are dropped and warned about, with the reason (it was an error naming a triangle the user
/// never wrote); one whose every triangle collapses is an error saying why.
#[test]
fn a_sphere_far_from_the_origin_drops_the_triangles_single_precision_merges() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    let ball = |at: f64, radius: f64| {
        format!(
            "type = \"sphere\"\ncenter = [{at:?}, {at:?}, {at:?}]\nradius = {radius:?}\n\
             material = \"white\""
        )
    };
    std::fs::write(&path, with_shape(&ball(3000.0, 1.0))).unwrap();
    let scene = load_scene(&path).unwrap();
    let warnings = scene.warnings();
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(
        warnings[0].starts_with("shapes[0] (sphere): dropped 672 degenerate (zero-area) triangles")
            && warnings[0].ends_with(
                "(merged by single precision at the sphere's distance from the origin: fewer \
                 `segments` keep them apart)"
            ),
        "{warnings:?}"
    );
    assert_eq!(scene.meshes[0].mesh.triangles.len(), 2 * 512 * 255 - 672);
    assert_eq!(
        error_of(&with_shape(&ball(1e12, 1.0)), &[]),
        "shapes[0] (sphere): every triangle has zero area in single precision (radius 1 at \
         [1000000000000.0, 1000000000000.0, 1000000000000.0]): bring it nearer the origin"
    );
}

/// `--seed` and `--threads` say what they take of a negative or fractional value, in every
/// command that has them (clap said "invalid digit found in string").
#[test]
fn seeds_and_thread_counts_say_what_they_take() {
    let exe = env!("CARGO_BIN_EXE_photondiff");
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/caustic-sphere.toml");
    for command in ["render", "photons", "reference"] {
        for (flag, name, value, range) in [
            ("--seed", "S", "-1", "0 to 2^64 - 1"),
            ("--threads", "N", "-1", "0 to 1024 (0 = one per core)"),
            ("--seed", "S", "1.5", "0 to 2^64 - 1"),
            ("--seed", "S", "18446744073709551616", "0 to 2^64 - 1"),
        ] {
            let run = Command::new(exe)
                .args([command, scene, flag, value])
                .output()
                .unwrap();
            let stderr = String::from_utf8_lossy(&run.stderr);
            assert_eq!(
                run.status.code(),
                Some(2),
                "{command} {flag} {value}: {stderr}"
            );
            assert!(
                stderr.starts_with(&format!(
                    "error: invalid value '{value}' for '{flag} <{name}>': expected a whole \
                     number from {range}, got {value}\n"
                )),
                "{command} {flag} {value}: {stderr}"
            );
        }
    }
}

/// A run that fails removes the folders it made for its outputs (a refused run left `o/a/` and
/// `o/t/u/` behind), but not a folder that was there before or one that holds a file.
#[test]
fn a_failed_run_leaves_no_folders_it_made() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("kept")).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_photondiff"))
        .args(["render", "missing.toml", "-o"])
        .arg(d.join("kept/a/x.exr"))
        .arg("--trace")
        .arg(d.join("t/u/trace.json"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let left: Vec<String> = walk(d);
    assert_eq!(left, ["kept"], "{left:?}");
}

/// The folders and files under `dir`, relative to it, sorted.
fn walk(dir: &Path) -> Vec<String> {
    let mut found = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            found.push(p.strip_prefix(dir).unwrap().display().to_string());
            if p.is_dir() {
                stack.push(p);
            }
        }
    }
    found.sort();
    found
}

/// Light tracing reaches a camera inside glass by no path: `render --estimator lighttrace`
/// and `reference` say so (their images were black without a word); a camera outside, even
/// one looking at the glass, is not warned about, nor one behind a glass sheet (facing away
/// from it, the camera seeing its back: the traced image was not black, and the warning said
/// it would be).
#[test]
fn a_camera_inside_glass_is_warned_about_by_light_tracing() {
    let dir = tempfile::tempdir().unwrap();
    let canonical = include_str!("../scenes/caustic-sphere.toml")
        .replace("width = 640", "width = 32")
        .replace("height = 480", "height = 24");
    let sphere = "type = \"sphere\"\ncenter = [0.0, 1.0, 0.0]\nradius = 1.0\n";
    assert!(canonical.contains(sphere));
    // Facing down (edge_u x edge_v = -y), seen from above along the view direction.
    let sheet = "type = \"quad\"\ncorner = [-1.5, 1.0, -1.5]\nedge_u = [3.0, 0.0, 0.0]\n\
                 edge_v = [0.0, 0.0, 3.0]\n";
    let with_sheet = canonical.replace(sphere, sheet);
    for (text, eye, warned) in [
        (&canonical, "[0.0, 1.0, 0.2]", true),
        (&canonical, "[0.0, 1.0, 3.0]", false),
        (&with_sheet, "[2.5, 4.5, 7.0]", false),
    ] {
        let scene = dir.path().join("scene.toml");
        let text = text.replace("eye = [2.5, 4.5, 7.0]", &format!("eye = {eye}"));
        std::fs::write(&scene, text).unwrap();
        let out = dir.path().join("x.exr");
        let (scene, out) = (scene.to_str().unwrap(), out.to_str().unwrap());
        let light = ["--estimator", "lighttrace", "--light-paths", "65536"];
        let mut render = vec!["render", scene, "-q", "-o", out];
        render.extend(light);
        let reference = [
            "reference",
            scene,
            "-q",
            "-o",
            out,
            "--direct-grids",
            "1,2",
            "--light-paths",
            "65536",
            "--caustic-paths",
            "65536",
        ];
        for args in [&render[..], &reference[..]] {
            let stderr = String::from_utf8(common::run_ok(args).stderr).unwrap();
            let warning = format!(
                "photondiff: warning: {scene}: the camera is inside shapes[1] (sphere), which \
                 is glass: light tracing reaches the camera through open space only, so what it \
                 traces will be black\n"
            );
            assert_eq!(
                stderr.contains(&warning),
                warned,
                "{eye} {args:?}: {stderr}"
            );
        }
    }
}

/// An image written to a device or pipe gets no preview beside it unless `--png` names one:
/// `-o /dev/null` wrote its preview to a file `/dev/null.png`, and a pipe's landed beside the
/// pipe. Here a named pipe, read by `cat` (started and waited for by this test).
#[test]
fn an_image_on_a_pipe_gets_no_preview_beside_it() {
    let exe = env!("CARGO_BIN_EXE_photondiff");
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    std::fs::write(&scene, common::SMALL_SCENE).unwrap();
    let pipe = dir.path().join("pipe.exr");
    assert!(Command::new("mkfifo")
        .arg(&pipe)
        .status()
        .unwrap()
        .success());
    let copy = dir.path().join("copy.bin");
    let mut reader = Command::new("sh")
        .arg("-c")
        .arg(format!("cat '{}' > '{}'", pipe.display(), copy.display()))
        .spawn()
        .unwrap();
    let out = Command::new(exe)
        .args(["render", "-q", "--estimator", "direct", "-o"])
        .arg(&pipe)
        .arg(&scene)
        .output()
        .unwrap();
    assert!(reader.wait().unwrap().success());
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(
        String::from_utf8_lossy(&out.stdout),
        format!(
            "wrote {} (no preview beside a device or pipe: --png for one)\n",
            pipe.display()
        )
    );
    assert!(!dir.path().join("pipe.png").exists());
    // The image went through the pipe: an OpenEXR file's magic number.
    assert_eq!(std::fs::read(&copy).unwrap()[..4], [0x76, 0x2f, 0x31, 0x01]);
}
