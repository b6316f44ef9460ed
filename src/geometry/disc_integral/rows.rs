//! The general formula's batches: rows of numbers (a parallelogram's six, a quadrilateral's
//! eight) kept as columns, so that [`LANES`] consecutive rows load as one [`Wide`] per column.

use crate::util::blocks::Blocks;

/// The batches' SIMD lanes: eight `f64`, one AVX-512 register where the machine has it (the
/// build targets the machine's CPU, `.cargo/config.toml`) and two AVX halves elsewhere. Eight
/// lanes where four were before made the general formula's batches 1.6x faster on this
/// AVX-512 machine (`integrated`'s render stage 5% at 20,000 photons, 7.5% at 1,280,000).
pub type Wide = wide::f64x8;

/// SIMD width of the batches.
pub const LANES: usize = 8;

/// Rows of `N` numbers stored as `N` columns, in blocks of [`LANES`] rows
/// ([`crate::util::blocks::Blocks`]), so that a block loads as one [`Wide`] per column.
pub type Rows<const N: usize> = Blocks<f64, LANES, N>;

impl<const N: usize> Rows<N> {
    /// Every [`LANES`] rows as one [`Wide`] per column, the last ones completed with copies of
    /// `filler` (which the caller chooses so that its answer is harmless: far from the disc).
    pub fn chunks(&mut self, filler: [f64; N]) -> impl Iterator<Item = [Wide; N]> + '_ {
        self.padded(filler)
            .iter()
            .map(|block| block.map(Wide::from))
    }
}
