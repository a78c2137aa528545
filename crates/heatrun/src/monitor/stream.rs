//! The streamed monitor: the model runs beside a recording as it is read, a finished
//! stretch of the grid at a time, in time order, so that a connected viewer and the
//! printout follow a recording of any length (or one still being written, read from a
//! pipe) while memory holds the raw samples of about one stretch, not of the file.
//!
//! The driver is the reader's [`SampleSink`]: it hands every sample to a
//! [`GridBuilder`] in stretched mode (the replay's one way from recording to grid),
//! whose watermark says when a stretch of the grid has all its samples in, and which
//! lays each such stretch on the one grid of the whole recording with an overlap before
//! it (the look-back of the flow input's ±30 s smoothing and of the inputs' dead times)
//! and after it (the look-ahead). The signal stage computes the stretch measured from the
//! origins taken once on the first stretch ([`Anchors`]: the initial references and
//! levels, the flow's Q₀); then the model steps through its instants, carrying x̂, the
//! alarm detector, the residual statistics and the lagged inlet shift across stretches.
//! An observer ([`StretchObserver`]: the rerun publisher) receives each stretch as it is
//! sealed.
//!
//! On a complete file this gives what the whole-file monitor gave (kept as the tests'
//! oracle): the same instants and values (to rounding), alarms, statistics
//! and restarts. Samples that arrive for an instant already sealed (a file's order is not
//! strictly time order), and samples the reader takes back at the end of the file after
//! their instant was sealed, are counted and reported as data loss, never fatal.

use std::collections::{BTreeMap, VecDeque};
use std::io::Read;
use std::path::{Path, PathBuf};

use nalgebra::DVector;

use super::band::{measurement_variance_k2, model_band_k, BandKind};
use super::{
    description_of, grid_alignments, inlet_warning, Accumulator, Band, Detector, MonitorOptions,
    MonitorResult, MonitorTraces, StateRef,
};
use crate::confidence::OpenLoopVariance;
use crate::decimate::{DecimateError, DecimatedRecording, DecimatedSeries};
use crate::error::{Error, Result};
use crate::grid::{GridBuilder, Ready, StretchPlan, MARGIN};
use crate::model_file::ThermalModel;
use crate::progress::Observer;
use crate::recording::{self, Quantity, ReadOptions, Sample, SampleSink, SensorChannel, Signal};
use crate::series::Series;
use crate::signals::SignalError;
use crate::signals::{
    self, Anchors, ModelSignals, FLOW_RISE_SMOOTHING_S, INLET_SMOOTHING_S, INPUT_GAP_BRIDGED_S,
};
use crate::spec::{delay, InputSource, ModelDescription, Reference};

/// The default stretch, s: ten minutes of grid, short against a fouling's hours and
/// long against the look-back and look-ahead each stretch decimates again.
pub const DEFAULT_STRETCH_S: f64 = 600.0;

/// The default longest wait for a silent channel, s: fifteen minutes.
pub const DEFAULT_MAX_LATENESS_S: f64 = 900.0;

/// How the recording is streamed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreamOptions {
    /// The grid time sealed at once, s.
    pub stretch_s: f64,
    /// How far the watermark may stay behind the newest sample for a silent channel, s.
    pub max_lateness_s: f64,
    /// Whether the result keeps the measured and predicted temperatures of every instant
    /// ([`MonitorTraces`], which grow with the grid: what an HTML page draws); without
    /// them it keeps the grid's times only.
    pub keep_traces: bool,
}

impl Default for StreamOptions {
    fn default() -> Self {
        StreamOptions {
            stretch_s: DEFAULT_STRETCH_S,
            max_lateness_s: DEFAULT_MAX_LATENESS_S,
            keep_traces: true,
        }
    }
}

/// One sealed stretch, as the observer receives it.
#[derive(Debug)]
pub struct Stretch<'a> {
    /// Its grid instants, ns since the epoch.
    pub time_ns: &'a [i64],
    /// θ_j per state on them, °C.
    pub measured: &'a [Series],
    /// θ̂_j per state on them, °C.
    pub predicted: &'a [Series],
    /// The band's half-width b_j per state on them, K (constant for the fixed band,
    /// varying for the model's; unknown before the model has started).
    pub band_k: &'a [Series],
    /// Per state, the instants (ns) and residuals (K) now known to lie inside an alarm
    /// and not given before (an alarm is known the hold time after its start, so these
    /// may reach back into earlier stretches).
    pub alarm_points: &'a [Vec<(i64, f64)>],
    /// Alarms raised in this stretch: (state, first instant outside the band, ns).
    pub raised: &'a [(usize, i64)],
    /// Samples the reader had delivered when the stretch was sealed.
    pub samples_read: u64,
}

