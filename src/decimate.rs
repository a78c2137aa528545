//! Decimation stage: samples at each channel's own rate → one grid of sample time Ts.
//!
//! Input: [`Sample`]s in any order (the decimator is a [`SampleSink`]). Output: a
//! [`DecimatedRecording`]: one value or `None` per grid instant t_k = k·Ts and
//! quantity. A channel faster than the grid is block-averaged over its window
//! (see [`Alignment`]), which is also its anti-alias filter; a slower channel is
//! interpolated linearly between neighbouring samples. Where a channel has no
//! data — an empty window, or neighbours further apart than 1.5 of its nominal
//! sample period — the value is `None`: a gap is recorded, never bridged.
//! Several sensors of one quantity are averaged where they have data.

use std::collections::{BTreeMap, HashMap};

use serde::Serialize;

use crate::error::{Error, Result};
use crate::recording::{Alignment, Quantity, Sample, SampleSink, SensorChannel};
use crate::series::Series;

/// Neighbouring samples further apart than this many nominal periods enclose a gap.
pub const GAP_FACTOR: f64 = 1.5;

/// Running sums of one grid window of one channel.
#[derive(Debug, Clone, Copy, Default)]
struct Window {
    sum: f64,
    /// Sum of the sample times' offsets from the window's reference time, in s (f32: the
    /// offsets are within ±Ts, and the window stays 16 bytes).
    offset_sum: f32,
    count: u32,
}

/// Windows per storage block.
const BLOCK: i64 = 1024;

/// Most grid instants a recording may span (about 3 years at Ts = 1 s).
pub const MAX_GRID_INSTANTS: i64 = 100_000_000;

/// The windows of one channel, in blocks of [`BLOCK`] allocated where samples fall, so
/// that memory follows the data and a stray timestamp costs one block, not its distance.
#[derive(Debug, Default)]
struct ChannelWindows {
    alignment: Option<Alignment>,
    blocks: Vec<Box<[Window]>>,
    /// Block number → index in `blocks`.
    block_of: HashMap<i64, usize>,
    /// The block used last: (block number, index), the common case of the next sample.
    last: Option<(i64, usize)>,
    /// Latest sample time seen so far in file order, ns.
    latest_ns: Option<i64>,
    /// A backward step in file order under watch: (time jumped from, time jumped to,
    /// samples checked since, of which landed in windows that already had data).
    suspect: Option<(i64, i64, u32, u32)>,
    /// A confirmed clock jump: (from, to).
    clock_jump: Option<(i64, i64)>,
}

/// A step back in a channel's own time, in file order, that is watched as a possible clock jump.
const CLOCK_JUMP_MIN_NS: i64 = 60_000_000_000;
/// Samples after a backward step that decide whether it overlaps earlier data.
const CLOCK_JUMP_WATCH: u32 = 20;

impl ChannelWindows {
    fn slot(&mut self, block: i64) -> usize {
        if let Some((b, i)) = self.last {
            if b == block {
                return i;
            }
        }
        let next = self.blocks.len();
        let i = *self.block_of.entry(block).or_insert(next);
        if i == next {
            self.blocks
                .push(vec![Window::default(); BLOCK as usize].into_boxed_slice());
        }
        self.last = Some((block, i));
        i
    }

    fn window_mut(&mut self, k: i64) -> &mut Window {
        let (block, at) = (k.div_euclid(BLOCK), k.rem_euclid(BLOCK) as usize);
        let i = self.slot(block);
        &mut self.blocks[i][at]
    }

    fn occupied(&self, k: i64) -> bool {
        let (block, at) = (k.div_euclid(BLOCK), k.rem_euclid(BLOCK) as usize);
        self.block_of
            .get(&block)
            .is_some_and(|&i| self.blocks[i][at].count > 0)
    }

    /// First and last occupied window and the number of samples, without allocating.
    fn extent(&self) -> Option<(i64, i64, i64)> {
        let (mut first, mut last, mut count) = (i64::MAX, i64::MIN, 0i64);
        for (&b, &i) in &self.block_of {
            for (j, w) in self.blocks[i].iter().enumerate() {
                if w.count > 0 {
                    let k = b * BLOCK + j as i64;
                    first = first.min(k);
                    last = last.max(k);
                    count += w.count as i64;
                }
            }
        }
        (count > 0).then_some((first, last, count))
    }

