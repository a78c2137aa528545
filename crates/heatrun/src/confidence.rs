//! The identification's uncertainty carried into the uses of the model: the tools
//! `rating`, `predict` and `monitor` share to give their figures an interval.
//!
//! Three sources, as the report carries them ([`ModelUncertainty`]):
//! - the parameters: C_Θ, the covariance of Θ = [Φ Γ] row by row (of θ_h = [Φ Γ; C D]
//!   for a model with hidden states, y = C x + D u: `hidden::covariance`), propagated by
//!   linearisation (the delta method), var g ≈ ∇gᵀ C_Θ ∇g, with ∇g by central differences
//!   of the whole map Θ ↦ g ([`linearise`]) where the map is nonlinear (losses at the
//!   predicted temperatures, a bisection, a time to a limit), or by the exact forward
//!   sensitivities of the recursion x(k+1) = Φ x(k) + Γ u(k) where the inputs are
//!   measured ([`OpenLoopVariance`]);
//! - the initial state, read from sensors with noise σ_j: P(0) = diag(σ_j²) (C⁺ diag(σ_j²)
//!   C⁺ᵀ for a start x(0) = C⁺ (y − D u) of a model with hidden states);
//! - the process noise of a model with a one-step predictor (`pem`): P(k+1) = Φ P(k) Φᵀ
//!   + K Λ Kᵀ.
//!
//! Linearisation rather than parameter draws: the map is smooth in Θ at the scale of its
//! standard errors (relative errors of 10⁻⁴ to 10⁻³ on a heat run), so the first-order
//! term is the distribution to well within the Monte-Carlo error draws would add, it is
//! deterministic, and it costs 2·n(n+m) runs of the map (36 for three states and three
//! losses) where draws need hundreds for a stable 95 % quantile. Where a figure is the
//! minimum of smooth ones (the continuous rating is the least of each part's own
//! limit), the minimum's distribution is taken from seeded draws of the linearised
//! Gaussian ([`gaussian_draws`]), which costs no runs of the map.

use nalgebra::{DMatrix, DVector};
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

use crate::model_file::{ModelUncertainty, ThermalModel, UseError};

pub use crate::thermal::Z95;

/// Θ of `model`, laid out as its covariance (`ModelUncertainty::theta_covariance`): the
/// rows of [Φ Γ] (the report's `theta_covariance`), and for a model with hidden states
/// then the rows of [C D] (θ_h = [Φ Γ; C D] row by row, its `hidden.parameter_covariance`).
pub fn theta_of(model: &ThermalModel) -> Vec<f64> {
    let (n, m) = (model.phi.nrows(), model.gamma.ncols());
    let rows = n + model.output.as_ref().map_or(0, |o| o.c.nrows());
    (0..rows)
        .flat_map(|i| (0..n + m).map(move |j| (i, j)))
        .map(|(i, j)| match (i < n, j < n) {
            (true, true) => model.phi[(i, j)],
            (true, false) => model.gamma[(i, j - n)],
            // Rows past n exist only with an output map.
            (false, true) => model.output.as_ref().map_or(0.0, |o| o.c[(i - n, j)]),
            (false, false) => model.output.as_ref().map_or(0.0, |o| o.d[(i - n, j - n)]),
        })
        .collect()
}

/// `model` with Φ and Γ (and C, D of a model with hidden states) from `theta` (laid out
/// as [`theta_of`]); everything else, the time constants included, as it was.
pub fn with_theta(model: &ThermalModel, theta: &[f64]) -> ThermalModel {
    let (n, m) = (model.phi.nrows(), model.gamma.ncols());
    let mut out = model.clone();
    for (k, &v) in theta.iter().enumerate() {
        let (i, j) = (k / (n + m), k % (n + m));
        match (&mut out.output, i < n, j < n) {
            (_, true, true) => out.phi[(i, j)] = v,
            (_, true, false) => out.gamma[(i, j - n)] = v,
            (Some(o), false, true) => o.c[(i - n, j)] = v,
            (Some(o), false, false) => o.d[(i - n, j - n)] = v,
            (None, false, _) => {}
        }
    }
    out
}

/// A map g(Θ) at the estimate and its Jacobian ∂g/∂Θ (one row per output).
#[derive(Debug, Clone)]
pub struct Linearised {
    /// g(Θ̂).
    pub value: Vec<f64>,
    /// ∂g/∂Θ by central differences, outputs × n(n+m).
    pub jacobian: DMatrix<f64>,
}

impl Linearised {
    /// The outputs' covariance J C Jᵀ.
    pub fn covariance(&self, theta_covariance: &DMatrix<f64>) -> DMatrix<f64> {
        &self.jacobian * theta_covariance * self.jacobian.transpose()
    }

