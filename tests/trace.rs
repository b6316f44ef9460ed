//! `render --trace FILE`: Chrome trace-event JSON with spans per stage, pass and tile and
//! counter tracks, in the shape Perfetto reads.

mod common;
use common::render_file;

use serde_json::Value;
use std::process::Command;

const EXE: &str = env!("CARGO_BIN_EXE_photondiff");

/// The complete events (`"ph": "X"`, spans) of the trace in `path`.
fn spans_of(path: &std::path::Path) -> Vec<Value> {
    let json: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let events = json["traceEvents"].as_array().unwrap();
    events.iter().filter(|e| e["ph"] == "X").cloned().collect()
}

/// `(start, end)` of the one span named `name` among `spans`.
fn only_span(spans: &[Value], name: &str) -> (f64, f64) {
    let found: Vec<&Value> = spans.iter().filter(|e| e["name"] == name).collect();
    assert_eq!(found.len(), 1, "{name}");
    interval(found[0])
}

/// `(start, end)` of a span, in microseconds.
fn interval(e: &Value) -> (f64, f64) {
    let start = e["ts"].as_f64().unwrap();
    (start, start + e["dur"].as_f64().unwrap())
}

/// Runs `photondiff COMMAND` on the canonical scene with `args`, writing its output to
/// `dir/OUTPUT`, its trace to `dir/t/trace.json` and its statistics to `dir/s/stats.json`
/// (folders it must create); returns what it printed and the two paths.
fn run_traced(
    dir: &std::path::Path,
    command: &str,
    output: &str,
    args: &[&str],
) -> (std::process::Output, std::path::PathBuf, std::path::PathBuf) {
    let (trace, stats) = (dir.join("t/trace.json"), dir.join("s/stats.json"));
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/caustic-sphere.toml");
    let out = Command::new(EXE)
        .args([command, scene])
        .args(args)
        .arg("-o")
        .arg(dir.join(output))
        .arg("--trace")
        .arg(&trace)
        .arg("--stats-json")
        .arg(&stats)
        .output()
        .unwrap();
    (out, trace, stats)
}

/// The canonical scene at `width` x `height` pixels, written into `dir`; its path.
fn canonical_at(dir: &std::path::Path, width: u32, height: u32) -> std::path::PathBuf {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/caustic-sphere.toml"
    ))
    .unwrap()
    .replace("width = 640", &format!("width = {width}"))
    .replace("height = 480", &format!("height = {height}"));
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, text).unwrap();
    scene
}

/// The stage names of the statistics JSON in `path`, in order, with the statistics.
fn stages_of(path: &std::path::Path) -> (Vec<String>, Value) {
    let stats: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let stages = stats["stages"].as_array().unwrap();
    let names = stages
        .iter()
        .map(|s| s["name"].as_str().unwrap().to_string());
    (names.collect(), stats)
}

