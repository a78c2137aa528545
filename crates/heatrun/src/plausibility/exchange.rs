//! Two temperature channels exchanged mid-run (a terminal block re-wired, a historian
//! tag re-mapped during the test).
//!
//! A thermal mass changes its temperature continuously: two parts cannot step at one
//! instant by the same amount in opposite directions, each landing on the other's level.
//! Where two temperature channels do, from instant s on each carries the other's sensor:
//! with a and b the channels' levels just before s (the median of the last
//! [`LEVEL_SAMPLES`] known values) and a', b' just after (the next ones),
//!
//! |a' − b| < [`MATCH_SHARE`]·|a − b|,  |b' − a| < [`MATCH_SHARE`]·|a − b|,
//! |a − b| > max([`MIN_GAP_K`], [`NOISE_SIGMAS`]·σ),
//!
//! σ the larger of the two channels' robust noise (1.4826·median |Δx| / √2). The
//! exchange is undone on the grid — the two series swapped from s on — before the signals
//! are made, so that the estimate sees each part's own sensor; the instant is named.

use super::{grid_time, Action, Check, Finding};
use crate::decimate::DecimatedRecording;
use crate::recording::Signal;

/// Known values either side of an instant whose median is the channel's level there.
pub const LEVEL_SAMPLES: usize = 5;
/// The farthest those values may lie from the instant, s.
pub const LEVEL_SPAN_S: f64 = 600.0;
/// The smallest difference of two channels an exchange must show, K.
pub const MIN_GAP_K: f64 = 2.0;
/// The difference must also exceed this many of the channels' noise σ.
pub const NOISE_SIGMAS: f64 = 20.0;
/// Each channel's level after the instant lies within this share of the difference of
/// the other's level before it.
pub const MATCH_SHARE: f64 = 0.2;

/// A channel's values the check reads: known, and where the channel was stored by
/// exception, stored at that instant (an interpolated value between stored samples would
/// turn a step into a ramp).
fn readings(decimated: &DecimatedRecording, signal: &Signal) -> Known {
    let s = &decimated.series[signal];
    Known::from_iter((0..decimated.len).map(|k| {
        let seen = s.observed.as_ref().is_none_or(|o| o[k]);
        s.values.get(k).filter(|_| seen)
    }))
}

/// A value or none at each instant, none stored as NaN: 8 bytes an instant where an
/// `Option<f64>` takes 16. Each channel holds three such series (its readings and its
/// levels either side): on a week at 1 s the four temperatures' twelve took 116 MB as
/// options (heaptrack, the week at 100 Hz), beside the grid and the model's signals, near
/// the replay's peak of heap (169 MB, in a later stage). A NaN reading, which no grid
/// holds, would read as none.
struct Known(Vec<f64>);

impl Known {
    /// The value at instant `k`, if known.
    fn get(&self, k: usize) -> Option<f64> {
        let v = self.0[k];
        (!v.is_nan()).then_some(v)
    }

    fn len(&self) -> usize {
        self.0.len()
    }
}

impl FromIterator<Option<f64>> for Known {
    fn from_iter<I: IntoIterator<Item = Option<f64>>>(values: I) -> Known {
        Known(values.into_iter().map(|v| v.unwrap_or(f64::NAN)).collect())
    }
}

/// The robust noise σ of a channel from its successive known differences.
fn noise(x: &Known) -> f64 {
    let mut d: Vec<f64> = (1..x.len())
        .filter_map(|k| Some((x.get(k)? - x.get(k - 1)?).abs()))
        .collect();
    if d.is_empty() {
        return 0.0;
    }
    let n = d.len();
    let (_, m, _) = d.select_nth_unstable_by(n / 2, f64::total_cmp);
    1.4826 * *m / std::f64::consts::SQRT_2
}

