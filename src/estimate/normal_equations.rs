//! The normal equations JᵀJ, Jᵀr of a least-squares problem whose Jacobian is met one
//! row at a time and never stored whole: rows are gathered in a small block over the
//! columns they can touch, and each full block is added as one matrix product,
//! JᵀJ += BᵀB, Jᵀr += Bᵀr_B.
//!
//! Adding each row's outer product entry by entry costs the same arithmetic but runs
//! at a fraction of the speed (strided, bounds-checked access to JᵀJ); the block
//! product runs at the speed of `matrixmultiply`'s kernels. With Θ of 114 entries (the
//! DaISy glass furnace) that is most of an output-error fit's time.

use nalgebra::{DMatrix, DMatrixView, DVector};

/// Rows gathered before they are added: enough for the product to run at full speed,
/// few enough that the block stays in cache.
const BLOCK_ROWS: usize = 128;

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
    /// BᵀB of the block (scratch).
    product: DMatrix<f64>,
}

impl RowBlock {
    /// An empty block over no columns.
    pub(crate) fn new() -> RowBlock {
        RowBlock {
            columns: Vec::new(),
            rows: Vec::new(),
            residuals: Vec::with_capacity(BLOCK_ROWS),
            filled: 0,
            product: DMatrix::zeros(0, 0),
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
        self.product = DMatrix::zeros(width, width);
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
    pub(crate) fn flush(&mut self, gram: &mut DMatrix<f64>, grad: &mut DVector<f64>) {
        let (rows, width) = (self.filled, self.columns.len());
        if rows == 0 || width == 0 {
            self.filled = 0;
            self.residuals.clear();
            return;
        }
        let data = &self.rows[..rows * width];
        // B (rows × width) row-major, and Bᵀ over the same storage.
        let b = DMatrixView::from_slice_with_strides(data, rows, width, width, 1);
        let bt = DMatrixView::from_slice_with_strides(data, width, rows, 1, width);
        self.product.gemm(1.0, &bt, &b, 0.0);
        for (a, &qa) in self.columns.iter().enumerate() {
            let row = &data[a..];
            grad[qa] += (0..rows)
                .map(|k| row[k * width] * self.residuals[k])
                .sum::<f64>();
            for (bi, &qb) in self.columns.iter().enumerate().skip(a) {
                gram[(qa, qb)] += self.product[(a, bi)];
            }
        }
        self.filled = 0;
        self.residuals.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn blocks_over_column_subsets_give_the_dense_normal_equations() {
        // 300 rows (more than two blocks) of a 9-column J: the first 200 touch columns
        // 0, 1, 2, 5, 6, the rest 0, 1, 2, 7, 8 (Θ and one segment's x0, as in an
        // output-error fit). Against JᵀJ, Jᵀr of the stored dense J.
        let mut rng = rand::rngs::StdRng::seed_from_u64(21);
        let (rows, cols) = (300, 9);
        let first = [0, 1, 2, 5, 6];
        let second = [0, 1, 2, 7, 8];
        let mut j = DMatrix::<f64>::zeros(rows, cols);
        let r = DVector::from_fn(rows, |_, _| rng.random_range(-1.0..1.0));
        let mut gram = DMatrix::zeros(cols, cols);
        let mut grad = DVector::zeros(cols);
        let mut block = RowBlock::new();
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
        }
        block.flush(&mut gram, &mut grad);
        let (dense_gram, dense_grad) = (j.transpose() * &j, j.transpose() * &r);
        for a in 0..cols {
            assert!((grad[a] - dense_grad[a]).abs() < 1e-12, "Jᵀr[{a}]");
            for b in 0..cols {
                let got = if a <= b { gram[(a, b)] } else { 0.0 };
                let want = if a <= b { dense_gram[(a, b)] } else { 0.0 };
                assert!((got - want).abs() < 1e-12, "JᵀJ[{a}, {b}]: {got} vs {want}");
            }
        }
        // Columns 3 and 4 are never touched; 5 and 7 never share a row.
        assert_eq!(gram[(3, 3)], 0.0);
        assert_eq!(gram[(5, 7)], 0.0);
        assert!(gram[(0, 0)] > 50.0);
    }
}
