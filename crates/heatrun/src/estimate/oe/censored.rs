//! Outputs stored by exception, read as censored observations.
//!
//! A historian keeps a value only when it has moved more than a deadband D from the last
//! kept value v (or at a heartbeat), so every instant in between says the measured value
//! m(k) stayed in [v − D, v + D]. With m(k) = ŷ(k) + e(k), e white N(0, σ²), the
//! likelihood of the record is
//!
//!   Π_kept φ((m − ŷ)/σ)/σ · Π_between [Φ(β) − Φ(α)],  α, β = (v ∓ D − ŷ)/σ.
//!
//! The kept values alone are a biased sample: a value is kept because its noise carried it
//! out of the band, which on a rising temperature favours values above the truth and makes
//! the model look faster. The instants between them carry the correction.
//!
//! The likelihood is maximised by iteratively reweighted output error (Fisher scoring): a
//! censored value's score is (E[m | band] − ŷ)/σ² and its observed information
//! e/σ² with e = 1 − Var[m | band]/σ², where
//! E[m | band] = ŷ + σ (φ(α) − φ(β)) / (Φ(β) − Φ(α)). So each iteration fits the model,
//! by output error, to the kept values (weight 1) and the working values
//! ŷ + (E[m | band] − ŷ)/e (weight e) of the censored ones, both at the current ŷ, and sets
//! σ² to the mean of (m − ŷ)² over kept values and E[(m − ŷ)² | band] over censored ones
//! (the EM update); at the fixed point the gradient of the working fit is the likelihood's.
//! The covariance is the inverse of that observed information.

use std::f64::consts::{FRAC_1_SQRT_2, PI};

use nalgebra::DMatrix;

use super::fit::{information_covariance, normalised_inverse, Fitted, OutputError};
use crate::estimate::{Estimate, IdentificationData, Result};

/// Most reweighting iterations.
pub const MAX_ITERATIONS: usize = 50;

/// Most extrapolation steps of a noise variance's fixed point.
const MAX_VARIANCE_ITERATIONS: usize = 50;

/// The iteration stops when no entry of Θ moves more than this, relative.
pub const TOLERANCE: f64 = 1e-7;

/// A censored value whose information share e is below this is left out (its band says
/// next to nothing about the model there).
const MIN_INFORMATION: f64 = 1e-6;

/// Whether the data hold outputs stored by exception (a mask and a declared deadband).
pub(crate) fn applies(data: &IdentificationData) -> bool {
    data.output_observed.is_some() && data.exception_storage.iter().any(Option::is_some)
}

/// The working record of one iteration.
struct Completion {
    /// Kept values as they are, censored ones by their working values; observed wherever
    /// either is.
    data: IdentificationData,
    /// σ² per output, maximising the likelihood for this simulation.
    noise_variance: Vec<f64>,
    /// Each entry's share of a kept value's information: 1 kept, 1 − Var/σ² censored.
    information: DMatrix<f64>,
}

/// Maximises the likelihood of an exception-stored record from a fit of its kept values.
pub(crate) fn maximise_likelihood(
    oe: &OutputError,
    data: &IdentificationData,
    first: Fitted,
) -> Result<Estimate> {
    let segments = data.segments();
    let rows_used = first.estimate.rows_used;
    let mut iterations = first.estimate.iterations;
    let mut fitted = first;
    let mut completion = complete(data, &fitted, &segments, &fitted.estimate.noise_variance);
    for _ in 0..MAX_ITERATIONS {
        let step = OutputError {
            weights: Some(normalised(&completion.noise_variance, &oe.weights)),
            progress: oe.progress.clone(),
        };
        let next = step.fit_weighted(
            &completion.data,
            &fitted.estimate.model,
            Some(completion.information.clone()),
        )?;
        let change = relative_change(&fitted.estimate.model.theta(), &next.estimate.model.theta());
        iterations += next.estimate.iterations;
        fitted = next;
        completion = complete(data, &fitted, &segments, &completion.noise_variance);
        if change < TOLERANCE {
            break;
        }
    }
    let (covariance, condition_number) = information_covariance(
        &completion.data,
        &fitted.estimate.model,
        &fitted.initial_states,
        &completion.noise_variance,
        completion.information,
    );
    Ok(Estimate {
        covariance: Some(covariance),
        robust_covariance: None,
        condition_number,
        noise_variance: completion.noise_variance,
        iterations,
        rows_used,
        ..fitted.estimate
    })
}

