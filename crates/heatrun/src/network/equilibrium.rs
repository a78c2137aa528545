//! Has the machine reached its thermal equilibrium?
//!
//! Two checks. IEC 60034-1 calls a machine in thermal equilibrium when no part's
//! temperature rise changes by more than 2 K per hour; here the rate is the
//! least-squares slope over the last hour of each state's series (a line through 3600
//! samples at Ts = 1 s, so PT100 noise of 0.05 K moves it by a few mK/h, where the
//! difference of two readings would move it by 0.07 K/h). The paper's check (section 3) is
//! that the final load was held for at least five of the slowest time constant: a
//! first-order rise then reaches 1 − e^(−held/T_max) = 99.3 % of its final value. Where
//! either check fails, the predicted steady state (eq. 31) is an extrapolation.

use serde::{Deserialize, Serialize};

use crate::series::Series;
use crate::signals::ModelSignals;
use crate::spec::{InputSource, ModelDescription, Reference};

/// IEC 60034-1's limit on a part's rate of rise at thermal equilibrium (K/h).
pub const IEC_LIMIT_K_PER_H: f64 = 2.0;
/// The window of the rate of rise (s).
pub const WINDOW_S: f64 = 3600.0;
/// Time constants the final load must be held (the paper's criterion).
pub const HELD_TIME_CONSTANTS: f64 = 5.0;

/// An input within this share of its range of its final level counts as held, however
/// still the load (the floor of the band a load step must leave).
pub const HELD_TOLERANCE: f64 = 0.05;
/// Half the width of the running median a load input is read through before its steps
/// are sought, s: a departure shorter than a minute (a governor's swing, a spike) is no
/// step, while the shortest load stage of a heat run (a load rejection of a few minutes)
/// keeps its edges, which a running median preserves.
pub const STEP_MEDIAN_HALF_WIDTH_S: f64 = 60.0;
/// The end of the run over which a load input's final level and its wander are read, s.
pub const FINAL_LEVEL_S: f64 = 1800.0;
/// A load step leaves the final level by more than this many of the load's own wander's
/// robust σ (what a governor and a voltage regulator make of a held set point).
pub const WANDER_SIGMAS: f64 = 4.0;

/// How a load input settled at its final level, as a heat-run engineer reads its trace.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoadSettling {
    /// The final level: the last value of a load whose wander is within the tolerance,
    /// the median over the last [`FINAL_LEVEL_S`] of one whose wander sets the band.
    pub level: f64,
    /// The load's own wander: the robust σ = 1.4826·median |u − ū| of its departures from
    /// its median ū over the last [`FINAL_LEVEL_S`] (0 for a load held still).
    pub wander: f64,
    /// The half-width of the band a step must leave: max([`HELD_TOLERANCE`]·range,
    /// [`WANDER_SIGMAS`]·wander).
    pub band: f64,
    /// The last instant whose running median lies outside the band (the last step), if
    /// the input ever left it.
    pub last_step: Option<usize>,
}

/// The median of `values` (NaN-free), `None` where empty.
fn median(mut values: Vec<f64>) -> Option<f64> {
    median_in(&mut values)
}

/// [`median`] of a slice, reordered in place: the running median's windows are one
/// reused buffer, not an allocation per instant (a week at 1 s made 3.7 million).
fn median_in(values: &mut [f64]) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    let n = values.len();
    let (_, &mut upper, _) = values.select_nth_unstable_by(n / 2, f64::total_cmp);
    if n % 2 == 1 {
        return Some(upper);
    }
    let lower = values[..n / 2]
        .iter()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max);
    Some(0.5 * (lower + upper))
}

/// The running median ũ(k) of the known values within `half` instants either side of k,
/// the window narrowed symmetrically at the ends (so ũ = u at the first and last
/// instant); `None` where u(k) is unknown. A load held still between steps is its own
/// running median where its stages outlast the window: a median keeps a step's edge.
/// `window` is scratch space, its contents replaced.
fn running_median(values: &Series, k: usize, half: usize, window: &mut Vec<f64>) -> Option<f64> {
    values.get(k)?;
    let h = half.min(k).min(values.len() - 1 - k);
    window.clear();
    window.extend((k - h..=k + h).filter_map(|i| values.get(i)));
    median_in(window)
}

