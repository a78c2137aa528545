//! Instrumental variables, iterated (the paper's "IV check", made consistent).
//!
//! Least squares regresses y(k) on the measured y(k−1), whose sensor noise is
//! correlated with the equation error, so it is biased. Replacing y(k−1) in the
//! instruments by the noise-free output ŷ(k−1) of a simulated model gives
//! θ_i = (Zᵀ F)⁻¹ Zᵀ y_i with Z rows [ŷ(k−1)ᵀ u(k−1)ᵀ] and F rows [y(k−1)ᵀ u(k−1)ᵀ];
//! ŷ comes from the previous estimate, starting from least squares, repeated until
//! Θ stops changing.

use nalgebra::{DMatrix, DVector};

use super::wls::WeightedLeastSquares;
use super::{
    check_enough_rows, regression, DiscreteModel, Estimate, Estimator, IdentificationData,
};
use crate::error::{Error, Result};

/// Iterated instrumental-variable estimator.
#[derive(Debug, Clone)]
pub struct InstrumentalVariables {
    /// Most re-estimations.
    pub max_iterations: usize,
    /// Stop when ‖ΔΘ‖ / ‖Θ‖ falls below this.
    pub tolerance: f64,
}

impl Default for InstrumentalVariables {
    fn default() -> Self {
        InstrumentalVariables {
            max_iterations: 30,
            tolerance: 1e-10,
        }
    }
}

impl Estimator for InstrumentalVariables {
    fn name(&self) -> &'static str {
        "iv"
    }

    fn estimate(&self, data: &IdentificationData) -> Result<Estimate> {
        // The lagged-output IV start is consistent but can be unstable on short or very
        // noisy records; least squares is biased but stable, and the iteration mends it.
        let first = match lagged_output_iv(data) {
            Ok(model) if model.spectral_radius() < 1.0 => model,
            _ => WeightedLeastSquares::default().estimate(data)?.model,
        };
        self.refine(data, first)
    }
}

/// The basic IV estimate with the output delayed once more as instrument:
/// Z rows [y(k−2)ᵀ u(k−1)ᵀ]. White sensor noise on y(k−2) is uncorrelated with the
/// equation error v(k) − Φ v(k−1), so this start is consistent without a model; the
/// simulated instruments then take the variance down.
pub fn lagged_output_iv(data: &IdentificationData) -> Result<DiscreteModel> {
    let rows: Vec<usize> = data
        .usable_rows()
        .into_iter()
        .filter(|&k| k >= 2 && data.outputs_known[k - 2])
        .collect();
    check_enough_rows(data, rows.len())?;
    let z = instrument_matrix(data, &rows, |k, j| data.outputs[(k - 2, j)]);
    Ok(solve(data, &rows, &z)?.0)
}

/// Z with rows [g(k, ·) u(k−1)ᵀ] for the given output instrument g.
fn instrument_matrix(
    data: &IdentificationData,
    rows: &[usize],
    g: impl Fn(usize, usize) -> f64,
) -> DMatrix<f64> {
    let (n, m) = (data.states(), data.input_count());
    DMatrix::from_fn(rows.len(), n + m, |r, j| {
        let k = rows[r];
        if j < n {
            g(k, j)
        } else {
            data.inputs[(k - 1, j - n)]
        }
    })
}

/// Solved IV system: the model, (ZsᵀFs)⁻¹, the scaled Z, F's column scale and the condition number.
type IvSolution = (DiscreteModel, DMatrix<f64>, DMatrix<f64>, Vec<f64>, f64);

