//! Split renders: tiles and photon-map files give the image of one process bit for bit, and
//! every bad input (bad split, foreign or overlapping parts, missing tiles, bad photon-map
//! files) is a one-line error with exit status 1 that leaves no output behind.

mod common;

use photondiff::render::part::read_part;
use photondiff::scene::hash::scene_hash;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const EXE: &str = env!("CARGO_BIN_EXE_photondiff");
/// Small photon counts keep each process fast; the split does not depend on them.
const PHOTONS: [&str; 4] = ["--photons", "20000", "--caustic-photons", "5000"];

/// The canonical scene at 128 x 112 (7 rows of render tiles), `extra` appended.
fn scene(dir: &Path, name: &str, extra: &str) -> PathBuf {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/caustic-sphere.toml"
    ))
    .unwrap()
    .replace("width = 640", "width = 128")
    .replace("height = 480", "height = 112");
    let path = dir.join(name);
    std::fs::write(&path, text + extra).unwrap();
    path
}

fn run(args: &[&str]) -> Output {
    Command::new(EXE).args(args).output().unwrap()
}

fn ok(args: &[&str]) {
    let out = run(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The one-line error of a command that must fail with status 1.
fn error(args: &[&str]) -> String {
    let out = run(args);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.starts_with("photondiff: error: "), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    stderr.trim_end().to_string()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The pixels of an EXR as bits.
fn bits(path: &Path) -> Vec<[u64; 3]> {
    read_part(path)
        .unwrap()
        .film
        .pixels
        .iter()
        .map(|p| p.to_array().map(f64::to_bits))
        .collect()
}

/// Renders tile `i` of `n` of `scene` into `dir` with the file's photon counts and `extra`,
/// returning the part's path.
fn tile(scene: &Path, dir: &Path, i: u32, n: u32, extra: &[&str]) -> PathBuf {
    let mut options = PHOTONS.to_vec();
    options.extend(extra);
    tile_with(scene, dir, i, n, &options)
}

/// Renders tile `i` of `n` of `scene` into `dir` with `options` alone (the render's defaults
/// otherwise), returning the part's path.
fn tile_with(scene: &Path, dir: &Path, i: u32, n: u32, options: &[&str]) -> PathBuf {
    let out = dir.join(format!("tile-{i}-of-{n}.exr"));
    let t = format!("{i}/{n}");
    let mut args = vec!["render", s(scene), "-o", s(&out), "--tile", &t, "--quiet"];
    args.extend(options);
    ok(&args);
    out
}

#[test]
fn tiles_and_photon_map_files_give_the_single_process_image_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = scene(d, "scene.toml", "");
    let whole = d.join("whole.exr");
    let mut args = vec!["render", s(&scene), "-o", s(&whole), "--quiet"];
    args.extend(PHOTONS);
    ok(&args);
    let reference = bits(&whole);
    assert!(
        reference.iter().any(|p| p[0] != 0),
        "a black image proves nothing"
    );

    let maps = d.join("maps.pdm");
    let mut args = vec!["photons", s(&scene), "-o", s(&maps), "--quiet"];
    args.extend(PHOTONS);
    ok(&args);
    let with_maps: [&str; 2] = ["--photon-maps", s(&maps)];

    for (n, extra) in [(1, &with_maps[..]), (4, &with_maps[..]), (7, &[][..])] {
        let parts_dir = d.join(format!("split-{n}"));
        std::fs::create_dir(&parts_dir).unwrap();
        // Merged in reverse order: the order of the parts must not matter.
        let parts: Vec<PathBuf> = (0..n)
            .rev()
            .map(|i| tile(&scene, &parts_dir, i, n, extra))
            .collect();
        let part = read_part(&parts[0]).unwrap();
        assert_eq!(part.display, (128, 112));
        assert_eq!(part.window.y1, 112, "the last tile ends at the bottom");
        assert_eq!(part.metadata["photondiff/tile"], format!("{}/{n}", n - 1));
        let merged = parts_dir.join("merged.exr");
        let mut args = vec!["merge", "-o", s(&merged)];
        args.extend(parts.iter().map(|p| s(p)));
        ok(&args);
        assert!(
            bits(&merged) == reference,
            "{n} tiles differ from one process"
        );
        assert!(parts_dir.join("merged.png").exists());
    }
}

#[test]
fn maps_traced_for_an_estimator_take_its_defaults() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = scene(d, "scene.toml", "");
    // `pd` at its defaults: the thesis's photon counts, no aimed bounces, no wall probes,
    // none of which the default maps (for `integrated`) have.
    let whole = d.join("whole.exr");
    ok(&[
        "render",
        s(&scene),
        "-o",
        s(&whole),
        "--quiet",
        "--estimator",
        "pd",
    ]);
    let maps = d.join("pd.pdm");
    ok(&[
        "photons",
        s(&scene),
        "-o",
        s(&maps),
        "--quiet",
        "--estimator",
        "pd",
    ]);
    let pd_maps = ["--estimator", "pd", "--photon-maps", s(&maps)];
    let parts: Vec<PathBuf> = (0..2)
        .map(|i| tile_with(&scene, d, i, 2, &pd_maps))
        .collect();
    let merged = d.join("merged.exr");
    ok(&["merge", "-o", s(&merged), s(&parts[0]), s(&parts[1])]);
    assert!(
        bits(&merged) == bits(&whole),
        "pd's tiles over its maps differ from one process"
    );
    // The default render's maps are not `pd`'s, and say why.
    let default_maps = d.join("default.pdm");
    let mut args = vec!["photons", s(&scene), "-o", s(&default_maps), "--quiet"];
    args.extend(PHOTONS);
    ok(&args);
    let out = d.join("x.exr");
    let mut args = vec!["render", s(&scene), "-o", s(&out), "--estimator", "pd"];
    args.extend(PHOTONS);
    args.extend(["--photon-maps", s(&default_maps)]);
    let e = error(&args);
    assert!(
        e.ends_with("photon maps traced with other settings: --global-aim is 0.15 in the file, 0 in this render (given, or the default of the --estimator: `photons` takes the render's --estimator and photon options)"),
        "{e}"
    );
    // An estimator without photon maps has none to trace.
    let e = error(&[
        "photons",
        s(&scene),
        "-o",
        s(&out),
        "--estimator",
        "lighttrace",
    ]);
    assert_eq!(
        e,
        "photondiff: error: --estimator lighttrace uses no photon maps"
    );
    assert!(!out.exists());
}

#[test]
fn progressive_tiles_give_the_single_process_image_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = scene(d, "scene.toml", "");
    let whole = d.join("whole.exr");
    let mut args = vec![
        "render",
        s(&scene),
        "-o",
        s(&whole),
        "--quiet",
        "--passes",
        "3",
    ];
    args.extend(PHOTONS);
    ok(&args);
    // The file's maps stand for pass 0's; passes 1 and 2 trace their own.
    let maps = d.join("maps.pdm");
    let mut args = vec!["photons", s(&scene), "-o", s(&maps), "--quiet"];
    args.extend(PHOTONS);
    ok(&args);
    let extra = ["--passes", "3", "--photon-maps", s(&maps)];
    let parts: Vec<PathBuf> = (0..3).map(|i| tile(&scene, d, i, 3, &extra)).collect();
    assert_eq!(
        read_part(&parts[0]).unwrap().metadata["photondiff/passes"],
        "3"
    );
    let merged = d.join("merged.exr");
    let mut args = vec!["merge", "-o", s(&merged)];
    args.extend(parts.iter().map(|p| s(p)));
    ok(&args);
    assert!(
        bits(&merged) == bits(&whole),
        "progressive tiles differ from one process"
    );
}

