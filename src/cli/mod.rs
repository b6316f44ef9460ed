//! The subcommands of the command line, one file each, and what they share.

/// `println!` for what a command prints on standard output, without its panic when the
/// reader has gone (`photondiff compare ... | head -3` panicked with "failed printing to
/// stdout: Broken pipe" and a backtrace): the line is dropped and the run goes on.
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::cli::print_out(format_args!($($arg)*))
    };
}

pub mod bvh;
pub mod compare;
pub mod info;
pub mod merge;
mod outputs;
pub mod pass_range;
pub mod photon_args;
pub mod photons;
pub mod reference;
pub mod render;
pub mod report;
pub mod resolution;

use outputs::resolved;
pub use outputs::{
    check_image_names, check_outputs, create_parent, preview_path, remove_created_folders,
};

use photondiff::scene::Scene;
use std::path::{Path, PathBuf};

/// Writes `line` and a newline on standard output ([`out!`]): a closed pipe drops it; any
/// other failure (a full disk under `> results.txt`) is kept for [`stdout_failure`], and the
/// run ends with it as its error.
pub fn print_out(line: std::fmt::Arguments) {
    use std::io::Write;
    // An output written to standard output (`--stats-json /dev/stdout`) is all it carries:
    // the line after it made the JSON unreadable.
    if OUTPUT_ON_STDOUT.load(std::sync::atomic::Ordering::Relaxed) {
        photondiff::stderr_line!("{line}");
        return;
    }
    if let Err(e) = writeln!(std::io::stdout().lock(), "{line}") {
        if e.kind() != std::io::ErrorKind::BrokenPipe {
            let _ = STDOUT_FAILURE.set(format!("standard output: cannot write: {e}"));
        }
    }
}

static STDOUT_FAILURE: std::sync::OnceLock<String> = std::sync::OnceLock::new();

/// Whether an output file is standard output itself ([`check_outputs`]): the lines
/// [`print_out`] writes go to standard error then.
static OUTPUT_ON_STDOUT: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Whether `path` is the file standard output writes to (`/dev/stdout`, or the file a shell
/// redirected it to).
fn is_stdout(path: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    let (Ok(a), Ok(b)) = (
        std::fs::metadata(path),
        std::fs::metadata("/proc/self/fd/1"),
    ) else {
        return false;
    };
    (a.dev(), a.ino()) == (b.dev(), b.ino())
}

/// The first failure to write standard output other than a closed pipe, if any.
pub fn stdout_failure() -> Option<&'static String> {
    STDOUT_FAILURE.get()
}

/// Loads the scene at `path` (its mesh files' reading a bar, `load`, when `progress`: a large
/// mesh takes seconds to read), refuses `outputs` that name one of its mesh files (known only
/// once the scene is read: a scene may be a pipe, read once), gives its camera `resolution`
/// (`--resolution`, where given) and prints its warnings. From
/// then on a failed run writes its trace ([`write_trace_of_failure`]).
pub fn load_scene(
    path: &Path,
    progress: bool,
    outputs: &[(&str, &Path)],
    resolution: Option<resolution::Resolution>,
) -> Result<(Scene, u64), String> {
    let bar = photondiff::util::progress::bar(progress, 1, "load");
    let loaded = photondiff::scene::file::load_scene_hashed(path, |done, total| {
        if bar.length() != Some(total) {
            bar.set_length(total);
        }
        bar.set_position(done);
    });
    bar.finish_and_clear();
    let (mut scene, hash) = loaded.map_err(|e| e.to_string())?;
    // Before the warnings: one counts the image's pixels (it gave the scene file's 640 x 480
    // under `--resolution 160x120`).
    resolution::apply(&mut scene, resolution);
    let meshes: Vec<PathBuf> = scene.mesh_files.iter().map(|m| resolved(m)).collect();
    for (flag, output) in outputs {
        let here = resolved(output);
        if let Some(k) = meshes.iter().position(|m| *m == here) {
            let mesh = &scene.mesh_files[k];
            return Err(format!(
                "{flag} names a mesh file of the scene ({}): the run would overwrite it",
                mesh.display()
            ));
        }
    }
    TRACE_PATH.lock().unwrap_or_else(|e| e.into_inner()).1 = true;
    warn_about_scene(path, &scene);
    Ok((scene, hash))
}

/// The most worker threads `--threads` takes: far beyond any machine this runs on, and low
/// enough that asking for a typo's worth (100000) is refused in one line instead of the
/// operating system failing thread after thread.
pub const MAX_THREADS: usize = 1024;

