//! The normal equations JᵀJ, Jᵀr of a least-squares problem whose Jacobian is met one
//! row at a time and never stored whole: rows are gathered in a small block over the
//! columns they can touch, and each full block is added at once, JᵀJ += BᵀB,
//! Jᵀr += Bᵀr_B.
//!
//! Adding each row's outer product to JᵀJ as it comes costs the same arithmetic but runs
//! at a fraction of the speed (JᵀJ read across its columns, strided and bounds-checked);
//! with Θ of 114 entries (the DaISy glass furnace) that was most of an output-error fit's
//! time.

use nalgebra::{DMatrix, DVector};

/// Rows gathered before they are added: enough to amortise reading JᵀJ and writing it
/// back (at 32 rows that was a third of the time), few enough that a block of the usual
/// 20 to 30 columns stays in the first-level cache (128 rows of 32 entries: 32 kB).
const BLOCK_ROWS: usize = 128;

/// Rows of JᵀJ one tile of [`add_tile`] sums at once.
const TILE_ROWS: usize = 4;

/// Columns of JᵀJ one tile of [`add_tile`] sums at once: with [`TILE_ROWS`], 32 sums in
/// registers, eight independent chains of four where one column's sums are one chain.
const TILE_COLUMNS: usize = 8;

/// Rows of J over a set of columns (increasing), gathered and added to JᵀJ (upper
/// triangle) and Jᵀr a block at a time.
#[derive(Debug, Clone)]
pub(crate) struct RowBlock {
    /// The column of J of each of the block's columns, increasing.
    columns: Vec<usize>,
    /// The rows, row-major, [`RowBlock::stride`] entries a row: the row's entries over
    /// `columns`, then its residual, then zeros up to the stride.
    rows: Vec<f64>,
    /// Entries a row, the columns and the residual padded for whole tiles.
    stride: usize,
    filled: usize,
    /// The sums of the block's tiles, `stride` × `stride` row-major: entry (a, b) of the
    /// block's part of [JᵀJ Jᵀr] for a ≤ b (b = the residual's column for Jᵀr), and
    /// products a tile computes beyond them that are never read.
    sums: Vec<f64>,
}

impl RowBlock {
    /// An empty block over no columns.
    pub(crate) fn new() -> RowBlock {
        RowBlock {
            columns: Vec::new(),
            rows: Vec::new(),
            stride: 0,
            filled: 0,
            sums: Vec::new(),
        }
    }

    /// Adds the rows gathered so far, then gathers rows over `columns` (increasing).
    pub(crate) fn set_columns(
        &mut self,
        columns: impl IntoIterator<Item = usize>,
        gram: &mut DMatrix<f64>,
        grad: &mut DVector<f64>,
    ) {
        self.flush(gram, grad);
        self.columns.clear();
        self.columns.extend(columns);
        debug_assert!(self.columns.windows(2).all(|w| w[0] < w[1]));
        // The columns and the residual, rounded up to whole tile rows, and one more tile
        // row: a tile starting at a multiple of TILE_ROWS at or before the residual's
        // column then ends within the stride.
        let with_residual = self.columns.len() + 1;
        self.stride = with_residual.div_ceil(TILE_ROWS) * TILE_ROWS + TILE_COLUMNS - TILE_ROWS;
        self.rows.clear();
        self.rows.resize(BLOCK_ROWS * self.stride, 0.0);
        self.sums.clear();
        self.sums.resize(self.stride * self.stride, 0.0);
    }

    /// A new row with residual `r`, to be filled in over the block's columns (in their
    /// order); adds the block first when it is full.
    pub(crate) fn push(
        &mut self,
        r: f64,
        gram: &mut DMatrix<f64>,
        grad: &mut DVector<f64>,
    ) -> &mut [f64] {
        if self.filled == BLOCK_ROWS {
            self.flush(gram, grad);
        }
        let width = self.columns.len();
        let at = self.filled * self.stride;
        self.filled += 1;
        self.rows[at + width] = r;
        &mut self.rows[at..at + width]
    }

    /// Adds the rows gathered so far to JᵀJ (upper triangle) and Jᵀr, and empties the block.
    ///
    /// Each entry receives its rows' products in row order, one at a time, exactly as
    /// adding the rows one by one would: the sums are the same to the last bit, so the
    /// estimates (and everything fitted to their covariance) do not move. Jᵀr is summed
    /// as one more column of JᵀJ, the residual's ([J r]ᵀ[J r] has Jᵀr there), and the
    /// block's part of [JᵀJ Jᵀr] in tiles of [`TILE_ROWS`] × [`TILE_COLUMNS`] held in
    /// registers through the block's rows ([`add_tile`]).
    pub(crate) fn flush(&mut self, gram: &mut DMatrix<f64>, grad: &mut DVector<f64>) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor has AVX2, checked just above.
            unsafe { self.flush_avx2(gram, grad) };
            return;
        }
        self.flush_portable(gram, grad);
    }

    /// [`RowBlock::flush`] compiled for AVX2: four sums to an instruction where the
    /// portable x86-64 build has two. The same products are added in the same order
    /// (Rust fuses no multiply into an add), so the sums are the same to the bit on every
    /// processor. An output-error fit's evaluation spends much of its time here.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn flush_avx2(&mut self, gram: &mut DMatrix<f64>, grad: &mut DVector<f64>) {
        self.flush_portable(gram, grad);
    }

    /// [`RowBlock::flush`] for any processor; inlined into each compiled variant.
    #[inline(always)]
    fn flush_portable(&mut self, gram: &mut DMatrix<f64>, grad: &mut DVector<f64>) {
        if self.filled == 0 {
            return;
        }
        let (width, stride) = (self.columns.len(), self.stride);
        let columns = &self.columns;
        let sums = &mut self.sums;
        for (a, &qa) in columns.iter().enumerate() {
            for (b, &qb) in columns.iter().enumerate().skip(a) {
                sums[a * stride + b] = gram[(qa, qb)];
            }
            sums[a * stride + width] = grad[qa];
        }
        let data = &self.rows[..self.filled * stride];
        for a0 in (0..width).step_by(TILE_ROWS) {
            for b0 in (a0..=width).step_by(TILE_COLUMNS) {
                add_tile(data, stride, (a0, b0), sums);
            }
        }
        for (a, &qa) in columns.iter().enumerate() {
            for (b, &qb) in columns.iter().enumerate().skip(a) {
                gram[(qa, qb)] = sums[a * stride + b];
            }
            grad[qa] = sums[a * stride + width];
        }
        self.filled = 0;
    }
}

