//! Instrumental variables, iterated (the paper's "IV check", made consistent).
//!
//! Least squares regresses y(k) on the measured y(k−1), whose sensor noise is
//! correlated with the equation error, so it is biased. Replacing y(k−1) in the
//! instruments by the noise-free output ŷ(k−1) of a simulated model gives
//! θ_i = (Zᵀ F)⁻¹ Zᵀ y_i with Z rows [ŷ(k−1)ᵀ u(k−1)ᵀ] and F rows [y(k−1)ᵀ u(k−1)ᵀ];
//! ŷ comes from the previous estimate, starting from least squares, repeated until
//! Θ stops changing.

use crate::estimate::Method;
use nalgebra::{DMatrix, DVector};

use super::wls::{full_rank, WeightedLeastSquares};
use super::{
    block_diagonal_covariance, check_enough_rows, equation_error_sse, DiscreteModel, Estimate,
    EstimationError, Estimator, IdentificationData, Result,
};

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
    fn method(&self) -> Method {
        Method::Iv
    }

    fn estimate(&self, data: &IdentificationData) -> Result<Estimate> {
        // The lagged-output IV start is consistent but can be unstable on short or very
        // noisy records; least squares is biased but stable, and the iteration mends it.
        let first = match lagged_output_iv(data) {
            Ok(model) if model.is_stable() => model,
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
    Ok(solve(data, &rows, |k, j| data.outputs[(k - 2, j)])?.model)
}

/// A solved IV system.
struct IvSolution {
    /// The model.
    model: DiscreteModel,
    /// (ZᵀF)⁻¹.
    inverse_moment: DMatrix<f64>,
    /// ZᵀZ.
    instrument_gram: DMatrix<f64>,
    /// Condition number of the scaled moment ZᵀF.
    condition_number: f64,
}

/// The moments ZᵀF, ZᵀZ (p × p) and ZᵀY (p × n) accumulated row by row, O(p²) memory
/// whatever the length; Z rows [g(k, ·) u(k−1)ᵀ], F rows φ(k)ᵀ.
fn moments(
    data: &IdentificationData,
    rows: &[usize],
    g: impl Fn(usize, usize) -> f64,
) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>, Vec<f64>) {
    let (n, p) = (data.states(), data.states() + data.input_count());
    let mut zf = DMatrix::<f64>::zeros(p, p);
    let mut zz = DMatrix::<f64>::zeros(p, p);
    let mut zy = DMatrix::<f64>::zeros(p, n);
    let mut ff = vec![0.0; p];
    let (mut f, mut z) = (vec![0.0; p], vec![0.0; p]);
    for &k in rows {
        data.regressor_row(k, &mut f);
        for j in 0..p {
            z[j] = if j < n { g(k, j) } else { f[j] };
            ff[j] += f[j] * f[j];
        }
        for a in 0..p {
            for b in 0..p {
                zf[(a, b)] += z[a] * f[b];
                zz[(a, b)] += z[a] * z[b];
            }
            for i in 0..n {
                zy[(a, i)] += z[a] * data.outputs[(k, i)];
            }
        }
    }
    (zf, zz, zy, ff)
}

/// θ_i = (ZᵀF)⁻¹ Zᵀ y_i for every output, with Z rows [g(k, ·) u(k−1)ᵀ]; the p×p
/// system is solved with both sides scaled to unit column norms.
fn solve(
    data: &IdentificationData,
    rows: &[usize],
    g: impl Fn(usize, usize) -> f64,
) -> Result<IvSolution> {
    let (n, m) = (data.states(), data.input_count());
    let p = n + m;
    let (zf, zz, zy, ff) = moments(data, rows, g);
    let f_scale: Vec<f64> = ff.iter().map(|v| 1.0 / v.sqrt().max(1e-300)).collect();
    let z_scale: Vec<f64> = (0..p)
        .map(|j| 1.0 / zz[(j, j)].sqrt().max(1e-300))
        .collect();
    let moment = DMatrix::from_fn(p, p, |a, b| zf[(a, b)] * z_scale[a] * f_scale[b]);
    let sv = moment.clone().singular_values();
    let (s_max, s_min) = (sv.max(), sv.min());
    let no_excitation = || EstimationError::NoExcitation {
        method: "instrumental variables",
        singular_value_ratio: s_min / s_max,
    };
    if !full_rank(s_min, s_max, 1e-12) {
        return Err(no_excitation());
    }
    let inv_scaled = moment.try_inverse().ok_or_else(no_excitation)?;
    // (ZᵀF)⁻¹ = D_f (E ZᵀF D_f)⁻¹ E.
    let inverse_moment =
        DMatrix::from_fn(p, p, |a, b| f_scale[a] * inv_scaled[(a, b)] * z_scale[b]);
    let mut theta = vec![0.0; n * p];
    for i in 0..n {
        let t = &inverse_moment * zy.column(i);
        theta[i * p..(i + 1) * p].copy_from_slice(t.as_slice());
    }
    Ok(IvSolution {
        model: DiscreteModel::from_theta(n, m, data.ts_s, &theta),
        inverse_moment,
        instrument_gram: zz,
        condition_number: s_max / s_min,
    })
}

