//! Signal stage: decimated channels → the model's states and inputs on the grid, as the
//! [`ModelDescription`] says.
//!
//! Input: a [`DecimatedRecording`], the description, and the nameplate where the
//! description needs one (the generator's loss model and per-unit bases). Output:
//! [`ModelSignals`], whose [`ModelSignals::identification_data`] is the estimator's input.
//!
//! A state is the rise x_j(k) = (θ_j(k) − θ_ref,j(k)) / θ_base of its channel above its
//! reference; an input is u_i(k) = P_i(k) / P_base, P_i a channel, an expression of
//! channels, or a heat source of the profile's loss model.

pub mod deadband;
mod gaps;

use std::collections::BTreeMap;

use nalgebra::DMatrix;

use crate::decimate::{DecimatedRecording, DecimatedSeries};
/// Why the model's signals cannot be built from a decimated recording.
#[derive(Debug, thiserror::Error)]
pub enum SignalError {
    /// A channel the model needs is not in the recording.
    #[error(
        "no channel carries `{channel}` (metadata `quantity` or a topic ending in /{channel})"
    )]
    MissingChannel {
        /// The quantity or free channel name.
        channel: String,
    },
    /// The model's states are never all known at one instant.
    #[error("{what} are never all known at the same instant")]
    NoCommonInstant {
        /// What was looked for.
        what: String,
    },
    /// An input's expression gives no finite value at any instant where its channels are
    /// all known (a division by zero, the logarithm of a negative number).
    #[error(
        "input `{input}`: its expression `{expression}` is not a finite number at any of the \
         {known} instants where its channels are known"
    )]
    ExpressionNeverFinite {
        /// The input.
        input: String,
        /// The expression's text.
        expression: String,
        /// Instants where every channel it reads is known.
        known: usize,
    },
    /// The model description needs a nameplate and none was resolved (a library misuse).
    #[error("the model's loss model and per-unit scaling need the machine's nameplate")]
    NameplateNeeded,
    /// A field-winding state, and the recording measures the field winding's temperature
    /// neither directly nor by its resistance.
    #[error(
        "the field winding state needs a `field_winding_temp` channel, or `field_voltage` \
         (with `field_current`) for the resistance method; the recording has neither"
    )]
    NoFieldState,
    /// The generator's losses (an input source) cannot be computed.
    #[error(transparent)]
    Losses(#[from] crate::losses::LossError),
    /// An input's dead time is not a whole number of samples of the grid.
    #[error(transparent)]
    InputDelay(#[from] crate::spec::delay::DelayError),
    /// The coolant's heat per litre cannot be had at the inlet's temperature.
    #[error(transparent)]
    Water(#[from] WaterError),
}

impl SignalError {
    /// Whether the error is the input's fault (every one but a library misuse and the
    /// water's range).
    pub fn is_bad_input(&self) -> bool {
        // The water's range is a property of the formulation, not of the recording (as
        // every network figure, exit status 1).
        !matches!(self, SignalError::NameplateNeeded | SignalError::Water(_))
    }
}

/// The signal stage's result.
pub type Result<T, E = SignalError> = std::result::Result<T, E>;
use crate::estimate::{ExceptionStorage, IdentificationData};
use crate::losses::{self, FieldTemperatureSource, GeneratorLosses};
use crate::recording::{Nameplate, Quantity, Signal, Storage};
use crate::series::Series;
use crate::spec::{
    coolant, delay, InputDescription, InputKind, InputSource, ModelDescription, Reference, Scaling,
    StateDescription,
};
use crate::thermal::water::{Water, WaterError};

pub use gaps::{bridged_instants_limit, Bridge, InputGaps, INPUT_GAP_BRIDGED_S};

/// What a state's rise is measured from, on the grid.
#[derive(Debug, Clone)]
pub enum ReferenceValues {
    /// A constant: the state's initial value (the paper), or 0 for an absolute state.
    Constant(f64),
    /// Another channel's value at each instant.
    Channel(Series),
}

/// One state on the grid.
#[derive(Debug, Clone)]
pub struct StateSignal {
    /// The state's name.
    pub name: String,
    /// The physical part, for people.
    pub part: String,
    /// The measured value θ_j(k) (°C for temperatures), `None` where unknown.
    pub measured: Series,
    /// θ_ref,j: what the rise is measured from.
    pub reference: ReferenceValues,
    /// For channels stored by exception: the instants that hold a stored sample (exact
    /// values); between them `measured` is interpolated and not used as an output.
    pub observed: Option<Vec<bool>>,
    /// The channel's storage by exception, where declared: (deadband in the channel's
    /// unit, heartbeat in s). Between stored samples the value stayed within the deadband.
    pub exception: Option<(f64, Option<f64>)>,
}

impl StateSignal {
    /// θ_ref,j(k).
    pub fn reference_at(&self, k: usize) -> Option<f64> {
        match &self.reference {
            ReferenceValues::Constant(c) => Some(*c),
            ReferenceValues::Channel(s) => s.get(k),
        }
    }

    /// The rise θ_j(k) − θ_ref,j(k), in the channel's unit (K).
    pub fn rise(&self, k: usize) -> Option<f64> {
        Some(self.measured.get(k)? - self.reference_at(k)?)
    }
}

/// One input on the grid.
#[derive(Debug, Clone)]
pub struct InputSignal {
    /// The input's name.
    pub name: String,
    /// Its unit before scaling, for people (`W`).
    pub unit: String,
    /// Heat, or another exogenous input.
    pub kind: InputKind,
    /// u_i(k) in the model's scaling (pu of the power base, or as recorded), held over
    /// [t_k, t_k + Ts).
    pub values: Series,
    /// For an input that is a multiple of the coolant outlet's rise above the inlet (the
    /// heat a flow change carries): that multiple, for the steady state.
    pub outlet_feedback: Option<OutletFeedback>,
    /// Its gaps: the short ones bridged in `values`, the long ones left as cuts.
    pub gaps: InputGaps,
}

/// An input proportional to the outlet state's rise above the inlet,
/// u_i(k) = κ(k)·(x_out(k) − u_inlet(k)) (the heat a flow change carries:
/// κ = −c·ρ·(Q − Q₀)·θ_base/P_base), so that its steady-state value follows the
/// steady state itself ([`ModelSignals::steady_state_input`]).
#[derive(Debug, Clone)]
pub struct OutletFeedback {
    /// The outlet's state.
    pub outlet_state: usize,
    /// The inlet's rise input, where the inlet drifts (the states are then measured
    /// from its initial level, and the rise above the inlet is x_out − u_inlet).
    pub inlet_input: Option<usize>,
    /// κ(k), input per unit of the outlet's rise above the inlet, model scaling.
    pub per_rise: Series,
    /// The flow Q₀ the model's A_c describes (the flow's initial level), l/s: the
    /// network's calorimetric scale c·ρ·Q₀.
    pub reference_flow_l_per_s: f64,
}

/// Where the generator's field winding temperature came from, and its values.
#[derive(Debug, Clone)]
pub struct FieldTemperature {
    /// θ_f on the grid, °C.
    pub values: Series,
    /// The method.
    pub source: FieldTemperatureSource,
}

/// The model's signals on the grid: the signal stage's output.
#[derive(Debug, Clone)]
pub struct ModelSignals {
    /// Sample time in s.
    pub ts_s: f64,
    /// Time of each grid instant, ns since the epoch.
    pub time_ns: Vec<i64>,
    /// The states, in model order.
    pub states: Vec<StateSignal>,
    /// The inputs, in model order.
    pub inputs: Vec<InputSignal>,
    /// The first instant at which every state is known (initial references are taken there).
    pub initial_index: usize,
    /// Kelvin per unit of a state: θ_base (pu) or 1 (as recorded).
    pub temperature_base_k: f64,
    /// Input unit per unit of an input: S_n in VA (pu) or 1 (as recorded).
    pub power_base: f64,
    /// The generator's field winding temperature (loss model only).
    pub field_temperature: Option<FieldTemperature>,
}

impl ModelSignals {
    /// Number of grid instants.
    pub fn len(&self) -> usize {
        self.time_ns.len()
    }

    /// Whether there are no instants.
    pub fn is_empty(&self) -> bool {
        self.time_ns.is_empty()
    }

    /// State j's rise at instant k in the model's scaling: (θ_j − θ_ref,j) / θ_base.
    pub fn rise_pu(&self, j: usize, k: usize) -> Option<f64> {
        self.states[j].rise(k).map(|r| r / self.temperature_base_k)
    }

    /// Each state's reference at the initial instant (the paper's θ_0).
    pub fn initial_references(&self) -> Vec<f64> {
        self.states
            .iter()
            .map(|s| s.reference_at(self.initial_index).unwrap_or(f64::NAN))
            .collect()
    }

    /// Moves each state's reference by `offset_pu[j]`·θ_base: θ_ref,j + d_j·θ_base, the
    /// initial temperature an estimator found where the rises were measured from one
    /// noisy first sample (y = x + d, d = −that sample's error). The rises then drop by
    /// d_j, so every later stage sees ŷ = x.
    pub fn shift_references(&mut self, offset_pu: &[f64]) {
        for (state, d) in self.states.iter_mut().zip(offset_pu) {
            let shift = d * self.temperature_base_k;
            match &mut state.reference {
                ReferenceValues::Constant(c) => *c += shift,
                ReferenceValues::Channel(series) => {
                    for k in 0..series.len() {
                        let moved = series.get(k).map(|v| v + shift);
                        series.set(k, moved);
                    }
                }
            }
        }
    }

    /// The last instant at which every input is known, with those inputs.
    pub fn last_inputs(&self) -> Option<(usize, Vec<f64>)> {
        (0..self.len()).rev().find_map(|k| {
            let u: Option<Vec<f64>> = self.inputs.iter().map(|i| i.values.get(k)).collect();
            Some((k, u?))
        })
    }

    /// The input whose steady state is reported (eq. 30): the last known inputs, except
    /// that an input fed by the outlet's rise ([`OutletFeedback`]: the heat a changed
    /// flow carries) takes the value consistent with the steady state it leads to. With
    /// G = −A_c⁻¹B_c, x_out = Σ_l G_out,l·u_l and u_Q = κ·(x_out − u_inlet) at the last
    /// instant's κ: u_Q = κ·(s − u_inlet)/(1 − κ·G_out,Q), s the sum over the other
    /// inputs. The last measured rise would leave the steady state short wherever the
    /// run ends before equilibrium. `None` where no instant has every input known.
    pub fn steady_state_input(&self, a_c: &DMatrix<f64>, b_c: &DMatrix<f64>) -> Option<Vec<f64>> {
        let (k, mut u) = self.last_inputs()?;
        let Some(gain) = a_c.clone().try_inverse().map(|inv| -(inv * b_c)) else {
            return Some(u);
        };
        for (q, input) in self.inputs.iter().enumerate() {
            let Some(f) = &input.outlet_feedback else {
                continue;
            };
            let Some(kappa) = f.per_rise.get(k) else {
                continue;
            };
            let o = f.outlet_state;
            let others: f64 = (0..u.len())
                .filter(|&l| l != q)
                .map(|l| gain[(o, l)] * u[l])
                .sum();
            let inlet = f.inlet_input.map_or(0.0, |l| u[l]);
            let denominator = 1.0 - kappa * gain[(o, q)];
            if denominator.abs() > 1e-9 {
                u[q] = kappa * (others - inlet) / denominator;
            }
        }
        Some(u)
    }

    /// The last instant at which every state is measured, with the measured values.
    pub fn last_measured(&self) -> Option<(usize, Vec<f64>)> {
        (0..self.len()).rev().find_map(|k| {
            let y: Option<Vec<f64>> = self.states.iter().map(|s| s.measured.get(k)).collect();
            Some((k, y?))
        })
    }

    /// The estimator's input: the rises as outputs y (N × n), the inputs as u (N × m).
    /// Entries of states stored by exception count as known only where a sample was
    /// stored; any output missing after the initial instant makes the data masked
    /// ([`IdentificationData::with_output_observed`]): each entry known where its value is.
    pub fn identification_data(&self) -> IdentificationData {
        let (len, n, m) = (self.len(), self.states.len(), self.inputs.len());
        let mut outputs = DMatrix::zeros(len, n);
        let mut inputs = DMatrix::zeros(len, m);
        let mut observed = DMatrix::from_element(len, n, true);
        let mut outputs_known = vec![true; len];
        let mut inputs_known = vec![true; len];
        for k in 0..len {
            for j in 0..n {
                let seen = self.states[j].observed.as_ref().is_none_or(|o| o[k]);
                match self.rise_pu(j, k).filter(|_| seen) {
                    Some(v) => outputs[(k, j)] = v,
                    None => {
                        observed[(k, j)] = false;
                        outputs_known[k] = false;
                    }
                }
            }
            for i in 0..m {
                match self.inputs[i].values.get(k) {
                    Some(v) => inputs[(k, i)] = v,
                    None => inputs_known[k] = false,
                }
            }
        }
        let data = IdentificationData::new(self.ts_s, outputs, inputs, outputs_known, inputs_known);
        // A missing output sample (a dropout, a value dropped as bad or out of range) is an
        // unobserved entry the simulation runs through, never a cut: with a mask the data
        // are split only where an input is unknown. Before the first instant every state
        // is known nothing is observed that the rises could be measured from.
        let partial = (self.initial_index..len).any(|k| !data.outputs_known[k]);
        if !partial && !self.states.iter().any(|s| s.observed.is_some()) {
            return data;
        }
        // The estimator treats the instants between stored samples as "within the
        // deadband" (censored), not as unknown: in the model's scaling and instants.
        let storage = self
            .states
            .iter()
            .map(|s| {
                s.exception.map(|(deadband, heartbeat_s)| ExceptionStorage {
                    deadband: deadband / self.temperature_base_k,
                    max_interval: heartbeat_s
                        .map_or(usize::MAX, |h| (h / self.ts_s).round().max(1.0) as usize),
                })
            })
            .collect();
        data.with_output_observed(observed)
            .with_exception_storage(storage)
    }
}

/// What the signal stage fixes once, from the start of a recording: each state's
/// constant reference (its initial value θ_ref,j = θ_j(k₀), k₀ the first instant every
/// state and reference is known), the initial level of every channel a reference, a
/// boundary rise or a flow input is measured from (the mean of its first
/// [`coolant::INITIAL_LEVEL_S`] of known values from k₀), and each input's origin where
/// it is measured from its first value. A stream computes them on its first stretch and
/// carries them, so that every later stretch is measured from the same origins as the
/// whole recording would be ([`compute_anchored`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Anchors {
    /// Per state, its constant reference (NaN where none could be taken), `None` for a
    /// state referenced to a channel at each instant.
    pub references: Vec<Option<f64>>,
    /// The initial level of each channel one is taken of (those with a value).
    pub levels: BTreeMap<Signal, f64>,
    /// Whether every level's averaging window was full (a stream waits for more of the
    /// recording while it is not).
    pub complete: bool,
    /// Per input, the first known value it is measured from (inputs with `from_initial`;
    /// `None` until one is seen).
    pub input_origins: Vec<Option<f64>>,
}

impl Anchors {
    /// The anchors of a decimated recording: its first common instant k₀ and the levels
    /// from there (errors where no instant has every state and reference known).
    pub fn find(
        description: &ModelDescription,
        decimated: &DecimatedRecording,
        nameplate: Option<&Nameplate>,
    ) -> Result<Anchors> {
        let states = states_of(description, decimated, nameplate)?;
        Ok(anchors_at(
            description,
            decimated,
            &states,
            initial_index(&states, decimated.len)?,
        ))
    }
}

/// The channels whose initial level the description measures from.
fn level_channels(description: &ModelDescription) -> Vec<&Signal> {
    let refs = description
        .states
        .iter()
        .filter_map(|d| match &d.reference {
            Reference::InitialOf(r) => Some(r),
            _ => None,
        });
    let inputs = description.inputs.iter().flat_map(|i| match &i.source {
        InputSource::BoundaryRise(c) => vec![c],
        InputSource::CoolantFlow { flow, inlet, .. } => vec![flow, inlet],
        _ => Vec::new(),
    });
    refs.chain(inputs).collect()
}

/// The first instant at which every state's rise is known.
fn initial_index(states: &[StateSignal], len: usize) -> Result<usize> {
    (0..len)
        .find(|&k| states.iter().all(|s| s.rise(k).is_some()))
        .ok_or_else(|| SignalError::NoCommonInstant {
            what: "the states and their references".into(),
        })
}

fn anchors_at(
    description: &ModelDescription,
    decimated: &DecimatedRecording,
    states: &[StateSignal],
    initial_index: usize,
) -> Anchors {
    let ts_s = decimated.ts_s();
    let window = (coolant::INITIAL_LEVEL_S / ts_s).round().max(1.0) as usize;
    let mut complete = true;
    let mut levels = BTreeMap::new();
    for c in level_channels(description) {
        let Some(series) = decimated.get_signal(c) else {
            continue;
        };
        if let Some(level) = coolant::initial_level(&series.values, initial_index, ts_s) {
            levels.insert(c.clone(), level);
        }
        let known = series
            .values
            .iter()
            .skip(initial_index)
            .flatten()
            .take(window);
        complete &= known.count() == window;
    }
    let references = states
        .iter()
        .zip(&description.states)
        .map(|(s, d)| match (&s.reference, &d.reference) {
            (ReferenceValues::Constant(c), _) if !c.is_nan() => Some(*c),
            (ReferenceValues::Constant(_), Reference::InitialOf(r)) => {
                Some(levels.get(r).copied().unwrap_or(f64::NAN))
            }
            (ReferenceValues::Constant(_), _) => {
                Some(s.measured.get(initial_index).unwrap_or(f64::NAN))
            }
            (ReferenceValues::Channel(_), _) => None,
        })
        .collect();
    Anchors {
        references,
        levels,
        complete,
        input_origins: vec![None; description.inputs.len()],
    }
}

/// The states as measured, their constant references not yet taken (NaN).
fn states_of(
    description: &ModelDescription,
    decimated: &DecimatedRecording,
    nameplate: Option<&Nameplate>,
) -> Result<Vec<StateSignal>> {
    let series = |s: &Signal| {
        decimated
            .get_signal(s)
            .ok_or_else(|| SignalError::MissingChannel {
                channel: s.name().to_owned(),
            })
    };
    let deadband_of = |s: &Signal| declared_deadband(decimated, s);
    let mut states = Vec::with_capacity(description.states.len());
    for s in &description.states {
        let mut state = match decimated.get_signal(&s.channel) {
            Some(measured) => state_signal(
                s,
                (measured.values.clone(), measured.observed.clone()),
                (&series, &deadband_of),
                decimated.ts_s(),
            )?,
            None => state_signal(
                s,
                (derived_state(s, decimated, nameplate)?, None),
                (&series, &deadband_of),
                decimated.ts_s(),
            )?,
        };
        state.exception = exception_storage(decimated, &s.channel);
        states.push(state);
    }
    Ok(states)
}

/// Computes the description's states and inputs from a decimated recording.
pub fn compute(
    description: &ModelDescription,
    decimated: &DecimatedRecording,
    nameplate: Option<&Nameplate>,
) -> Result<ModelSignals> {
    let states = states_of(description, decimated, nameplate)?;
    let initial_index = initial_index(&states, decimated.len)?;
    let mut anchors = anchors_at(description, decimated, &states, initial_index);
    finish(
        description,
        decimated,
        nameplate,
        (states, initial_index),
        &mut anchors,
    )
}

/// [`compute`] on a stretch of a recording, measured from `anchors` taken at the start of
/// the whole recording ([`Anchors::find`]) rather than from the stretch's own start: the
/// stretch's instants get the values the whole recording would give them, where the
/// stretch holds what each instant's value depends on (the flow input's smoothing
/// around it, an input's dead time before it). An input measured from its first value
/// takes the first one seen into `anchors`. The loss model's field temperature scaled
/// from the armature rise (neither θ_f nor U_f recorded) is scaled within the stretch.
pub fn compute_anchored(
    description: &ModelDescription,
    decimated: &DecimatedRecording,
    nameplate: Option<&Nameplate>,
    anchors: &mut Anchors,
) -> Result<ModelSignals> {
    let mut states = states_of(description, decimated, nameplate)?;
    for (s, r) in states.iter_mut().zip(&anchors.references) {
        if let (ReferenceValues::Constant(c), Some(r)) = (&mut s.reference, r) {
            *c = *r;
        }
    }
    let initial_index = initial_index(&states, decimated.len).unwrap_or(0);
    finish(
        description,
        decimated,
        nameplate,
        (states, initial_index),
        anchors,
    )
}

/// The inputs beside the states, from the anchors' references and levels.
fn finish(
    description: &ModelDescription,
    decimated: &DecimatedRecording,
    nameplate: Option<&Nameplate>,
    (mut states, initial_index): (Vec<StateSignal>, usize),
    anchors: &mut Anchors,
) -> Result<ModelSignals> {
    let series = |s: &Signal| {
        decimated
            .get_signal(s)
            .ok_or_else(|| SignalError::MissingChannel {
                channel: s.name().to_owned(),
            })
    };
    let n = decimated.len;
    let level = |c: &Signal| -> Result<f64> {
        series(c)?;
        anchors
            .levels
            .get(c)
            .copied()
            .ok_or_else(|| SignalError::NoCommonInstant {
                what: format!("the reference channel {}", c.name()),
            })
    };
    for (s, d) in states.iter_mut().zip(&description.states) {
        if let ReferenceValues::Constant(c) = &mut s.reference {
            if c.is_nan() {
                *c = match &d.reference {
                    Reference::InitialOf(r) => level(r)?,
                    _ => s.measured.get(initial_index).unwrap_or(f64::NAN),
                };
            }
        }
    }
    let (temperature_base_k, power_base) = match (description.scaling, nameplate) {
        (Scaling::NameplatePerUnit, Some(np)) => {
            (np.temperature_base_k, np.rated_apparent_power_va)
        }
        (Scaling::NameplatePerUnit, None) => return Err(SignalError::NameplateNeeded),
        (Scaling::AsRecorded, _) => (1.0, 1.0),
    };
    let generator = match (
        description
            .inputs
            .iter()
            .any(|i| matches!(i.source, InputSource::Loss(_))),
        nameplate,
    ) {
        (true, Some(np)) => Some(losses::compute(decimated, np, initial_index)?),
        (true, None) => return Err(SignalError::NameplateNeeded),
        (false, _) => None,
    };
    let origins = &mut anchors.input_origins;
    origins.resize(description.inputs.len(), None);
    let inputs = description
        .inputs
        .iter()
        .zip(origins.iter_mut())
        .map(|(i, origin)| {
            let scale = Scales {
                power_base,
                temperature_base_k,
            };
            let sources = (generator.as_ref(), &series, &level);
            input_signal(i, decimated, sources, scale, origin)
        })
        .collect::<Result<Vec<_>>>()?;
    let mut inputs = inputs;
    for (q, i) in description.inputs.iter().enumerate() {
        if let InputSource::CoolantFlow {
            flow,
            outlet,
            inlet,
        } = &i.source
        {
            let c_rho = Water::at(level(inlet)?)?.heat_per_litre_j_per_k();
            let q0 = level(flow)?;
            let per_k = -c_rho * temperature_base_k / power_base;
            inputs[q].outlet_feedback = description
                .states
                .iter()
                .position(|s| &s.channel == outlet)
                .map(|outlet_state| OutletFeedback {
                    outlet_state,
                    inlet_input: description.inputs.iter().position(
                        |d| matches!(&d.source, InputSource::BoundaryRise(c) if c == inlet),
                    ),
                    per_rise: series(flow)
                        .map(|f| {
                            f.values
                                .iter()
                                .map(|v| v.map(|v| per_k * (v - q0)))
                                .collect()
                        })
                        .unwrap_or_else(|_| Series::unknown(n)),
                    reference_flow_l_per_s: q0,
                });
        }
    }
    // Dead times: each delayed input shifted on the grid, once, for every later stage.
    delay_inputs(&description.inputs, decimated.ts_s(), &mut inputs)?;
    // Short gaps bridged as the model assumes between samples; long ones cut the data.
    for (signal, d) in inputs.iter_mut().zip(&description.inputs) {
        signal.gaps = gaps::bridge_gaps(&mut signal.values, bridge_of(d), decimated.ts_s());
    }
    Ok(ModelSignals {
        ts_s: decimated.ts_s(),
        time_ns: (0..n).map(|i| decimated.time_ns(i)).collect(),
        states,
        inputs,
        initial_index,
        temperature_base_k,
        power_base,
        field_temperature: generator.map(|g| FieldTemperature {
            values: g.field_temperature_c,
            source: g.field_temperature_source,
        }),
    })
}

/// The storage by exception of a state's channel (the first of its sensors that declares
/// one): (deadband, heartbeat s).
fn exception_storage(
    decimated: &DecimatedRecording,
    signal: &Signal,
) -> Option<(f64, Option<f64>)> {
    decimated
        .channels
        .iter()
        .filter(|c| &c.signal == signal)
        .find_map(|c| match c.storage {
            Storage::Exception {
                deadband,
                max_interval_s,
            } => Some((deadband, max_interval_s)),
            Storage::Sampled => None,
        })
}

/// The deadband a signal's channel declares, where it is stored by exception.
fn declared_deadband(decimated: &DecimatedRecording, signal: &Signal) -> Option<f64> {
    exception_storage(decimated, signal).map(|(deadband, _)| deadband)
}

/// A state whose channel the recording lacks. The field winding's temperature is also
/// measured by its resistance, R_f(θ_f) = U_f / I_f (the loss model's second source of
/// θ_f), so a field-winding state is read either way; any other state's channel is
/// missing.
fn derived_state(
    s: &StateDescription,
    decimated: &DecimatedRecording,
    nameplate: Option<&Nameplate>,
) -> Result<Series> {
    if s.channel != Signal::Profile(Quantity::FieldWindingTemp) {
        return Err(SignalError::MissingChannel {
            channel: s.channel.name().to_owned(),
        });
    }
    let np = nameplate.ok_or(SignalError::NameplateNeeded)?;
    decimated
        .get(Quantity::FieldCurrent)
        .and_then(|i_f| losses::field_temperature_by_resistance(decimated, np, &i_f.values))
        .ok_or(SignalError::NoFieldState)
}

fn state_signal<'a>(
    s: &StateDescription,
    (measured, observed): (Series, Option<Vec<bool>>),
    (series, deadband_of): (
        &impl Fn(&Signal) -> Result<&'a DecimatedSeries>,
        &impl Fn(&Signal) -> Option<f64>,
    ),
    ts_s: f64,
) -> Result<StateSignal> {
    let reference = match &s.reference {
        // NaN until the initial instant is known.
        Reference::Initial | Reference::InitialOf(_) => ReferenceValues::Constant(f64::NAN),
        Reference::Absolute => ReferenceValues::Constant(0.0),
        Reference::Channel(c) => {
            ReferenceValues::Channel(reconstructed(series(c)?, deadband_of(c), ts_s))
        }
    };
    Ok(StateSignal {
        name: s.name.clone(),
        part: s.part.clone(),
        measured,
        reference,
        observed,
        exception: None,
    })
}

