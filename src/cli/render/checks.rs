//! `render`'s options checked on their own and against each other, before the scene is read:
//! a large scene takes seconds to load and build, and an option the run cannot honour is
//! refused at once, with the option's name.

use super::reads::Run;
use super::{estimator_kind, RenderArgs, MAX_TIME_BUDGET};
use photondiff::estimate::final_gather::MAX_NEAR_REACH;
use photondiff::estimate::EstimatorKind;
use photondiff::render::defaults::DEFAULT_PASSES;
use photondiff::render::{StopRules, TileSplit};
use std::ops::Range;

/// The pass options as stop rules (for photon estimates and `direct`).
/// The most passes a render takes: a pass's footprint schedule is a product over the passes
/// before it (`passes::area_factor`), so pass 10^9 took 31 s to set up, and a range near 2^64
/// never began.
pub const MAX_PASSES: u64 = 1_000_000;

pub(super) fn stop_rules(args: &RenderArgs) -> Result<StopRules, String> {
    let passes = match &args.passes {
        None => None,
        Some(text) => match text.trim().parse::<u64>() {
            Ok(n) if (1..=MAX_PASSES).contains(&n) => Some(n),
            _ => {
                return Err(format!(
                    "--passes must be a whole number from 1 to {MAX_PASSES}, got {text}"
                ))
            }
        },
    };
    if let Some(t) = args.time_budget {
        if !(t.is_finite() && t > 0.0) {
            return Err(format!(
                "--time-budget must be a positive number of seconds, got {t}"
            ));
        }
        // A clock deadline must be representable (`Duration` panics past about 1.8e19 s);
        // no render needs more than a year.
        if t > MAX_TIME_BUDGET {
            return Err(format!(
                "--time-budget must be at most {MAX_TIME_BUDGET} seconds (a year), got {t:e}"
            ));
        }
    }
    if let Some(x) = args.target_noise {
        if !(x.is_finite() && x > 0.0) {
            return Err(format!(
                "--target-noise must be a positive relative standard error (e.g. 0.01), got {}",
                crate::cli::shown(x)
            ));
        }
    }
    if !(args.alpha > 0.0 && args.alpha < 1.0) {
        return Err(format!(
            "--alpha must be in (0, 1), got {}",
            crate::cli::shown(args.alpha)
        ));
    }
    if !(args.global_alpha > 0.0 && args.global_alpha < 1.0) {
        return Err(format!(
            "--global-alpha must be in (0, 1), got {}",
            crate::cli::shown(args.global_alpha)
        ));
    }
    let kind = estimator_kind(args);
    if kind == EstimatorKind::Lighttrace {
        for (given, option) in [
            (args.passes.is_some(), "--passes"),
            (args.target_noise.is_some(), "--target-noise"),
        ] {
            if given {
                return Err(format!(
                    "{option} does not apply to --estimator lighttrace (it takes --light-paths \
                     and --time-budget)"
                ));
            }
        }
    }
    let open = args.time_budget.is_some() || args.target_noise.is_some();
    // Progressive by default where the passes converge to the reference and the default
    // render's schedule is tuned (`integrated`); the thesis's single pass for the others.
    let default = match kind {
        EstimatorKind::Integrated => DEFAULT_PASSES,
        EstimatorKind::Direct
        | EstimatorKind::Jensen
        | EstimatorKind::Pd
        | EstimatorKind::Coplanar
        | EstimatorKind::Multisampled
        | EstimatorKind::Lighttrace => 1,
    };
    let passes = passes.or(if open { None } else { Some(default) });
    Ok(StopRules {
        passes,
        time_budget: args.time_budget.map(std::time::Duration::from_secs_f64),
        target_noise: args.target_noise,
        on_interrupt: true,
    })
}

/// `--tile`, parsed here rather than by clap so that a bad split is a one-line error with
/// status 1. (Whether the image has rows enough for it is known once the scene is read.)
pub(super) fn tile(args: &RenderArgs, kind: EstimatorKind) -> Result<Option<TileSplit>, String> {
    let Some(text) = &args.tile else {
        return Ok(None);
    };
    let tile: TileSplit = text.parse().map_err(|e| format!("--tile {e}"))?;
    if kind == EstimatorKind::Lighttrace {
        return Err(
            "--tile cannot split --estimator lighttrace (its paths reach any pixel)".into(),
        );
    }
    // Each part would stop on its own noise or clock, with its own count of passes, and
    // `merge` refuses parts of different counts only once all of them are done (or, where
    // the counts happen to agree, says the whole met a target it never measured).
    for (given, option) in [
        (args.target_noise.is_some(), "--target-noise"),
        (args.time_budget.is_some(), "--time-budget"),
    ] {
        if given {
            return Err(format!(
                "--tile cannot take {option}: each part would stop after its own number of \
                 passes; give the parts --passes N"
            ));
        }
    }
    Ok(Some(tile))
}

/// The options that only some estimators or some runs read: each given where nothing reads it
/// was ignored without a word, so each is refused.
pub(super) fn options(
    args: &RenderArgs,
    run: &Run,
    pass_range: Option<&Range<u64>>,
) -> Result<(), String> {
    if args.gather_rays > 0 && run.kind.reads_maps() && args.photon_maps.is_some() {
        return Err(
            "--gather-rays cannot read --photon-maps: final gathering traces its own radiance map"
                .into(),
        );
    }
    if let (Some(_), Some(range)) = (&args.photon_maps, pass_range) {
        // The file holds pass 0's photons; later passes trace their own.
        if range.start > 0 {
            return Err(format!(
                "--photon-maps holds pass 0's photons, which --pass-range {}..{} does not \
                 render (passes count from 0; the other passes trace their own)",
                range.start, range.end
            ));
        }
    }
    if !(0.0..=MAX_NEAR_REACH).contains(&args.gather_near) {
        return Err(format!(
            "--gather-near must be at least 0 and at most {MAX_NEAR_REACH}, got {}",
            crate::cli::shown(args.gather_near)
        ));
    }
    // Options refused where given and not read (`--photons 1000000` with `--estimator direct`
    // rendered the direct light alone, without a word): one table says which render reads
    // which, and the image's attributes name the same.
    super::reads::refuse_unread(&args.given, run)?;
    Ok(())
}
