//! The report of `heatrun replay --report` read back as a model to use: Φ, Γ, the
//! states and inputs by name (the report's `model` block: n states, m inputs), the
//! references the rises are measured from, the nameplate of the loss model, and the
//! model's own fit and validation error.

use std::path::{Path, PathBuf};

use nalgebra::DMatrix;
use serde::Deserialize;
use serde_json::Value;

use super::error::UseError;
use crate::losses::HeatSource;
use crate::recording::{Nameplate, Quantity};
use crate::spec::{InputExpression, InputKind};

/// What a state's rise is measured from.
#[derive(Debug, Clone, PartialEq)]
pub enum StateReference {
    /// The state's temperature at the start of the model's recording, °C.
    Initial(f64),
    /// Nothing: the state is the temperature itself.
    Absolute,
    /// Another channel at the same instant (a coolant inlet), by name; the value of the
    /// model's recording at its initial instant, °C, for when the schedule lacks it.
    Channel(String, f64),
    /// A channel's initial level in the model's recording, a constant (the coolant inlet
    /// at the start: the thermal network's reference node), by name, °C. Its drift from
    /// there is an input of the model ([`InputUse::BoundaryRise`]).
    InitialOf(String, f64),
}

/// One state of the model.
#[derive(Debug, Clone)]
pub struct ModelState {
    /// The state's name (`stator_winding_temp`).
    pub name: String,
    /// The channel that measures it.
    pub channel: String,
    /// The physical part, for people.
    pub part: String,
    /// What its rise is measured from.
    pub reference: StateReference,
}

/// How an input is computed from a load schedule.
#[derive(Debug, Clone)]
pub enum InputUse {
    /// One of the generator's loss model's heat sources.
    Loss(HeatSource),
    /// A channel's value, from the schedule's column of that name (the coolant inlet
    /// from `coolant_inlet_temp_c`).
    Channel(String),
    /// An expression of channels, each from the schedule's column of its name.
    Expression(Box<InputExpression>),
    /// A boundary channel's rise above its initial level in the model's recording (the
    /// coolant inlet's drift θ_in − θ_in,0), in the states' scaling; the level is the
    /// [`StateReference::InitialOf`] of the states.
    BoundaryRise(String),
    /// The heat a change of the cooling-water flow carries from the outlet node,
    /// u_Q = −c·ρ·(Q − Q₀)·(θ_out − θ_in), Q₀ the flow at the start of the model's test
    /// (`coolant_flow`): the model's A_c is the machine at Q₀.
    CoolantFlow {
        /// The flow channel, l/s.
        flow: String,
        /// The coolant outlet temperature channel.
        outlet: String,
        /// The coolant inlet temperature channel.
        inlet: String,
    },
}

/// One input of the model.
#[derive(Debug, Clone)]
pub struct ModelInput {
    /// The input's name.
    pub name: String,
    /// How it is computed.
    pub source: InputUse,
    /// Heat, the reference node's temperature, or another exogenous input.
    pub kind: InputKind,
    /// The input's shift, s (0: none): a dead time (> 0), the model is
    /// x(k+1) = Φ x(k) + Γ u(k − d), d = delay_s / Ts whole samples; or an advance
    /// (< 0, the report's `advance_s`): u(k + 1), the schedule read one sample ahead
    /// ([`super::simulate::DelayLine`]).
    pub delay_s: f64,
}

/// How the field winding temperature (for R_f in the field copper loss) is predicted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FieldTemperatureUse {
    /// A state of the model (index).
    State(usize),
    /// θ_f = intercept + slope · θ_Cu, fitted on the model's recording.
    FromStator {
        /// °C.
        intercept_c: f64,
        /// K per K.
        slope: f64,
    },
    /// The model has no field copper loss input.
    NotNeeded,
}

/// The model's error on data it was fitted to, and on data it was not (validation).
#[derive(Debug, Clone)]
pub struct ModelError {
    /// What the figures are from: `validation on …` or `fit on the estimation data`.
    pub source: String,
    /// RMSE per state, K.
    pub rmse_k: Vec<f64>,
    /// Largest absolute error per state, K.
    pub max_abs_error_k: Vec<f64>,
}

