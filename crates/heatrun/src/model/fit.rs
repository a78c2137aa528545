//! Fit quality of the simulated model against the measurement.

use std::ops::Range;

use nalgebra::DMatrix;
use serde::Serialize;

use crate::estimate::{DiscreteModel, IdentificationData};

/// Fit of the simulated outputs ŷ (eq. 8) to the measured y, per state.
#[derive(Debug, Clone, Serialize)]
pub struct Fit {
    /// SNR = 20·log10(‖y‖ / ‖y − ŷ‖), in dB (eq. 25).
    pub snr_db: Vec<f64>,
    /// NRMSE fit = 100·(1 − ‖y − ŷ‖ / ‖y − ȳ‖), in %.
    pub nrmse_fit_percent: Vec<f64>,
    /// Root-mean-square error, in K.
    pub rmse_k: Vec<f64>,
    /// Mean squared error, in K².
    pub mse_k2: Vec<f64>,
    /// Largest absolute error, in K.
    pub max_abs_error_k: Vec<f64>,
    /// Instants compared (with some output observed there).
    pub samples: usize,
}

/// The simulated model output over the data, NaN outside the segments.
pub fn simulate(
    model: &DiscreteModel,
    data: &IdentificationData,
    segments: &[Range<usize>],
) -> DMatrix<f64> {
    model.simulate_segments(data, segments)
}

/// Compares a simulation with the measured outputs at every observed entry where the
/// simulation exists; `temperature_base_k` converts pu errors to kelvin.
pub fn fit(data: &IdentificationData, simulated: &DMatrix<f64>, temperature_base_k: f64) -> Fit {
    let n = data.states();
    let mut fit = Fit {
        snr_db: vec![0.0; n],
        nrmse_fit_percent: vec![0.0; n],
        rmse_k: vec![0.0; n],
        mse_k2: vec![0.0; n],
        max_abs_error_k: vec![0.0; n],
        samples: 0,
    };
    let compared = |k: usize, j: usize| data.observed(k, j) && simulated[(k, 0)].is_finite();
    fit.samples = (0..data.len())
        .filter(|&k| (0..n).any(|j| compared(k, j)))
        .count();
    for j in 0..n {
        // Sums over the compared instants, taken in their order without gathering them:
        // on a week at 1 s the three gathered vectors were 14.5 MB, at the replay's peak.
        let rows = || (0..data.len()).filter(move |&k| compared(k, j));
        let count = rows().count();
        if count == 0 {
            continue;
        }
        let y = |k: usize| data.outputs[(k, j)];
        let e = |k: usize| data.outputs[(k, j)] - simulated[(k, j)];
        let mean = rows().map(y).sum::<f64>() / count as f64;
        let y_norm = rows().map(|k| y(k) * y(k)).sum::<f64>().sqrt();
        let e_norm = rows().map(|k| e(k) * e(k)).sum::<f64>().sqrt();
        let dev_norm = rows().map(|k| (y(k) - mean).powi(2)).sum::<f64>().sqrt();
        fit.snr_db[j] = 20.0 * (y_norm / e_norm).log10();
        fit.nrmse_fit_percent[j] = 100.0 * (1.0 - e_norm / dev_norm);
        fit.rmse_k[j] = e_norm / (count as f64).sqrt() * temperature_base_k;
        fit.mse_k2[j] = fit.rmse_k[j] * fit.rmse_k[j];
        fit.max_abs_error_k[j] =
            rows().fold(0.0_f64, |m, k| m.max(e(k).abs())) * temperature_base_k;
    }
    fit
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metrics_by_hand() {
        // y = [1, 2, 3], ŷ = [1, 2, 2]: ‖e‖ = 1, ‖y‖ = √14, ‖y − ȳ‖ = √2.
        let data = IdentificationData::complete(
            1.0,
            DMatrix::from_column_slice(3, 1, &[1.0, 2.0, 3.0]),
            DMatrix::zeros(3, 1),
        );
        let sim = DMatrix::from_column_slice(3, 1, &[1.0, 2.0, 2.0]);
        let f = fit(&data, &sim, 80.0);
        assert!((f.snr_db[0] - 20.0 * 14f64.sqrt().log10()).abs() < 1e-12);
        assert!((f.nrmse_fit_percent[0] - 100.0 * (1.0 - 1.0 / 2f64.sqrt())).abs() < 1e-12);
        assert!((f.rmse_k[0] - 80.0 / 3f64.sqrt()).abs() < 1e-12);
        assert_eq!(f.max_abs_error_k[0], 80.0);
    }

    #[test]
    fn only_observed_entries_are_compared() {
        // Output 0 = [1, 2, 3, 4] with instant 3 not kept (a wild value there must not
        // count); output 1 kept only at 0 and 3. ŷ = y − [0, 0, 1, ·] and y − [·, ·, ·, 2].
        let outputs = DMatrix::from_row_slice(4, 2, &[1.0, 5.0, 2.0, 0.0, 3.0, 0.0, 1e9, 7.0]);
        let data =
            IdentificationData::complete(1.0, outputs, DMatrix::zeros(4, 1)).with_output_observed(
                DMatrix::from_row_slice(4, 2, &[true, true, true, false, true, false, false, true]),
            );
        let sim = DMatrix::from_row_slice(4, 2, &[1.0, 5.0, 2.0, 0.0, 2.0, 0.0, 0.0, 5.0]);
        let f = fit(&data, &sim, 1.0);
        assert_eq!(f.samples, 4);
        assert!((f.rmse_k[0] - (1.0f64 / 3.0).sqrt()).abs() < 1e-12);
        assert!((f.rmse_k[1] - 2.0f64.sqrt()).abs() < 1e-12);
        assert_eq!(f.max_abs_error_k, vec![1.0, 2.0]);
    }
}