#[test]
fn bad_splits_are_one_line_errors_without_output() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene(dir.path(), "scene.toml", "");
    let out = dir.path().join("t.exr");
    for (split, message) in [
        (
            "0/0",
            "--tile \"0/0\": the number of tiles N must be at least 1",
        ),
        (
            "5/4",
            "--tile \"5/4\": tile I must be below N = 4 (tiles count from 0)",
        ),
        (
            "0/8",
            "--tile 0/8: the 112-pixel-high image has only 7 rows of 16-pixel tiles; use at most 7 tiles",
        ),
        (
            "x",
            "--tile expected I/N with 0 <= I < N (I counts from 0), got \"x\"",
        ),
    ] {
        let e = error(&["render", s(&scene), "-o", s(&out), "--tile", split]);
        assert_eq!(e, format!("photondiff: error: {message}"));
    }
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        1,
        "only the scene"
    );
}

#[test]
fn merge_refuses_foreign_overlapping_and_incomplete_parts() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene_a = scene(d, "a.toml", "");
    let scene_b = scene(d, "b.toml", "# another scene\n");
    let a: Vec<PathBuf> = (0..4).map(|i| tile(&scene_a, d, i, 4, &[])).collect();
    let b0 = tile(&scene_b, &d.join("b"), 0, 4, &[]);
    let seed = tile(&scene_a, &d.join("seed"), 1, 4, &["--seed", "7"]);
    let compact = tile(&scene_a, &d.join("compact"), 1, 4, &["--bvh-compact"]);
    // Robust traversal changes hits on edges: parts with and without it are not one image.
    let robust = tile(&scene_a, &d.join("robust"), 1, 4, &["--bvh-robust"]);
    // A part whose glass surfaces chose branches: the same image in expectation only.
    let split = tile(&scene_a, &d.join("split"), 1, 4, &["--split-depth", "1"]);
    let seven = tile(&scene_a, &d.join("seven"), 0, 7, &[]);
    let out = d.join("merged.exr");
    let merge = |parts: &[&PathBuf]| {
        let mut args = vec!["merge", "-o", s(&out)];
        args.extend(parts.iter().map(|p| s(p)));
        let e = error(&args);
        assert!(
            !out.exists() && !d.join("merged.png").exists(),
            "partial output"
        );
        e
    };
    let e = merge(&[&a[0], &a[1], &a[2], &b0]);
    assert_eq!(
        e,
        format!(
            "photondiff: error: {0} is from another scene than {1}: photondiff/scene_hash is {3:016x} in {0}, {2:016x} in {1}",
            s(&b0),
            s(&a[0]),
            scene_hash(&scene_a).unwrap(),
            scene_hash(&scene_b).unwrap()
        )
    );
    let e = merge(&[&a[0], &seed, &a[2], &a[3]]);
    assert_eq!(
        e,
        format!(
            "photondiff: error: {0} has other settings than {1}: photondiff/seed is 7 in {0}, 0 in {1}",
            s(&seed),
            s(&a[0])
        )
    );
    let e = merge(&[&a[0], &split, &a[2], &a[3]]);
    assert_eq!(
        e,
        format!(
            "photondiff: error: {0} has other settings than {1}: photondiff/split_depth is 1 in {0}, (none) in {1}",
            s(&split),
            s(&a[0])
        )
    );
    let e = merge(&[&a[0], &robust, &a[2], &a[3]]);
    assert_eq!(
        e,
        format!(
            "photondiff: error: {0} has other settings than {1}: photondiff/bvh_robust is true in {0}, false in {1}",
            s(&robust),
            s(&a[0])
        )
    );
    // Embree 4's compact BVH answers a few rays in a million otherwise: its parts and the
    // ordinary BVH's are not one image there. Embree 3's agree bit for bit, and merge.
    if photondiff::embree::COMPACT_CHANGES_HITS {
        let e = merge(&[&a[0], &compact, &a[2], &a[3]]);
        assert_eq!(
            e,
            format!(
                "photondiff: error: {0} has other settings than {1}: photondiff/bvh_compact is true in {0}, false in {1}",
                s(&compact),
                s(&a[0])
            )
        );
    } else {
        assert_eq!(bits(&compact), bits(&a[1]), "Embree 3: the same pixels");
        let merged = d.join("merged-compact.exr");
        ok(&[
            "merge",
            "-o",
            s(&merged),
            s(&a[0]),
            s(&compact),
            s(&a[2]),
            s(&a[3]),
        ]);
    }
    let e = merge(&[&a[0], &a[1], &a[1], &a[2], &a[3]]);
    assert_eq!(
        e,
        format!(
            "photondiff: error: {} (tile 1/4, x 0..128, y 16..48) overlaps {} (tile 1/4, x 0..128, y 16..48)",
            s(&a[1]),
            s(&a[1])
        )
    );
    let e = merge(&[&a[0], &seven, &a[1]]);
    assert_eq!(
        e,
        format!(
            "photondiff: error: {} (tile 0/4, x 0..128, y 0..16) overlaps {} (tile 0/7, x 0..128, y 0..16)",
            s(&a[0]),
            s(&seven)
        )
    );
    let e = merge(&[&a[2]]);
    assert_eq!(e, "photondiff: error: missing tiles: 0/4, 1/4, 3/4");
    // A part changed after it was written (one value, the file otherwise whole).
    let damaged = d.join("damaged.exr");
    std::fs::copy(&a[1], &damaged).unwrap();
    tamper(&damaged, "G", 37);
    let e = merge(&[&a[0], &damaged, &a[2], &a[3]]);
    assert_eq!(
        e,
        format!(
            "photondiff: error: {}: its pixels do not match the checksum written with them: the file was changed or damaged after it was written",
            s(&damaged)
        )
    );
}