/// θ_i = (ZᵀF)⁻¹ Zᵀ y_i for every output, with columns scaled to unit norm.
fn solve(data: &IdentificationData, rows: &[usize], z: &DMatrix<f64>) -> Result<IvSolution> {
    let (n, m) = (data.states(), data.input_count());
    let p = n + m;
    let (f, y) = regression(data, rows);
    let f_scale: Vec<f64> = (0..p)
        .map(|j| 1.0 / f.column(j).norm().max(1e-300))
        .collect();
    let fs = DMatrix::from_fn(f.nrows(), p, |r, j| f[(r, j)] * f_scale[j]);
    let z_scale: Vec<f64> = (0..p)
        .map(|j| 1.0 / z.column(j).norm().max(1e-300))
        .collect();
    let zs = DMatrix::from_fn(z.nrows(), p, |r, j| z[(r, j)] * z_scale[j]);
    let moment = zs.transpose() * &fs;
    let sv = moment.clone().singular_values();
    let (s_max, s_min) = (sv.max(), sv.min());
    if !(s_min > 1e-12 * s_max) {
        return Err(Error::Estimation(
            "instrumental variables: the instruments do not determine Θ (the inputs are not \
             persistently exciting)"
                .into(),
        ));
    }
    let inv = moment
        .try_inverse()
        .ok_or_else(|| Error::Estimation("singular IV moment matrix".into()))?;
    let mut theta = vec![0.0; n * p];
    for i in 0..n {
        let t = &inv * (zs.transpose() * y.column(i));
        for j in 0..p {
            theta[i * p + j] = t[j] * f_scale[j];
        }
    }
    let template = DiscreteModel {
        phi: DMatrix::zeros(n, n),
        gamma: DMatrix::zeros(n, m),
        ts_s: data.ts_s,
    };
    Ok((template.with_theta(&theta), inv, zs, f_scale, s_max / s_min))
}

impl InstrumentalVariables {
    /// Iterates from a given first model: instruments from its simulation, re-estimate,
    /// repeat. A step to an unstable model is halved until the model is stable.
    pub fn refine(&self, data: &IdentificationData, first: DiscreteModel) -> Result<Estimate> {
        let segments = data.segments();
        let rows: Vec<usize> = data.usable_rows();
        check_enough_rows(data, rows.len())?;
        let (n, m) = (data.states(), data.input_count());
        let p = n + m;
        if !(first.spectral_radius() < 1.0) {
            return Err(Error::Estimation(format!(
                "instrumental variables: the starting model is unstable (spectral radius {:.6}); \
                 the recording may be too short or not excite the machine",
                first.spectral_radius()
            )));
        }
        let mut model = first;
        let mut iterations = 0;
        let mut last = None;
        for _ in 0..self.max_iterations {
            iterations += 1;
            let sim = model.simulate_segments(data, &segments);
            let z = instrument_matrix(data, &rows, |k, j| sim[(k - 1, j)]);
            let solved = solve(data, &rows, &z)?;
            let old = DVector::from_vec(model.theta());
            let mut step = DVector::from_vec(solved.0.theta()) - &old;
            let mut next = model.with_theta((&old + &step).as_slice());
            let mut halvings = 0;
            while !(next.spectral_radius() < 1.0) && halvings < 30 {
                step *= 0.5;
                next = model.with_theta((&old + &step).as_slice());
                halvings += 1;
            }
            if !(next.spectral_radius() < 1.0) {
                break;
            }
            let change = step.norm() / old.norm().max(1e-300);
            model = next;
            last = Some(solved);
            if change < self.tolerance {
                break;
            }
        }
        let (_, inv, zs, f_scale, condition_number) = last.ok_or_else(|| {
            Error::Estimation("instrumental variables made no stable step".into())
        })?;
        // Covariance σ_i² (ZᵀF)⁻¹ ZᵀZ (ZᵀF)⁻ᵀ, in the scaled variables and scaled back.
        let d = DMatrix::from_diagonal(&DVector::from_column_slice(&f_scale));
        let core = &d * &inv * (zs.transpose() * &zs) * inv.transpose() * &d;
        let (f, y) = regression(data, &rows);
        let theta = model.theta();
        let mut covariance = DMatrix::zeros(n * p, n * p);
        let mut noise_variance = vec![0.0; n];
        for i in 0..n {
            let t = DVector::from_column_slice(&theta[i * p..(i + 1) * p]);
            let e = y.column(i) - &f * t;
            noise_variance[i] = e.norm_squared() / (rows.len() - p).max(1) as f64;
            covariance
                .view_mut((i * p, i * p), (p, p))
                .copy_from(&(&core * noise_variance[i]));
        }
        Ok(Estimate {
            model,
            method: self.name().into(),
            rows_used: rows.len(),
            condition_number,
            covariance: Some(covariance),
            noise_variance,
            iterations,
            output_offset: None,
        })
    }
}
