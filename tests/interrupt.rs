//! Ctrl-C during a progressive render: the first drops the pass under way and writes the mean
//! of the passes done (exit status 130, the statistics and the EXR saying why it stopped), or,
//! during the first pass, exits within seconds writing nothing; a second exits at once without
//! writing. `lighttrace` stops after the paths under way and writes
//! their image. The real signal, sent by `kill` to the real binary.

use photondiff::render::film::Film;
use std::path::Path;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::Duration;

mod common;
use common::SMALL_SCENE as SCENE;

/// Starts a render of `scene` with `extra` options that would run for ten minutes (a time
/// budget of 600 s, unless `extra` gives `--passes`: a tile takes no time budget).
fn start(dir: &Path, scene: &str, extra: &[&str]) -> Child {
    let file = dir.join("scene.toml");
    std::fs::write(&file, scene).unwrap();
    let long: &[&str] = match extra.contains(&"--passes") {
        true => &[],
        false => &["--time-budget", "600"],
    };
    Command::new(env!("CARGO_BIN_EXE_photondiff"))
        .args(["render", "--quiet", "--threads", "1"])
        .args(long)
        .args(extra)
        .arg("-o")
        .arg(dir.join("img.exr"))
        .arg("--stats-json")
        .arg(dir.join("stats.json"))
        .arg(&file)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Sends `signal` (`INT`, `TERM`) to the process we started (by its id).
fn interrupt(child: &Child, signal: &str) {
    let status = Command::new("kill")
        .args([&format!("-{signal}"), &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
}

/// Waits at most a minute; kills the process (ours) and fails if it has not ended by then.
fn wait(child: &mut Child) -> ExitStatus {
    common::wait_at_most(child, Duration::from_secs(60))
        .expect("the render did not stop within a minute of Ctrl-C")
}

/// Starts a render and interrupts it `times` times once it has run `after`; retries with a
/// longer wait if the signal came before the handler was installed (the process then dies of
/// the signal, with no exit status), which only a very busy machine would see.
fn run_and_interrupt(
    dir: &Path,
    scene: &str,
    extra: &[&str],
    times: usize,
) -> (ExitStatus, String) {
    run_and_signal(dir, scene, extra, times, "INT")
}

/// [`run_and_interrupt`] with another signal.
fn run_and_signal(
    dir: &Path,
    scene: &str,
    extra: &[&str],
    times: usize,
    signal: &str,
) -> (ExitStatus, String) {
    for wait_ms in [1000, 3000, 9000] {
        let mut child = start(dir, scene, extra);
        std::thread::sleep(Duration::from_millis(wait_ms));
        for _ in 0..times {
            interrupt(&child, signal);
            std::thread::sleep(Duration::from_millis(50));
        }
        let status = wait(&mut child);
        let mut stderr = String::new();
        std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut stderr).unwrap();
        if status.code().is_some() {
            return (status, stderr);
        }
    }
    panic!("the render died of the signal three times: no handler");
}

#[test]
fn the_first_ctrl_c_keeps_the_passes_done() {
    let dir = tempfile::tempdir().unwrap();
    let (status, stderr) = run_and_interrupt(dir.path(), SCENE, &[], 1);
    assert_eq!(status.code(), Some(130), "{stderr}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("stats.json")).unwrap())
            .unwrap();
    let passes = json["progressive"]["passes"].as_u64().unwrap();
    assert!(passes >= 1, "{json}");
    assert_eq!(json["progressive"]["stop"], "interrupted");
    // The seconds per pass are the kept passes': a pass cut short is a stage of its own, not
    // in them (counted in, one pass of 1.49 s read 2.78 s).
    let stages = json["stages"].as_array().unwrap();
    let seconds = |name: Option<&str>| -> f64 {
        stages
            .iter()
            .filter(|s| name.is_none_or(|n| s["name"] == n))
            .map(|s| s["seconds"].as_f64().unwrap())
            .sum()
    };
    let per_pass = json["progressive"]["seconds_per_pass"].as_f64().unwrap();
    let dropped = seconds(Some("dropped pass (interrupted)"));
    assert!(
        per_pass * passes as f64 <= seconds(None) - dropped + 0.05,
        "{json}"
    );
    assert_eq!(
        stderr.trim(),
        format!(
            "photondiff: interrupted: dropping the pass under way, then writing the mean of the \
             passes done (Ctrl-C again to exit at once)\n\
             photondiff: interrupted: the image is the mean of the {passes} passes done"
        )
    );
    let film = Film::read_exr(&dir.path().join("img.exr")).unwrap();
    assert!(film.pixels.iter().all(|p| p.is_finite()));
    assert!(film.pixels.iter().any(|p| p.max_element() > 0.0));
}

/// SIGTERM (a batch system's time limit: Slurm sends it, then SIGKILL after a grace period) is
/// taken as Ctrl-C: the passes done are written. It used to end the process with nothing. The
/// status is 128 + SIGTERM, as a shell reports a process the signal ended (until stop 60 it was
/// Ctrl-C's 130, and a script could not tell its scheduler's limit from a user's Ctrl-C).
#[test]
fn a_termination_signal_keeps_the_passes_done() {
    let dir = tempfile::tempdir().unwrap();
    let (status, stderr) = run_and_signal(dir.path(), SCENE, &[], 1, "TERM");
    assert_eq!(status.code(), Some(143), "{stderr}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("stats.json")).unwrap())
            .unwrap();
    assert!(
        json["progressive"]["passes"].as_u64().unwrap() >= 1,
        "{json}"
    );
    assert_eq!(json["progressive"]["stop"], "interrupted");
    assert!(stderr.contains("the image is the mean of the"), "{stderr}");
    let film = Film::read_exr(&dir.path().join("img.exr")).unwrap();
    assert!(film.pixels.iter().any(|p| p.max_element() > 0.0));
}

/// A tile stopped by SIGTERM (a Slurm task at its time limit) keeps its passes done, and
/// `merge` takes it, saying that the image holds fewer passes than were asked for.
#[test]
fn merging_an_interrupted_tile_warns_of_its_passes() {
    let dir = tempfile::tempdir().unwrap();
    let extra = ["--tile", "0/1", "--passes", "100000"];
    let (status, stderr) = run_and_signal(dir.path(), SCENE, &extra, 1, "TERM");
    assert_eq!(status.code(), Some(143), "{stderr}");
    let img = dir.path().join("img.exr");
    let part = photondiff::render::part::read_part(&img).unwrap();
    let passes = part.metadata["photondiff/passes"].clone();
    let out = Command::new(env!("CARGO_BIN_EXE_photondiff"))
        .arg("merge")
        .arg(&img)
        .arg("-o")
        .arg(dir.path().join("whole.exr"))
        .output()
        .unwrap();
    assert!(out.status.success());
    assert_eq!(
        String::from_utf8_lossy(&out.stderr),
        format!(
            "photondiff: warning: 1 of the 1 parts was interrupted ({}): the image holds the \
             {passes} passes each finished, not the passes asked for\n",
            img.display()
        )
    );
}

/// Passes of 20 million camera rays (seconds each, tens on a busy machine).
fn large() -> String {
    let large = SCENE.replace("width = 32\nheight = 24", "width = 640\nheight = 480");
    assert_ne!(large, SCENE);
    large
}

#[test]
fn a_second_ctrl_c_exits_at_once_without_an_image() {
    let dir = tempfile::tempdir().unwrap();
    // Both signals come while the first pass is under way: the second ends the run at once,
    // unless the first has already cut the pass short and ended it (50 ms apart: either way
    // nothing is written).
    let (status, stderr) = run_and_interrupt(dir.path(), &large(), &["--view-grid", "8"], 2);
    assert_eq!(status.code(), Some(130), "{stderr}");
    assert!(
        stderr.ends_with("photondiff: interrupted again: exiting without writing the image\n")
            || stderr.ends_with(
                "photondiff: error: interrupted during the first pass: no pass \
                 was finished, so no image was written\n"
            ),
        "{stderr}"
    );
    assert!(!dir.path().join("img.exr").exists());
    assert!(!dir.path().join("stats.json").exists());
}

/// A Ctrl-C during a pass cuts it short within seconds: the photon tracing and the tiles check
/// it. It waited for the pass to end (a pass can take minutes: a batch system's grace period
/// ran out), and during the last pass it was swallowed and the run exited 0 a minute later.
#[test]
fn a_ctrl_c_cuts_the_pass_under_way_short() {
    let dir = tempfile::tempdir().unwrap();
    let extra = ["--view-grid", "8", "--passes", "1"];
    let mut child = start(dir.path(), &large(), &extra);
    std::thread::sleep(Duration::from_millis(1500));
    let sent = std::time::Instant::now();
    interrupt(&child, "INT");
    let status = wait(&mut child);
    let took = sent.elapsed();
    let mut stderr = String::new();
    std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut stderr).unwrap();
    assert_eq!(status.code(), Some(130), "{stderr}");
    assert!(
        stderr.ends_with(
            "photondiff: error: interrupted during the first pass: no pass was finished, so no \
             image was written\n"
        ),
        "{stderr}"
    );
    assert!(took < Duration::from_secs(10), "{took:?}");
    // The signal's own line says what will happen: it promised the mean of the passes done.
    assert!(
        stderr.contains(
            "photondiff: interrupted: stopping the first pass, which is not finished: nothing \
             will be written (Ctrl-C again to exit at once)\n"
        ) && !stderr.contains("the mean of the passes done"),
        "{stderr}"
    );
    assert!(!dir.path().join("img.exr").exists());
}

#[test]
fn ctrl_c_ends_light_tracing_with_the_paths_traced() {
    let dir = tempfile::tempdir().unwrap();
    // Ten billion paths: hours, but for the signal.
    let asked: u64 = 10_000_000_000;
    let args = ["--estimator", "lighttrace", "--light-paths", "10000000000"];
    let (status, stderr) = run_and_interrupt(dir.path(), SCENE, &args, 1);
    assert_eq!(status.code(), Some(130), "{stderr}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("stats.json")).unwrap())
            .unwrap();
    let traced = json["light_paths"].as_u64().unwrap();
    assert!(traced > 0 && traced < asked, "{json}");
    // The scene's glass sphere is in view: light tracing warns first that it cannot see
    // through it.
    let (warning, rest) = stderr.split_once("\n").unwrap();
    assert!(
        warning.starts_with("photondiff: warning: ")
            && warning.contains(" pixels show a mirror or glass surface, which light tracing"),
        "{stderr}"
    );
    assert_eq!(
        rest.trim(),
        format!(
            "photondiff: interrupted: finishing the light paths under way, then writing the image \
             of the paths traced (Ctrl-C again to exit at once)\n\
             photondiff: interrupted: the image is of the {traced} light paths traced"
        )
    );
    let film = Film::read_exr(&dir.path().join("img.exr")).unwrap();
    assert!(film.pixels.iter().all(|p| p.is_finite()));
    assert!(film.pixels.iter().any(|p| p.max_element() > 0.0));
}

/// A pass cut short by Ctrl-C is left out of the seconds per pass: its time is a stage of its
/// own. Counted in, one pass of 1.49 s read 2.78 s each. The signal comes half a pass after the
/// first pass's line on standard error, so that the second is under way.
#[test]
fn a_dropped_pass_is_not_in_the_seconds_per_pass() {
    use std::io::BufRead;
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("scene.toml");
    std::fs::write(&file, large()).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_photondiff"))
        .args([
            "render",
            "--threads",
            "1",
            "--view-grid",
            "2",
            "--passes",
            "1000",
        ])
        .arg("-o")
        .arg(dir.path().join("img.exr"))
        .arg("--stats-json")
        .arg(dir.path().join("stats.json"))
        .arg(&file)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = std::io::BufReader::new(child.stderr.take().unwrap()).lines();
    // "passes: 1 of 1000 done, 2.3 s, ..." (not a terminal: lines, not a bar).
    let first = lines
        .by_ref()
        .map_while(Result::ok)
        .find_map(|l| {
            l.strip_prefix("passes: 1 of 1000 done, ")?
                .split(' ')
                .next()?
                .parse::<f64>()
                .ok()
        })
        .expect("no line for the first pass");
    std::thread::sleep(Duration::from_secs_f64(first / 2.0));
    interrupt(&child, "INT");
    let rest: Vec<String> = lines.map_while(Result::ok).collect();
    let status = wait(&mut child);
    assert_eq!(status.code(), Some(130), "{rest:?}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("stats.json")).unwrap())
            .unwrap();
    let stages = json["stages"].as_array().unwrap();
    let seconds = |name: &str| -> f64 {
        stages
            .iter()
            .filter(|s| s["name"] == name)
            .map(|s| s["seconds"].as_f64().unwrap())
            .sum()
    };
    let dropped = seconds("dropped pass (interrupted)");
    assert!(dropped > 0.0, "no pass was cut short: {json}");
    let passes = json["progressive"]["passes"].as_f64().unwrap();
    let kept = seconds("trace photons") + seconds("render");
    let per_pass = json["progressive"]["seconds_per_pass"].as_f64().unwrap();
    // The kept passes' stages, and the edge search before the first pass, at most.
    assert!(
        per_pass * passes >= kept && per_pass * passes < kept + 0.5 * dropped + 0.2,
        "{per_pass} s a pass over {passes}, stages {kept} s, dropped {dropped} s: {json}"
    );
}

/// Runs `photondiff COMMAND --quiet --threads 1 -o OUTPUT SCENE`, sends it Ctrl-C after
/// `wait_ms`; its exit status and standard error.
fn command_interrupted(
    command: &str,
    output: &Path,
    scene: &Path,
    wait_ms: u64,
) -> (ExitStatus, String) {
    command_signalled(command, output, scene, wait_ms, "INT")
}

/// [`command_interrupted`] with another signal.
fn command_signalled(
    command: &str,
    output: &Path,
    scene: &Path,
    wait_ms: u64,
    signal: &str,
) -> (ExitStatus, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_photondiff"))
        .args([command, "--quiet", "--threads", "1", "-o"])
        .arg(output)
        .arg(scene)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(wait_ms));
    interrupt(&child, signal);
    let status = wait(&mut child);
    let mut stderr = String::new();
    std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut stderr).unwrap();
    (status, stderr)
}

/// A Ctrl-C while the scene loads exits at once: there is nothing to keep. The scene file is
/// a named pipe nobody writes, so the loading never ends: before, the request waited for it
/// (for a large scene, tens of seconds of loading and BVH building), here for ever. SIGHUP and
/// SIGTERM do the same, each with its own status (128 + the signal's number).
#[test]
fn a_ctrl_c_while_the_scene_loads_exits_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    let made = Command::new("mkfifo").arg(&scene).status().unwrap();
    assert!(made.success());
    'signals: for (signal, code) in [("INT", 130), ("HUP", 129), ("TERM", 143)] {
        for wait_ms in [1000, 3000, 9000] {
            let image = dir.path().join("img.exr");
            let (status, stderr) = command_signalled("render", &image, &scene, wait_ms, signal);
            if status.code().is_none() {
                continue; // the signal came before the handler was installed
            }
            assert_eq!(status.code(), Some(code), "SIG{signal}: {stderr}");
            assert_eq!(
                stderr,
                "\nphotondiff: interrupted before there was anything to keep: exiting without writing\n"
            );
            assert!(!dir.path().join("img.exr").exists());
            continue 'signals;
        }
        panic!("the render died of SIG{signal} three times: no handler");
    }
}

/// A SIGTERM and then a Ctrl-C (a scheduler's limit, then a user who will not wait): the
/// second exits at once, with the status of the first.
#[test]
fn the_first_signal_names_the_status() {
    let dir = tempfile::tempdir().unwrap();
    for wait_ms in [1000, 3000, 9000] {
        let mut child = start(dir.path(), &large(), &["--view-grid", "8"]);
        std::thread::sleep(Duration::from_millis(wait_ms));
        interrupt(&child, "TERM");
        std::thread::sleep(Duration::from_millis(50));
        interrupt(&child, "INT");
        let status = wait(&mut child);
        let mut stderr = String::new();
        std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut stderr).unwrap();
        if status.code().is_none() {
            continue; // the signal came before the handler was installed
        }
        assert_eq!(status.code(), Some(143), "{stderr}");
        assert!(!dir.path().join("img.exr").exists(), "{stderr}");
        return;
    }
    panic!("the render died of the signal three times: no handler");
}

