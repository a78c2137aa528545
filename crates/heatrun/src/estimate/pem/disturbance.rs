//! The disturbance's intensity, estimated with Θ: the predictor of the augmented model
//! (see [`super`]) with process noise on d alone, Q = diag(0, …, 0, q), and the sensors'
//! noise R = diag(σ_c²) (from the differences of `oe`'s residuals), is the steady-state
//! Kalman filter
//!
//! ```text
//! P = Φ_a P Φ_aᵀ − Φ_a P C_aᵀ (C_a P C_aᵀ + R)⁻¹ C_a P Φ_aᵀ + Q,   K_a = Φ_a P C_aᵀ (C_a P C_aᵀ + R)⁻¹,
//! ```
//!
//! stable for every q > 0 (the pair (Φ_a, C_a) is detectable: d reaches the outputs
//! through x_j). One number, q, then stands for the disturbance, where a free K_a would
//! spend n(n + 1) on it, and its descent from K_a = 0 runs into unstable predictors (the
//! slow modes of a heat run sit at 1 − 10⁻⁴).
//!
//! q and Θ maximise the innovations' concentrated likelihood −½ Σ_c N_c ln σ̂_c²
//! together, by alternating: q is profiled with Θ and the start states held (one pass
//! of the filter per q, no sensitivities: a grid of half-decades refined by golden
//! section), then Θ and the start states are fitted by prediction error with that q's
//! K_a held (from the last fit: a warm start), and again until q settles (a few rounds:
//! Θ moves little once q is near its optimum). Each round raises the likelihood or the
//! fit is not taken. A Θ fit per q tried, as the search first did, costs some 14 fits
//! for the same optimum. As q → 0 the gain vanishes and the fit is `oe`'s: the
//! likelihood ratio against it ([`super::ratio`]) tests q = 0.

use nalgebra::{DMatrix, DVector};

use super::problem::{self, GainModel};
use super::PredictionError;
use crate::estimate::{DiscreteModel, Estimate, IdentificationData, Result};

/// The grid of log₁₀(q / σ_j²) the profile starts on, in half-decades: from a walk far
/// below the sensors' noise (10⁻¹²: a fraction of a millikelvin over a day) to one that
/// moves the state as much as the noise within a hundred samples (10⁻³).
const GRID: (f64, f64) = (-12.0, -3.0);

/// Golden-section steps refining the profile's best grid point within half a decade
/// either side (to ~0.01 decade: each step is one pass of the filter).
const GOLDEN_STEPS: usize = 10;

/// Rounds of (profile q, fit Θ) at most; the alternation stops sooner where q moved by
/// less than [`SETTLED_DECADES`].
const ROUNDS: usize = 4;

/// A change of log₁₀ q below which the alternation has settled (the likelihood is flat
/// in q near its maximum: a tenth of a decade changes the gain by ~10 %).
const SETTLED_DECADES: f64 = 0.1;

/// The fit with a disturbance entering `state`: q and Θ by alternation (see the
/// module's documentation), R from the residuals' differences ([`difference_variance`]):
/// `oe`'s residual variances, which the disturbance inflates, would make the gain's R
/// too large and its q with it.
pub(super) fn fit(
    pem: &PredictionError,
    data: &IdentificationData,
    start: &Estimate,
    initial_states: &[DVector<f64>],
    state: usize,
) -> Result<Estimate> {
    let search = Search {
        pem,
        data,
        state,
        counts: data.observed_counts(&data.segments()),
        r: difference_variance(data, start),
        floor: super::ratio::exact_floor(&start.noise_variance),
    };
    let mut at = search.profile(&start.model, initial_states)?;
    let (mut best_cost, mut best) = search
        .fit_at(at, start, initial_states)?
        .ok_or_else(no_filter)?;
    for _ in 1..ROUNDS {
        let x0 = fitted_initial_states(&best);
        let next = search.profile(&best.model, &x0)?;
        let settled = (next - at).abs() < SETTLED_DECADES;
        // Θ is refitted at the settled q too: its K_a is made from the fitted Φ, which
        // the last gain was not.
        if let Some((c, e)) = search.fit_at(next, &best, &x0)? {
            if c < best_cost {
                (best_cost, best) = (c, e);
            }
        }
        at = next;
        if settled {
            break;
        }
    }
    Ok(best)
}