/// Why an observer stopped the monitor (its own error, boxed: the library does not know
/// the observer's kind).
pub type ObserverError = Box<dyn std::error::Error + Send + Sync>;

/// Receives the stretches as they are sealed, in time order.
pub trait StretchObserver {
    /// A stretch was sealed; an error stops the monitor (it becomes
    /// [`crate::Error::Observer`]).
    fn stretch(&mut self, stretch: &Stretch<'_>) -> std::result::Result<(), ObserverError>;
}

/// Where the recording comes from.
pub enum Source<'r> {
    /// A file.
    File(&'r Path),
    /// A stream (standard input), read in order to its end, named `name` in messages.
    Stream {
        /// The bytes.
        reader: Box<dyn Read + Send + 'r>,
        /// Its name in messages (`-`).
        name: PathBuf,
    },
}

impl Source<'_> {
    fn name(&self) -> PathBuf {
        match self {
            Source::File(p) => p.to_path_buf(),
            Source::Stream { name, .. } => name.clone(),
        }
    }
}

/// What a streamed monitor is told besides the model and the recording.
#[derive(Default)]
pub struct Watchers<'a> {
    /// Receives every raw sample as the file streams by (the full-rate publisher).
    pub also: Option<&'a mut dyn SampleSink>,
    /// Receives each sealed stretch.
    pub observer: Option<&'a mut dyn StretchObserver>,
    /// The reader's progress.
    pub progress: Observer,
}

/// Monitors `source` with `model` as it is read (see the module).
pub fn monitor_stream(
    model: &ThermalModel,
    source: Source<'_>,
    options: &MonitorOptions,
    stream: &StreamOptions,
    watchers: Watchers<'_>,
) -> Result<MonitorResult> {
    let description = description_of(model)?;
    let name = source.name();
    let (rule, band_warning) = super::band::rule_for(model, options.band);
    let band = Band::from_model_error(&model.error, rule);
    let mut live = Live::new(model, description.clone(), &band, options.hold_s, stream)?;
    live.also = watchers.also;
    live.observer = watchers.observer;
    let read_options = ReadOptions {
        free_channels: description.free_channels(),
        progress: watchers.progress,
    };
    let summary = match source {
        Source::File(path) => recording::read_recording_with(path, &mut live, &read_options)?,
        Source::Stream { reader, name } => {
            recording::read_stream_with(reader, &name, 0, &mut live, &read_options)?
        }
    };
    live.advance(true);
    if let Some(e) = live.error.take() {
        return Err(e.in_recording(&name));
    }
    if !live.grid.has_sealed() {
        return Err(Error::from(DecimateError::NoSamples).in_recording(&name));
    }
    let mut data_loss = summary.data_loss;
    data_loss.extend(live.grid.late_lines());
    let mut result = live
        .run
        .finish(model, &band, options.hold_s, &name, data_loss);
    result.warnings.extend(band_warning);
    Ok(result)
}

/// The sample sink that drives the grid builder and runs the model over each stretch
/// it seals.
struct Live<'m, 'w> {
    model: &'m ThermalModel,
    description: ModelDescription,
    grid: GridBuilder,
    /// Instants per stretch (the origins are tried again a stretch later).
    stretch: i64,
    anchors: Option<Anchors>,
    /// The first instant not yet sealable at which to try taking the origins again.
    anchor_retry: i64,
    error: Option<Error>,
    also: Option<&'w mut dyn SampleSink>,
    observer: Option<&'w mut dyn StretchObserver>,
    run: Runner,
}

