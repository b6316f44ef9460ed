//! The general formula's batches: rows of numbers (a parallelogram's six, a quadrilateral's
//! eight) kept as columns, so that [`LANES`] consecutive rows load as one [`Wide`] per column.

/// The batches' SIMD lanes: eight `f64`, one AVX-512 register where the machine has it (the
/// build targets the machine's CPU, `.cargo/config.toml`) and two AVX halves elsewhere. Eight
/// lanes where four were before made the general formula's batches 1.6x faster on this
/// AVX-512 machine (`integrated`'s render stage 5% at 20,000 photons, 7.5% at 1,280,000).
pub type Wide = wide::f64x8;

/// SIMD width of the batches.
pub const LANES: usize = 8;

/// Rows of `N` numbers stored as `N` columns, in blocks of [`LANES`] rows (a block holds each
/// column's [`LANES`] numbers together), so that a block loads as one [`Wide`] per column.
///
/// Why blocks rather than one `Vec` a column: a row is added with one capacity check instead
/// of `N` (the batches take a row for about every other photon a gather finds: eleven
/// `Vec::push`es a quadrilateral were 1-2% of `integrated`'s render stage), and the storage is
/// kept across batches (cleared blocks are written over, not freed).
#[derive(Debug, Clone)]
pub struct Rows<const N: usize> {
    blocks: Vec<[[f64; LANES]; N]>,
    len: usize,
}

impl<const N: usize> Default for Rows<N> {
    fn default() -> Self {
        Rows {
            blocks: Vec::new(),
            len: 0,
        }
    }
}

impl<const N: usize> Rows<N> {
    /// Empties the batch, keeping its storage.
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Adds a row.
    #[inline]
    pub fn push_row(&mut self, row: [f64; N]) {
        let (b, k) = (self.len / LANES, self.len % LANES);
        if b == self.blocks.len() {
            self.blocks.push([[0.0; LANES]; N]);
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
    pub fn row(&self, k: usize) -> [f64; N] {
        assert!(k < self.len, "row {k} of {}", self.len);
        let block = &self.blocks[k / LANES];
        std::array::from_fn(|c| block[c][k % LANES])
    }

    /// Every [`LANES`] rows as one [`Wide`] per column, the last ones completed with copies of
    /// `filler` (which the caller chooses so that its answer is harmless: far from the disc).
    pub fn chunks(&mut self, filler: [f64; N]) -> impl Iterator<Item = [Wide; N]> + '_ {
        let tail = self.len % LANES;
        if tail != 0 {
            let last = &mut self.blocks[self.len / LANES];
            for (column, x) in last.iter_mut().zip(filler) {
                column[tail..].fill(x);
            }
        }
        self.blocks[..self.len.div_ceil(LANES)]
            .iter()
            .map(|block| block.map(Wide::from))
    }
}
