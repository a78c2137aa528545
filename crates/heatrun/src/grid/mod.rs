//! One way from recording to grid: the sans-IO grid builder that the replay and the
//! monitor both drive. Samples go in (it is the reader's [`SampleSink`]); the grid of Ts
//! comes out, as one [`DecimatedRecording`] of the whole recording (the replay) or as
//! sealed stretches of it, in time order, while the recording is still being read (the
//! monitor). It reads no file and knows no model: the driver feeds it, asks it for what
//! is ready, and does the rest (signals, estimation, the model beside the recording).
//!
//! **The whole recording** ([`GridBuilder::whole`]): every sample goes straight to one
//! `Decimator`; [`GridBuilder::finish`] lays it on the grid. Nothing raw is held.
//!
//! **Sealed stretches** ([`GridBuilder::in_stretches`]): the raw samples not yet sealed
//! are held with a watermark W, the oldest of the channels' settled times (each channel's
//! latest sample time less [`SETTLE_PERIODS`] of its own mean spacing: a channel slower
//! than the grid has then delivered the samples after every instant before W, so its
//! interpolation there is final, and enough of them for the decimator to judge its
//! spacing as it would on the whole file), but never more than the plan's lateness behind
//! the newest sample (a channel that fell silent holds nothing back; its silence is a
//! gap). Once W passes the end of the next stretch plus the driver's look-ahead,
//! [`GridBuilder::ready`] offers it; [`GridBuilder::seal`] lays its samples, with an
//! overlap before it (the look-back) and after it (the look-ahead), on the grid by a
//! `Decimator` of their own, windowed onto the one grid of the whole recording
//! ([`DecimatedRecording::window`]), and drops the samples no later stretch needs. Samples
//! that arrive for an instant already sealed, and samples the reader takes back after
//! their instant was sealed, are counted ([`GridBuilder::late_lines`]), never fatal.

use std::collections::BTreeMap;
use std::ops::Range;

use crate::decimate::{
    self, DecimateError, DecimatedRecording, DecimatedSeries, Decimator, GAP_FACTOR,
};
use crate::recording::{Alignment, Sample, SampleSink, SensorChannel, Signal, Storage};
use crate::series::Series;

/// Grid instants of margin on either side of a stretch beyond what the driver looks at
/// (the interval a sample of an interval-aligned channel is averaged over, the neighbour
/// an interpolation needs).
pub const MARGIN: i64 = 2;

/// Sample periods a channel's data are taken as complete behind its latest sample: the
/// decimator judges a channel's spacing (a sample in every window, or slower and
/// interpolated) from the samples it is given, so a stretch is laid out only once
/// this many samples after it have come.
pub const SETTLE_PERIODS: f64 = 20.0;

/// How a recording is cut into sealed stretches.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StretchPlan {
    /// Grid instants sealed at once (at least 1).
    pub stretch: i64,
    /// Instants before a stretch its driver looks at (smoothing, dead times).
    pub lookback: i64,
    /// Instants after a stretch its driver looks at (smoothing, advances).
    pub lookahead: i64,
    /// How far the watermark may stay behind the newest sample for a silent channel, ns.
    pub lateness_ns: u64,
}

/// A stretch ready to be sealed: instants `start..upto` of the grid (window indices),
/// `end` the first instant not yet sealable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ready {
    /// Its first instant.
    pub start: i64,
    /// One past its last instant.
    pub upto: i64,
    /// The first instant whose samples may not all be in yet.
    pub end: i64,
}

/// A sealed stretch: its samples laid on the grid with the overlap, and where in that
/// grid the stretch itself lies.
#[derive(Debug)]
pub struct Sealed {
    /// The stretch and its overlap on the grid.
    pub decimated: DecimatedRecording,
    /// The stretch's own instants within `decimated`.
    pub instants: Range<usize>,
}

/// The grid builder (see the module).
#[derive(Debug)]
pub struct GridBuilder {
    ts_s: f64,
    ts_ns: i64,
    alignments: BTreeMap<Signal, Alignment>,
    mode: Mode,
}

