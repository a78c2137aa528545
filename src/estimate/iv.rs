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
use super::{check_enough_rows, DiscreteModel, Estimate, Estimator, IdentificationData};
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
    Ok(solve(data, &rows, |k, j| data.outputs[(k - 2, j)])?.0)
}

/// Solved IV system: the model, (ZᵀF)⁻¹, ZᵀZ and the condition number of the scaled moment.
type IvSolution = (DiscreteModel, DMatrix<f64>, DMatrix<f64>, f64);

/// θ_i = (ZᵀF)⁻¹ Zᵀ y_i for every output, with Z rows [g(k, ·) u(k−1)ᵀ]. The moments
/// are accumulated row by row (O(p²) memory whatever the length) and the p×p system
/// is solved with both sides scaled to unit column norms.
fn solve(
    data: &IdentificationData,
    rows: &[usize],
    g: impl Fn(usize, usize) -> f64,
) -> Result<IvSolution> {
    let (n, m) = (data.states(), data.input_count());
    let p = n + m;
    let f_of = |k: usize, j: usize| {
        if j < n {
            data.outputs[(k - 1, j)]
        } else {
            data.inputs[(k - 1, j - n)]
        }
    };
    let z_of = |k: usize, j: usize| {
        if j < n {
            g(k, j)
        } else {
            data.inputs[(k - 1, j - n)]
        }
    };
    let mut zf = DMatrix::<f64>::zeros(p, p);
    let mut zz = DMatrix::<f64>::zeros(p, p);
    let mut zy = DMatrix::<f64>::zeros(p, n);
    let mut ff = vec![0.0; p];
    let (mut f, mut z) = (vec![0.0; p], vec![0.0; p]);
    for &k in rows {
        for j in 0..p {
            f[j] = f_of(k, j);
            z[j] = z_of(k, j);
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
    let f_scale: Vec<f64> = ff.iter().map(|v| 1.0 / v.sqrt().max(1e-300)).collect();
    let z_scale: Vec<f64> = (0..p)
        .map(|j| 1.0 / zz[(j, j)].sqrt().max(1e-300))
        .collect();
    let moment = DMatrix::from_fn(p, p, |a, b| zf[(a, b)] * z_scale[a] * f_scale[b]);
    let sv = moment.clone().singular_values();
    let (s_max, s_min) = (sv.max(), sv.min());
    if !(s_min > 1e-12 * s_max) {
        return Err(Error::Estimation(
            "instrumental variables: the instruments do not determine Θ (the inputs are not \
             persistently exciting)"
                .into(),
        ));
    }
    let inv_scaled = moment
        .try_inverse()
        .ok_or_else(|| Error::Estimation("singular IV moment matrix".into()))?;
    // (ZᵀF)⁻¹ = D_f (E ZᵀF D_f)⁻¹ E.
    let inv = DMatrix::from_fn(p, p, |a, b| f_scale[a] * inv_scaled[(a, b)] * z_scale[b]);
    let mut theta = vec![0.0; n * p];
    for i in 0..n {
        let t = &inv * zy.column(i);
        theta[i * p..(i + 1) * p].copy_from_slice(t.as_slice());
    }
    let template = DiscreteModel {
        phi: DMatrix::zeros(n, n),
        gamma: DMatrix::zeros(n, m),
        ts_s: data.ts_s,
    };
    Ok((template.with_theta(&theta), inv, zz, s_max / s_min))
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
            let solved = solve(data, &rows, |k, j| sim[(k - 1, j)])?;
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
        let (_, inv, zz, condition_number) = last.ok_or_else(|| {
            Error::Estimation("instrumental variables made no stable step".into())
        })?;
        // Covariance σ_i² (ZᵀF)⁻¹ ZᵀZ (ZᵀF)⁻ᵀ, with σ_i² of the equation error.
        let core = &inv * zz * inv.transpose();
        let theta = model.theta();
        let mut sse = vec![0.0; n];
        for &k in &rows {
            for (i, acc) in sse.iter_mut().enumerate() {
                let mut e = data.outputs[(k, i)];
                for j in 0..p {
                    let f = if j < n {
                        data.outputs[(k - 1, j)]
                    } else {
                        data.inputs[(k - 1, j - n)]
                    };
                    e -= theta[i * p + j] * f;
                }
                *acc += e * e;
            }
        }
        let mut covariance = DMatrix::zeros(n * p, n * p);
        let mut noise_variance = vec![0.0; n];
        for i in 0..n {
            noise_variance[i] = sse[i] / (rows.len() - p).max(1) as f64;
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
