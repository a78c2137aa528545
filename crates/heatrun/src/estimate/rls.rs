//! Recursive least squares with a forgetting factor: the LS estimate updated one
//! instant at a time, usable online, with its trajectory kept for inspection.
//!
//! With the regressor φ(k) = [y(k−1)ᵀ u(k−1)ᵀ]ᵀ shared by all outputs:
//! K = P φ / (λ + φᵀ P φ), θ_i ← θ_i + K (y_i(k) − φᵀ θ_i), P ← (P − K φᵀ P) / λ.
//! It starts diffuse (θ = 0, P large on the regressors' scales), and with λ = 1 ends
//! at the batch LS estimate.

use crate::estimate::Method;
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use super::{
    block_diagonal_covariance, check_enough_rows, DiscreteModel, Estimate, EstimationError,
    Estimator, IdentificationData, Result,
};

/// Θ at one instant of the recursion.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrajectoryPoint {
    /// Grid instant.
    pub instant: usize,
    /// Θ laid out as [`DiscreteModel::theta`].
    pub theta: Vec<f64>,
}

/// Recursive least squares; its [`Estimate`] carries the trajectory of Θ.
#[derive(Debug, Clone)]
pub struct RecursiveLeastSquares {
    /// Forgetting factor λ ∈ (0, 1]; 1 forgets nothing.
    pub forgetting: f64,
    /// Keep every this many instants of the trajectory (and the last).
    pub keep_every: usize,
}

impl Default for RecursiveLeastSquares {
    fn default() -> Self {
        RecursiveLeastSquares {
            forgetting: 1.0,
            keep_every: 10,
        }
    }
}

/// The recursion's state: Θ by columns (column i: θ_i, p × n) and P (p × p).
struct Recursion {
    theta: DMatrix<f64>,
    p: DMatrix<f64>,
    lambda: f64,
}

impl Recursion {
    /// A diffuse start: θ = 0 and P = 10⁸·diag(1/rms_j²) over the regressors' scales, so
    /// the prior weighs like a hundred-millionth of one equation.
    fn diffuse(data: &IdentificationData, rows: &[usize], lambda: f64) -> Recursion {
        let p = data.states() + data.input_count();
        let mut pm = DMatrix::zeros(p, p);
        for j in 0..p {
            let sum: f64 = rows.iter().map(|&k| data.regressor(k, j).powi(2)).sum();
            let rms = (sum / rows.len() as f64).sqrt().max(1e-300);
            pm[(j, j)] = 1e8 / (rms * rms);
        }
        Recursion {
            theta: DMatrix::zeros(p, data.states()),
            p: pm,
            lambda,
        }
    }

    /// One update with regressor φ and outputs y; adds each a-priori error² to `sse`.
    fn update(&mut self, phi: &DVector<f64>, y: impl Fn(usize) -> f64, sse: &mut [f64]) {
        let p_phi = &self.p * phi;
        let denom = self.lambda + phi.dot(&p_phi);
        let gain = &p_phi / denom;
        for (i, acc) in sse.iter_mut().enumerate() {
            let e = y(i) - phi.dot(&self.theta.column(i));
            *acc += e * e;
            let updated = self.theta.column(i) + &gain * e;
            self.theta.set_column(i, &updated);
        }
        self.p = (&self.p - &gain * p_phi.transpose()) / self.lambda;
        // Keep P symmetric against rounding.
        self.p = (&self.p + self.p.transpose()) * 0.5;
    }

    /// Θ laid out as [`DiscreteModel::theta`].
    fn theta_vec(&self) -> Vec<f64> {
        let (p, n) = self.theta.shape();
        (0..n)
            .flat_map(|i| (0..p).map(move |j| (i, j)))
            .map(|(i, j)| self.theta[(j, i)])
            .collect()
    }
}

impl Estimator for RecursiveLeastSquares {
    fn method(&self) -> Method {
        Method::Rls
    }

