//! Progressive passes: the image as the running mean of independent passes whose photon
//! footprints shrink, so that both the noise and the bias of the photon estimates vanish
//! (probabilistic progressive photon mapping, Knaus and Zwicker 2011).
//!
//! Pass `i` (from 0) depends only on the run's seed, `i` and the settings, never on the passes
//! before it, so any range of passes can be rendered alone and its [`PassSum`] merged with the
//! others' into the image of one run, bit for bit:
//! - **photons**: fresh caustic and global maps traced with seed [`derive_seed`]`(seed, i)` (the
//!   run's seed itself for pass 0);
//! - **footprint schedule**: every caustic footprint's area is multiplied by
//!   `s_i = prod_{j=1..i} (j + alpha) / (j + 1)` (`s_0 = 1`; Knaus and Zwicker's
//!   `r_{j+1}^2 / r_j^2 = (j + alpha) / (j + 1)`, the footprint area playing `r^2`), every
//!   global footprint's by the same product with `global_alpha`. Photon differentials are
//!   linear in the emission differentials, so scaling a map's overlap by its factor scales every
//!   footprint's area by it; the guards' smallest and largest radius scale by its square root
//!   (otherwise the clamps would stop the shrinking). `jensen` has no footprints: its largest
//!   radius scales by `sqrt(s_i)` and its `k` by `s_i` (at least 2), which shrinks its gather
//!   area at the caustic map's rate. With `alpha` in (0, 1) the variance of the mean of `N`
//!   passes falls as `N^-alpha`; a bias of second order in the radius (smooth light in the
//!   open) falls as `N^(alpha - 1)`, where `alpha = 2/3` balances the two, and a bias of first
//!   order (a caustic's peak and contour, light against a wall or over an edge, where the
//!   kernel meets a kink and the mirror photons reflect the light's slope instead of extending
//!   it) as `N^((alpha - 1) / 2)`, where `alpha = 1/2` balances them. Both maps have such
//!   places, and they come to dominate the error, so both default to 1/2 ([`DEFAULT_ALPHA`],
//!   [`DEFAULT_GLOBAL_ALPHA`]); `--global-alpha 0.667` suits a scene whose global light is
//!   smooth (README, "Progressive passes");
//! - **camera jitter**: pass `i` moves every camera ray to the point `R2(i)` of the plastic
//!   (R2) low-discrepancy sequence shifted to start at the cell's centre, `(0.5, 0.5)`, within
//!   its cell of the view grid (the pixel for a grid of 1). The point is the same for every
//!   pixel: each pass is an image sampled on a shifted grid, and over passes the offsets stratify
//!   the pixel, so edges and silhouettes converge to the box-filtered pixel. A ray's view
//!   footprint keeps its cell's size; estimates that integrate over it
//!   ([`crate::estimate::RadianceEstimator::integrates_view_footprint`]) gather over the cell's
//!   own footprint (moved back to the cell's centre), which keeps their box filter from widening
//!   into a tent. Pass 0 is centred: one pass is exactly the render without passes;
//! - area-light samples use the pass's seed.

use crate::embree;
use crate::estimate::select::GatherScene;
use crate::estimate::{EstimatorKind, EstimatorSettings, RadianceEstimator};
use crate::photons::options::PhotonOptions;
use crate::photons::PhotonMaps;
use crate::render::direct_light::DirectLight;
use crate::render::edges::EdgeMask;
use crate::render::image::{render_image, RenderOptions, RenderedImage};
use crate::render::noise::NoiseEstimate;
use crate::render::pass_sum::PassSum;
use crate::render::photon_pass::trace_photon_maps;
use crate::render::split::Window;
use crate::render::stats::{Stage, Stats};
use crate::scene::Scene;
use crate::util::rng::derive_seed;
use crate::util::trace;
use std::ops::Range;
use std::time::Instant;

