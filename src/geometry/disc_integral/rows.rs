//! The general formula's batches: rows of numbers (a parallelogram's six, a quadrilateral's
//! eight) kept as columns, so that four consecutive rows load as one `f64x4` per column.

use wide::f64x4;

/// SIMD width of the batches.
pub const LANES: usize = 4;

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

    /// Every four rows as one `f64x4` per column, the last four completed with copies of
    /// `filler` (which the caller chooses so that its answer is harmless: far from the disc).
    pub fn chunks(&mut self, filler: [f64; N]) -> impl Iterator<Item = [f64x4; N]> + '_ {
        while !self.columns[0].len().is_multiple_of(LANES) {
            for (c, x) in self.columns.iter_mut().zip(filler) {
                c.push(x);
            }
        }
        let columns = &self.columns;
        (0..columns[0].len()).step_by(LANES).map(move |k| {
            std::array::from_fn(|c| {
                f64x4::from(
                    <[f64; LANES]>::try_from(&columns[c][k..k + LANES]).unwrap_or([0.0; LANES]),
                )
            })
        })
    }
}