impl<'m, 'w> Live<'m, 'w> {
    fn new(
        model: &'m ThermalModel,
        description: ModelDescription,
        band: &Band,
        hold_s: f64,
        stream: &StreamOptions,
    ) -> Result<Live<'m, 'w>> {
        let instants = |s: f64| (s / model.ts_s).ceil() as i64;
        let flow = description
            .inputs
            .iter()
            .any(|i| matches!(i.source, InputSource::CoolantFlow { .. }));
        // The inlet's course and the flow's heat are local fits around each instant, and
        // an input's short gap is bridged from its neighbours: a stretch needs them all.
        let inlet = Signal::Profile(Quantity::CoolingWaterInletTemp);
        let reads_inlet = description
            .inputs
            .iter()
            .any(|i| matches!(&i.source, InputSource::BoundaryRise(c) if *c == inlet))
            || description
                .states
                .iter()
                .any(|s| matches!(&s.reference, Reference::Channel(c) if *c == inlet));
        let smoothing = [
            (flow, FLOW_RISE_SMOOTHING_S),
            (reads_inlet, INLET_SMOOTHING_S),
            (true, INPUT_GAP_BRIDGED_S),
        ]
        .iter()
        .filter(|(applies, _)| *applies)
        .map(|(_, s)| instants(*s))
        .max()
        .unwrap_or(0);
        // A dead time looks back d instants, an advance (a negative shift) ahead a.
        let shifts: Vec<isize> = description
            .inputs
            .iter()
            .filter_map(|i| delay::shift_samples(i.delay_s, model.ts_s))
            .collect();
        let dead_time = shifts.iter().copied().max().unwrap_or(0).max(0) as i64;
        let advance = -(shifts.iter().copied().min().unwrap_or(0).min(0)) as i64;
        let plan = StretchPlan {
            stretch: instants(stream.stretch_s).max(1),
            lookback: smoothing + dead_time + MARGIN,
            lookahead: smoothing + advance + MARGIN,
            lateness_ns: (stream.max_lateness_s.max(0.0) * 1e9) as u64,
        };
        let alignments = grid_alignments(model, &description);
        let grid = GridBuilder::in_stretches(model.ts_s, alignments, plan)?;
        Ok(Live {
            model,
            description,
            grid,
            stretch: plan.stretch,
            anchors: None,
            anchor_retry: i64::MIN,
            error: None,
            also: None,
            observer: None,
            run: Runner::new(model, band, hold_s, stream),
        })
    }

    /// Seals every stretch the grid builder offers (all of them at the end).
    fn advance(&mut self, last: bool) {
        while self.error.is_none() {
            let Some(ready) = self.grid.ready(last) else {
                return;
            };
            match self.seal(ready, last) {
                Ok(true) => {}
                Ok(false) => return,
                Err(e) => self.error = Some(e),
            }
        }
    }

    /// Seals `ready` and runs the model over it. `false` where the origins cannot be
    /// taken yet (the first stretch waits for more).
    fn seal(&mut self, ready: Ready, last: bool) -> Result<bool> {
        if self.anchors.is_none() {
            // Tried again a stretch later, not at every sample: until the origins can be
            // taken, the builder holds the recording from its start.
            if !last && ready.end < self.anchor_retry {
                return Ok(false);
            }
            self.anchor_retry = ready.end + self.stretch;
            let whole = self
                .grid
                .lay_out(ready.start, (ready.end - ready.start) as usize)?;
            let np = self.model.nameplate.as_ref();
            match Anchors::find(&self.description, &whole, np) {
                Ok(anchors) if anchors.complete || last => self.anchors = Some(anchors),
                Ok(_) => return Ok(false),
                Err(SignalError::NoCommonInstant { .. }) if !last => return Ok(false),
                Err(e) => return Err(e.into()),
            }
        }
        let mut sealed = self.grid.seal(ready, last)?;
        super::with_model_field_line(self.model, &mut sealed.decimated);
        let anchors = self.anchors.as_mut().expect("anchored above");
        let np = self.model.nameplate.as_ref();
        let signals = signals::compute_anchored(&self.description, &sealed.decimated, np, anchors)?;
        self.run
            .stretch(self.model, &signals, &sealed.decimated, sealed.instants);
        if let Some(observer) = self.observer.as_deref_mut() {
            observer
                .stretch(&self.run.last_stretch(self.grid.samples()).borrow())
                .map_err(crate::Error::Observer)?;
        }
        Ok(true)
    }
}

impl SampleSink for Live<'_, '_> {
    fn channel(&mut self, channel: &SensorChannel) {
        if let Some(also) = self.also.as_deref_mut() {
            also.channel(channel);
        }
        self.grid.channel(channel);
    }