/// Changes sample `i` of channel `name` of the EXR at `path` (its lowest bit), keeping every
/// attribute as written: a part damaged after it was written.
fn tamper(path: &Path, name: &str, i: usize) {
    use exr::prelude::*;
    let mut image = read_all_data_from_file(path).unwrap();
    let channel = image.layer_data[0]
        .channel_data
        .list
        .iter_mut()
        .find(|c| c.name.to_string() == name)
        .unwrap();
    match &mut channel.sample_data {
        Levels::Singular(FlatSamples::F32(v)) => v[i] = f32::from_bits(v[i].to_bits() ^ 1),
        Levels::Singular(FlatSamples::U32(v)) => v[i] ^= 1,
        _ => panic!("{name}: not f32 or u32 samples"),
    }
    image.write().to_file(path).unwrap();
}

#[test]
fn bad_photon_map_files_are_one_line_errors_without_output() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene_a = scene(d, "a.toml", "");
    let scene_b = scene(d, "b.toml", "# another scene\n");
    let maps = d.join("a.pdm");
    let mut args = vec!["photons", s(&scene_a), "-o", s(&maps), "--quiet"];
    args.extend(PHOTONS);
    ok(&args);
    let bytes = std::fs::read(&maps).unwrap();
    let out = d.join("out").join("x.exr");
    let render = |scene: &Path, maps: &Path, extra: &[&str]| {
        let mut args = vec!["render", s(scene), "-o", s(&out), "--photon-maps", s(maps)];
        args.extend(PHOTONS);
        args.extend(extra);
        let e = error(&args);
        assert!(!out.exists(), "partial output");
        e
    };
    let name = s(&maps);
    let e = render(&scene_b, &maps, &[]);
    assert_eq!(
        e,
        format!(
            "photondiff: error: {name}: photon maps of another scene (scene hash {:016x}; this scene's is {:016x})",
            scene_hash(&scene_a).unwrap(),
            scene_hash(&scene_b).unwrap()
        )
    );
    let e = render(&scene_a, &maps, &["--overlap", "16"]);
    assert!(e.ends_with("photon maps traced with other settings: --overlap is 32 in the file, 16 in this render (given, or the default of the --estimator: `photons` takes the render's --estimator and photon options)"), "{e}");
    let cut = d.join("cut.pdm");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let e = render(&scene_a, &cut, &[]);
    assert_eq!(
        e,
        format!(
            "photondiff: error: {}: truncated photon-map file: {} bytes, expected {}",
            s(&cut),
            bytes.len() / 2,
            bytes.len()
        )
    );
    let flipped = d.join("flipped.pdm");
    let mut f = bytes.clone();
    let k = f.len() - 100;
    f[k] ^= 1;
    std::fs::write(&flipped, &f).unwrap();
    let e = render(&scene_a, &flipped, &[]);
    assert!(
        e.ends_with("flipped.pdm: corrupt photon-map file: checksum mismatch"),
        "{e}"
    );
    // A version this build does not read: the next one.
    let next = photondiff::photons::file::VERSION + 1;
    let version = d.join("next.pdm");
    let mut v = bytes.clone();
    v[8..12].copy_from_slice(&next.to_le_bytes());
    std::fs::write(&version, &v).unwrap();
    let e = render(&scene_a, &version, &[]);
    assert!(
        e.ends_with(&format!(
            "next.pdm: photon-map file format version {next}; this photondiff reads version {}",
            next - 1
        )),
        "{e}"
    );
    let e = render(&scene_a, &scene_a, &[]);
    assert!(
        e.ends_with("a.toml: not a photondiff photon-map file"),
        "{e}"
    );
    let e = render(&scene_a, &d.join("none.pdm"), &[]);
    assert!(e.contains("none.pdm: cannot read photon maps: "), "{e}");
    // Everything the file's header shows is refused before the scene is read (a large one
    // takes seconds to load): the same errors with a scene that does not exist. The scene's
    // hash and the checksum need the scene and the photons.
    let missing = d.join("missing.toml");
    let none = d.join("none.pdm");
    for (maps, extra) in [
        (&maps, &["--overlap", "16"][..]),
        (&cut, &[]),
        (&version, &[]),
        (&scene_a, &[]),
        (&none, &[]),
    ] {
        assert_eq!(render(&missing, maps, extra), render(&scene_a, maps, extra));
    }
    let e = render(&missing, &flipped, &[]);
    assert!(e.contains("missing.toml"), "{e}");
    // A named pipe (a shell's `<(cat a.pdm)`) is read once, whole, after the scene: its header
    // is not read ahead, which would take it from the render.
    let fifo = d.join("maps.fifo");
    mkfifo(&fifo);
    let writer = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::write(fifo, bytes).unwrap())
    };
    let mut args = vec![
        "render",
        s(&scene_a),
        "-o",
        s(&out),
        "--photon-maps",
        s(&fifo),
    ];
    args.extend(["--quiet"]);
    args.extend(PHOTONS);
    ok(&args);
    writer.join().unwrap();
    assert!(out.exists());
    // The scene as a named pipe, with maps to match: read once, and hashed from what was read
    // (a second read to hash it waited for a writer for ever, or hashed nothing).
    std::fs::remove_file(&out).unwrap();
    let scene_fifo = d.join("scene.fifo");
    mkfifo(&scene_fifo);
    let text = std::fs::read(&scene_a).unwrap();
    let writer = {
        let fifo = scene_fifo.clone();
        std::thread::spawn(move || std::fs::write(fifo, text).unwrap())
    };
    let mut child = Command::new(env!("CARGO_BIN_EXE_photondiff"))
        .args([
            "render",
            s(&scene_fifo),
            "-o",
            s(&out),
            "--photon-maps",
            s(&maps),
        ])
        .args(["--quiet"])
        .args(PHOTONS)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let status = common::wait_at_most(&mut child, std::time::Duration::from_secs(120))
        .expect("a scene from a named pipe: the render did not finish in two minutes");
    let mut stderr = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut stderr).unwrap();
    assert!(status.success(), "{stderr}");
    writer.join().unwrap();
    assert!(out.exists());
}

