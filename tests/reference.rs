//! The light-tracing reference: its direct light on the floor against the analytic value, its
//! noise estimate, and its independence of the thread count.

use glam::DVec3;
use photondiff::embree::Device;
use photondiff::reference::light_tracer::{LightTraceOptions, LightTracer};
use photondiff::scene::file::load_scene;
use photondiff::scene::Scene;
use std::f64::consts::PI;
use std::path::Path;

mod common;

/// The canonical scene at `width x height`.
fn canonical(width: u32, height: u32) -> Scene {
    let mut scene = load_scene(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/caustic-sphere.toml"
    )))
    .unwrap();
    scene.camera = scene.camera.with_resolution(width, height);
    scene
}

#[test]
fn light_traced_direct_light_matches_the_analytic_value() {
    // Without the sphere: with it, light it reflects onto the floor adds about 1% here, which the
    // analytic direct light leaves out.
    let mut scene = canonical(80, 60);
    scene.meshes.truncate(1);
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let options = LightTraceOptions {
        paths: 12_000_000,
        seed: 3,
        ..LightTraceOptions::default()
    };
    let tracer = LightTracer::new(&scene, &embree, &options);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let result = pool.install(|| tracer.run(&indicatif::ProgressBar::hidden()));
    // A block of pixels around the pixel that sees (0, 0, 3).
    let camera = &scene.camera;
    let (x, y) = camera.project(DVec3::new(0.0, 0.0, 3.0)).unwrap();
    let (cx, cy) = (x as u32, y as u32);
    let light = DVec3::new(-4.0, 4.0, -1.0);
    let mut pixels = Vec::new();
    let (mut measured, mut analytic) = (0.0, 0.0);
    for py in cy.saturating_sub(16)..=(cy + 12).min(camera.height - 1) {
        for px in cx.saturating_sub(12)..=(cx + 12).min(camera.width - 1) {
            // The pixel's average of I cos / d^2 * albedo / pi over the floor it sees.
            let n = 16;
            let mut value = 0.0;
            for j in 0..n {
                for i in 0..n {
                    let r = camera.ray(
                        px as f64 + (i as f64 + 0.5) / n as f64,
                        py as f64 + (j as f64 + 0.5) / n as f64,
                        1.0,
                    );
                    let p = r.p + r.d * (-r.p.y / r.d.y);
                    let to = light - p;
                    let d2 = to.length_squared();
                    value += 60.0 * (to.y / d2.sqrt()) / d2 * 0.75 / PI / (n * n) as f64;
                }
            }
            analytic += value;
            pixels.push((py * camera.width + px) as usize);
            measured += result.film.pixel(px, py).x;
        }
    }
    assert!(pixels.len() > 400, "{} pixels", pixels.len());
    let noise = result.relative_noise(&pixels) / (pixels.len() as f64).sqrt();
    assert!(noise < 0.004, "the test's reference is too noisy: {noise}");
    let relative = measured / analytic - 1.0;
    assert!(
        relative.abs() < 0.01 + 3.0 * noise,
        "light traced {measured}, analytic {analytic} ({relative:+.4}, noise {noise:.4})"
    );
}

#[test]
fn light_tracing_ignores_the_thread_count() {
    let scene = canonical(40, 30);
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let options = LightTraceOptions {
        paths: 300_000,
        ..LightTraceOptions::default()
    };
    let tracer = LightTracer::new(&scene, &embree, &options);
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| tracer.run(&indicatif::ProgressBar::hidden()))
    };
    let (one, two) = (run(1), run(2));
    assert!(
        one.film == two.film,
        "the reference differs between 1 and 2 threads"
    );
    assert!(one.film.pixels.iter().any(|p| p.x > 0.0));
    assert!(one.half_a != one.half_b);
}

/// Mean over `pixels` and channels.
fn region_mean(film: &photondiff::render::film::Film, pixels: &[usize]) -> f64 {
    let sum: f64 = pixels
        .iter()
        .map(|&i| film.pixels[i].x + film.pixels[i].y + film.pixels[i].z)
        .sum();
    sum / (3 * pixels.len()) as f64
}