    fn sample(&mut self, sample: Sample) {
        if let Some(also) = self.also.as_deref_mut() {
            also.sample(sample);
        }
        if self.error.is_some() {
            return;
        }
        self.grid.sample(sample);
        if self.grid.take_due() {
            self.advance(false);
        }
    }

    fn retract(&mut self, sample: Sample) {
        if let Some(also) = self.also.as_deref_mut() {
            also.retract(sample);
        }
        self.grid.retract(sample);
    }
}

/// The model beside the recording, carried from one stretch to the next.
struct Runner {
    per_state: Vec<StateRef>,
    base: f64,
    /// The inlet temperature of the model test and the lag's weight per instant, where
    /// initial references shift with this recording's inlet.
    shift: Option<(f64, f64)>,
    shift_state: Option<f64>,
    x_hat: Option<DVector<f64>>,
    /// The prediction's variance beside x̂, where the band is the model's.
    variance: Option<OpenLoopVariance>,
    /// The model band's factor, where the band is the model's.
    model_band: Option<f64>,
    /// What a residual carries besides the prediction's variance, K² per state.
    measurement_k2: Vec<f64>,
    /// Per state: the model band summed over the instants compared, and their count.
    band_sum: Vec<(f64, usize)>,
    starts: usize,
    detector: Detector,
    stats: Vec<Accumulator>,
    band_k: Vec<f64>,
    t0: Option<i64>,
    /// The last stretch's instants.
    current: Traces,
    /// All instants before it (the temperatures only where they are kept).
    kept: Traces,
    overlay: Overlay,
    /// The coolant inlet and outlet on the grid (the inlet warning reads them).
    coolant: [Series; 2],
}

/// Measured and predicted temperature per state, grown stretch by stretch.
struct Traces {
    time_ns: Vec<i64>,
    measured: Vec<Series>,
    predicted: Vec<Series>,
    /// The band per state: the last stretch's only (the observer draws it), never kept.
    band_k: Vec<Series>,
}

impl Traces {
    fn new(n: usize) -> Traces {
        Traces {
            time_ns: Vec::new(),
            measured: vec![Series::default(); n],
            predicted: vec![Series::default(); n],
            band_k: vec![Series::default(); n],
        }
    }

    /// Moves `other`'s instants to the end of these (its temperatures where these keep
    /// them).
    fn append(&mut self, other: &mut Traces) {
        self.time_ns.append(&mut other.time_ns);
        for (kept, new) in self.measured.iter_mut().zip(&other.measured) {
            kept.extend(new);
        }
        for (kept, new) in self.predicted.iter_mut().zip(&other.predicted) {
            kept.extend(new);
        }
        for s in other
            .measured
            .iter_mut()
            .chain(other.predicted.iter_mut())
            .chain(other.band_k.iter_mut())
        {
            *s = Series::default();
        }
    }
}

impl Runner {
    fn new(model: &ThermalModel, band: &Band, hold_s: f64, stream: &StreamOptions) -> Runner {
        let n = model.state_count();
        let names = model.states.iter().map(|s| s.name.clone()).collect();
        let per_state = StateRef::per_state(model);
        let shift = match model.coolant_inlet_temp_c {
            Some(test) if !model.uses_coolant_inlet() => Some((test, lag_weight(model))),
            _ => None,
        };
        let detector = Detector::new(names, band.half_width_k.clone(), hold_s);
        // An excursion not yet known to be an alarm started at most the hold and the
        // clearing time before the last update, a stretch ago.
        let ring = 0.2 * hold_s + stream.stretch_s + model.ts_s;
        let ring = detector.hold_ns() + (ring * 1e9) as i64;
        Runner {
            per_state,
            base: model.temperature_base_k,
            shift,
            shift_state: None,
            x_hat: None,
            variance: None,
            model_band: (band.kind == BandKind::Model).then_some(band.factor),
            measurement_k2: measurement_variance_k2(model),
            band_sum: vec![(0.0, 0); n],
            starts: 0,
            detector,
            stats: vec![Accumulator::default(); n],
            band_k: band.half_width_k.clone(),
            t0: None,
            current: Traces::new(n),
            kept: Traces::new(if stream.keep_traces { n } else { 0 }),
            overlay: Overlay::new(n, ring),
            coolant: [Series::default(), Series::default()],
        }
    }