/// Makes a named pipe at `path`.
fn mkfifo(path: &Path) {
    assert!(Command::new("mkfifo").arg(path).status().unwrap().success());
}

/// Renders `scene` into `out` with the small photon counts and `extra`.
fn part(scene: &Path, out: &Path, extra: &[&str]) -> PathBuf {
    let mut args = vec!["render", s(scene), "-o", s(out), "--quiet"];
    args.extend(PHOTONS);
    args.extend(extra);
    ok(&args);
    out.to_path_buf()
}

/// A part's summary and JSON tell its own passes from the whole render's (they said "3
/// passes" for passes 1 to 3 of 4); the merge of `merge_args`' parts, of all 4.
fn pass_range_reports(scene: &Path, d: &Path, merge_args: &[String]) {
    let json = d.join("r1.json");
    let image = d.join("r1b.exr");
    let mut args = vec!["render", s(scene), "-o", s(&image)];
    args.extend(PHOTONS);
    args.extend([
        "--passes",
        "4",
        "--pass-range",
        "1..4",
        "--stats-json",
        s(&json),
    ]);
    let out = run(&args);
    assert!(out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("progressive: passes 1 to 3 of a 4-pass render ("),
        "{stderr}"
    );
    let read = |p: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
    };
    let p = &read(&json)["progressive"];
    assert_eq!(
        (&p["passes"], &p["pass_range"]),
        (&4.into(), &serde_json::json!([1, 4]))
    );
    let merged = d.join("merged.json");
    let mut args: Vec<&str> = merge_args.iter().map(|a| a.as_str()).collect();
    args.extend(["--stats-json", s(&merged)]);
    ok(&args);
    let p = &read(&merged)["progressive"];
    assert_eq!((&p["passes"], p.get("pass_range")), (&4.into(), None));
    // A range of every pass traces the camera rays the whole run does: the edge pixels found
    // once, not once a pass (502,568 camera rays against 349,096 for 8 passes).
    let stats = |extra: &[&str]| {
        let json = d.join("rays.json");
        let mut args = vec!["render", s(scene), "-o", s(&image), "--quiet"];
        args.extend(PHOTONS);
        args.extend(["--passes", "4", "--stats-json", s(&json)]);
        args.extend(extra);
        ok(&args);
        read(&json)
    };
    let whole = stats(&[]);
    let camera_rays = |s: &serde_json::Value| s["rays"]["camera"].as_u64().unwrap();
    assert_eq!(
        camera_rays(&stats(&["--pass-range", "0..4"])),
        camera_rays(&whole)
    );
    // The merged ranges' photon maps are the whole run's: counts over all 4 passes (not the
    // first-named part's 3), the power their mean; the seconds a pass weighed by passes.
    let merged = read(&merged);
    // The noise of the mean, from the merged sums of the whole image: the whole run's (it was
    // null, and a split run lost its only convergence figure).
    let noise = |s: &serde_json::Value, key: &str| s["progressive"]["noise"][key].clone();
    for key in ["whole", "caustic"] {
        let (a, b) = (noise(&merged, key), noise(&whole, key));
        let (a, b) = (a.as_f64().unwrap(), b.as_f64().unwrap());
        assert!((a - b).abs() <= 1e-9 * b, "noise {key}: {a} against {b}");
    }
    assert_eq!(
        noise(&merged, "caustic_pixels"),
        noise(&whole, "caustic_pixels")
    );
    for (m, w) in merged["photon_maps"]
        .as_array()
        .unwrap()
        .iter()
        .zip(whole["photon_maps"].as_array().unwrap())
    {
        for key in ["class", "emitted", "stored", "rays", "asked", "cap_reached"] {
            assert_eq!(m[key], w[key], "{key}: {m} against {w}");
        }
        let (a, b) = (m["power"].as_f64().unwrap(), w["power"].as_f64().unwrap());
        assert!((a - b).abs() <= 1e-9 * b.abs(), "power {a} against {b}");
    }
}