/// The units of the model's scaling: per power and per kelvin.
#[derive(Debug, Clone, Copy)]
struct Scales {
    power_base: f64,
    temperature_base_k: f64,
}

/// One input on the grid; `origin` is the value an input measured from its first value
/// is measured from (taken here, the first known one, where it is not yet known).
fn input_signal<'a>(
    i: &InputDescription,
    decimated: &DecimatedRecording,
    (generator, series, level): (
        Option<&GeneratorLosses>,
        &impl Fn(&Signal) -> Result<&'a DecimatedSeries>,
        &impl Fn(&Signal) -> Result<f64>,
    ),
    scale: Scales,
    origin: &mut Option<f64>,
) -> Result<InputSignal> {
    let power_base = scale.power_base;
    let values: Series = match &i.source {
        InputSource::Channel(c) => series(c)?
            .values
            .iter()
            .map(|v| v.map(|v| v / power_base))
            .collect(),
        InputSource::Expression(e) => {
            let channels = e
                .channels()
                .iter()
                .map(|c| series(c).map(|s| &s.values))
                .collect::<Result<Vec<_>>>()?;
            let mut args = vec![0.0; channels.len()];
            let mut known = 0;
            let values: Series = (0..decimated.len)
                .map(|k| {
                    for (a, c) in args.iter_mut().zip(&channels) {
                        *a = c.get(k)?;
                    }
                    known += 1;
                    e.eval(&args).map(|v| v / power_base)
                })
                .collect();
            // Where the channels are known and the expression never is, the expression is
            // at fault, not the recording's coverage: say so rather than "too few samples".
            if known > 0 && values.iter().all(|v| v.is_none()) {
                return Err(SignalError::ExpressionNeverFinite {
                    input: i.name.clone(),
                    expression: e.text().to_owned(),
                    known,
                });
            }
            values
        }
        InputSource::Loss(h) => generator
            .ok_or(SignalError::NameplateNeeded)?
            .heat_source(*h)
            .clone(),
        // θ_in(k) − θ_in,0 in the states' scaling: the reference node's drift.
        InputSource::BoundaryRise(c) => {
            let at = level(c)?;
            reconstructed(
                series(c)?,
                declared_deadband(decimated, c),
                decimated.ts_s(),
            )
            .iter()
            .map(|v| v.map(|v| (v - at) / scale.temperature_base_k))
            .collect()
        }
        InputSource::CoolantFlow {
            flow,
            outlet,
            inlet,
        } => coolant_flow_heat(
            [series(flow)?, series(outlet)?, series(inlet)?],
            level(flow)?,
            level(inlet)?,
            power_base,
            decimated.ts_s(),
        )?,
    };
    let values = if i.from_initial {
        if origin.is_none() {
            *origin = values.iter().flatten().next();
        }
        let first = origin.unwrap_or(0.0);
        values.iter().map(|v| v.map(|v| v - first)).collect()
    } else {
        values
    };
    Ok(InputSignal {
        name: i.name.clone(),
        unit: i.unit.clone(),
        kind: i.kind,
        values,
        outlet_feedback: None,
        gaps: InputGaps::none(bridge_of(i)),
    })
}

