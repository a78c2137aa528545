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
/// entry already left out or missing neither breaks nor extends it).
pub fn find(input: &ScreenInput<'_>, j: usize, noise_k: f64, resolution_k: f64) -> Vec<LeftOut> {
    let measured = input.channels[j].measured;
    let seen: Vec<(usize, f64)> = (0..input.data.len())
        .filter(|&k| input.data.observed(k, j))
        .filter_map(|k| Some((k, measured.get(k)?)))
        .collect();
    let shortest = shortest_implausible_run(seen.len(), probability_equal(noise_k, resolution_k));
    let mut out = Vec::new();
    let mut start = 0;
    for i in 1..=seen.len() {
        let same = i < seen.len() && {
            let (a, b) = (seen[start].1, seen[i].1);
            (b - a).abs() <= 1e-9 * a.abs().max(1.0)
        };
        if same {
            continue;
        }
        let run = &seen[start..i];
        start = i;
        if run.len() < shortest {
            continue;
        }
        let change = predicted_change_k(input, j, run);
        if change > resolution_k + 3.0 * noise_k + CHANGE_FLOOR_K {
            let (first, last) = (run[0].0, run[run.len() - 1].0);
            out.push(LeftOut {
                state: j,
                channel: input.channels[j].name.to_owned(),
                from_index: first,
                to_index: last,
                from_ns: input.time_ns[first],
                to_ns: input.time_ns[last],
                value: run[0].1,
                why: Why::Frozen,
                deviation_k: change,
                predicted: (first..=last)
                    .map(|k| predicted_reading(input, j, k))
                    .collect(),
            });
        }
    }
    out
}

/// The change of the model's predicted reading over a run, K: the range of
/// θ̂(k) ([`predicted_reading`]) over its instants.
fn predicted_change_k(input: &ScreenInput<'_>, j: usize, run: &[(usize, f64)]) -> f64 {
    let (lo, hi) = run
        .iter()
        .map(|&(k, _)| predicted_reading(input, j, k))
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