/// The working fit's weights: the user's, or the normalised inverse noise variances.
fn normalised(noise_variance: &[f64], given: &Option<Vec<f64>>) -> Vec<f64> {
    match given {
        Some(w) => w.clone(),
        None => normalised_inverse(noise_variance),
    }
}

/// Largest |b − a| / |a| over the entries.
fn relative_change(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (y - x).abs() / x.abs().max(1e-300))
        .fold(0.0, f64::max)
}

/// The working record at a fit: its simulation from its initial states, then per output
/// the noise variance that maximises the likelihood for that simulation, and the working
/// values and information shares at it.
fn complete(
    data: &IdentificationData,
    fitted: &Fitted,
    segments: &[std::ops::Range<usize>],
    noise_variance: &[f64],
) -> Completion {
    let (len, n) = (data.len(), data.states());
    let simulated = fitted.simulate_segments(data, segments);
    let mut outputs = data.outputs.clone();
    let mut observed = data
        .output_observed
        .clone()
        .unwrap_or_else(|| DMatrix::from_fn(len, n, |k, _| data.outputs_known[k]));
    let mut information = DMatrix::from_element(len, n, 1.0);
    let mut variances = noise_variance.to_vec();
    for (j, variance) in variances.iter_mut().enumerate() {
        let (v, column) = profile_variance(data, j, &simulated, *variance);
        *variance = v;
        for (k, entry) in column.iter().enumerate() {
            if let Entry::Censored { mean, variance } = *entry {
                let y_hat = simulated[(k, j)];
                let share = 1.0 - variance / v;
                if share >= MIN_INFORMATION {
                    outputs[(k, j)] = y_hat + (mean - y_hat) / share;
                    observed[(k, j)] = true;
                    information[(k, j)] = share;
                }
            }
        }
    }
    Completion {
        data: IdentificationData {
            outputs,
            ..data.clone()
        }
        .with_output_observed(observed),
        noise_variance: variances,
        information,
    }
}

/// The σ² of output j that maximises the likelihood for a fixed simulation: the fixed
/// point of σ² = f(σ²), the mean of (m − ŷ)² over kept values and E[(m − ŷ)² | band; σ]
/// over censored ones, from `variance`. The plain iteration converges linearly (at the
/// censored share of the information), so Steffensen's extrapolation
/// v − (f(v) − v)² / (f(f(v)) − 2 f(v) + v) takes it. Returns σ² with the entries at it.
fn profile_variance(
    data: &IdentificationData,
    j: usize,
    simulated: &DMatrix<f64>,
    variance: f64,
) -> (f64, Vec<Entry>) {
    let update = |v: f64| mean_squared_error(&complete_output(data, j, simulated, v), simulated, j);
    let mut v = variance;
    for _ in 0..MAX_VARIANCE_ITERATIONS {
        let Some(v1) = update(v) else { break };
        if (v1 / v - 1.0).abs() < 1e-12 {
            v = v1;
            break;
        }
        let Some(v2) = update(v1) else { break };
        let curvature = v2 - 2.0 * v1 + v;
        let extrapolated = v - (v1 - v).powi(2) / curvature;
        let next = if extrapolated.is_finite() && extrapolated > 0.0 {
            extrapolated
        } else {
            v2
        };
        let settled = (next / v - 1.0).abs() < 1e-12;
        v = next;
        if settled {
            break;
        }
    }
    (v, complete_output(data, j, simulated, v))
}

