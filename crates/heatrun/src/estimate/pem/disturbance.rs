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
//! slow modes of a heat run sit at 1 − 10⁻⁴). For each q, Θ and the start states are
//! fitted by prediction error with K_a held; q maximises the innovations' concentrated
//! likelihood −½ Σ_c N_c ln σ̂_c² over a grid of decades and a golden-section refinement
//!, and K_a is made once
//! more from the fitted Φ for the last fit. As q → 0 the gain
//! vanishes and the fit is `oe`'s: the likelihood ratio against it
//! ([`super::ratio`]) tests q = 0.

use nalgebra::{DMatrix, DVector};

use super::problem::{self, GainModel};
use super::PredictionError;
use crate::estimate::{Estimate, IdentificationData, Result};

/// The grid of log₁₀(q / σ_j²) the search starts on: from a walk far below the sensors'
/// noise (10⁻¹¹: a fraction of a millikelvin over a day) to one that moves the state as
/// much as the noise within a few hundred samples (10⁻⁴).
const GRID: std::ops::RangeInclusive<i32> = -11..=-4;

/// Golden-section steps refining the best decade (to about a fifth of a decade: the
/// likelihood is flat in q near its maximum).
const GOLDEN_STEPS: usize = 5;

/// The fit with a disturbance entering `state`: the intensity q searched, Θ and the
/// start states fitted for each (see the module's documentation), R from the residuals'
/// differences ([`difference_variance`]): `oe`'s residual variances, which the
/// disturbance inflates, would make the gain's R too large and its q with it.
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
        start,
        initial_states,
        state,
        counts: data.observed_counts(&data.segments()),
    };
    let r = difference_variance(data, start);
    let found = search.over(&r, None)?;
    // K_a once more from the fitted Φ, which the gain was not made from.
    let phi = found.estimate.model.phi.clone();
    Ok(match search.fit_at(found.q, &r, &phi)? {
        Some((_, e)) => e,
        None => found.estimate,
    })
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

/// The best fit a search found, and its intensity q.
struct Found {
    q: f64,
    estimate: Estimate,
}

/// What every fit of the search shares.
struct Search<'a> {
    pem: &'a PredictionError,
    data: &'a IdentificationData,
    start: &'a Estimate,
    initial_states: &'a [DVector<f64>],
    state: usize,
    counts: Vec<usize>,
}

impl Search<'_> {
    /// The fit with K_a of intensity `q`, R = diag(`r`) and Φ = `phi`, and its cost
    /// ([`cost`]); `None` where the Riccati equation has no solution.
    fn fit_at(&self, q: f64, r: &[f64], phi: &DMatrix<f64>) -> Result<Option<(f64, Estimate)>> {
        let Some(gain) = kalman_gain(phi, self.state, q, r) else {
            return Ok(None);
        };
        let model = GainModel::Disturbance {
            state: self.state,
            gain,
        };
        let mut e = problem::fit(self.pem, self.data, self.start, self.initial_states, &model)?;
        if let Some(d) = e.predictor.as_mut().and_then(|p| p.disturbance.as_mut()) {
            d.increment_sd = q.sqrt();
        }
        Ok(Some((cost(&self.counts, &e.noise_variance), e)))
    }

    /// The best log₁₀(q / r_j): on [`GRID`] (or at `centre`), refined by golden section
    /// within a decade either side.
    fn over(&self, r: &[f64], centre: Option<f64>) -> Result<Found> {
        let phi = &self.start.model.phi;
        let q_of = |s: f64| 10f64.powf(s) * r[self.state];
        let points: Vec<f64> = match centre {
            Some(c) => vec![c],
            None => GRID.map(f64::from).collect(),
        };
        let mut best: Option<(f64, f64, Estimate)> = None;
        for s in points {
            if let Some((c, e)) = self.fit_at(q_of(s), r, phi)? {
                if best.as_ref().is_none_or(|b| c < b.1) {
                    best = Some((s, c, e));
                }
            }
        }
        let Some((mut at, mut cost_at, mut estimate)) = best else {
            return Err(crate::estimate::EstimationError::MinimisationFailed {
                termination: levenberg_marquardt::TerminationReason::User(
                    "no stable Kalman filter for any disturbance intensity",
                ),
            });
        };
        let (mut low, mut high) = (at - 1.0, at + 1.0);
        for _ in 0..GOLDEN_STEPS {
            let trial = if at - low > high - at {
                at - 0.382 * (at - low)
            } else {
                at + 0.382 * (high - at)
            };
            match self.fit_at(q_of(trial), r, phi)? {
                Some((c, e)) if c < cost_at => {
                    if trial < at {
                        high = at;
                    } else {
                        low = at;
                    }
                    (at, cost_at, estimate) = (trial, c, e);
                }
                _ => {
                    if trial < at {
                        low = trial;
                    } else {
                        high = trial;
                    }
                }
            }
        }
        Ok(Found {
            q: q_of(at),
            estimate,
        })
    }
}

/// Σ_c N_c ln σ̂_c²: −2 × the innovations' concentrated log-likelihood, up to a constant.
fn cost(counts: &[usize], variance: &[f64]) -> f64 {
    counts
        .iter()
        .zip(variance)
        .map(|(n, v)| *n as f64 * v.max(1e-300).ln())
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
