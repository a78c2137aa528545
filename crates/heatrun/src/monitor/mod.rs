//! Monitoring: an identified model (the report of `heatrun replay --report`) run beside a
//! later recording of the same machine in normal service, part by part, with an alarm
//! where the measured temperature leaves the model's band for longer than a hold time
//! (a fouled cooler or a blocked duct shows as a slow rise above the model).
//!
//! Input: a [`ThermalModel`] and a recording. The recording goes through the replay's
//! stages — reader → decimator on the model's grid → signals — with the model's own
//! description (states, inputs, scaling) and nameplate, so the inputs u(k) are computed
//! exactly as they were when the model was identified. Then the model runs beside it:
//! x̂(k+1) = Φ x̂(k) + Γ u(k), from the recording's own first measured state (the
//! machine may be anywhere when a service recording starts) and again after every gap
//! in the inputs. The predicted temperature is θ̂_j = θ_ref,j + θ_base·ŷ_j, ŷ = x̂ (or,
//! for a model with hidden states, ŷ = C x̂ + D u, started from x̂ = C⁺ (y − D u)); the
//! residual r_j = θ_j − θ̂_j goes to the [`alarm::Detector`] against the [`band::Band`].
//!
//! References: a state measured from its initial temperature (the paper's formulation)
//! is measured from the model test's θ_ref,j, shifted by the coolant inlet's difference
//! from the model test's mean inlet where both recordings have one (the shift passed
//! through a first-order lag of the model's fastest time constant: no part follows the
//! inlet faster); a state measured from the coolant inlet's initial level (the network
//! formulation) is measured from this recording's own level, its drift an input (the
//! network's rises do not depend on the level chosen); a channel reference is read at
//! each instant. Output: a [`MonitorResult`]; memory grows with the grid, not the
//! samples.

pub mod alarm;
pub mod band;
pub mod output;
pub mod stream;

#[cfg(test)]
mod hidden_tests;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::decimate::DecimatedRecording;
use crate::error::Result;
use crate::model_file::{FieldTemperatureUse, ThermalModel, UseError};
use crate::recording::{Alignment, Quantity, SampleSink, Signal};
use crate::series::Series;
use crate::spec::{ModelDescription, Reference, Scaling, StateDescription};

pub use alarm::{Alarm, Detector};
pub use band::{Band, BandKind, BandRule};
pub use stream::{
    monitor_stream, ObserverError, Source, StreamOptions, Stretch, StretchObserver, Watchers,
};

/// How to monitor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MonitorOptions {
    /// How the band is set from the model's error.
    pub band: BandRule,
    /// How long a residual must stay outside the band to be an alarm, s.
    pub hold_s: f64,
}

/// The default hold time, s: ten minutes, a few times the fast constants of a
/// generator's winding and cooler, well inside the hours over which a fouled cooler's
/// effect builds.
pub const DEFAULT_HOLD_S: f64 = 600.0;

impl Default for MonitorOptions {
    fn default() -> Self {
        MonitorOptions {
            band: BandRule::default(),
            hold_s: DEFAULT_HOLD_S,
        }
    }
}

/// One part's residual over the recording.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PartStats {
    /// The state's name.
    pub state: String,
    /// The physical part.
    pub part: String,
    /// Its band, K.
    pub band_k: f64,
    /// Instants with a residual.
    pub instants: usize,
    /// Mean residual θ − θ̂, K.
    pub mean_k: f64,
    /// RMS residual, K.
    pub rms_k: f64,
    /// Largest |residual|, K (signed).
    pub max_deviation_k: f64,
    /// When, s from the first instant.
    pub max_deviation_at_s: f64,
    /// Share of the instants outside the band.
    pub outside_fraction: f64,
}

/// Measured and predicted temperature per state on the grid (what rerun shows).
#[derive(Debug, Clone)]
pub struct MonitorTraces {
    /// Grid times, ns since the epoch.
    pub time_ns: Vec<i64>,
    /// θ_j per state, °C (empty where the stream was told not to keep them,
    /// [`StreamOptions::keep_traces`]).
    pub measured: Vec<Series>,
    /// θ̂_j per state, °C (empty likewise).
    pub predicted: Vec<Series>,
}

impl MonitorTraces {
    /// The residual θ_j − θ̂_j at instant k, K.
    pub fn residual(&self, j: usize, k: usize) -> Option<f64> {
        Some(self.measured.get(j)?.get(k)? - self.predicted.get(j)?.get(k)?)
    }
}