#[test]
fn the_trace_has_spans_per_stage_pass_and_tile_and_counters() {
    let dir = tempfile::tempdir().unwrap();
    // 64 x 48 pixels: 4 x 3 = 12 render tiles of 16 x 16 per pass.
    let scene = canonical_at(dir.path(), 64, 48);
    let trace = dir.path().join("deep/trace.json");
    let trace_arg = trace.to_str().unwrap();
    let (stats, _) = render_file(
        &scene,
        &dir.path().join("a"),
        &[
            "-q",
            "--passes",
            "3",
            "--photons",
            "2000",
            "--caustic-photons",
            "2000",
            "--trace",
            trace_arg,
        ],
    );
    let json: Value = serde_json::from_str(&std::fs::read_to_string(&trace).unwrap()).unwrap();
    let events = json["traceEvents"].as_array().unwrap();
    let named = |ph: &str, name: &str| -> Vec<&Value> {
        events
            .iter()
            .filter(|e| e["ph"] == ph && e["name"] == name)
            .collect()
    };
    // Every complete event has the fields Perfetto needs, with sane values.
    for e in events.iter().filter(|e| e["ph"] == "X") {
        assert!(e["ts"].as_f64().unwrap() >= 0.0, "{e}");
        assert!(e["dur"].as_f64().unwrap() >= 0.0, "{e}");
        assert_eq!(e["pid"], 1);
        assert!(e["tid"].as_u64().unwrap() >= 1);
    }
    // Stages once (per pass for the per-pass ones), passes 0..3 in order, 12 tiles per pass.
    for stage in ["load scene", "build BVH", "write images"] {
        assert_eq!(named("X", stage).len(), 1, "{stage}");
    }
    assert_eq!(named("X", "trace photons").len(), 3);
    assert_eq!(named("X", "render").len(), 3);
    let passes = named("X", "pass");
    let numbers: Vec<u64> = passes
        .iter()
        .map(|p| p["args"]["pass"].as_u64().unwrap())
        .collect();
    assert_eq!(numbers, [0, 1, 2]);
    let tiles = named("X", "tile");
    assert_eq!(tiles.len(), 3 * 12);
    // Each tile lies within one pass's span, 12 in each.
    let end = |e: &Value| e["ts"].as_f64().unwrap() + e["dur"].as_f64().unwrap();
    for p in &passes {
        let inside = tiles
            .iter()
            .filter(|t| t["ts"].as_f64() >= p["ts"].as_f64() && end(t) <= end(p) + 1.0)
            .count();
        assert_eq!(inside, 12, "{p}");
    }
    // Counter tracks once per pass, numeric values (the noise from the second pass: one pass
    // has no estimate, and a 0 read as none); every thread that recorded is named.
    for (counter, passes) in [
        ("rays", 4),
        ("photons stored", 3),
        ("photons per gather", 3),
        ("noise of the mean", 2),
    ] {
        let c = named("C", counter);
        assert_eq!(c.len(), passes, "{counter}");
        for e in c {
            let args = e["args"].as_object().unwrap();
            assert!(
                !args.is_empty()
                    && args.values().all(Value::is_number)
                    && (counter != "noise of the mean" || args["image"].as_f64() > Some(0.0)),
                "{e}"
            );
        }
    }
    // The rays track's first point is the run's search for edge pixels (its corner rays,
    // once, in a stage of its own); then each pass's: one camera ray a pixel and, this being
    // a long run (3 passes), the rest of the long run's edge grid per edge pixel (63 more for
    // 8 x 8). The track's points add up to the statistics' count (they missed the corner
    // rays).
    let edges = stats["edge_pixels"].as_u64().unwrap();
    assert!(edges > 0 && edges.is_multiple_of(3), "{edges}");
    let grid = u64::from(photondiff::render::defaults::LONG_RUN_EDGE_GRID);
    let rays = named("C", "rays");
    assert_eq!(
        rays[1]["args"]["camera"],
        64 * 48 + (grid * grid - 1) * edges / 3
    );
    let camera = |e: &&Value| e["args"]["camera"].as_u64().unwrap();
    assert!(camera(&rays[0]) > 0);
    assert_eq!(
        rays.iter().map(camera).sum::<u64>(),
        stats["rays"]["camera"].as_u64().unwrap()
    );
    assert_eq!(named("X", "find edges").len(), 1);
    let named_threads: Vec<&Value> = named("M", "thread_name")
        .iter()
        .map(|e| &e["tid"])
        .collect();
    for e in events.iter().filter(|e| e["ph"] != "M") {
        assert!(named_threads.contains(&&e["tid"]), "{e}");
    }
}

/// `photons --trace --stats-json`: a span per stage and per map (each map's within the tracing
/// stage), and statistics that agree with what the command printed.
#[test]
fn photons_trace_their_stages_and_maps_and_write_their_statistics() {
    let dir = tempfile::tempdir().unwrap();
    let args = [
        "--caustic-photons",
        "3000",
        "--photons",
        "2000",
        "--threads",
        "2",
    ];
    let (out, trace, stats) = run_traced(dir.path(), "photons", "maps.pdm", &args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("memory: peak resident "), "{stderr}");
    let spans = spans_of(&trace);
    let span = |name: &str| only_span(&spans, name);
    let tracing = span("trace photons");
    for map in ["caustic map", "global map"] {
        let (start, end) = span(map);
        assert!(start >= tracing.0 && end <= tracing.1 + 1.0, "{map}");
    }
    assert!(span("load scene").1 <= span("build BVH").0 + 1.0);
    assert!(tracing.1 <= span("write photon maps").0 + 1.0);
    assert_eq!(spans.len(), 6);
    // The statistics: the stages in order, the maps' photons as printed, the BVH built.
    let (stages, stats) = stages_of(&stats);
    assert_eq!(
        stages,
        [
            "load scene",
            "build BVH",
            "trace photons",
            "write photon maps"
        ]
    );
    let stored = |k: usize| stats["photon_maps"][k]["stored"].as_u64().unwrap();
    assert_eq!(stored(0), 3000);
    assert_eq!(
        String::from_utf8_lossy(&out.stdout),
        format!(
            "wrote {}: 3000 caustic and {} global photons\n",
            dir.path().join("maps.pdm").display(),
            stored(1)
        )
    );
    assert_eq!(stats["memory"]["bvh"]["quality"], "medium");
    assert!(stats["memory"]["peak_resident_bytes"].as_u64().unwrap() > 0);
    // The threads the photons were traced on (it read 0).
    assert_eq!(stats["threads"], 2);
}