/// When a load input (known values on a grid of `ts_s`) last stepped. Its wander σ_w is
/// read over the last [`FINAL_LEVEL_S`] from its departures from its median there; its
/// final level m is its last value where [`WANDER_SIGMAS`]·σ_w is within
/// [`HELD_TOLERANCE`] of its range, else that median; the last step is the last instant k
/// at which its running median ũ(k) (half-width [`STEP_MEDIAN_HALF_WIDTH_S`]) lies
/// further from m than max([`HELD_TOLERANCE`]·(max − min), [`WANDER_SIGMAS`]·σ_w).
/// A load that wanders ±2 % with its governor and voltage regulator holds; a change of
/// load stage does not. On a load held still between clean steps this is exactly the
/// instant the old level ended (ũ = u, σ_w = 0). `None` where fewer than two values are
/// known.
// Read in place: a week at 1 s is 604,800 values, and the copies this made (14.5 MB)
// were held at the replay's peak of memory.
pub fn load_settling(values: &Series, ts_s: f64) -> Option<LoadSettling> {
    let (mut lo, mut hi, mut count) = (f64::INFINITY, f64::NEG_INFINITY, 0usize);
    for v in values.iter().flatten() {
        (lo, hi, count) = (lo.min(v), hi.max(v), count + 1);
    }
    if count < 2 || !(ts_s.is_finite() && ts_s > 0.0) {
        return None;
    }
    let len = values.len();
    let half = (STEP_MEDIAN_HALF_WIDTH_S / ts_s).round() as usize;
    let tail = len.saturating_sub((FINAL_LEVEL_S / ts_s).ceil() as usize + 1)..len;
    let tail: Vec<f64> = tail.filter_map(|k| values.get(k)).collect();
    let median_level = median(tail.clone())?;
    let wander = 1.4826 * median(tail.iter().map(|v| (v - median_level).abs()).collect())?;
    // Where the wander is within the tolerance (a load held still, or drifting slowly as
    // the copper loss does with the winding's resistance) the final value is the level;
    // where it sets the band, its last value is one swing of it: the median is.
    let level = if WANDER_SIGMAS * wander > HELD_TOLERANCE * (hi - lo) {
        median_level
    } else {
        values.iter().rev().flatten().next()?
    };
    let band = (HELD_TOLERANCE * (hi - lo)).max(WANDER_SIGMAS * wander);
    let last_step = last_outside(values, half, level, band);
    Some(LoadSettling {
        level,
        wander,
        band,
        last_step,
    })
}

/// The last instant k whose running median ũ(k) ([`running_median`], half-width `half`)
/// lies further from `level` than `band`: |ũ(k) − level| > band, sought from the end.
///
/// Counted, not sorted: d(v) = v − level is monotone in v, so "d > band" holds for the
/// largest values of a window and "d < −band" for the smallest. Of c known values, an odd
/// c's median is the ((c+1)/2)-th from either end, so d(ũ) > band exactly where at least
/// (c+1)/2 of them have d > band (the same test on the same differences: the result is the
/// sorted median's to the bit). An even c's median is the mean of the two middle values:
/// where the count does not settle it (exactly c/2 beyond the band) it is made. The counts
/// slide with k, one value in and one out; the windows narrowed at the ends are made. Per
/// instant this is O(1) where the median was O(half): W0's final load, held 11,600 s, took
/// 15 ms of the replay's critical path in medians of 121 values.
fn last_outside(values: &Series, half: usize, level: f64, band: f64) -> Option<usize> {
    let len = values.len();
    let beyond = |i: usize| -> (usize, usize, usize) {
        values.get(i).map_or((0, 0, 0), |v| {
            let d = v - level;
            (usize::from(d > band), usize::from(d < -band), 1)
        })
    };
    let mut window = Vec::with_capacity(2 * half + 1);
    let mut sorted = |k: usize| {
        running_median(values, k, half, &mut window).is_some_and(|f| (f - level).abs() > band)
    };
    // (above, below, known) over k − half..=k + half, valid for `counted_at`.
    let mut counts = (0usize, 0usize, 0usize);
    let mut counted_at: Option<usize> = None;
    for k in (0..len).rev() {
        let interior = k >= half && k + half < len;
        if interior {
            counts = match counted_at {
                Some(c) if c == k + 1 => {
                    let (gone, new) = (beyond(k + 1 + half), beyond(k - half));
                    (
                        counts.0 - gone.0 + new.0,
                        counts.1 - gone.1 + new.1,
                        counts.2 - gone.2 + new.2,
                    )
                }
                _ => (k - half..=k + half)
                    .map(beyond)
                    .fold((0, 0, 0), |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2)),
            };
            counted_at = Some(k);
        }
        if values.get(k).is_none() {
            continue;
        }
        let outside = if interior {
            match median_beyond(counts) {
                Some(decided) => decided,
                None => sorted(k),
            }
        } else {
            sorted(k)
        };
        if outside {
            return Some(k);
        }
    }
    None
}