/// How an input's short gaps are bridged: a slow quantity (the coolant inlet's rise, the
/// heat a flow change carries) along the straight line between its neighbours, every
/// other input held, as the model holds it between samples.
fn bridge_of(input: &InputDescription) -> Bridge {
    match (&input.source, input.kind) {
        (InputSource::BoundaryRise(_) | InputSource::CoolantFlow { .. }, _)
        | (_, InputKind::Boundary) => Bridge::Interpolate,
        _ => Bridge::Hold,
    }
}

/// The half-width of the local quadratic through which the coolant inlet's temperature
/// enters the model (as the reference the rises are measured from, or the boundary input
/// of its drift), s. The inlet is a slow quantity (river or reservoir water, a ramp and a
/// daily swing), so what the model needs is its course, not its samples: a PT100's noise
/// taken as an input is an error in the variables that biases the fastest time constant
/// (1-4 % on an RC unit whose inlet drifts 1 K over a 5.8 h run), and a historian's
/// staircase of values stored by exception is not the signal either. A quadratic over
/// ±60 s takes white noise down to √(2.25/121) ≈ 0.14 of itself and reconstructs a value
/// stored within a deadband along its course, while following any change of the inlet
/// slower than a few minutes.
pub const INLET_SMOOTHING_S: f64 = 60.0;