#[derive(Debug)]
enum Mode {
    Whole(Decimator),
    Stretches(Box<Stretches>),
}

/// What the stretched mode holds between samples.
#[derive(Debug)]
struct Stretches {
    plan: StretchPlan,
    /// The channels announced, in index order.
    channel_list: Vec<SensorChannel>,
    /// Per channel index: where its samples are windowed on the grid.
    windowing: Vec<Option<Alignment>>,
    /// Per channel index: when its samples came.
    arrivals: Vec<Option<Arrivals>>,
    newest: u64,
    /// The raw samples not yet sealed (and the overlap the next stretch needs), each with
    /// its grid window.
    buffer: Vec<(Sample, i64)>,
    /// The earliest and latest grid window holding a sample.
    window_range: Option<(i64, i64)>,
    samples: u64,
    /// The first instant not yet sealed (`None` before the first stretch).
    sealed: Option<i64>,
    /// When the next sample is worth a look for a ready stretch, and whether one came.
    next_check_ns: u64,
    due: bool,
    /// Per channel index: samples that arrived, and were taken back, after their
    /// instant was sealed.
    late: BTreeMap<usize, (u64, u64)>,
}

impl GridBuilder {
    /// A builder of the whole recording's grid of `ts_s` (the replay's).
    pub fn whole(
        ts_s: f64,
        alignments: BTreeMap<Signal, Alignment>,
    ) -> Result<GridBuilder, DecimateError> {
        let decimator = Decimator::new(ts_s, alignments.clone())?;
        Ok(GridBuilder {
            ts_s,
            ts_ns: (ts_s * 1e9).round() as i64,
            alignments,
            mode: Mode::Whole(decimator),
        })
    }

    /// A builder that seals stretches as the recording streams by (the monitor's).
    pub fn in_stretches(
        ts_s: f64,
        alignments: BTreeMap<Signal, Alignment>,
        plan: StretchPlan,
    ) -> Result<GridBuilder, DecimateError> {
        // The decimator's own check of the sample time, before any sample.
        Decimator::new(ts_s, BTreeMap::new())?;
        let plan = StretchPlan {
            stretch: plan.stretch.max(1),
            ..plan
        };
        Ok(GridBuilder {
            ts_s,
            ts_ns: (ts_s * 1e9).round() as i64,
            alignments,
            mode: Mode::Stretches(Box::new(Stretches {
                plan,
                channel_list: Vec::new(),
                windowing: Vec::new(),
                arrivals: Vec::new(),
                newest: 0,
                buffer: Vec::new(),
                window_range: None,
                samples: 0,
                sealed: None,
                next_check_ns: 0,
                due: false,
                late: BTreeMap::new(),
            })),
        })
    }

    /// The whole recording on the grid (in stretched mode: every sample still held).
    pub fn finish(self, channels: &[SensorChannel]) -> Result<DecimatedRecording, DecimateError> {
        match self.mode {
            Mode::Whole(decimator) => decimator.finish(channels),
            Mode::Stretches(s) => {
                let mut decimator = Decimator::new(self.ts_s, self.alignments.clone())?;
                for c in channels {
                    decimator.channel(c);
                }
                for (sample, _) in &s.buffer {
                    decimator.sample(*sample);
                }
                decimator.finish(channels)
            }
        }
    }

    /// The whole recording on the grid as it is, a channel whose clock jumped back laid
    /// out rather than refused (what `heatrun info` shows); in stretched mode, every
    /// sample still held.
    pub fn inspect(self, channels: &[SensorChannel]) -> Result<DecimatedRecording, DecimateError> {
        match self.mode {
            Mode::Whole(decimator) => decimator.inspect(channels),
            Mode::Stretches(_) => self.finish(channels),
        }
    }