/// Whether a window's median lies beyond the band, from how many of its `known` values lie
/// above and below it (`(above, below, known)`); `None` where an even count leaves the
/// mean of the middle two undecided ([`last_outside`]).
fn median_beyond((above, below, known): (usize, usize, usize)) -> Option<bool> {
    let side = |beyond: usize| -> Option<bool> {
        if known % 2 == 1 {
            return Some(2 * beyond > known);
        }
        match (2 * beyond).cmp(&known) {
            std::cmp::Ordering::Greater => Some(true),
            std::cmp::Ordering::Less => Some(false),
            std::cmp::Ordering::Equal => None,
        }
    };
    match (side(above), side(below)) {
        (Some(true), _) | (_, Some(true)) => Some(true),
        (Some(false), Some(false)) => Some(false),
        _ => None,
    }
}

/// How long the final load was held on a grid of `len` instants of `ts_s`: the time since
/// the last step ([`load_settling`]) of any of the load inputs.
pub fn held_s<'a, I>(load_inputs: I, len: usize, ts_s: f64) -> f64
where
    I: IntoIterator<Item = &'a crate::series::Series>,
{
    let since = load_inputs
        .into_iter()
        .filter_map(|values| load_settling(values, ts_s)?.last_step)
        .map(|k| k + 1)
        .max()
        .unwrap_or(0);
    (len.saturating_sub(1 + since)) as f64 * ts_s
}

/// The least-squares slope of one series over the last hour.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RateOfRise {
    /// The slope in K/h.
    pub k_per_h: f64,
    /// Its standard error from the residuals, K/h.
    pub standard_error_k_per_h: f64,
    /// Known instants in the window.
    pub instants: usize,
    /// Time between the first and last known instant of the window (s).
    pub span_s: f64,
}

