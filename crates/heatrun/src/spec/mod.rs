//! The model description: which channels are the thermal model's states, how its inputs
//! are computed, and how each channel is placed on the grid.
//!
//! Every stage after the recording reads this one description instead of knowing the
//! hydro generator: the decimator takes its [`ModelDescription::alignments`], the signal
//! stage ([`crate::signals`]) computes the states and inputs it names, and the report,
//! the summary and rerun name states and inputs as it does. The generator of the profile
//! is one description ([`ModelDescription::generator`]: three rises, the loss model's
//! three heat sources); a TOML spec ([`ModelDescription::from_toml_file`]) describes any
//! other thermal system of n states and m inputs.

pub mod coolant;
pub mod delay;
pub mod expression;
pub mod hidden;

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use serde::{Deserialize, Serialize};

pub use expression::InputExpression;

use crate::losses::HeatSource;
use crate::recording::{Alignment, Quantity, Signal};

/// What a state's value is measured from. In the report: `"initial"`, `"absolute"`,
/// `{"channel": name}` or `{"initial_of": name}`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Reference {
    /// The rise above the state's own first known value (the paper's formulation).
    Initial,
    /// The value itself.
    Absolute,
    /// The rise above another channel at the same instant (an ambient or coolant inlet).
    Channel(Signal),
    /// The rise above another channel's initial level, a constant (the mean of its first
    /// [`coolant::INITIAL_LEVEL_S`] seconds): the coolant inlet at the start, the thermal
    /// network's reference node. Its changes from there enter as an input
    /// ([`InputSource::BoundaryRise`]), and a start away from it is the model's free
    /// response from an estimated initial state.
    InitialOf(Signal),
}

/// One state of the model: a temperature channel, as a rise above its reference.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StateDescription {
    /// The state's name (report, summary, rerun entity).
    pub name: String,
    /// The channel that measures it.
    pub channel: Signal,
    /// What the rise is measured from.
    pub reference: Reference,
    /// The physical part it stands for, for people ("stator winding (copper)").
    pub part: String,
    /// Unit of the measured value (°C for temperatures). Optional in the report's schema:
    /// absent, °C, as in a spec.
    #[serde(default = "degrees_celsius")]
    pub unit: String,
}

/// A state's unit where the spec or the report names none.
fn degrees_celsius() -> String {
    "degC".into()
}

/// Whether an input is a heat source (the network is defined) or another exogenous input.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum InputKind {
    /// A heat flow into the system (W, or pu of a power base).
    #[default]
    Heat,
    /// Not heat (a fan speed, a flow): the model is identified, but no thermal network.
    Exogenous,
    /// The temperature of the network's reference node (the coolant inlet): not heat,
    /// but its column is the conductances to the reference (C⁻¹g₀), so the network is
    /// drawn from the heat inputs' columns.
    Boundary,
}

/// How an input's value at an instant is computed. In the report: `{"channel": name}`,
/// `{"expression": text}`, `{"loss": heat source}`, `{"boundary_rise": name}` or
/// `{"coolant_flow": {"flow", "outlet", "inlet"}}`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InputSource {
    /// A channel's value as recorded.
    Channel(Signal),
    /// An arithmetic expression of channels and constants (boxed: a parsed expression is
    /// large beside a channel name).
    Expression(Box<InputExpression>),
    /// One of the profile's loss model's heat sources (the generator).
    Loss(HeatSource),
    /// A boundary temperature's rise above its initial level, the same constant the
    /// states are measured from ([`Reference::InitialOf`]): the coolant inlet's drift
    /// θ_in(k) − θ_in,0. For a network C·dθ/dt = −L·θ + g₀·θ_in + K·P its column of B_c
    /// is C⁻¹g₀ = −A_c·1.
    BoundaryRise(Signal),
    /// The heat a cooling-water flow away from its initial level Q₀ carries out of the
    /// outlet node: −c·ρ·(Q(k) − Q₀)·(θ_out(k) − θ_in(k)), c·ρ of water at the inlet's
    /// initial level (IF97). With it the outlet's conductance to the coolant c·ρ·Q(t) is
    /// that of Q₀ in A_c plus this known input, and A_c stays the machine's at Q₀
    /// ([`coolant`] says why the measured temperatures are used).
    CoolantFlow {
        /// The flow channel, l/s.
        flow: Signal,
        /// The coolant outlet temperature channel.
        outlet: Signal,
        /// The coolant inlet temperature channel.
        inlet: Signal,
    },
}