/// Checks `--threads` (0 = one per core), warning when it asks for far more threads than
/// the machine has cores: they only take turns (1,024 on 2 cores traced photons 49 times
/// slower, without a word).
pub fn check_threads(threads: usize) -> Result<usize, String> {
    if threads > MAX_THREADS {
        return Err(format!(
            "--threads must be at most {MAX_THREADS} (0 = one per core), got {threads}"
        ));
    }
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    if threads > 4 * cores {
        photondiff::stderr_line!(
            "photondiff: warning: --threads {threads}: this machine has {cores} cores; more \
             threads than cores take turns and run slower, not faster (0 = one per core)"
        );
    }
    Ok(threads)
}

/// The most photons one map takes: photon indices are 32-bit.
pub const MAX_PHOTONS: usize = 1 << 31;

/// A whole number of 0 or more, for `--seed` (clap said "invalid digit found
/// in string" of `-1`).
pub fn whole<T: std::str::FromStr>(text: &str) -> Result<T, String> {
    text.trim()
        .parse()
        .map_err(|_| format!("expected a whole number from 0 to 2^64 - 1, got {text}"))
}

/// A whole number of threads for `--threads`, at most [`MAX_THREADS`] (0 = one per core): its
/// refusal of `-1` gave [`whole`]'s range, 0 to 2^64 - 1, not the option's.
pub fn thread_count(text: &str) -> Result<usize, String> {
    text.trim().parse().map_err(|_| {
        format!("expected a whole number from 0 to {MAX_THREADS} (0 = one per core), got {text}")
    })
}

/// Parses a photon count (`--photons`, `--caustic-photons`): a whole number up to
/// [`MAX_PHOTONS`].
pub fn photon_count(text: &str) -> Result<usize, String> {
    let n: usize = text
        .trim()
        .parse()
        .map_err(|_| format!("not a whole number of photons: {text}"))?;
    if n > MAX_PHOTONS {
        return Err(format!(
            "must be at most {MAX_PHOTONS} (photon indices are 32-bit), got {n}"
        ));
    }
    Ok(n)
}

/// Resident bytes a stored photon takes at the peak of its map's build (the photon and its
/// power while the map is traced; then its footprint box, the tree, the map's columns):
/// measured at stop 47, `photondiff photons` of 20,000 against 2,000,000 caustic photons, 44 MB
/// against 398 MB (179 bytes a photon; 690 before stop 47's leaner build; global photons on
/// `cornell-glass` 181), and 108 for final gathering's radiance map (`render --gather-rays 4`,
/// 20,000 against 1,000,000 photons); with some margin. `tests/memory.rs` checks a run
/// against it.
pub const PEAK_BYTES_PER_PHOTON: u64 = 250;

/// Bytes a stored caustic photon takes at the least while its map is traced: the map's photon
/// (`photons::map::Photon`, 80) and its power for a single emission (`f64` RGB, 24), both held
/// until the last photon is traced. A firm floor, where [`PEAK_BYTES_PER_PHOTON`] is a ceiling.
pub const LEAST_BYTES_PER_CAUSTIC_PHOTON: u64 = 104;

/// Starts recording the trace `--trace` asks for, if it does: its folder is made now, so that
/// an unwritable path is refused before the work rather than after it.
pub fn start_trace(trace: Option<&Path>) -> Result<(), String> {
    if let Some(path) = trace {
        create_parent(path)?;
        photondiff::util::trace::enable();
        *TRACE_PATH.lock().unwrap_or_else(|e| e.into_inner()) = (Some(path.to_path_buf()), false);
    }
    Ok(())
}

/// Ctrl-C during a render or a reference: the first asks it to stop after the work under way
/// (`first` says what: a pass, or the chunks of light paths of `lighttrace` and `reference`);
/// the image of what was done is written as usual, and the exit status is 130. A second exits
/// at once, writing nothing. Before the work a stop keeps begins (the scene's loading, the
/// BVH's building, and for `reference` its direct light) the first exits at once: there is
/// nothing to keep, and waiting for a large scene's loading to end only to stop took tens of
/// seconds. Not for a worker's pass range (`--pass-range`), whose passes belong to a larger
/// run: there Ctrl-C ends the process as usual.
///
/// SIGTERM (a batch system's time limit) and SIGHUP (a closed terminal) are taken alike; the
/// exit status names the signal that came first, 128 plus its number (143, 129), as a shell
/// would for a process the signal ended ([`photondiff::util::interrupt::exit_status`]). The
/// signals are received on a thread of their own (`signal_hook`'s iterator), so the handling
/// below runs outside the signal handler and may print and exit. Installed once a process.
pub(crate) fn stop_on_ctrl_c(first: &'static str) {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    static INSTALLED: std::sync::Once = std::sync::Once::new();
    INSTALLED.call_once(|| {
        let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
            // Without the handler the signals end the process as they would any other.
            return;
        };
        // A thread that cannot be made drops `signals`, which unregisters them.
        let _ = std::thread::Builder::new()
            .name("signals".into())
            .spawn(move || {
                for signal in signals.forever() {
                    on_signal(first, u8::try_from(signal).unwrap_or(SIGINT as u8));
                }
            });
    });
}

