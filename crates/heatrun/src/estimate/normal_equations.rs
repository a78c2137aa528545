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

/// Rows gathered before they are added: enough to amortise reading JᵀJ, few enough that
/// the block stays in the first-level cache (32 rows of 120 entries: 30 kB).
const BLOCK_ROWS: usize = 32;

/// Rows of J over a set of columns (increasing), gathered and added to JᵀJ (upper
/// triangle) and Jᵀr a block at a time.
#[derive(Debug, Clone)]
pub(crate) struct RowBlock {
    /// The column of J of each of the block's columns, increasing.
    columns: Vec<usize>,
    /// The rows, row-major: `filled` rows of `columns.len()` entries.
    rows: Vec<f64>,
    /// The residual of each row.
    residuals: Vec<f64>,
    filled: usize,
    /// One row of the block's part of JᵀJ as it is summed.
    scratch: Vec<f64>,
}

impl RowBlock {
    /// An empty block over no columns.
    pub(crate) fn new() -> RowBlock {
        RowBlock {
            columns: Vec::new(),
            rows: Vec::new(),
            residuals: Vec::with_capacity(BLOCK_ROWS),
            filled: 0,
            scratch: Vec::new(),
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
        let width = self.columns.len();
        self.rows.resize(BLOCK_ROWS * width, 0.0);
        self.scratch.resize(width, 0.0);
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
        let at = self.filled * width;
        self.filled += 1;
        self.residuals.push(r);
        &mut self.rows[at..at + width]
    }

    /// Adds the rows gathered so far to JᵀJ (upper triangle) and Jᵀr, and empties the block.
    ///
    /// Each entry receives its rows' products in row order, one at a time, exactly as
    /// adding the rows one by one would: the sums are the same to the last bit, so the
    /// estimates (and everything fitted to their covariance) do not move. A row of the
    /// block's upper triangle is summed in a contiguous scratch row ([`add_products`]).
    pub(crate) fn flush(&mut self, gram: &mut DMatrix<f64>, grad: &mut DVector<f64>) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor has AVX2, checked just above.
            unsafe { self.flush_avx2(gram, grad) };
            return;
        }
        self.flush_portable(gram, grad);
    }

    /// [`RowBlock::flush`] compiled for AVX2: the register sums of [`add_products`] four
    /// to an instruction where the portable x86-64 build has two. The same products are
    /// added in the same order (Rust fuses no multiply into an add), so the sums are the
    /// same to the bit on every processor. An output-error fit's evaluation spends much
    /// of its time here (43 % of a misfit model's 887-evaluation fit, `perf`).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn flush_avx2(&mut self, gram: &mut DMatrix<f64>, grad: &mut DVector<f64>) {
        self.flush_portable(gram, grad);
    }

    /// [`RowBlock::flush`] for any processor; inlined into each compiled variant.
    #[inline(always)]
    fn flush_portable(&mut self, gram: &mut DMatrix<f64>, grad: &mut DVector<f64>) {
        let (rows, width) = (self.filled, self.columns.len());
        let data = &self.rows[..rows * width];
        for (a, &qa) in self.columns.iter().enumerate() {
            let mut g = grad[qa];
            for (k, r) in self.residuals.iter().enumerate() {
                g += data[k * width + a] * r;
            }
            grad[qa] = g;
            let upper = &self.columns[a..];
            let sums = &mut self.scratch[..upper.len()];
            for (sum, &qb) in sums.iter_mut().zip(upper) {
                *sum = gram[(qa, qb)];
            }
            add_products(data, width, a, sums);
            for (sum, &qb) in sums.iter().zip(upper) {
                gram[(qa, qb)] = *sum;
            }
        }
        self.filled = 0;
        self.residuals.clear();
    }
}

/// Columns summed together in registers by [`add_products`].
const LANES: usize = 8;

/// sums[b − a] += Σ_k B[k][a] B[k][b] for b = a…width−1, over the rows of `data`
/// (row-major, `width` entries a row) in order, each product added on its own. The sums
/// of [`LANES`] columns stay in registers through all the rows.
#[inline(always)]
fn add_products(data: &[f64], width: usize, a: usize, sums: &mut [f64]) {
    let mut chunks = sums.chunks_exact_mut(LANES);
    let mut b = a;
    for chunk in &mut chunks {
        let mut acc = [0.0; LANES];
        acc.copy_from_slice(chunk);
        for row in data.chunks_exact(width) {
            let (ra, rb) = (row[a], &row[b..b + LANES]);
            for (s, v) in acc.iter_mut().zip(rb) {
                *s += ra * v;
            }
        }
        chunk.copy_from_slice(&acc);
        b += LANES;
    }
    for (i, sum) in chunks.into_remainder().iter_mut().enumerate() {
        for row in data.chunks_exact(width) {
            *sum += row[a] * row[b + i];
        }
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