/// One input of the model (in the report, its shift as `delay_s` or `advance_s`). Read
/// back from a report, its shift is held to a spec's rules: a negative shift, both
/// shifts, or an advanced boundary input is no input a replay writes, and the report's
/// error.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(into = "InputReport", try_from = "InputReport")]
pub struct InputDescription {
    /// The input's name (report, summary, rerun entity).
    pub name: String,
    /// How it is computed.
    pub source: InputSource,
    /// Its unit, for people (`W`, `pu`).
    pub unit: String,
    /// Heat or another exogenous input.
    pub kind: InputKind,
    /// Whether the input is taken as its change from its first known value (a boundary
    /// temperature or a drive whose starting value is the equilibrium), or as it is.
    pub from_initial: bool,
    /// Its shift in s, a whole number of samples ([`delay`]): a dead time τ_d > 0 acts on
    /// the states as u(k − τ_d / Ts); a negative value is an advance of −delay_s (the
    /// spec's `advance_s`, one sample: u(k + 1), an interval's mean stamped at its end);
    /// 0 for none. The report writes `delay_s` or `advance_s`, never a negative delay.
    pub delay_s: f64,
}

/// An input as the report writes it: its shift as a dead time or an advance, never a
/// negative delay (the schema's `minimum: 0`). `unit`, `kind` and `from_initial` may be
/// absent when read (reports before `from_initial`, hand-written ones): no unit, heat,
/// taken as it is.
#[derive(Serialize, Deserialize)]
struct InputReport {
    name: String,
    source: InputSource,
    #[serde(default)]
    unit: String,
    #[serde(default)]
    kind: InputKind,
    #[serde(default)]
    from_initial: bool,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    delay_s: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    advance_s: Option<f64>,
}

impl From<InputDescription> for InputReport {
    fn from(i: InputDescription) -> InputReport {
        InputReport {
            name: i.name,
            source: i.source,
            unit: i.unit,
            kind: i.kind,
            from_initial: i.from_initial,
            delay_s: (i.delay_s > 0.0).then_some(i.delay_s),
            advance_s: (i.delay_s < 0.0).then_some(-i.delay_s),
        }
    }
}

impl TryFrom<InputReport> for InputDescription {
    type Error = SpecError;

    /// The report's two shifts back into one signed shift, refused as a spec refuses them.
    fn try_from(i: InputReport) -> Result<InputDescription, SpecError> {
        let delay_s = shift_s(
            &i.name,
            i.delay_s.unwrap_or(0.0),
            i.advance_s.unwrap_or(0.0),
            &i.source,
        )?;
        Ok(InputDescription {
            name: i.name,
            source: i.source,
            unit: i.unit,
            kind: i.kind,
            from_initial: i.from_initial,
            delay_s,
        })
    }
}

/// How the signals are scaled for estimation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Scaling {
    /// The profile's per-unit system: rises in pu of the nameplate's `temperature_base_k`,
    /// heat sources in pu of S_n (the paper's units).
    NameplatePerUnit,
    /// The values as recorded: rises in the channel's unit (K), inputs in theirs.
    AsRecorded,
}

/// The thermal system to identify: its states, its inputs and how they are scaled.
///
/// Serialised both ways in the report's form, its `model` block, so that a report read
/// back describes the model as the replay that wrote it did; a TOML spec has its own
/// form ([`ModelDescription::from_toml`]).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ModelDescription {
    /// Name for people ("hydro generator (heatrun-scada/1)").
    pub name: String,
    /// The states x, in model order.
    pub states: Vec<StateDescription>,
    /// The inputs u, in model order.
    pub inputs: Vec<InputDescription>,
    /// Scaling of states and inputs.
    pub scaling: Scaling,
    /// The model grid's sample time the spec asks for, s (`None`: the caller's).
    pub sample_time_s: Option<f64>,
    /// The estimation method the spec asks for (`None`: the caller's).
    pub method: Option<String>,
    /// Hidden states the spec declares (`[hidden]`): the states above are then the
    /// measured outputs y = C x + D u of a larger model (`crate::hidden`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hidden: Option<hidden::HiddenSpec>,
}

