//! A slow channel stored by exception (a historian's deadband), reconstructed along its
//! course: the coolant inlet as the model's input or reference. A noise-free record gets
//! the smoothest course within its bands (below); a noisy one (its stored values scatter
//! about a smooth course by more than [`NOISE_FREE`]·d) the course of the record's
//! censored likelihood under the same smoothness penalty (`Stretch::censored`).
//!
//! A historian keeps a value only when it left the deadband ±d of the last kept value
//! (or a heartbeat passed). The kept points are therefore not a sample of the course:
//! each is where the value crossed the band's edge, and between two of them the value
//! stayed within ±d of the earlier one. A line or a local quadratic through the kept
//! points takes neither fact into account (issue 33: a historian export whose inlet
//! drifts 1 K along a slow wave, 0.05 K deadband, gave T1 3.8 % off; every sample kept,
//! 0.35 %). Here the course x_k on the grid is the smoothest one the record allows:
//!
//!   minimise  λ·Σ_k (x_{k−1} − 2·x_k + x_{k+1})²  +  Σ_{k stored} (x_k − v_k)²
//!   subject to  lo_k ≤ x_k ≤ hi_k,
//!
//! where, with v_i the last value stored at or before instant k and h = d + 2σ̂ (σ̂ the
//! sensor's noise, estimated from the stored points: the band holds the noisy reading,
//! not the course),
//!
//! - between stored instants: [lo_k, hi_k] = [v_i − h, v_i + h] (within the band of the
//!   last stored value),
//! - at a stored instant whose value left the band upwards: lo_k = v_i + d − 2σ̂ (it
//!   crossed the upper edge), downwards: hi_k = v_i − d + 2σ̂; a heartbeat's store (a
//!   value within the band) has no bound beyond its own value's weight,
//!
//! and λ = (P_c / (2π·Ts))⁴ sets the smoothing of the stored values' noise at periods
//! below P_c = [`CUTOFF_PERIOD_S`] (the half-power period of a Whittaker smoother). The
//! problem is a small banded quadratic programme: the normal equations of the
//! unconstrained part are pentadiagonal (λ·D₂ᵀD₂ + W), solved by a banded LDLᵀ in O(n),
//! and the bounds are met by an active set (a violated bound is held, a held bound whose
//! course would leave it inwards is released), at most [`MAX_ACTIVE_SET_ROUNDS`] rounds,
//! the result clipped into the bounds.

use crate::estimate::oe::censored::truncated_normal;
use crate::series::Series;

/// The half-power period of the reconstruction's smoothing, s: as the local quadratic
/// over ±60 s the sampled inlet is taken through (`signals::INLET_SMOOTHING_S`; a
/// 121-point quadratic's half-power period is about 128 s), so that a noisy value
/// stored by exception is smoothed as much as a noisy sampled one, while any change of
/// the inlet slower than a few minutes is followed.
pub const CUTOFF_PERIOD_S: f64 = 128.0;

/// The most rounds of the active set: each is one banded solve; a course that has not
/// settled by then is clipped into its bounds.
pub const MAX_ACTIVE_SET_ROUNDS: usize = 200;

/// A record whose stored values scatter about the smooth course through them by at most
/// this share of the deadband is taken as noise-free: the course is the smoothest within
/// the bands (active set); a noisier one's is its likelihood's (`Stretch::censored`).
pub const NOISE_FREE: f64 = 0.05;

/// The most rounds of the censored record's scoring.
pub const MAX_SCORING_ROUNDS: usize = 50;

/// A censored instant whose information share is below this is left out (its band says
/// next to nothing about the course there).
const MIN_INFORMATION: f64 = 1e-6;

/// A channel on the grid stored by exception: its values (unknown where there is no
/// record), the instants holding a stored value, and the deadband.
#[derive(Debug, Clone, Copy)]
pub struct ExceptionRecord<'a> {
    /// The value at each instant: stored where `stored`, anything in between (the
    /// decimator's line or the held value; only its being known is read there).
    pub values: &'a Series,
    /// Whether instant k holds a stored value.
    pub stored: &'a [bool],
    /// The deadband d in the channel's unit: declared, or [`estimated_deadband`].
    pub deadband: f64,
}

/// Why a record cannot be reconstructed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DeadbandError {
    /// The stored flags and the values are of different lengths.
    #[error("{stored} stored flags for {values} values")]
    Lengths {
        /// Flags.
        stored: usize,
        /// Values.
        values: usize,
    },
    /// The deadband is not a number ≥ 0.
    #[error("the deadband {0} is not a number ≥ 0")]
    Deadband(f64),
}