/// A channel whose runs of identical values are this long on average (in instants) is
/// taken for a value held between stored ones (a historian's export of a value stored by
/// exception, each row repeating the last kept value). A sampled PT100 at 0.01 K
/// resolution under 0.05 K of noise repeats a value for about 1.1 instants on average.
const HELD_RUN_INSTANTS: f64 = 5.0;

/// The fewest changes of a held channel from which its usual change is judged.
const MIN_CHANGES: usize = 4;

/// A channel as the model takes it: the coolant inlet's temperature reconstructed along
/// its course ([`inlet_course`]), the flow through its changes, every other channel as
/// decimated. `declared_deadband`: the channel's, where it declares storage by exception.
fn reconstructed(series: &DecimatedSeries, declared_deadband: Option<f64>, ts_s: f64) -> Series {
    match series.signal {
        Signal::Profile(Quantity::CoolingWaterInletTemp) => {
            inlet_course(series, declared_deadband, ts_s)
        }
        // The flow steps where a pump switches: taken through its changes, not smoothed.
        Signal::Profile(Quantity::CoolingWaterFlow) => {
            let mut values: Vec<Option<f64>> = series.values.iter().collect();
            if series.observed.is_none() {
                through_changes(&mut values);
            }
            values.into_iter().collect()
        }
        _ => series.values.clone(),
    }
}

