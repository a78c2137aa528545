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

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// A 2-state, 1-input system simulated from known matrices with random inputs.
    fn simulated(n: usize, seed: u64) -> (IdentificationData, DMatrix<f64>, DMatrix<f64>) {
        let phi = DMatrix::from_row_slice(2, 2, &[0.95, 0.02, 0.01, 0.99]);
        let gamma = DMatrix::from_row_slice(2, 1, &[0.3, 0.05]);
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let u = DMatrix::from_fn(n, 1, |_, _| rng.random_range(0.0..1.0));
        let mut y = DMatrix::zeros(n, 2);
        for k in 1..n {
            let next = &phi * y.row(k - 1).transpose() + &gamma * u.row(k - 1).transpose();
            y.set_row(k, &next.transpose());
        }
        (IdentificationData::complete(1.0, y, u), phi, gamma)
    }

    #[test]
    fn exact_data_give_the_true_matrices() {
        let (data, phi, gamma) = simulated(500, 7);
        let e = WeightedLeastSquares::default().estimate(&data).unwrap();
        assert!((e.model.phi - phi).norm() < 1e-12);
        assert!((e.model.gamma - gamma).norm() < 1e-12);
        assert_eq!(e.rows_used, 499);
    }

    #[test]
    fn rows_touching_missing_data_are_left_out() {
        let (mut data, phi, _) = simulated(500, 8);
        // Corrupt instant 200 and mark it unknown: rows 200 and 201 must be skipped.
        data.outputs[(200, 0)] = 1e6;
        data.outputs_known[200] = false;
        let e = WeightedLeastSquares::default().estimate(&data).unwrap();
        assert_eq!(e.rows_used, 497);
        assert!((e.model.phi - phi).norm() < 1e-12);
        assert_eq!(data.segments(), vec![0..200, 201..500]);
    }

    #[test]
    fn time_varying_weights_discount_a_disturbed_stretch() {
        let (mut data, phi, _) = simulated(600, 9);
        for k in 300..320 {
            data.outputs[(k, 1)] += 5.0; // a disturbance on state 2
        }
        let plain = WeightedLeastSquares::default().estimate(&data).unwrap();
        let mut w = DMatrix::from_element(600, 2, 1.0);
        // The disturbed values are regressors of both states' equations at k + 1.
        for k in 300..322 {
            w[(k, 0)] = 1e-12;
            w[(k, 1)] = 1e-12;
        }
        let weighted = WeightedLeastSquares { weights: Some(w) }.estimate(&data).unwrap();
        assert!((plain.model.phi.clone() - &phi).norm() > 1e-3);
        assert!((weighted.model.phi - phi).norm() < 1e-5);
    }
}
