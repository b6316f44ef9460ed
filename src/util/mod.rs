//! Small utilities every stage shares: random number streams, progress bars, atomic file
//! output, input files that are files, EXR inputs of a plausible size, the process's memory,
//! room for input-sized buffers (or a clear error), a trace for profiling, the request to stop
//! a run early, the worker threads and messages on standard error that cannot fail.

pub mod atomic;
pub mod blocks;
pub mod exr_input;
pub mod input;
pub mod interrupt;
pub mod memory;
pub mod pool;
pub mod progress;
pub mod reserve;
pub mod rng;
pub mod stderr;
#[cfg(test)]
pub(crate) mod strategies;
pub mod trace;