    /// Whether a sample since the last call makes a ready stretch worth looking for (at
    /// most once per instant of the grid, by the samples' own times).
    pub fn take_due(&mut self) -> bool {
        match &mut self.mode {
            Mode::Stretches(s) => std::mem::take(&mut s.due),
            Mode::Whole(_) => false,
        }
    }

    /// Samples taken so far (finite values of announced channels).
    pub fn samples(&self) -> u64 {
        match &self.mode {
            Mode::Stretches(s) => s.samples,
            Mode::Whole(_) => 0,
        }
    }

    /// Whether a stretch has been sealed.
    pub fn has_sealed(&self) -> bool {
        matches!(&self.mode, Mode::Stretches(s) if s.sealed.is_some())
    }

    /// The next stretch the watermark has passed (at the end, `last`: all that is left),
    /// where there is one.
    pub fn ready(&self, last: bool) -> Option<Ready> {
        let Mode::Stretches(s) = &self.mode else {
            return None;
        };
        let (lo, _) = s.window_range?;
        let end = s.sealable_end(self.ts_ns, last)?;
        let start = s.sealed.unwrap_or(lo);
        if end <= start || (!last && end - start < s.plan.stretch) {
            return None;
        }
        let upto = if last { end } else { start + s.plan.stretch };
        Some(Ready { start, upto, end })
    }

    /// The held samples laid on the grid from instant `lo` for `len` instants (nothing is
    /// sealed: what a driver looks at before it seals, e.g. the origins of its signals).
    pub fn lay_out(&self, lo: i64, len: usize) -> Result<DecimatedRecording, DecimateError> {
        match &self.mode {
            Mode::Stretches(s) => self.decimate(s, lo, len),
            Mode::Whole(_) => Err(DecimateError::NoSamples),
        }
    }

    /// Seals `ready` (checks the channels' clocks over it, lays it on the grid with its
    /// overlap, drops the samples no later stretch needs).
    pub fn seal(&mut self, ready: Ready, last: bool) -> Result<Sealed, DecimateError> {
        let (a, b) = (ready.start, ready.upto);
        let sealed = {
            let Mode::Stretches(s) = &self.mode else {
                return Err(DecimateError::NoSamples);
            };
            self.check_clock(s, a, b)?;
            let lo = a - s.plan.lookback;
            let hi = if last { b } else { b + s.plan.lookahead };
            let offset = (a - lo) as usize;
            Sealed {
                decimated: self.decimate(s, lo, (hi - lo) as usize)?,
                instants: offset..offset + (b - a) as usize,
            }
        };
        let ts_s = self.ts_s;
        if let Mode::Stretches(s) = &mut self.mode {
            s.sealed = Some(b);
            let cut = b - s.plan.lookback - 1;
            s.prune(cut, ts_s);
        }
        Ok(sealed)
    }

    /// The data-loss lines of samples that came too late for their stretch.
    pub fn late_lines(&self) -> Vec<String> {
        match &self.mode {
            Mode::Stretches(s) => s.late_lines(),
            Mode::Whole(_) => Vec::new(),
        }
    }

    /// A decimator with every channel announced.
    fn decimator(&self, s: &Stretches) -> Result<Decimator, DecimateError> {
        let mut decimator = Decimator::new(self.ts_s, self.alignments.clone())?;
        for c in &s.channel_list {
            decimator.channel(c);
        }
        Ok(decimator)
    }

    /// Refuses a channel whose clock jumped back over its own samples within instants
    /// `a..b`, judged, as a replay judges the whole recording, on their samples alone
    /// (the neighbour kept from before a gap would make the stretch look dense).
    fn check_clock(&self, s: &Stretches, a: i64, b: i64) -> Result<(), DecimateError> {
        let mut decimator = self.decimator(s)?;
        for (sample, w) in &s.buffer {
            if (a..b).contains(w) {
                decimator.sample(*sample);
            }
        }
        match decimator.finish(&s.channel_list) {
            Err(e @ DecimateError::ClockJump { .. }) => Err(e),
            _ => Ok(()),
        }
    }