#[test]
fn split_reference_agrees_with_plain_light_tracing_and_is_less_noisy() {
    use photondiff::reference::cache::{make, ReferenceSettings};
    use photondiff::reference::metrics::Regions;
    use photondiff::render::stats::Stats;
    let scene = canonical(80, 60);
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let paths = 6_000_000;
    let options = LightTraceOptions {
        paths,
        seed: 5,
        ..LightTraceOptions::default()
    };
    let plain = pool.install(|| {
        LightTracer::new(&scene, &embree, &options).run(&indicatif::ProgressBar::hidden())
    });
    let settings = ReferenceSettings {
        light_paths: paths / 2,
        caustic_paths: paths / 2,
        direct_grids: [4, 5],
        seed: 0,
    };
    let split = pool
        .install(|| {
            make(
                &scene,
                &embree,
                &settings,
                false,
                &mut |_| {},
                &mut Stats::default(),
            )
        })
        .unwrap();
    let regions = Regions::new(&scene, &embree, &split.film);
    for (name, pixels) in [
        ("floor", &regions.diffuse),
        ("caustic", &regions.caustic),
        ("shadow", &regions.shadow),
    ] {
        assert!(pixels.len() >= 20, "{name}: only {} pixels", pixels.len());
        let (a, b) = (
            region_mean(&plain.film, pixels),
            region_mean(&split.film, pixels),
        );
        let n = (pixels.len() as f64).sqrt();
        let (noise_plain, noise_split) =
            (plain.relative_noise(pixels), split.relative_noise(pixels));
        let sigma = (noise_plain.powi(2) + noise_split.powi(2)).sqrt() / n;
        assert!(
            (b / a - 1.0).abs() < 0.01 + 4.0 * sigma,
            "{name}: split {b}, plain {a} ({:+.4}, sigma {sigma:.4})",
            b / a - 1.0
        );
        // Same number of paths, but none wasted on directions that miss the sphere and no noise
        // from direct light: the caustic and the floor must be far less noisy.
        if name != "shadow" {
            assert!(
                noise_split < 0.5 * noise_plain,
                "{name}: split noise {noise_split:.4}, plain {noise_plain:.4}"
            );
        }
    }
}

