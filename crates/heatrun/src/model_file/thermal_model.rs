//! The report of `heatrun replay --report` read back as a model to use: Φ, Γ, the
//! states and inputs as the report's `model` block describes them (n states, m inputs),
//! the references the rises are measured from, the nameplate of the loss model, and the
//! model's own fit and validation error.

use std::path::{Path, PathBuf};

use nalgebra::{DMatrix, DVector};

use super::document::{EstimationEntry, Report};
use super::error::UseError;
use super::hidden::OutputMap;
use super::shape::matrix;
use crate::losses::{FieldTemperatureSource, HeatSource};
use crate::recording::{Nameplate, Quantity, Signal};
use crate::spec::{InputDescription, InputSource, Reference, Scaling, StateDescription};

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
    /// The states in model order, as the report's description has them.
    pub states: Vec<StateDescription>,
    /// The inputs in model order, as the report's description has them (none taken from
    /// its initial value: [`ThermalModel::from_report`] refuses those).
    pub inputs: Vec<InputDescription>,
    /// Each state's reference θ_ref,j at the start of the model's recording, °C: the
    /// state's own initial temperature ([`Reference::Initial`]), the reference channel's
    /// value then ([`Reference::Channel`], for a schedule that lacks the channel), or the
    /// channel's initial level ([`Reference::InitialOf`], the constant the rises are
    /// measured from).
    pub initial_reference_c: Vec<f64>,
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
    /// What the model knows of its own uncertainty, where the report carries it.
    pub uncertainty: ModelUncertainty,
    /// Where the model has hidden states (the report's `hidden` block is the replay's
    /// model): y = C x + D u, Φ and Γ then of its n states and `states` its p measured
    /// outputs. `None`: the measured-state model, y = x.
    pub output: Option<OutputMap>,
    /// Why the steady state the model was identified towards lies beyond its recording
    /// (the report's equilibrium warning: the final load held too short, a part still
    /// rising), where it does; `predict` and `rating` repeat it beside their results.
    pub steady_state_extrapolation: Option<String>,
}

/// The uncertainty a report carries beside its Φ and Γ: what `rating`, `predict` and
/// `monitor` propagate into their intervals and bands.
#[derive(Debug, Clone, Default)]
pub struct ModelUncertainty {
    /// C_Θ, the covariance of Θ = [Φ Γ] laid out row by row (n(n+m) square), in the
    /// model's units; for a model with hidden states, of θ_h = [Φ Γ; C D] row by row
    /// ((n + p)(n + m) square, the report's `hidden.parameter_covariance`); `None` where
    /// the report gives none.
    pub theta_covariance: Option<DMatrix<f64>>,
    /// The process noise a step adds to an open-loop prediction's state, Q = K Λ Kᵀ
    /// (n × n, model units), from the one-step predictor's gain K and innovations'
    /// variance Λ where the method estimated them (`pem`).
    pub process_noise: Option<DMatrix<f64>>,
    /// The RMS residual of the field winding's line from the stator winding's
    /// temperature, K, where the field winding is derived: the derived temperature's
    /// standard deviation.
    pub field_line_rms_k: Option<f64>,
    /// Where the field winding's line is the paper's scaling of the stator winding's rise
    /// to the nameplate's final field temperature F (no field channel: θ_f = θ_Cu0 +
    /// s·(θ_Cu − θ_Cu0), s = (F − θ_Cu0)/(θ_Cu,end − θ_Cu0)), its two samples
    /// [θ_Cu0, θ_Cu,end] and F, °C: each sample was read with the stator winding's noise,
    /// which moves the line (its residual is zero, so `field_line_rms_k` holds nothing).
    pub field_scaling_c: Option<FieldScaling>,
    /// The sensors' noise per state, K: √Λ_j · θ_base where the model has innovations
    /// (its process noise then apart), else the model's own RMSE (validation where the
    /// report has it, else the fit: the sensor noise plus what the model misses).
    pub sensor_noise_k: Vec<f64>,
}

/// The two samples of the paper's field scaling and the final field temperature, °C
/// ([`ModelUncertainty::field_scaling_c`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FieldScaling {
    /// θ_Cu0, the stator winding's temperature at the start.
    pub start_c: f64,
    /// θ_Cu,end, at the end of the model's heat run.
    pub end_c: f64,
    /// F, the nameplate's final field winding temperature.
    pub final_field_c: f64,
}