    /// The held samples laid on the grid from instant `lo` for `len` instants.
    fn decimate(
        &self,
        s: &Stretches,
        lo: i64,
        len: usize,
    ) -> Result<DecimatedRecording, DecimateError> {
        let mut decimator = self.decimator(s)?;
        for (sample, _) in &s.buffer {
            decimator.sample(*sample);
        }
        match decimator.inspect(&s.channel_list) {
            Ok(d) => Ok(d.window(lo, len)),
            Err(DecimateError::NoSamples) => Ok(self.unknown(s, lo, len)),
            Err(e) => Err(e),
        }
    }

    /// Every announced channel's signal, unknown throughout.
    fn unknown(&self, s: &Stretches, lo: i64, len: usize) -> DecimatedRecording {
        let series = s
            .channel_list
            .iter()
            .map(|c| {
                let d = DecimatedSeries {
                    signal: c.signal.clone(),
                    unit: c.canonical_unit().to_owned(),
                    values: Series::unknown(len),
                    sensors: 1,
                    observed: None,
                };
                (c.signal.clone(), d)
            })
            .collect();
        DecimatedRecording {
            ts_ns: self.ts_ns,
            first_index: lo,
            len,
            series,
            channels: Vec::new(),
        }
    }
}

impl Stretches {
    fn channel_of(&self, index: usize) -> Option<&SensorChannel> {
        match self.channel_list.get(index) {
            Some(c) if c.index == index => Some(c),
            _ => self.channel_list.iter().find(|c| c.index == index),
        }
    }

    fn window(&self, ts_ns: i64, sample: &Sample) -> Option<i64> {
        let alignment = (*self.windowing.get(sample.channel)?)?;
        Some(decimate::window_index(ts_ns, alignment, sample.log_time_ns))
    }

    /// The first instant not yet sealable: every instant before it has its samples in.
    fn sealable_end(&self, ts_ns: i64, last: bool) -> Option<i64> {
        let (_, hi) = self.window_range?;
        if last {
            return Some(hi + 1);
        }
        let slowest = self
            .arrivals
            .iter()
            .flatten()
            .map(Arrivals::settled)
            .min()?;
        let watermark = slowest.max(self.newest.saturating_sub(self.plan.lateness_ns));
        Some((watermark as i64).div_euclid(ts_ns) - self.plan.lookahead - MARGIN)
    }

    /// Drops the samples before grid window `cut`, but each channel's last occupied window
    /// before it (the neighbour an interpolation after the cut needs).
    fn prune(&mut self, cut: i64, ts_s: f64) {
        let mut last_before = vec![i64::MIN; self.windowing.len()];
        for (s, w) in &self.buffer {
            if *w < cut {
                last_before[s.channel] = last_before[s.channel].max(*w);
            }
        }
        // A neighbour further back than any interpolation reaches is not kept: laid out
        // beside the first samples after a gap, it would make the gap look like the
        // channel's spacing.
        let reach = |c: usize, w: i64| {
            let reach_s = match (self.channel_of(c).map(|c| c.storage), &self.arrivals.get(c)) {
                (Some(Storage::Exception { max_interval_s, .. }), _) => {
                    max_interval_s.map_or(f64::INFINITY, |m| GAP_FACTOR * m)
                }
                (_, Some(Some(a))) => 2.0 * GAP_FACTOR * a.period_s(),
                _ => 0.0,
            };
            ((cut - w) as f64 - 2.0) * ts_s <= reach_s
        };
        let reaches: Vec<bool> = last_before
            .iter()
            .enumerate()
            .map(|(c, &w)| w > i64::MIN && reach(c, w))
            .collect();
        self.buffer
            .retain(|(s, w)| *w >= cut || (last_before[s.channel] == *w && reaches[s.channel]));
    }

