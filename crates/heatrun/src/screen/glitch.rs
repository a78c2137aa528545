//! Glitches: a measured output far outside the measurement noise of the model's
//! prediction, against the residuals on both sides of it.
//!
//! The residual r(k) = y(k) − ŷ(k) of a model near the truth is measurement noise plus a
//! slow model error. A glitch is a spike: r(k) stands apart from the median of the
//! [`WINDOW`] residuals before it *and* of those after it, in the same direction. Either
//! side alone would also flag a step of the residual (a sensor that resumes after
//! freezing, a model error that changes at a load step); a spike departs from both. The
//! departure d(k) = the smaller of the two (0 if they differ in sign) is compared with
//! [`THRESHOLD`] times its noise scale σ_d = σ·√(1 + π/(2·WINDOW)) (a residual minus
//! the median of WINDOW others), σ the residuals' noise.
//!
//! The reading itself must spike as well (depart from both sides by as much): a thermal
//! mass does not let a temperature jump and come back, whereas a model that is wrong
//! for a few samples (a dead time it lacks, a transient it misses) leaves a bump in the
//! residual under a reading that moves smoothly, and that is the model's error to show,
//! not the data's to hide.

use super::robust::{median, sigma_mad};
use super::{predicted_reading, LeftOut, ScreenInput, Why};

/// Residuals on each side a sample is judged against (a window of 5 s at 1 s: shorter
/// than the fastest thermal time constant, long enough for a median that one neighbouring
/// glitch does not move).
pub const WINDOW: usize = 5;

/// A glitch departs from both sides by more than this many noise scales. For Gaussian
/// noise one side alone exceeds 7 σ_d with probability 2.6·10⁻¹²: a week at 1 s of three
/// outputs (1.8·10⁶ samples) expects 5·10⁻⁶ false glitches, which leaves room for
/// residuals heavier-tailed than Gaussian (quantisation, a model error at load steps).
pub const THRESHOLD: f64 = 7.0;

/// The smallest noise σ taken, K: a noise-free recording's residuals are rounding, and a
/// glitch is a departure a sensor could show, not one of 10⁻⁹ K.
pub const NOISE_FLOOR_K: f64 = 0.002;

/// σ of the residuals' measurement noise, K: 1.4826·MAD of their first differences / √2
/// (differences remove a slow model error; the MAD ignores the glitches themselves), at
/// least [`NOISE_FLOOR_K`] and the quantisation noise of `resolution_k` (r/√12).
pub fn noise_scale_k(residuals: &[Option<f64>], resolution_k: f64) -> f64 {
    let steps: Vec<f64> = residuals
        .windows(2)
        .filter_map(|w| Some(w[1]? - w[0]?))
        .collect();
    let sigma = if steps.is_empty() {
        0.0
    } else {
        sigma_mad(&steps) / std::f64::consts::SQRT_2
    };
    sigma.max(NOISE_FLOOR_K).max(resolution_k / 12f64.sqrt())
}

/// The departure d(k) of residual k from both sides (module doc), `None` where the
/// residual is unknown or a side has no residual.
pub fn departure(residuals: &[Option<f64>], k: usize) -> Option<f64> {
    let r = residuals[k]?;
    let before = side_departure(residuals, r, &mut (0..k).rev())?;
    let after = side_departure(residuals, r, &mut (k + 1..residuals.len()))?;
    Some(of_both_sides(before, after))
}

/// [`departure`] where it is larger than `limit` in size, else `None`. The departure is
/// never larger than its side before, so the side after is looked at only where the side
/// before departs by more than `limit`: the screen's usual instant needs one median.
fn departure_beyond(residuals: &[Option<f64>], k: usize, limit: f64) -> Option<f64> {
    let r = residuals[k]?;
    let before = side_departure(residuals, r, &mut (0..k).rev())?;
    if before.abs() <= limit {
        return None;
    }
    let after = side_departure(residuals, r, &mut (k + 1..residuals.len()))?;
    Some(of_both_sides(before, after)).filter(|d| d.abs() > limit)
}

/// r less the median of the first [`WINDOW`] known residuals `side` reaches, `None` where
/// it reaches none.
fn side_departure(
    residuals: &[Option<f64>],
    r: f64,
    side: &mut dyn Iterator<Item = usize>,
) -> Option<f64> {
    // The side's residuals in an array on the stack: this runs at every instant of every
    // output, and two allocations an instant were most of the screen's time.
    let mut v = [0.0; WINDOW];
    let mut held = 0;
    for value in side.filter_map(|i| residuals[i]).take(WINDOW) {
        v[held] = value;
        held += 1;
    }
    (held > 0).then(|| r - median(&mut v[..held]))
}

/// d = the smaller of the two sides' departures, 0 where they differ in sign.
fn of_both_sides(before: f64, after: f64) -> f64 {
    if before.signum() != after.signum() {
        return 0.0;
    }
    before.signum() * before.abs().min(after.abs())
}

/// Output j's glitches: runs of neighbouring instants whose residual departs by more
/// than [`THRESHOLD`]·σ_d and whose reading departs in the same direction by as much,
/// each a stretch; `residuals` and `readings` (the observed entries' values) in K.
pub fn find(
    input: &ScreenInput<'_>,
    j: usize,
    (residuals, readings): (&[Option<f64>], &[Option<f64>]),
    noise_k: f64,
) -> Vec<LeftOut> {
    let limit = THRESHOLD * noise_k * (1.0 + std::f64::consts::PI / (2.0 * WINDOW as f64)).sqrt();
    let mut out: Vec<LeftOut> = Vec::new();
    for k in 0..residuals.len() {
        let Some(d) = departure_beyond(residuals, k, limit) else {
            continue;
        };
        let spikes =
            departure(readings, k).is_some_and(|m| m.abs() > limit && m.signum() == d.signum());
        if !spikes {
            continue;
        }
        match out.last_mut() {
            Some(last) if last.to_index + 1 == k => {
                last.to_index = k;
                last.to_ns = input.time_ns[k];
                last.deviation_k = last.deviation_k.max(d.abs());
                last.predicted.push(predicted_reading(input, j, k));
            }
            _ => out.push(LeftOut {
                state: j,
                channel: input.channels[j].name.to_owned(),
                from_index: k,
                to_index: k,
                from_ns: input.time_ns[k],
                to_ns: input.time_ns[k],
                value: input.channels[j].measured.get(k).unwrap_or(f64::NAN),
                why: Why::Glitch,
                deviation_k: d.abs(),
                predicted: vec![predicted_reading(input, j, k)],
            }),
        }
    }
    out
}