/// Mean of (m − ŷ)² over kept entries and E[(m − ŷ)² | band] over censored ones, or
/// `None` where there is no entry.
fn mean_squared_error(column: &[Entry], simulated: &DMatrix<f64>, j: usize) -> Option<f64> {
    let (mut sum, mut count) = (0.0, 0usize);
    for (k, entry) in column.iter().enumerate() {
        match *entry {
            Entry::Kept(e2) => sum += e2,
            Entry::Censored { mean, variance } => {
                sum += (mean - simulated[(k, j)]).powi(2) + variance;
            }
            Entry::Unknown => continue,
        }
        count += 1;
    }
    (count > 0).then(|| (sum / count as f64).max(1e-30))
}

/// One entry of the record at a simulation.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Entry {
    /// A kept value, with its squared simulation error.
    Kept(f64),
    /// A censored value's conditional mean and variance given its band.
    Censored { mean: f64, variance: f64 },
    /// Outside the simulation, or a gap.
    Unknown,
}

/// The entries of output j over the simulated instants: kept, censored (unobserved,
/// within the heartbeat of the last kept value, the output stored by exception) or
/// unknown.
fn complete_output(
    data: &IdentificationData,
    j: usize,
    simulated: &DMatrix<f64>,
    variance: f64,
) -> Vec<Entry> {
    let storage = data.exception_storage[j];
    let sigma = variance.max(1e-300).sqrt();
    let mut last_kept: Option<(usize, f64)> = None;
    (0..data.len())
        .map(|k| {
            let y_hat = simulated[(k, j)];
            if data.observed(k, j) {
                last_kept = Some((k, data.outputs[(k, j)]));
                return if y_hat.is_finite() {
                    Entry::Kept((data.outputs[(k, j)] - y_hat).powi(2))
                } else {
                    Entry::Unknown
                };
            }
            match (storage, last_kept) {
                (Some(st), Some((at, v))) if y_hat.is_finite() && k - at < st.max_interval => {
                    let (mean, variance) =
                        truncated_normal(y_hat, sigma, v - st.deadband, v + st.deadband);
                    Entry::Censored { mean, variance }
                }
                _ => Entry::Unknown,
            }
        })
        .collect()
}

/// Mean and variance of N(μ, σ²) truncated to [a, b].
pub(crate) fn truncated_normal(mu: f64, sigma: f64, a: f64, b: f64) -> (f64, f64) {
    let (alpha, beta) = ((a - mu) / sigma, (b - mu) / sigma);
    let z = normal_interval(alpha, beta);
    if z.is_nan() || z <= 1e-12 {
        // The band lies many σ from the model: its nearest edge, with no spread.
        return (mu.clamp(a, b), 0.0);
    }
    let (pa, pb) = (density(alpha), density(beta));
    // x φ(x) → 0 at an infinite edge.
    let moment = |x: f64, p: f64| if x.is_infinite() { 0.0 } else { x * p };
    let shift = (pa - pb) / z;
    let spread = 1.0 + (moment(alpha, pa) - moment(beta, pb)) / z - shift * shift;
    (mu + sigma * shift, sigma * sigma * spread.max(0.0))
}

/// The standard normal density.
fn density(x: f64) -> f64 {
    if x.is_infinite() {
        return 0.0;
    }
    (-0.5 * x * x).exp() / (2.0 * PI).sqrt()
}