/// Runs `photondiff reference` on a 64 x 48 canonical scene with `args`; returns its status and
/// standard error.
fn reference_cli(dir: &std::path::Path, args: &[&str]) -> (bool, String) {
    let scene = dir.join("scene.toml");
    let text = include_str!("../scenes/caustic-sphere.toml")
        .replace("width = 640", "width = 64")
        .replace("height = 480", "height = 48");
    std::fs::write(&scene, text).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_photondiff"))
        .arg("reference")
        .arg(&scene)
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A reference made in parts with different seeds and merged is the parts' mean, image and
/// halves alike; parts that are not independent or not alike are refused.
#[test]
fn references_made_in_parts_merge_into_their_mean() {
    use photondiff::render::film::Film;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let small = ["--light-paths", "200000", "--caustic-paths", "100000"];
    let grids = ["--direct-grids", "2,3"];
    for seed in ["1", "2"] {
        let out = format!("part{seed}.exr");
        // The first part quiet, the second telling its stages.
        let quiet: &[&str] = if seed == "1" { &["--quiet"] } else { &[] };
        let (ok, err) = reference_cli(
            d,
            &[
                &small[..],
                &grids,
                quiet,
                &[
                    "--seed",
                    seed,
                    "-o",
                    &out,
                    "--stats-json",
                    &format!("part{seed}.json"),
                ],
            ]
            .concat(),
        );
        assert!(ok, "{err}");
        // Rounded up to an even number of chunks of 65,536 (4 and 2).
        let told = err.contains("reference: light tracing 262144 + 131072 caustic paths");
        // Quiet, only the warning that the sphere's pixels stay dark.
        let warned_only = err.lines().count() == 1
            && err.contains(" pixels show a mirror or glass surface, which light tracing");
        assert_eq!((told, warned_only), (seed == "2", seed == "1"), "{err}");
    }
    let (ok, err) = reference_cli(
        d,
        &[
            "--merge",
            "part1.exr",
            "part2.exr",
            "-o",
            "all.exr",
            "--stats-json",
            "all.json",
        ],
    );
    assert!(ok, "{err}");
    // The merge's statistics count its parts' light paths and rays.
    let light = |name: &str| {
        let text = std::fs::read_to_string(d.join(name)).unwrap();
        let json: serde_json::Value = serde_json::from_str(&text).unwrap();
        [&json["light_paths"], &json["light_rays"]].map(|v| v.as_u64().unwrap())
    };
    let (one, two) = (light("part1.json"), light("part2.json"));
    assert_eq!(one[0], 262_144 + 131_072);
    assert!(one[1] > one[0] && two[1] > two[0] && one[1] != two[1]);
    assert_eq!(light("all.json"), [one[0] + two[0], one[1] + two[1]]);
    for suffix in ["", "-a", "-b"] {
        let read = |name: &str| Film::read_exr(&d.join(format!("{name}{suffix}.exr"))).unwrap();
        let (one, two, all) = (read("part1"), read("part2"), read("all"));
        assert!(one != two, "seeds 1 and 2 traced the same paths");
        for ((a, b), m) in one.pixels.iter().zip(&two.pixels).zip(&all.pixels) {
            let mean = (*a + *b) * 0.5;
            assert!((*m - mean).abs().max_element() <= 1e-6 * mean.max_element().max(1e-30));
        }
    }
    // A reference whose half is another's, or of another size, is refused, naming it: the
    // merge would average that half in as this reference's.
    for (name, part, half) in [("swap", "part2", "part1-b.exr"), ("small", "part1", "")] {
        for suffix in ["", "-a"] {
            let from = d.join(format!("{part}{suffix}.exr"));
            std::fs::copy(from, d.join(format!("{name}{suffix}.exr"))).unwrap();
        }
        match half {
            "" => Film::new(32, 48)
                .write_exr(&d.join("small-b.exr"), &[])
                .unwrap(),
            _ => drop(std::fs::copy(d.join(half), d.join(format!("{name}-b.exr"))).unwrap()),
        }
    }
    let (ok, err) = reference_cli(d, &["--merge", "part1.exr", "swap.exr", "-o", "y.exr"]);
    assert!(!ok);
    assert!(
        err.starts_with("photondiff: error: swap.exr: pixel (")
            && err.ends_with(
                "is not the mean of its halves swap-a.exr and swap-b.exr: a half was replaced \
                 or belongs to another reference\n"
            ),
        "{err}"
    );
    let (ok, err) = reference_cli(d, &["--merge", "part2.exr", "small.exr", "-o", "y.exr"]);
    assert!(!ok);
    assert_eq!(
        err,
        "photondiff: error: small-b.exr: 32x48 pixels, but its reference small.exr has 64x48\n"
    );
    assert!(!d.join("y.exr").exists());
    // A half given as a part: its own halves are missing, and the message says whose.
    let (ok, err) = reference_cli(d, &["--merge", "part2-b.exr", "-o", "y.exr"]);
    assert!(!ok);
    assert!(
        err.starts_with("photondiff: error: part2-b-a.exr: cannot read EXR: ")
            && err.ends_with(" (half a of part2-b.exr, being merged)\n"),
        "{err}"
    );
    // A merged reference merges again as the parts it holds: all.exr (seeds 1 and 2) with a
    // third part is the mean of the three, weighing two to one; with part 1 again, refused.
    let (ok, err) = reference_cli(
        d,
        &[
            &small[..],
            &grids,
            &[
                "--quiet",
                "--seed",
                "3",
                "-o",
                "part3.exr",
                "--stats-json",
                "part3.json",
            ],
        ]
        .concat(),
    );
    assert!(ok, "{err}");
    let (ok, err) = reference_cli(
        d,
        &[
            "--merge",
            "all.exr",
            "part3.exr",
            "-o",
            "all3.exr",
            "--stats-json",
            "all3.json",
        ],
    );
    assert!(ok, "{err}");
    let three = light("part3.json");
    assert_eq!(
        light("all3.json"),
        [one[0] + two[0] + three[0], one[1] + two[1] + three[1]]
    );
    for suffix in ["", "-a", "-b"] {
        let read = |name: &str| Film::read_exr(&d.join(format!("{name}{suffix}.exr"))).unwrap();
        let parts = [read("part1"), read("part2"), read("part3")];
        for (i, m) in read("all3").pixels.iter().enumerate() {
            let mean = parts.iter().map(|p| p.pixels[i]).sum::<glam::DVec3>() / 3.0;
            assert!((*m - mean).abs().max_element() <= 1e-6 * mean.max_element().max(1e-30));
        }
    }
    let merged = photondiff::render::part::read_part(&d.join("all3.exr")).unwrap();
    assert_eq!(
        merged.metadata["photondiff/reference"],
        "mean of 3 references with seeds [1, 2, 3], each 200000-100000-2x3"
    );
    let (ok, err) = reference_cli(d, &["--merge", "all.exr", "part1.exr", "-o", "x.exr"]);
    assert!(!ok);
    assert!(err.contains("part1.exr: seed 1 appears twice"), "{err}");
    // A merged reference whose count of parts disagrees with its seeds is refused, naming it.
    let text = "mean of 2 references with seeds [7], each 200000-100000-2x3";
    let meta = [("photondiff/reference".to_string(), text.to_string())];
    for suffix in ["", "-a", "-b"] {
        let film = Film::new(64, 48);
        film.write_exr(&d.join(format!("odd{suffix}.exr")), &meta)
            .unwrap();
    }
    let (ok, err) = reference_cli(d, &["--merge", "odd.exr", "part3.exr", "-o", "x.exr"]);
    assert!(!ok);
    assert_eq!(
        err,
        format!("photondiff: error: odd.exr: cannot read the merged parts' seeds in {text:?}\n")
    );
    // A part written before references counted their light paths merges, its count unknown
    // (0); one whose count cannot be read is refused, naming it.
    let old = [(
        "photondiff/reference".to_string(),
        "200000-100000-2x3-seed9".to_string(),
    )];
    let bad = [
        old[0].clone(),
        (
            "photondiff/light_tracing".to_string(),
            "many paths, 3 rays".to_string(),
        ),
    ];
    for suffix in ["", "-a", "-b"] {
        let film = Film::new(64, 48);
        film.write_exr(&d.join(format!("old{suffix}.exr")), &old)
            .unwrap();
        film.write_exr(&d.join(format!("bad{suffix}.exr")), &bad)
            .unwrap();
    }
    let (ok, err) = reference_cli(
        d,
        &[
            "--merge",
            "old.exr",
            "part3.exr",
            "-o",
            "old3.exr",
            "--stats-json",
            "old3.json",
        ],
    );
    assert!(ok, "{err}");
    assert_eq!(light("old3.json"), [0, 0]);
    let (ok, err) = reference_cli(d, &["--merge", "part3.exr", "bad.exr", "-o", "x.exr"]);
    assert!(!ok);
    assert_eq!(
        err,
        "photondiff: error: bad.exr: cannot read the light paths and rays in \
         photondiff/light_tracing \"many paths, 3 rays\"\n"
    );
    // Tracing settings say nothing to a merge: given with it, they are refused (they were
    // ignored), and --direct-grids twice is refused (its values were appended).
    for extra in [
        ["--light-paths", "5"],
        ["--seed", "4"],
        ["--direct-grids", "2,4"],
    ] {
        let (ok, err) = reference_cli(
            d,
            &[
                &["--merge", "part1.exr", "part2.exr", "-o", "x.exr"][..],
                &extra,
            ]
            .concat(),
        );
        assert!(!ok);
        assert!(
            err.starts_with(&format!(
                "error: the argument '--merge <PART.exr>...' cannot be used with '{}",
                extra[0]
            )),
            "{err}"
        );
    }
    let (ok, err) = reference_cli(
        d,
        &[
            "--direct-grids",
            "2,3",
            "--direct-grids",
            "4,5",
            "-o",
            "x.exr",
        ],
    );
    assert!(!ok);
    assert!(
        err.starts_with("error: the argument '--direct-grids <A,B>' cannot be used multiple times"),
        "{err}"
    );
    // Each grid in 1..=64, told as such (-1 was "not in 0..=4294967295"), and the two apart.
    for (grids, bad) in [("-1,1", "-1"), ("0,2", "0"), ("2,65", "65")] {
        let (ok, err) = reference_cli(d, &[&format!("--direct-grids={grids}"), "-o", "x.exr"]);
        assert!(!ok);
        let expected = format!(
            "error: invalid value '{bad}' for '--direct-grids <A,B>': {bad} is not in 1..=64"
        );
        assert!(err.starts_with(&expected), "{err}");
    }
    let (ok, err) = reference_cli(d, &["--direct-grids", "3,3", "-o", "x.exr"]);
    assert!(!ok);
    assert_eq!(
        err,
        "photondiff: error: --direct-grids must be two different numbers in 1..=64, got [3, 3]\n"
    );
    // The same seed twice would count the same paths twice.
    let (ok, err) = reference_cli(d, &["--merge", "part1.exr", "part1.exr", "-o", "x.exr"]);
    assert!(!ok);
    assert!(err.contains("part1.exr: seed 1 appears twice"), "{err}");
    // What needs no scene is refused before the scene is read (a large one takes seconds):
    // the same errors for a scene that does not exist.
    for (args, message) in [
        (
            &["--merge", "part1.exr", "part1.exr", "-o", "x.exr"][..],
            "photondiff: error: part1.exr: seed 1 appears twice among the parts: they would not \
             be independent\n",
        ),
        (
            &["--light-paths", "0", "--caustic-paths", "0", "-o", "x.exr"][..],
            "photondiff: error: --light-paths and --caustic-paths cannot both be 0\n",
        ),
    ] {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_photondiff"))
            .arg("reference")
            .arg(d.join("missing.toml"))
            .args(args)
            .current_dir(d)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        assert_eq!(String::from_utf8_lossy(&out.stderr), message);
    }
    // Other settings (here the direct grids) cannot be averaged.
    let (ok, err) = reference_cli(
        d,
        &[
            &small[..],
            &["--direct-grids", "2,4", "--seed", "3", "-o", "part3.exr"],
        ]
        .concat(),
    );
    assert!(ok, "{err}");
    let (ok, err) = reference_cli(d, &["--merge", "part1.exr", "part3.exr", "-o", "x.exr"]);
    assert!(!ok);
    assert!(
        err.contains(
            "part3.exr: made with 200000-100000-2x4, but part1.exr with 200000-100000-2x3"
        ),
        "{err}"
    );
    // References of another scene (here the light moved) are not this scene's.
    let other = d.join("other.toml");
    let text = std::fs::read_to_string(d.join("scene.toml"))
        .unwrap()
        .replace(
            "position = [-4.0, 4.0, -1.0]",
            "position = [-4.0, 5.0, -1.0]",
        );
    std::fs::write(&other, text).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_photondiff"))
        .arg("reference")
        .arg(&other)
        .args(["--merge", "part1.exr", "part2.exr", "-o", "x.exr"])
        .current_dir(d)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        err.starts_with(
            "photondiff: error: part1.exr: a reference of another scene (photondiff/scene_hash "
        ),
        "{err}"
    );
    assert!(!d.join("x.exr").exists());
    // Nor are its regions measured on another scene by `report`.
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_photondiff"))
        .args(["report", "--reference", "part1.exr", "part2.exr", "--scene"])
        .arg(&other)
        .args(["-o", "rep"])
        .current_dir(d)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.starts_with(&format!(
            "photondiff: error: part1.exr: a reference of another scene than {} (",
            other.display()
        )),
        "{err}"
    );
    assert!(!d.join("rep").exists());
}

