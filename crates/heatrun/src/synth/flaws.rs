//! The ordinary flaws of real plant data, laid on a synthetic run's written samples:
//! dropouts of the state temperatures, timeouts of an input, unflagged glitches and a
//! frozen sensor (a SCADA link holding the last good value).
//!
//! A flaw changes only what is written: the noise is drawn for every sample as without
//! flaws (the flaws' own times come from a generator of their own), so a flawed run is
//! the clean run of the same seed with exactly its flaws, which is what the tests that
//! hold an estimate unmoved by them compare against.

use rand::{Rng, SeedableRng};
use serde::Serialize;

use super::{Result, SynthError};
use crate::recording::Quantity;

/// The fault code a transducer or its link writes in place of a reading (−3276.8, the
/// most negative 16-bit count at 0.1 resolution), out of every quantity's physical range.
pub const FAULT_CODE: f64 = -3276.8;

/// How far a glitch that is not a fault code lies above the true reading, K: far beyond
/// any sensor's noise, well inside the physical range, so that only the data themselves
/// can contradict it.
pub const GLITCH_OFFSET_K: f64 = 15.0;

/// The flaws of a run (none by default).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Flaws {
    /// N: every N-th sample of each of `dropout_channels` is written missing, the
    /// channel's dropouts alternately as `{"value":null}` and `{"value":NaN}` (the profile
    /// allows both; the reader counts both as the channel's dropouts).
    pub dropout_every: Option<usize>,
    /// The channels whose samples drop out (the stator winding and core temperatures).
    pub dropout_channels: Vec<Quantity>,
    /// Single missing samples ("I/O Timeout") of `timeout_channel`, spread over the run.
    pub input_timeouts: usize,
    /// The input that times out (the armature current).
    pub timeout_channel: Quantity,
    /// Samples of `glitch_channel` replaced without a flag, at spread, seeded times: the
    /// even-numbered ones by the reading + [`GLITCH_OFFSET_K`], the odd-numbered ones by
    /// [`FAULT_CODE`].
    pub glitches: usize,
    /// The channel that glitches (the core temperature).
    pub glitch_channel: Quantity,
    /// `freeze_channel` held from `from_s` until (not including) `to_s`.
    pub freeze: Option<Freeze>,
    /// The channel that freezes (the stator winding temperature).
    pub freeze_channel: Quantity,
}

impl Default for Flaws {
    fn default() -> Self {
        Flaws {
            dropout_every: None,
            dropout_channels: vec![Quantity::StatorWindingTemp, Quantity::CoreTemp],
            input_timeouts: 0,
            timeout_channel: Quantity::ArmatureCurrent,
            glitches: 0,
            glitch_channel: Quantity::CoreTemp,
            freeze: None,
            freeze_channel: Quantity::StatorWindingTemp,
        }
    }
}

/// A frozen sensor: every sample in [from_s, to_s) (s after the start) reads the value
/// of the first sample at or after `from_s`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Freeze {
    /// From, s after the start.
    pub from_s: f64,
    /// Until, s after the start (excluded).
    pub to_s: f64,
}

impl Flaws {
    /// Whether any flaw is asked for.
    pub fn any(&self) -> bool {
        self.dropout_every.is_some()
            || self.input_timeouts > 0
            || self.glitches > 0
            || self.freeze.is_some()
    }

    /// Rejects flaws that cannot be laid on a run of `duration_s`.
    pub(super) fn check(&self, duration_s: f64) -> Result<()> {
        if self.dropout_every.is_some_and(|n| n < 2) {
            return Err(SynthError::Options(
                "dropouts every N samples need N ≥ 2 (every sample missing is no channel)".into(),
            ));
        }
        if let Some(f) = self.freeze {
            if !(f.from_s.is_finite() && f.to_s.is_finite() && 0.0 <= f.from_s && f.from_s < f.to_s)
                || f.from_s >= duration_s
            {
                return Err(SynthError::Options(format!(
                    "the freeze {}:{} must be two times, s, with 0 ≤ from < to and from inside the run of {duration_s} s",
                    f.from_s, f.to_s
                )));
            }
        }
        Ok(())
    }
}

/// What is written for one sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Written {
    /// A reading (flawed or not).
    Value(f64),
    /// A dropout written `{"value":null}`.
    Null,
    /// A dropout written `{"value":NaN}`.
    NaN,
}

/// The flaws that were laid on a run, recorded in its truth file (times in s after the
/// start, as the samples' times).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct FlawRecord {
    /// The flaws asked for.
    pub asked: Option<Flaws>,
    /// Per dropout channel, the number of its samples written missing.
    pub dropouts: Vec<ChannelDropouts>,
    /// The times of the input's missing samples.
    pub input_timeouts_s: Vec<f64>,
    /// The glitches as written.
    pub glitches: Vec<Glitch>,
    /// The freeze as laid: the first and last frozen sample's time and the value held.
    pub freeze: Option<FrozenStretch>,
}

/// A channel's dropouts.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ChannelDropouts {
    /// The channel's quantity.
    pub channel: Quantity,
    /// Its samples written missing.
    pub count: usize,
}

