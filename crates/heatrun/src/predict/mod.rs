//! Prediction: an identified model (the report of `heatrun replay --report`) and a load
//! schedule → every part's temperature on the model's sample time.
//!
//! Input: a [`ThermalModel`] ([`crate::model_file`], read from the report: n states and
//! m inputs by name) and a [`LoadSchedule`] ([`load`], a CSV). Output: a [`Prediction`]. The
//! inputs follow the profile's loss model with the resistances at the predicted
//! temperatures ([`simulate`]); an apparent-power schedule gets its field current from
//! the salient-pole phasor diagram ([`phasor`]). Each schedule row holds until the
//! next (as the model's inputs hold over a sample interval): x(k+1) = Φ x(k) + Γ u(k),
//! u(k) from the row in force at t_k and the temperatures at t_k. A model with hidden
//! states predicts its measured outputs y = C x + D u (the report's `states`); its
//! hidden states are simulated but not written (they are no part's temperature).

/// The steps of the model's sample time a prediction may span: it holds every step's
/// temperatures, inputs and the band's linearisation in memory, about 1.5 kB a step (a
/// schedule of 10⁶ s at 1 s peaked at 1.46 GB resident), so 2·10⁶ steps (23 days at 1 s)
/// need about 3 GB; a schedule of 10¹² s asked for 8 TB and aborted.
pub const MAX_PREDICTION_STEPS: usize = 2_000_000;

pub mod band;
pub mod load;
pub mod phasor;
pub mod simulate;

#[cfg(test)]
pub(crate) mod hidden_tests;

use std::fmt::Write as _;
use std::path::Path;

use nalgebra::DVector;

pub use load::{LoadSchedule, OperatingPoint};
pub use simulate::{DelayLine, Simulator};

use crate::model_file::{FieldTemperatureUse, ThermalModel, UseError};
use crate::spec::{InputSource, Reference};

/// Where the prediction starts.
#[derive(Debug, Clone, PartialEq)]
pub enum InitialState {
    /// The temperatures at the start of the model's recording (its initial rises).
    Measured,
    /// The steady state of the schedule's first row.
    Steady,
    /// These temperatures, °C, one per state.
    Temperatures(Vec<f64>),
}

/// Every state's predicted temperature on the model's grid.
#[derive(Debug, Clone)]
pub struct Prediction {
    /// State names, in model order.
    pub states: Vec<String>,
    /// Input names, in model order.
    pub inputs: Vec<String>,
    /// Times, s (the schedule's clock), on the model's sample time.
    pub time_s: Vec<f64>,
    /// `temperatures_c[k][j]`: state j at t_k, °C.
    pub temperatures_c: Vec<Vec<f64>>,
    /// `inputs_model[k][i]`: input i held over [t_k, t_k+1), in the model's scaling
    /// (the last instant repeats the one before).
    pub inputs_model: Vec<Vec<f64>>,
    /// The field winding temperature used for R_f, °C, where there is one.
    pub field_temperature_c: Vec<Option<f64>>,
    /// Whether the field winding temperature is derived from the stator winding's (not a
    /// state): it is then written as a column of its own, `field_winding_temp_c`.
    pub field_derived: bool,
    /// Each temperature's 95 % band, where the report carries the covariance of Θ.
    pub band_c: Option<band::Bands>,
    /// What was assumed or ignored.
    pub warnings: Vec<String>,
}

/// Runs `model` over `schedule` from `initial`, each temperature with its 95 % band
/// where the report carries the covariance of Θ ([`band`]).
pub fn predict(
    model: &ThermalModel,
    schedule: &LoadSchedule,
    initial: &InitialState,
) -> Result<Prediction, UseError> {
    let mut prediction = predict_from(model, schedule, initial, None)?;
    band::add_bands(&mut prediction, model, schedule, initial)?;
    Ok(prediction)
}

