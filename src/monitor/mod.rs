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
//! in the inputs. The predicted temperature is θ̂_j = θ_ref,j + θ_base·x̂_j; the residual
//! r_j = θ_j − θ̂_j goes to the [`alarm::Detector`] against the [`band::Band`].
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

use std::path::{Path, PathBuf};

use nalgebra::DVector;

use crate::decimate::{DecimatedRecording, Decimator};
use crate::error::{Error, Result};
use crate::predict::model::{InputUse, StateReference};
use crate::predict::{ThermalModel, UseError};
use crate::recording::{self, Alignment, Quantity, ReadOptions, SampleSink, Signal};
use crate::series::Series;
use crate::signals::{self, ModelSignals};
use crate::spec::{
    InputDescription, InputSource, ModelDescription, Reference, Scaling, StateDescription,
};

pub use alarm::{Alarm, Detector};
pub use band::{Band, BandRule};

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
    /// θ_j per state, °C.
    pub measured: Vec<Series>,
    /// θ̂_j per state, °C.
    pub predicted: Vec<Series>,
}

impl MonitorTraces {
    /// The residual θ_j − θ̂_j at instant k, K.
    pub fn residual(&self, j: usize, k: usize) -> Option<f64> {
        Some(self.measured[j].get(k)? - self.predicted[j].get(k)?)
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

/// Monitors `recording` with `model`. `also` receives every raw sample as the file
/// streams by (the full-rate publisher).
pub fn monitor(
    model: &ThermalModel,
    recording: &Path,
    options: &MonitorOptions,
    also: Option<&mut dyn SampleSink>,
) -> Result<MonitorResult> {
    let description = description_of(model)?;
    let in_file = |e: Error| e.in_recording(recording);
    let (summary, decimated) = read(recording, model, &description, also)?;
    let signals =
        signals::compute(&description, &decimated, model.nameplate.as_ref()).map_err(in_file)?;
    let references = references(model, &signals, &decimated);
    let warnings = inlet_warning(model, &decimated).into_iter().collect();
    let band = Band::from_model_error(&model.error, options.band);
    let run = run_beside(model, &signals, &references, &band, options.hold_s);
    let states: Vec<String> = model.states.iter().map(|s| s.name.clone()).collect();
    let stats = run
        .stats
        .iter()
        .enumerate()
        .map(|(j, acc)| acc.finish(&states[j], &model.states[j].part, band.half_width_k[j]))
        .collect();
    Ok(MonitorResult {
        recording: recording.to_owned(),
        model: model.path.clone(),
        ts_s: model.ts_s,
        parts: model.states.iter().map(|s| s.part.clone()).collect(),
        states,
        band,
        hold_s: options.hold_s,
        alarms: run.alarms,
        stats,
        restarts: run.restarts,
        data_loss: summary.data_loss,
        warnings,
        traces: run.traces,
    })
}

/// The model's description for the signal stage: its states as measured (their
/// references are applied here, see the module), its inputs as identified.
pub fn description_of(model: &ThermalModel) -> Result<ModelDescription, UseError> {
    let states = model
        .states
        .iter()
        .map(|s| StateDescription {
            name: s.name.clone(),
            channel: Signal::from_name(&s.channel),
            reference: match &s.reference {
                StateReference::Initial(_) | StateReference::Absolute => Reference::Absolute,
                StateReference::Channel(c, _) => Reference::Channel(Signal::from_name(c)),
                StateReference::InitialOf(c, _) => Reference::InitialOf(Signal::from_name(c)),
            },
            part: s.part.clone(),
            unit: "degC".into(),
        })
        .collect();
    let inputs = model
        .inputs
        .iter()
        .map(|i| InputDescription {
            name: i.name.clone(),
            source: match &i.source {
                InputUse::Loss(h) => InputSource::Loss(*h),
                InputUse::Channel(c) => InputSource::Channel(Signal::from_name(c)),
                InputUse::Expression(e) => InputSource::Expression(e.clone()),
                InputUse::BoundaryRise(c) => InputSource::BoundaryRise(Signal::from_name(c)),
                // A flow change in service is carried as in the test, from this
                // recording's own initial flow.
                InputUse::CoolantFlow {
                    flow,
                    outlet,
                    inlet,
                } => InputSource::CoolantFlow {
                    flow: Signal::from_name(flow),
                    outlet: Signal::from_name(outlet),
                    inlet: Signal::from_name(inlet),
                },
            },
            unit: String::new(),
            kind: i.kind,
            from_initial: false,
            delay_s: i.delay_s,
        })
        .collect();
    let description = ModelDescription {
        name: model.name.clone(),
        states,
        inputs,
        scaling: if model.per_unit {
            Scaling::NameplatePerUnit
        } else {
            Scaling::AsRecorded
        },
        sample_time_s: Some(model.ts_s),
        method: None,
    };
    if description.needs_nameplate() && model.nameplate.is_none() {
        return Err(model.missing("nameplate", "the loss model and the per-unit bases need"));
    }
    Ok(description)
}

/// Reads and decimates the recording on the model's grid (with the coolant inlet, for
/// the shift of initial references, where the model test recorded one).
fn read(
    path: &Path,
    model: &ThermalModel,
    description: &ModelDescription,
    also: Option<&mut dyn SampleSink>,
) -> Result<(recording::RecordingSummary, DecimatedRecording)> {
    let mut alignments = description.alignments();
    if model.coolant_inlet_temp_c.is_some() {
        alignments
            .entry(Signal::Profile(Quantity::CoolingWaterInletTemp))
            .or_insert(Alignment::Instant);
    }
    let mut decimator = Decimator::new(model.ts_s, alignments)?;
    let options = ReadOptions {
        free_channels: description.free_channels(),
        ..ReadOptions::default()
    };
    let summary = match also {
        Some(also) => recording::read_recording_with(
            path,
            &mut crate::pipeline::Tee {
                decimator: &mut decimator,
                also,
            },
            &options,
        )?,
        None => recording::read_recording_with(path, &mut decimator, &options)?,
    };
    let decimated = decimator
        .finish(&summary.channels)
        .map_err(|e| e.in_recording(path))?;
    Ok((summary, decimated))
}

/// A warning where the recording's coolant inlet varies and the model's rises are
/// measured from their initial values: such a model has no input for the inlet, so its
/// prediction follows the inlet only as the lagged shift, which the slow parts do not
/// follow; the model identified with the coolant inlet as its reference does.
fn inlet_warning(model: &ThermalModel, decimated: &DecimatedRecording) -> Option<String> {
    let inlet = crate::spec::coolant::inlet_behaviour(decimated)?;
    let initial_states = model
        .states
        .iter()
        .any(|s| matches!(s.reference, StateReference::Initial(_)));
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
enum StateRef {
    /// The model test's reference plus the lagged coolant shift.
    ModelInitial(f64),
    /// The signal stage's reference (a channel, or this recording's inlet level).
    FromSignals,
}

struct References {
    per_state: Vec<StateRef>,
    /// The lagged inlet shift per instant, K (0 where it does not apply).
    shift: Vec<f64>,
}

impl References {
    fn at(&self, signals: &ModelSignals, j: usize, k: usize) -> Option<f64> {
        match self.per_state[j] {
            StateRef::ModelInitial(theta_ref) => Some(theta_ref + self.shift[k]),
            StateRef::FromSignals => signals.states[j].reference_at(k),
        }
    }
}

fn references(
    model: &ThermalModel,
    signals: &ModelSignals,
    decimated: &DecimatedRecording,
) -> References {
    let per_state = model
        .states
        .iter()
        .map(|s| match s.reference {
            StateReference::Initial(r) => StateRef::ModelInitial(r),
            StateReference::Absolute => StateRef::ModelInitial(0.0),
            _ => StateRef::FromSignals,
        })
        .collect();
    let inlet = decimated.get(Quantity::CoolingWaterInletTemp);
    let shift = match (model.coolant_inlet_temp_c, inlet) {
        (Some(test), Some(inlet)) if !model.uses_coolant_inlet() => {
            lagged_shift(&inlet.values, test, model, signals.ts_s)
        }
        _ => vec![0.0; signals.len()],
    };
    References { per_state, shift }
}

/// θ_in(k) − θ_in,test through a first-order lag of the model's fastest time constant,
/// the last value held across gaps.
fn lagged_shift(inlet: &Series, test_c: f64, model: &ThermalModel, ts_s: f64) -> Vec<f64> {
    let tau = model
        .time_constants_s
        .iter()
        .copied()
        .filter(|t| t.is_finite() && *t > 0.0)
        .fold(f64::INFINITY, f64::min);
    let alpha = if tau.is_finite() {
        1.0 - (-ts_s / tau).exp()
    } else {
        1.0
    };
    let mut state: Option<f64> = None;
    inlet
        .iter()
        .map(|v| {
            if let Some(v) = v {
                let d = v - test_c;
                state = Some(state.map_or(d, |s| s + alpha * (d - s)));
            }
            state.unwrap_or(0.0)
        })
        .collect()
}

/// Running sums of one part's residual.
#[derive(Debug, Clone, Default)]
struct Accumulator {
    n: usize,
    sum: f64,
    sum_sq: f64,
    max: f64,
    max_at_s: f64,
    outside: usize,
}

impl Accumulator {
    fn add(&mut self, r: f64, t_s: f64, band_k: f64) {
        self.n += 1;
        self.sum += r;
        self.sum_sq += r * r;
        if r.abs() > self.max.abs() {
            self.max = r;
            self.max_at_s = t_s;
        }
        self.outside += usize::from(r.abs() > band_k);
    }

    fn finish(&self, state: &str, part: &str, band_k: f64) -> PartStats {
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

struct Run {
    traces: MonitorTraces,
    stats: Vec<Accumulator>,
    alarms: Vec<Alarm>,
    restarts: usize,
}

/// The model beside the recording, instant by instant (see the module).
fn run_beside(
    model: &ThermalModel,
    signals: &ModelSignals,
    refs: &References,
    band: &Band,
    hold_s: f64,
) -> Run {
    let (n, len) = (model.state_count(), signals.len());
    let base = model.temperature_base_k;
    let names = model.states.iter().map(|s| s.name.clone()).collect();
    let mut detector = Detector::new(names, band.half_width_k.clone(), hold_s);
    let mut stats = vec![Accumulator::default(); n];
    let mut predicted = vec![Series::unknown(len); n];
    let (mut x_hat, mut starts) = (None::<DVector<f64>>, 0usize);
    let t0 = signals.time_ns.first().copied().unwrap_or(0);
    let mut residuals = vec![None; n];
    for k in 0..len {
        let measured: Vec<Option<f64>> = signals.states.iter().map(|s| s.measured.get(k)).collect();
        let reference: Vec<Option<f64>> = (0..n).map(|j| refs.at(signals, j, k)).collect();
        if x_hat.is_none() {
            let rises: Option<Vec<f64>> = (0..n)
                .map(|j| Some((measured[j]? - reference[j]?) / base))
                .collect();
            if let Some(r) = rises {
                x_hat = Some(DVector::from_vec(r));
                starts += 1;
            }
        }
        let t_s = (signals.time_ns[k] - t0) as f64 / 1e9;
        for j in 0..n {
            let theta_hat = x_hat
                .as_ref()
                .and_then(|x| Some(reference[j]? + base * x[j]));
            predicted[j].set(k, theta_hat);
            residuals[j] = measured[j].zip(theta_hat).map(|(m, p)| m - p);
            if let Some(r) = residuals[j] {
                stats[j].add(r, t_s, band.half_width_k[j]);
            }
        }
        detector.observe(signals.time_ns[k], &residuals);
        let u: Option<Vec<f64>> = signals.inputs.iter().map(|i| i.values.get(k)).collect();
        x_hat = match (x_hat, u) {
            (Some(x), Some(u)) => Some(&model.phi * x + &model.gamma * DVector::from_vec(u)),
            _ => None,
        };
    }
    let last = signals.time_ns.last().copied().unwrap_or(0);
    Run {
        traces: MonitorTraces {
            time_ns: signals.time_ns.clone(),
            measured: signals.states.iter().map(|s| s.measured.clone()).collect(),
            predicted,
        },
        stats,
        alarms: detector.finish(last),
        restarts: starts.saturating_sub(1),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::signals::{InputSignal, ReferenceValues, StateSignal};
    use crate::spec::InputKind;

    /// One state, one input, as recorded: x(k+1) = 0.9 x(k) + 0.05 u(k), rises above
    /// the test's initial 20 °C; the model's validation RMSE 0.1 K.
    fn model() -> ThermalModel {
        let report = serde_json::json!({
            "profile": crate::report::PROFILE,
            "sample_time_s": 1.0,
            "states": ["part"],
            "inputs": ["heater"],
            "phi": [[0.9]],
            "gamma": [[0.05]],
            "time_constants_s": [9.49],
            "fit": {"rmse_k": [0.1], "max_abs_error_k": [0.3]},
            "model": {
                "name": "one node",
                "states": [{"name": "part", "channel": "part_temp", "reference": "initial",
                            "part": "the part"}],
                "inputs": [{"name": "heater", "source": {"channel": "heater_w"},
                            "unit": "W", "kind": "heat"}],
                "scaling": "as_recorded"
            },
            "estimation": {"initial_temperature_c": [20.0], "temperature_base_k": 1.0}
        });
        ThermalModel::from_json(&report.to_string(), Path::new("model.json")).unwrap()
    }

    /// The model by hand from rise x0 under u = 2 W: x(k) = 0.9^k x0 + (1 − 0.9^k).
    fn by_hand(x0: f64, k: i32) -> f64 {
        0.9f64.powi(k) * x0 + (1.0 - 0.9f64.powi(k))
    }

    #[test]
    fn the_model_runs_beside_the_recording_restarts_after_a_gap_and_alarms() {
        let model = model();
        let len: usize = 20;
        // Measured: the model's own path from 25 °C, 2 K above it from instant 5; after
        // the input's gap at instant 10, the model's path from 30 °C.
        let measured: Series = (0..len)
            .map(|k| {
                Some(match k {
                    0..5 => 20.0 + by_hand(5.0, k as i32),
                    5..=10 => 22.0 + by_hand(5.0, k as i32),
                    _ => 20.0 + by_hand(10.0, k as i32 - 11),
                })
            })
            .collect();
        let heater: Series = (0..len).map(|k| (k != 10).then_some(2.0)).collect();
        let signals = ModelSignals {
            ts_s: 1.0,
            time_ns: (0..len as i64).map(|k| k * 1_000_000_000).collect(),
            states: vec![StateSignal {
                name: "part".into(),
                part: "the part".into(),
                measured,
                reference: ReferenceValues::Constant(0.0),
                observed: None,
                exception: None,
            }],
            inputs: vec![InputSignal {
                name: "heater".into(),
                unit: "W".into(),
                kind: InputKind::Heat,
                values: heater,
                outlet_feedback: None,
            }],
            initial_index: 0,
            temperature_base_k: 1.0,
            power_base: 1.0,
            field_temperature: None,
        };
        let refs = References {
            per_state: vec![StateRef::ModelInitial(20.0)],
            shift: vec![0.0; len],
        };
        let band = Band::from_model_error(&model.error, BandRule::default());
        assert_eq!(band.half_width_k, vec![0.5]);
        let run = run_beside(&model, &signals, &refs, &band, 3.0);
        let predicted = |k: usize| run.traces.predicted[0].get(k).unwrap();
        for k in 0..=10 {
            let expected = 20.0 + by_hand(5.0, k as i32);
            assert!((predicted(k) - expected).abs() < 1e-12, "instant {k}");
        }
        // No input at 10: restarted at 11 from the measured 30 °C (a rise of 10 K).
        assert_eq!(run.restarts, 1);
        assert!((predicted(11) - 30.0).abs() < 1e-12);
        assert!((predicted(12) - (20.0 + by_hand(10.0, 1))).abs() < 1e-12);
        // 2 K above from 5 s to 10 s, back inside at 11 s: 6 s outside > 3 s hold.
        let alarms = &run.alarms;
        assert_eq!(alarms.len(), 1, "{alarms:?}");
        let s = 1_000_000_000;
        assert_eq!(
            (alarms[0].start_ns, alarms[0].end_ns),
            (5 * s, Some(11 * s))
        );
        assert!((alarms[0].peak_deviation_k - 2.0).abs() < 1e-12);
    }
}