/// A spec file (`--spec FILE.toml`) that cannot be read or used; both are the input's
/// fault.
#[derive(Debug, thiserror::Error)]
pub enum SpecFileError {
    /// The file could not be opened or read.
    #[error("{path}: cannot read: {source}")]
    Read {
        /// The spec file.
        path: std::path::PathBuf,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// The spec is unusable.
    // Not `source`: the message already holds the spec's error, and a source would make
    // the CLI's `{:#}` print it twice.
    #[error("{path}: {problem}")]
    Bad {
        /// The spec file.
        path: std::path::PathBuf,
        /// What is wrong, naming the key, state or input.
        problem: SpecError,
    },
}

/// A spec file that cannot be used, with the key at fault.
#[derive(Debug, thiserror::Error)]
pub enum SpecError {
    /// The file is not TOML of the spec's form.
    #[error("{message}")]
    Syntax {
        /// The TOML parser's message (it names the line and key).
        message: String,
    },
    /// A state or input names no channel, or two things share a name.
    #[error("{what} `{name}`: {problem}")]
    Entry {
        /// `state` or `input`.
        what: &'static str,
        /// Its name.
        name: String,
        /// What is wrong.
        problem: String,
    },
    /// The spec has no states or no inputs.
    #[error("a spec needs at least one [[state]] and one [[input]]")]
    Empty,
}

impl ModelDescription {
    /// The hydro generator of the profile: the rises of stator winding, core and cooling
    /// water outlet above their initial values (pu of `temperature_base_k`), driven by the
    /// loss model's armature copper, field copper and iron losses (pu of S_n).
    pub fn generator() -> ModelDescription {
        let state = |q: Quantity, part: &str| StateDescription {
            name: q.name().into(),
            channel: Signal::Profile(q),
            reference: Reference::Initial,
            part: part.into(),
            unit: "degC".into(),
        };
        ModelDescription {
            name: "hydro generator (heatrun-scada/1)".into(),
            states: vec![
                state(Quantity::StatorWindingTemp, "stator winding (copper)"),
                state(Quantity::CoreTemp, "iron core"),
                state(Quantity::CoolingWaterOutletTemp, "cooling water (cooler)"),
            ],
            inputs: HeatSource::ALL
                .iter()
                .map(|&h| InputDescription {
                    name: h.name().into(),
                    source: InputSource::Loss(h),
                    unit: "pu".into(),
                    kind: InputKind::Heat,
                    from_initial: false,
                    delay_s: 0.0,
                })
                .collect(),
            scaling: Scaling::NameplatePerUnit,
            sample_time_s: None,
            method: None,
            hidden: None,
        }
    }

    /// The generator with the field winding as a fourth state (the paper's "further
    /// improvement"): the rise of `field_winding_temp` above its initial value, measured by
    /// that channel or, where the recording lacks it, by the resistance method U_f / I_f.
    pub fn generator_with_field_state() -> ModelDescription {
        let mut model = ModelDescription::generator();
        model.name = "hydro generator with field winding state (heatrun-scada/1)".into();
        model.states.push(StateDescription {
            name: Quantity::FieldWindingTemp.name().into(),
            channel: Signal::Profile(Quantity::FieldWindingTemp),
            reference: Reference::Initial,
            part: "field winding (rotor)".into(),
            unit: "degC".into(),
        });
        model
    }

    /// Reads a TOML spec (format: README, "Any thermal system").
    pub fn from_toml_file(path: &Path) -> Result<ModelDescription, SpecFileError> {
        let text = std::fs::read_to_string(path).map_err(|source| SpecFileError::Read {
            path: path.to_owned(),
            source,
        })?;
        ModelDescription::from_toml(&text).map_err(|problem| SpecFileError::Bad {
            path: path.to_owned(),
            problem,
        })
    }

    /// Parses a TOML spec.
    pub fn from_toml(text: &str) -> Result<ModelDescription, SpecError> {
        let file: SpecFile = toml::from_str(text).map_err(|e| SpecError::Syntax {
            message: crate::toml_message::located(text, &e),
        })?;
        file.into_description()
    }

    /// Number of states n.
    pub fn state_count(&self) -> usize {
        self.states.len()
    }

    /// Number of inputs m.
    pub fn input_count(&self) -> usize {
        self.inputs.len()
    }

    /// Whether every input is heat or the reference node's temperature, so that a thermal
    /// network can be drawn from the model.
    pub fn inputs_are_heat(&self) -> bool {
        self.inputs
            .iter()
            .all(|i| matches!(i.kind, InputKind::Heat | InputKind::Boundary))
    }

    /// Whether the signals need the machine's nameplate (the loss model, the pu bases).
    pub fn needs_nameplate(&self) -> bool {
        self.scaling == Scaling::NameplatePerUnit
            || self
                .inputs
                .iter()
                .any(|i| matches!(i.source, InputSource::Loss(_)))
    }

