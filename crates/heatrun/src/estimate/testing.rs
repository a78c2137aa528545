//! Systems simulated from known matrices, for the estimators' unit tests.

use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};

use super::{DiscreteModel, IdentificationData};

/// A stable two-state, two-input model with time constants of about 18 and 200 samples.
pub(crate) fn two_state_model() -> DiscreteModel {
    DiscreteModel {
        phi: DMatrix::from_row_slice(2, 2, &[0.95, 0.02, 0.01, 0.99]),
        gamma: DMatrix::from_row_slice(2, 2, &[0.3, -0.1, 0.05, 0.08]),
        ts_s: 1.0,
    }
}

/// m inputs, each a random level in [0, 1) held for 20 to 80 instants (load steps).
pub(crate) fn step_inputs(len: usize, m: usize, seed: u64) -> DMatrix<f64> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let mut u = DMatrix::zeros(len, m);
    for j in 0..m {
        let mut k = 0;
        while k < len {
            let level: f64 = rng.random_range(0.0..1.0);
            let hold = rng.random_range(20..80);
            for i in k..(k + hold).min(len) {
                u[(i, j)] = level;
            }
            k += hold;
        }
    }
    u
}

/// The outputs of `model` driven by `inputs` from `x0`, noise-free.
pub(crate) fn simulate(model: &DiscreteModel, inputs: &DMatrix<f64>, x0: &[f64]) -> DMatrix<f64> {
    let n = model.phi.nrows();
    let mut y = DMatrix::zeros(inputs.nrows(), n);
    let mut x = DVector::from_column_slice(x0);
    for k in 0..inputs.nrows() {
        y.set_row(k, &x.transpose());
        x = &model.phi * &x + &model.gamma * inputs.row(k).transpose();
    }
    y
}

/// `y` with white Gaussian noise of σ added to every entry.
pub(crate) fn with_noise(y: &DMatrix<f64>, sigma: f64, seed: u64) -> DMatrix<f64> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let normal = Normal::new(0.0, sigma).expect("σ ≥ 0");
    y.map(|v| v + normal.sample(&mut rng))
}

/// Noise-free data of `model` over `len` instants from x0 = [0.5, 0.2, …].
pub(crate) fn exact_data(model: &DiscreteModel, len: usize, seed: u64) -> IdentificationData {
    let u = step_inputs(len, model.gamma.ncols(), seed);
    let x0: Vec<f64> = (0..model.phi.nrows())
        .map(|i| 0.5 - 0.3 * i as f64)
        .collect();
    IdentificationData::complete(model.ts_s, simulate(model, &u, &x0), u)
}

/// Largest |a − b| / |b| over the entries of Θ.
pub(crate) fn theta_error(a: &DiscreteModel, b: &DiscreteModel) -> f64 {
    a.theta()
        .iter()
        .zip(b.theta())
        .map(|(x, y)| (x - y).abs() / y.abs())
        .fold(0.0, f64::max)
}