/// An identified model, as its report describes it.
#[derive(Debug, Clone)]
pub struct ThermalModel {
    /// The report it was read from.
    pub path: PathBuf,
    /// The system's name for people.
    pub name: String,
    /// Sample time Ts, s.
    pub ts_s: f64,
    /// Φ (n × n).
    pub phi: DMatrix<f64>,
    /// Γ (n × m).
    pub gamma: DMatrix<f64>,
    /// Time constants, ascending, s.
    pub time_constants_s: Vec<f64>,
    /// The states in model order.
    pub states: Vec<ModelState>,
    /// The inputs in model order.
    pub inputs: Vec<ModelInput>,
    /// Kelvin per unit of a state.
    pub temperature_base_k: f64,
    /// Watts (or the input's unit) per unit of a heat input.
    pub power_base_w: f64,
    /// Whether states and inputs are per unit of the nameplate's bases (the profile's
    /// scaling), not as recorded.
    pub per_unit: bool,
    /// The nameplate of the loss model, where the report has one.
    pub nameplate: Option<Nameplate>,
    /// Measured temperatures at the start of the model's recording, °C.
    pub initial_temperature_c: Vec<f64>,
    /// Mean coolant inlet temperature of the model's recording, °C, where recorded.
    pub coolant_inlet_temp_c: Option<f64>,
    /// How θ_f is predicted.
    pub field_temperature: FieldTemperatureUse,
    /// The model's own error (validation where the report has it, else the fit).
    pub error: ModelError,
}

/// The report's keys this module reads; others are ignored (later profiles may add more).
#[derive(Deserialize)]
struct ReportFile {
    profile: String,
    sample_time_s: f64,
    states: Vec<String>,
    inputs: Vec<String>,
    phi: Vec<Vec<f64>>,
    gamma: Vec<Vec<f64>>,
    time_constants_s: Vec<f64>,
    fit: FitFile,
    nameplate: Option<Nameplate>,
    model: Option<DescriptionFile>,
    estimation: Option<EstimationFile>,
    validation: Option<ValidationFile>,
}

#[derive(Deserialize)]
struct FitFile {
    rmse_k: Vec<f64>,
    max_abs_error_k: Vec<f64>,
}

#[derive(Deserialize)]
struct ValidationFile {
    source: String,
    fit: FitFile,
}

#[derive(Deserialize)]
struct DescriptionFile {
    name: String,
    scaling: Option<String>,
    states: Vec<StateFile>,
    inputs: Vec<InputFile>,
}

#[derive(Deserialize)]
struct StateFile {
    name: String,
    channel: String,
    reference: Value,
    part: String,
}

#[derive(Deserialize)]
struct InputFile {
    name: String,
    source: Value,
    #[serde(default)]
    from_initial: bool,
    #[serde(default)]
    kind: InputKind,
    /// The input's dead time, s (absent: none).
    #[serde(default)]
    delay_s: f64,
    /// The input's advance, s (absent: none).
    #[serde(default)]
    advance_s: f64,
}

#[derive(Deserialize)]
struct EstimationFile {
    initial_temperature_c: Vec<f64>,
    temperature_base_k: f64,
    power_base_mva: Option<f64>,
    initial_reference_c: Option<Vec<f64>>,
    coolant_inlet_temp_c: Option<f64>,
    field_temperature: Option<Value>,
    field_temperature_from_stator: Option<FieldLineFile>,
}

#[derive(Deserialize)]
struct FieldLineFile {
    intercept_c: f64,
    slope: f64,
}

impl ThermalModel {
    /// Reads a model report (`heatrun replay --report`).
    pub fn read(path: &Path) -> Result<ThermalModel, UseError> {
        let text = std::fs::read_to_string(path).map_err(|source| UseError::Read {
            path: path.to_owned(),
            source,
        })?;
        ThermalModel::from_json(&text, path)
    }

