//! Prediction error: a stochastic model with process noise,
//!
//! ```text
//! x(k+1) = Φ x(k) + Γ u(k) + w(k),   y(k) = C x(k) + v(k)   (C = I: every state measured)
//! ```
//!
//! in innovations form, the one-step predictor (a steady-state Kalman filter)
//!
//! ```text
//! x̂(k+1) = Φ x̂(k) + Γ u(k) + K e(k),   e(k) = y(k) − C x̂(k),
//! ```
//!
//! with Θ = [Φ Γ], the gain K (n × p) and each segment's x̂(start) estimated together by
//! minimising the weighted innovations J = ½ Σ_k e(k)ᵀ W e(k), W = Λ⁻¹ re-estimated from
//! the innovations (the likelihood of Gaussian innovations with a diagonal covariance Λ,
//! concentrated). K parametrises Q and R together: K = Φ P Cᵀ (C P Cᵀ + R)⁻¹ of the Riccati
//! solution P of (Q, R); only K is identifiable from y alone, as SITB's `pem` with a
//! disturbance model. Where the sensor noise is white and nothing else disturbs the
//! plant, the optimal K is 0 and the predictor is the simulation: the fit is `oe`'s,
//! from which it starts.
//!
//! The Jacobian comes from the forward sensitivities of the predictor,
//! ∂x̂(k+1)/∂θ = (Φ − K M_k) ∂x̂(k)/∂θ + ∂Φ/∂θ x̂(k) + ∂Γ/∂θ u(k) + ∂K/∂θ M_k e(k),
//! with M_k the diagonal of the outputs observed at k: a missing output is skipped in
//! the filter's update (its innovation is unknown, so only the others correct x̂; with
//! none observed it is the time update alone). The steady-state gain is kept through a
//! gap rather than the filter's growing one, an approximation that errs towards trusting
//! the model after a gap.
//!
//! **A disturbance state** ([`PredictionError::disturbance_state`]): an unmeasured heat
//! that wanders (a valve, the air circuit, a neighbour) is integrated white noise, not
//! the white process noise above, and a predictor of x alone follows it only by a gain
//! that also takes up the sensors' noise. The model is then augmented with d, a random
//! walk entering state j (the cooling water's node, where such heat arrives),
//!
//! ```text
//! x_a = [x; d],   Φ_a = [Φ e_j; 0 1],   Γ_a = [Γ; 0],   C_a = [I 0],   d(k+1) = d(k) + w_d(k),
//! x̂_a(k+1) = Φ_a x̂_a(k) + Γ_a u(k) + K_a e(k),   K_a = [K; k_d]   ((n + 1) × n),
//! ```
//!
//! d in the state's own units per sample (the rise the heat adds each step), d̂(start) = 0
//! in each segment. K_a is the steady-state Kalman gain of w_d's variance q and the
//! sensors' R, q estimated with Θ (`disturbance`); as q → 0, K_a → 0
//! and the predictor is `oe`'s simulation again.

mod disturbance;
mod problem;
pub mod ratio;

use nalgebra::{DMatrix, DVector};

use super::oe::OutputError;
use super::{DiscreteModel, Estimate, Estimator, IdentificationData, Method, Result};
use crate::progress::Observer;

/// The prediction-error estimator.
#[derive(Debug, Clone, Default)]
pub struct PredictionError {
    /// Per-output weights w_i > 0 of the innovations; `None` uses Λ⁻¹ of the innovations
    /// (from `oe`'s simulation error first), re-estimated once.
    pub weights: Option<Vec<f64>>,
    /// Told each evaluation of the objective (its number and J) as the fit goes.
    pub progress: Observer,
    /// The state a random-walk disturbance d enters (see the module's documentation);
    /// `None`, or an index that names no state: the predictor of x alone.
    pub disturbance_state: Option<usize>,
}

/// The disturbance state of a predictor: d(k+1) = d(k) + k_d e(k), entering x_j.
#[derive(Debug, Clone, PartialEq)]
pub struct Disturbance {
    /// j: the state d enters (x_j(k+1) gains d(k)).
    pub state: usize,
    /// k_d (n, by output): d's row of the gain K_a.
    pub gain: Vec<f64>,
    /// √q: the standard deviation of d's increment per sample, the disturbance's
    /// intensity the gain was made from (the state's units per sample per sample).
    pub increment_sd: f64,
}

