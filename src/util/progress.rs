//! Progress of long stages, shared by every stage that reports it: a bar where standard error
//! is a terminal, and where it is not (a batch job's log, a pipe), where a bar cannot be
//! drawn, a line every [`LOG_INTERVAL`] with the same figures.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle, TermLike};
use std::io::{IsTerminal, Write};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// How often a stage's progress is written as a line where no bar can be drawn.
pub const LOG_INTERVAL: Duration = Duration::from_secs(15);

/// [`LOG_INTERVAL`], or the seconds `PHOTONDIFF_PROGRESS_INTERVAL` gives (a positive number;
/// the tests write lines without waiting 15 s for them).
fn log_interval() -> Duration {
    std::env::var("PHOTONDIFF_PROGRESS_INTERVAL")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s > 0.0 && *s < 1e6)
        .map_or(LOG_INTERVAL, Duration::from_secs_f64)
}

/// Whether progress is drawn as bars (standard error is a terminal) rather than written as
/// lines.
pub fn draws_bars() -> bool {
    std::io::stderr().is_terminal()
}

/// A progress bar over `total` steps labelled `stage` when `visible`: drawn on standard error
/// where it is a terminal, else written there as a line (`photons  42% 00:00:15 eta 21s`) every
/// [`LOG_INTERVAL`]; hidden, at no cost to the caller, when not `visible`.
pub fn bar(visible: bool, total: u64, stage: &str) -> ProgressBar {
    if !visible {
        return ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::hidden());
    }
    let (bar, template) = if draws_bars() {
        (
            ProgressBar::new(total),
            "{prefix:>8} [{bar:40}] {percent:>3}% {elapsed_precise} eta {eta}",
        )
    } else {
        let lines = Lines::new(Box::new(std::io::stderr()), log_interval());
        let lines = ProgressDrawTarget::term_like_with_hz(Box::new(lines), 1);
        let bar = ProgressBar::with_draw_target(Some(total), lines);
        // Redrawn every second whether or not the stage moves, so that a stage that stores
        // nothing for minutes (global photons of an open scene) still writes its line every
        // interval: 400 million asked wrote nothing for 40 s.
        bar.enable_steady_tick(Duration::from_secs(1));
        (bar, "{prefix} {percent:>3}% {elapsed_precise} eta {eta}")
    };
    if let Ok(style) = ProgressStyle::with_template(template) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_prefix(stage.to_string());
    bar
}

/// A bar's drawing turned into lines: what a redraw writes is kept, and written to `sink` as
/// one line at most every `interval` (the first once the stage has run that long); cursor
/// movements and clearing mean nothing in a log.
struct Lines {
    interval: Duration,
    state: Mutex<LinesState>,
}

/// What [`Lines`] holds between redraws: where it writes, the text of the redraw under way and
/// when it last wrote a line.
struct LinesState {
    sink: Box<dyn Write + Send>,
    text: String,
    last: Instant,
}

impl Lines {
    fn new(sink: Box<dyn Write + Send>, interval: Duration) -> Self {
        Lines {
            interval,
            state: Mutex::new(LinesState {
                sink,
                text: String::new(),
                last: Instant::now(),
            }),
        }
    }
}

impl std::fmt::Debug for Lines {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Lines")
            .field("interval", &self.interval)
            .finish()
    }
}