mod schedule;
mod stop;
pub use schedule::{area_factor, jitter, pass_photons, DEFAULT_ALPHA, DEFAULT_GLOBAL_ALPHA};
pub use stop::{PassReport, StopReason, StopRules, DROPPED_PASS, INTERRUPTED_IN_FIRST_PASS};

/// A progressive render's settings: everything pass `i` depends on besides `i`.
#[derive(Clone)]
pub struct Progressive<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// Its Embree scene.
    pub embree: &'a embree::Scene,
    /// Photon tracing of pass 0 (later passes derive theirs).
    pub photons: PhotonOptions,
    /// The estimate of pass 0 (`max_radius` and `k` are derived per pass).
    pub estimator: EstimatorSettings,
    /// Rendering of pass 0 (seed and jitter are derived per pass).
    pub render: RenderOptions,
    /// The caustic map's schedule's `alpha` (and `jensen`'s), in (0, 1).
    pub alpha: f64,
    /// The global map's schedule's `alpha`, in (0, 1).
    pub global_alpha: f64,
}

impl Progressive<'_> {
    /// The photon, estimator and render settings of pass `pass`.
    pub fn pass_settings(&self, pass: u64) -> (PhotonOptions, EstimatorSettings, RenderOptions) {
        let s = area_factor(self.alpha, pass);
        let photons = pass_photons(&self.photons, self.alpha, self.global_alpha, pass);
        let k = self.estimator.k;
        let estimator = EstimatorSettings {
            max_radius: photons.limits(self.scene).max_radius,
            k: if k <= 2 {
                k
            } else {
                ((k as f64 * s).round() as usize).max(2)
            },
            ..self.estimator
        };
        let render = self
            .render
            .clone()
            .with_seed(derive_seed(self.render.seed, pass))
            .with_jitter(jitter(pass));
        (photons, estimator, render)
    }

    /// This run with its edge pixels found once for all its passes ([`EdgeMask`]), when its
    /// render options ask for an edge grid and carry none yet; the corner rays are counted in
    /// `stats`. [`Progressive::run`] and [`Progressive::render_range`] do this themselves; a
    /// caller that renders pass after pass with [`Progressive::render_pass`] does it first.
    pub fn with_edges_found(&self, stats: &mut Stats) -> Self {
        let mut run = self.clone();
        let r = &run.render;
        if r.edge_grid_used() > 1 && r.edges.is_none() {
            let camera = &self.scene.camera;
            let window = r
                .window
                .unwrap_or(Window::full(camera.width, camera.height));
            // A stage of its own, its rays on the trace's track: they were in the run's count
            // of camera rays but in no stage's time and on no pass's point of the track.
            let (mask, corner_rays) = stats.time("find edges", || {
                EdgeMask::find(self.scene, self.embree, window)
            });
            stats.rays.camera += corner_rays;
            trace::counter(
                "rays",
                || serde_json::json!({"camera": corner_rays, "specular": 0, "shadow": 0}),
            );
            run.render.edges = Some(mask);
        }
        run
    }

    /// Renders pass `pass` alone, recording its stages and counts in `stats`; `progress` shows
    /// the photon and tile progress bars.
    pub fn render_pass(
        &self,
        pass: u64,
        progress: bool,
        stats: &mut Stats,
    ) -> Result<RenderedImage, String> {
        self.render_pass_with(pass, None, progress, stats)
    }

    /// [`Progressive::render_pass`] with the pass's photon maps, when given, instead of
    /// tracing them (read from a file: `render --photon-maps`).
    pub fn render_pass_with(
        &self,
        pass: u64,
        maps: Option<PhotonMaps>,
        progress: bool,
        stats: &mut Stats,
    ) -> Result<RenderedImage, String> {
        let (photons, settings, render) = self.pass_settings(pass);
        let render = render.with_progress(progress);
        let maps = match settings.kind {
            EstimatorKind::Direct => None,
            EstimatorKind::Lighttrace => {
                return Err("the light tracer has no progressive passes".to_string())
            }
            _ => Some(match maps {
                Some(maps) => maps,
                None => trace_photon_maps(
                    self.scene,
                    self.embree,
                    &photons,
                    render.threads,
                    progress,
                    stats,
                )?,
            }),
        };
        // Direct light where gather rays land close by: one sample per light (the gather
        // averages over many such hits).
        let near_direct = DirectLight {
            scene: self.scene,
            embree: self.embree,
            area_strata: 1,
            footprint_strata: 1,
            jitter: [0.5; 2],
            epsilon: self.scene.ray_epsilon(),
        };
        let at = GatherScene {
            scene: self.scene,
            embree: self.embree,
            max_depth: render.max_depth,
            seed: render.seed,
            direct: &near_direct,
        };
        let estimators = match &maps {
            Some(m) => m.estimators_for(&settings, at)?,
            None => Vec::new(),
        };
        let refs: Vec<&dyn RadianceEstimator> = estimators.iter().map(|e| e.as_ref()).collect();
        render_image(self.scene, self.embree, &refs, &render, stats)
    }

    /// Renders the passes of `range` and sums them (what a worker rendering part of a run does;
    /// [`PassSum::merge`] joins the parts).
    pub fn render_range(&self, range: Range<u64>, stats: &mut Stats) -> Result<PassSum, String> {
        let run = self.with_edges_found(stats);
        let (width, height) = self.film_size();
        let mut sum = PassSum::new(width, height);
        for pass in range {
            let span = trace::span_with("pass", || serde_json::json!({ "pass": pass }));
            let mut pass_stats = Stats::default();
            sum.add(&run.render_pass(pass, false, &mut pass_stats)?);
            drop(span);
            trace_pass(&pass_stats);
            stats.absorb_pass(pass_stats);
        }
        stats.finish_passes(sum.passes);
        Ok(sum)
    }

    /// Renders passes from 0 until a rule of `stop` ends the run; records the passes' stages
    /// and counts and the report in `stats`. `progress` shows a progress bar over the passes
    /// (or, for a single pass, the photon and tile bars).
    pub fn run(
        &self,
        stop: &StopRules,
        progress: bool,
        stats: &mut Stats,
    ) -> Result<PassSum, String> {
        self.run_with_maps(stop, None, progress, stats)
    }

    /// The size of each pass's film: the render options' window, or the whole image.
    fn film_size(&self) -> (u32, u32) {
        let camera = &self.scene.camera;
        self.render.film_size(camera.width, camera.height)
    }

    /// [`Progressive::run`] with pass 0's photon maps, when given, instead of tracing them.
    pub fn run_with_maps(
        &self,
        stop: &StopRules,
        mut maps: Option<PhotonMaps>,
        progress: bool,
        stats: &mut Stats,
    ) -> Result<PassSum, String> {
        let single = stop.passes == Some(1);
        let bar = crate::util::progress::pass_bar(progress && !single, stop.passes);
        let start = Instant::now();
        let run = self.with_edges_found(stats);
        let (width, height) = self.film_size();
        let mut sum = PassSum::new(width, height);
        let mut noise = NoiseEstimate::default();
        // When the last pass kept ended: a pass an interrupt cut short is not one of them (its
        // time counted in, one pass of 1.49 s read 2.78 s).
        let mut passes_end = 0.0;
        // Pass 0 read from a file traces no photons: the passes after it are timed without it.
        let loaded = maps.is_some();
        let mut first_end = None;
        let reason = loop {
            let done = sum.passes;
            let elapsed = start.elapsed().as_secs_f64();
            let per_pass = pass_seconds(elapsed, done, first_end);
            if stop.passes.is_some_and(|n| done >= n) {
                break StopReason::Passes;
            }
            if let Some(budget) = stop.time_budget {
                if done > 0 && elapsed + per_pass > budget.as_secs_f64() {
                    break StopReason::TimeBudget;
                }
            }
            match (stop.target_noise, noise.worst()) {
                (Some(target), Some(now)) if now < target => break StopReason::TargetNoise,
                // Two passes or more: the noise is known unless the image is black.
                (Some(_), None) if done >= 2 => break StopReason::BlackImage,
                _ => {}
            }
            if stop.on_interrupt && done > 0 && crate::util::interrupt::requested() {
                crate::util::interrupt::honour();
                break StopReason::Interrupted;
            }
            let span = trace::span_with("pass", || serde_json::json!({ "pass": done }));
            let mut pass_stats = Stats::default();
            let pass_maps = if done == 0 { maps.take() } else { None };
            // The stages' own progress too where it is written as lines (a batch job's log):
            // a pass can take minutes, and the default's 2 passes wrote nothing until the
            // first ended (110 s in silence). On a terminal the pass bar stands alone.
            let inner = progress && (single || !crate::util::progress::draws_bars());
            let image = run.render_pass_with(done, pass_maps, inner, &mut pass_stats)?;
            drop(span);
            // A stop cut the pass short: it is dropped, and the run ends with the passes done.
            if stop.on_interrupt && crate::util::interrupt::take_cut() {
                if done == 0 {
                    return Err(INTERRUPTED_IN_FIRST_PASS.to_string());
                }
                crate::util::interrupt::honour();
                // Its time in a stage of its own and a mark in the trace: the statistics'
                // stages left it out (0.6 s of the run unaccounted for), and the trace showed
                // its spans as a pass like the others.
                let seconds: f64 = pass_stats.stages.iter().map(|s| s.seconds).sum();
                stats.stages.push(Stage {
                    name: DROPPED_PASS.to_string(),
                    seconds,
                });
                trace::instant(DROPPED_PASS, serde_json::json!({ "pass": done }));
                break StopReason::Interrupted;
            }
            trace_pass(&pass_stats);
            stats.absorb_pass(pass_stats);
            // Timed: 22 ms a pass at 640 x 480, a fifth of a 30-pass run's time with the
            // tiles' assembly, was in no stage.
            noise = stats.time_summed("sum passes", || {
                sum.add(&image);
                NoiseEstimate::of(&sum)
            });
            crate::util::interrupt::keep();
            // From the second pass: one pass has no noise estimate, and a 0 on the track
            // read as a noiseless image.
            if let Some(whole) = noise.whole {
                trace::counter("noise of the mean", || {
                    let mut values = serde_json::json!({ "image": whole });
                    if let Some(caustic) = noise.caustic {
                        values["caustic"] = caustic.into();
                    }
                    values
                });
            }
            let elapsed = start.elapsed().as_secs_f64();
            passes_end = elapsed;
            if loaded && sum.passes == 1 {
                first_end = Some(elapsed);
            }
            bar.set_position(sum.passes);
            let slower = self.alpha.min(self.global_alpha);
            let per_pass = pass_seconds(elapsed, sum.passes, first_end);
            let message = status(stop, sum.passes, elapsed, per_pass, &noise, slower);
            if progress && !single && !crate::util::progress::draws_bars() {
                crate::stderr_line!("{}", pass_line(stop, sum.passes, elapsed, &message));
            }
            bar.set_message(message);
        };
        bar.finish_and_clear();
        stats.finish_passes(sum.passes);
        stats.progressive = Some(PassReport {
            passes: sum.passes,
            pass_range: None,
            alpha: self.alpha,
            global_alpha: self.global_alpha,
            last_area_factor: area_factor(self.alpha, sum.passes.saturating_sub(1)),
            stop: reason,
            seconds_per_pass: passes_end / sum.passes.max(1) as f64,
            noise,
        });
        Ok(sum)
    }
}

