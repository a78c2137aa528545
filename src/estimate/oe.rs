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
    cache: std::cell::RefCell<Option<(DVector<f64>, Evaluation)>>,
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

    /// One pass over the data: the weighted squared error per output and, when asked,
    /// the normal equations JᵀJ and Jᵀr of the weighted residuals. The Jacobian itself is
    /// never stored (a week at 1 s would be 1.8 million rows); the sensitivities live in
    /// flat buffers.
    fn evaluate(&self, with_jacobian: bool) -> Evaluation {
        let (n, m) = (self.n, self.m);
        let p = n + m;
        let pt = n * p;
        let model = self.model();
        let phi: Vec<f64> = (0..n * n).map(|q| model.phi[(q / n, q % n)]).collect();
        let gamma: Vec<f64> = (0..n * m).map(|q| model.gamma[(q / m, q % m)]).collect();
        let cols = self.params.len();
        let mut sse = vec![0.0; n];
        let mut gram = with_jacobian.then(|| DMatrix::<f64>::zeros(cols, cols));
        let mut grad = with_jacobian.then(|| DVector::<f64>::zeros(cols));
        let mut row_j = vec![0.0; cols];
        let mut nonzero: Vec<usize> = Vec::with_capacity(pt + n);
        let mut y = vec![0.0; n];
        let mut y_next = vec![0.0; n];
        // sens[q·n + c] = ∂ŷ_c/∂θ_q; sens_x0[q·n + c] = ∂ŷ_c/∂x0_q.
        let mut sens = vec![0.0; pt * n];
        let mut sens_next = vec![0.0; pt * n];
        let mut sens_x0 = vec![0.0; n * n];
        let mut sens_x0_next = vec![0.0; n * n];
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
                    let r = self.sqrt_w[c] * (self.data.outputs[(k, c)] - y[c]);
                    sse[c] += r * r;
                    if let (Some(gram), Some(grad)) = (gram.as_mut(), grad.as_mut()) {
                        // This row of J: −√w_c ∂ŷ_c/∂(θ, this segment's x0); zero elsewhere.
                        nonzero.clear();
                        for q in 0..pt {
                            row_j[q] = -self.sqrt_w[c] * sens[q * n + c];
                            nonzero.push(q);
                        }
                        if self.estimate_x0 {
                            let at = pt + s * n;
                            for q in 0..n {
                                row_j[at + q] = -self.sqrt_w[c] * sens_x0[q * n + c];
                                nonzero.push(at + q);
                            }
                        }
                        for (a, &qa) in nonzero.iter().enumerate() {
                            grad[qa] += row_j[qa] * r;
                            for &qb in &nonzero[a..] {
                                gram[(qa, qb)] += row_j[qa] * row_j[qb];
                            }
                        }
                    }
                }
            }
        }
        if let Some(g) = gram.as_mut() {
            for a in 0..cols {
                for b in 0..a {
                    g[(a, b)] = g[(b, a)];
                }
            }
        }
        Evaluation { sse, gram, grad }
    }

    /// The evaluation at the current parameters, computed once per parameter vector.
    fn evaluated(&self) -> std::cell::Ref<'_, Evaluation> {
        let stale = self
            .cache
            .borrow()
            .as_ref()
            .is_none_or(|(at, _)| at != &self.params);
        if stale {
            let e = self.evaluate(true);
            *self.cache.borrow_mut() = Some((self.params.clone(), e));
        }
        std::cell::Ref::map(self.cache.borrow(), |c| &c.as_ref().expect("just filled").1)
    }
}

/// The result of one pass over the data.
#[derive(Debug, Clone)]
struct Evaluation {
    /// Σ_k (√w_c (y_c − ŷ_c))² per output.
    sse: Vec<f64>,
    /// JᵀJ of the weighted residuals.
    gram: Option<DMatrix<f64>>,
    /// Jᵀr of the weighted residuals.
    grad: Option<DVector<f64>>,
}

