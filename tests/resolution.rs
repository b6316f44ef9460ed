//! `--resolution WxH`: `render` and `reference` at another image size than the scene file's,
//! exactly as a copy of the scene file with that size would render, and under the scene file's
//! own content hash.

mod common;

use common::{run_ok, SMALL_SCENE};
use photondiff::render::part::read_part;
use std::ffi::OsStr;
use std::path::Path;
use std::process::Command;

const EXE: &str = env!("CARGO_BIN_EXE_photondiff");

/// One pass of a few photons: enough for an image with light in it, in a fraction of a second.
const FEW: [&str; 6] = [
    "--passes",
    "1",
    "--caustic-photons",
    "4000",
    "--photons",
    "2000",
];

/// Standard error of a run that must fail with status 1 (an error, not a panic).
fn error_of(args: &[&OsStr]) -> String {
    let out = Command::new(EXE).args(args).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    stderr
}

fn write_scene(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// The scene file at 32 x 24 rendered with `--resolution 40x30` gives, bit for bit, the image
/// of the same scene written at 40 x 30 (another aspect ratio too: 30 x 30), with the first
/// file's content hash, not the copy's.
#[test]
fn a_resolution_renders_what_the_scene_file_at_that_size_renders() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_scene(dir.path(), "small.toml", SMALL_SCENE);
    for (w, h) in [(40u32, 30u32), (30, 30)] {
        let sized = SMALL_SCENE
            .replace("width = 32", &format!("width = {w}"))
            .replace("height = 24", &format!("height = {h}"));
        let copy = write_scene(dir.path(), &format!("copy{w}x{h}.toml"), &sized);
        let (given, edited) = (dir.path().join("given.exr"), dir.path().join("edited.exr"));
        let size = format!("{w}x{h}");
        let mut args: Vec<&OsStr> = vec!["render".as_ref(), file.as_os_str(), "-o".as_ref()];
        args.extend([
            given.as_os_str(),
            OsStr::new("--resolution"),
            OsStr::new(&size),
        ]);
        args.extend(FEW.map(OsStr::new));
        run_ok(&args);
        let mut args: Vec<&OsStr> = vec!["render".as_ref(), copy.as_os_str(), "-o".as_ref()];
        args.push(edited.as_os_str());
        args.extend(FEW.map(OsStr::new));
        run_ok(&args);
        let (a, b) = (read_part(&given).unwrap(), read_part(&edited).unwrap());
        assert_eq!((a.display, b.display), ((w, h), (w, h)));
        assert_eq!((a.film.width, a.film.height), (w, h));
        assert!(a.film.pixels.iter().any(|p| p.max_element() > 0.0));
        assert_eq!(a.film.pixels, b.film.pixels, "{size}");
        // The scene file's own hash: a preview and the final image are of one scene.
        let hash = |p: &photondiff::render::part::Part| p.metadata["photondiff/scene_hash"].clone();
        let plain = dir.path().join("plain.exr");
        run_ok([
            "render".as_ref(),
            file.as_os_str(),
            "-o".as_ref(),
            plain.as_os_str(),
            "--estimator".as_ref(),
            "direct".as_ref(),
        ]);
        assert_eq!(hash(&a), hash(&read_part(&plain).unwrap()));
        assert_ne!(hash(&a), hash(&b));
    }
}

/// A reference made at a `--resolution` has that size, and its parts merge only at it: the
/// exact refusal without it, naming the part and the option.
#[test]
fn references_at_a_resolution_merge_at_that_resolution() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_scene(dir.path(), "small.toml", SMALL_SCENE);
    let part = |seed: &str| {
        let out = dir.path().join(format!("part{seed}.exr"));
        let head: [&OsStr; 6] = [
            "reference".as_ref(),
            file.as_os_str(),
            "-o".as_ref(),
            out.as_os_str(),
            "--resolution".as_ref(),
            "20x10".as_ref(),
        ];
        let quick = common::QUICK_REFERENCE.map(OsStr::new);
        let tail: [&OsStr; 3] = ["--seed".as_ref(), seed.as_ref(), "-q".as_ref()];
        run_ok([&head[..], &quick, &tail].concat());
        out
    };
    let (one, two) = (part("1"), part("2"));
    let p = read_part(&one).unwrap();
    assert_eq!((p.film.width, p.film.height, p.display), (20, 10, (20, 10)));
    let merged = dir.path().join("merged.exr");
    let mut args: Vec<&OsStr> = vec!["reference".as_ref(), file.as_os_str(), "-o".as_ref()];
    args.extend([
        merged.as_os_str(),
        OsStr::new("--merge"),
        one.as_os_str(),
        two.as_os_str(),
    ]);
    let stderr = error_of(&args);
    assert!(
        stderr.contains(&format!(
            "photondiff: error: {}: a 20 x 10 reference, but the camera renders 32 x 24 (made \
             with --resolution? give the same --resolution 20x10 to merge it)",
            one.display()
        )),
        "{stderr}"
    );
    assert!(!merged.exists());
    args.extend([
        OsStr::new("-q"),
        OsStr::new("--resolution"),
        OsStr::new("20x10"),
    ]);
    run_ok(&args);
    let m = read_part(&merged).unwrap();
    assert_eq!((m.film.width, m.film.height), (20, 10));
}