/// The median of up to [`LEVEL_SAMPLES`] known values taken from `indices` in order,
/// `None` with fewer than three. Gathered on the stack: it is asked twice an instant for
/// each channel (a week at 1 s made 25 million allocations of it).
fn level(x: &Known, indices: impl Iterator<Item = usize>) -> Option<f64> {
    let mut kept = [0.0; LEVEL_SAMPLES];
    let mut n = 0;
    for value in indices.filter_map(|k| x.get(k)).take(LEVEL_SAMPLES) {
        kept[n] = value;
        n += 1;
    }
    let v = &mut kept[..n];
    if v.len() < 3 {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some(v[v.len() / 2])
}

/// What the check reads of one channel, taken once for every pair it is in: its
/// readings, its robust noise σ and its level either side of each instant k — the median
/// of the last known values before k (`before`) and of the next ones after it (`after`),
/// [`LEVEL_SAMPLES`] of each within `reach` instants.
struct Channel {
    readings: Known,
    noise: f64,
    before: Known,
    after: Known,
}

impl Channel {
    fn of(readings: Known, reach: usize) -> Channel {
        let len = readings.len();
        let before = (0..len)
            .map(|k| level(&readings, (k.saturating_sub(reach)..k).rev()))
            .collect();
        let after = (0..len)
            .map(|k| level(&readings, (k + 1)..(k + 1 + reach).min(len)))
            .collect();
        Channel {
            noise: noise(&readings),
            readings,
            before,
            after,
        }
    }
}

/// The instants either side of one whose known values make a level there.
fn reach(ts_s: f64) -> usize {
    ((LEVEL_SPAN_S / ts_s).ceil() as usize).max(LEVEL_SAMPLES)
}

/// An exchange found: from instant `at` on, the two channels carry each other's values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Exchange {
    /// The first grid instant exchanged.
    pub at: usize,
    /// The first channel's level just before, °C.
    pub a_before: f64,
    /// The second channel's level just before, °C.
    pub b_before: f64,
}

/// The first exchange of `a` and `b` at or after instant `from`, on a grid of `ts_s`.
pub fn find(a: &[Option<f64>], b: &[Option<f64>], ts_s: f64, from: usize) -> Option<Exchange> {
    let len = a.len().min(b.len());
    let (a, b) = (
        Channel::of(a[..len].iter().copied().collect(), reach(ts_s)),
        Channel::of(b[..len].iter().copied().collect(), reach(ts_s)),
    );
    find_between(&a, &b, from)
}

/// [`find`] of two channels read (both over the same instants).
fn find_between(a: &Channel, b: &Channel, from: usize) -> Option<Exchange> {
    let len = a.readings.len();
    let floor = MIN_GAP_K.max(NOISE_SIGMAS * a.noise.max(b.noise));
    for k in from.max(1)..len.saturating_sub(1) {
        let (Some(a0), Some(b0)) = (a.before.get(k), b.before.get(k)) else {
            continue;
        };
        let gap = a0 - b0;
        if gap.abs() <= floor {
            continue;
        }
        let (Some(a1), Some(b1)) = (a.after.get(k), b.after.get(k)) else {
            continue;
        };
        if (a1 - b0).abs() < MATCH_SHARE * gap.abs() && (b1 - a0).abs() < MATCH_SHARE * gap.abs() {
            // The first k the windows show it at lies before the exchange (the values
            // ahead are mostly exchanged already): the first instant from k whose reading
            // of `a` lies nearer `b`'s old level is the one exchanged.
            let at = (k..len)
                .find(|&j| {
                    a.readings
                        .get(j)
                        .is_some_and(|v| (v - b0).abs() < (v - a0).abs())
                })
                .unwrap_or(k);
            return Some(Exchange {
                at,
                a_before: a0,
                b_before: b0,
            });
        }
    }
    None
}

/// Finds every exchange among the recording's temperature channels (unit °C), swaps each
/// pair back from its instant on, and says so: one finding per exchange.
pub fn undo(decimated: &mut DecimatedRecording) -> Vec<Finding> {
    let temperatures: Vec<Signal> = decimated
        .series
        .iter()
        .filter(|(_, s)| s.unit == "degC")
        .map(|(signal, _)| signal.clone())
        .collect();
    let reach = reach(decimated.ts_s());
    let read = |decimated: &DecimatedRecording, signal: &Signal| {
        Channel::of(readings(decimated, signal), reach)
    };
    // Each channel's levels are its own: read side by side, on rayon's threads.
    let mut channels: Vec<Channel> = {
        use rayon::prelude::*;
        let shared: &DecimatedRecording = decimated;
        temperatures.par_iter().map(|s| read(shared, s)).collect()
    };
    let mut findings = Vec::new();
    for i in 0..temperatures.len() {
        for j in i + 1..temperatures.len() {
            let (first, second) = (&temperatures[i], &temperatures[j]);
            let mut from = 0;
            // A wire exchanged back later is found again once the first is undone.
            while let Some(e) = find_between(&channels[i], &channels[j], from) {
                swap_from(decimated, first, second, e.at);
                findings.push(finding(decimated, first, second, &e));
                channels[i] = read(decimated, first);
                channels[j] = read(decimated, second);
                from = e.at + 1;
            }
        }
    }
    findings
}