    /// The occupied windows in grid order: (k, window).
    fn occupied_windows(&self) -> Vec<(i64, Window)> {
        let mut order: Vec<(i64, usize)> = self.block_of.iter().map(|(b, i)| (*b, *i)).collect();
        order.sort_unstable();
        order
            .into_iter()
            .flat_map(|(b, i)| {
                self.blocks[i]
                    .iter()
                    .enumerate()
                    .filter(|(_, w)| w.count > 0)
                    .map(move |(j, w)| (b * BLOCK + j as i64, *w))
            })
            .collect()
    }
}

/// Streams samples into per-channel grid windows.
#[derive(Debug)]
pub struct Decimator {
    ts_ns: i64,
    channels: Vec<ChannelWindows>,
    quantities: Vec<Quantity>,
}

/// What the decimator learnt about one channel.
#[derive(Debug, Clone, Serialize)]
pub struct ChannelGrid {
    /// The channel's topic.
    pub topic: String,
    /// The quantity.
    pub quantity: Quantity,
    /// Median spacing of the channel's samples, in s (its nominal sample period).
    pub nominal_period_s: f64,
    /// Whether it has a sample in (nearly) every grid window (block-averaged), or
    /// is slower than the grid (interpolated).
    pub block_averaged: bool,
    /// Number of gaps inside its span.
    pub gaps: usize,
    /// Grid instants inside its span without a value because of gaps.
    pub gap_instants: usize,
}

/// One quantity on the grid.
#[derive(Debug, Clone)]
pub struct DecimatedSeries {
    /// The quantity.
    pub quantity: Quantity,
    /// The value at each grid instant in the canonical unit, `None` where no sensor has data.
    pub values: Series,
    /// How many sensors were combined.
    pub sensors: usize,
}

/// A heat run on one time grid: the decimator's output.
#[derive(Debug, Clone)]
pub struct DecimatedRecording {
    /// Sample time Ts in ns.
    pub ts_ns: i64,
    /// Index k of the first grid instant: t_0 = first_index·Ts since the epoch.
    pub first_index: i64,
    /// Number of grid instants.
    pub len: usize,
    /// The quantities present.
    pub series: BTreeMap<Quantity, DecimatedSeries>,
    /// Per-channel findings, in channel order.
    pub channels: Vec<ChannelGrid>,
}

impl DecimatedRecording {
    /// Sample time in seconds.
    pub fn ts_s(&self) -> f64 {
        self.ts_ns as f64 * 1e-9
    }

    /// Time of grid instant i in ns since the epoch: (first_index + i)·Ts.
    pub fn time_ns(&self, i: usize) -> i64 {
        (self.first_index + i as i64) * self.ts_ns
    }

    /// The series of a quantity, if the recording has it.
    pub fn get(&self, q: Quantity) -> Option<&DecimatedSeries> {
        self.series.get(&q)
    }
}

impl Decimator {
    /// A decimator onto the grid of sample time `ts_s` seconds.
    pub fn new(ts_s: f64) -> Result<Decimator> {
        if !(ts_s.is_finite() && ts_s >= 1e-3 && ts_s <= 3600.0) {
            return Err(Error::Usage(format!(
                "--ts {ts_s}: the sample time must be between 0.001 s and 3600 s"
            )));
        }
        Ok(Decimator {
            ts_ns: (ts_s * 1e9).round() as i64,
            channels: Vec::new(),
            quantities: Vec::new(),
        })
    }

    fn reference_ns(&self, alignment: Alignment, k: i64) -> i64 {
        match alignment {
            Alignment::Instant => k * self.ts_ns,
            Alignment::Interval => k * self.ts_ns + self.ts_ns / 2,
        }
    }

