//! Small utilities every stage shares: random number streams, progress bars, atomic file
//! output, the process's memory and a trace for profiling.

pub mod atomic;
pub mod memory;
pub mod progress;
pub mod rng;
pub mod trace;
