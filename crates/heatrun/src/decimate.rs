//! Decimation stage: samples at each channel's own rate → one grid of sample time Ts.
//!
//! Input: [`Sample`]s in any order (the decimator is a [`SampleSink`]). Output: a
//! [`DecimatedRecording`]: one value or `None` per grid instant t_k = k·Ts and
//! signal. A channel faster than the grid is block-averaged over its window
//! (see [`Alignment`]), which is also its anti-alias filter; a slower channel is
//! interpolated linearly between neighbouring samples, or held from one to the next where
//! its metadata says so (a command: [`Interpolation::Step`]). Where a channel has no
//! data — an empty window, or neighbours further apart than 1.5 of its nominal
//! sample period — the value is `None`: a gap is recorded, never bridged.
//! Several sensors of one signal are averaged where they have data.
//!
//! The order the samples arrive in changes nothing: each window is a sum, and a channel
//! whose clock jumped back is recognised by what its samples say — a stretch holding
//! about twice the samples its rate allows, the earlier samples and those after the jump
//! sharing the same times ([`ClockJump`]) — not by the order they are stored in.

use std::collections::{BTreeMap, HashMap};
use std::hash::{BuildHasherDefault, Hasher};

use serde::Serialize;

/// The decimation stage's result.
pub type Result<T, E = DecimateError> = std::result::Result<T, E>;
use crate::recording::{
    format_time, Alignment, Interpolation, Quantity, Sample, SampleSink, SensorChannel, Signal,
    Storage,
};
use crate::series::Series;

/// Neighbouring samples further apart than this many nominal periods enclose a gap
/// (for a channel stored by exception: this many of its longest interval).
pub const GAP_FACTOR: f64 = 1.5;

/// Most grid instants a recording may span (about 3 years at Ts = 1 s).
pub const MAX_GRID_INSTANTS: i64 = 100_000_000;

/// The shortest stretch of doubled samples taken for a clock jump, s: shorter ones are
/// within what a recorder's buffering can do to a channel's rate.
pub const CLOCK_JUMP_MIN_S: f64 = 60.0;

/// A stretch this many times denser than the channel's rate is a doubled stretch.
const DENSE_FACTOR: f64 = 1.6;

/// Samples expected per stretch the density is judged over.
const DENSITY_SAMPLES: i64 = 16;

/// Windows per storage block.
const BLOCK: i64 = 1024;

/// Why samples cannot be laid on the grid.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DecimateError {
    /// The grid's sample time is outside the range the decimator supports.
    #[error("the sample time {ts_s} s is outside 0.001 s to 3600 s")]
    SampleTime {
        /// The sample time asked for, s.
        ts_s: f64,
    },
    /// No channel delivered a sample.
    #[error("the recording holds no heat-run samples")]
    NoSamples,
    /// The samples span far more grid instants than there are samples.
    #[error(
        "the samples span {} to {}, far more sample times than there are samples: a clock \
         or a timestamp is damaged, or the sample time is too short for the data",
        format_time(*.first_ns), format_time(*.last_ns)
    )]
    SparseSpan {
        /// The first grid instant with a sample, ns since the epoch.
        first_ns: u64,
        /// The last grid instant with a sample, ns since the epoch.
        last_ns: u64,
    },
    /// A channel's clock jumped back over its own earlier samples.
    #[error(
        "channel {channel}: its clock jumps back: from {} to {} it holds {:.1} times the \
         samples its rate allows, so samples after a jump overlap earlier ones and their \
         times cannot be trusted (a clock reset, two recordings of it merged, or a stretch \
         written twice); cut the recording at the jump",
        format_time(.jump.overlap_start_ns), format_time(.jump.overlap_end_ns), .jump.density_ratio
    )]
    ClockJump {
        /// The channel's topic.
        channel: String,
        /// Where and how much.
        jump: ClockJump,
    },
}

/// A stretch of one channel holding about twice the samples its rate allows: its clock
/// jumped back to `overlap_start_ns`, and the samples after the jump share the times of
/// the earlier ones until `overlap_end_ns`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ClockJump {
    /// Start of the doubled stretch (where the clock jumped back to), ns since the epoch.
    pub overlap_start_ns: u64,
    /// End of the doubled stretch, ns since the epoch.
    pub overlap_end_ns: u64,
    /// Samples in the stretch over those the channel's rate gives (about 2 for one jump).
    pub density_ratio: f64,
}

/// Running sums of one grid window of one channel.
#[derive(Debug, Clone, Copy, Default)]
struct Window {
    sum: f64,
    /// Sum of the sample times' offsets from the window's reference time, in s (f32: the
    /// offsets are within ±Ts, and the window stays 16 bytes).
    offset_sum: f32,
    count: u32,
}

/// Hashes a block number by one multiplication: block numbers are not chosen by an
/// adversary, and a sample in a block other than the last one's (any order but time
/// order) looks its block up.
#[derive(Debug, Default)]
struct BlockHasher(u64);

impl Hasher for BlockHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ b as u64).wrapping_mul(0x100_0000_01b3);
        }
    }

    fn write_i64(&mut self, block: i64) {
        // Fibonacci hashing: the high bits, which the table uses, mix every input bit.
        self.0 = (block as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    }
}

/// The windows of one channel, in blocks of [`BLOCK`] allocated where samples fall, so
/// that memory follows the data and a stray timestamp costs one block, not its distance.
#[derive(Debug)]
struct ChannelWindows {
    /// Where the channel's samples are windowed (a channel stored by exception: the
    /// nearest instant, whatever its signal's alignment).
    alignment: Alignment,
    blocks: Vec<Box<[Window]>>,
    /// Block number → index in `blocks`.
    block_of: HashMap<i64, usize, BuildHasherDefault<BlockHasher>>,
    /// The block used last: (block number, index), the common case of the next sample.
    last: Option<(i64, usize)>,
}

