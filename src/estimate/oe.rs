//! Output error: Θ = [Φ Γ] and each segment's initial state x0 minimising the
//! simulation error J = ½ Σ_k e(k)ᵀ W e(k) of eqs. 3–4 with ŷ from eq. 8, by
//! Levenberg–Marquardt (the `levenberg-marquardt` crate), started from the iterated
//! IV estimate. The Jacobian comes from the forward sensitivities
//! ∂ŷ(k)/∂θ_ij = Φ ∂ŷ(k−1)/∂θ_ij + e_i φ_j(k−1), φ = [ŷᵀ uᵀ]ᵀ, and
//! ∂ŷ(k)/∂x0 = Φ^(k−start): exact, and one simulation's cost per parameter.
//! Sensor noise on y enters only the residual, not the regressors, so the estimate
//! is consistent where least squares is not.

use std::ops::Range;

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::{DMatrix, DVector, Dyn, Owned};

use super::iv::InstrumentalVariables;
use super::{check_enough_rows, DiscreteModel, Estimate, Estimator, IdentificationData};
use crate::error::{Error, Result};

/// Segments beyond this many keep their measured initial state instead of estimating it.
pub const MAX_ESTIMATED_INITIAL_STATES: usize = 50;

/// The output-error estimator.
#[derive(Debug, Clone, Default)]
pub struct OutputError {
    /// Per-output weights w_i; `None` uses 1/σ_i² of the starting model's simulation error.
    pub weights: Option<Vec<f64>>,
}

struct Problem<'a> {
    data: &'a IdentificationData,
    segments: Vec<Range<usize>>,
    estimate_x0: bool,
    sqrt_w: Vec<f64>,
    n: usize,
    m: usize,
    params: DVector<f64>,
}

