//! Small utilities every stage shares: random number streams, progress bars, atomic file
//! output, input files that are files, EXR inputs of a plausible size, the process's memory, a
//! trace for profiling and the request to stop a run early.

pub mod atomic;
pub mod blocks;
pub mod exr_input;
pub mod input;
pub mod interrupt;
pub mod memory;
pub mod progress;
pub mod rng;
#[cfg(test)]
pub(crate) mod strategies;
pub mod trace;
