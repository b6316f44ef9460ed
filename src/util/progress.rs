//! Progress bars for long stages, shared by every stage that reports progress.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// A progress bar over `total` steps labelled `stage`, drawn on standard error when `visible`
/// (and hidden otherwise, at no cost to the caller).
pub fn bar(visible: bool, total: u64, stage: &str) -> ProgressBar {
    if !visible {
        return ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::hidden());
    }
    let bar = ProgressBar::new(total);
    if let Ok(style) = ProgressStyle::with_template(
        "{prefix:>8} [{bar:40}] {percent:>3}% {elapsed_precise} eta {eta}",
    ) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_prefix(stage.to_string());
    bar
}

/// A progress bar over progressive passes (`total` of them, or an open count), whose message
/// the pass loop sets to the time left and the noise estimate.
pub fn pass_bar(visible: bool, total: Option<u64>) -> ProgressBar {
    if !visible {
        return ProgressBar::hidden();
    }
    let (bar, template) = match total {
        Some(n) => (
            ProgressBar::new(n),
            "{prefix:>8} [{bar:30}] {pos}/{len} passes, {elapsed_precise}, {msg}",
        ),
        None => (
            ProgressBar::no_length(),
            "{prefix:>8} {pos} passes, {elapsed_precise}, {msg}",
        ),
    };
    if let Ok(style) = ProgressStyle::with_template(template) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_prefix("passes");
    bar.enable_steady_tick(std::time::Duration::from_millis(250));
    bar
}