impl FieldScaling {
    /// The scaling of a report: θ_Cu0 = a/(1 − s) and θ_Cu,end = θ_Cu0 + (F − θ_Cu0)/s
    /// from its line θ_f = a + s·θ_Cu, where the line is the scaling
    /// (`ScaledArmatureRise`) and s ∉ {0, 1}.
    fn of(report: &Report) -> Option<FieldScaling> {
        let e = &report.estimation;
        let Some(FieldTemperatureSource::ScaledArmatureRise { final_temp_c, .. }) =
            &e.field_temperature
        else {
            return None;
        };
        let final_temp_c = *final_temp_c;
        let line = e.field_temperature_from_stator.as_ref()?;
        let s = line.slope;
        if !(s.is_finite() && s != 0.0 && s != 1.0) {
            return None;
        }
        let start_c = line.intercept_c / (1.0 - s);
        Some(FieldScaling {
            start_c,
            end_c: start_c + (final_temp_c - start_c) / s,
            final_field_c: final_temp_c,
        })
    }

    /// The line θ_f = a + s·θ_Cu of these samples: (a, s).
    pub fn line(&self) -> (f64, f64) {
        let s = (self.final_field_c - self.start_c) / (self.end_c - self.start_c);
        (self.start_c * (1.0 - s), s)
    }
}

impl ThermalModel {
    /// Reads a model report (`heatrun replay --report`).
    pub fn read(path: &Path) -> Result<ThermalModel, UseError> {
        ThermalModel::from_report(&Report::read(path)?, path)
    }

