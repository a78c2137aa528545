//! Input dead time: an input that acts on the states only d samples after it is applied.
//!
//! A spec's input may carry `delay_s` (τ_d, seconds). The model is then
//!
//! x(k+1) = Φ x(k) + Σ_i Γ_i u_i(k − d_i),   d_i = τ_d,i / Ts,
//!
//! for the inputs' columns Γ_i. Heated plants show it where the heat takes a transport or
//! conduction time to reach the sensor (a glass furnace's cooling acts after 3-5 samples,
//! a lab heater's thermistor after ~15 s). It is carried out in one place: the signal
//! stage shifts each delayed input's series d_i instants later on the grid
//! (`signals::delay_inputs`), so that every stage after it (estimators, simulation, fit, report)
//! sees an ordinary model of the shifted input. The first d_i instants have no input
//! value: they are unknown, and the estimators skip them as they skip any gap.
//!
//! The delay must be a whole number of samples: d_i = τ_d,i / Ts within
//! [`WHOLE_SAMPLE_TOLERANCE`] of an integer, or it is refused (rounding it would
//! identify a different model than the one the spec names).
//!
//! **An advance** (`advance_s`, one sample at most) is the opposite shift, for a logger
//! that stamps each interval's mean input at the interval's *end*: the value recorded at
//! t_{k+1} is the input held over [t_k, t_{k+1}), so the model must read
//!
//! x(k+1) = Φ x(k) + Γ_i u_i(k + 1),
//!
//! and the series is shifted one instant earlier (its last instant unknown). The data
//! show it as an output that moves in the same sample as the recorded input (a glass
//! furnace's heating 2: the cross-correlation of Δy with u peaks at lag 0, 0.4-0.85,
//! and is ≈ 0 at lag −1). In prediction terms the model is non-causal in the recorded
//! series: a prediction needs each advanced input one sample ahead (a schedule gives
//! it; an input computed from the predicted temperatures cannot, and is refused). It is
//! carried as a negative shift, [`super::InputDescription::delay_s`] = −`advance_s`.

use crate::series::Series;

/// How far τ_d / Ts may sit from a whole number and still count as one (a fraction of a
/// sample: decimal seconds such as 0.1 s are not exact in binary).
pub const WHOLE_SAMPLE_TOLERANCE: f64 = 1e-6;

/// The most an input may be advanced, in samples: one interval's mean stamped at its end.
pub const MAX_ADVANCE_SAMPLES: usize = 1;

/// A delay that is not a whole number of samples, or an advance that is not one sample.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub struct DelayError {
    /// The input's name.
    pub input: String,
    /// Its shift as given, s: a delay (> 0) or an advance (< 0, `advance_s` = −delay_s).
    pub delay_s: f64,
    /// The grid's sample time, s.
    pub ts_s: f64,
}

impl std::fmt::Display for DelayError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (input, ts) = (&self.input, self.ts_s);
        if self.delay_s < 0.0 {
            write!(
                f,
                "input `{input}`: advance_s = {} s is not one sample of Ts = {ts} s (an advance is the interval's mean stamped at its end: one sample)",
                -self.delay_s
            )
        } else {
            write!(
                f,
                "input `{input}`: delay_s = {} s is not a whole number of samples of Ts = {ts} s (round it to a multiple of Ts)",
                self.delay_s
            )
        }
    }
}

/// Whether `delay_s` can be a delay at all (finite, not negative): the spec's check.
pub fn is_valid_delay(delay_s: f64) -> bool {
    delay_s.is_finite() && delay_s >= 0.0
}

/// The delay in whole samples, d = τ_d / Ts, or `None` where τ_d is not within
/// [`WHOLE_SAMPLE_TOLERANCE`] of a multiple of Ts (or is negative or not finite).
pub fn samples(delay_s: f64, ts_s: f64) -> Option<usize> {
    if !(is_valid_delay(delay_s) && ts_s.is_finite() && ts_s > 0.0) {
        return None;
    }
    let d = delay_s / ts_s;
    let whole = d.round();
    ((d - whole).abs() <= WHOLE_SAMPLE_TOLERANCE * whole.max(1.0)).then_some(whole as usize)
}

