//! A trace for profiling: spans (stages, passes, tiles) and counters recorded as Chrome
//! trace-event JSON (`--trace FILE`), which Perfetto and `chrome://tracing` open.
//!
//! Recording is off unless [`enable`] was called; then each span costs a clock read and a
//! mutex push when it ends. Written by hand rather than through `tracing-chrome` because that
//! layer does not write counter events (`"ph": "C"`), which Perfetto draws as tracks.
//!
//! Each event is kept as its compact JSON text, so the trace holds in memory what its file
//! will: kept as `serde_json::Value`s (and copied whole for writing), 70,000 events of a 10 MB
//! file held 370 MB, and a run of a thousand passes at 640 x 480 would have held gigabytes.

use serde_json::{json, Value};
use std::borrow::Cow;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Mutex, OnceLock};
use std::time::Instant;

struct Recorder {
    start: Instant,
    /// The events so far, each as compact JSON followed by a comma.
    events: Mutex<Vec<u8>>,
}

static RECORDER: OnceLock<Recorder> = OnceLock::new();
static ENABLED: AtomicBool = AtomicBool::new(false);
static NEXT_THREAD: AtomicU64 = AtomicU64::new(1);

thread_local! {
    /// This thread's id in the trace (small numbers, in order of first use), announced with
    /// its name in a metadata event the first time it records anything.
    static THREAD: u64 = {
        let tid = NEXT_THREAD.fetch_add(1, Ordering::Relaxed);
        let name = std::thread::current()
            .name()
            .map_or_else(|| format!("thread {tid}"), str::to_string);
        push(json!({"name": "thread_name", "ph": "M", "pid": 1, "tid": tid,
                    "args": {"name": name}}));
        tid
    };
}

fn recorder() -> &'static Recorder {
    RECORDER.get_or_init(|| Recorder {
        start: Instant::now(),
        events: Mutex::new(Vec::new()),
    })
}

fn push(event: Value) {
    if let Ok(mut events) = recorder().events.lock() {
        // Writing a `Value` into a `Vec` cannot fail; were it to, the event is left out.
        if serde_json::to_writer(&mut *events, &event).is_ok() {
            events.push(b',');
        }
    }
}

/// Microseconds since recording began (the trace's time unit).
fn now_us() -> f64 {
    recorder().start.elapsed().as_secs_f64() * 1e6
}

/// Starts recording (for the rest of the process).
pub fn enable() {
    recorder();
    ENABLED.store(true, Ordering::Relaxed);
}

/// Whether spans and counters are being recorded.
pub fn enabled() -> bool {
    ENABLED.load(Ordering::Relaxed)
}

/// A span in progress: recorded as a complete event (`"ph": "X"`) when dropped.
#[must_use = "a span ends when dropped"]
pub struct Span(Option<(Cow<'static, str>, Value, f64)>);

impl Drop for Span {
    fn drop(&mut self) {
        if let Some((name, args, start)) = self.0.take() {
            let tid = THREAD.with(|t| *t);
            push(
                json!({"name": name, "cat": "photondiff", "ph": "X", "pid": 1, "tid": tid,
                        "ts": start, "dur": now_us() - start, "args": args}),
            );
        }
    }
}

/// A span named `name` from now until the returned guard is dropped.
pub fn span(name: impl Into<Cow<'static, str>>) -> Span {
    span_with(name, || Value::Null)
}

/// [`span`] with arguments shown beside it (`args` is only evaluated when recording).
pub fn span_with(name: impl Into<Cow<'static, str>>, args: impl FnOnce() -> Value) -> Span {
    if !enabled() {
        return Span(None);
    }
    let args = match args() {
        Value::Null => json!({}),
        a => a,
    };
    Span(Some((name.into(), args, now_us())))
}

/// Counter track `name` takes `values` (an object of numbers, one line each) from now on.
pub fn counter(name: &str, values: impl FnOnce() -> Value) {
    if enabled() {
        let tid = THREAD.with(|t| *t);
        push(
            json!({"name": name, "ph": "C", "pid": 1, "tid": tid, "ts": now_us(),
                    "args": values()}),
        );
    }
}

/// An instant event `name` (a line across every track in Perfetto) with `args`: a run's
/// failure, at the moment it was given up.
pub fn instant(name: &str, args: Value) {
    if enabled() {
        let tid = THREAD.with(|t| *t);
        push(
            json!({"name": name, "cat": "photondiff", "ph": "i", "s": "g", "pid": 1,
                    "tid": tid, "ts": now_us(), "args": args}),
        );
    }
}

/// Writes what was recorded to `path` (whole or not at all), as `{"traceEvents": [...]}`.
pub fn write(path: &Path) -> Result<(), String> {
    use std::io::Write;
    let process = json!({"name": "process_name", "ph": "M", "pid": 1, "tid": 0,
                         "args": {"name": "photondiff"}});
    let events = match recorder().events.lock() {
        Ok(events) => events,
        Err(poisoned) => poisoned.into_inner(),
    };
    crate::util::atomic::write_with(path, |out| {
        out.write_all(b"{\"traceEvents\":[")?;
        out.write_all(&events)?;
        serde_json::to_writer(&mut *out, &process)?;
        out.write_all(b"],\"displayTimeUnit\":\"ms\"}")
    })
}