/// The coolant inlet's course on the grid. Stored by exception — declared (the
/// channel's deadband; its stored instants from the grid), or a value held between
/// changes on every row ([`HELD_RUN_INSTANTS`]; its changes are the stored values, the
/// band their usual size) — the smoothest course within the band of each stored value
/// until the next ([`deadband::course`]): the stored points are where the value crossed
/// the band, not a sample of it. Sampled: a local quadratic over ±[`INLET_SMOOTHING_S`].
fn inlet_course(series: &DecimatedSeries, declared_deadband: Option<f64>, ts_s: f64) -> Series {
    let record = match (&series.observed, declared_deadband) {
        (Some(stored), Some(deadband)) => Some((stored.clone(), deadband)),
        (None, _) => held_between_changes(&series.values),
        (Some(_), None) => None,
    };
    if let Some((stored, deadband)) = record {
        let record = deadband::ExceptionRecord {
            values: &series.values,
            stored: &stored,
            deadband,
        };
        // Lengths agree and a declared deadband is checked by the reader: no error here.
        if let Ok(course) = deadband::course(record, ts_s) {
            return course;
        }
    }
    let values: Vec<Option<f64>> = series.values.iter().collect();
    let half = (INLET_SMOOTHING_S / ts_s).round() as usize;
    local_quadratic(&values, half).into_iter().collect()
}