    /// The data-loss lines of samples that came too late.
    fn late_lines(&self) -> Vec<String> {
        let topic = |c: usize| {
            self.channel_of(c)
                .map_or_else(|| format!("#{c}"), |c| c.topic.clone())
        };
        let mut lines = Vec::new();
        for (&c, &(arrived, retracted)) in &self.late {
            if arrived > 0 {
                lines.push(format!(
                    "{arrived} samples of channel {} arrived after their instant was monitored",
                    topic(c)
                ));
            }
            if retracted > 0 {
                lines.push(format!(
                    "{retracted} samples of channel {} were found faulty at the end of the \
                     file after their instant was monitored",
                    topic(c)
                ));
            }
        }
        lines
    }
}

impl SampleSink for GridBuilder {
    fn channel(&mut self, channel: &SensorChannel) {
        let alignments = &self.alignments;
        match &mut self.mode {
            Mode::Whole(decimator) => decimator.channel(channel),
            Mode::Stretches(s) => {
                if s.windowing.len() <= channel.index {
                    s.windowing.resize(channel.index + 1, None);
                }
                s.windowing[channel.index] = Some(decimate::channel_alignment(alignments, channel));
                s.channel_list.retain(|c| c.index != channel.index);
                s.channel_list.push(channel.clone());
                s.channel_list.sort_by_key(|c| c.index);
            }
        }
    }

    fn sample(&mut self, sample: Sample) {
        let ts_ns = self.ts_ns;
        let s = match &mut self.mode {
            Mode::Whole(decimator) => return decimator.sample(sample),
            Mode::Stretches(s) => s,
        };
        if !sample.value.is_finite() {
            return;
        }
        let Some(w) = s.window(ts_ns, &sample) else {
            return;
        };
        s.samples += 1;
        if s.sealed.is_some_and(|sealed| w < sealed) {
            s.late.entry(sample.channel).or_default().0 += 1;
        }
        s.window_range = Some(match s.window_range {
            Some((lo, hi)) => (lo.min(w), hi.max(w)),
            None => (w, w),
        });
        if s.arrivals.len() <= sample.channel {
            s.arrivals.resize(sample.channel + 1, None);
        }
        let t = sample.log_time_ns;
        match &mut s.arrivals[sample.channel] {
            Some(a) => a.add(t),
            slot @ None => {
                *slot = Some(Arrivals {
                    first: t,
                    latest: t,
                    count: 1,
                })
            }
        }
        s.newest = s.newest.max(t);
        s.buffer.push((sample, w));
        if t >= s.next_check_ns {
            s.next_check_ns = t + ts_ns as u64;
            s.due = true;
        }
    }

    fn retract(&mut self, sample: Sample) {
        let ts_ns = self.ts_ns;
        let s = match &mut self.mode {
            Mode::Whole(decimator) => return decimator.retract(sample),
            Mode::Stretches(s) => s,
        };
        if !sample.value.is_finite() {
            return;
        }
        match (s.window(ts_ns, &sample), s.sealed) {
            (Some(w), Some(sealed)) if w < sealed => {
                s.late.entry(sample.channel).or_default().1 += 1
            }
            _ => {
                if let Some(i) = s.buffer.iter().position(|(b, _)| *b == sample) {
                    s.buffer.remove(i);
                }
            }
        }
    }
}

/// When one channel's samples came: enough to say how far behind its latest sample its
/// data are complete.
#[derive(Debug, Clone, Copy)]
struct Arrivals {
    first: u64,
    latest: u64,
    count: u64,
}

impl Arrivals {
    fn add(&mut self, t: u64) {
        self.first = self.first.min(t);
        self.latest = self.latest.max(t);
        self.count += 1;
    }

    /// Its mean spacing so far, s (gaps make it longer, never shorter).
    fn period_s(&self) -> f64 {
        (self.latest - self.first) as f64 * 1e-9 / (self.count.max(2) - 1) as f64
    }

    /// The time up to which its data are complete, ns.
    fn settled(&self) -> u64 {
        let behind = (SETTLE_PERIODS * self.period_s() * 1e9) as u64;
        self.latest.saturating_sub(behind)
    }
}