    /// Parses a model report's text; `path` names it in messages.
    pub fn from_json(text: &str, path: &Path) -> Result<ThermalModel, UseError> {
        let p = path.to_owned();
        // The profile first: a report of another version may not parse as this one.
        let value: Value = serde_json::from_str(text).map_err(|e| UseError::NotAReport {
            path: p.clone(),
            message: e.to_string(),
        })?;
        match value.get("profile").and_then(Value::as_str) {
            Some(crate::report::PROFILE) => {}
            Some(other) => {
                return Err(UseError::ProfileVersion {
                    path: p,
                    found: other.to_owned(),
                    expected: crate::report::PROFILE,
                })
            }
            None => {
                return Err(UseError::NotAReport {
                    path: p,
                    message: "no `profile` key".into(),
                })
            }
        }
        let file: ReportFile = serde_json::from_value(value).map_err(|e| UseError::NotAReport {
            path: p.clone(),
            message: e.to_string(),
        })?;
        debug_assert_eq!(file.profile, crate::report::PROFILE);
        build(file, p)
    }

    /// n.
    pub fn state_count(&self) -> usize {
        self.states.len()
    }

    /// The index of the state measured by `quantity`'s channel.
    pub fn state_of(&self, quantity: Quantity) -> Option<usize> {
        self.states
            .iter()
            .position(|s| s.channel == quantity.name())
    }

    /// Whether an input or a state reference reads the coolant inlet itself (the model
    /// then carries the coolant; no shift is added).
    pub fn uses_coolant_inlet(&self) -> bool {
        let inlet = Quantity::CoolingWaterInletTemp.name();
        self.inputs.iter().any(|i| match &i.source {
            InputUse::Channel(c) => c == inlet,
            InputUse::Expression(e) => e.channels().iter().any(|c| c.name() == inlet),
            InputUse::BoundaryRise(c) => c == inlet,
            // Zero at the test's flow, which a prediction holds (the heat it carries is
            // then the model's own).
            InputUse::Loss(_) | InputUse::CoolantFlow { .. } => false,
        }) || self.states.iter().any(|s| match &s.reference {
            StateReference::Channel(c, _) | StateReference::InitialOf(c, _) => c == inlet,
            _ => false,
        })
    }

    /// The initial level of a boundary channel the states are measured from (their
    /// [`StateReference::InitialOf`]), °C.
    pub fn initial_level_of(&self, channel: &str) -> Option<f64> {
        self.states.iter().find_map(|s| match &s.reference {
            StateReference::InitialOf(c, level) if c == channel => Some(*level),
            _ => None,
        })
    }

    /// The report needs `key` for `needed_for`.
    pub(crate) fn missing(&self, key: &str, needed_for: &str) -> UseError {
        UseError::MissingBlock {
            path: self.path.clone(),
            key: key.into(),
            needed_for: needed_for.into(),
        }
    }
}