/// Where `values` hold each value for [`HELD_RUN_INSTANTS`] or more on average with at
/// least [`MIN_CHANGES`] changes (a value stored by exception, exported on every row):
/// the instants it changed at (each the first of its run, a stored value) and the
/// deadband its changes show ([`deadband::estimated_deadband`]).
fn held_between_changes(values: &Series) -> Option<(Vec<bool>, f64)> {
    let changed: Vec<bool> = (0..values.len())
        .map(|k| values.get(k).is_some() && (k == 0 || values.get(k - 1) != values.get(k)))
        .collect();
    let changes = changed.iter().filter(|c| **c).count();
    let known = values.iter().flatten().count();
    if changes == 0 || (known as f64) < HELD_RUN_INSTANTS * changes as f64 {
        return None;
    }
    Some((changed, deadband::estimated_deadband(values, MIN_CHANGES)?))
}

/// Where `values` hold each value for [`HELD_RUN_INSTANTS`] or more on average, the value
/// between the instants it changed at, linearly: a value stored by exception is exact
/// where it was kept (the first instant of each run) and the signal moved on from there,
/// so the staircase of held values lags its course by up to the deadband. A change far
/// larger than the usual one (over twice the median: a step, a pump switched) happened
/// at its own instant and is not spread back over the run before it. Unknown instants
/// stay unknown; the last run is held.
fn through_changes(values: &mut [Option<f64>]) {
    let changes: Vec<usize> = (0..values.len())
        .filter(|&k| values[k].is_some() && (k == 0 || values[k - 1] != values[k]))
        .collect();
    let known = values.iter().flatten().count();
    if changes.is_empty() || (known as f64) < HELD_RUN_INSTANTS * changes.len() as f64 {
        return;
    }
    let mut jumps: Vec<f64> = changes
        .windows(2)
        .filter_map(|p| Some((values[p[1]]? - values[p[0]]?).abs()))
        .collect();
    // A few changes say nothing of a usual one (a constant flow and one pump switch).
    if jumps.len() < MIN_CHANGES {
        return;
    }
    jumps.sort_by(f64::total_cmp);
    let usual = jumps[jumps.len() / 2];
    for pair in changes.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        let (Some(va), Some(vb)) = (values[a], values[b]) else {
            continue;
        };
        // Only across a run of held values (not across a gap), and not a step.
        if values[a..b].iter().any(Option::is_none) || (vb - va).abs() > 2.0 * usual {
            continue;
        }
        for (i, v) in values.iter_mut().enumerate().take(b).skip(a + 1) {
            *v = Some(va + (vb - va) * (i - a) as f64 / (b - a) as f64);
        }
    }
}