/// The least-squares slope (K/h) of the known values (K or °C) among the instants within
/// [`WINDOW_S`] of the last instant of a grid of `ts_s`:
/// b = Σ(t − t̄)(y − ȳ) / Σ(t − t̄)², with its standard error √(s²/Σ(t − t̄)²),
/// s² = Σ residual²/(N − 2). `None` where fewer than three values are known or they span
/// less than half the window (a recording shorter than half an hour).
pub fn rate_over_last_hour<S>(values: S, ts_s: f64) -> Option<RateOfRise>
where
    S: IntoIterator<Item = Option<f64>>,
    S::IntoIter: DoubleEndedIterator + ExactSizeIterator,
{
    if !(ts_s.is_finite() && ts_s > 0.0) {
        return None;
    }
    let take = (WINDOW_S / ts_s + 1e-9).floor() as usize + 1;
    // t counts back from the last instant: t = −age·Ts.
    let points: Vec<(f64, f64)> = values
        .into_iter()
        .rev()
        .take(take)
        .enumerate()
        .filter_map(|(age, y)| y.map(|y| (-(age as f64) * ts_s, y)))
        .collect();
    let n = points.len();
    if n < 3 {
        return None;
    }
    let span_s = points[0].0 - points[n - 1].0;
    if span_s < 0.5 * WINDOW_S {
        return None;
    }
    let (t_mean, y_mean) = points.iter().fold((0.0, 0.0), |(a, b), (t, y)| {
        (a + t / n as f64, b + y / n as f64)
    });
    let (mut sxx, mut sxy) = (0.0, 0.0);
    for &(t, y) in &points {
        sxx += (t - t_mean) * (t - t_mean);
        sxy += (t - t_mean) * (y - y_mean);
    }
    let slope = sxy / sxx;
    let ssr: f64 = points
        .iter()
        .map(|&(t, y)| (y - y_mean - slope * (t - t_mean)).powi(2))
        .sum();
    let se = (ssr / (n - 2) as f64 / sxx).sqrt();
    Some(RateOfRise {
        k_per_h: slope * 3600.0,
        standard_error_k_per_h: se * 3600.0,
        instants: n,
        span_s,
    })
}

/// Each state's [`rate_over_last_hour`] of its rise above its reference, in K/h. A state
/// measured from a reference channel's initial level ([`Reference::InitialOf`]: the
/// coolant inlet) whose drift is an input ([`InputSource::BoundaryRise`]) is taken as its
/// rise above that channel at each instant, θ_j(k) − θ_ref(k): an inlet that warms over
/// the day moves every temperature with it, and that is not the machine heating. A state
/// whose reference does not move (a constant inlet, the paper's initial values) has the
/// rate of its rise as it is.
pub fn rates_of_rise(model: &ModelDescription, signals: &ModelSignals) -> Vec<Option<RateOfRise>> {
    let base = signals.temperature_base_k;
    (0..signals.states.len())
        .map(|j| {
            let state = &signals.states[j];
            let drift = match model.states.get(j).map(|d| &d.reference) {
                Some(Reference::InitialOf(r)) => {
                    model.inputs.iter().zip(&signals.inputs).find_map(|(d, i)| {
                        matches!(&d.source, InputSource::BoundaryRise(c) if c == r)
                            .then_some(&i.values)
                    })
                }
                _ => None,
            };
            let rise = (0..signals.len()).map(|k| match drift {
                Some(d) => Some(state.rise(k)? - d.get(k)? * base),
                None => state.rise(k),
            });
            rate_over_last_hour(rise, signals.ts_s)
        })
        .collect()
}

/// Both equilibrium checks for a recording (read back from a report by `predict` and
/// `rating`, which say when the steady state they rest on is an extrapolation).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Equilibrium {
    /// The states' names.
    pub states: Vec<String>,
    /// Each state's rate of rise over the last hour (`None`: not enough data).
    pub rate_of_rise: Vec<Option<RateOfRise>>,
    /// [`IEC_LIMIT_K_PER_H`].
    pub iec_limit_k_per_h: f64,
    /// Every rate known and within the limit (IEC 60034-1).
    pub iec_equilibrium: bool,
    /// How long the final load was held (s).
    pub held_s: f64,
    /// T_max, the slowest time constant (s).
    pub slowest_time_constant_s: f64,
    /// held / T_max.
    pub held_over_slowest: f64,
    /// 1 − e^(−held/T_max): the share of the slowest mode's final rise reached.
    pub fraction_of_final_rise_reached: f64,
    /// held ≥ [`HELD_TIME_CONSTANTS`]·T_max (the paper's criterion; 99.3 % reached).
    pub held_long_enough: bool,
    /// Either check failed: the predicted steady state lies beyond the recording.
    pub steady_state_is_extrapolation: bool,
}

