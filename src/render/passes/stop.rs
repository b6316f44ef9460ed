//! When a progressive render stops ([`StopRules`], [`StopReason`]) and what it reports
//! ([`PassReport`]).

use crate::render::defaults::DEFAULT_PASSES;
use crate::render::noise::NoiseEstimate;
use serde::Serialize;
use std::time::Duration;

/// The error of a run stopped during its first pass: no pass is whole, so there is no image.
pub const INTERRUPTED_IN_FIRST_PASS: &str =
    "interrupted during the first pass: no pass was finished, so no image was written";

/// When a progressive render stops: after `passes` passes, before a pass that would end after
/// `time_budget`, once the noise estimate falls below `target_noise` (or two passes show a
/// black image), or (with `on_interrupt`) when [`crate::util::interrupt`] asks it to, the pass
/// under way dropped, whichever comes first. At least one pass is rendered, but for a stop
/// asked during the first.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StopRules {
    /// Largest number of passes (`None`: no limit).
    pub passes: Option<u64>,
    /// Time for all passes (photon tracing and rendering; not loading or writing).
    pub time_budget: Option<Duration>,
    /// Relative standard error ([`NoiseEstimate::worst`]) to reach.
    pub target_noise: Option<f64>,
    /// Whether a stop requested through [`crate::util::interrupt`] (Ctrl-C at the command
    /// line) ends the run after the pass under way.
    pub on_interrupt: bool,
}

impl StopRules {
    /// Whether these rules make a long run: a time budget, a target noise or more than
    /// [`DEFAULT_PASSES`] passes (where [`crate::render::defaults::LONG_RUN_EDGE_GRID`]
    /// applies).
    pub fn is_long(&self) -> bool {
        self.time_budget.is_some()
            || self.target_noise.is_some()
            || self.passes.is_some_and(|n| n > DEFAULT_PASSES)
    }
}

/// The stage (and the trace's mark) of a pass an interrupt cut short and the run dropped.
pub const DROPPED_PASS: &str = "dropped pass (interrupted)";

/// Why a progressive render stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// The number of passes asked for was rendered.
    Passes,
    /// Another pass would not have fitted the time budget.
    TimeBudget,
    /// The noise estimate fell below the target.
    TargetNoise,
    /// A stop was requested (Ctrl-C): the image is the mean of the passes done.
    Interrupted,
    /// With a target noise, two passes gave an image black everywhere: its relative noise is
    /// undefined, and waiting for it ran forever.
    BlackImage,
}

impl StopReason {
    /// Its name in the statistics JSON and the EXR attribute `photondiff/passes_stopped_by`
    /// (`time_budget`; the attribute once lower-cased the variant's name, `timebudget`).
    pub fn name(self) -> &'static str {
        match self {
            StopReason::Passes => "passes",
            StopReason::TimeBudget => "time_budget",
            StopReason::TargetNoise => "target_noise",
            StopReason::Interrupted => "interrupted",
            StopReason::BlackImage => "black_image",
        }
    }

    /// As the statistics' summary says it (the JSON's names, in words).
    pub fn words(self) -> &'static str {
        match self {
            StopReason::Passes => "the passes asked for",
            StopReason::TimeBudget => "the time budget",
            StopReason::TargetNoise => "the target noise",
            StopReason::Interrupted => "an interrupt",
            StopReason::BlackImage => "a black image (no noise to measure against the target)",
        }
    }
}

/// What a progressive render reports (in the statistics and the EXR metadata).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PassReport {
    /// Passes of the render: those rendered, or for a `--pass-range` part the whole render's
    /// count, its own passes being [`PassReport::pass_range`].
    pub passes: u64,
    /// A `--pass-range A..B` part's passes, `[A, B]` (B not rendered); `None` for a whole
    /// render and in a merge's report.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pass_range: Option<[u64; 2]>,
    /// The caustic map's schedule's `alpha`.
    pub alpha: f64,
    /// The global map's schedule's `alpha`.
    pub global_alpha: f64,
    /// The caustic footprints' area factor of the last pass.
    pub last_area_factor: f64,
    /// Why it stopped.
    pub stop: StopReason,
    /// Mean wall-clock seconds per pass.
    pub seconds_per_pass: f64,
    /// The noise of the mean, estimated from the passes.
    pub noise: NoiseEstimate,
}

impl PassReport {
    /// The passes this run rendered (a part's own, not the whole render's).
    pub fn rendered(&self) -> u64 {
        self.pass_range.map_or(self.passes, |[a, b]| b - a)
    }

    /// "N passes", or a part's "passes A to B - 1 of an N-pass render".
    pub fn describe_passes(&self) -> String {
        match self.pass_range {
            None => format!("{} passes", self.passes),
            Some([a, b]) if b == a + 1 => format!("pass {a} of a {}-pass render", self.passes),
            Some([a, b]) => format!("passes {a} to {} of a {}-pass render", b - 1, self.passes),
        }
    }
}
