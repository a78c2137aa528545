//! Weighted least squares (eqs. 3–7), solved by a singular value decomposition of
//! the column-scaled regression matrix rather than the normal equations (F^T F)^{-1},
//! whose condition number is the square of F's.

use nalgebra::{DMatrix, DVector};

use super::{
    check_enough_rows, regression, DiscreteModel, Estimate, Estimator, IdentificationData,
};
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
        let (f, y) = regression(data, &rows);
        let mut theta = vec![0.0; n * p];
        let mut covariance = DMatrix::zeros(n * p, n * p);
        let mut noise_variance = vec![0.0; n];
        let mut condition_number: f64 = 0.0;
        for i in 0..n {
            // Equation k is weighted by w_i(k); its row is scaled by √w_i(k).
            let sqrt_w: Vec<f64> = rows
                .iter()
                .map(|&k| {
                    self.weights
                        .as_ref()
                        .map_or(1.0, |w| w[(k, i)].max(0.0).sqrt())
                })
                .collect();
            let fw = DMatrix::from_fn(rows.len(), p, |r, j| sqrt_w[r] * f[(r, j)]);
            let yw = DVector::from_fn(rows.len(), |r, _| sqrt_w[r] * y[(r, i)]);
            let solution = solve_scaled(fw.clone(), &yw)?;
            condition_number = condition_number.max(solution.condition_number);
            let residual = &yw - &fw * &solution.theta;
            let dof = (rows.len() - p).max(1) as f64;
            noise_variance[i] = residual.norm_squared() / dof;
            theta[i * p..(i + 1) * p].copy_from_slice(solution.theta.as_slice());
            covariance
                .view_mut((i * p, i * p), (p, p))
                .copy_from(&(&solution.inverse_gram * noise_variance[i]));
        }
        let template = DiscreteModel {
            phi: DMatrix::zeros(n, n),
            gamma: DMatrix::zeros(n, m),
            ts_s: data.ts_s,
        };
        Ok(Estimate {
            model: template.with_theta(&theta),
            method: self.name().into(),
            rows_used: rows.len(),
            condition_number,
            covariance: Some(covariance),
            noise_variance,
            iterations: 0,
            output_offset: None,
        })
    }
}

/// A least-squares solution with what its uncertainty needs.
#[derive(Debug, Clone)]
pub struct ScaledSolution {
    /// The minimiser θ.
    pub theta: DVector<f64>,
    /// Condition number of the column-scaled F.
    pub condition_number: f64,
    /// (FᵀF)⁻¹, from the SVD: D V Σ⁻² Vᵀ D with D the column scaling.
    pub inverse_gram: DMatrix<f64>,
}

/// Solves min ‖F θ − y‖ by SVD after scaling F's columns to unit norm; returns θ and
/// the condition number of the scaled F. Errors when F is rank deficient: the
/// inputs did not excite the system enough to tell the parameters apart.
pub fn solve_scaled(mut f: DMatrix<f64>, y: &DVector<f64>) -> Result<ScaledSolution> {
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
    let v_t = svd
        .v_t
        .as_ref()
        .ok_or_else(|| Error::Estimation("SVD without V".into()))?;
    let sigma_inv2 = DMatrix::from_diagonal(&svd.singular_values.map(|s| 1.0 / (s * s)));
    let d = DMatrix::from_diagonal(&DVector::from_column_slice(&scale));
    let inverse_gram = &d * v_t.transpose() * sigma_inv2 * v_t * &d;
    Ok(ScaledSolution {
        theta,
        condition_number: s_max / s_min,
        inverse_gram,
    })
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
        let weighted = WeightedLeastSquares { weights: Some(w) }
            .estimate(&data)
            .unwrap();
        assert!((plain.model.phi.clone() - &phi).norm() > 1e-3);
        assert!((weighted.model.phi - phi).norm() < 1e-5);
    }
}