    /// How each channel the model reads is placed on the grid. The discrete model
    /// x(k) = Φ x(k−1) + Γ u(k−1) relates point values of the states at t_k to inputs
    /// held over [t_{k−1}, t_k): temperatures (states, their references, and the
    /// temperatures the loss model reads) are [`Alignment::Instant`]; everything else,
    /// the inputs' channels, [`Alignment::Interval`].
    pub fn alignments(&self) -> BTreeMap<Signal, Alignment> {
        let mut map = BTreeMap::new();
        for s in &self.states {
            map.insert(s.channel.clone(), Alignment::Instant);
            if let Reference::Channel(r) | Reference::InitialOf(r) = &s.reference {
                map.insert(r.clone(), Alignment::Instant);
            }
        }
        for i in &self.inputs {
            match &i.source {
                InputSource::Channel(c) | InputSource::BoundaryRise(c) => {
                    map.entry(c.clone()).or_insert(Alignment::Interval);
                }
                InputSource::CoolantFlow {
                    flow,
                    outlet,
                    inlet,
                } => {
                    map.entry(flow.clone()).or_insert(Alignment::Interval);
                    // Temperatures are point values, as the states are.
                    for t in [outlet, inlet] {
                        map.insert(t.clone(), Alignment::Instant);
                    }
                }
                InputSource::Expression(e) => {
                    for c in e.channels() {
                        map.entry(c.clone()).or_insert(Alignment::Interval);
                    }
                }
                InputSource::Loss(_) => {}
            }
        }
        if self
            .inputs
            .iter()
            .any(|i| matches!(i.source, InputSource::Loss(_)))
        {
            // The loss model's temperatures (resistance corrections) are point values too.
            for q in Quantity::ALL.into_iter().filter(|q| q.is_temperature()) {
                map.insert(Signal::Profile(q), Alignment::Instant);
            }
        }
        map
    }