impl ChannelWindows {
    fn new(alignment: Alignment) -> ChannelWindows {
        ChannelWindows {
            alignment,
            blocks: Vec::new(),
            block_of: HashMap::default(),
            last: None,
        }
    }

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

/// The time of window k's reference point, ns: the instant, or the middle of the interval.
fn reference_ns(ts_ns: i64, alignment: Alignment, k: i64) -> i64 {
    match alignment {
        Alignment::Instant => k * ts_ns,
        Alignment::Interval => k * ts_ns + ts_ns / 2,
    }
}

/// The window a sample at `t` ns falls in.
fn window_of(ts_ns: i64, alignment: Alignment, t: i64) -> i64 {
    match alignment {
        Alignment::Instant => (t + ts_ns / 2).div_euclid(ts_ns),
        Alignment::Interval => t.div_euclid(ts_ns),
    }
}

/// Streams samples into per-channel grid windows.
#[derive(Debug)]
pub(crate) struct Decimator {
    ts_ns: i64,
    alignments: BTreeMap<Signal, Alignment>,
    /// Per channel index: its windows, signal and storage (`None` until announced).
    channels: Vec<Option<(ChannelWindows, Signal, Storage)>>,
}

/// What the decimator learnt about one channel.
#[derive(Debug, Clone, Serialize)]
pub struct ChannelGrid {
    /// The channel's topic.
    pub topic: String,
    /// The signal it carries.
    pub signal: Signal,
    /// How its samples were stored.
    pub storage: Storage,
    /// Its nominal sample period, in s: from the samples per window of a channel faster
    /// than the grid, the median spacing of its samples otherwise.
    pub nominal_period_s: f64,
    /// Whether it has a sample in (nearly) every grid window (block-averaged), or
    /// is slower than the grid or stored by exception (interpolated).
    pub block_averaged: bool,
    /// Number of gaps inside its span (never a silence of a channel stored by exception
    /// shorter than 1.5 × its longest interval).
    pub gaps: usize,
    /// Grid instants inside its span without a value because of gaps.
    pub gap_instants: usize,
    /// A stretch where its samples come twice: its clock jumped back.
    pub clock_jump: Option<ClockJump>,
}

/// One signal on the grid.
#[derive(Debug, Clone)]
pub struct DecimatedSeries {
    /// The signal.
    pub signal: Signal,
    /// The unit of `values`: the quantity's canonical unit, or a free channel's as written.
    pub unit: String,
    /// The value at each grid instant, unknown where no sensor has data.
    pub values: Series,
    /// How many sensors were combined.
    pub sensors: usize,
    /// For a signal with a channel stored by exception: at each grid instant, whether a
    /// stored sample falls in its window (an exact value, assigned to the nearest instant)
    /// rather than one interpolated or held between stored samples. `None` for sampled
    /// signals.
    pub observed: Option<Vec<bool>>,
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
    /// The signals present.
    pub series: BTreeMap<Signal, DecimatedSeries>,
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

    /// The series of a profile quantity, if the recording has it.
    pub fn get(&self, q: Quantity) -> Option<&DecimatedSeries> {
        self.series.get(&Signal::Profile(q))
    }

    /// The series of any signal (a free channel among them), if the recording has it.
    pub fn get_signal(&self, s: &Signal) -> Option<&DecimatedSeries> {
        self.series.get(s)
    }

    /// The same signals on `len` grid instants from grid index `first_index` (t_0 =
    /// first_index·Ts): unknown (and not observed) where this recording has no instant.
    /// A stream lays each stretch on the one grid of the whole recording with it.
    pub fn window(&self, first_index: i64, len: usize) -> DecimatedRecording {
        let source = |i: usize| -> Option<usize> {
            let k = first_index + i as i64 - self.first_index;
            (0..self.len as i64).contains(&k).then_some(k as usize)
        };
        let series = self
            .series
            .iter()
            .map(|(signal, s)| {
                let values = (0..len).map(|i| s.values.get(source(i)?)).collect();
                let observed = s
                    .observed
                    .as_ref()
                    .map(|o| (0..len).map(|i| source(i).is_some_and(|k| o[k])).collect());
                let laid = DecimatedSeries {
                    signal: s.signal.clone(),
                    unit: s.unit.clone(),
                    values,
                    sensors: s.sensors,
                    observed,
                };
                (signal.clone(), laid)
            })
            .collect();
        DecimatedRecording {
            ts_ns: self.ts_ns,
            first_index,
            len,
            series,
            channels: self.channels.clone(),
        }
    }
}

/// Where a `Decimator` with the signals' `alignments` windows `channel`'s samples: a
/// channel stored by exception at the nearest instant, a sampled one as its signal says.
pub fn channel_alignment(
    alignments: &BTreeMap<Signal, Alignment>,
    channel: &SensorChannel,
) -> Alignment {
    match channel.storage {
        Storage::Exception { .. } => Alignment::Instant,
        Storage::Sampled => alignments
            .get(&channel.signal)
            .copied()
            .unwrap_or(Alignment::Interval),
    }
}

/// The grid window (index k on the grid of `ts_ns`) a sample at `t_ns` falls in, for a
/// channel windowed with `alignment` ([`channel_alignment`]).
pub fn window_index(ts_ns: i64, alignment: Alignment, t_ns: u64) -> i64 {
    window_of(ts_ns, alignment, t_ns as i64)
}

/// One occupied window as a point: grid index, mean time in s after the grid's start,
/// mean value.
#[derive(Debug, Clone, Copy)]
struct Point {
    k: i64,
    t_s: f64,
    value: f64,
}

/// One channel laid on the grid.
struct Laid {
    values: Series,
    /// Occupied windows, for a channel stored by exception.
    observed: Option<Vec<bool>>,
    grid: ChannelGrid,
}

impl Decimator {
    /// A decimator onto the grid of sample time `ts_s` seconds; `alignments` says where
    /// each signal's samples sit on it (a signal not in the map: [`Alignment::Interval`]).
    pub fn new(ts_s: f64, alignments: BTreeMap<Signal, Alignment>) -> Result<Decimator> {
        if !(ts_s.is_finite() && (1e-3..=3600.0).contains(&ts_s)) {
            return Err(DecimateError::SampleTime { ts_s });
        }
        Ok(Decimator {
            ts_ns: (ts_s * 1e9).round() as i64,
            alignments,
            channels: Vec::new(),
        })
    }

    fn alignment(&self, signal: &Signal) -> Alignment {
        self.alignments
            .get(signal)
            .copied()
            .unwrap_or(Alignment::Interval)
    }

    /// Finishes the grid: unknown where a channel has no data, sensors combined. A
    /// channel whose clock jumped back over its own samples is refused.
    pub fn finish(self, channels: &[SensorChannel]) -> Result<DecimatedRecording> {
        self.lay_out(channels, true)
    }

    /// The grid and every channel's findings, a clock jump among them
    /// ([`ChannelGrid::clock_jump`]) rather than refused: what `heatrun info` shows.
    pub fn inspect(self, channels: &[SensorChannel]) -> Result<DecimatedRecording> {
        self.lay_out(channels, false)
    }

