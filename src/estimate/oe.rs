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

    /// Residuals and, when asked, the Jacobian, from one pass over the data.
    fn evaluate(&self, with_jacobian: bool) -> (DVector<f64>, Option<DMatrix<f64>>) {
        let (n, m) = (self.n, self.m);
        let p = n + m;
        let model = self.model();
        let cols = self.params.len();
        let mut r = DVector::zeros(self.rows());
        let mut jac = with_jacobian.then(|| DMatrix::zeros(self.rows(), cols));
        let mut row = 0;
        for (s, seg) in self.segments.iter().enumerate() {
            let mut y = self.x0(s);
            // Sensitivities of ŷ to each θ (n·p of them) and to this segment's x0 (n).
            let mut sens_theta = vec![DVector::<f64>::zeros(n); n * p];
            let mut sens_x0 = DMatrix::<f64>::identity(n, n);
            for k in seg.clone() {
                if k > seg.start {
                    let u = self.data.inputs.row(k - 1).transpose();
                    if with_jacobian {
                        for i in 0..n {
                            for j in 0..p {
                                let phi_j = if j < n { y[j] } else { u[j - n] };
                                let s_prev = &sens_theta[i * p + j];
                                let mut next = &model.phi * s_prev;
                                next[i] += phi_j;
                                sens_theta[i * p + j] = next;
                            }
                        }
                        sens_x0 = &model.phi * &sens_x0;
                    }
                    y = &model.phi * &y + &model.gamma * &u;
                }
                for c in 0..n {
                    r[row + c] = self.sqrt_w[c] * (self.data.outputs[(k, c)] - y[c]);
                }
                if let Some(jac) = jac.as_mut() {
                    for (q, sens) in sens_theta.iter().enumerate() {
                        for c in 0..n {
                            jac[(row + c, q)] = -self.sqrt_w[c] * sens[c];
                        }
                    }
                    if self.estimate_x0 {
                        let at = self.p_theta() + s * n;
                        for c in 0..n {
                            for q in 0..n {
                                jac[(row + c, at + q)] = -self.sqrt_w[c] * sens_x0[(c, q)];
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
        let start = InstrumentalVariables::default().estimate(data)?;
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
        let problem = Problem {
            data,
            segments: segments.clone(),
            estimate_x0,
            sqrt_w: w.iter().map(|v| v.max(0.0).sqrt()).collect(),
            n,
            m,
            params: DVector::from_vec(params),
        };
        let (problem, report) = LevenbergMarquardt::new().with_patience(200).minimize(problem);
        if !report.objective_function.is_finite() {
            return Err(Error::Estimation(format!(
                "output error: the minimisation failed ({:?}); the start model may be unstable",
                report.termination
            )));
        }
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
            iterations: report.number_of_evaluations,
            output_offset: None,
        })
    }
}
