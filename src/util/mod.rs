//! Small utilities every stage shares: random number streams and progress bars.

pub mod progress;
pub mod rng;