    /// The grid's phase φ, s: the median offset from their instants of the samples of
    /// the channels read about once per window at an instant (a temperature recorded
    /// every Ts, as a historian's 10 s export, whose readings need not fall on t_k = k·Ts),
    /// where it exceeds [`OFF_REFERENCE`] of Ts; else 0.
    ///
    /// A reading is the state at its own time: laid on the instant up to Ts/2 away, it
    /// lags or leads the inputs' intervals by that much, which biases the fastest time
    /// constant (9 % on a noise-free 10 s export of an RC unit read 5 s off its
    /// instants). Interpolated to the instant instead, each value is the mean of two
    /// readings and its noise is no longer white (the estimator's choice reads that as a
    /// disturbance). So the grid moves to the readings: every channel is taken at
    /// t_k + φ (`at_reference`, the interpolated channels' reference times), the
    /// readings stay as they were read, and an input's interval mean is the line between
    /// neighbouring windows' means at the shifted interval's middle. The instants keep
    /// their times t_k (off by |φ| ≤ Ts/2).
    fn grid_phase(&self) -> f64 {
        let ts_s = self.ts_ns as f64 * 1e-9;
        let mut offsets: Vec<f32> = Vec::new();
        for (ch, _, storage) in self.channels.iter().flatten() {
            if *storage != Storage::Sampled || ch.alignment != Alignment::Instant {
                continue;
            }
            let Some((first, last, count)) = ch.extent() else {
                continue;
            };
            // About one reading per window: a faster channel's mean sits at the instant.
            let span = last - first + 1;
            if count < 16 || count > span + span / 10 || 2 * count < span {
                continue;
            }
            offsets.extend(
                ch.blocks
                    .iter()
                    .flat_map(|b| b.iter())
                    .filter(|w| w.count == 1)
                    .map(|w| w.offset_sum),
            );
        }
        if offsets.is_empty() {
            return 0.0;
        }
        offsets.sort_by(f32::total_cmp);
        // A phase is a constant offset. Readings whose offsets spread over the window (a
        // drifting clock: TCLab's rows every 1.0013 s) have none, and a moved grid would
        // interpolate every one of them.
        let quartile = |q: usize| offsets[(offsets.len() - 1) * q / 4] as f64;
        if quartile(3) - quartile(1) > PHASE_SPREAD * ts_s {
            return 0.0;
        }
        let phase = offsets[offsets.len() / 2] as f64;
        if phase.abs() > OFF_REFERENCE * ts_s {
            phase
        } else {
            0.0
        }
    }

    /// The first and last occupied window over all channels, checked against the data.
    fn bounds(&self) -> Result<(i64, i64)> {
        let (mut lo, mut hi, mut densest) = (i64::MAX, i64::MIN, 0i64);
        for (ch, _, _) in self.channels.iter().flatten() {
            if let Some((first, last, count)) = ch.extent() {
                lo = lo.min(first);
                hi = hi.max(last);
                densest = densest.max(count);
            }
        }
        if lo > hi {
            return Err(DecimateError::NoSamples);
        }
        // The grid must stay in proportion to the data: a stray timestamp far from the rest
        // would otherwise make every series as long as the distance to it.
        if hi - lo >= MAX_GRID_INSTANTS || hi - lo > 100 * densest + 100_000 {
            let at = |k: i64| (k * self.ts_ns).max(0) as u64;
            return Err(DecimateError::SparseSpan {
                first_ns: at(lo),
                last_ns: at(hi),
            });
        }
        Ok((lo, hi))
    }

    fn lay_out(
        self,
        channels: &[SensorChannel],
        refuse_clock_jumps: bool,
    ) -> Result<DecimatedRecording> {
        let side_by_side = self
            .bounds()
            .is_ok_and(|(lo, hi)| ((hi - lo + 1) as usize) <= SIDE_BY_SIDE_INSTANTS);
        self.lay_out_with(channels, refuse_clock_jumps, side_by_side)
    }