    /// Finishes the grid: `None` where a channel has no data, sensors combined.
    pub fn finish(mut self, channels: &[SensorChannel]) -> Result<DecimatedRecording> {
        let mut lo = i64::MAX;
        let mut hi = i64::MIN;
        let mut densest = 0i64;
        for ch in &self.channels {
            if let Some((first, last, count)) = ch.extent() {
                lo = lo.min(first);
                hi = hi.max(last);
                densest = densest.max(count);
            }
        }
        // The grid must stay in proportion to the data: a stray timestamp far from the rest
        // would otherwise make every series as long as the distance to it.
        if lo <= hi && (hi - lo >= MAX_GRID_INSTANTS || hi - lo > 100 * densest + 100_000) {
            let at = |k: i64| crate::recording::format_time((k * self.ts_ns).max(0) as u64);
            return Err(Error::InsufficientData(format!(
                "the samples span {} to {}, far more sample times than there are samples: a clock \
                 or a timestamp is damaged, or --ts is too short for the data (see `heatrun info`)",
                at(lo),
                at(hi)
            )));
        }
        if lo > hi {
            return Err(Error::InsufficientData(
                "the recording holds no heat-run samples".into(),
            ));
        }
        for (idx, ch) in self.channels.iter().enumerate() {
            if let Some((from, to)) = ch.clock_jump {
                let topic = channels.get(idx).map(|c| c.topic.as_str()).unwrap_or("?");
                return Err(Error::ClockJump(format!(
                    "channel {topic}: its clock jumps back from {} to {} and the samples after the jump \
                     overlap earlier ones, so their times cannot be trusted (a clock reset, or two \
                     recordings merged); cut the recording at the jump",
                    crate::recording::format_time(from.max(0) as u64),
                    crate::recording::format_time(to.max(0) as u64)
                )));
            }
        }
        let len = (hi - lo + 1) as usize;
        let mut grids = Vec::new();
        let mut per_quantity: BTreeMap<Quantity, Vec<Series>> = BTreeMap::new();
        let ts_ns = self.ts_ns;
        let quantities = self.quantities.clone();
        // One channel at a time: its windows are freed before the next is laid out.
        for (idx, ch) in std::mem::take(&mut self.channels).into_iter().enumerate() {
            let quantity = quantities[idx];
            let alignment = quantity.alignment();
            let windows = ch.occupied_windows();
            drop(ch);
            let (values, grid) = channel_on_grid(ts_ns, &windows, alignment, lo, len);
            grids.push(ChannelGrid {
                topic: channels
                    .get(idx)
                    .map(|c| c.topic.clone())
                    .unwrap_or_default(),
                quantity,
                ..grid
            });
            per_quantity.entry(quantity).or_default().push(values);
        }
        let series = per_quantity
            .into_iter()
            .map(|(quantity, sensors)| {
                let values = (0..len)
                    .map(|i| {
                        let (sum, n) = sensors
                            .iter()
                            .filter_map(|s| s.get(i))
                            .fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
                        (n > 0).then(|| sum / n as f64)
                    })
                    .collect();
                (
                    quantity,
                    DecimatedSeries {
                        quantity,
                        values,
                        sensors: sensors.len(),
                    },
                )
            })
            .collect();
        Ok(DecimatedRecording {
            ts_ns,
            first_index: lo,
            len,
            series,
            channels: grids,
        })
    }
}

/// The time of window k's reference point, ns: the instant, or the middle of the interval.
fn reference_ns(ts_ns: i64, alignment: Alignment, k: i64) -> i64 {
    match alignment {
        Alignment::Instant => k * ts_ns,
        Alignment::Interval => k * ts_ns + ts_ns / 2,
    }
}

fn channel_on_grid(
    ts_ns: i64,
    windows: &[(i64, Window)],
    alignment: Alignment,
    lo: i64,
    len: usize,
) -> (Series, ChannelGrid) {
    let ts = ts_ns as f64 * 1e-9;
    // Occupied windows as points (grid index, mean time in s relative to grid start, mean).
    let points: Vec<(i64, f64, f64)> = windows
        .iter()
        .map(|(k, w)| {
            let k = *k;
            let t = (reference_ns(ts_ns, alignment, k) - lo * ts_ns) as f64 * 1e-9
                + w.offset_sum as f64 / w.count as f64;
            (k, t, w.sum / w.count as f64)
        })
        .collect();
    let mut values = Series::unknown(len);
    let empty = ChannelGrid {
        topic: String::new(),
        quantity: Quantity::CoreTemp,
        nominal_period_s: f64::NAN,
        block_averaged: false,
        gaps: 0,
        gap_instants: 0,
    };
    if points.is_empty() {
        return (values, empty);
    }
    let total: u64 = windows.iter().map(|(_, w)| w.count as u64).sum();
    let mut index_steps: Vec<i64> = points.windows(2).map(|p| p[1].0 - p[0].0).collect();
    index_steps.sort_unstable();
    let median_step = index_steps.get(index_steps.len() / 2).copied().unwrap_or(1);
    let block_averaged = median_step <= 1;
    let (first_k, last_k) = (points[0].0, points[points.len() - 1].0);
    let mut gaps = 0;
    let mut gap_instants = 0;
    let nominal_period_s;
    if block_averaged {
        let span_windows = (last_k - first_k + 1) as f64;
        nominal_period_s = ts * span_windows / total as f64;
        for &(k, _, v) in &points {
            values.set((k - lo) as usize, Some(v));
        }
        for p in points.windows(2) {
            if p[1].0 - p[0].0 > 1 {
                gaps += 1;
                gap_instants += (p[1].0 - p[0].0 - 1) as usize;
            }
        }
    } else {
        let mut spacing: Vec<f64> = points.windows(2).map(|p| p[1].1 - p[0].1).collect();
        spacing.sort_by(f64::total_cmp);
        nominal_period_s = spacing[spacing.len() / 2];
        let limit = GAP_FACTOR * nominal_period_s;
        // Interpolate at each instant's reference time between the points around it.
        let offset = match alignment {
            Alignment::Instant => 0.0,
            Alignment::Interval => ts / 2.0,
        };
        let mut j = 0;
        for i in 0..len {
            let t = i as f64 * ts + offset;
            while j + 1 < points.len() && points[j + 1].1 < t {
                j += 1;
            }
            let a = points[j];
            if let Some(exact) = points[j..(j + 2).min(points.len())]
                .iter()
                .find(|p| (p.1 - t).abs() < 1e-9)
            {
                values.set(i, Some(exact.2));
                continue;
            }
            if j + 1 >= points.len() || a.1 > t {
                continue;
            }
            let b = points[j + 1];
            if b.1 - a.1 <= limit {
                values.set(i, Some(a.2 + (b.2 - a.2) * (t - a.1) / (b.1 - a.1)));
            } else {
                gap_instants += 1;
            }
        }
        gaps = points
            .windows(2)
            .filter(|p| p[1].1 - p[0].1 > limit)
            .count();
    }
    (
        values,
        ChannelGrid {
            nominal_period_s,
            block_averaged,
            gaps,
            gap_instants,
            ..empty
        },
    )
}

