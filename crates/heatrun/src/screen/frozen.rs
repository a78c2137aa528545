//! Frozen sensors: a run of identical values far longer than the channel's noise and
//! resolution allow, while the model says the value should have changed.
//!
//! Two readings of a channel with Gaussian noise σ quantised at resolution r are equal
//! with probability p = E[max(0, 1 − |d|/r)], d ~ N(0, 2σ²) (the two values fall in one
//! step of r): with x = r/(√2·σ),
//! p = (2Φ(x) − 1) − 2/(x·√(2π))·(1 − e^(−x²/2))
//! (≈ r/(2√π·σ) for σ ≫ r; 1 for σ ≪ r, where equal readings say nothing). A signal that
//! moves only makes equal readings rarer, so p bounds them. A run of L identical values
//! among the N of the channel is implausible as noise when N·p^(L−1) < [`FALSE_RUNS`]:
//! the expected number of such runs in the channel. It is left out only if the model
//! also predicts that the value moved over the run by more than the resolution, three
//! noise σ and [`CHANGE_FLOOR_K`]: a sensor at a true steady state reads one value too.

use super::robust::normal_cdf;
use super::{predicted_reading, LeftOut, ScreenInput, Why};

/// The expected number of runs, in a channel of clean noise, as long as one left out.
pub const FALSE_RUNS: f64 = 1e-3;

/// The least change, K, the model must predict over a run for it to be left out: a
/// frozen value that the truth stays within this of biases nothing.
pub const CHANGE_FLOOR_K: f64 = 0.05;

/// p: the probability that two readings are equal (module doc).
pub fn probability_equal(noise_k: f64, resolution_k: f64) -> f64 {
    if resolution_k <= 0.0 {
        return 0.0;
    }
    if noise_k <= 0.0 {
        return 1.0;
    }
    let x = resolution_k / (std::f64::consts::SQRT_2 * noise_k);
    let p = (2.0 * normal_cdf(x) - 1.0)
        - 2.0 / (x * (2.0 * std::f64::consts::PI).sqrt()) * (1.0 - (-0.5 * x * x).exp());
    p.clamp(0.0, 1.0)
}

/// The shortest run of identical values among `count` readings that noise alone makes
/// implausible: the least L with count·p^(L−1) < [`FALSE_RUNS`] (`usize::MAX` if p = 1).
pub fn shortest_implausible_run(count: usize, p: f64) -> usize {
    if p >= 1.0 {
        return usize::MAX;
    }
    if p <= 0.0 {
        return 2;
    }
    let steps = ((FALSE_RUNS / count.max(1) as f64).ln() / p.ln()).floor() as usize + 1;
    steps + 1
}

/// Output j's frozen runs. A run is over the instants where the output is observed (an
/// entry already left out or missing neither breaks nor extends it). The readings are
/// walked twice (counted, then read run by run), never collected: on a week at 1 s they
/// were 9.7 MB an output, at the replay's peak.
pub fn find(input: &ScreenInput<'_>, j: usize, noise_k: f64, resolution_k: f64) -> Vec<LeftOut> {
    let seen = || readings(input, j);
    let shortest =
        shortest_implausible_run(seen().count(), probability_equal(noise_k, resolution_k));
    let mut out = Vec::new();
    let mut run: Option<Run> = None;
    for (k, value) in seen() {
        match run.as_mut() {
            Some(r) if (value - r.value).abs() <= 1e-9 * r.value.abs().max(1.0) => {
                r.last = k;
                r.readings += 1;
            }
            _ => {
                out.extend(
                    run.take()
                        .and_then(|r| judged(input, j, r, shortest, (noise_k, resolution_k))),
                );
                run = Some(Run {
                    first: k,
                    last: k,
                    value,
                    readings: 1,
                });
            }
        }
    }
    out.extend(run.and_then(|r| judged(input, j, r, shortest, (noise_k, resolution_k))));
    out
}

/// Output j's readings where it is observed, (instant, value) in time order.
fn readings<'a>(input: &'a ScreenInput<'_>, j: usize) -> impl Iterator<Item = (usize, f64)> + 'a {
    let measured = input.channels[j].measured;
    (0..input.data.len())
        .filter(move |&k| input.data.observed(k, j))
        .filter_map(move |k| Some((k, measured.get(k)?)))
}

/// A run of equal readings: its first and last instant, its value, its length in readings.
#[derive(Debug, Clone, Copy)]
struct Run {
    first: usize,
    last: usize,
    value: f64,
    readings: usize,
}

/// The run as a frozen stretch, where it is at least `shortest` readings long and the
/// model predicts a change over it beyond resolution, noise and [`CHANGE_FLOOR_K`].
fn judged(
    input: &ScreenInput<'_>,
    j: usize,
    run: Run,
    shortest: usize,
    (noise_k, resolution_k): (f64, f64),
) -> Option<LeftOut> {
    if run.readings < shortest {
        return None;
    }
    let measured = input.channels[j].measured;
    let instants =
        (run.first..=run.last).filter(|&k| input.data.observed(k, j) && measured.get(k).is_some());
    let change = predicted_change_k(input, j, instants);
    (change > resolution_k + 3.0 * noise_k + CHANGE_FLOOR_K).then(|| LeftOut {
        state: j,
        channel: input.channels[j].name.to_owned(),
        from_index: run.first,
        to_index: run.last,
        from_ns: input.time_ns[run.first],
        to_ns: input.time_ns[run.last],
        value: run.value,
        why: Why::Frozen,
        deviation_k: change,
        predicted: (run.first..=run.last)
            .map(|k| predicted_reading(input, j, k))
            .collect(),
    })
}

/// The change of the model's predicted reading over a run, K: the range of
/// θ̂(k) ([`predicted_reading`]) over its instants.
fn predicted_change_k(
    input: &ScreenInput<'_>,
    j: usize,
    instants: impl Iterator<Item = usize>,
) -> f64 {
    let (lo, hi) = instants
        .map(|k| predicted_reading(input, j, k))
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if hi >= lo {
        hi - lo
    } else {
        0.0
    }
}