/// `reference` stops as `lighttrace` does: a Ctrl-C during the light tracing writes the
/// reference of the paths traced, its attribute naming them (so that no merge takes it for a
/// reference of the paths asked), status 130. It ended the process, hours of paths lost.
#[test]
fn ctrl_c_ends_a_references_light_tracing_with_the_paths_traced() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let output = dir.path().join("ref.exr");
    for wait_ms in [2000, 5000, 12000] {
        // 10^9 + 10^9 paths (the default): hours, but for the signal.
        let (status, stderr) = command_interrupted("reference", &output, &scene, wait_ms);
        if status.code().is_none() || stderr.contains("before there was anything to keep") {
            continue; // the signal came before the light tracing: nothing was kept
        }
        assert_eq!(status.code(), Some(130), "{stderr}");
        let attribute = |path: &Path, key: &str| {
            photondiff::render::part::read_part(path).unwrap().metadata[key].clone()
        };
        let tag = attribute(&output, "photondiff/reference");
        let counts: Vec<u64> = tag.split('-').take(2).map(|n| n.parse().unwrap()).collect();
        let (global, caustic) = (counts[0], counts[1]);
        assert!(global > 0 && caustic > 0, "{tag}");
        assert!(global + caustic < 2_000_000_000, "{tag}");
        assert_eq!(tag, format!("{global}-{caustic}-16x17"));
        assert!(
            stderr.trim().ends_with(&format!(
            "photondiff: interrupted: the reference is of the {global} light paths and {caustic} \
             caustic paths traced (of 1000000000 and 1000000000 asked; its attribute says so: \
             photondiff/reference {tag})"
        )),
            "{stderr}"
        );
        // Its halves say the same.
        for half in ["ref-a.exr", "ref-b.exr"] {
            assert_eq!(
                attribute(&dir.path().join(half), "photondiff/reference"),
                tag
            );
        }
        let film = Film::read_exr(&output).unwrap();
        assert!(film.pixels.iter().all(|p| p.is_finite()));
        return;
    }
    panic!("the signal never came during the light tracing");
}