    /// Each output's variance, diag(J C Jᵀ), without forming the whole matrix.
    pub fn variances(&self, theta_covariance: &DMatrix<f64>) -> Vec<f64> {
        let jc = &self.jacobian * theta_covariance;
        (0..self.jacobian.nrows())
            .map(|r| jc.row(r).dot(&self.jacobian.row(r)).max(0.0))
            .collect()
    }
}

/// Linearises the whole map `g` (a model in, figures out) around the model's Θ: each
/// entry stepped by ±h_j, h_j = 10⁻² of its standard error (√C_jj; small against the
/// map's curvature, large against the map's own rounding: a bisection to 10⁻⁹),
/// ∂g/∂Θ_j = (g(Θ + h_j e_j) − g(Θ − h_j e_j)) / 2h_j. An output that is not finite at
/// the estimate or a step (no limit reached) gets a zero row: no interval is claimed.
pub fn linearise<F>(
    model: &ThermalModel,
    theta_covariance: &DMatrix<f64>,
    g: F,
) -> Result<Linearised, UseError>
where
    F: Fn(&ThermalModel) -> Result<Vec<f64>, UseError>,
{
    let theta = theta_of(model);
    let value = g(model)?;
    let mut jacobian = DMatrix::zeros(value.len(), theta.len());
    for j in 0..theta.len() {
        let sd = theta_covariance[(j, j)].max(0.0).sqrt();
        if sd == 0.0 {
            // An entry the estimator held fixed (a structural zero) moves nothing.
            continue;
        }
        let h = (1e-2 * sd).max(1e-12 * theta[j].abs());
        let mut step = theta.clone();
        step[j] = theta[j] + h;
        let plus = g(&with_theta(model, &step))?;
        step[j] = theta[j] - h;
        let minus = g(&with_theta(model, &step))?;
        for (r, (p, q)) in plus.iter().zip(&minus).enumerate() {
            let d = (p - q) / (2.0 * h);
            jacobian[(r, j)] = if d.is_finite() { d } else { 0.0 };
        }
    }
    Ok(Linearised { value, jacobian })
}

/// `count` draws of N(mean, covariance), seeded: mean + V √Λ z with z ~ N(0, I) and
/// covariance = V Λ Vᵀ (its symmetric eigen-decomposition, negative rounding clipped to
/// zero, so a covariance of rank below its size draws on its own subspace).
pub fn gaussian_draws(
    mean: &DVector<f64>,
    covariance: &DMatrix<f64>,
    count: usize,
    seed: u64,
) -> Vec<DVector<f64>> {
    let symmetric = 0.5 * (covariance + covariance.transpose());
    let eigen = symmetric.symmetric_eigen();
    let scale = DMatrix::from_diagonal(&eigen.eigenvalues.map(|v| v.max(0.0).sqrt()));
    let root = &eigen.eigenvectors * scale;
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    (0..count)
        .map(|_| {
            let z = DVector::from_fn(mean.len(), |_, _| StandardNormal.sample(&mut rng));
            mean + &root * z
        })
        .collect()
}

/// The `q` quantile (0 ≤ q ≤ 1) of `values` by the nearest rank.
pub fn quantile(values: &mut [f64], q: f64) -> f64 {
    values.sort_by(f64::total_cmp);
    let last = values.len().saturating_sub(1);
    values[((q * last as f64).round() as usize).min(last)]
}

/// The variance of an open-loop prediction x̂(k+1) = Φ x̂(k) + Γ u(k) with measured
/// inputs, and of its outputs ŷ = C x̂ + D u (ŷ = x̂ without hidden states), carried step
/// by step beside it:
///
/// - the parameters' share by the exact forward sensitivities S(k) = ∂x̂(k)/∂Θ,
///   S(k+1) = Φ S(k) + E(k), E(k) holding z(k) = [x̂(k); u(k)] in state i's row under
///   Θ's entries of that row; the outputs' ∂ŷ/∂Θ = C S + F(k), F(k) holding z(k) in
///   output r's row under the entries of row r of [C D]; var = diag((∂ŷ/∂Θ) C_Θ (∂ŷ/∂Θ)ᵀ);
/// - the start's and the process noise's share, P(0) = C⁺ diag(σ_j² / θ_base²) C⁺ᵀ
///   (the start x̂(0) = C⁺ (y(0) − D u(0)) from the measured outputs; diag(σ²) for a
///   measured-state model), P(k+1) = Φ P(k) Φᵀ + Q (Q = K Λ Kᵀ where the model has it,
///   else 0), the outputs' C P Cᵀ.
///
/// In the model's units (per unit of the temperature base where scaled).
#[derive(Debug, Clone)]
pub struct OpenLoopVariance {
    sensitivity: DMatrix<f64>,
    state: DMatrix<f64>,
}