fn matrix(
    rows: &[Vec<f64>],
    (nrows, ncols): (usize, usize),
    key: &'static str,
    path: &Path,
    (n, m): (usize, usize),
) -> Result<DMatrix<f64>, UseError> {
    if rows.len() != nrows || rows.iter().any(|r| r.len() != ncols) {
        return Err(UseError::Shape {
            path: path.to_owned(),
            key,
            found: format!(
                "{} rows of [{}] entries",
                rows.len(),
                rows.iter()
                    .map(|r| r.len().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            expected: format!("{nrows} × {ncols}"),
            states: n,
            inputs: m,
        });
    }
    Ok(DMatrix::from_fn(nrows, ncols, |i, j| rows[i][j]))
}

fn build(file: ReportFile, path: PathBuf) -> Result<ThermalModel, UseError> {
    let (n, m) = (file.states.len(), file.inputs.len());
    let phi = matrix(&file.phi, (n, n), "phi", &path, (n, m))?;
    let gamma = matrix(&file.gamma, (n, m), "gamma", &path, (n, m))?;
    let missing = |key: &str| UseError::MissingBlock {
        path: path.clone(),
        key: key.into(),
        needed_for: "every use of the model needs".into(),
    };
    let description = file.model.ok_or_else(|| missing("model"))?;
    let estimation = file.estimation.ok_or_else(|| missing("estimation"))?;
    if description.states.len() != n || description.inputs.len() != m {
        return Err(UseError::Shape {
            path: path.clone(),
            key: "model",
            found: format!(
                "{} states and {} inputs",
                description.states.len(),
                description.inputs.len()
            ),
            expected: format!("{n} and {m}"),
            states: n,
            inputs: m,
        });
    }
    let per_state = |v: &Vec<f64>, key: &'static str| {
        if v.len() == n {
            Ok(())
        } else {
            Err(UseError::Shape {
                path: path.clone(),
                key,
                found: format!("{} values", v.len()),
                expected: format!("{n}"),
                states: n,
                inputs: m,
            })
        }
    };
    per_state(
        &estimation.initial_temperature_c,
        "estimation.initial_temperature_c",
    )?;
    let initial_reference = match &estimation.initial_reference_c {
        Some(r) => {
            per_state(r, "estimation.initial_reference_c")?;
            r.clone()
        }
        // Reports before `initial_reference_c`: the paper's references are the initial
        // temperatures themselves.
        None => estimation.initial_temperature_c.clone(),
    };
    let states = description
        .states
        .into_iter()
        .zip(&initial_reference)
        .map(|(s, &r0)| state(s, r0, &path))
        .collect::<Result<Vec<_>, _>>()?;
    let inputs = description
        .inputs
        .into_iter()
        .map(|i| input(i, &path))
        .collect::<Result<Vec<_>, _>>()?;
    let error = match file.validation {
        Some(v) => ModelError {
            source: format!("validation on {}", v.source),
            rmse_k: v.fit.rmse_k,
            max_abs_error_k: v.fit.max_abs_error_k,
        },
        None => ModelError {
            source: "fit on the estimation data".into(),
            rmse_k: file.fit.rmse_k,
            max_abs_error_k: file.fit.max_abs_error_k,
        },
    };
    per_state(&error.rmse_k, "fit.rmse_k")?;
    per_state(&error.max_abs_error_k, "fit.max_abs_error_k")?;
    let mut model = ThermalModel {
        path,
        name: description.name,
        ts_s: file.sample_time_s,
        phi,
        gamma,
        time_constants_s: file.time_constants_s,
        states,
        inputs,
        temperature_base_k: estimation.temperature_base_k,
        power_base_w: estimation.power_base_mva.map_or(1.0, |p| p * 1e6),
        per_unit: description
            .scaling
            .as_deref()
            .map_or(estimation.power_base_mva.is_some(), |s| {
                s == "nameplate_per_unit"
            }),
        nameplate: file.nameplate,
        initial_temperature_c: estimation.initial_temperature_c.clone(),
        coolant_inlet_temp_c: estimation.coolant_inlet_temp_c,
        field_temperature: FieldTemperatureUse::NotNeeded,
        error,
    };
    model.field_temperature = field_temperature_use(&model, &estimation)?;
    if !(model.ts_s > 0.0) {
        return Err(model.missing("sample_time_s", "the simulation needs (a positive number)"));
    }
    Ok(model)
}

fn state(s: StateFile, initial_reference: f64, path: &Path) -> Result<ModelState, UseError> {
    let reference = match &s.reference {
        Value::String(r) if r == "initial" => StateReference::Initial(initial_reference),
        Value::String(r) if r == "absolute" => StateReference::Absolute,
        Value::Object(o) if o.len() == 1 && o.get("channel").is_some_and(Value::is_string) => {
            let channel = o["channel"].as_str().unwrap_or_default().to_owned();
            StateReference::Channel(channel, initial_reference)
        }
        Value::Object(o) if o.len() == 1 && o.get("initial_of").is_some_and(Value::is_string) => {
            let channel = o["initial_of"].as_str().unwrap_or_default().to_owned();
            StateReference::InitialOf(channel, initial_reference)
        }
        other => {
            return Err(UseError::Unsupported {
                path: path.to_owned(),
                what: "state reference of",
                name: s.name,
                source_kind: format!("`{other}`"),
            })
        }
    };
    Ok(ModelState {
        name: s.name,
        channel: s.channel,
        part: s.part,
        reference,
    })
}

fn input(i: InputFile, path: &Path) -> Result<ModelInput, UseError> {
    let unsupported = |kind: String| UseError::Unsupported {
        path: path.to_owned(),
        what: "input",
        name: i.name.clone(),
        source_kind: kind,
    };
    if i.from_initial {
        // Its offset (the first value of the model's recording) is not in the report.
        return Err(unsupported(
            "taken from its value at the start of the model's recording".into(),
        ));
    }
    if !crate::spec::delay::is_valid_delay(i.delay_s) {
        return Err(unsupported(format!("a dead time of {} s", i.delay_s)));
    }
    if !crate::spec::delay::is_valid_delay(i.advance_s) || (i.advance_s > 0.0 && i.delay_s > 0.0) {
        return Err(unsupported(format!(
            "an advance of {} s (with a dead time of {} s)",
            i.advance_s, i.delay_s
        )));
    }
    let (kind, value) = match &i.source {
        Value::Object(o) if o.len() == 1 => o.iter().next().map(|(k, v)| (k.as_str(), v)),
        _ => None,
    }
    .ok_or_else(|| unsupported(format!("`{}`", i.source)))?;
    let source = match (kind, value.as_str()) {
        ("loss", Some(name)) => HeatSource::ALL
            .into_iter()
            .find(|h| h.name() == name)
            .map(InputUse::Loss)
            .ok_or_else(|| unsupported(format!("the loss `{name}`")))?,
        ("channel", Some(name)) => InputUse::Channel(name.to_owned()),
        ("boundary_rise", Some(name)) => InputUse::BoundaryRise(name.to_owned()),
        ("expression", Some(text)) => {
            InputUse::Expression(Box::new(InputExpression::parse(text).map_err(unsupported)?))
        }
        ("coolant_flow", None) => {
            let name = |key: &str| value.get(key).and_then(Value::as_str).map(str::to_owned);
            match (name("flow"), name("outlet"), name("inlet")) {
                (Some(flow), Some(outlet), Some(inlet)) => InputUse::CoolantFlow {
                    flow,
                    outlet,
                    inlet,
                },
                _ => return Err(unsupported(format!("`{}`", i.source))),
            }
        }
        _ => return Err(unsupported(format!("`{}`", i.source))),
    };
    // An advanced input is read from the schedule one sample ahead; one computed from the
    // predicted temperatures (a loss, the inlet, a flow's heat) is not known there.
    if i.advance_s > 0.0 && !matches!(source, InputUse::Channel(_) | InputUse::Expression(_)) {
        return Err(unsupported(format!(
            "`{}` advanced {} s (only a channel or an expression can be read ahead)",
            i.source, i.advance_s
        )));
    }
    Ok(ModelInput {
        name: i.name,
        source,
        kind: i.kind,
        delay_s: if i.advance_s > 0.0 {
            -i.advance_s
        } else {
            i.delay_s
        },
    })
}

fn field_temperature_use(
    model: &ThermalModel,
    estimation: &EstimationFile,
) -> Result<FieldTemperatureUse, UseError> {
    let needs = model
        .inputs
        .iter()
        .any(|i| matches!(i.source, InputUse::Loss(HeatSource::FieldCopperLoss)));
    if !needs {
        return Ok(FieldTemperatureUse::NotNeeded);
    }
    if let Some(j) = model.state_of(Quantity::FieldWindingTemp) {
        return Ok(FieldTemperatureUse::State(j));
    }
    if let Some(line) = &estimation.field_temperature_from_stator {
        return Ok(FieldTemperatureUse::FromStator {
            intercept_c: line.intercept_c,
            slope: line.slope,
        });
    }
    // Reports before `field_temperature_from_stator`: the paper's scaling is such a line,
    // θ_f = θ_Cu0 + s·(θ_Cu − θ_Cu0).
    let scaled = estimation.field_temperature.as_ref().and_then(|f| {
        (f.get("method")?.as_str()? == "scaled_armature_rise").then(|| f.get("scale")?.as_f64())?
    });
    let stator = model.state_of(Quantity::StatorWindingTemp);
    match (scaled, stator) {
        (Some(s), Some(j)) => {
            let theta0 = model.initial_temperature_c[j];
            Ok(FieldTemperatureUse::FromStator {
                intercept_c: theta0 * (1.0 - s),
                slope: s,
            })
        }
        _ => Err(model.missing(
            "estimation.field_temperature_from_stator",
            "the field copper loss needs for R_f when the field winding is not a state",
        )),
    }
}