    /// The model a report describes; `path` names the report in messages. Refuses a
    /// report whose matrices and names disagree in size, and inputs a load schedule
    /// cannot give.
    pub fn from_report(report: &Report, path: &Path) -> Result<ThermalModel, UseError> {
        let (n, m) = (report.states.len(), report.inputs.len());
        let phi = matrix(&report.phi, (n, n), "phi", path, (n, m))?;
        let gamma = matrix(&report.gamma, (n, m), "gamma", path, (n, m))?;
        // A hidden-state model replaces the measured-state one (`n` stays the outputs').
        let hidden = match report.hidden.as_ref().filter(|h| h.replay_model) {
            Some(h) => Some(super::hidden::read(h, &report.states, m, path)?),
            None => None,
        };
        let (description, estimation) = (&report.model, &report.estimation);
        if description.states.len() != n || description.inputs.len() != m {
            return Err(UseError::Shape {
                path: path.to_owned(),
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
        let per_state = |v: &[f64], key: &'static str| {
            if v.len() == n {
                Ok(())
            } else {
                Err(UseError::Shape {
                    path: path.to_owned(),
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
        let initial_reference_c = match &estimation.initial_reference_c {
            Some(r) => {
                per_state(r, "estimation.initial_reference_c")?;
                r.clone()
            }
            // Reports before `initial_reference_c`: the paper's references are the initial
            // temperatures themselves.
            None => estimation.initial_temperature_c.clone(),
        };
        for input in &description.inputs {
            usable(input, path)?;
        }
        let error = match &report.validation {
            Some(v) => ModelError {
                source: format!("validation on {}", v.source),
                rmse_k: v.fit.rmse_k.clone(),
                max_abs_error_k: v.fit.max_abs_error_k.clone(),
            },
            None => ModelError {
                source: "fit on the estimation data".into(),
                rmse_k: report.fit.rmse_k.clone(),
                max_abs_error_k: report.fit.max_abs_error_k.clone(),
            },
        };
        per_state(&error.rmse_k, "fit.rmse_k")?;
        per_state(&error.max_abs_error_k, "fit.max_abs_error_k")?;
        let uncertainty = match &hidden {
            // The covariance of the hidden model's own θ_h = [Φ Γ; C D] where the report
            // carries it (no predictor of its states: no process noise).
            Some(h) => ModelUncertainty {
                theta_covariance: h.covariance.clone(),
                sensor_noise_k: error.rmse_k.clone(),
                field_line_rms_k: report
                    .estimation
                    .field_temperature_from_stator
                    .as_ref()
                    .map(|l| l.rms_residual_k),
                field_scaling_c: FieldScaling::of(report),
                ..ModelUncertainty::default()
            },
            None => model_uncertainty(report, path, &error.rmse_k)?,
        };
        let (phi, gamma, output) = match hidden {
            Some(h) => (h.phi, h.gamma, Some(h.output)),
            None => (phi, gamma, None),
        };
        let mut model = ThermalModel {
            path: path.to_owned(),
            name: description.name.clone(),
            ts_s: report.sample_time_s,
            phi,
            gamma,
            output,
            time_constants_s: report.time_constants_s.clone(),
            states: description.states.clone(),
            inputs: description.inputs.clone(),
            initial_reference_c,
            temperature_base_k: estimation.temperature_base_k,
            power_base_w: estimation.power_base_mva.map_or(1.0, |p| p * 1e6),
            per_unit: description.scaling == Scaling::NameplatePerUnit,
            nameplate: report.nameplate.clone(),
            initial_temperature_c: estimation.initial_temperature_c.clone(),
            coolant_inlet_temp_c: estimation.coolant_inlet_temp_c,
            field_temperature: FieldTemperatureUse::NotNeeded,
            error: error.clone(),
            uncertainty,
            steady_state_extrapolation: report
                .equilibrium
                .as_ref()
                .and_then(|e| e.why_extrapolation()),
        };
        model.field_temperature = field_temperature_use(&model, estimation)?;
        if !(model.ts_s > 0.0) {
            return Err(model.missing("sample_time_s", "the simulation needs (a positive number)"));
        }
        Ok(model)
    }

    /// The measured temperatures (the report's `states`): n for a measured-state model,
    /// the p outputs of one with hidden states.
    pub fn state_count(&self) -> usize {
        self.states.len()
    }

    /// The model's own states, n (measured and hidden): Φ's order.
    pub fn order(&self) -> usize {
        self.phi.nrows()
    }

    /// The measured outputs of state `x` at input `u`: y = C x + D u, or x itself for a
    /// measured-state model.
    pub fn outputs(&self, x: &DVector<f64>, u: &DVector<f64>) -> DVector<f64> {
        match &self.output {
            Some(o) => o.outputs(x, u),
            None => x.clone(),
        }
    }

    /// The state a start from measured outputs `y` (at input `u`) takes: y itself for a
    /// measured-state model, the least-norm x with C x + D u = y for one with hidden
    /// states ([`OutputMap::state_from_outputs`]).
    pub fn state_from_outputs(&self, y: &DVector<f64>, u: &DVector<f64>) -> DVector<f64> {
        match &self.output {
            Some(o) => o.state_from_outputs(y, u),
            None => y.clone(),
        }
    }

    /// The index of the state measured by `quantity`'s channel.
    pub fn state_of(&self, quantity: Quantity) -> Option<usize> {
        self.states
            .iter()
            .position(|s| s.channel == Signal::Profile(quantity))
    }

    /// Whether an input or a state reference reads the coolant inlet itself (the model
    /// then carries the coolant; no shift is added).
    pub fn uses_coolant_inlet(&self) -> bool {
        let inlet = &Signal::Profile(Quantity::CoolingWaterInletTemp);
        self.inputs.iter().any(|i| match &i.source {
            InputSource::Channel(c) | InputSource::BoundaryRise(c) => c == inlet,
            InputSource::Expression(e) => e.channels().contains(inlet),
            // Zero at the test's flow, which a prediction holds (the heat it carries is
            // then the model's own).
            InputSource::Loss(_) | InputSource::CoolantFlow { .. } => false,
        }) || self.states.iter().any(|s| match &s.reference {
            Reference::Channel(c) | Reference::InitialOf(c) => c == inlet,
            Reference::Initial | Reference::Absolute => false,
        })
    }

    /// The initial level of a boundary channel the states are measured from (their
    /// [`Reference::InitialOf`]), °C.
    pub fn initial_level_of(&self, channel: &Signal) -> Option<f64> {
        self.states
            .iter()
            .zip(&self.initial_reference_c)
            .find_map(|(s, level)| match &s.reference {
                Reference::InitialOf(c) if c == channel => Some(*level),
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

/// The covariance of Θ and the process noise K Λ Kᵀ a report carries, each checked for
/// its size (n(n+m) square; n × n and n).
fn model_uncertainty(
    report: &Report,
    path: &Path,
    rmse_k: &[f64],
) -> Result<ModelUncertainty, UseError> {
    let (n, m) = (report.states.len(), report.inputs.len());
    let p = n * (n + m);
    let theta_covariance = match &report.theta_covariance {
        Some(rows) => Some(matrix(rows, (p, p), "theta_covariance", path, (n, m))?),
        None => None,
    };
    let process_noise = match (&report.kalman_gain, &report.innovation_variance) {
        (Some(k), Some(lambda)) => {
            let k = matrix(k, (n, n), "kalman_gain", path, (n, m))?;
            if lambda.len() != n {
                return Err(UseError::Shape {
                    path: path.to_owned(),
                    key: "innovation_variance",
                    found: format!("{} values", lambda.len()),
                    expected: format!("{n}"),
                    states: n,
                    inputs: m,
                });
            }
            let lambda = DMatrix::from_diagonal(&nalgebra::DVector::from_column_slice(lambda));
            Some(&k * lambda * k.transpose())
        }
        _ => None,
    };
    Ok(ModelUncertainty {
        theta_covariance,
        process_noise,
        field_line_rms_k: report
            .estimation
            .field_temperature_from_stator
            .as_ref()
            .map(|l| l.rms_residual_k),
        field_scaling_c: FieldScaling::of(report),
        sensor_noise_k: match &report.innovation_variance {
            Some(lambda) if lambda.len() == n => lambda
                .iter()
                .map(|v| v.max(0.0).sqrt() * report.estimation.temperature_base_k)
                .collect(),
            _ => rmse_k.to_vec(),
        },
    })
}

/// Refuses an input a load schedule cannot give: one taken as its change from its value
/// at the start of the model's recording (that value is not in the report), and one read
/// ahead that the schedule does not hold (computed from the predicted temperatures).
fn usable(i: &InputDescription, path: &Path) -> Result<(), UseError> {
    let unsupported = |kind: String| UseError::Unsupported {
        path: path.to_owned(),
        what: "input",
        name: i.name.clone(),
        source_kind: kind,
    };
    if i.from_initial {
        return Err(unsupported(
            "taken from its value at the start of the model's recording".into(),
        ));
    }
    let advance_s = -i.delay_s;
    if advance_s > 0.0
        && !matches!(
            i.source,
            InputSource::Channel(_) | InputSource::Expression(_)
        )
    {
        // The source as the report writes it.
        let source = serde_json::to_string(&i.source).unwrap_or_default();
        return Err(unsupported(format!(
            "`{source}` advanced {advance_s} s (only a channel or an expression can be read ahead)"
        )));
    }
    Ok(())
}

fn field_temperature_use(
    model: &ThermalModel,
    estimation: &EstimationEntry,
) -> Result<FieldTemperatureUse, UseError> {
    let needs = model
        .inputs
        .iter()
        .any(|i| matches!(i.source, InputSource::Loss(HeatSource::FieldCopperLoss)));
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
    let scaled = match estimation.field_temperature {
        Some(FieldTemperatureSource::ScaledArmatureRise { scale, .. }) => Some(scale),
        _ => None,
    };
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

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    /// A report of the generator as an older heatrun wrote it: no references
    /// (`initial_reference_c`), no field line (`field_temperature_from_stator`, the
    /// paper's scale instead), no `from_initial`, and figures JSON could only write as
    /// null (an infinite SNR) or in a form of their own.
    fn older_report() -> serde_json::Value {
        let state = |name: &str, part: &str| {
            json!({"name": name, "channel": name, "reference": "initial", "part": part,
                   "unit": "degC"})
        };
        let input = |name: &str| json!({"name": name, "source": {"loss": name}, "unit": "pu", "kind": "heat"});
        json!({
            "profile": "heatrun-scada/1",
            "sample_time_s": 1.0,
            "method": "oe",
            "states": ["stator_winding_temp", "core_temp"],
            "inputs": ["armature_copper_loss", "field_copper_loss"],
            "phi": [[0.9, 0.05], [0.02, 0.95]],
            "gamma": [[0.1, 0.02], [0.01, 0.03]],
            "time_constants_s": [8.0, 25.0],
            "fit": {"snr_db": [null, null], "rmse_k": [0.1, 0.2],
                    "max_abs_error_k": [0.3, 0.6]},
            "network": {"a shape": "of its own"},
            "nameplate": null,
            "model": {
                "name": "two parts",
                "states": [state("stator_winding_temp", "stator winding"),
                           state("core_temp", "iron core")],
                "inputs": [input("armature_copper_loss"), input("field_copper_loss")],
                "scaling": "nameplate_per_unit"
            },
            "estimation": {
                "initial_temperature_c": [30.0, 28.0],
                "temperature_base_k": 80.0,
                "power_base_mva": 100.0,
                "condition_number": null,
                "field_temperature": {"method": "scaled_armature_rise", "scale": 1.5,
                                      "final_temp_c": 90.0}
            }
        })
    }

    fn read(report: &serde_json::Value) -> Result<ThermalModel, UseError> {
        let path = Path::new("model.json");
        ThermalModel::from_report(&Report::from_json(&report.to_string(), path)?, path)
    }

    #[test]
    fn an_older_report_is_read_with_the_references_and_field_line_it_implies() {
        let model = read(&older_report()).unwrap();
        // The references of a report before them: the initial temperatures.
        assert_eq!(model.initial_reference_c, [30.0, 28.0]);
        assert_eq!(model.states[1].reference, Reference::Initial);
        assert_eq!(model.state_of(Quantity::CoreTemp), Some(1));
        // θ_f = θ_Cu0 + s·(θ_Cu − θ_Cu0) = θ_Cu0·(1 − s) + s·θ_Cu, θ_Cu0 = 30 °C, s = 1.5.
        assert_eq!(
            model.field_temperature,
            FieldTemperatureUse::FromStator {
                intercept_c: -15.0,
                slope: 1.5
            }
        );
        assert!(model.per_unit && model.power_base_w == 1e8);
        assert_eq!(model.error.source, "fit on the estimation data");
        assert_eq!(model.error.rmse_k, [0.1, 0.2]);
        assert!(!model.uses_coolant_inlet());
    }

    #[test]
    fn the_version_comes_first_then_the_blocks_then_their_sizes() {
        let message = |edit: fn(&mut serde_json::Value)| {
            let mut report = older_report();
            edit(&mut report);
            read(&report).unwrap_err().to_string()
        };
        assert_eq!(
            message(|r| r["profile"] = "heatrun-scada/2".into()),
            "model.json: a report of profile `heatrun-scada/2`; this heatrun reads `heatrun-scada/1`"
        );
        assert_eq!(
            message(|r| r["profile"] = 2.into()),
            "model.json: not a heatrun model report: its `profile` is not the name of a heatrun \
             profile"
        );
        assert_eq!(
            message(|r| {
                r.as_object_mut().unwrap().remove("profile");
            }),
            "model.json: not a heatrun model report: no `profile` key"
        );
        assert_eq!(
            message(|r| r["model"] = serde_json::Value::Null),
            "model.json: the report has no `model`, which every use of the model needs"
        );
        assert_eq!(
            message(|r| {
                r.as_object_mut().unwrap().remove("estimation");
            }),
            "model.json: the report has no `estimation`, which every use of the model needs"
        );
        assert_eq!(
            message(|r| r["phi"][1] = json!([0.9])),
            "model.json: `phi` is 2 rows of [2, 1] entries; the model of 2 states and 2 inputs \
             needs 2 × 2"
        );
        assert_eq!(
            message(|r| r["estimation"]["initial_reference_c"] = json!([20.0])),
            "model.json: `estimation.initial_reference_c` is 1 values; the model of 2 states \
             and 2 inputs needs 2"
        );
        assert_eq!(
            message(|r| r["model"]["inputs"][0]["from_initial"] = true.into()),
            "model.json: input `armature_copper_loss` is taken from its value at the start of \
             the model's recording, which a load schedule cannot give"
        );
        assert_eq!(
            message(|r| r["model"]["inputs"][1]["advance_s"] = 1.0.into()),
            "model.json: input `field_copper_loss` is `{\"loss\":\"field_copper_loss\"}` \
             advanced 1 s (only a channel or an expression can be read ahead), which a load \
             schedule cannot give"
        );
        assert_eq!(
            message(|r| {
                r["estimation"]
                    .as_object_mut()
                    .unwrap()
                    .remove("field_temperature");
            }),
            "model.json: the report has no `estimation.field_temperature_from_stator`, which \
             the field copper loss needs for R_f when the field winding is not a state"
        );
        // A description this version cannot read names the key where serde stopped.
        let unknown = message(|r| r["model"]["inputs"][0]["source"] = json!({"fan": "x"}));
        assert!(
            unknown.starts_with("model.json: not a heatrun model report: unknown variant `fan`"),
            "{unknown}"
        );
    }

    /// A recording or any file that is not text, given for the report, is named as such
    /// in one line (it was "stream did not contain valid UTF-8").
    #[test]
    fn a_recording_or_a_binary_file_is_not_taken_for_a_report() {
        let dir = tempfile::tempdir().unwrap();
        let recording = dir.path().join("run.mcap");
        let mut bytes = mcap::MAGIC.to_vec();
        bytes.extend([0xff, 0x00, 0x10]);
        std::fs::write(&recording, &bytes).unwrap();
        let binary = dir.path().join("model.bin");
        std::fs::write(&binary, [0x7b, 0xff, 0xfe, 0x00]).unwrap();
        for (path, why) in [
            (&recording, "it is an MCAP recording, not the report of one"),
            (&binary, "it is not text (JSON)"),
        ] {
            let message = Report::read(path).unwrap_err().to_string();
            assert_eq!(
                message,
                format!("{}: not a heatrun model report: {why}", path.display())
            );
        }
    }
}