/// The error of a search that found no stable filter at any intensity.
fn no_filter() -> crate::estimate::EstimationError {
    crate::estimate::EstimationError::MinimisationFailed {
        termination: levenberg_marquardt::TerminationReason::User(
            "no stable Kalman filter for any disturbance intensity",
        ),
    }
}

/// The start states a fit ended at (x̂(start) of each segment).
fn fitted_initial_states(e: &Estimate) -> Vec<DVector<f64>> {
    e.predictor
        .as_ref()
        .map(|p| p.initial_states.clone())
        .unwrap_or_default()
}

/// R from `start`'s simulation residuals e: Var(e(k+1) − e(k)) / 2 per output over
/// consecutive observed pairs. White sensor noise gives σ_v² exactly; a disturbance,
/// slow against Ts, adds little to a difference where it inflates e's variance (a
/// heat run's walk moves its state by ~10⁻³ of the noise per sample).
fn difference_variance(data: &IdentificationData, start: &Estimate) -> Vec<f64> {
    let segments = data.segments();
    let simulated = start.model.simulate_segments(data, &segments);
    (0..data.states())
        .map(|c| {
            let (mut sum, mut count) = (0.0, 0usize);
            for seg in &segments {
                for k in seg.start..seg.end.saturating_sub(1) {
                    if data.observed(k, c) && data.observed(k + 1, c) {
                        let e0 = data.outputs[(k, c)] - simulated[(k, c)];
                        let e1 = data.outputs[(k + 1, c)] - simulated[(k + 1, c)];
                        sum += (e1 - e0).powi(2);
                        count += 1;
                    }
                }
            }
            let v = sum / (2.0 * count.max(1) as f64);
            if v.is_finite() && v > 0.0 {
                v
            } else {
                start.noise_variance[c].max(1e-24)
            }
        })
        .collect()
}

/// What every step of the search shares.
struct Search<'a> {
    pem: &'a PredictionError,
    data: &'a IdentificationData,
    state: usize,
    counts: Vec<usize>,
    /// R's diagonal, σ_c² (see [`difference_variance`]).
    r: Vec<f64>,
    /// The variance below which an output is taken as exact, from `oe`'s
    /// ([`super::ratio::exact_floor`]).
    floor: f64,
}

