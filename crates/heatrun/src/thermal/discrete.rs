//! The discrete-time model every estimator produces (eq. 1): x(k) = Φ x(k−1) + Γ u(k−1).
//! Its simulation on identification data is the estimators' own (`estimate::discrete`).

use nalgebra::DMatrix;
use serde::Serialize;

/// A discrete-time model x(k) = Φ x(k−1) + Γ u(k−1) (eq. 1) with y = x.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DiscreteModel {
    /// State transition matrix Φ (n × n).
    pub phi: DMatrix<f64>,
    /// Input matrix Γ (n × m).
    pub gamma: DMatrix<f64>,
    /// Sample time Ts in s.
    pub ts_s: f64,
}

impl DiscreteModel {
    /// The model of n states and m inputs with Θ = [Φ Γ] (eq. 5) from a vector laid out
    /// as [`DiscreteModel::theta`]: row i of Θ at indices i·(n+m) .. (i+1)·(n+m).
    pub fn from_theta(n: usize, m: usize, ts_s: f64, theta: &[f64]) -> DiscreteModel {
        let p = n + m;
        debug_assert_eq!(theta.len(), n * p);
        DiscreteModel {
            phi: DMatrix::from_fn(n, n, |i, j| theta[i * p + j]),
            gamma: DMatrix::from_fn(n, m, |i, j| theta[i * p + n + j]),
            ts_s,
        }
    }

    /// Θ = [Φ Γ] as one vector, row by row: index i·(n+m) + j.
    pub fn theta(&self) -> Vec<f64> {
        let (n, m) = (self.phi.nrows(), self.gamma.ncols());
        (0..n)
            .flat_map(|i| (0..n + m).map(move |j| (i, j)))
            .map(|(i, j)| {
                if j < n {
                    self.phi[(i, j)]
                } else {
                    self.gamma[(i, j - n)]
                }
            })
            .collect()
    }

    /// A model of this one's shape and sample time with Θ from `theta`
    /// (laid out as [`DiscreteModel::theta`]).
    pub fn with_theta(&self, theta: &[f64]) -> DiscreteModel {
        DiscreteModel::from_theta(self.phi.nrows(), self.gamma.ncols(), self.ts_s, theta)
    }

    /// Whether every eigenvalue of Φ lies inside the unit circle (false for NaN entries).
    pub fn is_stable(&self) -> bool {
        self.spectral_radius() < 1.0
    }

    /// Largest modulus of Φ's eigenvalues (the model is stable below 1); NaN where Φ
    /// has non-finite entries.
    pub fn spectral_radius(&self) -> f64 {
        crate::thermal::matrix::spectral_radius(&self.phi)
    }
}