/// A size that is not `WIDTHxHEIGHT`, or is out of a scene file's bounds, is refused before
/// anything is read, with what is expected.
#[test]
fn bad_resolutions_are_refused_with_what_is_expected() {
    for (value, message) in [
        (
            "40",
            "expected WIDTHxHEIGHT in pixels, such as 320x240, got \"40\"",
        ),
        (
            "0x30",
            "each side must be in 1..=32768 pixels, got \"0x30\"",
        ),
        (
            "20000x20000",
            "width x height must be at most 134217728 pixels (20 GB to render), got 20000 x \
             20000 = 400000000",
        ),
    ] {
        for command in ["render", "reference"] {
            let out = Command::new(EXE)
                .args([
                    command,
                    "no-such-scene.toml",
                    "-o",
                    "x.exr",
                    "--resolution",
                    value,
                ])
                .output()
                .unwrap();
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{stderr}");
            assert!(
                stderr.contains(&format!(
                    "invalid value '{value}' for '--resolution <WxH>': {message}"
                )),
                "{command}: {stderr}"
            );
        }
    }
}

/// Tiles rendered at a `--resolution` merge into the whole render at that size, bit for bit,
/// and a tile of another size is refused by `merge`, naming both sizes.
#[test]
fn tiles_at_a_resolution_merge_into_the_whole_image_at_it() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_scene(dir.path(), "small.toml", SMALL_SCENE);
    let render = |out: &Path, size: &str, tile: Option<&str>| {
        let mut args: Vec<&OsStr> = vec!["render".as_ref(), file.as_os_str(), "-o".as_ref()];
        args.extend([
            out.as_os_str(),
            OsStr::new("--resolution"),
            OsStr::new(size),
        ]);
        args.extend(FEW.map(OsStr::new));
        args.push(OsStr::new("-q"));
        if let Some(t) = tile {
            args.extend([OsStr::new("--tile"), OsStr::new(t)]);
        }
        run_ok(&args);
    };
    let whole = dir.path().join("whole.exr");
    render(&whole, "40x48", None);
    let parts: Vec<_> = (0..3)
        .map(|i| {
            let out = dir.path().join(format!("tile{i}.exr"));
            render(&out, "40x48", Some(&format!("{i}/3")));
            out
        })
        .collect();
    let merged = dir.path().join("merged.exr");
    let mut args: Vec<&OsStr> = vec!["merge".as_ref(), "-o".as_ref(), merged.as_os_str()];
    args.extend(parts.iter().map(|p| p.as_os_str()));
    run_ok(&args);
    let (m, w) = (read_part(&merged).unwrap(), read_part(&whole).unwrap());
    assert_eq!(m.display, (40, 48));
    assert_eq!(m.film.pixels, w.film.pixels);
    // A tile of the scene file's own size among them.
    let other = dir.path().join("other.exr");
    render(&other, "32x24", Some("0/2"));
    let refused = dir.path().join("refused.exr");
    let mut args: Vec<&OsStr> = vec!["merge".as_ref(), "-o".as_ref(), refused.as_os_str()];
    args.extend([parts[0].as_os_str(), other.as_os_str()]);
    let stderr = error_of(&args);
    assert!(
        stderr.contains(&format!(
            "{} is a 32 x 24 image but {} is 40 x 48",
            other.display(),
            parts[0].display()
        )),
        "{stderr}"
    );
}

/// The scene's warnings are of the image rendered: under `--resolution` the pixels the shapes
/// cover are counted of its size (it gave the scene file's own, `of 768 pixels` for a
/// 16 x 12 image), by `render` and by `reference` alike.
#[test]
fn the_scenes_warnings_count_the_pixels_of_the_resolution_given() {
    let dir = tempfile::tempdir().unwrap();
    // Seen through 179.9 degrees, the small scene is a speck in the middle of the image.
    let wide = SMALL_SCENE.replace("fov_y = 40.0", "fov_y = 179.9");
    assert_ne!(wide, SMALL_SCENE);
    let scene = write_scene(dir.path(), "wide.toml", &wide);
    let out_exr = dir.path().join("w.exr");
    let reference = dir.path().join("r.exr");
    for args in [
        vec!["render", "--estimator", "direct", "--passes", "1", "-o"],
        vec![
            "reference",
            "--light-paths",
            "1000",
            "--caustic-paths",
            "1000",
            "-o",
        ],
    ] {
        let output = if args[0] == "render" {
            &out_exr
        } else {
            &reference
        };
        let out = Command::new(EXE)
            .args(&args)
            .arg(output)
            .args(["--resolution", "16x12", "--quiet"])
            .arg(&scene)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{stderr}");
        assert!(
            stderr.contains(" of 192 pixels; fov_y = 179.9): the image will be almost black"),
            "{args:?}: {stderr}"
        );
    }
}