    /// Steps the model through instants `range` of a stretch's signals.
    fn stretch(
        &mut self,
        model: &ThermalModel,
        signals: &ModelSignals,
        decimated: &DecimatedRecording,
        range: std::ops::Range<usize>,
    ) {
        let values = |q: Quantity| decimated.get(q).map(|s| &s.values);
        let inlet = values(Quantity::CoolingWaterInletTemp);
        let outlet = values(Quantity::CoolingWaterOutletTemp);
        self.kept.append(&mut self.current);
        for k in range {
            let inlet_k = inlet.and_then(|s| s.get(k));
            self.coolant[0].push(inlet_k);
            self.coolant[1].push(outlet.and_then(|s| s.get(k)));
            let shift = self.lagged_shift(inlet_k);
            self.step(model, signals, k, shift);
        }
        let now = self.current.time_ns.last().copied().unwrap_or(0);
        self.overlay.update(&self.detector, now);
    }

    /// θ_in − θ_in,test through the first-order lag, the last value held across gaps.
    fn lagged_shift(&mut self, inlet: Option<f64>) -> f64 {
        let Some((test, alpha)) = self.shift else {
            return 0.0;
        };
        if let Some(v) = inlet {
            let d = v - test;
            self.shift_state = Some(self.shift_state.map_or(d, |s| s + alpha * (d - s)));
        }
        self.shift_state.unwrap_or(0.0)
    }

    /// One instant: start (or restart) from the measured state, predict, compare, step.
    fn step(&mut self, model: &ThermalModel, signals: &ModelSignals, k: usize, shift: f64) {
        let n = self.per_state.len();
        let time_ns = signals.time_ns[k];
        let t0 = *self.t0.get_or_insert(time_ns);
        let measured: Vec<Option<f64>> = signals.states.iter().map(|s| s.measured.get(k)).collect();
        let reference: Vec<Option<f64>> = (0..n)
            .map(|j| match self.per_state[j] {
                StateRef::ModelInitial(r) => Some(r + shift),
                StateRef::FromSignals => signals.states[j].reference_at(k),
            })
            .collect();
        // The inputs now, for the feedthrough D u of a model with hidden states.
        let u_now: Option<DVector<f64>> = signals
            .inputs
            .iter()
            .map(|i| i.values.get(k))
            .collect::<Option<Vec<f64>>>()
            .map(DVector::from_vec);
        if self.x_hat.is_none() {
            let rises: Option<Vec<f64>> = (0..n)
                .map(|j| Some((measured[j]? - reference[j]?) / self.base))
                .collect();
            if let Some(r) = rises {
                // A model with hidden states starts from the least-norm state giving the
                // measured rises (`OutputMap::state_from_outputs`), its variance carried
                // through y = C x + D u.
                let zero = DVector::zeros(model.inputs.len());
                let u = u_now.as_ref().unwrap_or(&zero);
                let y = DVector::from_vec(r);
                self.x_hat = Some(model.state_from_outputs(&y, u));
                self.starts += 1;
                let start: Vec<f64> = (model.uncertainty.sensor_noise_k.iter())
                    .map(|s| (s / self.base).powi(2))
                    .collect();
                self.variance = Some(
                    OpenLoopVariance::start(model, &start).with_start_sensitivity(model, &y, u),
                );
            }
        }
        self.set_model_band(model, u_now.as_ref());
        let t_s = (time_ns - t0) as f64 / 1e9;
        let mut residuals = vec![None; n];
        let y_hat = self.x_hat.as_ref().map(|x| match &u_now {
            Some(u) => model.outputs(x, u),
            None => model.outputs(x, &DVector::zeros(model.inputs.len())),
        });
        for j in 0..n {
            let theta_hat = y_hat
                .as_ref()
                .and_then(|y| Some(reference[j]? + self.base * y[j]));
            residuals[j] = measured[j].zip(theta_hat).map(|(m, p)| m - p);
            if let Some(r) = residuals[j] {
                self.stats[j].add(r, t_s, self.band_k[j]);
                self.band_sum[j].0 += self.band_k[j];
                self.band_sum[j].1 += 1;
            }
            self.current.measured[j].push(measured[j]);
            self.current.predicted[j].push(theta_hat);
            self.current.band_k[j].push(theta_hat.map(|_| self.band_k[j]));
        }
        self.current.time_ns.push(time_ns);
        self.detector.observe(time_ns, &residuals);
        self.overlay.remember(time_ns, residuals);
        self.x_hat = match (self.x_hat.take(), u_now) {
            (Some(x), Some(u)) => {
                if let Some(v) = &mut self.variance {
                    v.step(model, &model.uncertainty, &x, &u);
                }
                Some(&model.phi * x + &model.gamma * u)
            }
            _ => {
                self.variance = None;
                None
            }
        };
    }

