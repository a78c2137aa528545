//! A known system with a hidden state, for the hidden-state tests.

use nalgebra::{DMatrix, DVector};

use super::HiddenStateModel;
use crate::estimate::testing::{step_inputs, with_noise};
use crate::estimate::IdentificationData;

/// Three thermal nodes, two of them measured (C = [I 0]), two inputs: a winding (node 0)
/// and its housing (node 1) read by sensors, coupled through a core (node 2) no sensor
/// reads. Φ = V diag(0.6, 0.92, 0.985) V⁻¹: time constants 1.96, 12.0 and 66.2 samples.
pub(crate) fn known_system() -> HiddenStateModel {
    let v = DMatrix::from_row_slice(3, 3, &[1.0, 0.4, 0.3, -0.5, 1.0, 0.6, 0.2, -0.7, 1.0]);
    let lambda = DMatrix::from_diagonal(&DVector::from_vec(vec![0.6, 0.92, 0.985]));
    let phi = &v * lambda * v.clone().try_inverse().expect("V is invertible");
    let mut c = DMatrix::zeros(2, 3);
    c.view_mut((0, 0), (2, 2)).fill_with_identity();
    HiddenStateModel {
        phi,
        gamma: DMatrix::from_row_slice(3, 2, &[0.08, 0.01, 0.02, 0.05, 0.01, 0.02]),
        c,
        d: DMatrix::zeros(2, 2),
        ts_s: 1.0,
    }
}

/// `len` instants of `model` driven by seeded load steps from rest, its outputs with
/// white noise of σ = `sigma`.
pub(crate) fn simulate_known(
    model: &HiddenStateModel,
    len: usize,
    sigma: f64,
    seed: u64,
) -> IdentificationData {
    simulate_known_coloured(model, len, sigma, 0.0, seed)
}

/// As [`simulate_known`], the noise on each output AR(1): v(k) = ρ v(k−1) + ε(k), its
/// stationary σ = `sigma` (ε's σ·√(1 − ρ²)); `rho` = 0 is white noise.
pub(crate) fn simulate_known_coloured(
    model: &HiddenStateModel,
    len: usize,
    sigma: f64,
    rho: f64,
    seed: u64,
) -> IdentificationData {
    let u = step_inputs(len, model.gamma.ncols(), seed);
    let data = IdentificationData::complete(model.ts_s, DMatrix::zeros(len, model.c.nrows()), u);
    let y = model.simulate(&data, 0..len, &DVector::zeros(model.order()));
    if sigma == 0.0 {
        return IdentificationData::complete(model.ts_s, y, data.inputs);
    }
    let innovations = with_noise(
        &DMatrix::zeros(len, y.ncols()),
        sigma * (1.0 - rho * rho).sqrt(),
        seed + 1000,
    );
    let mut noise = innovations.clone();
    // Stationary from the first instant: v(0) ~ N(0, σ²).
    noise.row_mut(0).scale_mut(1.0 / (1.0 - rho * rho).sqrt());
    for k in 1..len {
        let carried = noise.row(k - 1) * rho + innovations.row(k);
        noise.row_mut(k).copy_from(&carried);
    }
    IdentificationData::complete(model.ts_s, y + noise, data.inputs)
}