#[test]
fn pass_ranges_and_tiles_merge_into_the_single_process_image_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = scene(d, "scene.toml", "");
    let whole = part(&scene, &d.join("whole.exr"), &["--passes", "4"]);
    let merge = |name: &str, parts: &[&PathBuf]| {
        let out = d.join(name);
        let mut args = vec!["merge".to_string(), "-o".into(), s(&out).into()];
        args.extend(parts.iter().map(|p| s(p).to_string()));
        (out, args)
    };
    // Two pass ranges of the whole image.
    let r0 = part(
        &scene,
        &d.join("r0.exr"),
        &["--passes", "4", "--pass-range", "0..1"],
    );
    let r1 = part(
        &scene,
        &d.join("r1.exr"),
        &["--passes", "4", "--pass-range", "1..4"],
    );
    let (out, args) = merge("ranges.exr", &[&r1, &r0]);
    ok(&args.iter().map(|a| a.as_str()).collect::<Vec<_>>());
    // A pass sum changed after the part was written: merged, it moved the image (one flipped
    // byte: relRMSE 1.9e13) without a word.
    let damaged = d.join("damaged.exr");
    std::fs::copy(&r1, &damaged).unwrap();
    tamper(&damaged, "pd.fixed.R.1", 200);
    let (_, bad) = merge("bad.exr", &[&damaged, &r0]);
    assert_eq!(
        error(&bad.iter().map(|a| a.as_str()).collect::<Vec<_>>()),
        format!(
            "photondiff: error: {}: its pass sums do not match the checksum written with them: the file was changed or damaged after it was written",
            s(&damaged)
        )
    );
    pass_range_reports(&scene, d, &args);
    assert!(
        bits(&out) == bits(&whole),
        "2 pass ranges differ from one process"
    );
    // Tiles split differently by passes.
    let t = |i: u32, range: &str| {
        let name = format!("t{i}-{range}.exr");
        let t = format!("{i}/2");
        part(
            &scene,
            &d.join(name),
            &["--passes", "4", "--tile", &t, "--pass-range", range],
        )
    };
    let (a, b, c, e) = (t(0, "0..2"), t(0, "2..4"), t(1, "0..3"), t(1, "3..4"));
    let (out, args) = merge("tiles.exr", &[&c, &a, &e, &b]);
    ok(&args.iter().map(|a| a.as_str()).collect::<Vec<_>>());
    assert!(
        bits(&out) == bits(&whole),
        "tiles x pass ranges differ from one process"
    );
    // Missing and overlapping ranges.
    let (out, args) = merge("bad.exr", &[&a, &c]);
    let e1 = error(&args.iter().map(|a| a.as_str()).collect::<Vec<_>>());
    assert_eq!(
        e1,
        "photondiff: error: missing passes 2..4 of tile 0/2; missing passes 3..4 of tile 1/2"
    );
    let wide = t(0, "1..3");
    let (_, args) = merge("bad.exr", &[&a, &wide, &b, &c, &e]);
    let e2 = error(&args.iter().map(|a| a.as_str()).collect::<Vec<_>>());
    assert!(
        e2.contains("(tile 0/2, passes 0..2, x 0..128, y 0..48) overlaps"),
        "{e2}"
    );
    assert!(!out.exists(), "partial output");
    // Bad ranges.
    let bad = d.join("bad-range.exr");
    for (extra, message) in [
        (
            &["--passes", "4", "--pass-range", "3..3"][..],
            "--pass-range expected A..B with A < B (passes A to B - 1, from 0), got \"3..3\"",
        ),
        (
            &["--passes", "4", "--pass-range", "5..2"][..],
            "--pass-range expected A..B with A < B (passes A to B - 1, from 0), got \"5..2\"",
        ),
        (
            &["--passes", "4", "--pass-range", "2..5"][..],
            "--pass-range 2..5: passes beyond --passes 4 (passes count from 0)",
        ),
        (
            &["--pass-range", "0..1"][..],
            "--pass-range needs --passes N (the whole render's passes) and neither --time-budget nor --target-noise",
        ),
        // Maps from a file are pass 0's: a range without pass 0 would ignore them.
        (
            &["--passes", "4", "--pass-range", "1..3", "--photon-maps", "maps.pdm"][..],
            "--photon-maps holds pass 0's photons, which --pass-range 1..3 does not render (passes count from 0; the other passes trace their own)",
        ),
    ] {
        let mut args = vec!["render", s(&scene), "-o", s(&bad)];
        args.extend(extra);
        let e = error(&args);
        assert_eq!(e, format!("photondiff: error: {message}"));
        assert!(!bad.exists());
    }
}