    /// The model band at this instant, for the detector and the statistics (kept
    /// as it was where the band is fixed or the model has not started).
    fn set_model_band(&mut self, model: &ThermalModel, u: Option<&DVector<f64>>) {
        let (Some(factor), Some(v), Some(x)) = (self.model_band, &self.variance, &self.x_hat)
        else {
            return;
        };
        let zero = DVector::zeros(model.inputs.len());
        let var = v.variances(model, &model.uncertainty, x, u.unwrap_or(&zero));
        self.band_k = model_band_k(factor, self.base, &var, &self.measurement_k2);
        self.detector.set_band(&self.band_k);
    }

    /// The last stretch sealed, for the observer.
    fn last_stretch(&self, samples_read: u64) -> StretchView {
        StretchView {
            time_ns: self.current.time_ns.clone(),
            measured: self.current.measured.clone(),
            predicted: self.current.predicted.clone(),
            band_k: self.current.band_k.clone(),
            alarm_points: self.overlay.points.clone(),
            raised: self.overlay.raised.clone(),
            samples_read,
        }
    }

    /// The result, once the recording has ended.
    fn finish(
        mut self,
        model: &ThermalModel,
        band: &Band,
        hold_s: f64,
        recording: &Path,
        data_loss: Vec<String>,
    ) -> MonitorResult {
        self.kept.append(&mut self.current);
        let last = self.kept.time_ns.last().copied().unwrap_or(0);
        let states: Vec<String> = model.states.iter().map(|s| s.name.clone()).collect();
        let mut band = band.clone();
        if self.model_band.is_some() {
            // The model band's mean over the instants compared, for the summary.
            for (b, (sum, count)) in band.half_width_k.iter_mut().zip(&self.band_sum) {
                if *count > 0 {
                    *b = sum / *count as f64;
                }
            }
        }
        let stats = self
            .stats
            .iter()
            .enumerate()
            .map(|(j, acc)| acc.finish(&states[j], &model.states[j].part, band.half_width_k[j]))
            .collect();
        let first_index = self
            .t0
            .unwrap_or(0)
            .div_euclid((model.ts_s * 1e9).round() as i64);
        let warnings = inlet_warning(model, &coolant_grid(self.coolant, model.ts_s, first_index))
            .into_iter()
            .collect();
        MonitorResult {
            recording: recording.to_owned(),
            model: model.path.clone(),
            ts_s: model.ts_s,
            parts: model.states.iter().map(|s| s.part.clone()).collect(),
            states,
            band,
            hold_s,
            alarms: self.detector.finish(last),
            stats,
            restarts: self.starts.saturating_sub(1),
            data_loss,
            warnings,
            traces: MonitorTraces {
                time_ns: self.kept.time_ns,
                measured: self.kept.measured,
                predicted: self.kept.predicted,
            },
        }
    }
}

/// The lag's weight per instant, 1 − exp(−Ts/τ) for the model's fastest time constant.
fn lag_weight(model: &ThermalModel) -> f64 {
    let tau = model
        .time_constants_s
        .iter()
        .copied()
        .filter(|t| t.is_finite() && *t > 0.0)
        .fold(f64::INFINITY, f64::min);
    if tau.is_finite() {
        1.0 - (-model.ts_s / tau).exp()
    } else {
        1.0
    }
}

/// The coolant inlet and outlet on the grid, as the inlet warning reads a recording.
fn coolant_grid([inlet, outlet]: [Series; 2], ts_s: f64, first_index: i64) -> DecimatedRecording {
    let len = inlet.len();
    let mut series = BTreeMap::new();
    for (q, values) in [
        (Quantity::CoolingWaterInletTemp, inlet),
        (Quantity::CoolingWaterOutletTemp, outlet),
    ] {
        if values.iter().any(|v| v.is_some()) {
            let s = DecimatedSeries {
                signal: Signal::Profile(q),
                unit: q.canonical_unit().into(),
                values,
                sensors: 1,
                observed: None,
            };
            series.insert(Signal::Profile(q), s);
        }
    }
    DecimatedRecording {
        ts_ns: (ts_s * 1e9).round() as i64,
        first_index,
        len,
        series,
        channels: Vec::new(),
    }
}