    /// The channels the model reads that are not quantities of the profile: the reader
    /// is asked for them by name.
    pub fn free_channels(&self) -> BTreeSet<String> {
        self.alignments()
            .into_keys()
            .filter_map(|s| match s {
                Signal::Free(name) => Some(name),
                Signal::Profile(_) => None,
            })
            .collect()
    }
}

/// The TOML form of a spec.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SpecFile {
    name: Option<String>,
    sample_time_s: Option<f64>,
    method: Option<String>,
    #[serde(default, rename = "state")]
    states: Vec<StateFile>,
    #[serde(default, rename = "input")]
    inputs: Vec<InputFile>,
    hidden: Option<hidden::HiddenSpec>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct StateFile {
    name: String,
    channel: Option<String>,
    reference: Option<ReferenceFile>,
    part: Option<String>,
    unit: Option<String>,
}

/// A state's `reference` in TOML: a word or a channel's name, or a table naming the
/// channel whose initial level it is measured from (as the report writes it).
#[derive(Debug, Deserialize)]
#[serde(
    untagged,
    expecting = "a reference is \"initial\", \"none\", a channel's name, or { initial_of = \"channel\" }"
)]
enum ReferenceFile {
    Name(String),
    InitialOf(InitialOfFile),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct InitialOfFile {
    initial_of: String,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct InputFile {
    name: String,
    channel: Option<String>,
    expression: Option<String>,
    unit: Option<String>,
    #[serde(default)]
    kind: InputKind,
    reference: Option<String>,
    #[serde(default)]
    delay_s: f64,
    /// One sample for an input whose logger stamps an interval's mean at its end.
    #[serde(default)]
    advance_s: f64,
}

impl SpecFile {
    fn into_description(self) -> Result<ModelDescription, SpecError> {
        if self.states.is_empty() || self.inputs.is_empty() {
            return Err(SpecError::Empty);
        }
        if let Some(ts) = self.sample_time_s {
            if !(ts.is_finite() && ts > 0.0) {
                return Err(SpecError::Syntax {
                    message: format!("sample_time_s = {ts}: must be a positive number of seconds"),
                });
            }
        }
        let mut names = BTreeSet::new();
        let states = self
            .states
            .into_iter()
            .map(|s| {
                unique(&mut names, "state", &s.name)?;
                s.into_description()
            })
            .collect::<Result<Vec<_>, _>>()?;
        let mut names = BTreeSet::new();
        let inputs = self
            .inputs
            .into_iter()
            .map(|i| {
                unique(&mut names, "input", &i.name)?;
                i.into_description()
            })
            .collect::<Result<Vec<_>, _>>()?;
        if let Some(ts) = self.sample_time_s {
            // With the spec's own Ts, a delay off the grid is refused here already; with
            // the caller's, the signal stage refuses it.
            if let Some(i) = inputs
                .iter()
                .find(|i| delay::shift_samples(i.delay_s, ts).is_none())
            {
                let problem = if i.delay_s < 0.0 {
                    format!(
                        "advance_s = {} s is not one sample of sample_time_s = {ts} s",
                        -i.delay_s
                    )
                } else {
                    format!(
                        "delay_s = {} s is not a whole number of samples of sample_time_s = {ts} s",
                        i.delay_s
                    )
                };
                return Err(SpecError::Entry {
                    what: "input",
                    name: i.name.clone(),
                    problem,
                });
            }
        }
        if let Some(problem) = self.hidden.as_ref().and_then(hidden::HiddenSpec::problem) {
            return Err(SpecError::Syntax {
                message: format!("[hidden] {problem}"),
            });
        }
        Ok(ModelDescription {
            name: self.name.unwrap_or_else(|| "thermal system (spec)".into()),
            states,
            inputs,
            scaling: Scaling::AsRecorded,
            sample_time_s: self.sample_time_s,
            method: self.method,
            hidden: self.hidden,
        })
    }
}

fn unique(names: &mut BTreeSet<String>, what: &'static str, name: &str) -> Result<(), SpecError> {
    if name.trim().is_empty() || !names.insert(name.to_owned()) {
        return Err(SpecError::Entry {
            what,
            name: name.into(),
            problem: "names must be non-empty and unique".into(),
        });
    }
    Ok(())
}

impl StateFile {
    fn into_description(self) -> Result<StateDescription, SpecError> {
        let channel = self.channel.unwrap_or_else(|| self.name.clone());
        let (word, initial_of) = match &self.reference {
            None => (None, None),
            Some(ReferenceFile::Name(w)) => (Some(w.as_str()), None),
            Some(ReferenceFile::InitialOf(r)) => (None, Some(r.initial_of.as_str())),
        };
        if word.or(initial_of) == Some(channel.as_str()) {
            return Err(SpecError::Entry {
                what: "state",
                name: self.name,
                problem: "its reference is its own channel".into(),
            });
        }
        let reference = match (word, initial_of) {
            (_, Some(r)) => Reference::InitialOf(Signal::from_name(r)),
            (None | Some("initial"), None) => Reference::Initial,
            (Some("none"), None) => Reference::Absolute,
            (Some(other), None) => Reference::Channel(Signal::from_name(other)),
        };
        Ok(StateDescription {
            part: self.part.unwrap_or_else(|| self.name.clone()),
            unit: self.unit.unwrap_or_else(degrees_celsius),
            name: self.name,
            channel: Signal::from_name(&channel),
            reference,
        })
    }
}

impl InputFile {
    fn into_description(self) -> Result<InputDescription, SpecError> {
        let source = match (self.channel, self.expression) {
            (Some(c), None) => InputSource::Channel(Signal::from_name(&c)),
            (None, Some(e)) => InputSource::Expression(Box::new(
                InputExpression::parse(&e).map_err(|problem| SpecError::Entry {
                    what: "input",
                    name: self.name.clone(),
                    problem,
                })?,
            )),
            _ => {
                return Err(SpecError::Entry {
                    what: "input",
                    name: self.name,
                    problem: "give exactly one of `channel` or `expression`".into(),
                })
            }
        };
        // A boundary input is the reference node's temperature: its rise above its
        // initial level, the constant states with `{ initial_of = … }` are measured from.
        let source = match (self.kind, source) {
            (InputKind::Boundary, InputSource::Channel(c)) => InputSource::BoundaryRise(c),
            (InputKind::Boundary, InputSource::Expression(_)) => {
                return Err(SpecError::Entry {
                    what: "input",
                    name: self.name,
                    problem: "a boundary input is a temperature `channel`, not an expression"
                        .into(),
                })
            }
            (_, source) => source,
        };
        let from_initial = match self.reference.as_deref() {
            None | Some("none") => false,
            Some("initial") => true,
            Some(other) => {
                return Err(SpecError::Entry {
                    what: "input",
                    name: self.name,
                    problem: format!(
                        "reference = \"{other}\": an input's reference is \"initial\" or \"none\""
                    ),
                })
            }
        };
        let shift_s = shift_s(&self.name, self.delay_s, self.advance_s, &source)?;
        Ok(InputDescription {
            name: self.name,
            source,
            unit: self.unit.unwrap_or_else(|| "W".into()),
            kind: self.kind,
            from_initial,
            delay_s: shift_s,
        })
    }
}

/// An input's signed shift, s: its dead time, or minus its advance. An advance is refused
/// together with a dead time (they are opposite shifts) and on a boundary input (a
/// temperature is a point value at its instant, not an interval's mean).
fn shift_s(
    name: &str,
    delay_s: f64,
    advance_s: f64,
    source: &InputSource,
) -> Result<f64, SpecError> {
    let entry = |problem: String| SpecError::Entry {
        what: "input",
        name: name.to_owned(),
        problem,
    };
    for (key, value) in [("delay_s", delay_s), ("advance_s", advance_s)] {
        if !delay::is_valid_delay(value) {
            return Err(entry(format!(
                "{key} = {value}: a shift is a number of seconds ≥ 0"
            )));
        }
    }
    if advance_s == 0.0 {
        return Ok(delay_s);
    }
    if delay_s != 0.0 {
        return Err(entry(
            "give `delay_s` or `advance_s`, not both (they shift the input opposite ways)".into(),
        ));
    }
    if matches!(source, InputSource::BoundaryRise(_)) {
        return Err(entry(
            "a boundary input is a temperature at its instant: it cannot be advanced".into(),
        ));
    }
    Ok(-advance_s)
}

#[cfg(test)]
mod tests {
    use super::*;

    const TCLAB: &str = r#"
        name = "TCLab"
        sample_time_s = 1.0
        [[state]]
        name = "T1"
        [[state]]
        name = "T2"
        channel = "T2"
        reference = "ambient"
        [[input]]
        name = "heater_1"
        expression = "0.01 * Q1 * 3.0"
        [[input]]
        name = "fan"
        channel = "fan_speed"
        kind = "exogenous"
        reference = "initial"
    "#;

    #[test]
    fn a_spec_names_states_inputs_and_their_channels() {
        let d = ModelDescription::from_toml(TCLAB).unwrap();
        assert_eq!((d.state_count(), d.input_count()), (2, 2));
        assert_eq!(d.states[0].channel, Signal::Free("T1".into()));
        assert_eq!(
            d.states[1].reference,
            Reference::Channel(Signal::Free("ambient".into()))
        );
        assert!(!d.inputs_are_heat());
        assert!(d.inputs[1].from_initial && !d.inputs[0].from_initial);
        assert!(!d.needs_nameplate());
        let a = d.alignments();
        assert_eq!(a[&Signal::Free("T1".into())], Alignment::Instant);
        assert_eq!(a[&Signal::Free("ambient".into())], Alignment::Instant);
        assert_eq!(a[&Signal::Free("Q1".into())], Alignment::Interval);
        assert_eq!(a[&Signal::Free("fan_speed".into())], Alignment::Interval);
        let free: Vec<_> = d.free_channels().into_iter().collect();
        assert_eq!(free, ["Q1", "T1", "T2", "ambient", "fan_speed"]);
    }

    #[test]
    fn the_generator_is_three_rises_and_the_loss_model() {
        let d = ModelDescription::generator();
        let names: Vec<_> = d.states.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "stator_winding_temp",
                "core_temp",
                "cooling_water_outlet_temp"
            ]
        );
        assert!(d.needs_nameplate() && d.inputs_are_heat());
        let a = d.alignments();
        assert_eq!(
            a[&Signal::Profile(Quantity::FieldWindingTemp)],
            Alignment::Instant
        );
        assert!(!a.contains_key(&Signal::Profile(Quantity::ArmatureCurrent)));
        assert!(d.free_channels().is_empty());
    }