/// A Ctrl-C after the last pass has ended (here as the images are written) cuts nothing: the
/// run writes the image asked for and exits 0, and says the signal came too late, since the
/// signal's own line had promised to drop the pass under way (a hostile user's sweep read the
/// two lines and a status of 0 as a swallowed Ctrl-C).
#[test]
fn a_ctrl_c_after_the_last_pass_cuts_nothing_and_says_so() {
    use std::io::BufRead;
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("scene.toml");
    std::fs::write(&file, SCENE).unwrap();
    // Direct light alone at 2400 x 1800: the passes take about a second each, the writing of
    // the EXR and PNG a few tenths, while the signal is sent.
    let mut child = Command::new(env!("CARGO_BIN_EXE_photondiff"))
        .args(["render", "--estimator", "direct", "--passes", "2"])
        .args(["--resolution", "2400x1800", "-o"])
        .arg(dir.path().join("img.exr"))
        .arg(&file)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = std::io::BufReader::new(child.stderr.take().unwrap()).lines();
    let mut stderr = String::new();
    for line in lines.by_ref() {
        let line = line.unwrap();
        stderr += &line;
        stderr.push('\n');
        if line.starts_with("passes: 2 of 2 done") {
            interrupt(&child, "INT");
            break;
        }
    }
    for line in lines {
        stderr += &line.unwrap();
        stderr.push('\n');
    }
    let status = wait(&mut child);
    assert_eq!(status.code(), Some(0), "{stderr}");
    assert!(
        stderr.contains(
            "photondiff: interrupted: dropping the pass under way, then writing the mean of the \
             passes done (Ctrl-C again to exit at once)\n"
        ) && stderr.ends_with(
            "photondiff: interrupted too late to cut anything: the work asked for was done and \
             written\n"
        ),
        "{stderr}"
    );
    let film = Film::read_exr(&dir.path().join("img.exr")).unwrap();
    assert_eq!((film.width, film.height), (2400, 1800));
}