/// The half-width of the local quadratic through which the outlet's rise above the inlet
/// enters the flow's heat, s: it takes the PT100 noise of the rise down about fivefold
/// (the centre weight of a 61-point quadratic fit is 0.037), while a quadratic follows the
/// cooler's 70 s transient without the lag or bias of a moving average.
pub const FLOW_RISE_SMOOTHING_S: f64 = 30.0;

/// The heat a flow away from its initial level Q₀ carries out of the outlet node, in the
/// inputs' scaling: −c·ρ·(Q(k) − Q₀)·Δθ(k) / P_base, c·ρ of water at the inlet's initial
/// level `inlet_c` (IF97; the flow is metered there), Δθ the outlet's rise above the
/// inlet, θ_out − θ_in, fitted by a local quadratic over ±[`FLOW_RISE_SMOOTHING_S`].
/// The measured rise carries the sensors' noise into the input, and with it into the
/// equation error of the next instant's output: smoothed, the input is known to within
/// its own small error (`spec::coolant::flow_input` says why the measured rise is used).
/// `[flow, outlet, inlet]` are the three channels on the grid.
fn coolant_flow_heat(
    [flow, outlet, inlet]: [&DecimatedSeries; 3],
    flow_0: f64,
    inlet_c: f64,
    power_base: f64,
    ts_s: f64,
) -> Result<Series> {
    let c_rho = Water::at(inlet_c)?.heat_per_litre_j_per_k();
    let flow = &reconstructed(flow, None, ts_s);
    let rise: Vec<Option<f64>> = (0..flow.len())
        .map(|k| Some(outlet.values.get(k)? - inlet.values.get(k)?))
        .collect();
    let half = (FLOW_RISE_SMOOTHING_S / ts_s).round() as usize;
    let smooth = local_quadratic(&rise, half);
    Ok((0..flow.len())
        .map(|k| Some(-c_rho * (flow.get(k)? - flow_0) * smooth[k]? / power_base))
        .collect())
}

/// The value at each instant of the least-squares quadratic in time through the known
/// values within `half` instants either side (a Savitzky–Golay filter that tolerates
/// gaps); the value itself where fewer than four are known.
pub(crate) fn local_quadratic(values: &[Option<f64>], half: usize) -> Vec<Option<f64>> {
    (0..values.len())
        .map(|k| {
            values[k]?;
            let lo = k.saturating_sub(half);
            let hi = (k + half).min(values.len() - 1);
            // Normal equations of y = a + b·t + c·t² with t = j − k.
            let mut m = nalgebra::Matrix3::<f64>::zeros();
            let mut r = nalgebra::Vector3::<f64>::zeros();
            let mut count = 0;
            for (j, v) in values.iter().enumerate().take(hi + 1).skip(lo) {
                let Some(v) = v else { continue };
                let t = j as f64 - k as f64;
                let phi = nalgebra::Vector3::new(1.0, t, t * t);
                m += phi * phi.transpose();
                r += phi * *v;
                count += 1;
            }
            if count < 4 {
                return values[k];
            }
            m.lu().solve(&r).map(|c| c[0]).or(values[k])
        })
        .collect()
}

