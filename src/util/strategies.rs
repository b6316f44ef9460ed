//! Property-test strategies shared by the unit tests.

use proptest::prelude::*;

/// Steps between the ends of [`f32_in`].
const STEPS: u32 = 1 << 20;

/// An `f32` from `lo` to `hi` (both ends included), on a grid of 2^20 steps. Why not
/// proptest's own `lo..hi`: proptest 1.12's `f32` range sampler can fail its own assertion
/// (`self.low - result < initial.step`, `float_samplers.rs`) on some seeds, failing a test
/// that found nothing (seen in CI on `0f32..10.0`-style ranges).
pub fn f32_in(lo: f32, hi: f32) -> impl Strategy<Value = f32> + Clone {
    (0..=STEPS).prop_map(move |k| lo + (hi - lo) * (k as f32 / STEPS as f32))
}