/// `render`, `photons` and `reference` alike: an unwritable `--trace` path is one line on stderr, exit 1,
/// and nothing is rendered or traced (the command's output is not written).
#[test]
fn an_unwritable_trace_path_is_a_one_line_error_before_any_work() {
    let commands = [
        ("render", "a.exr"),
        ("photons", "maps.pdm"),
        ("reference", "ref.exr"),
    ];
    for (command, output) in commands {
        let dir = tempfile::tempdir().unwrap();
        // A file where a folder should be, and a loop of symbolic links (each said what the
        // system call said: "File exists", or nothing until after the work).
        let blocker = dir.path().join("file");
        std::fs::write(&blocker, "").unwrap();
        let looped = dir.path().join("loop.json");
        std::os::unix::fs::symlink("loop.json", &looped).unwrap();
        let cases = [
            (
                blocker.join("trace.json"),
                format!("{}: is a file, not a folder", blocker.display()),
            ),
            (
                blocker.join("sub/trace.json"),
                format!(
                    "{}: cannot create folder: {} is a file",
                    blocker.join("sub").display(),
                    blocker.display()
                ),
            ),
            (
                looped.clone(),
                format!(
                    "{}: cannot write: a loop of symbolic links (more than 40 followed)",
                    looped.display()
                ),
            ),
        ];
        let output = dir.path().join(output);
        for (trace, message) in cases {
            let out = Command::new(EXE)
                .args([
                    command,
                    concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/caustic-sphere.toml"),
                ])
                .arg("-o")
                .arg(&output)
                .arg("--trace")
                .arg(&trace)
                .output()
                .unwrap();
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(1), "{command}: {stderr}");
            assert_eq!(
                stderr,
                format!("photondiff: error: --trace: {message}\n"),
                "{command}"
            );
            assert!(!output.exists(), "{command} wrote {}", output.display());
        }
    }
}

/// An output that is a symbolic link to a file not written yet is written through the link,
/// as a link to an existing file is (it failed with "No such file or directory" after the
/// render).
#[test]
fn an_output_linked_to_a_file_not_yet_written_is_written_through_the_link() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    let text = include_str!("../scenes/caustic-sphere.toml")
        .replace("width = 640", "width = 32")
        .replace("height = 480", "height = 24");
    std::fs::write(&scene, text).unwrap();
    let link = dir.path().join("image.exr");
    std::os::unix::fs::symlink("later/target.exr", &link).unwrap();
    let args: [&std::ffi::OsStr; 7] = [
        "render".as_ref(),
        scene.as_ref(),
        "--estimator".as_ref(),
        "direct".as_ref(),
        "-q".as_ref(),
        "-o".as_ref(),
        link.as_ref(),
    ];
    common::run_ok(args);
    assert!(link.is_symlink());
    let film = photondiff::render::film::Film::read_exr(&dir.path().join("later/target.exr"));
    assert_eq!(film.map(|f| (f.width, f.height)), Ok((32, 24)));
}