impl SampleSink for Decimator {
    fn channel(&mut self, channel: &SensorChannel) {
        while self.channels.len() <= channel.index {
            self.channels.push(ChannelWindows::default());
            self.quantities.push(channel.quantity);
        }
        self.channels[channel.index].alignment = Some(channel.quantity.alignment());
        self.quantities[channel.index] = channel.quantity;
    }

    fn sample(&mut self, sample: Sample) {
        if !sample.value.is_finite() {
            return;
        }
        let ts = self.ts_ns;
        let alignment = self.channels[sample.channel]
            .alignment
            .unwrap_or(Alignment::Instant);
        let t = sample.log_time_ns as i64;
        let k = match alignment {
            Alignment::Instant => (t + ts / 2).div_euclid(ts),
            Alignment::Interval => t.div_euclid(ts),
        };
        let reference = self.reference_ns(alignment, k);
        let ch = &mut self.channels[sample.channel];
        // Out-of-order storage lands earlier samples in empty windows; a clock jump back
        // lands them on windows that already hold data. Watch each large backward step.
        let latest = ch.latest_ns.unwrap_or(t);
        if ch.suspect.is_none() && ch.clock_jump.is_none() && t < latest - CLOCK_JUMP_MIN_NS {
            ch.suspect = Some((latest, t, 0, 0));
        }
        ch.latest_ns = Some(latest.max(t));
        let occupied = ch.suspect.is_some() && ch.occupied(k);
        if let Some((from, to, checked, overlapped)) = ch.suspect.as_mut() {
            *checked += 1;
            if occupied {
                *overlapped += 1;
            }
            if *checked >= CLOCK_JUMP_WATCH {
                if *overlapped * 4 >= *checked * 3 {
                    ch.clock_jump = Some((*from, *to));
                }
                ch.suspect = None;
            }
        }
        let w = ch.window_mut(k);
        w.sum += sample.value;
        w.offset_sum += ((t - reference) as f64 * 1e-9) as f32;
        w.count += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel(index: usize, quantity: Quantity) -> SensorChannel {
        SensorChannel {
            index,
            topic: format!("/scada/{quantity}"),
            quantity,
            sensor: None,
            unit: quantity.canonical_unit().into(),
            unit_scale: 1.0,
        }
    }

    const S: u64 = 1_000_000_000;

    #[test]
    fn block_average_of_interval_channel() {
        // 10 Hz current over two 1-s intervals: values 0..9 then 10..19.
        let chans = [channel(0, Quantity::ArmatureCurrent)];
        let mut d = Decimator::new(1.0).unwrap();
        d.channel(&chans[0]);
        for i in 0..20u64 {
            d.sample(Sample {
                channel: 0,
                log_time_ns: 100 * S + i * S / 10,
                value: i as f64,
            });
        }
        let r = d.finish(&chans).unwrap();
        assert_eq!(r.first_index, 100);
        let v = &r.get(Quantity::ArmatureCurrent).unwrap().values;
        assert_eq!(v, &vec![Some(4.5), Some(14.5)]);
    }

    #[test]
    fn instant_channel_is_centred_on_grid_instants() {
        // 10 Hz temperature at t = 99.55 … 100.45 averages onto instant 100.
        let chans = [channel(0, Quantity::CoreTemp)];
        let mut d = Decimator::new(1.0).unwrap();
        d.channel(&chans[0]);
        for i in 0..10u64 {
            let t = 99 * S + S / 2 + S / 20 + i * S / 10; // 99.55, 99.65, … 100.45
            d.sample(Sample {
                channel: 0,
                log_time_ns: t,
                value: 2.0 * i as f64,
            });
        }
        let r = d.finish(&chans).unwrap();
        assert_eq!(r.first_index, 100);
        assert_eq!(r.get(Quantity::CoreTemp).unwrap().values, vec![Some(9.0)]);
    }

    #[test]
    fn slow_channel_is_interpolated_and_gap_is_not_bridged() {
        // A temperature every 10 s, linear in time, with one sample missing.
        let chans = [channel(0, Quantity::CoreTemp)];
        let mut d = Decimator::new(1.0).unwrap();
        d.channel(&chans[0]);
        for i in (0..8u64).filter(|i| *i != 5) {
            d.sample(Sample {
                channel: 0,
                log_time_ns: i * 10 * S,
                value: i as f64 * 10.0,
            });
        }
        let r = d.finish(&chans).unwrap();
        let v = &r.get(Quantity::CoreTemp).unwrap().values;
        assert_eq!(r.len, 71);
        for (i, x) in v.iter().enumerate() {
            if (40..60).contains(&i) && i != 40 {
                assert_eq!(x, None, "instant {i} lies in the gap");
            } else {
                assert!((x.unwrap() - i as f64).abs() < 1e-9, "instant {i}: {x:?}");
            }
        }
        assert_eq!(r.channels[0].gaps, 1);
        assert!(!r.channels[0].block_averaged);
        assert!((r.channels[0].nominal_period_s - 10.0).abs() < 1e-12);
    }

    #[test]
    fn order_of_samples_does_not_matter() {
        let chans = [channel(0, Quantity::ArmatureCurrent)];
        let samples: Vec<Sample> = (0..50u64)
            .map(|i| Sample {
                channel: 0,
                log_time_ns: 10 * S + i * S / 5,
                value: (i * i) as f64,
            })
            .collect();
        let run = |order: &[usize]| {
            let mut d = Decimator::new(1.0).unwrap();
            d.channel(&chans[0]);
            for &i in order {
                d.sample(samples[i]);
            }
            d.finish(&chans)
                .unwrap()
                .get(Quantity::ArmatureCurrent)
                .unwrap()
                .values
                .clone()
        };
        let forward: Vec<usize> = (0..50).collect();
        let backward: Vec<usize> = (0..50).rev().collect();
        assert_eq!(run(&forward), run(&backward));
    }

    #[test]
    fn empty_window_of_fast_channel_is_a_gap() {
        let chans = [channel(0, Quantity::LineVoltage)];
        let mut d = Decimator::new(1.0).unwrap();
        d.channel(&chans[0]);
        for i in (0..100u64).filter(|i| !(30..40).contains(i)) {
            d.sample(Sample {
                channel: 0,
                log_time_ns: i * S / 10,
                value: 1.0,
            });
        }
        let r = d.finish(&chans).unwrap();
        let v = &r.get(Quantity::LineVoltage).unwrap().values;
        assert_eq!(v.get(3), None);
        assert_eq!(v.iter().filter(|x| x.is_some()).count(), 9);
        assert_eq!(r.channels[0].gaps, 1);
    }

    #[test]
    fn sensors_of_one_quantity_are_averaged() {
        let chans = [
            channel(0, Quantity::StatorWindingTemp),
            channel(1, Quantity::StatorWindingTemp),
        ];
        let mut d = Decimator::new(1.0).unwrap();
        d.channel(&chans[0]);
        d.channel(&chans[1]);
        for i in 0..5u64 {
            d.sample(Sample {
                channel: 0,
                log_time_ns: i * S,
                value: 50.0,
            });
            if i != 2 {
                d.sample(Sample {
                    channel: 1,
                    log_time_ns: i * S,
                    value: 52.0,
                });
            }
        }
        let r = d.finish(&chans).unwrap();
        let s = r.get(Quantity::StatorWindingTemp).unwrap();
        assert_eq!(s.sensors, 2);
        assert_eq!(s.values.get(1), Some(51.0));
        assert_eq!(
            s.values.get(2),
            Some(50.0),
            "one sensor missing: the other stands"
        );
    }
}
