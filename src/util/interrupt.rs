//! A request to end a long run early: Ctrl-C at the command line. A progressive render checks
//! it between passes and stops with the passes it has, so that minutes of passes are not lost
//! to one keystroke; within a pass, photon tracing and the tiles check it too ([`cut_short`])
//! and the pass they cut is dropped, so that a stop takes seconds, not what is left of a pass
//! (minutes for a large one: a batch system's grace period ran out). The command line installs
//! the handler that makes the request (a second Ctrl-C there exits at once). The library never
//! installs one: a render embedded elsewhere stops only by its rules.

use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};

/// Whether a stop was requested. Process-wide, as the signal that sets it.
static REQUESTED: AtomicBool = AtomicBool::new(false);

/// The number of the signal that first requested the stop (0: none, or a request that came
/// from no signal).
static SIGNAL: AtomicU8 = AtomicU8::new(0);

/// SIGINT's number: what [`exit_status`] assumes of a request that named no signal.
const SIGINT: u8 = 2;

/// Requests a stop; returns whether one had been requested before.
pub fn request() -> bool {
    REQUESTED.swap(true, Ordering::SeqCst)
}

/// [`request`] made by the signal numbered `signal` (the first one's number is kept for
/// [`exit_status`]).
pub fn request_by(signal: u8) -> bool {
    let _ = SIGNAL.compare_exchange(0, signal, Ordering::SeqCst, Ordering::SeqCst);
    request()
}

/// The exit status of a run the request stopped: 128 plus the number of the signal that made
/// it, as a shell reports a process the signal ended (130 for Ctrl-C's SIGINT, 143 for
/// SIGTERM, a batch system's time limit, 129 for SIGHUP), so that a script can tell a user's
/// Ctrl-C from its scheduler's limit.
pub fn exit_status() -> u8 {
    match SIGNAL.load(Ordering::SeqCst) {
        0 => 128 + SIGINT,
        signal => 128u8.saturating_add(signal),
    }
}

/// Whether a stop has been requested.
pub fn requested() -> bool {
    REQUESTED.load(Ordering::SeqCst)
}

/// Whether work under way was cut short because of the request since [`take_cut`] last asked.
static CUT: AtomicBool = AtomicBool::new(false);

/// Whether work under way (a batch of photons, a tile) should be cut short: a stop was
/// requested. Records the cut, so that the run drops what it cut ([`take_cut`]).
pub fn cut_short() -> bool {
    let requested = requested();
    if requested {
        CUT.store(true, Ordering::SeqCst);
    }
    requested
}

/// Whether work was cut short since the last call (and forgets it).
pub fn take_cut() -> bool {
    CUT.swap(false, Ordering::SeqCst)
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

/// Whether the run has begun the work a stop keeps (passes, light paths). Before it (reading
/// the scene, hashing its meshes, building the BVH: tens of seconds for a large scene) a stop
/// has nothing to keep, and the command line exits at once rather than after the loading.
static BEGUN: AtomicBool = AtomicBool::new(false);

/// Records that the work a stop keeps has begun.
pub fn begin() {
    BEGUN.store(true, Ordering::SeqCst);
}

/// Whether the work a stop keeps has begun ([`begin`]).
pub fn begun() -> bool {
    BEGUN.load(Ordering::SeqCst)
}

/// Whether the run holds work a stop would keep: a pass summed, or light paths under way
/// (their tracer stops only after a round of them). Before it, a stop during the first pass
/// writes nothing, and the message says so rather than promising the passes done.
static KEPT: AtomicBool = AtomicBool::new(false);

/// Records that the run holds work a stop would keep.
pub fn keep() {
    KEPT.store(true, Ordering::SeqCst);
}

/// Whether the run holds work a stop would keep ([`keep`]).
pub fn kept() -> bool {
    KEPT.load(Ordering::SeqCst)
}