/// A glitch as written.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Glitch {
    /// The sample's time, s after the start.
    pub time_s: f64,
    /// The value written in place of the reading.
    pub value: f64,
}

/// A frozen stretch as written.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FrozenStretch {
    /// The first frozen sample's time, s after the start.
    pub from_s: f64,
    /// The last frozen sample's time, s after the start.
    pub to_s: f64,
    /// The value held.
    pub value: f64,
}

/// Where the flaws fall: a plan made from the channels' sample counts before any sample
/// is written, then applied sample by sample.
pub(super) struct FlawPlan {
    flaws: Flaws,
    /// Sample indices of the timeouts, of the glitches (ascending).
    timeouts: Vec<usize>,
    glitches: Vec<usize>,
    /// Per channel (by quantity): samples seen so far, dropouts written.
    seen: std::collections::HashMap<Quantity, usize>,
    held: Option<f64>,
    record: FlawRecord,
}

impl FlawPlan {
    /// The plan for `flaws` on a run whose electrical channels have `electrical_samples`
    /// samples and whose temperatures have `temperature_samples`; the flaws' times are
    /// drawn from their own generator seeded from `seed`.
    pub(super) fn new(
        flaws: &Flaws,
        electrical_samples: usize,
        temperature_samples: usize,
        seed: u64,
    ) -> FlawPlan {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed ^ 0x0066_6c61_7773);
        let count = |q: Quantity| {
            if super::slow(q) {
                temperature_samples
            } else {
                electrical_samples
            }
        };
        let timeouts = spread(flaws.input_timeouts, count(flaws.timeout_channel), &mut rng);
        let glitches = spread(flaws.glitches, count(flaws.glitch_channel), &mut rng);
        FlawPlan {
            flaws: flaws.clone(),
            timeouts,
            glitches,
            seen: Default::default(),
            held: None,
            record: FlawRecord {
                asked: flaws.any().then(|| flaws.clone()),
                dropouts: flaws
                    .dropout_channels
                    .iter()
                    .map(|&channel| ChannelDropouts { channel, count: 0 })
                    .collect(),
                ..FlawRecord::default()
            },
        }
    }

    /// What is written for the next sample of `quantity`, read `value` at `t_s` after
    /// the start. A dropout wins over a glitch, a glitch over the freeze.
    pub(super) fn apply(&mut self, quantity: Quantity, t_s: f64, value: f64) -> Written {
        let seen = self.seen.entry(quantity).or_insert(0);
        let index = *seen;
        *seen += 1;
        let mut out = value;
        if quantity == self.flaws.freeze_channel {
            out = self.frozen(t_s, value);
        }
        let f = &self.flaws;
        if quantity == f.glitch_channel {
            if let Ok(j) = self.glitches.binary_search(&index) {
                out = if j % 2 == 0 {
                    // Rounded as every written value is, so that it reads as a sensor's.
                    super::round_to_12_digits(value + GLITCH_OFFSET_K)
                } else {
                    FAULT_CODE
                };
                self.record.glitches.push(Glitch {
                    time_s: t_s,
                    value: out,
                });
            }
        }
        if quantity == f.timeout_channel && self.timeouts.binary_search(&index).is_ok() {
            self.record.input_timeouts_s.push(t_s);
            return Written::Null;
        }
        let dropout = f
            .dropout_every
            .is_some_and(|n| (index + 1).is_multiple_of(n));
        if let Some(d) = self
            .record
            .dropouts
            .iter_mut()
            .find(|d| d.channel == quantity)
        {
            if dropout {
                d.count += 1;
                return if d.count % 2 == 1 {
                    Written::Null
                } else {
                    Written::NaN
                };
            }
        }
        Written::Value(out)
    }

    /// The frozen channel's value at `t_s`: the first reading inside the freeze, held
    /// until it ends.
    fn frozen(&mut self, t_s: f64, value: f64) -> f64 {
        let Some(freeze) = self.flaws.freeze else {
            return value;
        };
        if !(freeze.from_s..freeze.to_s).contains(&t_s) {
            return value;
        }
        let held = *self.held.get_or_insert(value);
        let stretch = self.record.freeze.get_or_insert(FrozenStretch {
            from_s: t_s,
            to_s: t_s,
            value: held,
        });
        stretch.to_s = t_s;
        held
    }

    /// The record of what was laid.
    pub(super) fn finish(self) -> FlawRecord {
        self.record
    }
}

/// `n` sample indices out of `samples`, one in each of n equal slots, drawn from the
/// slot's middle half so that no two are adjacent and none sits at an end of the run.
fn spread(n: usize, samples: usize, rng: &mut impl Rng) -> Vec<usize> {
    if n == 0 || samples == 0 {
        return Vec::new();
    }
    let slot = samples as f64 / n as f64;
    let mut picked: Vec<usize> = (0..n)
        .map(|j| {
            let start = j as f64 * slot + 0.25 * slot;
            (start + rng.random::<f64>() * 0.5 * slot).floor() as usize
        })
        .map(|i| i.min(samples - 1))
        .collect();
    picked.dedup();
    picked
}