/// A region the scene does not have (no glass: no caustic) is reported as such, not with an
/// infinite noise.
#[test]
fn an_empty_region_has_no_noise_to_tell() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("floor.toml");
    let text = include_str!("../scenes/caustic-sphere.toml")
        .replace("width = 640", "width = 32")
        .replace("height = 480", "height = 24");
    let floor_only = text.split("[[shapes]]\ntype = \"sphere\"").next().unwrap();
    std::fs::write(&scene, floor_only).unwrap();
    let image = dir.path().join("r.exr");
    let out = common::run_ok([
        "reference",
        scene.to_str().unwrap(),
        "--light-paths",
        "65536",
        "--caustic-paths",
        "0",
        "--direct-grids",
        "1,2",
        "--quiet",
        "-o",
        image.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    let caustic = stdout
        .lines()
        .find(|l| l.trim_start().starts_with("caustic"))
        .unwrap();
    assert_eq!(
        caustic.split_whitespace().collect::<Vec<_>>(),
        ["caustic", "0", "px", "n/a", "(no", "pixels)"]
    );
    assert!(!stdout.contains("inf"), "{stdout}");
}

/// Each half of a reference gets as many light-traced paths as the other: a count of one chunk
/// (65,536 or fewer) is rounded up to two. With one chunk, half B had direct light only and the
/// reference came out a fifth too dark, with no sign of it.
#[test]
fn both_halves_trace_paths_however_few_are_asked() {
    use photondiff::render::film::Film;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (ok, err) = reference_cli(
        d,
        &[
            "--light-paths",
            "1",
            "--caustic-paths",
            "65536",
            "--direct-grids",
            "2,3",
            "-o",
            "r.exr",
        ],
    );
    assert!(ok, "{err}");
    assert!(
        err.contains("reference: light tracing 131072 + 131072 caustic paths"),
        "{err}"
    );
    let mean = |name: &str| {
        let film = Film::read_exr(&d.join(name)).unwrap();
        film.pixels.iter().map(|p| p.element_sum()).sum::<f64>() / film.pixels.len() as f64
    };
    let (a, b) = (mean("r-a.exr"), mean("r-b.exr"));
    // Was 0.904: the light-traced paths are a tenth of this image.
    assert!((b / a - 1.0).abs() < 0.04, "half B / half A = {}", b / a);
    assert_eq!(photondiff::reference::light_tracer::traced_paths(0), 0);
    assert_eq!(
        photondiff::reference::light_tracer::traced_paths(65536),
        131072
    );
    assert_eq!(
        photondiff::reference::light_tracer::traced_paths(131073),
        262144
    );
}

/// The benchmarks' cached reference is read back only for the scene it was made of: the same
/// scene reads it, the scene edited under the same name makes it anew (it was measured against
/// the old scene's reference, without a word).
#[test]
fn a_cached_reference_is_remade_for_an_edited_scene() {
    use photondiff::reference::cache::{load_or_make, ReferenceSettings};
    let dir = tempfile::tempdir().unwrap();
    let mut scene = canonical(16, 12);
    let settings = ReferenceSettings {
        light_paths: 1,
        caustic_paths: 1,
        direct_grids: [1, 2],
        seed: 0,
    };
    let device = Device::new().unwrap();
    let cached = |scene: &photondiff::scene::Scene| {
        let embree = scene.build_embree(&device).unwrap();
        let mut log = Vec::new();
        let reference = load_or_make(
            scene,
            &embree,
            dir.path(),
            "canonical",
            &settings,
            &mut |m| log.push(m.to_string()),
        )
        .unwrap();
        // As the file holds them (f32), whether made or read back.
        let sum = reference
            .film
            .pixels
            .iter()
            .map(|p| p.x as f32 as f64)
            .sum::<f64>();
        (sum, log.join("\n"))
    };
    let (first, log) = cached(&scene);
    assert!(log.contains("reference: making it"), "{log}");
    let (again, log) = cached(&scene);
    assert!(!log.contains("making"), "{log}");
    assert_eq!(again, first);
    if let photondiff::scene::Light::Point { intensity, .. } = &mut scene.lights[0] {
        *intensity *= 2.0;
    }
    let (edited, log) = cached(&scene);
    assert!(
        log.contains("was made of another scene of that name") && log.contains("making it"),
        "{log}"
    );
    assert!((edited / first - 2.0).abs() < 1e-6, "{edited} {first}");
}

/// The reference warns that the pixels showing the glass sphere stay dark (light tracing
/// cannot see through it: judged over the whole image, the render was blamed for that gap),
/// counting them as the camera's centre rays find them, and `--masks` writes its regions for
/// `compare --mask`: 1 in the region, 0 elsewhere, the floor's pixels all seen on the floor.
#[test]
fn the_reference_warns_of_pixels_it_cannot_see_and_writes_its_regions() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (ok, err) = reference_cli(
        d,
        &[
            "-o",
            "r.exr",
            "--light-paths",
            "1",
            "--caustic-paths",
            "1",
            "--masks",
            "--quiet",
        ],
    );
    assert!(ok, "{err}");
    let scene = canonical(64, 48);
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let (mut glass, mut floor) = (0, Vec::new());
    for y in 0..48 {
        for x in 0..64 {
            let r = scene.camera.ray(x as f64 + 0.5, y as f64 + 0.5, 1.0);
            let hit = embree.intersect(&photondiff::embree::Ray::new(r.p, r.d));
            match hit.map(|h| scene.material(h.geom_id)) {
                Some(photondiff::scene::Material::Glass { .. }) => glass += 1,
                Some(_) => floor.push(y * 64 + x),
                None => {}
            }
        }
    }
    assert!(glass > 100, "{glass}");
    assert_eq!(
        err.lines().next().unwrap(),
        format!(
            "photondiff: warning: {}: {glass} of 3072 pixels show a mirror or glass surface, \
             which light tracing cannot see through: they stay dark or partial however many \
             paths are traced; judge renders against it over the diffuse pixels only \
             (`photondiff reference --masks` writes them for `compare --mask`)",
            d.join("scene.toml").display()
        )
    );
    for region in ["floor", "caustic", "contour", "shadow"] {
        let mask =
            photondiff::render::film::Film::read_exr(&d.join(format!("r-{region}.exr"))).unwrap();
        let inside: Vec<usize> = (0..mask.pixels.len())
            .filter(|&i| mask.pixels[i] == DVec3::ONE)
            .collect();
        assert!(mask
            .pixels
            .iter()
            .all(|&p| p == DVec3::ONE || p == DVec3::ZERO));
        assert!(!inside.is_empty(), "{region}");
        assert!(inside.iter().all(|i| floor.contains(i)), "{region}");
        if region == "floor" {
            // Seen on the floor over the whole pixel: inside the centre rays' floor, apart
            // from the sphere's outline.
            assert!(inside.len() < floor.len() && inside.len() > floor.len() * 9 / 10);
        }
    }
}

