//! The general formula's batches: rows of numbers (a parallelogram's six, a quadrilateral's
//! eight) kept as columns, so that [`LANES`] consecutive rows load as one [`Wide`] per column.

/// The batches' SIMD lanes: eight `f64`, one AVX-512 register where the machine has it (the
/// build targets the machine's CPU, `.cargo/config.toml`) and two AVX halves elsewhere. Eight
/// lanes where four were before made the general formula's batches 1.6x faster on this
/// AVX-512 machine (`integrated`'s render stage 5% at 20,000 photons, 7.5% at 1,280,000).
pub type Wide = wide::f64x8;

/// SIMD width of the batches.
pub const LANES: usize = 8;

/// Rows of `N` numbers stored as `N` columns (structure of arrays).
#[derive(Debug, Clone)]
pub struct Rows<const N: usize> {
    columns: [Vec<f64>; N],
    len: usize,
}

impl<const N: usize> Default for Rows<N> {
    fn default() -> Self {
        Rows {
            columns: std::array::from_fn(|_| Vec::new()),
            len: 0,
        }
    }
}

impl<const N: usize> Rows<N> {
    /// Empties the batch, keeping its storage.
    pub fn clear(&mut self) {
        for c in &mut self.columns {
            c.clear();
        }
        self.len = 0;
    }

    /// Adds a row.
    pub fn push_row(&mut self, row: [f64; N]) {
        for (c, x) in self.columns.iter_mut().zip(row) {
            c.push(x);
        }
        self.len += 1;
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the batch is empty.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Row `k`.
    pub fn row(&self, k: usize) -> [f64; N] {
        std::array::from_fn(|c| self.columns[c][k])
    }

    /// Every [`LANES`] rows as one [`Wide`] per column, the last ones completed with copies of
    /// `filler` (which the caller chooses so that its answer is harmless: far from the disc).
    pub fn chunks(&mut self, filler: [f64; N]) -> impl Iterator<Item = [Wide; N]> + '_ {
        while !self.columns[0].len().is_multiple_of(LANES) {
            for (c, x) in self.columns.iter_mut().zip(filler) {
                c.push(x);
            }
        }
        let columns = &self.columns;
        (0..columns[0].len()).step_by(LANES).map(move |k| {
            std::array::from_fn(|c| {
                Wide::from(
                    <[f64; LANES]>::try_from(&columns[c][k..k + LANES]).unwrap_or([0.0; LANES]),
                )
            })
        })
    }
}