impl Equilibrium {
    /// Both checks from each state's rate of rise (in state order, named by `states`),
    /// the time the final load was held and the slowest time constant.
    pub fn assess(
        states: &[String],
        rate_of_rise: Vec<Option<RateOfRise>>,
        held_s: f64,
        slowest_time_constant_s: f64,
    ) -> Equilibrium {
        let iec_equilibrium = rate_of_rise
            .iter()
            .all(|r| r.is_some_and(|r| r.k_per_h.abs() <= IEC_LIMIT_K_PER_H));
        let held_over_slowest = held_s / slowest_time_constant_s;
        // No usable time constant fails the check rather than passing it.
        let held_long_enough = slowest_time_constant_s.is_finite()
            && slowest_time_constant_s > 0.0
            && held_over_slowest >= HELD_TIME_CONSTANTS;
        Equilibrium {
            states: states.to_vec(),
            rate_of_rise,
            iec_limit_k_per_h: IEC_LIMIT_K_PER_H,
            iec_equilibrium,
            held_s,
            slowest_time_constant_s,
            held_over_slowest,
            fraction_of_final_rise_reached: 1.0 - (-held_over_slowest).exp(),
            held_long_enough,
            steady_state_is_extrapolation: !(iec_equilibrium && held_long_enough),
        }
    }

    /// One plain sentence where the steady state is an extrapolation, naming why.
    pub fn warning(&self) -> Option<String> {
        self.why_extrapolation()
            .map(|why| format!("The predicted steady state is an extrapolation: {why}."))
    }

