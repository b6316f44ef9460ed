//! `render --pass-range A..B`: passes A to B - 1 of an N-pass progressive render, written with
//! their exact sums (`photondiff::render::pass_part`) for `photondiff merge`.

use photondiff::estimate::EstimatorKind;
use photondiff::photons::PhotonMaps;
use photondiff::render::merge::parse_range;
use photondiff::render::noise::NoiseEstimate;
use photondiff::render::pass_sum::PassSum;
use photondiff::render::passes::{area_factor, PassReport, StopReason};
use photondiff::render::stats::Stats;
use photondiff::render::{Progressive, StopRules};
use std::ops::Range;
use std::time::Instant;

/// Checks `--pass-range` against the other options: it needs `--passes N` (the whole render's
/// count, which the range must lie in) and neither `--time-budget` nor `--target-noise` (every
/// part must know the whole's pass count).
pub fn check(
    text: Option<&str>,
    passes_given: bool,
    stop: &StopRules,
    estimator: EstimatorKind,
) -> Result<Option<Range<u64>>, String> {
    let Some(text) = text else { return Ok(None) };
    let range = parse_range(text).map_err(|e| format!("--pass-range {e}"))?;
    if estimator == EstimatorKind::Lighttrace {
        return Err("--pass-range does not apply to --estimator lighttrace".into());
    }
    let total = match (
        passes_given,
        stop.passes,
        stop.time_budget,
        stop.target_noise,
    ) {
        (true, Some(n), None, None) => n,
        _ => {
            return Err(
                "--pass-range needs --passes N (the whole render's passes) and neither \
                 --time-budget nor --target-noise"
                    .into(),
            )
        }
    };
    if range.end > total {
        return Err(format!(
            "--pass-range {text}: passes beyond --passes {total} (passes count from 0)"
        ));
    }
    Ok(Some(range))
}

/// Renders the passes of `range` of a `total`-pass render (`maps`, when given, standing for
/// pass 0's photon maps), recording the passes and a report in `stats`.
pub fn render(
    progressive: &Progressive,
    range: Range<u64>,
    total: u64,
    mut maps: Option<PhotonMaps>,
    stats: &mut Stats,
) -> Result<PassSum, String> {
    let start = Instant::now();
    // The edge pixels once for the range, as a whole run finds them once (each pass found
    // them again: 502,568 camera rays against 349,096 for 8 passes).
    let progressive = &progressive.with_edges_found(stats);
    let camera = &progressive.scene.camera;
    let (width, height) = progressive.render.film_size(camera.width, camera.height);
    let mut sum = PassSum::new(width, height);
    for pass in range.clone() {
        let mut pass_stats = Stats::default();
        let pass_maps = if pass == 0 { maps.take() } else { None };
        sum.add(&progressive.render_pass_with(pass, pass_maps, false, &mut pass_stats)?);
        stats.absorb_pass(pass_stats);
    }
    stats.finish_passes(sum.passes);
    stats.progressive = Some(PassReport {
        passes: total,
        pass_range: Some([range.start, range.end]),
        alpha: progressive.alpha,
        global_alpha: progressive.global_alpha,
        last_area_factor: area_factor(progressive.alpha, range.end - 1),
        stop: StopReason::Passes,
        seconds_per_pass: start.elapsed().as_secs_f64() / sum.passes.max(1) as f64,
        noise: NoiseEstimate::of(&sum),
    });
    Ok(sum)
}