impl Problem<'_> {
    fn p_theta(&self) -> usize {
        self.n * (self.n + self.m)
    }

    fn model(&self) -> DiscreteModel {
        let template = DiscreteModel {
            phi: DMatrix::zeros(self.n, self.n),
            gamma: DMatrix::zeros(self.n, self.m),
            ts_s: self.data.ts_s,
        };
        template.with_theta(&self.params.as_slice()[..self.p_theta()])
    }

    fn x0(&self, s: usize) -> DVector<f64> {
        if self.estimate_x0 {
            let at = self.p_theta() + s * self.n;
            DVector::from_column_slice(&self.params.as_slice()[at..at + self.n])
        } else {
            self.data.outputs.row(self.segments[s].start).transpose()
        }
    }

    fn rows(&self) -> usize {
        self.segments.iter().map(|s| s.len()).sum::<usize>() * self.n
    }

    /// Residuals and, when asked, the Jacobian, from one pass over the data. The
    /// sensitivities live in flat buffers: this runs once per LM step over every instant.
    fn evaluate(&self, with_jacobian: bool) -> (DVector<f64>, Option<DMatrix<f64>>) {
        let (n, m) = (self.n, self.m);
        let p = n + m;
        let pt = n * p;
        let model = self.model();
        let phi: Vec<f64> = (0..n * n).map(|q| model.phi[(q / n, q % n)]).collect();
        let gamma: Vec<f64> = (0..n * m).map(|q| model.gamma[(q / m, q % m)]).collect();
        let rows = self.rows();
        let cols = self.params.len();
        let mut r = DVector::zeros(rows);
        let mut jac = with_jacobian.then(|| DMatrix::zeros(rows, cols));
        let mut y = vec![0.0; n];
        let mut y_next = vec![0.0; n];
        // sens[q·n + c] = ∂ŷ_c/∂θ_q; sens_x0[q·n + c] = ∂ŷ_c/∂x0_q.
        let mut sens = vec![0.0; pt * n];
        let mut sens_next = vec![0.0; pt * n];
        let mut sens_x0 = vec![0.0; n * n];
        let mut sens_x0_next = vec![0.0; n * n];
        let mut row = 0;
        for (s, seg) in self.segments.iter().enumerate() {
            let x0 = self.x0(s);
            y.copy_from_slice(x0.as_slice());
            sens.iter_mut().for_each(|v| *v = 0.0);
            sens_x0.iter_mut().for_each(|v| *v = 0.0);
            for q in 0..n {
                sens_x0[q * n + q] = 1.0;
            }
            for k in seg.clone() {
                if k > seg.start {
                    let u = self.data.inputs.row(k - 1);
                    if with_jacobian {
                        for q in 0..pt {
                            let (i, j) = (q / p, q % p);
                            let regressor = if j < n { y[j] } else { u[j - n] };
                            for c in 0..n {
                                let mut acc = if c == i { regressor } else { 0.0 };
                                for l in 0..n {
                                    acc += phi[c * n + l] * sens[q * n + l];
                                }
                                sens_next[q * n + c] = acc;
                            }
                        }
                        std::mem::swap(&mut sens, &mut sens_next);
                        for q in 0..n {
                            for c in 0..n {
                                let mut acc = 0.0;
                                for l in 0..n {
                                    acc += phi[c * n + l] * sens_x0[q * n + l];
                                }
                                sens_x0_next[q * n + c] = acc;
                            }
                        }
                        std::mem::swap(&mut sens_x0, &mut sens_x0_next);
                    }
                    for c in 0..n {
                        let mut acc = 0.0;
                        for l in 0..n {
                            acc += phi[c * n + l] * y[l];
                        }
                        for l in 0..m {
                            acc += gamma[c * m + l] * u[l];
                        }
                        y_next[c] = acc;
                    }
                    std::mem::swap(&mut y, &mut y_next);
                }
                for c in 0..n {
                    r[row + c] = self.sqrt_w[c] * (self.data.outputs[(k, c)] - y[c]);
                }
                if let Some(jac) = jac.as_mut() {
                    let data = jac.as_mut_slice();
                    for q in 0..pt {
                        for c in 0..n {
                            data[q * rows + row + c] = -self.sqrt_w[c] * sens[q * n + c];
                        }
                    }
                    if self.estimate_x0 {
                        let at = pt + s * n;
                        for q in 0..n {
                            for c in 0..n {
                                data[(at + q) * rows + row + c] = -self.sqrt_w[c] * sens_x0[q * n + c];
                            }
                        }
                    }
                }
                row += n;
            }
        }
        (r, jac)
    }
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for Problem<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        self.params.copy_from(x);
    }

    fn params(&self) -> DVector<f64> {
        self.params.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        let (r, _) = self.evaluate(false);
        r.iter().all(|v| v.is_finite()).then_some(r)
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let (_, j) = self.evaluate(true);
        j.filter(|j| j.iter().all(|v| v.is_finite()))
    }
}

impl Estimator for OutputError {
    fn name(&self) -> &'static str {
        "oe"
    }

    fn estimate(&self, data: &IdentificationData) -> Result<Estimate> {
        // A rough IV start is enough: LM takes it the rest of the way.
        let start = InstrumentalVariables { max_iterations: 10, tolerance: 1e-6 }.estimate(data)?;
        self.refine(data, &start.model)
    }
}