/// The light tracer's paths end by Russian roulette, not by a cap that cuts light off: in a
/// closed diffuse sphere of albedo 0.95 a path meets the wall 1 / (1 - 0.95) = 20 times on
/// average (each meeting carrying the light's whole power), where the former cap of 32
/// bounces allowed (1 - 0.95^32) / 0.05 = 16.1, and the reference read 0.81 of the exact light.
#[test]
fn light_paths_in_a_closed_bright_sphere_are_not_cut_short() {
    use photondiff::photons::emission::Emitter;
    use photondiff::photons::light_path::LightPaths;
    use photondiff::util::rng::Rng;
    let text = common::closed_sphere("type = \"diffuse\"\nalbedo = [0.95, 0.95, 0.95]", 64);
    let scene = photondiff::scene::file::parse_scene(&text, Path::new(".")).unwrap();
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let paths = LightPaths {
        scene: &scene,
        embree: &embree,
        max_bounces: LightTraceOptions::default().max_bounces,
        diffuse_spread: 0.0,
        epsilon: scene.ray_epsilon(),
        aim: None,
    };
    let emitter = Emitter::global(&scene, 1000, 1.0, 0);
    let n = 20_000u64;
    let mut visits = 0u64;
    for i in 0..n {
        let mut rng = Rng::new(5, i);
        let (emission, _) = emitter.emit_from_light(i, &mut rng).unwrap();
        paths.walk(emission, &mut rng, |_| {
            visits += 1;
            true
        });
    }
    // The mean of a geometric count of mean 20 and standard deviation 19.5: 0.14 over 20,000.
    let mean = visits as f64 / n as f64;
    assert!((mean - 20.0).abs() < 0.7, "{mean} wall meetings a path");
}