impl Search<'_> {
    /// q = 10^`at` σ_j²: the intensity at log₁₀(q / σ_j²) = `at`.
    fn q(&self, at: f64) -> f64 {
        10f64.powf(at) * self.r[self.state]
    }

    /// The profile's cost Σ_c N_c ln σ̂_c² at log₁₀(q / σ_j²) = `at` with Θ of `model`
    /// and the start states held; `None` where there is no stable filter.
    fn profile_cost(&self, at: f64, model: &DiscreteModel, x0: &[DVector<f64>]) -> Option<f64> {
        let gain = kalman_gain(&model.phi, self.state, self.q(at), &self.r)?;
        let variance = problem::innovation_variance(self.data, model, x0, self.state, gain)?;
        Some(cost(&self.counts, &variance, self.floor))
    }

    /// The best log₁₀(q / σ_j²) with Θ of `model` held: on [`GRID`]'s half-decades, then
    /// golden section within half a decade either side.
    fn profile(&self, model: &DiscreteModel, x0: &[DVector<f64>]) -> Result<f64> {
        let steps = ((GRID.1 - GRID.0) * 2.0).round() as usize;
        let (at, cost_at) = (0..=steps)
            .map(|i| GRID.0 + 0.5 * i as f64)
            .filter_map(|s| self.profile_cost(s, model, x0).map(|c| (s, c)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .ok_or_else(no_filter)?;
        let cost_of = |s: f64| self.profile_cost(s, model, x0).unwrap_or(f64::INFINITY);
        Ok(golden_minimum(cost_of, (at - 0.5, at + 0.5), (at, cost_at)))
    }

    /// The fit at log₁₀(q / σ_j²) = `at`, K_a from `start`'s Φ, Θ and the start states
    /// from `start` and `x0`, and its cost ([`cost`]); `None` where the Riccati equation
    /// has no solution.
    fn fit_at(
        &self,
        at: f64,
        start: &Estimate,
        x0: &[DVector<f64>],
    ) -> Result<Option<(f64, Estimate)>> {
        let q = self.q(at);
        let Some(gain) = kalman_gain(&start.model.phi, self.state, q, &self.r) else {
            return Ok(None);
        };
        let model = GainModel::Disturbance {
            state: self.state,
            gain,
        };
        let mut e = problem::fit(self.pem, self.data, start, x0, &model)?;
        if let Some(d) = e.predictor.as_mut().and_then(|p| p.disturbance.as_mut()) {
            d.increment_sd = q.sqrt();
        }
        Ok(Some((cost(&self.counts, &e.noise_variance, self.floor), e)))
    }
}

/// The minimum of `f` on `bracket` by golden section from a known point `best` inside
/// it: each step tries the golden point of the larger side and keeps the smaller value.
fn golden_minimum(f: impl Fn(f64) -> f64, bracket: (f64, f64), best: (f64, f64)) -> f64 {
    let (mut low, mut high) = bracket;
    let (mut at, mut value) = best;
    for _ in 0..GOLDEN_STEPS {
        let trial = if at - low > high - at {
            at - 0.382 * (at - low)
        } else {
            at + 0.382 * (high - at)
        };
        let v = f(trial);
        if v < value {
            if trial < at {
                high = at;
            } else {
                low = at;
            }
            (at, value) = (trial, v);
        } else if trial < at {
            low = trial;
        } else {
            high = trial;
        }
    }
    at
}

/// Σ_c N_c ln max(σ̂_c², floor): −2 × the innovations' concentrated log-likelihood, up
/// to a constant, an output without noise held at the floor of R
/// ([`super::ratio::exact_floor`]): otherwise the search would chase its rounding.
fn cost(counts: &[usize], variance: &[f64], floor: f64) -> f64 {
    counts
        .iter()
        .zip(variance)
        .map(|(n, v)| *n as f64 * v.max(floor).ln())
        .sum()
}

/// K_a of the augmented model (d entering `state`) with Q = q on d alone and R =
/// diag(`r`), from the filter's Riccati equation solved by structure-preserving doubling
/// (Chu, Fan and Lin 2005): with A = Φ_aᵀ, G = C_aᵀ R⁻¹ C_a, H = Q,
/// A ← A (I + G H)⁻¹ A, G ← G + A (I + G H)⁻¹ G Aᵀ, H ← H + Aᵀ H (I + G H)⁻¹ A, H → P
/// quadratically (a slow mode at 1 − 10⁻⁶ takes some 20 doublings where the plain
/// recursion takes millions of steps). `None` where a step cannot be inverted or P does
/// not settle.
pub(super) fn kalman_gain(
    phi: &DMatrix<f64>,
    state: usize,
    q: f64,
    r: &[f64],
) -> Option<DMatrix<f64>> {
    let n = phi.nrows();
    let p = riccati(phi, state, q, r)?;
    let phi_a = problem::augmented_phi(phi, state);
    let c = DMatrix::from_fn(n, n + 1, |i, j| if i == j { 1.0 } else { 0.0 });
    let r_m = DMatrix::from_fn(n, n, |i, j| if i == j { r[i] } else { 0.0 });
    let s = &c * &p * c.transpose() + r_m;
    Some(&phi_a * &p * c.transpose() * s.try_inverse()?)
}

/// P, the filter's Riccati solution of [`kalman_gain`], by the doubling.
fn riccati(phi: &DMatrix<f64>, state: usize, q: f64, r: &[f64]) -> Option<DMatrix<f64>> {
    let n = phi.nrows();
    let na = n + 1;
    let phi_a = problem::augmented_phi(phi, state);
    let c = DMatrix::from_fn(n, na, |i, j| if i == j { 1.0 } else { 0.0 });
    let r_inv = DMatrix::from_fn(n, n, |i, j| if i == j { 1.0 / r[i] } else { 0.0 });
    let identity = DMatrix::<f64>::identity(na, na);
    let mut a = phi_a.transpose();
    let mut g = c.transpose() * r_inv * &c;
    let mut h = DMatrix::zeros(na, na);
    h[(n, n)] = q;
    let mut settled = false;
    for _ in 0..80 {
        let w = (&identity + &g * &h).try_inverse()?;
        let a_w = &a * &w;
        let next_h = &h + a.transpose() * &h * &w * &a;
        let next_g = &g + &a_w * &g * a.transpose();
        a = &a_w * &a;
        let change = (&next_h - &h).amax();
        h = next_h;
        g = next_g;
        if !h.iter().all(|v| v.is_finite()) {
            return None;
        }
        if change <= 1e-13 * h.amax() {
            settled = true;
            break;
        }
    }
    settled.then_some(h)
}