impl TermLike for Lines {
    fn width(&self) -> u16 {
        100
    }
    fn move_cursor_up(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_down(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_right(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_left(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn write_line(&self, s: &str) -> std::io::Result<()> {
        self.write_str(s)
    }
    fn write_str(&self, s: &str) -> std::io::Result<()> {
        if let Ok(mut state) = self.state.lock() {
            state.text.push_str(s.trim_end());
        }
        Ok(())
    }
    fn clear_line(&self) -> std::io::Result<()> {
        Ok(())
    }
    fn flush(&self) -> std::io::Result<()> {
        let Ok(mut state) = self.state.lock() else {
            return Ok(());
        };
        let state = &mut *state;
        if !state.text.is_empty() && state.last.elapsed() >= self.interval {
            writeln!(state.sink, "{}", state.text.trim())?;
            state.last = Instant::now();
        }
        state.text.clear();
        Ok(())
    }
}

/// A progress bar over progressive passes (`total` of them, or an open count), whose message
/// the pass loop sets to the time left and the noise estimate. Only where bars are drawn
/// ([`draws_bars`]): elsewhere each pass writes its own line (`render::passes`).
pub fn pass_bar(visible: bool, total: Option<u64>) -> ProgressBar {
    if !visible || !draws_bars() {
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

/// A time left, as a progress line shows it: seconds under two minutes, then minutes, hours and
/// days, and "over a year" beyond (an unreachable `--target-noise` once showed
/// `367399166820846980411787253405786272738312192.0 s left`).
pub fn time_left(seconds: f64) -> String {
    let t = seconds.max(0.0);
    if seconds.is_nan() {
        "? s left".into()
    } else if t < 120.0 {
        format!("{t:.1} s left")
    } else if t < 7200.0 {
        format!("{:.0} min left", t / 60.0)
    } else if t < 2.0 * 86400.0 {
        format!("{:.1} h left", t / 3600.0)
    } else if t < 365.0 * 86400.0 {
        format!("{:.0} days left", t / 86400.0)
    } else {
        "over a year left".into()
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn times_left_read_in_their_unit() {
        assert_eq!(time_left(4.04), "4.0 s left");
        assert_eq!(time_left(-1.0), "0.0 s left");
        assert_eq!(time_left(f64::NAN), "? s left");
        assert_eq!(time_left(600.0), "10 min left");
        assert_eq!(time_left(3.0 * 3600.0), "3.0 h left");
        assert_eq!(time_left(10.0 * 86400.0), "10 days left");
        assert_eq!(time_left(3.7e44), "over a year left");
        assert_eq!(time_left(f64::INFINITY), "over a year left");
    }

    use super::*;
    use std::sync::Arc;

    /// A sink the test reads back.
    #[derive(Clone, Default)]
    struct Shared(Arc<Mutex<Vec<u8>>>);

    impl Write for Shared {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.0.lock().unwrap().extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    /// A bar drawn into `Lines` over `sink`, as [`bar`] makes it where there is no terminal.
    fn logged(sink: &Shared, interval: Duration) -> ProgressBar {
        let lines = Lines::new(Box::new(sink.clone()), interval);
        let bar = ProgressBar::with_draw_target(
            Some(200),
            ProgressDrawTarget::term_like(Box::new(lines)),
        );
        bar.set_style(ProgressStyle::with_template("{prefix} {percent:>3}% {pos}").unwrap());
        bar.set_prefix("light");
        bar
    }

    #[test]
    fn without_a_terminal_progress_is_a_line_at_most_every_interval() {
        let sink = Shared::default();
        let bar = logged(&sink, Duration::ZERO);
        bar.set_position(50);
        bar.set_position(100);
        let text = String::from_utf8(sink.0.lock().unwrap().clone()).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert!(lines.contains(&"light  25% 50"), "{text}");
        assert_eq!(lines.last(), Some(&"light  50% 100"), "{text}");
        // Nothing before the interval has passed since the stage began.
        let quiet = Shared::default();
        let bar = logged(&quiet, Duration::from_secs(3600));
        bar.set_position(150);
        bar.finish_and_clear();
        assert!(quiet.0.lock().unwrap().is_empty());
    }

    #[test]
    fn a_stage_that_does_not_move_still_writes_its_lines() {
        let sink = Shared::default();
        let bar = logged(&sink, Duration::from_millis(40));
        bar.set_position(10);
        // As `bar` ticks without a terminal (there every second): no step is taken here.
        bar.enable_steady_tick(Duration::from_millis(10));
        std::thread::sleep(Duration::from_millis(300));
        bar.finish_and_clear();
        let text = String::from_utf8(sink.0.lock().unwrap().clone()).unwrap();
        assert!(
            text.lines().filter(|l| *l == "light   5% 10").count() >= 2,
            "{text}"
        );
    }
}