/// The step from `model` towards `target`, halved until the model it leads to is
/// stable (at most 30 times); `None` if none is. Returns the model and ‖step‖/‖Θ‖.
fn stable_step(model: &DiscreteModel, target: &DiscreteModel) -> Option<(DiscreteModel, f64)> {
    let old = DVector::from_vec(model.theta());
    let mut step = DVector::from_vec(target.theta()) - &old;
    let mut next = model.with_theta((&old + &step).as_slice());
    let mut halvings = 0;
    while !next.is_stable() && halvings < 30 {
        step *= 0.5;
        next = model.with_theta((&old + &step).as_slice());
        halvings += 1;
    }
    let change = step.norm() / old.norm().max(1e-300);
    next.is_stable().then_some((next, change))
}

impl InstrumentalVariables {
    /// Iterates from a given first model: instruments from its simulation, re-estimate,
    /// repeat. A step to an unstable model is halved until the model is stable.
    pub fn refine(&self, data: &IdentificationData, first: DiscreteModel) -> Result<Estimate> {
        let segments = data.segments();
        let rows: Vec<usize> = data.usable_rows();
        check_enough_rows(data, rows.len())?;
        let p = data.states() + data.input_count();
        if !first.is_stable() {
            return Err(EstimationError::UnstableStart {
                method: "instrumental variables",
                spectral_radius: first.spectral_radius(),
            });
        }
        let mut model = first;
        let mut iterations = 0;
        let mut last: Option<IvSolution> = None;
        let mut unstable_radius = f64::NAN;
        for _ in 0..self.max_iterations {
            iterations += 1;
            let sim = model.simulate_segments(data, &segments);
            let solved = solve(data, &rows, |k, j| sim[(k - 1, j)])?;
            let Some((next, change)) = stable_step(&model, &solved.model) else {
                unstable_radius = solved.model.spectral_radius();
                break;
            };
            model = next;
            last = Some(solved);
            if change < self.tolerance {
                break;
            }
        }
        let last = last.ok_or(EstimationError::NoStableStep {
            spectral_radius: unstable_radius,
        })?;
        // Covariance σ_i² (ZᵀF)⁻¹ ZᵀZ (ZᵀF)⁻ᵀ, with σ_i² of the equation error.
        let core = &last.inverse_moment * last.instrument_gram * last.inverse_moment.transpose();
        let sse = equation_error_sse(data, &rows, &model.theta());
        let noise_variance: Vec<f64> = sse
            .iter()
            .map(|s| s / (rows.len() - p).max(1) as f64)
            .collect();
        Ok(Estimate {
            model,
            method: self.method(),
            rows_used: rows.len(),
            condition_number: last.condition_number,
            covariance: Some(block_diagonal_covariance(&[&core], &noise_variance)),
            robust_covariance: None,
            noise_variance,
            iterations,
            output_offset: None,
            trajectory: None,
            network: None,
            predictor: None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate::testing::{exact_data, theta_error, two_state_model, with_noise};

    #[test]
    fn noise_free_data_give_the_true_matrices() {
        let truth = two_state_model();
        let data = exact_data(&truth, 1500, 1);
        let first = lagged_output_iv(&data).unwrap();
        assert!(theta_error(&first, &truth) < 1e-9, "{first:?}");
        let e = InstrumentalVariables::default().estimate(&data).unwrap();
        assert!(theta_error(&e.model, &truth) < 1e-9, "{:?}", e.model);
        assert_eq!(e.method, Method::Iv);
        assert_eq!(e.rows_used, 1499);
    }

    #[test]
    fn the_regressors_as_instruments_give_least_squares() {
        // Z = F: θ_i = (FᵀF)⁻¹ Fᵀ y_i, the least-squares estimate, noise and all.
        let truth = two_state_model();
        let mut data = exact_data(&truth, 1500, 2);
        data.outputs = with_noise(&data.outputs, 0.01, 3);
        let rows = data.usable_rows();
        let iv = solve(&data, &rows, |k, j| data.outputs[(k - 1, j)]).unwrap();
        let ls = WeightedLeastSquares::default().estimate(&data).unwrap();
        // Equal to rounding: the moments square F's condition number, which QR does not.
        assert!(theta_error(&iv.model, &ls.model) < 1e-8);
        assert!(theta_error(&ls.model, &truth) > 1e-3, "the noise biases it");
    }

    #[test]
    fn output_noise_biases_least_squares_but_not_iv() {
        let truth = two_state_model();
        let mut data = exact_data(&truth, 20000, 4);
        data.outputs = with_noise(&data.outputs, 0.1, 5);
        let ls = WeightedLeastSquares::default().estimate(&data).unwrap();
        let iv = InstrumentalVariables::default().estimate(&data).unwrap();
        let (ls_err, iv_err) = (
            theta_error(&ls.model, &truth),
            theta_error(&iv.model, &truth),
        );
        assert!(ls_err > 0.3, "least squares: {ls_err}, iv {iv_err}");
        assert!(iv_err < 0.03, "least squares: {ls_err}, iv {iv_err}");
    }

    #[test]
    fn constant_inputs_do_not_determine_theta() {
        let truth = two_state_model();
        let mut data = exact_data(&truth, 500, 6);
        data.inputs.fill(1.0);
        match InstrumentalVariables::default().estimate(&data) {
            Err(EstimationError::NoExcitation {
                singular_value_ratio,
                ..
            }) => assert!(singular_value_ratio < 1e-10),
            other => panic!("{other:?}"),
        }
    }
}