/// What monitoring a recording found: the typed result the printout, the JSON and rerun
/// are drawn from.
#[derive(Debug, Clone)]
pub struct MonitorResult {
    /// The recording monitored.
    pub recording: PathBuf,
    /// The model's report.
    pub model: PathBuf,
    /// The model grid's sample time, s.
    pub ts_s: f64,
    /// State names, in model order.
    pub states: Vec<String>,
    /// The parts, in model order.
    pub parts: Vec<String>,
    /// The band.
    pub band: Band,
    /// The hold time, s.
    pub hold_s: f64,
    /// The alarms, in the order they were raised.
    pub alarms: Vec<Alarm>,
    /// The residual per part.
    pub stats: Vec<PartStats>,
    /// How often the model restarted from the measured state after a gap.
    pub restarts: usize,
    /// Damage to the recording (the reader's data-loss lines).
    pub data_loss: Vec<String>,
    /// What the user should know about the comparison (a varying inlet the model does
    /// not carry).
    pub warnings: Vec<String>,
    /// The traces.
    pub traces: MonitorTraces,
}

impl MonitorResult {
    /// Whether no alarm was raised.
    pub fn healthy(&self) -> bool {
        self.alarms.is_empty()
    }

    /// The first grid instant, ns since the epoch.
    pub fn start_ns(&self) -> i64 {
        self.traces.time_ns.first().copied().unwrap_or(0)
    }

    /// Seconds of `time_ns` from the first grid instant.
    pub fn seconds(&self, time_ns: i64) -> f64 {
        (time_ns - self.start_ns()) as f64 / 1e9
    }
}

/// Monitors `recording` with `model`, streamed as it is read ([`stream`], with the
/// default stretch). `also` receives every raw sample as the file streams by (the
/// full-rate publisher).
pub fn monitor(
    model: &ThermalModel,
    recording: &Path,
    options: &MonitorOptions,
    also: Option<&mut dyn SampleSink>,
) -> Result<MonitorResult> {
    let watchers = stream::Watchers {
        also,
        ..Default::default()
    };
    stream::monitor_stream(
        model,
        stream::Source::File(recording),
        options,
        &stream::StreamOptions::default(),
        watchers,
    )
}

/// The model's description for the signal stage: the report's own, its states as
/// measured (a rise from the model test's initial temperature is measured here, see the
/// module), on the model's grid.
pub fn description_of(model: &ThermalModel) -> Result<ModelDescription, UseError> {
    let states = model
        .states
        .iter()
        .map(|s| StateDescription {
            reference: match &s.reference {
                Reference::Initial => Reference::Absolute,
                other => other.clone(),
            },
            ..s.clone()
        })
        .collect();
    let description = ModelDescription {
        name: model.name.clone(),
        states,
        // A flow change in service is carried as in the test, from this recording's own
        // initial flow.
        inputs: model.inputs.clone(),
        scaling: if model.per_unit {
            Scaling::NameplatePerUnit
        } else {
            Scaling::AsRecorded
        },
        sample_time_s: Some(model.ts_s),
        method: None,
        hidden: None,
    };
    if description.needs_nameplate() && model.nameplate.is_none() {
        return Err(model.missing("nameplate", "the loss model and the per-unit bases need"));
    }
    Ok(description)
}

/// Gives `decimated` the field winding's temperature by the model's own line,
/// θ_f = a + b·θ_Cu (`FieldTemperatureUse::FromStator`: the report's
/// `estimation.field_temperature_from_stator`), where the recording has neither a
/// `field_winding_temp` nor a `field_voltage` channel and the model derives θ_f so.
///
/// Why: the loss model would otherwise scale the field winding's temperature from the
/// stator winding's rise *over the stretch at hand* to the nameplate's final field
/// temperature (the paper's method for a heat run that ends at rated load). A service
/// recording neither starts cold nor ends at rated load, and a stretch of it may barely
/// rise (the loss model then refuses it, `FieldScalingRise`); the line the model's own
/// heat run was scaled by is the one its Γ was identified with, and the one `predict`
/// and `rating` use. A recording with a field channel is left as it is.
pub fn with_model_field_line(model: &ThermalModel, decimated: &mut DecimatedRecording) {
    let FieldTemperatureUse::FromStator { intercept_c, slope } = model.field_temperature else {
        return;
    };
    if decimated.get(Quantity::FieldWindingTemp).is_some()
        || decimated.get(Quantity::FieldVoltage).is_some()
    {
        return;
    }
    let Some(stator) = decimated.get(Quantity::StatorWindingTemp) else {
        return;
    };
    let values: Series = stator
        .values
        .iter()
        .map(|t| t.map(|t| intercept_c + slope * t))
        .collect();
    let signal = Signal::Profile(Quantity::FieldWindingTemp);
    let series = crate::decimate::DecimatedSeries {
        signal: signal.clone(),
        unit: "degC".into(),
        values,
        sensors: 0,
        observed: None,
    };
    decimated.series.insert(signal, series);
}