/// The course of `record` on the grid of `ts_s` (see the module's text): known where the
/// record's values are known, each stretch of known instants reconstructed on its own.
pub fn course(record: ExceptionRecord, ts_s: f64) -> Result<Series, DeadbandError> {
    let n = record.values.len();
    if record.stored.len() != n {
        return Err(DeadbandError::Lengths {
            stored: record.stored.len(),
            values: n,
        });
    }
    if !(record.deadband.is_finite() && record.deadband >= 0.0) {
        return Err(DeadbandError::Deadband(record.deadband));
    }
    let lambda = (CUTOFF_PERIOD_S / (2.0 * std::f64::consts::PI * ts_s)).powi(4);
    let mut out = Series::unknown(n);
    let mut k = 0;
    while k < n {
        if record.values.get(k).is_none() {
            k += 1;
            continue;
        }
        let start = k;
        while k < n && record.values.get(k).is_some() {
            k += 1;
        }
        let stretch = Stretch::new(record, start..k);
        for (j, x) in stretch.reconstruct(lambda).into_iter().enumerate() {
            out.set(start + j, Some(x));
        }
    }
    Ok(out)
}

/// The deadband of a value held between changes (a historian's export repeating the
/// last kept value on every row, with no deadband declared): the median size of its
/// changes, each a crossing of the band's edge (d plus what the value moved past it in
/// one sample, so at least d: a band so taken holds the course). `None` where fewer than
/// `min_changes` changes are known.
pub fn estimated_deadband(values: &Series, min_changes: usize) -> Option<f64> {
    let mut last: Option<f64> = None;
    let mut jumps: Vec<f64> = Vec::new();
    for v in values.iter() {
        match (last, v) {
            (Some(a), Some(b)) if a != b => jumps.push((b - a).abs()),
            _ => {}
        }
        if v.is_some() {
            last = v;
        }
    }
    if jumps.len() < min_changes {
        return None;
    }
    jumps.sort_by(f64::total_cmp);
    Some(jumps[jumps.len() / 2])
}

/// One stretch of known instants: the stored values and the bounds they set.
struct Stretch {
    /// The grid's value at each instant of the stretch.
    values: Vec<f64>,
    /// Stored value at each instant of the stretch, where one is stored.
    stored: Vec<Option<f64>>,
    /// The band's half-width d.
    deadband: f64,
}

impl Stretch {
    fn new(record: ExceptionRecord, range: std::ops::Range<usize>) -> Stretch {
        // A value stored again unchanged adds nothing the band does not say (a table
        // repeating the kept value on every row, declared stored by exception).
        let mut last: Option<f64> = None;
        let values = range
            .clone()
            .map(|k| record.values.get(k).unwrap_or(f64::NAN))
            .collect();
        let stored = range
            .map(|k| {
                let v = record.values.get(k).filter(|_| record.stored[k])?;
                let new = last != Some(v);
                last = Some(v);
                new.then_some(v)
            })
            .collect();
        Stretch {
            values,
            stored,
            deadband: record.deadband,
        }
    }

    /// The bounds [lo_k, hi_k] at each instant for a noise of `sigma` (module text).
    fn bounds(&self, sigma: f64) -> Vec<(f64, f64)> {
        let d = self.deadband;
        let slack = 2.0 * sigma;
        let mut last: Option<f64> = None;
        self.stored
            .iter()
            .map(|v| {
                let bound = match (last, v) {
                    (None, _) => (f64::NEG_INFINITY, f64::INFINITY),
                    (Some(a), None) => (a - d - slack, a + d + slack),
                    (Some(a), Some(b)) if *b > a + d => (a + d - slack, f64::INFINITY),
                    (Some(a), Some(b)) if *b < a - d => (f64::NEG_INFINITY, a - d + slack),
                    (Some(_), Some(_)) => (f64::NEG_INFINITY, f64::INFINITY),
                };
                if v.is_some() {
                    last = *v;
                }
                bound
            })
            .collect()
    }

    fn reconstruct(&self, lambda: f64) -> Vec<f64> {
        let n = self.stored.len();
        let kept = self.stored.iter().flatten().count();
        // Too short to bend, or at most one value stored: as the grid holds it.
        if n < 3 || kept < 2 {
            return self.values.clone();
        }
        let free = Smoother::new(&self.stored, lambda).solve(&[]);
        let sigma = noise_of(&self.stored, &free);
        let bounds = self.bounds(sigma);
        let course = active_set(&self.stored, lambda, &bounds);
        if sigma <= NOISE_FREE * self.deadband {
            return course;
        }
        self.censored(course, sigma, lambda)
    }