    #[test]
    fn bad_specs_name_the_entry() {
        let bad = |t: &str| ModelDescription::from_toml(t).unwrap_err().to_string();
        assert!(bad("[[state]]\nname = \"a\"").contains("at least one"));
        let both = "[[state]]\nname=\"a\"\n[[input]]\nname=\"p\"\nchannel=\"x\"\nexpression=\"x\"";
        assert!(bad(both).contains("input `p`"), "{}", bad(both));
        let dup =
            "[[state]]\nname=\"a\"\n[[state]]\nname=\"a\"\n[[input]]\nname=\"p\"\nchannel=\"x\"";
        assert!(bad(dup).contains("state `a`"));
        let unknown = "colour = 1\n[[state]]\nname=\"a\"\n[[input]]\nname=\"p\"\nchannel=\"x\"";
        assert!(bad(unknown).contains("colour"), "{}", bad(unknown));
        let late = "sample_time_s = 2.0\n[[state]]\nname=\"a\"\n[[input]]\nname=\"p\"\nchannel=\"x\"\ndelay_s = 3.0";
        assert!(
            bad(late).contains("input `p`: delay_s = 3"),
            "{}",
            bad(late)
        );
        let early = "[[state]]\nname=\"a\"\n[[input]]\nname=\"p\"\nchannel=\"x\"\ndelay_s = -1.0";
        assert!(
            bad(early).contains("input `p`: delay_s = -1"),
            "{}",
            bad(early)
        );
        let expr = "[[state]]\nname=\"a\"\n[[input]]\nname=\"p\"\nexpression=\"3 * (x\"";
        assert!(bad(expr).contains("input `p`"), "{}", bad(expr));
        let own = "[[state]]\nname=\"a\"\nreference={initial_of=\"a\"}\n[[input]]\nname=\"p\"\nchannel=\"x\"";
        assert!(bad(own).contains("its own channel"), "{}", bad(own));
        let table = "[[state]]\nname=\"a\"\nreference={initial=\"b\"}\n[[input]]\nname=\"p\"\nchannel=\"x\"";
        assert!(bad(table).contains("initial_of"), "{}", bad(table));
        let boundary =
            "[[state]]\nname=\"a\"\n[[input]]\nname=\"p\"\nexpression=\"x + 1\"\nkind=\"boundary\"";
        assert!(bad(boundary).contains("input `p`"), "{}", bad(boundary));
    }

