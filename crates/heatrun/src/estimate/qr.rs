//! Least squares over arbitrarily many rows in O(p²) memory: a QR factorisation of
//! [F Y] updated block by block. After every block, T (upper triangular, p+q square)
//! satisfies TᵀT = [F Y]ᵀ[F Y]; its leading p×p block is R, the next q columns Qᵀ Y,
//! and the trailing q×q block holds the residuals. Stacking [T; block] and refactoring
//! is as stable as a QR of the whole matrix, with no normal equations.

use nalgebra::DMatrix;

/// Rows gathered before each refactorisation.
const BLOCK_ROWS: usize = 2048;

/// A block-updated QR factorisation of [F Y] (p regressors, q right-hand sides).
#[derive(Debug, Clone)]
pub struct StreamingQr {
    p: usize,
    q: usize,
    t: DMatrix<f64>,
    block: Vec<f64>,
}

impl StreamingQr {
    /// An empty factorisation for p regressors and q right-hand sides.
    pub fn new(p: usize, q: usize) -> Self {
        StreamingQr {
            p,
            q,
            t: DMatrix::zeros(p + q, p + q),
            block: Vec::with_capacity(BLOCK_ROWS * (p + q)),
        }
    }

    /// Adds one row: regressors f (length p) and right-hand sides y (length q).
    pub fn push(&mut self, f: &[f64], y: &[f64]) {
        self.block.extend_from_slice(f);
        self.block.extend_from_slice(y);
        if self.block.len() >= BLOCK_ROWS * (self.p + self.q) {
            self.fold();
        }
    }

    fn fold(&mut self) {
        let w = self.p + self.q;
        let k = self.block.len() / w;
        if k == 0 {
            return;
        }
        let mut stacked = DMatrix::zeros(w + k, w);
        stacked.view_mut((0, 0), (w, w)).copy_from(&self.t);
        for r in 0..k {
            for c in 0..w {
                stacked[(w + r, c)] = self.block[r * w + c];
            }
        }
        self.block.clear();
        let r = stacked.qr().r();
        self.t.fill(0.0);
        let rows = r.nrows().min(w);
        self.t
            .view_mut((0, 0), (rows, w))
            .copy_from(&r.view((0, 0), (rows, w)));
    }

    /// The factors: R (p×p, upper triangular), Qᵀ Y (p×q) and the residual sum of
    /// squares of each right-hand side.
    pub fn finish(mut self) -> (DMatrix<f64>, DMatrix<f64>, Vec<f64>) {
        self.fold();
        let (p, q) = (self.p, self.q);
        let r = self.t.view((0, 0), (p, p)).into_owned();
        let qty = self.t.view((0, p), (p, q)).into_owned();
        let tail = self.t.view((p, p), (q, q));
        let rss = (0..q).map(|j| tail.column(j).norm_squared()).collect();
        (r, qty, rss)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DVector;

    /// Solves R θ = Qᵀy for an upper-triangular R.
    fn back_substitute(r: &DMatrix<f64>, qty: &DVector<f64>) -> Option<DVector<f64>> {
        r.solve_upper_triangular(qty)
    }

    #[test]
    fn matches_a_whole_matrix_solution() {
        // y = 2 f0 − 3 f1 + noise-free, over more rows than one block.
        let n = 5000;
        let mut qr = StreamingQr::new(2, 1);
        let mut f = DMatrix::zeros(n, 2);
        let mut y = DVector::zeros(n);
        for i in 0..n {
            let (a, b) = (
                (i as f64 * 0.37).sin(),
                (i as f64 * 0.11).cos() + 0.1 * i as f64 / n as f64,
            );
            let v = 2.0 * a - 3.0 * b + if i % 7 == 0 { 0.01 } else { 0.0 };
            qr.push(&[a, b], &[v]);
            f[(i, 0)] = a;
            f[(i, 1)] = b;
            y[i] = v;
        }
        let (r, qty, rss) = qr.finish();
        let theta = back_substitute(&r, &qty.column(0).into_owned()).unwrap();
        let direct = f.clone().svd(true, true).solve(&y, 0.0).unwrap();
        assert!((theta - &direct).norm() < 1e-12);
        let resid = (&y - &f * &direct).norm_squared();
        assert!(
            (rss[0] - resid).abs() < 1e-10 * resid.max(1e-300),
            "{} vs {resid}",
            rss[0]
        );
    }
}