/// sums[a][b] += Σ_k B[k][a] B[k][b] over the tile a = a0…a0+3, b = b0…b0+7, over the
/// rows of `data` (row-major, `stride` entries a row) in order, each product added on its
/// own. The tile's 32 sums stay in registers through all the rows: each row costs 32
/// independent multiply-adds, where one column's sums down the rows would be a chain
/// waiting on each add.
#[inline(always)]
fn add_tile(data: &[f64], stride: usize, (a0, b0): (usize, usize), sums: &mut [f64]) {
    let mut acc = [[0.0; TILE_COLUMNS]; TILE_ROWS];
    for (i, tile_row) in acc.iter_mut().enumerate() {
        let at = (a0 + i) * stride + b0;
        tile_row.copy_from_slice(&sums[at..at + TILE_COLUMNS]);
    }
    for row in data.chunks_exact(stride) {
        let rb = &row[b0..b0 + TILE_COLUMNS];
        let ra = &row[a0..a0 + TILE_ROWS];
        for (tile_row, &x) in acc.iter_mut().zip(ra) {
            for (s, &v) in tile_row.iter_mut().zip(rb) {
                *s += x * v;
            }
        }
    }
    for (i, tile_row) in acc.iter().enumerate() {
        let at = (a0 + i) * stride + b0;
        sums[at..at + TILE_COLUMNS].copy_from_slice(tile_row);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn blocks_over_column_subsets_give_the_row_by_row_sums_exactly() {
        // 300 rows (several blocks) of a 29-column J: the first 200 touch columns
        // 0…12 and 19…23, the rest 0…12 and 24…28 (Θ and one segment's x0, as in an
        // output-error fit; 18 columns, more than two register chunks and a remainder).
        // Against the sums row by row, and JᵀJ, Jᵀr of the stored dense J.
        let mut rng = rand::rngs::StdRng::seed_from_u64(21);
        let (rows, cols) = (300, 29);
        let first: Vec<usize> = (0..13).chain(19..24).collect();
        let second: Vec<usize> = (0..13).chain(24..29).collect();
        let mut j = DMatrix::<f64>::zeros(rows, cols);
        let r = DVector::from_fn(rows, |_, _| rng.random_range(-1.0..1.0));
        let mut gram = DMatrix::zeros(cols, cols);
        let mut grad = DVector::zeros(cols);
        let mut block = RowBlock::new();
        // The reference sums as each row comes, entry by entry.
        let mut one_by_one = DMatrix::<f64>::zeros(cols, cols);
        let mut one_by_one_grad = DVector::<f64>::zeros(cols);
        for k in 0..rows {
            let columns: &[usize] = if k < 200 { &first } else { &second };
            if k == 0 || k == 200 {
                block.set_columns(columns.iter().copied(), &mut gram, &mut grad);
            }
            let row = block.push(r[k], &mut gram, &mut grad);
            for (slot, &q) in row.iter_mut().zip(columns) {
                *slot = rng.random_range(-1.0..1.0);
                j[(k, q)] = *slot;
            }
            for &qa in columns {
                one_by_one_grad[qa] += j[(k, qa)] * r[k];
                for &qb in columns.iter().filter(|&&qb| qb >= qa) {
                    one_by_one[(qa, qb)] += j[(k, qa)] * j[(k, qb)];
                }
            }
        }
        block.flush(&mut gram, &mut grad);
        // The same sums to the last bit (upper triangle).
        assert_eq!(grad, one_by_one_grad);
        for a in 0..cols {
            for b in a..cols {
                assert_eq!(
                    gram[(a, b)].to_bits(),
                    one_by_one[(a, b)].to_bits(),
                    "[{a}, {b}]"
                );
            }
        }
        let (dense_gram, dense_grad) = (j.transpose() * &j, j.transpose() * &r);
        for a in 0..cols {
            assert!((grad[a] - dense_grad[a]).abs() < 1e-12, "Jᵀr[{a}]");
            for b in 0..cols {
                let got = if a <= b { gram[(a, b)] } else { 0.0 };
                let want = if a <= b { dense_gram[(a, b)] } else { 0.0 };
                assert!((got - want).abs() < 1e-12, "JᵀJ[{a}, {b}]: {got} vs {want}");
            }
        }
        // Columns 13…18 are never touched; 19 and 24 never share a row.
        assert_eq!(gram[(15, 15)], 0.0);
        assert_eq!(gram[(19, 24)], 0.0);
        assert!(gram[(0, 0)] > 50.0);
    }
}