impl Evaluation {
    /// The least-squares problem in square-root form: R with RᵀR = JᵀJ, and the reduced
    /// residual [R⁻ᵀJᵀr; √(‖r‖² − ‖R⁻ᵀJᵀr‖²)], whose norm is ‖r‖. Levenberg–Marquardt
    /// sees the same JᵀJ, Jᵀr and objective as with the full Jacobian, at p + 1 rows.
    fn square_root_form(&self) -> Option<(DVector<f64>, DMatrix<f64>)> {
        let gram = self.gram.as_ref()?;
        let grad = self.grad.as_ref()?;
        let p = gram.nrows();
        // Symmetric scaling keeps the factorisation accurate; a whisper of ridge keeps it
        // defined where a parameter is not seen (a segment too short for its x0).
        let d: Vec<f64> = (0..p)
            .map(|i| 1.0 / gram[(i, i)].max(1e-300).sqrt())
            .collect();
        let scaled = DMatrix::from_fn(p, p, |i, j| {
            gram[(i, j)] * d[i] * d[j] + if i == j { 1e-13 } else { 0.0 }
        });
        let chol = scaled.cholesky()?;
        // R = L_sᵀ D⁻¹ (JᵀJ = D⁻¹ L_s L_sᵀ D⁻¹).
        let l = chol.l();
        let r_mat = DMatrix::from_fn(p, p, |i, j| l[(j, i)] / d[j]);
        let z = r_mat.transpose().solve_lower_triangular(grad)?;
        let total: f64 = self.sse.iter().sum();
        let rest = (total - z.norm_squared()).max(0.0).sqrt();
        let mut residual = DVector::zeros(p + 1);
        residual.rows_mut(0, p).copy_from(&z);
        residual[p] = rest;
        let mut jacobian = DMatrix::zeros(p + 1, p);
        jacobian.view_mut((0, 0), (p, p)).copy_from(&r_mat);
        Some((residual, jacobian))
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
        let (r, _) = self.evaluated().square_root_form()?;
        r.iter().all(|v| v.is_finite()).then_some(r)
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let (_, j) = self.evaluated().square_root_form()?;
        j.iter().all(|v| v.is_finite()).then_some(j)
    }
}

impl Estimator for OutputError {
    fn name(&self) -> &'static str {
        "oe"
    }

    fn estimate(&self, data: &IdentificationData) -> Result<Estimate> {
        // A rough IV start is enough: LM takes it the rest of the way.
        let start = InstrumentalVariables {
            max_iterations: 10,
            tolerance: 1e-6,
        }
        .estimate(data)?;
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
                let (sum, count) =
                    segments
                        .iter()
                        .flat_map(|s| s.clone())
                        .fold((0.0, 0usize), |(a, k), i| {
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
            cache: std::cell::RefCell::new(None),
        };
        // Tolerances far below the statistical uncertainty of Θ (~1e-3 relative), and far
        // above rounding: the last evaluations of the default 30·ε would buy nothing.
        let lm = LevenbergMarquardt::new()
            .with_patience(200)
            .with_ftol(1e-10)
            .with_xtol(1e-10)
            .with_gtol(1e-10);
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
            let sse = problem.evaluate(false).sse;
            let per = problem.rows() / n;
            let inv: Vec<f64> = (0..n)
                .map(|c| 1.0 / (sse[c] / problem.sqrt_w[c].powi(2) / per.max(1) as f64).max(1e-30))
                .collect();
            let mean = inv.iter().sum::<f64>() / n as f64;
            let next: Vec<f64> = inv.iter().map(|v| (v / mean).sqrt()).collect();
            let change = next
                .iter()
                .zip(&problem.sqrt_w)
                .map(|(a, b)| (a / b - 1.0).abs())
                .fold(0.0, f64::max);
            problem.sqrt_w = next;
            if change < 0.05 {
                break;
            }
        }
        let w: Vec<f64> = problem.sqrt_w.iter().map(|v| v * v).collect();
        let model = problem.model();
        let evaluation = problem.evaluate(true);
        let rows = problem.rows();
        let dof = rows.saturating_sub(problem.params.len()).max(1) as f64;
        let sigma2 = evaluation.sse.iter().sum::<f64>() / dof;
        // Covariance σ² (JᵀJ)⁻¹ from the eigen-decomposition of the scaled JᵀJ; Θ's block.
        let gram = evaluation
            .gram
            .as_ref()
            .ok_or_else(|| Error::Estimation("output error: no normal equations".into()))?;
        let p_all = gram.nrows();
        let scale: Vec<f64> = (0..p_all)
            .map(|i| 1.0 / gram[(i, i)].max(1e-300).sqrt())
            .collect();
        let scaled = DMatrix::from_fn(p_all, p_all, |i, j| gram[(i, j)] * scale[i] * scale[j]);
        let eig = scaled.symmetric_eigen();
        let (e_max, e_min) = (eig.eigenvalues.max(), eig.eigenvalues.min().max(0.0));
        let inv = DMatrix::from_diagonal(&eig.eigenvalues.map(|e| {
            if e > 1e-14 * e_max {
                1.0 / e
            } else {
                0.0
            }
        }));
        let d = DMatrix::from_diagonal(&DVector::from_column_slice(&scale));
        let full = &d * &eig.eigenvectors * inv * eig.eigenvectors.transpose() * &d * sigma2;
        let p_theta = n * (n + m);
        let covariance = full.view((0, 0), (p_theta, p_theta)).into_owned();
        let per = rows / n;
        let noise_variance: Vec<f64> = (0..n)
            .map(|c| evaluation.sse[c] / per.max(1) as f64 / w[c].max(1e-300))
            .collect();
        let condition_number = (e_max / e_min.max(1e-300)).sqrt();
        Ok(Estimate {
            model,
            method: self.name().into(),
            rows_used,
            condition_number,
            covariance: Some(covariance),
            noise_variance,
            iterations: evaluations,
            output_offset: None,
        })
    }
}
