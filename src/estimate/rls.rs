//! Recursive least squares with a forgetting factor: the LS estimate updated one
//! instant at a time, usable online, with its trajectory kept for inspection.
//!
//! With the regressor φ(k) = [y(k−1)ᵀ u(k−1)ᵀ]ᵀ shared by all outputs:
//! K = P φ / (λ + φᵀ P φ), θ_i ← θ_i + K (y_i(k) − φᵀ θ_i), P ← (P − K φᵀ P) / λ.
//! It starts diffuse (θ = 0, P large on the regressors' scales), and with λ = 1 ends
//! at the batch LS estimate.

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use super::{check_enough_rows, DiscreteModel, Estimate, Estimator, IdentificationData};
use crate::error::{Error, Result};

/// Θ at one instant of the recursion.
#[derive(Debug, Clone, Serialize)]
pub struct TrajectoryPoint {
    /// Grid instant.
    pub instant: usize,
    /// Θ laid out as [`DiscreteModel::theta`].
    pub theta: Vec<f64>,
}

/// Recursive least squares.
#[derive(Debug, Clone)]
pub struct RecursiveLeastSquares {
    /// Forgetting factor λ ∈ (0, 1]; 1 forgets nothing.
    pub forgetting: f64,
    /// Keep every this many instants of the trajectory.
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

impl RecursiveLeastSquares {
    /// Runs the recursion; returns the final estimate and the trajectory.
    pub fn run(&self, data: &IdentificationData) -> Result<(Estimate, Vec<TrajectoryPoint>)> {
        if !(self.forgetting > 0.0 && self.forgetting <= 1.0) {
            return Err(Error::Usage(format!(
                "--forgetting {} must be in (0, 1]",
                self.forgetting
            )));
        }
        let rows = data.usable_rows();
        check_enough_rows(data, rows.len())?;
        let (n, m) = (data.states(), data.input_count());
        let p = n + m;
        // A diffuse start: θ = 0 and P = 10⁸·diag(1/rms_j²) over the regressors' scales, so
        // the prior weighs like a hundred-millionth of one equation.
        let mut pm = DMatrix::zeros(p, p);
        for j in 0..p {
            let sum: f64 = rows
                .iter()
                .map(|&k| {
                    if j < n {
                        data.outputs[(k - 1, j)]
                    } else {
                        data.inputs[(k - 1, j - n)]
                    }
                    .powi(2)
                })
                .sum();
            let rms = (sum / rows.len() as f64).sqrt().max(1e-300);
            pm[(j, j)] = 1e8 / (rms * rms);
        }
        let mut theta = DMatrix::zeros(p, n); // column i: θ_i
        let warm = 0;
        let lambda = self.forgetting;
        let mut trajectory = Vec::new();
        let template = DiscreteModel {
            phi: DMatrix::zeros(n, n),
            gamma: DMatrix::zeros(n, m),
            ts_s: data.ts_s,
        };
        let as_vec = |theta: &DMatrix<f64>| -> Vec<f64> {
            (0..n)
                .flat_map(|i| (0..p).map(move |j| theta[(j, i)]))
                .collect()
        };
        let mut sse = vec![0.0; n];
        for (count, &k) in rows.iter().enumerate().skip(warm) {
            let phi = DVector::from_fn(p, |j, _| {
                if j < n {
                    data.outputs[(k - 1, j)]
                } else {
                    data.inputs[(k - 1, j - n)]
                }
            });
            let p_phi = &pm * &phi;
            let denom = lambda + phi.dot(&p_phi);
            let gain = &p_phi / denom;
            for i in 0..n {
                let e = data.outputs[(k, i)] - phi.dot(&theta.column(i));
                sse[i] += e * e;
                let updated = theta.column(i) + &gain * e;
                theta.set_column(i, &updated);
            }
            pm = (&pm - &gain * p_phi.transpose()) / lambda;
            // Keep P symmetric against rounding.
            pm = (&pm + pm.transpose()) * 0.5;
            if count % self.keep_every.max(1) == 0 || count + 1 == rows.len() {
                trajectory.push(TrajectoryPoint {
                    instant: k,
                    theta: as_vec(&theta),
                });
            }
        }
        let dof = (rows.len() - warm).max(1) as f64;
        let noise_variance: Vec<f64> = sse.iter().map(|s| s / dof).collect();
        let mut covariance = DMatrix::zeros(n * p, n * p);
        for i in 0..n {
            covariance
                .view_mut((i * p, i * p), (p, p))
                .copy_from(&(&pm * noise_variance[i]));
        }
        let estimate = Estimate {
            model: template.with_theta(&as_vec(&theta)),
            method: "rls".into(),
            rows_used: rows.len(),
            condition_number: f64::NAN,
            covariance: Some(covariance),
            noise_variance,
            iterations: rows.len() - warm,
            output_offset: None,
        };
        Ok((estimate, trajectory))
    }
}

impl Estimator for RecursiveLeastSquares {
    fn name(&self) -> &'static str {
        "rls"
    }

    fn estimate(&self, data: &IdentificationData) -> Result<Estimate> {
        Ok(self.run(data)?.0)
    }
}