/// A scene whose every light is at zero is warned about and its reference is black: it
/// panicked picking a light among none. Its regions' noise is "n/a (no light)", `null` in the
/// JSON (it printed `inf`).
#[test]
fn a_reference_of_unlit_scene_is_black_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let text = include_str!("../scenes/caustic-sphere.toml")
        .replace("width = 640", "width = 32")
        .replace("height = 480", "height = 24")
        .replace(
            "intensity = [60.0, 60.0, 60.0]",
            "intensity = [0.0, 0.0, 0.0]",
        );
    let scene = dir.path().join("dark.toml");
    std::fs::write(&scene, text).unwrap();
    let (exr, stats) = (dir.path().join("ref.exr"), dir.path().join("s.json"));
    let head: [&std::ffi::OsStr; 4] = [
        "reference".as_ref(),
        scene.as_os_str(),
        "-o".as_ref(),
        exr.as_os_str(),
    ];
    let quick = common::QUICK_REFERENCE.map(std::ffi::OsStr::new);
    let tail: [&std::ffi::OsStr; 2] = ["--stats-json".as_ref(), stats.as_os_str()];
    let out = common::run_ok([&head[..], &quick, &tail].concat());
    let film = photondiff::render::film::Film::read_exr(&exr).unwrap();
    assert!(film.pixels.iter().all(|&p| p == DVec3::ZERO));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    let floor = &json["reference_regions"][0];
    assert_eq!(floor["name"], "floor");
    assert!(floor["pixels"].as_u64().unwrap() > 0);
    assert!(floor["relative_noise"].is_null(), "{json}");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let line = format!(
        "  floor    {:7} px  n/a (no light)",
        floor["pixels"].as_u64().unwrap()
    );
    assert!(
        stdout.lines().any(|l| l == line),
        "{line:?} not in {stdout}"
    );
}
