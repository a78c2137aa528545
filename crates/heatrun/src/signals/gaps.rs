//! Gaps in the model's inputs: short ones bridged as the model itself assumes between
//! samples, long ones left as cuts of the data.
//!
//! The discrete model holds each input over its interval, x(k+1) = Φ x(k) + Γ u(k): an
//! input missing for a few instants (an "I/O Timeout" cell, a dropped message) is
//! bridged by holding its last value, which is what the model assumes between any two
//! samples anyway, or, for a slow quantity (the coolant inlet's rise, the heat a flow
//! change carries), by the straight line between its neighbours. A gap longer than
//! [`INPUT_GAP_BRIDGED_S`] is a cut: the estimator starts a new segment after it and
//! estimates that segment's initial state. An output's missing sample is never a cut:
//! it is an unobserved entry the simulation runs through
//! ([`super::ModelSignals::identification_data`]).

use serde::Serialize;

use crate::series::Series;

/// The longest input gap bridged, s (and never fewer than one sample period).
///
/// Holding an input across a gap of length g misplaces at most the heat ΔP·g of a
/// step that happens inside the gap; the fastest mode (time constant τ₁) takes it up
/// as a transient of relative size at most 1 − e^(−g/τ₁). With g = 10 s and the
/// fastest winding constant of the machines heatrun is checked on (the paper's 23.9 s,
/// the RC unit's 71 s), that bound is 34 % and 13 % of one step's fast transient, for
/// the few samples after a step that falls inside a gap, and nothing at all while the
/// load is steady, which is where nearly every gap of a heat run falls. Longer gaps
/// are where a link was down long enough for the operating point to move unseen: the
/// data are cut there, each side its own segment with its own initial state.
pub const INPUT_GAP_BRIDGED_S: f64 = 10.0;

/// How an input's gaps are bridged.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Bridge {
    /// The last value held (zero-order hold: what the model assumes between samples).
    Hold,
    /// The straight line between the neighbours (a slow quantity: a temperature, a flow).
    Interpolate,
}

/// What the signal stage did with one input's gaps.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct InputGaps {
    /// How short gaps were bridged.
    pub bridge: Bridge,
    /// Gaps of at most [`INPUT_GAP_BRIDGED_S`] that were bridged.
    pub bridged: usize,
    /// Instants filled in by bridging.
    pub bridged_instants: usize,
    /// The longest bridged gap, s (0 without one).
    pub longest_bridged_s: f64,
    /// Longer gaps, left unknown: each cuts the data into segments.
    pub cut: usize,
    /// Instants inside the cuts.
    pub cut_instants: usize,
}

impl InputGaps {
    /// No gaps, bridged the way `bridge` says.
    pub fn none(bridge: Bridge) -> InputGaps {
        InputGaps {
            bridge,
            bridged: 0,
            bridged_instants: 0,
            longest_bridged_s: 0.0,
            cut: 0,
            cut_instants: 0,
        }
    }

    /// Whether the input had any gap inside its span.
    pub fn any(&self) -> bool {
        self.bridged + self.cut > 0
    }
}

/// The longest gap bridged, in instants of the grid `ts_s`:
/// ⌊[`INPUT_GAP_BRIDGED_S`] / Ts⌋, at least one.
pub fn bridged_instants_limit(ts_s: f64) -> usize {
    ((INPUT_GAP_BRIDGED_S / ts_s + 1e-9).floor() as usize).max(1)
}

/// Bridges the gaps of `values` inside its span (unknown instants with a known value on
/// either side) of at most [`bridged_instants_limit`] instants, the way `bridge` says;
/// longer gaps and the unknown instants before the first and after the last known value
/// stay unknown. Returns what was done.
pub fn bridge_gaps(values: &mut Series, bridge: Bridge, ts_s: f64) -> InputGaps {
    let limit = bridged_instants_limit(ts_s);
    let mut gaps = InputGaps::none(bridge);
    let Some(first) = (0..values.len()).find(|&k| values.get(k).is_some()) else {
        return gaps;
    };
    let mut last_known = first;
    for k in first + 1..values.len() {
        let Some(after) = values.get(k) else {
            continue;
        };
        let missing = k - last_known - 1;
        if missing > 0 {
            if missing <= limit {
                let before = values.get(last_known).unwrap_or(after);
                for i in last_known + 1..k {
                    let value = match bridge {
                        Bridge::Hold => before,
                        Bridge::Interpolate => {
                            let f = (i - last_known) as f64 / (k - last_known) as f64;
                            before + f * (after - before)
                        }
                    };
                    values.set(i, Some(value));
                }
                gaps.bridged += 1;
                gaps.bridged_instants += missing;
                gaps.longest_bridged_s = gaps.longest_bridged_s.max(missing as f64 * ts_s);
            } else {
                gaps.cut += 1;
                gaps.cut_instants += missing;
            }
        }
        last_known = k;
    }
    gaps
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(values: &[Option<f64>]) -> Series {
        values.iter().copied().collect()
    }

    fn values(s: &Series) -> Vec<Option<f64>> {
        s.iter().collect()
    }

    #[test]
    fn a_short_gap_is_held_and_counted() {
        let mut s = series(&[None, Some(1.0), None, None, Some(4.0), Some(5.0), None]);
        let gaps = bridge_gaps(&mut s, Bridge::Hold, 1.0);
        // Before the first and after the last known value nothing is filled.
        assert_eq!(
            values(&s),
            vec![
                None,
                Some(1.0),
                Some(1.0),
                Some(1.0),
                Some(4.0),
                Some(5.0),
                None
            ]
        );
        assert_eq!((gaps.bridged, gaps.bridged_instants, gaps.cut), (1, 2, 0));
        assert_eq!(gaps.longest_bridged_s, 2.0);
    }

    #[test]
    fn a_slow_quantity_is_interpolated() {
        let mut s = series(&[Some(0.0), None, None, None, Some(4.0)]);
        bridge_gaps(&mut s, Bridge::Interpolate, 2.0);
        assert_eq!(
            values(&s),
            vec![Some(0.0), Some(1.0), Some(2.0), Some(3.0), Some(4.0)]
        );
    }

    #[test]
    fn a_gap_longer_than_the_limit_is_a_cut() {
        // At Ts = 1 s the limit is 10 instants: 10 are bridged, 11 are not.
        let mut ten: Vec<Option<f64>> = vec![Some(1.0)];
        ten.extend(std::iter::repeat_n(None, 10));
        ten.push(Some(2.0));
        let mut eleven = ten.clone();
        eleven.insert(1, None);
        let (mut a, mut b) = (series(&ten), series(&eleven));
        assert_eq!(bridge_gaps(&mut a, Bridge::Hold, 1.0).bridged, 1);
        let cut = bridge_gaps(&mut b, Bridge::Hold, 1.0);
        assert_eq!((cut.bridged, cut.cut, cut.cut_instants), (0, 1, 11));
        assert!(b.get(5).is_none());
        // On a coarse grid one missing sample is still bridged.
        assert_eq!(bridged_instants_limit(60.0), 1);
    }
}