    #[test]
    fn an_input_may_be_advanced_one_sample_and_the_report_says_so() {
        let spec = |extra: &str| {
            format!(
                "sample_time_s = 2.0\n[[state]]\nname=\"a\"\n\
                 [[input]]\nname=\"p\"\nchannel=\"x\"\n\
                 [[input]]\nname=\"p_late\"\nchannel=\"x\"\ndelay_s = 4.0\n\
                 [[input]]\nname=\"p_early\"\nchannel=\"x\"\n{extra}"
            )
        };
        // One channel in three inputs: at k + 1, k and k − 2 on the grid of 2 s.
        let d = ModelDescription::from_toml(&spec("advance_s = 2.0")).unwrap();
        let shifts: Vec<f64> = d.inputs.iter().map(|i| i.delay_s).collect();
        assert_eq!(shifts, [0.0, 4.0, -2.0]);
        let json = serde_json::to_value(&d.inputs).unwrap();
        assert_eq!(json[1]["delay_s"], 4.0);
        assert!(json[1].get("advance_s").is_none());
        assert_eq!(json[2]["advance_s"], 2.0);
        assert!(json[2].get("delay_s").is_none());
        assert!(json[0].get("delay_s").is_none() && json[0].get("advance_s").is_none());
        let bad = |extra: &str| {
            ModelDescription::from_toml(&spec(extra))
                .unwrap_err()
                .to_string()
        };
        assert_eq!(
            bad("advance_s = 4.0"),
            "input `p_early`: advance_s = 4 s is not one sample of sample_time_s = 2 s"
        );
        assert!(bad("advance_s = -2.0").contains("input `p_early`: advance_s = -2"));
        assert!(bad("advance_s = 2.0\ndelay_s = 2.0").contains("not both"));
        let boundary = "[[state]]\nname=\"a\"\nreference={initial_of=\"inlet\"}\n\
                        [[input]]\nname=\"inlet_rise\"\nchannel=\"inlet\"\nkind=\"boundary\"\nadvance_s = 1.0";
        let e = ModelDescription::from_toml(boundary)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("input `inlet_rise`") && e.contains("cannot be advanced"),
            "{e}"
        );
    }

    /// Every form of reference, source and shift serialises to the report's `model` block
    /// and reads back from it unchanged.
    #[test]
    fn the_description_is_the_reports_model_block_both_ways() {
        let text = "name = \"every form\"\nsample_time_s = 2.0\n\
                    [[state]]\nname=\"a\"\nreference={initial_of=\"inlet\"}\n\
                    [[state]]\nname=\"b\"\nchannel=\"core_temp\"\nreference=\"ambient\"\nunit=\"K\"\n\
                    [[state]]\nname=\"c\"\nreference=\"none\"\n\
                    [[input]]\nname=\"p\"\nchannel=\"x\"\ndelay_s = 4.0\n\
                    [[input]]\nname=\"q\"\nexpression=\"3 * x^2\"\nadvance_s = 2.0\n\
                    [[input]]\nname=\"fan\"\nchannel=\"fan\"\nkind=\"exogenous\"\nreference=\"initial\"\n\
                    [[input]]\nname=\"inlet_rise\"\nchannel=\"inlet\"\nkind=\"boundary\"";
        let mut d = ModelDescription::from_toml(text).unwrap();
        d.inputs.push(InputDescription {
            name: "flow".into(),
            source: InputSource::CoolantFlow {
                flow: Signal::Profile(Quantity::CoolingWaterFlow),
                outlet: Signal::Profile(Quantity::CoolingWaterOutletTemp),
                inlet: Signal::Profile(Quantity::CoolingWaterInletTemp),
            },
            unit: "pu".into(),
            kind: InputKind::Heat,
            from_initial: false,
            delay_s: 0.0,
        });
        for d in [d, ModelDescription::generator_with_field_state()] {
            let written = serde_json::to_value(&d).unwrap();
            let read: ModelDescription = serde_json::from_value(written.clone()).unwrap();
            assert_eq!(serde_json::to_value(&read).unwrap(), written);
            assert_eq!(read.states, d.states);
            let shifts =
                |d: &ModelDescription| d.inputs.iter().map(|i| i.delay_s).collect::<Vec<_>>();
            assert_eq!(shifts(&read), shifts(&d));
        }
        // The forms as the schema states them.
        let d = ModelDescription::from_toml(text).unwrap();
        let json = serde_json::to_value(&d).unwrap();
        assert_eq!(
            json["states"][0]["reference"],
            serde_json::json!({"initial_of": "inlet"})
        );
        assert_eq!(json["states"][2]["reference"], "absolute");
        assert_eq!(
            json["inputs"][1]["source"],
            serde_json::json!({"expression": "3 * x^2"})
        );
        assert_eq!(
            json["inputs"][3]["source"],
            serde_json::json!({"boundary_rise": "inlet"})
        );
        let generator = serde_json::to_value(ModelDescription::generator()).unwrap();
        assert_eq!(
            generator["inputs"][2]["source"],
            serde_json::json!({"loss": "iron_loss"})
        );
    }

    /// A report's input whose shift no spec allows is the report's error, named as a
    /// spec's would be; absent keys an older report lacks take their defaults.
    #[test]
    fn a_reports_input_is_held_to_a_specs_rules() {
        let input = |extra: &str| {
            serde_json::from_str::<InputDescription>(&format!(
                r#"{{"name": "p", "source": {{"channel": "x"}}{extra}}}"#
            ))
        };
        let read = input("").unwrap();
        assert_eq!(
            (read.kind, read.from_initial, read.delay_s),
            (InputKind::Heat, false, 0.0)
        );
        assert_eq!(input(r#", "advance_s": 1.0"#).unwrap().delay_s, -1.0);
        let bad = |extra: &str| input(extra).unwrap_err().to_string();
        assert!(bad(r#", "delay_s": -3.0"#).starts_with("input `p`: delay_s = -3"));
        assert!(bad(r#", "delay_s": 1.0, "advance_s": 1.0"#).contains("not both"));
        let state: StateDescription = serde_json::from_str(
            r#"{"name": "a", "channel": "core_temp", "reference": "initial", "part": "core"}"#,
        )
        .unwrap();
        assert_eq!(state.unit, "degC");
        assert_eq!(state.channel, Signal::Profile(Quantity::CoreTemp));
    }

    #[test]
    fn a_state_may_be_measured_from_a_channels_initial_level() {
        let text = "[[state]]\nname=\"a\"\nreference={initial_of=\"inlet\"}\n\
                    [[input]]\nname=\"p\"\nchannel=\"x\"\n\
                    [[input]]\nname=\"inlet_rise\"\nchannel=\"inlet\"\nkind=\"boundary\"";
        let d = ModelDescription::from_toml(text).unwrap();
        let inlet = Signal::Free("inlet".into());
        assert_eq!(d.states[0].reference, Reference::InitialOf(inlet.clone()));
        assert!(matches!(&d.inputs[1].source, InputSource::BoundaryRise(c) if *c == inlet));
        assert!(matches!(d.inputs[0].source, InputSource::Channel(_)));
        // The reference channel is a point value, as the state is.
        assert_eq!(d.alignments()[&inlet], Alignment::Instant);
        assert!(d.inputs_are_heat());
    }
}