/// The signed shift in whole samples of `ts_s`: d = delay_s / Ts for a dead time (> 0),
/// −a for an advance of a ≤ [`MAX_ADVANCE_SAMPLES`] samples (`delay_s` < 0); `None`
/// where either is off the grid, an advance is longer, or `delay_s` is not finite.
pub fn shift_samples(delay_s: f64, ts_s: f64) -> Option<isize> {
    if delay_s >= 0.0 {
        return samples(delay_s, ts_s).map(|d| d as isize);
    }
    samples(-delay_s, ts_s)
        .filter(|&a| a <= MAX_ADVANCE_SAMPLES)
        .map(|a| -(a as isize))
}

/// The series shifted `a` instants earlier: s'(k) = s(k + a), unknown for the last a
/// instants (their input was recorded after the recording ends).
pub fn advance(series: &Series, a: usize) -> Series {
    (0..series.len()).map(|k| series.get(k + a)).collect()
}

/// The series shifted `d` instants later: s'(k) = s(k − d), unknown for k < d. Its length
/// is the grid's; the last d values of `s` drop out (they act after the recording ends).
pub fn shift(series: &Series, d: usize) -> Series {
    let len = series.len();
    (0..len)
        .map(|k| k.checked_sub(d).and_then(|j| series.get(j)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whole_samples_only() {
        assert_eq!(samples(15.0, 1.0), Some(15));
        assert_eq!(samples(0.0, 2.0), Some(0));
        assert_eq!(samples(0.3, 0.1), Some(3)); // 0.3 / 0.1 = 2.9999999999999996
        assert_eq!(samples(6.0, 3.0), Some(2));
        assert_eq!(samples(5.0, 3.0), None);
        assert_eq!(samples(1.5, 1.0), None);
        assert_eq!(samples(-1.0, 1.0), None);
        assert_eq!(samples(f64::NAN, 1.0), None);
    }

    #[test]
    fn an_advance_is_one_whole_sample_at_most() {
        assert_eq!(shift_samples(2.0, 1.0), Some(2));
        assert_eq!(shift_samples(-1.0, 1.0), Some(-1));
        assert_eq!(shift_samples(-0.5, 0.5), Some(-1));
        assert_eq!(shift_samples(-2.0, 1.0), None);
        assert_eq!(shift_samples(-0.5, 1.0), None);
        assert_eq!(shift_samples(f64::NAN, 1.0), None);
    }

    #[test]
    fn an_advance_moves_values_earlier_and_leaves_the_end_unknown() {
        let s: Series = vec![Some(1.0), Some(2.0), None, Some(4.0), Some(5.0)].into();
        assert_eq!(
            advance(&s, 1),
            vec![Some(2.0), None, Some(4.0), Some(5.0), None]
        );
        assert_eq!(advance(&s, 0), s);
    }

    #[test]
    fn an_advance_off_the_grid_names_its_key() {
        let e = DelayError {
            input: "heating".into(),
            delay_s: -2.0,
            ts_s: 1.0,
        };
        assert_eq!(
            e.to_string(),
            "input `heating`: advance_s = 2 s is not one sample of Ts = 1 s (an advance is the interval's mean stamped at its end: one sample)"
        );
    }

    #[test]
    fn a_shift_moves_values_later_and_leaves_the_start_unknown() {
        let s: Series = vec![Some(1.0), Some(2.0), None, Some(4.0), Some(5.0)].into();
        assert_eq!(shift(&s, 2), vec![None, None, Some(1.0), Some(2.0), None]);
        assert_eq!(shift(&s, 0), s);
        assert_eq!(shift(&s, 9), vec![None; 5]);
    }
}
