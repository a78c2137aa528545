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
//! ([`delay_inputs`]), so that every stage after it (estimators, simulation, fit, report)
//! sees an ordinary model of the shifted input. The first d_i instants have no input
//! value: they are unknown, and the estimators skip them as they skip any gap.
//!
//! The delay must be a whole number of samples: d_i = τ_d,i / Ts within
//! [`WHOLE_SAMPLE_TOLERANCE`] of an integer, or it is refused (rounding it would
//! identify a different model than the one the spec names).

use crate::series::Series;
use crate::signals::InputSignal;

use super::InputDescription;

/// How far τ_d / Ts may sit from a whole number and still count as one (a fraction of a
/// sample: decimal seconds such as 0.1 s are not exact in binary).
pub const WHOLE_SAMPLE_TOLERANCE: f64 = 1e-6;

/// A delay that is not a whole number of samples, or not a delay.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("input `{input}`: delay_s = {delay_s} s is not a whole number of samples of Ts = {ts_s} s (round it to a multiple of Ts)")]
pub struct DelayError {
    /// The input's name.
    pub input: String,
    /// Its delay as given, s.
    pub delay_s: f64,
    /// The grid's sample time, s.
    pub ts_s: f64,
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

/// The series shifted `d` instants later: s'(k) = s(k − d), unknown for k < d. Its length
/// is the grid's; the last d values of `s` drop out (they act after the recording ends).
pub fn shift(series: &Series, d: usize) -> Series {
    let len = series.len();
    (0..len)
        .map(|k| k.checked_sub(d).and_then(|j| series.get(j)))
        .collect()
}

/// Shifts each delayed input by its delay in samples of `ts_s` (the signal stage's one
/// call): `inputs` and `descriptions` are in model order. Refuses a delay that is not a
/// whole number of samples.
pub fn delay_inputs(
    descriptions: &[InputDescription],
    ts_s: f64,
    inputs: &mut [InputSignal],
) -> Result<(), DelayError> {
    for (signal, description) in inputs.iter_mut().zip(descriptions) {
        if description.delay_s == 0.0 {
            continue;
        }
        let d = samples(description.delay_s, ts_s).ok_or_else(|| DelayError {
            input: description.name.clone(),
            delay_s: description.delay_s,
            ts_s,
        })?;
        signal.values = shift(&signal.values, d);
    }
    Ok(())
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
    fn a_shift_moves_values_later_and_leaves_the_start_unknown() {
        let s: Series = vec![Some(1.0), Some(2.0), None, Some(4.0), Some(5.0)].into();
        assert_eq!(shift(&s, 2), vec![None, None, Some(1.0), Some(2.0), None]);
        assert_eq!(shift(&s, 0), s);
        assert_eq!(shift(&s, 9), vec![None; 5]);
    }
}
