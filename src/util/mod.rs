//! Small utilities every stage shares: random number streams, progress bars, atomic file
//! output and the process's memory.

pub mod atomic;
pub mod memory;
pub mod progress;
pub mod rng;