    /// The band of the last stored value at each unstored instant, where there is one.
    fn bands(&self) -> Vec<Option<(f64, f64)>> {
        let d = self.deadband;
        let mut last: Option<f64> = None;
        self.stored
            .iter()
            .map(|v| {
                let band = match (last, v) {
                    (Some(a), None) => Some((a - d, a + d)),
                    _ => None,
                };
                if v.is_some() {
                    last = *v;
                }
                band
            })
            .collect()
    }

    /// The course maximising the record's likelihood under the smoothness penalty, for a
    /// noisy reading m = x + e, e ~ N(0, σ²) (as `estimate::oe::censored` does for an
    /// output): each stored value is an exact reading, each instant between two a reading
    /// within the band [v − d, v + d] (censored), so that
    ///
    ///   maximise  Σ_stored ln φ((m_k − x_k)/σ) + Σ_between ln[Φ(β_k) − Φ(α_k)] − λ/(2σ²)·‖D₂x‖²,
    ///   α_k, β_k = (v ∓ d − x_k)/σ.
    ///
    /// The stored values alone are a biased sample (a reading is stored because its noise
    /// carried it out of the band, which on a rising inlet favours readings above the
    /// course); the instants between carry the correction. Fisher scoring: each round
    /// smooths the stored values (weight 1) and each censored instant's working value
    /// x + (E[m | band] − x)/e (weight e = 1 − Var[m | band]/σ²) at the current course,
    /// and σ² is the mean of (m − x)² over stored values and E[(m − x)² | band] over
    /// censored ones (the EM update), until the course moves less than 10⁻⁴·d.
    fn censored(&self, start: Vec<f64>, sigma: f64, lambda: f64) -> Vec<f64> {
        let bands = self.bands();
        let mut x = start;
        let mut sigma = sigma;
        for _ in 0..MAX_SCORING_ROUNDS {
            let mut smoother = Smoother::new(&self.stored, lambda);
            let (mut squares, mut count) = (0.0, 0usize);
            for (k, band) in bands.iter().enumerate() {
                if let Some(m) = self.stored[k] {
                    squares += (m - x[k]).powi(2);
                    count += 1;
                    continue;
                }
                let Some((lo, hi)) = band else { continue };
                let (mean, variance) = truncated_normal(x[k], sigma, *lo, *hi);
                squares += variance + (mean - x[k]).powi(2);
                count += 1;
                let e = 1.0 - variance / (sigma * sigma);
                if e > MIN_INFORMATION {
                    smoother.weights[k] = e;
                    smoother.targets[k] = x[k] + (mean - x[k]) / e;
                }
            }
            let next = smoother.solve(&[]);
            let moved = next
                .iter()
                .zip(&x)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            x = next;
            if count > 0 {
                sigma = (squares / count as f64)
                    .sqrt()
                    .max(NOISE_FREE * self.deadband);
            }
            if moved < 1e-4 * self.deadband {
                break;
            }
        }
        x
    }
}

/// σ̂: the stored values' spread about the smooth course through them (1.4826 × the
/// median absolute residual: a Gaussian's σ, robust to a few crossings the smoothing
/// cuts).
fn noise_of(stored: &[Option<f64>], course: &[f64]) -> f64 {
    let mut r: Vec<f64> = stored
        .iter()
        .zip(course)
        .filter_map(|(v, x)| Some((v.as_ref()? - x).abs()))
        .collect();
    if r.is_empty() {
        return 0.0;
    }
    r.sort_by(f64::total_cmp);
    1.4826 * r[r.len() / 2]
}

/// The course that meets `bounds`: each round solves with the held bounds as stiff
/// targets, holds every bound the course leaves, and releases a held bound the course
/// would leave inwards (the bound no longer pushes it).
fn active_set(stored: &[Option<f64>], lambda: f64, bounds: &[(f64, f64)]) -> Vec<f64> {
    let smoother = Smoother::new(stored, lambda);
    let mut held: Vec<Option<f64>> = vec![None; stored.len()];
    let mut x = smoother.solve(&[]);
    for _ in 0..MAX_ACTIVE_SET_ROUNDS {
        let mut changed = false;
        for (k, &(lo, hi)) in bounds.iter().enumerate() {
            match held[k] {
                // A band of no width (deadband 0, no noise) is held for good.
                Some(b) if lo < hi && ((b == hi && x[k] < hi) || (b == lo && x[k] > lo)) => {
                    held[k] = None;
                    changed = true;
                }
                Some(_) => {}
                None if x[k] > hi => {
                    held[k] = Some(hi);
                    changed = true;
                }
                None if x[k] < lo => {
                    held[k] = Some(lo);
                    changed = true;
                }
                None => {}
            }
        }
        if !changed {
            break;
        }
        let targets: Vec<(usize, f64)> = held
            .iter()
            .enumerate()
            .filter_map(|(k, b)| Some((k, (*b)?)))
            .collect();
        x = smoother.solve(&targets);
    }
    x.iter()
        .zip(bounds)
        .map(|(x, &(lo, hi))| x.clamp(lo, hi))
        .collect()
}