/// Shifts each delayed input by its delay in samples of `ts_s`, and each advanced one
/// that many instants earlier (the signal stage's one call): `inputs` and `descriptions`
/// are in model order. Refuses a shift that is not a whole number of samples (or an
/// advance beyond [`delay::MAX_ADVANCE_SAMPLES`]).
fn delay_inputs(
    descriptions: &[InputDescription],
    ts_s: f64,
    inputs: &mut [InputSignal],
) -> Result<(), delay::DelayError> {
    for (signal, description) in inputs.iter_mut().zip(descriptions) {
        if description.delay_s == 0.0 {
            continue;
        }
        let d =
            delay::shift_samples(description.delay_s, ts_s).ok_or_else(|| delay::DelayError {
                input: description.name.clone(),
                delay_s: description.delay_s,
                ts_s,
            })?;
        signal.values = match usize::try_from(d) {
            Ok(later) => delay::shift(&signal.values, later),
            Err(_) => delay::advance(&signal.values, d.unsigned_abs()),
        };
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A channel of `values` on a 1 s grid.
    fn decimated(signal: Signal, values: impl Iterator<Item = f64>) -> DecimatedSeries {
        DecimatedSeries {
            signal,
            unit: "degC".into(),
            values: values.map(Some).collect(),
            sensors: 1,
            observed: None,
        }
    }

    #[test]
    fn the_inlet_is_taken_along_its_course_and_other_channels_as_recorded() {
        // A 1 K ramp over 5 h with a PT100's noise (σ = 0.05 K, drawn from a fixed LCG
        // so the test is the same everywhere).
        let mut state: u64 = 7;
        let mut uniform = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let n = 18_000;
        let course = |k: usize| 10.0 + k as f64 / n as f64;
        let noise: Vec<f64> = (0..n)
            .map(|_| 0.05 * 12f64.sqrt() * (uniform() - 0.5))
            .collect();
        let noisy = |k: usize| course(k) + noise[k];
        let inlet = Signal::Profile(Quantity::CoolingWaterInletTemp);
        let taken = reconstructed(&decimated(inlet.clone(), (0..n).map(noisy)), None, 1.0);
        let rms = |f: &dyn Fn(usize) -> f64| {
            ((0..n).map(|k| f(k).powi(2)).sum::<f64>() / n as f64).sqrt()
        };
        let error = rms(&|k| taken.get(k).unwrap() - course(k));
        // White noise through a 121-point quadratic: √(2.25/121) ≈ 0.14 of itself.
        assert!(error < 0.2 * 0.05, "{error}");
        // Stored by exception with a 0.05 K deadband and exported as every second's last
        // kept value (a staircase lagging the course by up to 0.05 K): taken through the
        // instants it changed at, it comes back well within the deadband.
        let mut kept = course(0);
        let held: Vec<f64> = (0..n)
            .map(|k| {
                if (course(k) - kept).abs() > 0.05 {
                    kept = course(k);
                }
                kept
            })
            .collect();
        let staircase = rms(&|k| held[k] - course(k));
        let taken = reconstructed(&decimated(inlet, held.iter().copied()), None, 1.0);
        // Up to the last change (after it, the last kept value is all there is: held).
        let last_change = (1..n).rev().find(|&k| held[k] != held[k - 1]).unwrap();
        let before = (0..last_change)
            .map(|k| (taken.get(k).unwrap() - course(k)).abs())
            .fold(0.0, f64::max);
        let after = (last_change..n)
            .map(|k| (taken.get(k).unwrap() - course(k)).abs())
            .fold(0.0, f64::max);
        assert!(
            staircase > 0.02 && before < 0.002 && after <= 0.05,
            "{staircase} {before} {after}"
        );
        // A flow held between changes: a slow drift taken through its changes, a pump's
        // step kept at its own instant (not spread back over the run before it).
        let flow_course =
            |k: usize| 48.0 + 0.5 * k as f64 / n as f64 - if k >= 9000 { 10.0 } else { 0.0 };
        let mut kept = flow_course(0);
        let held: Vec<f64> = (0..n)
            .map(|k| {
                if (flow_course(k) - kept).abs() > 0.05 {
                    kept = flow_course(k);
                }
                kept
            })
            .collect();
        let flow = Signal::Profile(Quantity::CoolingWaterFlow);
        let taken = reconstructed(&decimated(flow, held.iter().copied()), None, 1.0);
        assert!((taken.get(8999).unwrap() - flow_course(8999)).abs() <= 0.05 + 1e-9);
        assert_eq!(taken.get(9000), Some(held[9000]));
        // Between the drift's changes (every 1,800 s) up to the last one before the step;
        // after that one the value is held until the step, within the deadband.
        let worst = (100..7200)
            .map(|k| (taken.get(k).unwrap() - flow_course(k)).abs())
            .fold(0.0, f64::max);
        assert!(worst < 0.002, "{worst}");
        // Any other channel is the model's as recorded.
        let stator = Signal::Profile(Quantity::StatorWindingTemp);
        let as_recorded = reconstructed(&decimated(stator, (0..n).map(noisy)), None, 1.0);
        assert!((0..n).all(|k| as_recorded.get(k) == Some(noisy(k))));
    }

    /// One node at rise x above the coolant: dx/dt = −a·x + b_h·u_h + b_q·u_Q, with the
    /// flow's heat u_Q = κ·x. At rest x = b_h·u_h/(a − b_q·κ), u_Q = κ·x (by hand).
    #[test]
    fn the_flow_input_of_the_steady_state_is_consistent_with_it() {
        let (a, b_h, b_q, u_h, kappa) = (0.01, 0.02, 0.015, 0.3, 0.2);
        let len = 5;
        let known = |v: f64| -> Series { (0..len).map(|_| Some(v)).collect() };
        let input = |name: &str, values: Series, feedback| InputSignal {
            name: name.into(),
            unit: "pu".into(),
            kind: InputKind::Heat,
            values,
            outlet_feedback: feedback,
            gaps: InputGaps::none(Bridge::Hold),
        };
        let signals = ModelSignals {
            ts_s: 1.0,
            time_ns: (0..len as i64).collect(),
            states: vec![StateSignal {
                name: "cooling_water_outlet_temp".into(),
                part: "cooling water".into(),
                measured: known(20.0),
                reference: ReferenceValues::Constant(10.0),
                observed: None,
                exception: None,
            }],
            inputs: vec![
                input("heat", known(u_h), None),
                // Its last value from a rise short of the steady one.
                input(
                    "cooling_water_flow_heat",
                    known(kappa * 0.1),
                    Some(OutletFeedback {
                        outlet_state: 0,
                        inlet_input: None,
                        per_rise: known(kappa),
                        reference_flow_l_per_s: 48.0,
                    }),
                ),
            ],
            initial_index: 0,
            temperature_base_k: 100.0,
            power_base: 1.0,
            field_temperature: None,
        };
        let a_c = DMatrix::from_element(1, 1, -a);
        let b_c = DMatrix::from_row_slice(1, 2, &[b_h, b_q]);
        let u = signals.steady_state_input(&a_c, &b_c).unwrap();
        let x = b_h * u_h / (a - b_q * kappa);
        assert_eq!(u[0], u_h);
        assert!((u[1] - kappa * x).abs() < 1e-15, "{u:?} vs {}", kappa * x);
        // Without the feedback the last input stands.
        let mut plain = signals.clone();
        plain.inputs[1].outlet_feedback = None;
        assert_eq!(
            plain.steady_state_input(&a_c, &b_c).unwrap()[1],
            kappa * 0.1
        );
        // An output offset d = 0.02 pu moves the reference by d·θ_base = 2 K: the rise
        // (20 − 10 = 10 K) becomes 8 K, 0.08 pu, and the data follow.
        let mut shifted = signals.clone();
        shifted.shift_references(&[0.02]);
        assert_eq!(shifted.initial_references(), vec![12.0]);
        assert!((shifted.rise_pu(0, 3).unwrap() - 0.08).abs() < 1e-15);
        let mut data = signals.identification_data();
        data.shift_outputs(&[0.02]);
        let moved = shifted.identification_data().outputs;
        assert!((data.outputs - moved).amax() < 1e-15);
    }
}