/// `farm/slurm/submit.sh` refuses, before submitting anything, what would fail only once the
/// cluster had run: an OUTDIR holding an earlier run's parts (the merge took them beside the
/// new ones and failed after every task), an option without its value.
#[test]
fn submit_refuses_an_earlier_runs_parts_and_a_missing_value_before_any_job() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene(dir.path(), "s.toml", "");
    let out = dir.path().join("run");
    std::fs::create_dir_all(out.join("parts")).unwrap();
    std::fs::write(out.join("parts/tile-0-of-4.passes-0-1.exr"), b"").unwrap();
    let submit = concat!(env!("CARGO_MANIFEST_DIR"), "/farm/slurm/submit.sh");
    let run = |args: &[&str]| {
        // No sbatch on PATH: a job submitted would fail with "not found", not with the refusal.
        let out = Command::new("sh")
            .arg(submit)
            .args(args)
            .env("PHOTONDIFF", EXE)
            .env("PATH", "/usr/bin:/bin")
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
        (
            out.status.code(),
            stderr.lines().next().unwrap_or("").to_string(),
        )
    };
    assert_eq!(
        run(&[s(&scene), s(&out)]),
        (
            Some(1),
            format!(
                "submit.sh: {} holds parts of an earlier run (tile-0-of-4.passes-0-1.exr): give a \
                 new OUTDIR, or remove them (--array re-runs tasks of that run)",
                out.join("parts").display()
            )
        )
    );
    assert_eq!(
        run(&["--tiles"]),
        (Some(1), "submit.sh: --tiles needs a value".to_string())
    );
}