/// A sealed stretch, owned (the observer borrows it as a [`Stretch`]).
struct StretchView {
    time_ns: Vec<i64>,
    measured: Vec<Series>,
    predicted: Vec<Series>,
    band_k: Vec<Series>,
    alarm_points: Vec<Vec<(i64, f64)>>,
    raised: Vec<(usize, i64)>,
    samples_read: u64,
}

impl StretchView {
    fn borrow(&self) -> Stretch<'_> {
        Stretch {
            time_ns: &self.time_ns,
            measured: &self.measured,
            predicted: &self.predicted,
            band_k: &self.band_k,
            alarm_points: &self.alarm_points,
            raised: &self.raised,
            samples_read: self.samples_read,
        }
    }
}

/// Which residuals lie inside an alarm, as far as the detector knows: an excursion is an
/// alarm once it has lasted longer than the hold time, which is known only that long
/// after its start, so the last hold time's residuals are kept to draw it from its start.
struct Overlay {
    /// The recent instants' residuals.
    ring: VecDeque<(i64, Vec<Option<f64>>)>,
    ring_ns: i64,
    /// Per state, the last instant given as inside an alarm.
    given_until: Vec<i64>,
    /// Per state, whether its open excursion was raised.
    raised_open: Vec<bool>,
    /// Closed alarms already drawn.
    closed_seen: usize,
    /// What the last update made known.
    points: Vec<Vec<(i64, f64)>>,
    raised: Vec<(usize, i64)>,
}

impl Overlay {
    fn new(n: usize, ring_ns: i64) -> Overlay {
        Overlay {
            ring: VecDeque::new(),
            ring_ns,
            given_until: vec![i64::MIN; n],
            raised_open: vec![false; n],
            closed_seen: 0,
            points: vec![Vec::new(); n],
            raised: Vec::new(),
        }
    }

    fn remember(&mut self, time_ns: i64, residuals: Vec<Option<f64>>) {
        self.ring.push_back((time_ns, residuals));
    }

    /// Gives the residuals of state j in `[start, end)` not given before.
    fn give(&mut self, j: usize, start: i64, end: i64) {
        for (t, r) in &self.ring {
            if *t >= start && *t < end && *t > self.given_until[j] {
                if let Some(r) = r[j] {
                    self.points[j].push((*t, r));
                }
            }
        }
        let upto = self.ring.iter().map(|(t, _)| *t).filter(|t| *t < end).max();
        if let Some(t) = upto {
            self.given_until[j] = self.given_until[j].max(t);
        }
    }

    /// What the detector knows at `now` (the last instant observed).
    fn update(&mut self, detector: &Detector, now: i64) {
        self.points.iter_mut().for_each(Vec::clear);
        self.raised.clear();
        let closed: Vec<(usize, i64, Option<i64>)> = detector.closed()[self.closed_seen..]
            .iter()
            .map(|a| (a.state, a.start_ns, a.end_ns))
            .collect();
        self.closed_seen += closed.len();
        for (j, start, end) in closed {
            if !self.raised_open[j] {
                self.raised.push((j, start));
            }
            self.raised_open[j] = false;
            self.give(j, start, end.unwrap_or(i64::MAX));
        }
        let hold = detector.hold_ns();
        for j in 0..self.given_until.len() {
            let Some((start, inside_since)) = detector.open_excursion(j) else {
                self.raised_open[j] = false;
                continue;
            };
            // Outside now: it lasts until now at least (as the detector's end would count it).
            let certain = inside_since.unwrap_or(now) - start > hold;
            if certain {
                if !self.raised_open[j] {
                    self.raised.push((j, start));
                    self.raised_open[j] = true;
                }
                self.give(j, start, inside_since.unwrap_or(i64::MAX));
            }
        }
        while self
            .ring
            .front()
            .is_some_and(|(t, _)| now - *t > self.ring_ns)
        {
            self.ring.pop_front();
        }
    }
}