impl OpenLoopVariance {
    /// The variance at a (re)start from the measured outputs, whose sensors' noise is
    /// `start_variance` per output (model units²): no parameter share yet.
    pub fn start(model: &ThermalModel, start_variance: &[f64]) -> OpenLoopVariance {
        let n = model.phi.nrows();
        let outputs = DMatrix::from_diagonal(&DVector::from_column_slice(start_variance));
        let state = match &model.output {
            Some(o) => {
                let pinv =
                    o.c.clone()
                        .pseudo_inverse(1e-12)
                        .unwrap_or_else(|_| DMatrix::zeros(o.c.ncols(), o.c.nrows()));
                &pinv * outputs * pinv.transpose()
            }
            None => outputs,
        };
        OpenLoopVariance {
            sensitivity: DMatrix::zeros(n, theta_of(model).len()),
            state,
        }
    }

    /// The start's own sensitivity for a model with hidden states: x̂(0) = C⁺ (y − D u)
    /// moves with C and D, S(0) = ∂x̂(0)/∂Θ by central differences over the entries of
    /// [C D] with a variance (steps of 10⁻⁶ of each entry, at least 10⁻⁹; x̂(0) is smooth
    /// in C of full row rank). Nothing changes without hidden states, or without C_Θ.
    pub fn with_start_sensitivity(
        mut self,
        model: &ThermalModel,
        y: &DVector<f64>,
        u: &DVector<f64>,
    ) -> OpenLoopVariance {
        let (Some(_), Some(cov)) = (&model.output, &model.uncertainty.theta_covariance) else {
            return self;
        };
        let n = model.phi.nrows();
        let theta = theta_of(model);
        let first = n * (n + model.gamma.ncols());
        for q in first..theta.len() {
            if !(cov[(q, q)] > 0.0) {
                continue;
            }
            let h = (1e-6 * theta[q].abs()).max(1e-9);
            let mut step = theta.clone();
            step[q] = theta[q] + h;
            let plus = with_theta(model, &step).state_from_outputs(y, u);
            step[q] = theta[q] - h;
            let minus = with_theta(model, &step).state_from_outputs(y, u);
            self.sensitivity
                .set_column(q, &((plus - minus) / (2.0 * h)));
        }
        self
    }

    /// One step with the state x̂(k) and input u(k) the prediction stepped with.
    pub fn step(
        &mut self,
        model: &ThermalModel,
        uncertainty: &ModelUncertainty,
        x: &DVector<f64>,
        u: &DVector<f64>,
    ) {
        let (n, m) = (model.phi.nrows(), model.gamma.ncols());
        let mut next = &model.phi * &self.sensitivity;
        for i in 0..n {
            for (j, z) in x.iter().chain(u.iter()).enumerate() {
                next[(i, i * (n + m) + j)] += z;
            }
        }
        self.sensitivity = next;
        self.state = &model.phi * &self.state * model.phi.transpose();
        if let Some(q) = &uncertainty.process_noise {
            self.state += q;
        }
    }

    /// Each measured output's prediction variance now, model units², at the state x̂
    /// and input u of this instant: the parameters' share (where the report has C_Θ)
    /// plus the start's and the process noise's.
    pub fn variances(
        &self,
        model: &ThermalModel,
        uncertainty: &ModelUncertainty,
        x: &DVector<f64>,
        u: &DVector<f64>,
    ) -> Vec<f64> {
        let (n, m) = (model.phi.nrows(), model.gamma.ncols());
        let (outputs, state) = match &model.output {
            Some(o) => {
                let mut s = &o.c * &self.sensitivity;
                for r in 0..o.c.nrows() {
                    for (j, z) in x.iter().chain(u.iter()).enumerate() {
                        s[(r, (n + r) * (n + m) + j)] += z;
                    }
                }
                (s, &o.c * &self.state * o.c.transpose())
            }
            None => (self.sensitivity.clone(), self.state.clone()),
        };
        let parameters = uncertainty.theta_covariance.as_ref().map(|c| {
            let sc = &outputs * c;
            (0..outputs.nrows())
                .map(|i| sc.row(i).dot(&outputs.row(i)))
                .collect::<Vec<_>>()
        });
        (0..outputs.nrows())
            .map(|i| {
                let p = parameters.as_ref().map_or(0.0, |v| v[i]);
                (p + state[(i, i)]).max(0.0)
            })
            .collect()
    }
}

#[cfg(test)]
pub(crate) mod tests;