/// The pentadiagonal normal equations (λ·D₂ᵀD₂ + W + S)·x = W·v + S·b, W each instant's
/// weight w_k on its target v_k (1 on a stored value, 0 where none, a censored instant's
/// information share), S a stiff weight at each held bound b.
struct Smoother {
    weights: Vec<f64>,
    targets: Vec<f64>,
    lambda: f64,
}

impl Smoother {
    /// Unit weights on the stored values.
    fn new(stored: &[Option<f64>], lambda: f64) -> Smoother {
        Smoother {
            weights: stored
                .iter()
                .map(|v| if v.is_some() { 1.0 } else { 0.0 })
                .collect(),
            targets: stored.iter().map(|v| v.unwrap_or(0.0)).collect(),
            lambda,
        }
    }

    /// The solution with the instants `held` pinned at their values.
    fn solve(&self, held: &[(usize, f64)]) -> Vec<f64> {
        let n = self.weights.len();
        let l = self.lambda;
        // D₂ᵀD₂'s bands: each second difference (k−1, k, k+1) adds [1 −2 1]ᵀ[1 −2 1].
        let mut a0 = vec![0.0; n];
        let mut a1 = vec![0.0; n];
        let mut a2 = vec![0.0; n];
        for c in 1..n - 1 {
            a0[c - 1] += l;
            a0[c] += 4.0 * l;
            a0[c + 1] += l;
            a1[c - 1] -= 2.0 * l;
            a1[c] -= 2.0 * l;
            a2[c - 1] += l;
        }
        let mut b = vec![0.0; n];
        let weighted = self.weights.iter().zip(&self.targets);
        for ((a, b), (w, t)) in a0.iter_mut().zip(b.iter_mut()).zip(weighted) {
            *a += w;
            *b += w * t;
        }
        // Stiff, but within what f64 solves: 10⁶ times the largest curvature weight.
        let stiff = 1e6 * (16.0 * l + 1.0);
        for &(k, target) in held {
            a0[k] += stiff;
            b[k] += stiff * target;
        }
        banded_solve(&a0, &a1, &a2, &b)
    }
}

/// Solves the symmetric positive definite pentadiagonal system with diagonal `a0`, first
/// and second off-diagonals `a1`, `a2` (a1[k] = M[k+1][k], a2[k] = M[k+2][k]) by LDLᵀ:
/// d_k = a0_k − l1_k²·d_{k−1} − l2_k²·d_{k−2}, l1_{k+1} = (a1_k − l2_{k+1}·l1_k·d_{k−1})/d_k,
/// l2_{k+2} = a2_k/d_k; then L·y = b, x = L⁻ᵀ·D⁻¹·y.
fn banded_solve(a0: &[f64], a1: &[f64], a2: &[f64], b: &[f64]) -> Vec<f64> {
    let n = a0.len();
    let (mut d, mut l1, mut l2) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for k in 0..n {
        let mut dk = a0[k];
        if k >= 1 {
            dk -= l1[k] * l1[k] * d[k - 1];
        }
        if k >= 2 {
            dk -= l2[k] * l2[k] * d[k - 2];
        }
        d[k] = dk;
        if k + 1 < n {
            let coupled = if k >= 1 {
                l2[k + 1] * l1[k] * d[k - 1]
            } else {
                0.0
            };
            l1[k + 1] = (a1[k] - coupled) / dk;
        }
        if k + 2 < n {
            l2[k + 2] = a2[k] / dk;
        }
    }
    let mut y = b.to_vec();
    for k in 0..n {
        if k >= 1 {
            y[k] -= l1[k] * y[k - 1];
        }
        if k >= 2 {
            y[k] -= l2[k] * y[k - 2];
        }
    }
    for (y, d) in y.iter_mut().zip(&d) {
        *y /= d;
    }
    for k in (0..n).rev() {
        if k + 1 < n {
            y[k] -= l1[k + 1] * y[k + 1];
        }
        if k + 2 < n {
            y[k] -= l2[k + 2] * y[k + 2];
        }
    }
    y
}

#[cfg(test)]
mod tests;