/// Φ(β) − Φ(α) for α ≤ β, from the tail on the side that keeps its digits.
fn normal_interval(alpha: f64, beta: f64) -> f64 {
    let upper_tail = |x: f64| 0.5 * libm::erfc(x * FRAC_1_SQRT_2);
    if alpha >= 0.0 {
        upper_tail(alpha) - upper_tail(beta)
    } else if beta <= 0.0 {
        upper_tail(-beta) - upper_tail(-alpha)
    } else {
        1.0 - upper_tail(-alpha) - upper_tail(beta)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate::testing::{
        exact_data, simulate, step_inputs, theta_error, two_state_model, with_noise,
    };
    use crate::estimate::{Estimator, ExceptionStorage};

    #[test]
    fn truncated_normal_moments_by_hand() {
        // Symmetric band ±1σ about μ: mean μ; variance σ²(1 − 2φ(1)/(2Φ(1) − 1)).
        let (mean, var) = truncated_normal(2.0, 0.5, 1.5, 2.5);
        let phi1 = (-0.5f64).exp() / (2.0 * PI).sqrt();
        let mass = 0.682_689_492_137_085_9;
        assert!((mean - 2.0).abs() < 1e-15);
        assert!(
            (var - 0.25 * (1.0 - 2.0 * phi1 / mass)).abs() < 1e-12,
            "{var}"
        );
        // Half-line [μ, ∞): mean μ + σ√(2/π), variance σ²(1 − 2/π).
        let (mean, var) = truncated_normal(0.0, 2.0, 0.0, f64::INFINITY);
        assert!((mean - 2.0 * (2.0 / PI).sqrt()).abs() < 1e-12);
        assert!((var - 4.0 * (1.0 - 2.0 / PI)).abs() < 1e-12);
        // A band 40σ away: its nearest edge.
        assert_eq!(truncated_normal(0.0, 0.1, 4.0, 5.0), (4.0, 0.0));
    }

    /// Keeps a value of each output when it moved more than `deadband` from the last
    /// kept one or `heartbeat` instants after it.
    fn by_exception(y: &DMatrix<f64>, deadband: f64, heartbeat: usize) -> DMatrix<bool> {
        let mut kept = DMatrix::from_element(y.nrows(), y.ncols(), false);
        for j in 0..y.ncols() {
            let mut last = (0, y[(0, j)]);
            kept[(0, j)] = true;
            for k in 1..y.nrows() {
                if (y[(k, j)] - last.1).abs() > deadband || k - last.0 >= heartbeat {
                    kept[(k, j)] = true;
                    last = (k, y[(k, j)]);
                }
            }
        }
        kept
    }

    fn exception_stored(y: DMatrix<f64>, u: DMatrix<f64>, deadband: f64) -> IdentificationData {
        let kept = by_exception(&y, deadband, 300);
        let storage = ExceptionStorage {
            deadband,
            max_interval: 300,
        };
        IdentificationData::complete(1.0, y, u)
            .with_output_observed(kept)
            .with_exception_storage(vec![Some(storage); 2])
    }

    #[test]
    fn noise_free_values_kept_by_exception_give_the_true_matrices() {
        let truth = two_state_model();
        let full = exact_data(&truth, 4000, 31);
        let data = exception_stored(full.outputs, full.inputs, 0.1);
        let seen = data
            .output_observed
            .as_ref()
            .unwrap()
            .iter()
            .filter(|&&o| o)
            .count();
        assert!(seen < 8000 / 4, "{seen} of 8000 kept");
        let e = OutputError::default().estimate(&data).unwrap();
        assert!(theta_error(&e.model, &truth) < 1e-6, "{:?}", e.model);
    }

    #[test]
    fn the_censored_instants_remove_the_bias_of_the_kept_values() {
        // σ = 0.01, deadband 2σ: a value is kept mostly because its noise left the band.
        // Fitted to the kept values alone the estimate is biased by many standard errors;
        // with the instants between them it is within its 95 % intervals.
        let truth = two_state_model();
        let u = step_inputs(40000, 2, 32);
        let y = with_noise(&simulate(&truth, &u, &[0.5, 0.2]), 0.01, 33);
        let data = exception_stored(y, u, 0.02);
        let kept_only = OutputError::default().refine(&data, &truth).unwrap();
        let censored = OutputError::default().estimate(&data).unwrap();
        let z = |e: &Estimate| -> f64 {
            let cov = e.covariance.as_ref().unwrap();
            e.model
                .theta()
                .iter()
                .zip(truth.theta())
                .enumerate()
                .map(|(q, (a, t))| (a - t).abs() / cov[(q, q)].sqrt())
                .fold(0.0, f64::max)
        };
        let (biased, corrected) = (z(&kept_only), z(&censored));
        assert!(
            biased > 5.0,
            "kept values alone: worst |error|/σ = {biased:.1}"
        );
        assert!(
            corrected < 3.0,
            "censored: worst |error|/σ = {corrected:.1}"
        );
        for v in &censored.noise_variance {
            assert!((v.sqrt() / 0.01 - 1.0).abs() < 0.05, "σ = {}", v.sqrt());
        }
    }
}
