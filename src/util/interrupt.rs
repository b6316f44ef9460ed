//! A request to end a long run early: Ctrl-C at the command line. A progressive render checks
//! it between passes and stops with the passes it has, so that minutes of passes are not lost
//! to one keystroke; the command line installs the handler that makes the request (a second
//! Ctrl-C there exits at once). The library never installs one: a render embedded elsewhere
//! stops only by its rules.

use std::sync::atomic::{AtomicBool, Ordering};

/// Whether a stop was requested. Process-wide, as the signal that sets it.
static REQUESTED: AtomicBool = AtomicBool::new(false);

/// Requests a stop; returns whether one had been requested before.
pub fn request() -> bool {
    REQUESTED.swap(true, Ordering::SeqCst)
}

/// Whether a stop has been requested.
pub fn requested() -> bool {
    REQUESTED.load(Ordering::SeqCst)
}

/// Whether a run stopped early because of the request (a request that came too late to cut
/// anything, during the last pass or the writing, leaves it unset).
static HONOURED: AtomicBool = AtomicBool::new(false);

/// Records that a run stopped early because of the request.
pub fn honour() {
    HONOURED.store(true, Ordering::SeqCst);
}

/// Whether a run stopped early because of the request (what the command line's exit status
/// tells).
pub fn honoured() -> bool {
    HONOURED.load(Ordering::SeqCst)
}