/// The one-step predictor of an estimate: the Kalman gain and the innovations' variance.
#[derive(Debug, Clone, PartialEq)]
pub struct Predictor {
    /// K (n × n, rows by state, columns by output), from x̂(k+1) = Φ x̂(k) + Γ u(k) + K e(k)
    /// (+ d̂(k) into x_j where there is a disturbance).
    pub gain: DMatrix<f64>,
    /// The disturbance state, where the predictor has one.
    pub disturbance: Option<Disturbance>,
    /// Var e_i per output (pu²): the innovations' variance at the estimate.
    pub innovation_variance: Vec<f64>,
    /// x̂(start) of each segment of the data it was fitted on, as fitted (a slow mode of
    /// the predictor remembers its start for hours: the analysis of the same data starts
    /// where the fit did).
    pub initial_states: Vec<DVector<f64>>,
}

impl Predictor {
    /// The one-step predictions ŷ(k|k−1) = x̂(k) over `data`'s segments (N × n, NaN
    /// outside them): the innovations y − ŷ are what the residual analysis tests for
    /// whiteness. Each segment starts from its fitted x̂(start) where `data` has the
    /// segments the predictor was fitted on, else from the model's initial state (the
    /// measured y(start) where observed).
    pub fn predict(&self, model: &DiscreteModel, data: &IdentificationData) -> DMatrix<f64> {
        let n = data.states();
        let mut out = DMatrix::from_element(data.len(), n, f64::NAN);
        let segments = data.segments();
        let fitted = segments.len() == self.initial_states.len();
        for (s, seg) in segments.into_iter().enumerate() {
            let mut x = if fitted {
                self.initial_states[s].clone()
            } else {
                model.initial_state(data, seg.clone())
            };
            let mut d = 0.0;
            for k in seg.clone() {
                out.set_row(k, &x.transpose());
                if k + 1 == seg.end {
                    break;
                }
                let e = DVector::from_fn(n, |c, _| {
                    if data.observed(k, c) {
                        data.outputs[(k, c)] - x[c]
                    } else {
                        0.0
                    }
                });
                let u = data.inputs.row(k).transpose();
                let mut next = &model.phi * &x + &model.gamma * u + &self.gain * &e;
                if let Some(dist) = &self.disturbance {
                    next[dist.state] += d;
                    d += dist
                        .gain
                        .iter()
                        .zip(e.iter())
                        .map(|(k, e)| k * e)
                        .sum::<f64>();
                }
                x = next;
            }
        }
        out
    }

    /// The largest |K_ij|: how far the predictor is from the simulation (0 for `oe`).
    pub fn largest_gain(&self) -> f64 {
        self.gain.amax()
    }
}

impl Estimator for PredictionError {
    fn method(&self) -> Method {
        Method::Pem
    }

    /// `oe`'s fit, then the predictor's gain and Θ together from it (K = 0 at the start).
    fn estimate(&self, data: &IdentificationData) -> Result<Estimate> {
        let oe = OutputError {
            weights: self.weights.clone(),
            progress: self.progress.clone(),
        };
        let start = oe.start(data)?;
        let fitted = oe.fit(data, &start)?;
        self.refine(data, &fitted.estimate, &fitted.initial_states)
    }
}

impl PredictionError {
    /// The prediction-error fit from `start` (Θ, with K = 0) and its segments' initial
    /// states; with a disturbance state, its intensity searched
    /// (`disturbance`).
    pub fn refine(
        &self,
        data: &IdentificationData,
        start: &Estimate,
        initial_states: &[DVector<f64>],
    ) -> Result<Estimate> {
        match self.disturbance_state.filter(|&j| j < data.states()) {
            Some(state) => disturbance::fit(self, data, start, initial_states, state),
            None => problem::fit(self, data, start, initial_states, &problem::GainModel::Free),
        }
    }
}

#[cfg(test)]
mod tests;