/// One pass's counts as counter tracks of the trace.
fn trace_pass(pass: &Stats) {
    trace::counter("rays", || {
        let r = &pass.rays;
        serde_json::json!({"camera": r.camera, "specular": r.specular, "shadow": r.shadow})
    });
    // A pass that traced no maps (`direct`; pass 0 of `--photon-maps`, whose maps were read)
    // has no point on the track (it had an empty one).
    if !pass.photon_maps.is_empty() {
        trace::counter("photons stored", || {
            serde_json::Value::Object(
                pass.photon_maps
                    .iter()
                    .map(|m| (format!("{:?}", m.class), m.stored.into()))
                    .collect(),
            )
        });
    }
    // A pass without gathers (`direct`) has no point on the track (it had 0 / 0).
    if pass.gathers.gathers > 0 {
        trace::counter("photons per gather", || {
            let g = &pass.gathers;
            let per = |n: u64| n as f64 / g.gathers as f64;
            serde_json::json!({"found": per(g.photons_found), "used": per(g.photons_used)})
        });
    }
}

/// The line a pass writes where no progress bar is drawn ([`crate::util::progress`]): what
/// the bar shows, e.g. `passes: 3 of 8 done, 2.4 s, 4.0 s left, noise 2.40% (caustic 2.11%)`.
fn pass_line(stop: &StopRules, done: u64, elapsed: f64, status: &str) -> String {
    let of = stop.passes.map_or(String::new(), |n| format!(" of {n}"));
    format!("passes: {done}{of} done, {elapsed:.1} s, {status}")
}