    /// [`Decimator::lay_out`], the channels side by side or one after the other.
    fn lay_out_with(
        mut self,
        channels: &[SensorChannel],
        refuse_clock_jumps: bool,
        side_by_side: bool,
    ) -> Result<DecimatedRecording> {
        let (lo, hi) = self.bounds()?;
        let len = (hi - lo + 1) as usize;
        let ts_ns = self.ts_ns;
        let phase_s = self.grid_phase();
        let jobs: Vec<(usize, ChannelWindows, Signal, Storage)> =
            std::mem::take(&mut self.channels)
                .into_iter()
                .enumerate()
                .filter_map(|(idx, slot)| {
                    slot.map(|(ch, signal, storage)| (idx, ch, signal, storage))
                })
                .collect();
        let lay = |(idx, ch, signal, storage): (usize, ChannelWindows, Signal, Storage)| {
            let channel = channels.get(idx);
            let windows = ch.occupied_windows();
            drop(ch);
            let jump = match storage {
                Storage::Sampled => clock_jump(ts_ns, &windows),
                Storage::Exception { .. } => None,
            };
            let topic = channel.map(|c| c.topic.clone()).unwrap_or_default();
            if let (Some(jump), true) = (jump, refuse_clock_jumps) {
                return Err(DecimateError::ClockJump {
                    channel: topic,
                    jump,
                });
            }
            let place = Placement {
                ts_ns,
                alignment: self.alignment(&signal),
                storage,
                interpolation: channel.map(|c| c.interpolation).unwrap_or_default(),
                lo,
                len,
                phase_s,
            };
            let mut laid = place.channel(&windows);
            laid.grid.topic = topic;
            laid.grid.signal = signal;
            laid.grid.clock_jump = jump;
            Ok(laid)
        };
        let laid: Vec<Result<Laid>> = if side_by_side {
            // On rayon's threads, the grid in the channels' order whatever the cores.
            use rayon::prelude::*;
            jobs.into_par_iter().map(lay).collect()
        } else {
            // One channel at a time: its windows are freed before the next is laid out.
            let mut laid = Vec::new();
            for job in jobs {
                let one = lay(job);
                let failed = one.is_err();
                laid.push(one);
                if failed {
                    break;
                }
            }
            laid
        };
        let mut grids = Vec::new();
        let mut per_signal: BTreeMap<Signal, Vec<Laid>> = BTreeMap::new();
        for laid in laid {
            let laid = laid?;
            grids.push(laid.grid.clone());
            per_signal
                .entry(laid.grid.signal.clone())
                .or_default()
                .push(laid);
        }
        let series = per_signal
            .into_iter()
            .map(|(signal, sensors)| {
                let unit = channels
                    .iter()
                    .find(|c| c.signal == signal)
                    .map(|c| c.canonical_unit().to_owned())
                    .unwrap_or_default();
                (signal.clone(), combine(signal, unit, sensors, len))
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

/// The longest grid whose channels are laid out side by side: each channel in flight
/// holds its windows and its laid series, so a heat run of a day and a half at 1 s adds a
/// few MB, where a week at 1 s lays its channels one after the other for its peak of
/// memory.
pub const SIDE_BY_SIDE_INSTANTS: usize = 1 << 17;

/// The mean of a signal's sensors at each instant where any has data; `observed` where
/// any of them has a stored sample.
fn combine(signal: Signal, unit: String, sensors: Vec<Laid>, len: usize) -> DecimatedSeries {
    let values = (0..len)
        .map(|i| {
            let (sum, n) = sensors
                .iter()
                .filter_map(|s| s.values.get(i))
                .fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
            (n > 0).then(|| sum / n as f64)
        })
        .collect();
    let observed = sensors.iter().any(|s| s.observed.is_some()).then(|| {
        (0..len)
            .map(|i| {
                sensors.iter().any(|s| match &s.observed {
                    Some(o) => o[i],
                    None => s.values.get(i).is_some(),
                })
            })
            .collect()
    });
    DecimatedSeries {
        signal,
        unit,
        values,
        sensors: sensors.len(),
        observed,
    }
}

/// Where one channel goes on the grid.
struct Placement {
    ts_ns: i64,
    /// Where the signal's values sit: the instant, or the interval after it.
    alignment: Alignment,
    storage: Storage,
    /// How the value runs between samples, where they are interpolated.
    interpolation: Interpolation,
    /// First grid index and number of instants.
    lo: i64,
    len: usize,
    /// The grid's phase φ ([`Decimator::grid_phase`]), s: every channel's value at
    /// instant k is its value at t_k + φ (its interval's mean from t_k + φ).
    phase_s: f64,
}

impl Placement {
    fn ts_s(&self) -> f64 {
        self.ts_ns as f64 * 1e-9
    }

    /// Lays out one channel's occupied windows (in grid order).
    fn channel(&self, windows: &[(i64, Window)]) -> Laid {
        let mut laid = Laid {
            values: Series::unknown(self.len),
            observed: None,
            grid: ChannelGrid {
                topic: String::new(),
                signal: Signal::Free(String::new()),
                storage: self.storage,
                nominal_period_s: f64::NAN,
                block_averaged: false,
                gaps: 0,
                gap_instants: 0,
                clock_jump: None,
            },
        };
        if windows.is_empty() {
            return laid;
        }
        let window_alignment = match self.storage {
            Storage::Sampled => self.alignment,
            Storage::Exception { .. } => Alignment::Instant,
        };
        let points = self.points(windows, window_alignment);
        match self.storage {
            Storage::Sampled if median_step(&points) <= 1 => {
                let total: u64 = windows.iter().map(|(_, w)| w.count as u64).sum();
                let span = (points[points.len() - 1].k - points[0].k + 1) as f64;
                laid.grid.nominal_period_s = self.ts_s() * span / total as f64;
                laid.grid.block_averaged = true;
                self.block_averaged(&points, window_alignment, &mut laid);
            }
            Storage::Sampled => {
                let period = median_spacing(&points);
                laid.grid.nominal_period_s = period;
                self.interpolated(&points, GAP_FACTOR * period, false, &mut laid);
            }
            Storage::Exception { max_interval_s, .. } => {
                laid.grid.nominal_period_s = median_spacing(&points);
                let limit = max_interval_s.map_or(f64::INFINITY, |m| GAP_FACTOR * m);
                self.interpolated(&points, limit, true, &mut laid);
                let mut observed = vec![false; self.len];
                for p in &points {
                    observed[(p.k - self.lo) as usize] = true;
                }
                laid.observed = Some(observed);
            }
        }
        laid
    }

    /// Occupied windows as points: index, mean time relative to the grid's start, mean.
    fn points(&self, windows: &[(i64, Window)], window_alignment: Alignment) -> Vec<Point> {
        windows
            .iter()
            .map(|&(k, w)| Point {
                k,
                t_s: (reference_ns(self.ts_ns, window_alignment, k) - self.lo * self.ts_ns) as f64
                    * 1e-9
                    + w.offset_sum as f64 / w.count as f64,
                value: w.sum / w.count as f64,
            })
            .collect()
    }

    /// A channel with a sample in (nearly) every window: each window's mean is the value,
    /// on a grid moved by a phase φ ≠ 0 taken to its reference time moved by φ
    /// ([`at_reference`]); an empty window inside the span is a gap.
    fn block_averaged(&self, points: &[Point], window_alignment: Alignment, laid: &mut Laid) {
        let reference_s = |k: i64| {
            (reference_ns(self.ts_ns, window_alignment, k) - self.lo * self.ts_ns) as f64 * 1e-9
                + self.phase_s
        };
        let tolerance_s = OFF_REFERENCE * self.ts_s();
        for (j, p) in points.iter().enumerate() {
            // Unmoved, the window's mean is its value whatever its samples' phase inside
            // it (a 10 Hz channel read at the start of each tenth: its mean is the
            // interval's, though its mean time is 0.05 s early).
            let value = if self.phase_s == 0.0 {
                p.value
            } else {
                at_reference(points, j, reference_s(p.k), tolerance_s)
            };
            laid.values.set((p.k - self.lo) as usize, Some(value));
        }
        for pair in points.windows(2) {
            let missing = pair[1].k - pair[0].k - 1;
            if missing > 0 {
                laid.grid.gaps += 1;
                laid.grid.gap_instants += missing as usize;
            }
        }
    }

    /// A channel slower than the grid, or stored by exception: at each instant's reference
    /// time, the line between the points around it, or the earlier point's value for a
    /// [`Interpolation::Step`] channel (held until the next sample), never across more than
    /// `limit` s. `hold` carries the last point forward up to `limit` (a channel stored by
    /// exception: no new sample means no change).
    fn interpolated(&self, points: &[Point], limit: f64, hold: bool, laid: &mut Laid) {
        let ts = self.ts_s();
        let offset = self.phase_s
            + match self.alignment {
                Alignment::Instant => 0.0,
                Alignment::Interval => ts / 2.0,
            };
        let last = points[points.len() - 1];
        let mut j = 0;
        for i in 0..self.len {
            let t = i as f64 * ts + offset;
            while j + 1 < points.len() && points[j + 1].t_s < t {
                j += 1;
            }
            let a = points[j];
            if let Some(exact) = points[j..(j + 2).min(points.len())]
                .iter()
                .find(|p| (p.t_s - t).abs() < 1e-9)
            {
                laid.values.set(i, Some(exact.value));
                continue;
            }
            if a.t_s > t {
                continue;
            }
            if j + 1 >= points.len() {
                if hold && t - last.t_s <= limit {
                    laid.values.set(i, Some(last.value));
                }
                continue;
            }
            let b = points[j + 1];
            if b.t_s - a.t_s <= limit {
                let value = match self.interpolation {
                    Interpolation::Linear => {
                        a.value + (b.value - a.value) * (t - a.t_s) / (b.t_s - a.t_s)
                    }
                    Interpolation::Step => a.value,
                };
                laid.values.set(i, Some(value));
            } else {
                laid.grid.gap_instants += 1;
            }
        }
        laid.grid.gaps = points
            .windows(2)
            .filter(|p| p[1].t_s - p[0].t_s > limit)
            .count();
    }
}

/// The largest interquartile range of the readings' offsets from their instants, as a
/// fraction of Ts, for which they have a phase ([`Decimator::grid_phase`]).
const PHASE_SPREAD: f64 = 0.1;

/// A window's samples whose mean time is further than this share of Ts from the
/// window's reference time are taken to it along the line to a neighbouring window
/// ([`at_reference`]); nearer, the mean is the value (a fast channel's samples spread
/// evenly over the window: its mean time is the reference up to a sample's jitter, and
/// the mean is its anti-alias filter).
const OFF_REFERENCE: f64 = 0.01;

/// Window `j`'s value at its reference time `reference_s` (s after the grid's start).
///
/// A window's mean v̄_j is the value at its samples' mean time t̄_j, not at the reference
/// time t_ref (its instant or its interval's middle, moved by the grid's phase,
/// [`Decimator::grid_phase`]): a channel read at the grid's own rate but at another
/// phase has one sample per window, up to Ts/2 from where it is laid, and an input's
/// interval mean is to be taken from the instant the readings sit at. Where
/// |t̄_j − t_ref| exceeds `tolerance_s`, the value is
/// the line through (t̄_j, v̄_j) and the adjacent window's (t̄_i, v̄_i), i = j ± 1, on the
/// reference's side where there is one (interpolation), else on the other (half a window
/// of extrapolation at an end or a gap's edge):
///
///   v(t_ref) = v̄_j + (v̄_i − v̄_j)·(t_ref − t̄_j)/(t̄_i − t̄_j).
///
/// A window with no adjacent neighbour keeps its mean.
fn at_reference(points: &[Point], j: usize, reference_s: f64, tolerance_s: f64) -> f64 {
    let p = points[j];
    let off = reference_s - p.t_s;
    if off.abs() <= tolerance_s {
        return p.value;
    }
    let adjacent = |i: Option<usize>| {
        let q = points.get(i?)?;
        ((q.k - p.k).abs() == 1 && q.t_s != p.t_s).then_some(*q)
    };
    let (toward, away) = if off > 0.0 {
        (adjacent(j.checked_add(1)), adjacent(j.checked_sub(1)))
    } else {
        (adjacent(j.checked_sub(1)), adjacent(j.checked_add(1)))
    };
    match toward.or(away) {
        Some(q) => p.value + (q.value - p.value) * off / (q.t_s - p.t_s),
        None => p.value,
    }
}

/// The median step in windows between neighbouring occupied windows (1: every window).
fn median_step(points: &[Point]) -> i64 {
    let mut steps: Vec<i64> = points.windows(2).map(|p| p[1].k - p[0].k).collect();
    steps.sort_unstable();
    steps.get(steps.len() / 2).copied().unwrap_or(1)
}

/// The median spacing in time between neighbouring points, s (NaN for one point).
fn median_spacing(points: &[Point]) -> f64 {
    let mut spacing: Vec<f64> = points.windows(2).map(|p| p[1].t_s - p[0].t_s).collect();
    spacing.sort_by(f64::total_cmp);
    spacing.get(spacing.len() / 2).copied().unwrap_or(f64::NAN)
}

/// Finds a stretch where a sampled channel holds about twice the samples its rate gives:
/// the samples after a jump of its clock back, on top of the earlier ones.
///
/// The channel's span is cut into stretches of M windows that hold about
/// [`DENSITY_SAMPLES`] samples each; its rate is the lower quartile of the non-empty
/// stretches' counts but the first and the last, which the span may cover in part (so a doubled stretch of up to three quarters of the span does not
/// move it, nor do gaps); a run of stretches each holding [`DENSE_FACTOR`] times that,
/// together longer than [`CLOCK_JUMP_MIN_S`], is the jump's overlap. The counts do not
/// depend on the order the samples came in. A channel stored twice throughout (every
/// sample duplicated) has twice the rate everywhere, and no such run.
fn clock_jump(ts_ns: i64, windows: &[(i64, Window)]) -> Option<ClockJump> {
    let total: i64 = windows.iter().map(|(_, w)| w.count as i64).sum();
    let (first, last) = (windows.first()?.0, windows.last()?.0);
    if total < 4 * DENSITY_SAMPLES {
        return None;
    }
    let span = last - first + 1;
    let m = ((DENSITY_SAMPLES * span + total - 1) / total).max(1);
    let stretches = (span / m) as usize;
    if stretches < 4 {
        return None;
    }
    let mut counts = vec![0u64; stretches];
    for (k, w) in windows {
        if let Some(c) = counts.get_mut(((k - first) / m) as usize) {
            *c += w.count as u64;
        }
    }
    // The first and the last stretch hold only the part of them the span covers (on a
    // grid of hours, a 5.8 h run's first window held its half hour): their counts do
    // not say the rate, and as its quartile they made every full stretch look doubled.
    let mut occupied: Vec<u64> = counts[1..stretches - 1]
        .iter()
        .copied()
        .filter(|c| *c > 0)
        .collect();
    occupied.sort_unstable();
    let rate = *occupied.get(occupied.len() / 4)? as f64;
    let dense = |c: u64| c as f64 >= DENSE_FACTOR * rate;
    let (mut best, mut run_start) = (None::<(usize, usize)>, None::<usize>);
    for (s, &c) in counts.iter().enumerate().chain([(stretches, &0)]) {
        match (dense(c) && s < stretches, run_start) {
            (true, None) => run_start = Some(s),
            (false, Some(a)) => {
                if best.is_none_or(|(b0, b1)| s - a > b1 - b0) {
                    best = Some((a, s));
                }
                run_start = None;
            }
            _ => {}
        }
    }
    let (a, b) = best?;
    let ts_s = ts_ns as f64 * 1e-9;
    if b - a < 2 || ((b - a) as i64 * m) as f64 * ts_s < CLOCK_JUMP_MIN_S {
        return None;
    }
    let in_run: u64 = counts[a..b].iter().sum();
    let at = |s: usize| ((first + s as i64 * m) * ts_ns).max(0) as u64;
    Some(ClockJump {
        overlap_start_ns: at(a),
        overlap_end_ns: at(b),
        density_ratio: in_run as f64 / ((b - a) as f64 * rate),
    })
}

impl Decimator {
    /// The channel's windows and the window and reference offset (s) of a sample.
    fn place(&mut self, sample: &Sample) -> Option<(&mut ChannelWindows, i64, f32)> {
        let ts = self.ts_ns;
        let (ch, _, _) = self.channels.get_mut(sample.channel)?.as_mut()?;
        let t = sample.log_time_ns as i64;
        let k = window_of(ts, ch.alignment, t);
        let offset = ((t - reference_ns(ts, ch.alignment, k)) as f64 * 1e-9) as f32;
        Some((ch, k, offset))
    }
}

impl SampleSink for Decimator {
    fn channel(&mut self, channel: &SensorChannel) {
        while self.channels.len() <= channel.index {
            self.channels.push(None);
        }
        let alignment = match channel.storage {
            // A stored sample is an exact value at its own time: the nearest instant's.
            Storage::Exception { .. } => Alignment::Instant,
            Storage::Sampled => self.alignment(&channel.signal),
        };
        self.channels[channel.index] = Some((
            ChannelWindows::new(alignment),
            channel.signal.clone(),
            channel.storage,
        ));
    }

    fn sample(&mut self, sample: Sample) {
        if !sample.value.is_finite() {
            return;
        }
        if let Some((ch, k, offset)) = self.place(&sample) {
            let w = ch.window_mut(k);
            w.sum += sample.value;
            w.offset_sum += offset;
            w.count += 1;
        }
    }

    fn retract(&mut self, sample: Sample) {
        if !sample.value.is_finite() {
            return;
        }
        if let Some((ch, k, offset)) = self.place(&sample) {
            let w = ch.window_mut(k);
            if w.count > 0 {
                w.sum -= sample.value;
                w.offset_sum -= offset;
                w.count -= 1;
                if w.count == 0 {
                    *w = Window::default();
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel(index: usize, quantity: Quantity) -> SensorChannel {
        SensorChannel {
            index,
            topic: format!("/scada/{quantity}"),
            signal: Signal::Profile(quantity),
            sensor: None,
            unit: quantity.canonical_unit().into(),
            unit_scale: 1.0,
            storage: Storage::Sampled,
            interpolation: Interpolation::Linear,
            resolution: None,
        }
    }

    const S: u64 = 1_000_000_000;

    #[test]
    fn a_step_channel_is_held_between_its_samples() {
        // A heater command read every 3 s, 0 % until it is set to 10 % at t = 30 s, on a
        // 1 s grid of interval means (the instant i stands for [i, i + 1) s, its reference
        // time i + 0.5 s). Held, it is 0 up to the interval that starts at 30 s and 10 from
        // there; as a line it ramps over 27…30 s (5 % at 28.5 s), its step 1.5 s early.
        let of = |interpolation| {
            let q1 = SensorChannel {
                signal: Signal::Free("Q1".into()),
                topic: "/lab/Q1".into(),
                interpolation,
                ..channel(0, Quantity::CoreTemp)
            };
            let mut d = Decimator::new(1.0, BTreeMap::new()).unwrap();
            d.channel(&q1);
            for k in 0..=20u64 {
                d.sample(sample(0, 3 * k * S, if k >= 10 { 10.0 } else { 0.0 }));
            }
            let r = d.finish(std::slice::from_ref(&q1)).unwrap();
            r.get_signal(&Signal::Free("Q1".into()))
                .unwrap()
                .values
                .clone()
        };
        let held = of(Interpolation::Step);
        for i in 0..60 {
            let want = if i >= 30 { 10.0 } else { 0.0 };
            assert_eq!(held.get(i), Some(want), "instant {i}");
        }
        let line = of(Interpolation::Linear);
        assert!(
            (line.get(28).unwrap() - 5.0).abs() < 1e-9,
            "{:?}",
            line.get(28)
        );
        assert_eq!(line.get(30), Some(10.0));
    }

    fn decimator(chans: &[SensorChannel]) -> Decimator {
        let alignments = crate::spec::ModelDescription::generator().alignments();
        let mut d = Decimator::new(1.0, alignments).unwrap();
        for c in chans {
            d.channel(c);
        }
        d
    }

    fn sample(channel: usize, log_time_ns: u64, value: f64) -> Sample {
        Sample {
            channel,
            log_time_ns,
            value,
        }
    }

    /// A seeded permutation of 0..n (Fisher–Yates on a small LCG).
    fn shuffled(n: usize, seed: u64) -> Vec<usize> {
        let mut order: Vec<usize> = (0..n).collect();
        let mut state = seed;
        for i in (1..n).rev() {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            order.swap(i, (state >> 33) as usize % (i + 1));
        }
        order
    }

    /// Channels laid out side by side give the grid one at a time gives, and the same
    /// refusal: the first channel (in order) whose clock jumped back.
    #[test]
    fn side_by_side_and_one_after_the_other_lay_out_the_same() {
        let chans = [
            channel(0, Quantity::ArmatureCurrent),
            channel(1, Quantity::CoreTemp),
            channel(2, Quantity::FieldCurrent),
            channel(3, Quantity::StatorWindingTemp),
            channel(4, Quantity::CoolingWaterFlow),
        ];
        let fill = |d: &mut Decimator, jump_on: &[usize]| {
            for i in 0..6000u64 {
                for (c, _) in chans.iter().enumerate() {
                    let t = 1000 * S + i * S / 10 + c as u64 * S / 100;
                    // A clock that jumps back 120 s halfway through.
                    let t = if jump_on.contains(&c) && i >= 3000 {
                        t - 120 * S
                    } else {
                        t
                    };
                    d.sample(sample(c, t, (i as f64 * 0.1 + c as f64).sin()));
                }
            }
        };
        let laid = |side_by_side: bool, jump_on: &[usize]| {
            let mut d = decimator(&chans);
            fill(&mut d, jump_on);
            format!("{:?}", d.lay_out_with(&chans, true, side_by_side))
        };
        assert_eq!(laid(true, &[]), laid(false, &[]));
        assert!(laid(true, &[]).starts_with("Ok("));
        let refused = laid(false, &[1, 3]);
        assert_eq!(laid(true, &[1, 3]), refused);
        assert!(
            refused.contains("ClockJump") && refused.contains("core_temp"),
            "{refused}"
        );
    }

    #[test]
    fn block_average_of_interval_channel() {
        // 10 Hz current over two 1-s intervals: values 0..9 then 10..19.
        let chans = [channel(0, Quantity::ArmatureCurrent)];
        let mut d = decimator(&chans);
        for i in 0..20u64 {
            d.sample(sample(0, 100 * S + i * S / 10, i as f64));
        }
        let r = d.finish(&chans).unwrap();
        assert_eq!(r.first_index, 100);
        let s = r.get(Quantity::ArmatureCurrent).unwrap();
        assert_eq!(s.values, vec![Some(4.5), Some(14.5)]);
        assert_eq!((s.unit.as_str(), s.observed.as_ref()), ("A", None));
        assert!((r.channels[0].nominal_period_s - 0.1).abs() < 1e-12);
    }

    #[test]
    fn instant_channel_is_centred_on_grid_instants() {
        // 10 Hz temperature at t = 99.55 … 100.45 averages onto instant 100.
        let chans = [channel(0, Quantity::CoreTemp)];
        let mut d = decimator(&chans);
        for i in 0..10u64 {
            let t = 99 * S + S / 2 + S / 20 + i * S / 10; // 99.55, 99.65, … 100.45
            d.sample(sample(0, t, 2.0 * i as f64));
        }
        let r = d.finish(&chans).unwrap();
        assert_eq!(r.first_index, 100);
        assert_eq!(r.get(Quantity::CoreTemp).unwrap().values, vec![Some(9.0)]);
    }

    #[test]
    fn a_grid_moves_to_temperatures_read_off_its_instants() {
        // A temperature every 10 s read 5 s before each instant of a 10 s grid (a
        // historian's export out of phase with the grid), along θ(t) = 0.01·t², and a
        // current read every second along I(t) = t. The grid moves to the readings
        // (φ = −5 s): each temperature is laid as read (its noise untouched), and the
        // current's value at instant k is its mean over [t_k + φ, t_k + φ + Ts), the line
        // between the neighbouring windows' means: t_k exactly for a ramp (its mean over
        // the unmoved interval would be t_k + 5).
        let chans = [
            channel(0, Quantity::CoreTemp),
            channel(1, Quantity::ArmatureCurrent),
        ];
        let mut d = decimator_of(10.0, &chans);
        let course = |t: f64| 0.01 * t * t;
        for i in 0..30u64 {
            let t = 1005.0 + 10.0 * i as f64;
            d.sample(sample(0, (t * 1e9) as u64, course(t)));
        }
        for i in 0..300u64 {
            let t = 1010.0 + i as f64 + 0.5;
            d.sample(sample(1, (t * 1e9) as u64, t));
        }
        let r = d.finish(&chans).unwrap();
        assert_eq!(r.first_index, 101);
        let theta = &r.get(Quantity::CoreTemp).unwrap().values;
        for i in 0..30 {
            assert_eq!(theta.get(i), Some(course(1005.0 + 10.0 * i as f64)), "{i}");
        }
        let current = &r.get(Quantity::ArmatureCurrent).unwrap().values;
        // From the second window of the current (the first has none before it: its
        // line runs to the next one, which is the same line).
        for i in 1..30 {
            let t_k = 1010.0 + 10.0 * i as f64;
            let got = current.get(i).unwrap();
            assert!((got - t_k).abs() < 1e-4, "{t_k} s: {got}");
        }
        // Read on the instants, nothing moves.
        let mut d = decimator_of(10.0, &chans[..1]);
        for i in 0..30u64 {
            d.sample(sample(0, (100 + 10 * i) * S, course(10.0 * i as f64)));
        }
        let r = d.finish(&chans[..1]).unwrap();
        let theta = &r.get(Quantity::CoreTemp).unwrap().values;
        assert!((0..30).all(|i| theta.get(i) == Some(course(10.0 * i as f64))));
    }

    fn decimator_of(ts_s: f64, chans: &[SensorChannel]) -> Decimator {
        let alignments = crate::spec::ModelDescription::generator().alignments();
        let mut d = Decimator::new(ts_s, alignments).unwrap();
        for c in chans {
            d.channel(c);
        }
        d
    }

    #[test]
    fn alignment_comes_from_the_map() {
        // The same samples as an instant signal and as an interval one (a free channel
        // not in the map is an interval signal).
        let free = SensorChannel {
            signal: Signal::Free("Q1".into()),
            topic: "/lab/Q1".into(),
            ..channel(0, Quantity::CoreTemp)
        };
        for (alignments, first_index) in [
            (
                BTreeMap::from([(Signal::Free("Q1".into()), Alignment::Instant)]),
                100,
            ),
            (BTreeMap::new(), 99),
        ] {
            let mut d = Decimator::new(1.0, alignments).unwrap();
            d.channel(&free);
            for i in 0..10u64 {
                d.sample(sample(0, 99 * S + S / 2 + S / 20 + i * S / 10, 1.0));
            }
            let r = d.finish(std::slice::from_ref(&free)).unwrap();
            assert_eq!(r.first_index, first_index);
            assert!(r.get_signal(&Signal::Free("Q1".into())).is_some());
        }
    }

    #[test]
    fn slow_channel_is_interpolated_and_gap_is_not_bridged() {
        // A temperature every 10 s, linear in time, with one sample missing.
        let chans = [channel(0, Quantity::CoreTemp)];
        let mut d = decimator(&chans);
        for i in (0..8u64).filter(|i| *i != 5) {
            d.sample(sample(0, i * 10 * S, i as f64 * 10.0));
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
        // Two channels, one fast and one slow, 2000 s: forward, backward and shuffled
        // orders give the same grid and the same findings.
        let chans = [
            channel(0, Quantity::ArmatureCurrent),
            channel(1, Quantity::CoreTemp),
        ];
        let mut samples: Vec<Sample> = (0..10_000u64)
            .map(|i| sample(0, 10 * S + i * S / 5, (i % 97) as f64))
            .collect();
        samples.extend((0..200u64).map(|i| sample(1, 10 * S + i * 10 * S, i as f64)));
        let run = |order: &[usize]| {
            let mut d = decimator(&chans);
            for &i in order {
                d.sample(samples[i]);
            }
            let r = d.finish(&chans).unwrap();
            let grids: Vec<_> = r
                .channels
                .iter()
                .map(|g| (g.nominal_period_s, g.gaps, g.block_averaged))
                .collect();
            (
                r.get(Quantity::ArmatureCurrent).unwrap().values.clone(),
                r.get(Quantity::CoreTemp).unwrap().values.clone(),
                grids,
            )
        };
        let n = samples.len();
        let forward = run(&(0..n).collect::<Vec<_>>());
        assert_eq!(forward, run(&(0..n).rev().collect::<Vec<_>>()));
        assert_eq!(forward, run(&shuffled(n, 7)));
    }

    #[test]
    fn empty_window_of_fast_channel_is_a_gap() {
        let chans = [channel(0, Quantity::LineVoltage)];
        let mut d = decimator(&chans);
        for i in (0..100u64).filter(|i| !(30..40).contains(i)) {
            d.sample(sample(0, i * S / 10, 1.0));
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
        let mut d = decimator(&chans);
        for i in 0..5u64 {
            d.sample(sample(0, i * S, 50.0));
            if i != 2 {
                d.sample(sample(1, i * S, 52.0));
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

    #[test]
    fn a_retracted_sample_is_undone() {
        let chans = [channel(0, Quantity::ArmatureCurrent)];
        let mut d = decimator(&chans);
        for i in 0..10u64 {
            d.sample(sample(0, i * S / 10, 2.0));
        }
        d.sample(sample(0, 5 * S / 100, -3000.0));
        d.sample(sample(0, 2 * S + S / 2, -3000.0));
        d.retract(sample(0, 5 * S / 100, -3000.0));
        d.retract(sample(0, 2 * S + S / 2, -3000.0));
        let r = d.finish(&chans).unwrap();
        // The second fault was alone in its window: the window is empty again.
        assert_eq!(
            r.get(Quantity::ArmatureCurrent).unwrap().values,
            vec![Some(2.0)]
        );
    }

    /// A 1 Hz channel of `duration` s whose clock jumps back by `back` s at `at` s:
    /// samples (true time, log time, value), the value the true time.
    fn jumped(duration: u64, at: u64, back: u64) -> Vec<Sample> {
        (0..duration)
            .map(|t| {
                let log = if t >= at { t - back } else { t };
                sample(0, (1000 + log) * S, t as f64)
            })
            .collect()
    }

    #[test]
    fn a_clock_jump_is_found_in_any_order() {
        let chans = [channel(0, Quantity::StatorWindingTemp)];
        // The clock jumps back an hour at 4000 s of 6000 s: 400–2400 s come twice.
        let samples = jumped(6000, 4000, 3600);
        for order in [
            (0..6000).collect::<Vec<_>>(),
            (0..6000).rev().collect(),
            shuffled(6000, 3),
        ] {
            let mut d = decimator(&chans);
            for i in order {
                d.sample(samples[i]);
            }
            let err = d.finish(&chans).unwrap_err();
            let DecimateError::ClockJump { channel, jump } = err else {
                panic!("{err}");
            };
            assert_eq!(channel, "/scada/stator_winding_temp");
            let (from, to) = (
                jump.overlap_start_ns / S - 1000,
                jump.overlap_end_ns / S - 1000,
            );
            // At the resolution of the stretches judged (11 s here).
            assert!(
                (385..=420).contains(&from) && (2380..=2400).contains(&to),
                "{from}–{to}"
            );
            assert!((jump.density_ratio - 2.0).abs() < 0.1, "{jump:?}");
        }
        // `inspect` reports it instead, with the period and gaps.
        let mut d = decimator(&chans);
        for s in &samples {
            d.sample(*s);
        }
        let r = d.inspect(&chans).unwrap();
        assert!(r.channels[0].clock_jump.is_some());
    }

    #[test]
    fn jumps_of_slow_and_fast_channels_and_what_is_not_a_jump() {
        let chans = [channel(0, Quantity::CoreTemp)];
        let run = |samples: &[Sample], storage: Storage| {
            let chans = [SensorChannel {
                storage,
                ..chans[0].clone()
            }];
            let mut d = decimator(&chans);
            for s in samples {
                d.sample(*s);
            }
            d.finish(&chans)
        };
        // A 0.1 Hz channel jumping back 20 minutes; its samples then fall on the same
        // windows as the earlier ones.
        let slow: Vec<Sample> = (0..2000u64)
            .map(|i| {
                let t = i * 10;
                let log = if t >= 15_000 { t - 1200 } else { t };
                sample(0, log * S, 1.0)
            })
            .collect();
        assert!(run(&slow, Storage::Sampled).is_err());
        // The same stored by exception: no rate, nothing judged.
        let exception = Storage::Exception {
            deadband: 0.1,
            max_interval_s: None,
        };
        assert!(run(&slow, exception).is_ok());
        // Every sample stored twice: twice the rate everywhere, no jump.
        let twice: Vec<Sample> = jumped(3000, 3000, 0)
            .into_iter()
            .flat_map(|s| [s, s])
            .collect();
        assert!(run(&twice, Storage::Sampled).is_ok());
        // A jump of 30 s: too short to tell from a recorder's buffering.
        assert!(run(&jumped(3000, 2000, 30), Storage::Sampled).is_ok());
        // A clean 1 Hz channel of 5.8 h on a grid of hours: its first and last windows
        // hold the half hours the run covers of them, and are not the rate (every full
        // hour was taken for a doubled one).
        let alignments = crate::spec::ModelDescription::generator().alignments();
        for ts_s in [600.0, 1800.0, 3600.0] {
            let mut d = Decimator::new(ts_s, alignments.clone()).unwrap();
            d.channel(&chans[0]);
            for t in 0..20_869u64 {
                d.sample(sample(0, (21_600 + t) * S, 1.0));
            }
            assert!(d.finish(&chans).is_ok(), "Ts {ts_s} s");
        }
        // A 100 Hz channel jumping back 2 minutes.
        let fast: Vec<Sample> = (0..300_000u64)
            .map(|i| {
                let t = i * S / 100;
                let log = if t >= 2000 * S { t - 120 * S } else { t };
                sample(0, log, 1.0)
            })
            .collect();
        assert!(run(&fast, Storage::Sampled).is_err());
    }

    #[test]
    fn a_channel_stored_by_exception() {
        // Stored at 0, 100, 130 and 400 s (a silence of 270 s), at most every 300 s.
        let mut ch = channel(0, Quantity::CoreTemp);
        ch.storage = Storage::Exception {
            deadband: 0.5,
            max_interval_s: Some(300.0),
        };
        let other = channel(1, Quantity::CoolingWaterOutletTemp);
        let chans = [ch, other];
        let mut d = decimator(&chans);
        for (t, v) in [(0u64, 20.0), (100, 30.0), (130, 31.0), (400, 31.0)] {
            d.sample(sample(0, t * S + S / 4, v)); // a quarter second after the instant
        }
        for t in 0..900u64 {
            d.sample(sample(1, t * S, 10.0));
        }
        let r = d.finish(&chans).unwrap();
        let s = r.get(Quantity::CoreTemp).unwrap();
        // Linear between stored samples (at their own times), then held to 1.5 × 300 s.
        assert!((s.values.get(50).unwrap() - (20.0 + 10.0 * 49.75 / 100.0)).abs() < 1e-9);
        assert!((s.values.get(200).unwrap() - 31.0).abs() < 1e-12);
        assert_eq!(s.values.get(850), Some(31.0));
        assert_eq!(
            s.values.get(851),
            None,
            "held only up to 1.5 × the longest interval"
        );
        let observed = s.observed.as_ref().unwrap();
        let at: Vec<usize> = (0..r.len).filter(|&i| observed[i]).collect();
        assert_eq!(at, vec![0, 100, 130, 400]);
        let g = &r.channels[0];
        assert_eq!((g.gaps, g.gap_instants, g.block_averaged), (0, 0, false));
        assert!(r
            .get(Quantity::CoolingWaterOutletTemp)
            .unwrap()
            .observed
            .is_none());
        // A silence longer than 1.5 × 300 s is a gap.
        let mut d = decimator(&chans);
        for (t, v) in [(0u64, 20.0), (500, 30.0)] {
            d.sample(sample(0, t * S, v));
        }
        let r = d.finish(&chans[..1]).unwrap();
        assert_eq!(r.channels[0].gaps, 1);
        assert_eq!(r.get(Quantity::CoreTemp).unwrap().values.get(250), None);
    }

    #[test]
    fn sample_time_and_span_are_checked() {
        assert_eq!(
            Decimator::new(0.0, BTreeMap::new())
                .unwrap_err()
                .to_string(),
            "the sample time 0 s is outside 0.001 s to 3600 s"
        );
        let chans = [channel(0, Quantity::CoreTemp)];
        let d = decimator(&chans);
        assert!(matches!(d.finish(&chans), Err(DecimateError::NoSamples)));
        // A stray sample decades away from the rest.
        let mut d = decimator(&chans);
        for t in 0..100u64 {
            d.sample(sample(0, (1_600_000_000 + t) * S, 1.0));
        }
        d.sample(sample(0, 100 * S, 1.0));
        assert!(matches!(
            d.finish(&chans),
            Err(DecimateError::SparseSpan { .. })
        ));
    }
}
