//! Rows of numbers kept as columns in blocks of `L` rows, so that `L` consecutive rows load as
//! one SIMD register a column: the batches the estimators fill a photon at a time and then
//! evaluate a block at a time (`integrated`'s general formula, multi-sampled's kernel sums).

/// Rows of `N` numbers of type `T` stored as `N` columns, in blocks of `L` rows (a block holds
/// each column's `L` numbers together).
///
/// Why blocks rather than one `Vec` a column: a row is added with one capacity check instead
/// of `N` (the batches take a row for about every other photon a gather finds: eleven
/// `Vec::push`es a quadrilateral were 1-2% of `integrated`'s render stage, six a photon 4% of
/// multi-sampled's at 1,280,000 photons), and the storage is kept across batches (cleared
/// blocks are written over, not freed).
#[derive(Debug, Clone)]
pub struct Blocks<T, const L: usize, const N: usize> {
    blocks: Vec<[[T; L]; N]>,
    len: usize,
}

impl<T, const L: usize, const N: usize> Default for Blocks<T, L, N> {
    fn default() -> Self {
        Blocks {
            blocks: Vec::new(),
            len: 0,
        }
    }
}

impl<T: Copy + Default, const L: usize, const N: usize> Blocks<T, L, N> {
    /// Empties the batch, keeping its storage.
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Adds a row.
    #[inline]
    pub fn push_row(&mut self, row: [T; N]) {
        let (b, k) = (self.len / L, self.len % L);
        if b == self.blocks.len() {
            self.blocks.push([[T::default(); L]; N]);
        }
        let block = &mut self.blocks[b];
        for (column, x) in block.iter_mut().zip(row) {
            column[k] = x;
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
    pub fn row(&self, k: usize) -> [T; N] {
        assert!(k < self.len, "row {k} of {}", self.len);
        let block = &self.blocks[k / L];
        std::array::from_fn(|c| block[c][k % L])
    }

    /// The blocks that hold the rows, the last one's rows past the end set to `filler` (which
    /// the caller chooses so that its answer is harmless).
    pub fn padded(&mut self, filler: [T; N]) -> &[[[T; L]; N]] {
        let tail = self.len % L;
        if tail != 0 {
            let last = &mut self.blocks[self.len / L];
            for (column, x) in last.iter_mut().zip(filler) {
                column[tail..].fill(x);
            }
        }
        &self.blocks[..self.len.div_ceil(L)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_come_back_in_their_blocks_padded_and_over_cleared_storage() {
        let mut rows = Blocks::<f32, 4, 2>::default();
        for k in 0..6 {
            rows.push_row([k as f32, -(k as f32)]);
        }
        assert_eq!((rows.len(), rows.row(5)), (6, [5.0, -5.0]));
        let blocks = rows.padded([9.0, 8.0]).to_vec();
        assert_eq!(blocks.len(), 2);
        assert_eq!(blocks[1], [[4.0, 5.0, 9.0, 9.0], [-4.0, -5.0, 8.0, 8.0]]);
        // Cleared, the blocks are written over: what is padded is the new rows' tail.
        rows.clear();
        rows.push_row([1.0, 2.0]);
        assert_eq!(
            rows.padded([0.0, 0.0]),
            &[[[1.0, 0.0, 0.0, 0.0], [2.0, 0.0, 0.0, 0.0]]]
        );
        rows.clear();
        assert!(rows.is_empty() && rows.padded([0.0; 2]).is_empty());
    }
}
