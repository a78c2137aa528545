//! Weighted least squares (eqs. 3–7), solved by a singular value decomposition of
//! the column-scaled regression matrix rather than the normal equations (F^T F)^{-1},
//! whose condition number is the square of F's.

use nalgebra::{DMatrix, DVector};

use super::{check_enough_rows, DiscreteModel, Estimate, Estimator, IdentificationData};
use crate::error::{Error, Result};

/// Smallest ratio σ_min/σ_max of the scaled regression matrix accepted as full rank.
pub const RANK_TOLERANCE: f64 = 1e-10;

/// The paper's estimator: minimises J = ½ Σ_k e(k)ᵀ W(k) e(k) (eq. 3) with the
/// equation error e(k) = y(k) − Φ y(k−1) − Γ u(k−1), W(k) = diag(w_1(k) … w_n(k)).
#[derive(Debug, Clone, Default)]
pub struct WeightedLeastSquares {
    /// Per-instant, per-output weights w_i(k) (N × n); `None` weighs all equally.
    /// With weights constant in time the estimate equals ordinary least squares:
    /// each output's row of Θ is a separate problem.
    pub weights: Option<DMatrix<f64>>,
}

impl Estimator for WeightedLeastSquares {
    fn name(&self) -> &'static str {
        if self.weights.is_some() {
            "wls"
        } else {
            "ls"
        }
    }

    fn estimate(&self, data: &IdentificationData) -> Result<Estimate> {
        let rows = data.usable_rows();
        check_enough_rows(data, rows.len())?;
        let (n, m) = (data.states(), data.input_count());
        let p = n + m;
        let regressor = |k: usize, j: usize| {
            if j < n {
                data.outputs[(k - 1, j)]
            } else {
                data.inputs[(k - 1, j - n)]
            }
        };
        let mut phi = DMatrix::zeros(n, n);
        let mut gamma = DMatrix::zeros(n, m);
        let mut condition_number: f64 = 0.0;
        for i in 0..n {
            let weight = |k: usize| self.weights.as_ref().map_or(1.0, |w| w[(k, i)].max(0.0).sqrt());
            let f = DMatrix::from_fn(rows.len(), p, |r, j| weight(rows[r]) * regressor(rows[r], j));
            let y = DVector::from_fn(rows.len(), |r, _| weight(rows[r]) * data.outputs[(rows[r], i)]);
            let (theta, cond) = solve_scaled(f, &y)?;
            condition_number = condition_number.max(cond);
            for j in 0..n {
                phi[(i, j)] = theta[j];
            }
            for j in 0..m {
                gamma[(i, j)] = theta[n + j];
            }
        }
        Ok(Estimate {
            model: DiscreteModel { phi, gamma, ts_s: data.ts_s },
            method: self.name().into(),
            rows_used: rows.len(),
            condition_number,
        })
    }
}

/// Solves min ‖F θ − y‖ by SVD after scaling F's columns to unit norm; returns θ and
/// the condition number of the scaled F. Errors when F is rank deficient: the
/// inputs did not excite the system enough to tell the parameters apart.
pub fn solve_scaled(mut f: DMatrix<f64>, y: &DVector<f64>) -> Result<(DVector<f64>, f64)> {
    let p = f.ncols();
    let mut scale = vec![1.0; p];
    for (j, s) in scale.iter_mut().enumerate() {
        let norm = f.column(j).norm();
        if norm == 0.0 || !norm.is_finite() {
            return Err(Error::Estimation(format!(
                "regressor {} is zero throughout: that signal never changes from zero, so its \
                 parameters cannot be estimated",
                j + 1
            )));
        }
        *s = 1.0 / norm;
        f.column_mut(j).scale_mut(*s);
    }
    let svd = f.svd(true, true);
    let s_max = svd.singular_values.max();
    let s_min = svd.singular_values.min();
    if !(s_min > RANK_TOLERANCE * s_max) {
        return Err(Error::Estimation(format!(
            "the regression is rank deficient (σ_min/σ_max = {:.1e}): the inputs are not \
             persistently exciting (constant, or proportional to each other), so Φ and Γ \
             cannot be told apart; use a heat run with load steps",
            s_min / s_max
        )));
    }
    let theta = svd
        .solve(y, 0.0)
        .map_err(|e| Error::Estimation(format!("least-squares solve failed: {e}")))?;
    let theta = DVector::from_fn(p, |j, _| theta[j] * scale[j]);
    Ok((theta, s_max / s_min))
}
