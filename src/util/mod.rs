//! Small utilities every stage shares: random number streams, progress bars and atomic file
//! output.

pub mod atomic;
pub mod progress;
pub mod rng;