    /// Runs the recursion over the usable rows; the estimate is where it ends, with its
    /// trajectory (every `keep_every`-th row and the last).
    fn estimate(&self, data: &IdentificationData) -> Result<Estimate> {
        if !(self.forgetting > 0.0 && self.forgetting <= 1.0) {
            return Err(EstimationError::ForgettingFactor {
                value: self.forgetting,
            });
        }
        let rows = data.usable_rows();
        check_enough_rows(data, rows.len())?;
        let (n, m) = (data.states(), data.input_count());
        let p = n + m;
        let mut recursion = Recursion::diffuse(data, &rows, self.forgetting);
        let mut trajectory = Vec::new();
        let mut sse = vec![0.0; n];
        for (count, &k) in rows.iter().enumerate() {
            let phi = DVector::from_fn(p, |j, _| data.regressor(k, j));
            recursion.update(&phi, |i| data.outputs[(k, i)], &mut sse);
            if count % self.keep_every.max(1) == 0 || count + 1 == rows.len() {
                trajectory.push(TrajectoryPoint {
                    instant: k,
                    theta: recursion.theta_vec(),
                });
            }
        }
        let dof = rows.len().max(1) as f64;
        let noise_variance: Vec<f64> = sse.iter().map(|s| s / dof).collect();
        Ok(Estimate {
            model: DiscreteModel::from_theta(n, m, data.ts_s, &recursion.theta_vec()),
            method: self.method(),
            rows_used: rows.len(),
            condition_number: f64::NAN,
            covariance: Some(block_diagonal_covariance(&[&recursion.p], &noise_variance)),
            robust_covariance: None,
            noise_variance,
            iterations: rows.len(),
            output_offset: None,
            trajectory: Some(trajectory),
            network: None,
            predictor: None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate::testing::{
        exact_data, simulate, step_inputs, theta_error, two_state_model, with_noise,
    };
    use crate::estimate::WeightedLeastSquares;

    #[test]
    fn without_forgetting_it_ends_at_batch_least_squares() {
        let truth = two_state_model();
        let mut data = exact_data(&truth, 2000, 21);
        data.outputs = with_noise(&data.outputs, 0.01, 22);
        data.outputs_known[700] = false;
        let rls = RecursiveLeastSquares::default().estimate(&data).unwrap();
        let ls = WeightedLeastSquares::default().estimate(&data).unwrap();
        // The diffuse prior weighs like 1e-8 of an equation: equal to far below the noise.
        assert!(theta_error(&rls.model, &ls.model) < 1e-6);
        assert!(
            theta_error(&ls.model, &truth) > 1e-3,
            "noisy enough to matter"
        );
        assert_eq!(rls.rows_used, ls.rows_used);
        assert_eq!(rls.method, Method::Rls);
        let trajectory = rls.trajectory.as_ref().unwrap();
        let rows = data.usable_rows();
        assert_eq!(trajectory[0].instant, rows[0]);
        assert_eq!(trajectory[1].instant, rows[10]);
        assert_eq!(trajectory.last().unwrap().instant, *rows.last().unwrap());
        assert_eq!(trajectory.last().unwrap().theta, rls.model.theta());
    }

    #[test]
    fn forgetting_follows_a_change_of_the_system() {
        // The system's Γ doubles halfway: with λ = 0.95 the old half is forgotten (its
        // weight 0.95^1000 ≈ 5e-23), without forgetting the estimate lies in between.
        let before = two_state_model();
        let after = before.with_theta(
            &before
                .theta()
                .iter()
                .enumerate()
                .map(|(q, t)| if q % 4 >= 2 { 2.0 * t } else { *t })
                .collect::<Vec<_>>(),
        );
        let u = step_inputs(2000, 2, 23);
        let first = simulate(&before, &u.rows(0, 1000).into_owned(), &[0.5, 0.2]);
        let x = &before.phi * first.row(999).transpose() + &before.gamma * u.row(999).transpose();
        let second = simulate(&after, &u.rows(1000, 1000).into_owned(), x.as_slice());
        let y = DMatrix::from_fn(2000, 2, |k, j| {
            if k < 1000 {
                first[(k, j)]
            } else {
                second[(k - 1000, j)]
            }
        });
        let data = IdentificationData::complete(1.0, y, u);
        let forgetting = RecursiveLeastSquares {
            forgetting: 0.95,
            keep_every: 1,
        }
        .estimate(&data)
        .unwrap();
        assert!(theta_error(&forgetting.model, &after) < 1e-6);
        let remembering = RecursiveLeastSquares::default().estimate(&data).unwrap();
        assert!(theta_error(&remembering.model, &after) > 0.05);
        assert!(theta_error(&remembering.model, &before) > 0.05);
        // Just before the change the forgetting estimate was the first system.
        let at_change = forgetting
            .trajectory
            .as_ref()
            .unwrap()
            .iter()
            .find(|pt| pt.instant == 999)
            .unwrap();
        assert!(theta_error(&before.with_theta(&at_change.theta), &before) < 1e-6);
    }

    #[test]
    fn a_forgetting_factor_outside_the_interval_is_refused() {
        let data = exact_data(&two_state_model(), 300, 24);
        for value in [0.0, 1.5, f64::NAN] {
            let e = RecursiveLeastSquares {
                forgetting: value,
                keep_every: 1,
            }
            .estimate(&data)
            .unwrap_err();
            assert!(
                matches!(e, EstimationError::ForgettingFactor { value: v } if v.to_bits() == value.to_bits()),
                "{e}"
            );
        }
    }
}