/// What [`stop_on_ctrl_c`] does with the signal numbered `signal`.
fn on_signal(first: &str, signal: u8) {
    let stopped_before = photondiff::util::interrupt::request_by(signal);
    let status = i32::from(photondiff::util::interrupt::exit_status());
    if !photondiff::util::interrupt::begun() {
        photondiff::stderr_line!(
            "\nphotondiff: interrupted before there was anything to keep: exiting without writing"
        );
        std::process::exit(status);
    }
    if stopped_before {
        photondiff::stderr_line!(
            "\nphotondiff: interrupted again: exiting without writing the image"
        );
        std::process::exit(status);
    }
    if photondiff::util::interrupt::kept() {
        photondiff::stderr_line!(
            "\nphotondiff: interrupted: {first} (Ctrl-C again to exit at once)"
        );
    } else {
        // It said it would write the passes done, then that none was.
        photondiff::stderr_line!(
            "\nphotondiff: interrupted: stopping the first pass, which is not finished: \
             nothing will be written (Ctrl-C again to exit at once)"
        );
    }
}

/// Where `--trace` goes, once [`start_trace`] has begun it, and whether a failed run may
/// write it there ([`write_trace_of_failure`]): only once the scene is read and no output
/// names one of its mesh files ([`load_scene`]), which a failure's trace would overwrite.
static TRACE_PATH: std::sync::Mutex<(Option<PathBuf>, bool)> = std::sync::Mutex::new((None, false));

/// Writes the trace of a run that failed with `message`, if one was being recorded and the
/// scene was read, with the failure as an instant event at its end: the trace of a run that
/// failed after an hour is the one worth reading. Returns where it went.
pub fn write_trace_of_failure(message: &str) -> Option<PathBuf> {
    let (path, armed) = TRACE_PATH.lock().unwrap_or_else(|e| e.into_inner()).clone();
    let path = path.filter(|_| armed)?;
    photondiff::util::trace::instant("error", serde_json::json!({ "message": message }));
    photondiff::util::trace::write(&path).ok()?;
    Some(path)
}

/// Writes the trace (`--trace`) and the statistics as JSON (`--stats-json`) where asked for,
/// at the end of a run.
/// `written` are the run's outputs, already complete: an error here says they are, so that
/// an hour's image is not thrown away for want of its statistics.
pub fn write_trace_and_stats(
    trace: Option<&Path>,
    stats_json: Option<&Path>,
    stats: &photondiff::render::stats::Stats,
    written: &[&Path],
) -> Result<(), String> {
    let kept = |e: String| {
        let names: Vec<String> = written.iter().map(|p| p.display().to_string()).collect();
        format!(
            "{e} (the run's output is complete and kept: {})",
            names.join(", ")
        )
    };
    if let Some(path) = trace {
        photondiff::util::trace::write(path).map_err(|e| kept(format!("--trace: {e}")))?;
    }
    if let Some(path) = stats_json {
        create_parent(path).map_err(kept)?;
        let json = serde_json::to_string_pretty(stats).map_err(|e| e.to_string())?;
        photondiff::util::atomic::write_bytes(path, json.as_bytes())
            .map_err(|e| kept(format!("--stats-json: {e}")))?;
    }
    Ok(())
}

/// Prints `memory` (its peak recorded now) on standard error as `render`'s statistics do,
/// unless `quiet`: `photons` and `reference` build the same BVH and hold the same meshes.
pub fn print_memory(memory: &mut photondiff::render::stats::MemoryStats, quiet: bool) {
    if !quiet {
        memory.record_peak();
        photondiff::stderr_line!("{}", memory.summary());
    }
}