/// Exchanges the two series' values (and stored-sample marks) from instant `at` on.
fn swap_from(decimated: &mut DecimatedRecording, a: &Signal, b: &Signal, at: usize) {
    let mut sb = decimated
        .series
        .remove(b)
        .expect("a series of the recording");
    let sa = decimated
        .series
        .get_mut(a)
        .expect("a series of the recording");
    for k in at..decimated.len {
        let (va, vb) = (sa.values.get(k), sb.values.get(k));
        sa.values.set(k, vb);
        sb.values.set(k, va);
    }
    if let (Some(oa), Some(ob)) = (sa.observed.as_mut(), sb.observed.as_mut()) {
        for k in at..decimated.len {
            std::mem::swap(&mut oa[k], &mut ob[k]);
        }
    }
    decimated.series.insert(b.clone(), sb);
}

fn finding(decimated: &DecimatedRecording, a: &Signal, b: &Signal, e: &Exchange) -> Finding {
    let time = grid_time(decimated, e.at);
    let step = e.b_before - e.a_before;
    Finding {
        check: Check::ExchangedMidRun,
        channels: vec![a.name().to_owned(), b.name().to_owned()],
        time: Some(time.clone()),
        cause: "the two sensors' wires or tags exchanged during the run".into(),
        action: Action::Corrected,
        message: format!(
            "{a} and {b} exchange their values at {time}: {a} steps {step:+.2} K and {b} \
             {:+.2} K at one instant, each landing on the other's level, which no thermal \
             mass allows (likely the two sensors' wires or tags exchanged during the run); \
             swapped back from that instant on",
            -step
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two first-order rises with a little deterministic ripple, exchanged from `at` on.
    fn pair(len: usize, at: Option<usize>) -> (Vec<Option<f64>>, Vec<Option<f64>>) {
        let ripple = |k: usize| 0.05 * ((k as f64) * 1.7).sin();
        let a: Vec<f64> = (0..len)
            .map(|k| 10.0 + 60.0 * (1.0 - (-(k as f64) / 700.0).exp()) + ripple(k))
            .collect();
        let b: Vec<f64> = (0..len)
            .map(|k| 10.0 + 35.0 * (1.0 - (-(k as f64) / 3000.0).exp()) + ripple(k + 7))
            .collect();
        let (mut a2, mut b2) = (a.clone(), b.clone());
        if let Some(at) = at {
            a2[at..].copy_from_slice(&b[at..]);
            b2[at..].copy_from_slice(&a[at..]);
        }
        (
            a2.into_iter().map(Some).collect(),
            b2.into_iter().map(Some).collect(),
        )
    }

    #[test]
    fn an_exchange_is_found_at_its_instant() {
        let (a, b) = pair(8000, Some(5000));
        let e = find(&a, &b, 1.0, 0).unwrap();
        assert_eq!(e.at, 5000);
        assert!(e.a_before > e.b_before + 10.0);
        // Swapped back, nothing is left to find.
        let (mut a, mut b) = (a, b);
        for k in e.at..a.len() {
            std::mem::swap(&mut a[k], &mut b[k]);
        }
        assert!(find(&a, &b, 1.0, 0).is_none());
        assert_eq!(a, pair(8000, None).0);
    }

    #[test]
    fn rises_that_cross_or_step_together_are_no_exchange() {
        let (a, b) = pair(8000, None);
        assert!(find(&a, &b, 1.0, 0).is_none());
        // A load step: both jump the same way at once.
        let a: Vec<Option<f64>> = a
            .iter()
            .enumerate()
            .map(|(k, v)| v.map(|v| v + if k >= 4000 { 8.0 } else { 0.0 }))
            .collect();
        let b: Vec<Option<f64>> = b
            .iter()
            .enumerate()
            .map(|(k, v)| v.map(|v| v + if k >= 4000 { 5.0 } else { 0.0 }))
            .collect();
        assert!(find(&a, &b, 1.0, 0).is_none());
        // Two channels a kelvin apart swapping are within noise of each other: no finding.
        let c: Vec<Option<f64>> = (0..3000)
            .map(|k| Some(20.0 + if k < 1500 { 0.0 } else { 1.0 }))
            .collect();
        let d: Vec<Option<f64>> = (0..3000)
            .map(|k| Some(21.0 - if k < 1500 { 0.0 } else { 1.0 }))
            .collect();
        assert!(find(&c, &d, 1.0, 0).is_none());
    }
}