/// Where each signal's samples sit on the model's grid: the description's alignments,
/// and the coolant inlet at the instant where the model test recorded one (for the
/// shift of initial references).
pub fn grid_alignments(
    model: &ThermalModel,
    description: &ModelDescription,
) -> BTreeMap<Signal, Alignment> {
    let mut alignments = description.alignments();
    if model.coolant_inlet_temp_c.is_some() {
        alignments
            .entry(Signal::Profile(Quantity::CoolingWaterInletTemp))
            .or_insert(Alignment::Instant);
    }
    alignments
}

/// A warning where the recording's coolant inlet varies and the model's rises are
/// measured from their initial values: such a model has no input for the inlet, so its
/// prediction follows the inlet only as the lagged shift, which the slow parts do not
/// follow; the model identified with the coolant inlet as its reference does.
pub fn inlet_warning(model: &ThermalModel, decimated: &DecimatedRecording) -> Option<String> {
    let inlet = crate::spec::coolant::inlet_behaviour(decimated)?;
    let initial_states = model
        .states
        .iter()
        .any(|s| matches!(s.reference, Reference::Initial));
    (inlet.varies() && initial_states && !model.uses_coolant_inlet()).then(|| {
        format!(
            "the coolant inlet varies by {:.2} K in this recording, and the model measures its \
             rises from their initial values (it has no input for the inlet): its prediction \
             follows the inlet as a shift lagged by its fastest time constant, which the slow \
             parts do not follow; a model identified with the coolant inlet as its reference \
             carries the inlet's drift as an input",
            inlet.variation_k
        )
    })
}

/// θ_ref,j(k) per state (see the module on references).
pub enum StateRef {
    /// The model test's reference plus the lagged coolant shift.
    ModelInitial(f64),
    /// The signal stage's reference (a channel, or this recording's inlet level).
    FromSignals,
}

impl StateRef {
    /// Each state's reference: a rise from the model test's initial temperature is
    /// measured from the test's θ_ref,j, an absolute temperature from 0, the others by
    /// the signal stage.
    pub fn per_state(model: &ThermalModel) -> Vec<StateRef> {
        model
            .states
            .iter()
            .zip(&model.initial_reference_c)
            .map(|(s, &r0)| match s.reference {
                Reference::Initial => StateRef::ModelInitial(r0),
                Reference::Absolute => StateRef::ModelInitial(0.0),
                Reference::Channel(_) | Reference::InitialOf(_) => StateRef::FromSignals,
            })
            .collect()
    }
}

/// Running sums of one part's residual.
#[derive(Debug, Clone, Default)]
pub struct Accumulator {
    n: usize,
    sum: f64,
    sum_sq: f64,
    max: f64,
    max_at_s: f64,
    outside: usize,
}

impl Accumulator {
    /// Adds residual `r` (K) at `t_s` seconds from the start, against a band of `band_k`.
    pub fn add(&mut self, r: f64, t_s: f64, band_k: f64) {
        self.n += 1;
        self.sum += r;
        self.sum_sq += r * r;
        if r.abs() > self.max.abs() {
            self.max = r;
            self.max_at_s = t_s;
        }
        self.outside += usize::from(r.abs() > band_k);
    }

    /// The part's statistics: mean, RMS, largest deviation and the share outside the band.
    pub fn finish(&self, state: &str, part: &str, band_k: f64) -> PartStats {
        let n = self.n.max(1) as f64;
        PartStats {
            state: state.into(),
            part: part.into(),
            band_k,
            instants: self.n,
            mean_k: self.sum / n,
            rms_k: (self.sum_sq / n).sqrt(),
            max_deviation_k: self.max,
            max_deviation_at_s: self.max_at_s,
            outside_fraction: self.outside as f64 / n,
        }
    }
}