/// `reference --trace --stats-json`: a span per stage, the light tracing's chunks of paths
/// within its stage, and statistics holding the camera rays the grids cast and the noise per
/// region that standard output printed.
#[test]
fn reference_traces_its_stages_and_writes_its_noise_per_region() {
    let dir = tempfile::tempdir().unwrap();
    let args = [&common::QUICK_REFERENCE[..], &["--quiet"]].concat();
    let (out, trace, stats) = run_traced(dir.path(), "reference", "ref.exr", &args);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let (stages, stats) = stages_of(&stats);
    let expected = [
        "load scene",
        "build BVH",
        "direct light, half A",
        "direct light, half B",
        "light tracing",
        "find regions",
        "write images",
    ];
    assert_eq!(stages, expected);
    // 1 x 1 and 2 x 2 camera rays a pixel of 640 x 480; two chunks of 65,536 paths a set.
    assert_eq!(stats["rays"]["camera"], 640 * 480 * (1 + 4));
    assert_eq!(stats["light_paths"], 262_144);
    assert!(stats["light_rays"].as_u64().unwrap() > 262_144);
    // The noise per region, as printed: each line of standard output from the JSON's numbers.
    let regions = stats["reference_regions"].as_array().unwrap();
    let names: Vec<&str> = regions
        .iter()
        .map(|r| r["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["floor", "caustic", "contour", "shadow"]);
    for r in regions {
        let line = format!(
            "  {:8} {:7} px  {:.4}",
            r["name"].as_str().unwrap(),
            r["pixels"].as_u64().unwrap(),
            r["relative_noise"].as_f64().unwrap()
        );
        assert!(
            stdout.lines().any(|l| l == line),
            "{line:?} not in {stdout}"
        );
    }
    let noise = stats["reference_noise"].as_f64().unwrap();
    assert!(noise > 0.0 && noise.is_finite());
    // The trace: each stage once, in order, and the four chunks of paths inside the tracing.
    let spans = spans_of(&trace);
    let stage_spans: Vec<(f64, f64)> = expected.iter().map(|n| only_span(&spans, n)).collect();
    for pair in stage_spans.windows(2) {
        assert!(pair[0].1 <= pair[1].0 + 1.0, "{pair:?}");
    }
    let tracing = stage_spans[4];
    let chunks: Vec<(f64, f64)> = spans
        .iter()
        .filter(|e| e["name"] == "light paths")
        .map(interval)
        .collect();
    assert_eq!(chunks.len(), 4);
    for (start, end) in chunks {
        assert!(start >= tracing.0 && end <= tracing.1 + 1.0);
    }
}

/// A run that fails once its scene is read still writes its trace, ending in an instant event
/// that holds the error (the trace of a run that failed after an hour is the one worth
/// reading; nothing was written before; not before the scene is read, when the trace's path
/// might name one of its mesh files); a run whose statistics cannot be written after its
/// image was says that the image is complete and kept.
#[test]
fn a_failed_run_writes_its_trace_and_a_finished_image_is_said_to_be_kept() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    let text = include_str!("../scenes/caustic-sphere.toml")
        .replace("width = 640", "width = 32")
        .replace("height = 480", "height = 24");
    // Photon maps of the scene before its floor was repainted: refused once the scene is
    // read, after the trace began.
    std::fs::write(&scene, &text).unwrap();
    let maps = dir.path().join("maps.pdm");
    common::run_ok([
        "photons".as_ref(),
        scene.as_os_str(),
        "-q".as_ref(),
        "--caustic-photons".as_ref(),
        "1000".as_ref(),
        "--photons".as_ref(),
        "1000".as_ref(),
        "-o".as_ref(),
        maps.as_os_str(),
    ]);
    // Read into a 2-pass render: pass 0 stored no photons of its own, so the track has a
    // point for pass 1 alone (pass 0's was empty).
    let trace = dir.path().join("loaded.json");
    common::run_ok([
        "render".as_ref(),
        scene.as_os_str(),
        "-q".as_ref(),
        "--photon-maps".as_ref(),
        maps.as_os_str(),
        "--caustic-photons".as_ref(),
        "1000".as_ref(),
        "--photons".as_ref(),
        "1000".as_ref(),
        "--passes".as_ref(),
        "2".as_ref(),
        "-o".as_ref(),
        dir.path().join("loaded.exr").as_os_str(),
        "--trace".as_ref(),
        trace.as_os_str(),
    ]);
    let json: Value = serde_json::from_str(&std::fs::read_to_string(&trace).unwrap()).unwrap();
    let stored: Vec<&Value> = json["traceEvents"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|e| e["ph"] == "C" && e["name"] == "photons stored")
        .collect();
    assert_eq!(stored.len(), 1, "{stored:?}");
    assert!(
        stored[0]["args"]["Caustic"].as_u64() > Some(0),
        "{stored:?}"
    );
    let repainted = text.replace("albedo = [0.75, 0.75, 0.75]", "albedo = [0.7, 0.7, 0.7]");
    assert_ne!(repainted, text);
    std::fs::write(&scene, &repainted).unwrap();
    let trace = dir.path().join("trace.json");
    let out = Command::new(EXE)
        .arg("render")
        .arg(&scene)
        .arg("--photon-maps")
        .arg(&maps)
        .args(["--caustic-photons", "1000", "--photons", "1000", "-o"])
        .arg(dir.path().join("a.exr"))
        .arg("--trace")
        .arg(&trace)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.ends_with(&format!(
            "photondiff: the trace of the failed run is in {}\n",
            trace.display()
        )),
        "{stderr}"
    );
    let json: Value = serde_json::from_str(&std::fs::read_to_string(&trace).unwrap()).unwrap();
    let events = json["traceEvents"].as_array().unwrap();
    let errors: Vec<&Value> = events.iter().filter(|e| e["name"] == "error").collect();
    assert_eq!(errors.len(), 1, "{events:?}");
    assert_eq!(errors[0]["ph"], "i");
    let message = errors[0]["args"]["message"].as_str().unwrap();
    assert!(
        message.starts_with(&format!("{}: photon maps of another scene", maps.display())),
        "{message}"
    );
    // The stages before the failure are in it.
    assert!(
        events
            .iter()
            .any(|e| e["ph"] == "X" && e["name"] == "load scene"),
        "{events:?}"
    );
    assert!(!dir.path().join("a.exr").exists());

    // The image written, then its statistics refused by a full device.
    let (exr, png) = (dir.path().join("b.exr"), dir.path().join("b.png"));
    let out = Command::new(EXE)
        .arg("render")
        .arg(&scene)
        .args(["--estimator", "direct", "-q", "-o"])
        .arg(&exr)
        .args(["--stats-json", "/dev/full"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert_eq!(
        stderr,
        format!(
            "photondiff: error: --stats-json: /dev/full: cannot write: No space left on device \
             (os error 28) (the run's output is complete and kept: {}, {})\n",
            exr.display(),
            png.display()
        )
    );
    assert!(exr.exists() && png.exists());
}

/// The trace holds in memory about what its file takes, not forty times that: kept as JSON
/// values, a 10 MB trace of 800 passes held 370 MB. Peak resident memory of 300 passes of
/// `direct` at 160 x 120 (80 tiles a pass: 24,000 tile spans) with and without the trace.
/// The same run's thread tracks: one pool of workers for the whole run, not two a pass.
#[test]
fn the_trace_holds_about_its_file_in_memory_and_one_track_per_thread() {
    let dir = tempfile::tempdir().unwrap();
    let scene = canonical_at(dir.path(), 160, 120);
    let trace = dir.path().join("trace.json");
    let args = [
        "-q",
        "--estimator",
        "direct",
        "--passes",
        "300",
        "--threads",
        "1",
    ];
    let peak = |s: &Value| s["memory"]["peak_resident_bytes"].as_f64().unwrap();
    let (plain, _) = render_file(&scene, &dir.path().join("plain"), &args);
    let mut traced_args = args.to_vec();
    traced_args.extend(["--trace", trace.to_str().unwrap()]);
    let (traced, _) = render_file(&scene, &dir.path().join("traced"), &traced_args);
    let file = std::fs::metadata(&trace).unwrap().len() as f64;
    let json: Value = serde_json::from_str(&std::fs::read_to_string(&trace).unwrap()).unwrap();
    let events = json["traceEvents"].as_array().unwrap();
    let tiles = events.iter().filter(|e| e["name"] == "tile").count();
    assert_eq!(tiles, 300 * 80);
    let extra = peak(&traced) - peak(&plain);
    assert!(
        extra < 3.0 * file + 16e6,
        "the trace took {extra:.3e} bytes for a file of {file:.3e}"
    );
    // The main thread and one worker (photons and tiles alike).
    let tracks = events
        .iter()
        .filter(|e| e["ph"] == "M" && e["name"] == "thread_name")
        .count();
    assert_eq!(tracks, 2);
    // `direct` gathers no photons: no points on that track (it had 0 / 0 a pass).
    assert!(!events.iter().any(|e| e["name"] == "photons per gather"));
    // The passes' sums are a stage (a fifth of such a run's time was in none).
    let stages = traced["stages"].as_array().unwrap();
    assert!(
        stages.iter().any(|s| s["name"] == "sum passes"),
        "{stages:?}"
    );
}