    /// Why the steady state is an extrapolation (each failed check, `; ` between them),
    /// where it is one.
    pub fn why_extrapolation(&self) -> Option<String> {
        if !self.steady_state_is_extrapolation {
            return None;
        }
        let mut why = Vec::new();
        for (name, rate) in self.states.iter().zip(&self.rate_of_rise) {
            match rate {
                None => why.push(format!("the {name} has less than half an hour of data at the end")),
                Some(r) if r.k_per_h.abs() > IEC_LIMIT_K_PER_H => why.push(format!(
                    "the {name} still changes by {:+.1} K/h (IEC 60034-1 allows {IEC_LIMIT_K_PER_H} K/h)",
                    r.k_per_h
                )),
                Some(_) => {}
            }
        }
        if !self.held_long_enough {
            why.push(format!(
                "the final load was held {:.1} times the slowest time constant ({:.0} s), so the slowest part reached {:.1} % of its final rise ({HELD_TIME_CONSTANTS} give 99.3 %)",
                self.held_over_slowest,
                self.slowest_time_constant_s,
                100.0 * self.fraction_of_final_rise_reached
            ));
        }
        Some(why.join("; "))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{rngs::StdRng, SeedableRng};
    use rand_distr::{Distribution, Normal};

    /// θ(t) = Δ(1 − e^(−t/T)) on a 1 s grid from 0 to `end_s`.
    fn first_order(delta: f64, t: f64, end_s: usize) -> Vec<Option<f64>> {
        (0..=end_s)
            .map(|k| Some(delta * (1.0 - (-(k as f64) / t).exp())))
            .collect()
    }

    /// The continuous least-squares slope of Δ(1 − e^(−t/T)) over a window of 2h centred
    /// on t_m: Δ/T·e^(−t_m/T)·3(x·cosh x − sinh x)/x³ with x = h/T.
    fn ls_slope_of_exponential(delta: f64, t: f64, t_mid: f64, h: f64) -> f64 {
        let x = h / t;
        delta / t * (-t_mid / t).exp() * 3.0 * (x * x.cosh() - x.sinh()) / x.powi(3)
    }

    #[test]
    fn a_ramp_has_its_slope_exactly() {
        let ramp: Vec<Option<f64>> = (0..10_000).map(|k| Some(20.0 + 1e-3 * k as f64)).collect();
        let r = rate_over_last_hour(ramp, 1.0).unwrap();
        assert!((r.k_per_h - 3.6).abs() < 1e-9);
        assert!(r.standard_error_k_per_h < 1e-9);
        assert_eq!(r.instants, 3601);
        assert_eq!(r.span_s, 3600.0);
    }

    #[test]
    fn first_order_rise_slope_matches_the_closed_form() {
        let (delta, t, end) = (60.0, 3000.0, 12_000);
        let rise = first_order(delta, t, end);
        let r = rate_over_last_hour(rise, 1.0).unwrap();
        let expected = 3600.0 * ls_slope_of_exponential(delta, t, end as f64 - 1800.0, 1800.0);
        assert!(
            (r.k_per_h - expected).abs() / expected < 5e-5,
            "{} vs {expected}",
            r.k_per_h
        );
    }

    #[test]
    fn noise_moves_the_slope_by_its_standard_error() {
        let noise = Normal::new(0.0, 0.05).unwrap();
        let mut rng = StdRng::seed_from_u64(10);
        // A line with PT100-like noise: the standard error is σ/√Σ(t − t̄)²
        // = σ·√(12/(N(N²−1)))·3600 K/h with N = 3601 → 0.00289 K/h.
        let ramp: Vec<Option<f64>> = (0..10_000)
            .map(|k| Some(20.0 + 1e-3 * k as f64 + noise.sample(&mut rng)))
            .collect();
        let r = rate_over_last_hour(ramp, 1.0).unwrap();
        let se = r.standard_error_k_per_h;
        assert!((se - 0.00289).abs() < 0.0002, "{se}");
        assert!((r.k_per_h - 3.6).abs() < 4.0 * se, "{}", r.k_per_h);
        // A first-order rise with the same noise keeps the clean slope within 0.01 K/h.
        let (delta, t, end) = (60.0, 3000.0, 12_000);
        let clean = rate_over_last_hour(first_order(delta, t, end), 1.0).unwrap();
        let noisy: Vec<Option<f64>> = first_order(delta, t, end)
            .into_iter()
            .map(|y| y.map(|y| y + noise.sample(&mut rng)))
            .collect();
        let r = rate_over_last_hour(noisy, 1.0).unwrap();
        assert!(
            (r.k_per_h - clean.k_per_h).abs() < 0.01,
            "{} vs {}",
            r.k_per_h,
            clean.k_per_h
        );
    }

    #[test]
    fn gaps_and_short_records() {
        let mut rise = first_order(60.0, 3000.0, 12_000);
        for v in rise.iter_mut().rev().take(1000) {
            *v = None;
        }
        let r = rate_over_last_hour(rise, 1.0).unwrap();
        assert_eq!(r.instants, 2601);
        assert_eq!(r.span_s, 2600.0);
        assert!(rate_over_last_hour(first_order(60.0, 3000.0, 1000), 1.0).is_none());
        // On a 10 s grid the hour is 361 instants.
        let coarse: Vec<Option<f64>> = (0..2000).map(|k| Some(k as f64)).collect();
        let r = rate_over_last_hour(coarse, 10.0).unwrap();
        assert_eq!(r.instants, 361);
        assert!((r.k_per_h - 360.0).abs() < 1e-9);
    }

    #[test]
    fn held_five_time_constants_is_equilibrium() {
        // Δ = 60 K, T = 3000 s: the rate at 5T is 72·e^(−5) ≈ 0.49 K/h.
        let t = 3000.0;
        let states = ["stator winding".to_string()];
        let rate = rate_over_last_hour(first_order(60.0, t, 15_000), 1.0);
        let eq = Equilibrium::assess(&states, vec![rate], 15_000.0, t);
        assert!(eq.iec_equilibrium && eq.held_long_enough);
        assert!((eq.fraction_of_final_rise_reached - (1.0 - (-5.0_f64).exp())).abs() < 1e-12);
        assert!((eq.fraction_of_final_rise_reached - 0.993).abs() < 0.0005);
        assert!(!eq.steady_state_is_extrapolation);
        assert_eq!(eq.warning(), None);
    }

    #[test]
    fn held_two_time_constants_is_an_extrapolation() {
        // At 2T the rate is about 72·e^(−2)·1.04 ≈ 10 K/h over the last hour.
        let t = 3000.0;
        let states = ["iron core".to_string(), "cooling water".to_string()];
        let rate = rate_over_last_hour(first_order(60.0, t, 6000), 1.0);
        let eq = Equilibrium::assess(&states, vec![rate, None], 6000.0, t);
        assert!(!eq.iec_equilibrium && !eq.held_long_enough);
        assert!(eq.steady_state_is_extrapolation);
        assert!((eq.held_over_slowest - 2.0).abs() < 1e-12);
        let w = eq.warning().unwrap();
        assert!(w.contains("the iron core still changes by +"), "{w}");
        assert!(
            w.contains("the cooling water has less than half an hour"),
            "{w}"
        );
        assert!(w.contains("86.5 % of its final rise"), "{w}");
    }

    #[test]
    fn with_the_inlet_as_reference_the_rate_is_of_the_rise_above_the_inlet() {
        use crate::recording::{Quantity, Signal};
        use crate::series::Series;
        use crate::signals::{InputSignal, ReferenceValues, StateSignal};
        use crate::spec::InputKind;
        // A machine held 20 K above an inlet that warms by 3 K/h (pu of 100 K): the
        // winding rises 3 K/h above the inlet's initial level, which is the river, not
        // the machine; above the inlet it is at equilibrium.
        let (len, base) = (7200, 100.0);
        let inlet_c = |k: usize| 10.0 + 3.0 * k as f64 / 3600.0;
        let series =
            |f: &dyn Fn(usize) -> f64| -> Series { (0..len).map(|k| Some(f(k))).collect() };
        let inlet = Signal::Profile(Quantity::CoolingWaterInletTemp);
        let mut model = ModelDescription::generator();
        model.states.truncate(1);
        model.states[0].reference = Reference::InitialOf(inlet.clone());
        model.inputs.push(crate::spec::InputDescription {
            name: "cooling_water_inlet_rise".into(),
            source: InputSource::BoundaryRise(inlet),
            unit: "pu".into(),
            kind: InputKind::Boundary,
            from_initial: false,
            delay_s: 0.0,
        });
        let signals = ModelSignals {
            ts_s: 1.0,
            time_ns: (0..len as i64).map(|k| k * 1_000_000_000).collect(),
            states: vec![StateSignal {
                name: "stator_winding_temp".into(),
                part: "stator winding".into(),
                measured: series(&|k| inlet_c(k) + 20.0),
                reference: ReferenceValues::Constant(10.0),
                observed: None,
                exception: None,
            }],
            inputs: (0..4)
                .map(|i| InputSignal {
                    name: format!("u{i}"),
                    unit: "pu".into(),
                    kind: if i == 3 {
                        InputKind::Boundary
                    } else {
                        InputKind::Heat
                    },
                    values: series(&|k| {
                        if i == 3 {
                            (inlet_c(k) - 10.0) / base
                        } else {
                            0.01
                        }
                    }),
                    outlet_feedback: None,
                    gaps: crate::signals::InputGaps::none(crate::signals::Bridge::Hold),
                })
                .collect(),
            initial_index: 0,
            temperature_base_k: base,
            power_base: 1.0,
            field_temperature: None,
        };
        let r = rates_of_rise(&model, &signals)[0].unwrap();
        assert!(r.k_per_h.abs() < 1e-9, "{}", r.k_per_h);
        // Without the inlet's input (a description read as the paper's) the rate is the
        // rise's own: the 3 K/h of the inlet, beyond IEC's 2 K/h.
        model.inputs.truncate(3);
        let r = rates_of_rise(&model, &signals)[0].unwrap();
        assert!((r.k_per_h - 3.0).abs() < 1e-9, "{}", r.k_per_h);
    }

    /// A load of stages: (start instant, level), on `len` instants of 1 s.
    fn stages(len: usize, stages: &[(usize, f64)]) -> Vec<Option<f64>> {
        (0..len)
            .map(|k| {
                stages
                    .iter()
                    .rev()
                    .find(|(start, _)| k >= *start)
                    .map(|s| s.1)
            })
            .collect()
    }

    #[test]
    fn a_still_load_is_held_from_its_last_stage_however_short_the_stage_before() {
        // Load-up, a load rejection of 209 s (the synthesiser's), the final load from 8139 s.
        let len = 20_868;
        let u = stages(len, &[(0, 0.06), (800, 0.5), (7930, 0.06), (8139, 0.86)]);
        let series: crate::series::Series = u.into_iter().collect();
        let s = load_settling(&series, 1.0).unwrap();
        assert_eq!(s.last_step, Some(8138));
        assert_eq!((s.level, s.wander), (0.86, 0.0));
        assert!((s.band - 0.05 * 0.8).abs() < 1e-12);
        assert_eq!(held_s([&series], len, 1.0), (len - 1 - 8139) as f64);
    }

    #[test]
    fn a_load_wandering_two_percent_is_held_from_its_last_real_step() {
        // ±2 % of the set point, a new value every 30 to 90 s, as a governor keeps it; the
        // last real step (0.75 → 1) at 11 484 s.
        use rand::Rng;
        let mut rng = StdRng::seed_from_u64(34);
        let len = 20_868;
        let mut u = Vec::with_capacity(len);
        let mut hold = 0;
        let mut v = 0.0;
        for k in 0..len {
            let set = if k < 11_484 { 0.75 } else { 1.0 };
            if hold == 0 || k == 11_484 {
                v = set * (1.0 + rng.random_range(-0.02..0.02));
                hold = rng.random_range(30..90);
            }
            hold -= 1;
            u.push(Some(v));
        }
        let series: crate::series::Series = u.into_iter().collect();
        let s = load_settling(&series, 1.0).unwrap();
        let step = s.last_step.unwrap();
        assert!((11_440..11_484).contains(&step), "{step}");
        assert!(s.wander > 0.005 && s.wander < 0.02, "{}", s.wander);
        // The last value alone as the final level, and any change a step, would find the
        // load never held: the wander's own last change.
        let held = held_s([&series], len, 1.0);
        assert!((held - (len - 11_484) as f64).abs() < 60.0, "{held}");
    }

    #[test]
    fn the_counted_median_test_finds_the_sorted_medians_last_step_to_the_instant() {
        // Levels, gaps (even windows), values on the band's edges and ties: the search by
        // counts against the median made at every instant, on series short enough to
        // reach the narrowed ends and long enough to slide.
        use rand::Rng;
        let mut rng = StdRng::seed_from_u64(7);
        for case in 0..400 {
            let len = rng.random_range(1..400);
            let half = rng.random_range(0..12);
            let (level, band) = (1.0, 0.25);
            let edges = [0.75, 1.25, 1.0, 0.5, 1.5];
            let values: crate::series::Series = (0..len)
                .map(|_| match rng.random_range(0..10) {
                    0 | 1 => None,
                    2..=4 => Some(edges[rng.random_range(0..edges.len())]),
                    _ => Some(rng.random_range(0.3..1.7)),
                })
                .collect();
            let mut window = Vec::new();
            let sorted = (0..len).rev().find(|&k| {
                running_median(&values, k, half, &mut window)
                    .is_some_and(|f| (f - level).abs() > band)
            });
            assert_eq!(
                last_outside(&values, half, level, band),
                sorted,
                "case {case}: len {len}, half {half}"
            );
        }
    }

    #[test]
    fn steady_rates_but_short_hold_still_extrapolates() {
        let flat = vec![Some(25.0); 4000];
        let rate = rate_over_last_hour(flat, 1.0);
        assert!(rate.unwrap().k_per_h.abs() < 1e-12);
        let eq = Equilibrium::assess(&["x".to_string()], vec![rate], 4000.0, 3344.5);
        assert!(eq.iec_equilibrium && !eq.held_long_enough && eq.steady_state_is_extrapolation);
        // No time constant (0 s) is no evidence of a long enough hold.
        let eq = Equilibrium::assess(&["x".to_string()], vec![rate], 4000.0, 0.0);
        assert!(!eq.held_long_enough && eq.steady_state_is_extrapolation);
    }
}
