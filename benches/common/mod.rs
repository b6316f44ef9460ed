//! What several benchmarks share: settings from the environment, medians, and whole
//! `photondiff render` processes timed as a user runs them. Each benchmark uses part of it.
#![allow(dead_code)]

use photondiff::estimate::RadianceEstimator;
use photondiff::render::stats::Stats;
use photondiff::render::{render_image, RenderOptions};
use photondiff::scene::Scene;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

/// The environment variable `name` parsed, or `default` when it is unset. A whole number may
/// be written as the README writes counts (`1e8`, `2*10^7` is not taken). A value that does
/// not parse stops the benchmark: it fell back to the default without a word, so
/// `PHOTONDIFF_REFERENCE_PATHS=2e7` began a reference of 2*10^8 paths (40 minutes).
pub fn env_or<T: std::str::FromStr>(name: &str, default: T) -> T {
    let Ok(text) = std::env::var(name) else {
        return default;
    };
    let text = text.trim();
    if let Ok(v) = text.parse() {
        return v;
    }
    // `1e8`, `2.5e6`: a whole number in scientific notation.
    let whole = text
        .parse::<f64>()
        .ok()
        .filter(|x| x.fract() == 0.0 && x.abs() < 9.0e15)
        .and_then(|x| format!("{x:.0}").parse().ok());
    whole.unwrap_or_else(|| {
        eprintln!(
            "{name}={text}: not a value this setting takes (a number such as 200000000 or 2e8)"
        );
        std::process::exit(2)
    })
}

/// The median (the upper one of an even count).
pub fn median(mut t: Vec<f64>) -> f64 {
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

/// The ratio `a[i] / b[i]` of times measured back to back in each repetition `i`: lowest,
/// median and highest. Its spread shows how much of a ratio of medians the shared machine's
/// noise can move.
pub fn ratio_spread(a: &[f64], b: &[f64]) -> (f64, f64, f64) {
    let mut r: Vec<f64> = a.iter().zip(b).map(|(x, y)| x / y).collect();
    r.sort_by(f64::total_cmp);
    (r[0], r[r.len() / 2], r[r.len() - 1])
}

/// One render of `estimators` over `scene` with the default options, in this process: its
/// statistics (the render stage's seconds, the gathers' counts).
pub fn render_in_process(
    scene: &Scene,
    embree: &photondiff::embree::Scene,
    estimators: &[Box<dyn RadianceEstimator + '_>],
) -> Stats {
    let refs: Vec<&dyn RadianceEstimator> = estimators.iter().map(|e| e.as_ref()).collect();
    let mut stats = Stats::default();
    render_image(scene, embree, &refs, &RenderOptions::default(), &mut stats)
        .expect("the render runs");
    stats
}

/// Runs `photondiff render SCENE -q -o OUT ARGS...` (this package's binary); returns its wall
/// time in seconds. Its standard error (the open scene's global map falls short, a warning that
/// would repeat every run) is shown only when it fails.
pub fn render_process<S: AsRef<std::ffi::OsStr>>(
    scene: &Path,
    out: &Path,
    args: &[S],
) -> Result<f64, String> {
    let start = Instant::now();
    let output = Command::new(env!("CARGO_BIN_EXE_photondiff"))
        .arg("render")
        .arg(scene)
        .args(["-q", "-o"])
        .arg(out)
        .args(args)
        .output()
        .map_err(|e| format!("cannot run photondiff: {e}"))?;
    let seconds = start.elapsed().as_secs_f64();
    if !output.status.success() {
        let args: Vec<_> = args.iter().map(|a| a.as_ref().to_string_lossy()).collect();
        return Err(format!(
            "photondiff render {args:?} failed: {}\n{}",
            output.status,
            String::from_utf8_lossy(&output.stderr)
        ));
    }
    Ok(seconds)
}

/// `scenes/{file}` of this package, built into Embree, and its split reference of
/// `light_paths` isotropic + `caustic_paths` aimed light paths (direct light on 16x16 and
/// 17x17 rays per pixel), made on first use and cached in `out/reference/` as `{name}-...`.
pub fn scene_with_reference(
    file: &str,
    name: &str,
    light_paths: u64,
    caustic_paths: u64,
) -> Result<
    (
        photondiff::scene::Scene,
        photondiff::embree::Scene,
        photondiff::reference::cache::Reference,
    ),
    String,
> {
    use photondiff::reference::cache::{load_or_make, ReferenceSettings};
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene = photondiff::scene::file::load_scene(&root.join("scenes").join(file))
        .map_err(|e| e.to_string())?;
    let device = photondiff::embree::Device::new().map_err(|e| e.to_string())?;
    let embree = scene.build_embree(&device).map_err(|e| e.to_string())?;
    let settings = ReferenceSettings {
        light_paths,
        caustic_paths,
        direct_grids: [16, 17],
        seed: 0,
    };
    let reference = load_or_make(
        &scene,
        &embree,
        &root.join("out/reference"),
        name,
        &settings,
        &mut |m| eprintln!("{m}"),
    )?;
    Ok((scene, embree, reference))
}

/// Errors against a reference as a table shows them. The README's rule: the reference's own
/// noise (from its halves) is at most a third of any error quoted against it. A cell whose
/// error is under three times that noise is marked `~` (the reference cannot resolve it), and
/// [`Resolution::note`] says how many were and what to do. Before stop 56 only the
/// convergence bench marked them: a smaller reference's unresolved figures read like the
/// published ones.
#[derive(Default)]
pub struct Resolution {
    marked: usize,
    cells: usize,
}

impl Resolution {
    /// `error` with `digits` decimals (as a percentage where `percent`), `~` first where it is
    /// under three times `noise`, the reference's relative noise over the same pixels.
    pub fn cell(&mut self, error: f64, noise: f64, digits: usize, percent: bool) -> String {
        self.cells += 1;
        let unresolved = error < 3.0 * noise;
        self.marked += usize::from(unresolved);
        let mark = if unresolved { "~" } else { "" };
        if percent {
            format!("{mark}{:.digits$}%", 100.0 * error)
        } else {
            format!("{mark}{error:.digits$}")
        }
    }

    /// Whether any cell was marked.
    pub fn any(&self) -> bool {
        self.marked > 0
    }

    /// The table's note: what `~` means, how many cells carry it ("" when none does) and the
    /// bench's `settings` that make its reference larger. Also said on standard error, where a
    /// long run's reader looks first.
    pub fn note(&self, settings: &str) -> String {
        if self.marked == 0 {
            return String::new();
        }
        let text = format!(
            "`~`: {} of {} errors are under three times the reference's noise over the same \
             pixels, which cannot resolve them; a larger reference ({settings}) can.",
            self.marked, self.cells
        );
        eprintln!("warning: {text}");
        text
    }
}