/// Runs `model` over `schedule` from `initial`, its initial rises (the measured outputs)
/// moved by `start_offset` (model units) where given: the map [`band`] linearises.
fn predict_from(
    model: &ThermalModel,
    schedule: &LoadSchedule,
    initial: &InitialState,
    start_offset: Option<&DVector<f64>>,
) -> Result<Prediction, UseError> {
    let sim = Simulator::new(model)?;
    let mut warnings = schedule.warnings.clone();
    // What the prediction tends to at a held load is the model's steady state: say where
    // the model's own recording never reached it.
    warnings.extend(
        model
            .steady_state_extrapolation
            .as_ref()
            .map(|why| format!("the steady state the model tends to at a held load is an extrapolation beyond its recording: {why}")),
    );
    if schedule.points.iter().any(|p| p.coolant_inlet_c.is_some()) && !sim.coolant_applies() {
        warnings.push(format!(
            "{}: the model's recording has no coolant inlet temperature, so `{}` is ignored: \
             the rises are those of the model's test",
            schedule.path.display(),
            load::COOLANT_COLUMN
        ));
    }
    if let Some(q) = model
        .inputs
        .iter()
        .find(|i| matches!(i.source, InputSource::CoolantFlow { .. }))
    {
        warnings.push(format!(
            "the model carries the cooling-water flow (input `{}`): the prediction holds the \
             flow at the start of the model's test, the flow its A_c describes",
            q.name
        ));
    }
    let (t0, t_end) = schedule.span_s();
    let ts = model.ts_s;
    let steps = ((t_end - t0) / ts + 1e-9).floor() as usize;
    let first = schedule.point_at(t0);
    let n = model.state_count();
    let rises = match initial {
        InitialState::Measured => DVector::from_fn(n, |j, _| {
            let theta0 = model.initial_temperature_c[j];
            let r0 = match &model.states[j].reference {
                Reference::Initial | Reference::Channel(_) | Reference::InitialOf(_) => {
                    model.initial_reference_c[j]
                }
                Reference::Absolute => 0.0,
            };
            (theta0 - r0) / model.temperature_base_k
        }),
        InitialState::Steady => sim.steady_state(first)?,
        InitialState::Temperatures(theta) => {
            if theta.len() != n {
                return Err(UseError::Request(format!(
                    "{} initial temperatures given; the model has {n} states ({})",
                    theta.len(),
                    model
                        .states
                        .iter()
                        .map(|s| s.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                )));
            }
            sim.rises(theta, first)
        }
    };
    // The model's own start: the measured rises themselves, or, with hidden states, the
    // steady state's states or the least-norm state giving the measured rises.
    let mut x = match initial {
        _ if model.output.is_none() => rises,
        InitialState::Steady => sim.steady_state_with_states(first)?.0,
        _ => {
            let u = sim.inputs(first, &sim.temperatures(&rises, first))?;
            model.state_from_outputs(&rises, &u)
        }
    };
    if let Some(offset) = start_offset {
        // An offset of the measured rises: the state's C⁺ offset with hidden states.
        x += model.state_from_outputs(offset, &DVector::zeros(model.inputs.len()));
    }
    let mut out = Prediction {
        states: model.states.iter().map(|s| s.name.clone()).collect(),
        inputs: model.inputs.iter().map(|i| i.name.clone()).collect(),
        time_s: Vec::with_capacity(steps + 1),
        temperatures_c: Vec::with_capacity(steps + 1),
        inputs_model: Vec::with_capacity(steps + 1),
        field_temperature_c: Vec::with_capacity(steps + 1),
        field_derived: matches!(
            model.field_temperature,
            FieldTemperatureUse::FromStator { .. }
        ),
        band_c: None,
        warnings,
    };
    let mut delays = DelayLine::new(model)?;
    // The input last applied, for the feedthrough D u of a model with hidden states:
    // the losses are computed at y = C x + D u(k−1), then the temperatures given are
    // C x + D u(k) (exact where D = 0, the default).
    let mut last_u = DVector::zeros(model.inputs.len());
    for k in 0..=steps {
        let t = t0 + k as f64 * ts;
        let p = schedule.point_at(t);
        let theta = sim.temperatures(&model.outputs(&x, &last_u), p);
        if let Some(e) = ran_away(schedule, (t, &theta), &out.states) {
            return Err(e);
        }
        let located = |e| at_schedule_time(e, schedule, t);
        let now = sim.inputs(p, &theta).map_err(located)?;
        let u = if delays.reads_ahead() {
            // An advanced input (`advance_s`) acts as u(k + 1): the schedule one sample on.
            let next = sim
                .inputs(schedule.point_at(t + ts), &theta)
                .map_err(located)?;
            delays.apply_ahead(now, &next)
        } else {
            delays.apply(now)
        };
        let theta = match &model.output {
            Some(_) => sim.temperatures(&model.outputs(&x, &u), p),
            None => theta,
        };
        last_u.copy_from(&u);
        out.field_temperature_c
            .push(sim.field_temperature_c(&theta, p));
        out.time_s.push(t);
        out.temperatures_c.push(theta);
        out.inputs_model.push(u.iter().copied().collect());
        x = sim.step(&x, &u);
    }
    Ok(out)
}

/// Temperatures beyond which a prediction has run away from anything a thermal model of a
/// generator describes (insulation chars long before), °C.
const RUNAWAY_C: f64 = 1e4;

/// Where the temperatures `theta` (°C of the parts `states`) at time `t_s` of the
/// schedule have run away (a load far beyond the model's, whose copper losses grow with
/// the temperature they raise): the error naming the part, the time and the row.
fn ran_away(
    schedule: &LoadSchedule,
    (t_s, theta): (f64, &[f64]),
    states: &[String],
) -> Option<UseError> {
    let j = theta.iter().position(|v| !(v.abs() < RUNAWAY_C))?;
    let what = format!(
        "the predicted temperatures ran away ({} at {:.3e} °C): the schedule's load is far \
         beyond any the model describes",
        states.get(j).map_or("a part", String::as_str),
        theta[j]
    );
    Some(at_schedule_time(UseError::Request(what), schedule, t_s))
}

/// A request error at time `t_s` of the schedule, named by the schedule's file, the time
/// and the row in force (an input that could not be computed there); any other error as
/// it is.
fn at_schedule_time(e: UseError, schedule: &LoadSchedule, t_s: f64) -> UseError {
    let UseError::Request(message) = e else {
        return e;
    };
    let row = schedule.time_s.partition_point(|&r| r <= t_s + 1e-9);
    let row_s = schedule.time_s[row.saturating_sub(1)];
    UseError::Request(format!(
        "{}: at {t_s} s (the row of time_s {row_s}): {message}",
        schedule.path.display()
    ))
}

impl Prediction {
    /// The prediction as CSV: `time_s` and `<state>_c` per state, °C (and
    /// `field_winding_temp_c` where the field winding is derived, not a state), each
    /// followed by its 95 % band `<state>_c_lo95`, `<state>_c_hi95` where there is one.
    pub fn to_csv(&self) -> String {
        let mut s = String::from("time_s");
        let mut names: Vec<&str> = self.states.iter().map(String::as_str).collect();
        if self.field_derived {
            names.push("field_winding_temp");
        }
        for name in &names {
            let _ = write!(s, ",{name}_c");
            if self.band_c.is_some() {
                let _ = write!(s, ",{name}_c_lo95,{name}_c_hi95");
            }
        }
        s.push('\n');
        for (k, (t, theta)) in self.time_s.iter().zip(&self.temperatures_c).enumerate() {
            let _ = write!(s, "{t}");
            let derived = self.field_temperature_c[k].unwrap_or(f64::NAN);
            let values = theta
                .iter()
                .copied()
                .chain(self.field_derived.then_some(derived));
            for (c, v) in values.enumerate() {
                let _ = write!(s, ",{v:.4}");
                if let Some(b) = &self.band_c {
                    let half = b.half_width_k[k][c];
                    let _ = write!(s, ",{:.4},{:.4}", v - half, v + half);
                }
            }
            s.push('\n');
        }
        s
    }

    /// Writes [`Prediction::to_csv`] to `path`, complete or not at all.
    pub fn write_csv(&self, path: &Path) -> Result<(), crate::atomic::WriteError> {
        crate::atomic::write_atomically(path, self.to_csv().as_bytes())
    }

    /// Each state's highest temperature and when, (°C, s).
    pub fn peaks(&self) -> Vec<(f64, f64)> {
        (0..self.states.len())
            .map(|j| {
                self.temperatures_c.iter().zip(&self.time_s).fold(
                    (f64::NEG_INFINITY, 0.0),
                    |m, (th, &t)| {
                        if th[j] > m.0 {
                            (th[j], t)
                        } else {
                            m
                        }
                    },
                )
            })
            .collect()
    }
}