/// Refuses, before the photons are traced, caustic photons that cannot fit in the memory the
/// process may still take even at [`LEAST_BYTES_PER_CAUSTIC_PHOTON`]: a scene with caustics
/// stores every caustic photon asked for, and 2 * 10^7 of them under a 1.5 GB limit traced for
/// 15 s and aborted ("memory allocation of 1342177280 bytes failed"). Warns where maps of all
/// the photons asked for may not fit (at [`PEAK_BYTES_PER_PHOTON`]): a warning, not an error,
/// because an open scene stores far fewer global photons than asked (a run asked for 4 * 10^9
/// grew by 11 MB/s for minutes without a word).
pub fn check_photon_memory(
    path: &Path,
    scene: &photondiff::scene::Scene,
    options: &photondiff::photons::options::PhotonOptions,
) -> Result<(), String> {
    use photondiff::util::memory;
    let caustic = options.caustic_photons;
    let stores_caustics = caustic > 0
        && scene.has_diffuse_surface()
        && !photondiff::photons::emission::Emitter::caustic(scene, 1, options.overlap, 0)
            .is_empty();
    let least = caustic as u64 * LEAST_BYTES_PER_CAUSTIC_PHOTON;
    if let Some(left) = memory::short_of(least).filter(|_| stores_caustics) {
        return Err(format!(
            "{}: --caustic-photons {caustic}: the caustic map needs at least {} while it is \
             traced ({LEAST_BYTES_PER_CAUSTIC_PHOTON} bytes a photon), more than {left}",
            path.display(),
            memory::gigabytes(least)
        ));
    }
    let photons = options.global_photons + caustic;
    let need = photons as u64 * PEAK_BYTES_PER_PHOTON;
    if let Some(total) = memory::total_bytes() {
        if need > total / 2 {
            let gb = |b: u64| b as f64 / 1e9;
            photondiff::stderr_line!(
                "photondiff: warning: {}: {photons} photons may need up to {:.1} GB while their \
                 maps are built (about {PEAK_BYTES_PER_PHOTON} bytes a photon); this process may \
                 use {:.1} GB",
                path.display(),
                gb(need),
                gb(total)
            );
        }
    }
    Ok(())
}

/// Warns when the camera is inside glass, where light tracing (`render --estimator
/// lighttrace`, `reference`) reaches it by no path (`photondiff::reference::light_tracer::
/// camera_in_glass`).
pub fn warn_camera_in_glass(
    path: &Path,
    scene: &photondiff::scene::Scene,
    embree: &photondiff::embree::Scene,
) {
    if let Some(glass) = photondiff::reference::light_tracer::camera_in_glass(scene, embree) {
        photondiff::stderr_line!(
            "photondiff: warning: {}: the camera is inside {glass}, which is glass: light \
             tracing reaches the camera through open space only, so what it traces will be \
             black",
            path.display()
        );
    }
}

/// Warns, before light tracing, when pixels show mirrors or glass: the light tracer leaves
/// them dark or partial, and a reference judged over the whole image blames the render for
/// its own gap (a glass sphere of ior 1 read relRMSE 0.137 against the scene without it).
pub fn warn_specular_pixels(
    path: &Path,
    scene: &photondiff::scene::Scene,
    embree: &photondiff::embree::Scene,
) {
    let seen = photondiff::reference::light_tracer::pixels_seeing_specular(scene, embree);
    if seen > 0 {
        let all = u64::from(scene.camera.width) * u64::from(scene.camera.height);
        photondiff::stderr_line!(
            "photondiff: warning: {}: {seen} of {all} pixels show a mirror or glass surface, \
             which light tracing cannot see through: they stay dark or partial however many \
             paths are traced; judge renders against it over the diffuse pixels only \
             (`photondiff reference --masks` writes them for `compare --mask`)",
            path.display()
        );
    }
}

/// Prints what in the scene at `path` will make its image black or wrong without an error
/// (`photondiff::scene::warnings`), one warning a line.
pub fn warn_about_scene(path: &Path, scene: &photondiff::scene::Scene) {
    for w in photondiff::scene::warnings::warnings(scene) {
        photondiff::stderr_line!("photondiff: warning: {}: {w}", path.display());
    }
}

/// A number as an error message shows it: as written for everyday sizes, in exponent form for
/// huge and tiny ones (`1e300` was printed as 301 digits).
pub fn shown(x: f64) -> String {
    if x.is_finite() && x != 0.0 && !(1e-6..1e9).contains(&x.abs()) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_shown_short() {
        assert_eq!(shown(0.5), "0.5");
        assert_eq!(shown(-3.0), "-3");
        assert_eq!(shown(1e300), "1e300");
        assert_eq!(shown(-2.5e-9), "-2.5e-9");
        assert_eq!(shown(f64::NAN), "NaN");
        assert_eq!(shown(0.0), "0");
    }
}