/// The time a pass is expected to take after `done` passes in `elapsed` seconds: their mean,
/// or, where pass 0 read its photon maps from a file and ended at `first_end`, the mean of the
/// passes after it, which trace their own (600,000 caustic photons: pass 0 took 0.4 s, pass 1
/// 2.6 s, and a 1.5 s budget ran 3.0 s). After pass 0 alone, pass 0's time: nothing better
/// is known (README, "--time-budget").
fn pass_seconds(elapsed: f64, done: u64, first_end: Option<f64>) -> f64 {
    match first_end {
        Some(first) if done >= 2 => (elapsed - first) / (done - 1) as f64,
        _ => elapsed / done.max(1) as f64,
    }
}

/// The progress bar's message: time left (the least any rule allows, from the expected pass
/// time `per_pass`) and the noise estimate.
fn status(
    stop: &StopRules,
    done: u64,
    elapsed: f64,
    per_pass: f64,
    noise: &NoiseEstimate,
    alpha: f64,
) -> String {
    let mut left: Option<f64> = None;
    let mut bound = |t: f64| left = Some(left.map_or(t, |l: f64| l.min(t)));
    if let Some(n) = stop.passes {
        bound(n.saturating_sub(done) as f64 * per_pass);
    }
    if let Some(budget) = stop.time_budget {
        let fit = ((budget.as_secs_f64() - elapsed) / per_pass)
            .floor()
            .max(0.0);
        bound(fit * per_pass);
    }
    if let (Some(target), Some(now)) = (stop.target_noise, noise.worst()) {
        // The noise of the mean falls about as passes^(-alpha / 2) (the slower map's alpha).
        let needed = done as f64 * (now / target).powf(2.0 / alpha);
        bound((needed - done as f64).max(0.0) * per_pass);
    }
    let left = left.map_or("? s left".to_string(), crate::util::progress::time_left);
    format!("{left}, noise {}", noise.describe())
}

#[cfg(test)]
mod tests {
    use super::StopReason;

    /// A pass after one read from a file is expected to take what the passes after it took.
    #[test]
    fn passes_after_loaded_maps_are_timed_without_the_first() {
        assert_eq!(super::pass_seconds(3.0, 2, None), 1.5);
        assert_eq!(super::pass_seconds(0.5, 1, Some(0.5)), 0.5);
        assert_eq!(super::pass_seconds(5.5, 3, Some(0.5)), 2.5);
    }

    /// The EXR attribute's name for a stop is the statistics JSON's (it read `timebudget`
    /// against the JSON's `time_budget`).
    #[test]
    fn a_stops_name_is_the_one_the_json_gives() {
        use StopReason::*;
        for stop in [Passes, TimeBudget, TargetNoise, Interrupted, BlackImage] {
            assert_eq!(serde_json::to_value(stop).unwrap(), stop.name());
        }
    }
}