impl OutputError {
    /// Minimises the simulation error starting from `start`.
    pub fn refine(&self, data: &IdentificationData, start: &DiscreteModel) -> Result<Estimate> {
        let segments = data.segments();
        let rows_used = data.usable_rows().len();
        check_enough_rows(data, rows_used)?;
        let (n, m) = (data.states(), data.input_count());
        let estimate_x0 = segments.len() <= MAX_ESTIMATED_INITIAL_STATES;
        // Weights: the user's, or the inverse variance of the start model's simulation error.
        let sim = start.simulate_segments(data, &segments);
        let variance: Vec<f64> = (0..n)
            .map(|c| {
                let (sum, count) = segments.iter().flat_map(|s| s.clone()).fold((0.0, 0usize), |(a, k), i| {
                    let e = data.outputs[(i, c)] - sim[(i, c)];
                    (a + e * e, k + 1)
                });
                (sum / count.max(1) as f64).max(1e-24)
            })
            .collect();
        let w: Vec<f64> = match &self.weights {
            Some(w) => w.clone(),
            None => {
                let inv: Vec<f64> = variance.iter().map(|v| 1.0 / v).collect();
                let mean = inv.iter().sum::<f64>() / n as f64;
                inv.iter().map(|v| v / mean).collect()
            }
        };
        let mut params: Vec<f64> = start.theta();
        if estimate_x0 {
            for seg in &segments {
                params.extend(data.outputs.row(seg.start).iter());
            }
        }
        let sqrt_w: Vec<f64> = w.iter().map(|v| v.max(0.0).sqrt()).collect();
        let mut problem = Problem {
            data,
            segments: segments.clone(),
            estimate_x0,
            sqrt_w,
            n,
            m,
            params: DVector::from_vec(params),
        };
        // Tolerances far below the statistical uncertainty of Θ (~1e-3 relative), and far
        // above rounding: the last evaluations of the default 30·ε would buy nothing.
        let lm = LevenbergMarquardt::new().with_patience(200).with_ftol(1e-10).with_xtol(1e-10).with_gtol(1e-10);
        let mut evaluations = 0;
        // Two passes when no weights are given: the second with 1/σ_i² of the first
        // pass's residuals, which are then the sensor noise rather than the start's misfit.
        for pass in 0..2 {
            let (solved, report) = lm.minimize(problem);
            problem = solved;
            evaluations += report.number_of_evaluations;
            if !report.objective_function.is_finite() {
                return Err(Error::Estimation(format!(
                    "output error: the minimisation failed ({:?}); the start model may be unstable",
                    report.termination
                )));
            }
            if pass == 1 || self.weights.is_some() {
                break;
            }
            let (r, _) = problem.evaluate(false);
            let per = r.len() / n;
            let inv: Vec<f64> = (0..n)
                .map(|c| {
                    let sum: f64 = (0..per).map(|i| (r[i * n + c] / problem.sqrt_w[c]).powi(2)).sum();
                    1.0 / (sum / per.max(1) as f64).max(1e-30)
                })
                .collect();
            let mean = inv.iter().sum::<f64>() / n as f64;
            let next: Vec<f64> = inv.iter().map(|v| (v / mean).sqrt()).collect();
            let change = next.iter().zip(&problem.sqrt_w).map(|(a, b)| (a / b - 1.0).abs()).fold(0.0, f64::max);
            problem.sqrt_w = next;
            if change < 0.05 {
                break;
            }
        }
        let w: Vec<f64> = problem.sqrt_w.iter().map(|v| v * v).collect();
        let model = problem.model();
        let (r, jac) = problem.evaluate(true);
        let jac = jac.ok_or_else(|| Error::Estimation("output error: no Jacobian".into()))?;
        let dof = (r.len().saturating_sub(problem.params.len())).max(1) as f64;
        let sigma2 = r.norm_squared() / dof;
        // Covariance σ² (JᵀJ)⁻¹ from the SVD of the column-scaled Jacobian; Θ's block of it.
        let scale: Vec<f64> = (0..jac.ncols()).map(|j| 1.0 / jac.column(j).norm().max(1e-300)).collect();
        let js = DMatrix::from_fn(jac.nrows(), jac.ncols(), |i, j| jac[(i, j)] * scale[j]);
        let svd = js.svd(false, true);
        let (s_max, s_min) = (svd.singular_values.max(), svd.singular_values.min());
        let v_t = svd.v_t.ok_or_else(|| Error::Estimation("output error: no SVD".into()))?;
        let d = DMatrix::from_diagonal(&DVector::from_column_slice(&scale));
        let sinv2 = DMatrix::from_diagonal(&svd.singular_values.map(|s| if s > 1e-14 * s_max { 1.0 / (s * s) } else { 0.0 }));
        let full = &d * v_t.transpose() * sinv2 * &v_t * &d * sigma2;
        let p_theta = n * (n + m);
        let covariance = full.view((0, 0), (p_theta, p_theta)).into_owned();
        let noise_variance: Vec<f64> = (0..n)
            .map(|c| {
                let (sum, count) = (0..r.len() / n).fold((0.0, 0usize), |(a, k), i| (a + r[i * n + c].powi(2), k + 1));
                sum / count.max(1) as f64 / w[c].max(1e-300)
            })
            .collect();
        Ok(Estimate {
            model,
            method: self.name().into(),
            rows_used,
            condition_number: s_max / s_min,
            covariance: Some(covariance),
            noise_variance,
            iterations: evaluations,
            output_offset: None,
        })
    }
}
