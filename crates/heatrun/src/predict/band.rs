//! The prediction's 95 % band: each predicted temperature ± 1.96 σ, σ² the sum of
//!
//! - the parameters' share, ∇θ̂(k)ᵀ C_Θ ∇θ̂(k), ∇ by central differences of the whole
//!   prediction (losses at the predicted temperatures, the phasor diagram, dead times
//!   and the derived field winding included: [`crate::confidence::linearise`]);
//! - the start's share: the samples the prediction starts from and is measured from
//!   carry the sensors' noise σ_j, Σ_j (∂θ̂(k)/∂θ_j(0))² σ_j² by moving each by ±σ_j
//!   (`add_start`: the start temperature, whose error decays with the modes, and the
//!   reference of a state measured from its own initial temperature, whose error stays;
//!   a steady start is the model's own, inside the parameters' share);
//! - the process noise where the model has it (`pem`'s K Λ Kᵀ): P(k+1) = Φ P(k) Φᵀ +
//!   K Λ Kᵀ from P(0) = 0, θ_base² P_jj for state j and slope² times the stator winding's
//!   for the derived field winding.
//!
//! The band is of the machine's temperature, not of a measurement of it: the sensors'
//! noise enters only through the start.

use nalgebra::{DMatrix, DVector};

use super::{predict_from, InitialState, LoadSchedule, Prediction};
use crate::confidence::{linearise, Z95};
use crate::model_file::{FieldTemperatureUse, ThermalModel, UseError};
use crate::spec::Reference;

/// The 95 % bands of a prediction.
#[derive(Debug, Clone)]
pub struct Bands {
    /// `half_width_k[k][c]`: 1.96 σ of column c at t_k, K; columns the states in model
    /// order, then the derived field winding where there is one.
    pub half_width_k: Vec<Vec<f64>>,
    /// What σ holds: `parameters`, `initial state and reference`, `field line`,
    /// `process noise`.
    pub sources: Vec<&'static str>,
}

impl Bands {
    /// The mean half-width over instants and columns, K.
    pub fn mean_half_width_k(&self) -> f64 {
        let all: Vec<f64> = self.half_width_k.iter().flatten().copied().collect();
        all.iter().sum::<f64>() / all.len().max(1) as f64
    }
}

/// The prediction's values, instant by instant: the states, then the derived field
/// winding where there is one.
fn flatten(p: &Prediction) -> Vec<f64> {
    p.temperatures_c
        .iter()
        .zip(&p.field_temperature_c)
        .flat_map(|(theta, field)| {
            let derived = p.field_derived.then(|| field.unwrap_or(f64::NAN));
            theta.iter().copied().chain(derived)
        })
        .collect()
}

/// Sets `prediction.band_c` where the report carries C_Θ (else warns that it has none).
pub(super) fn add_bands(
    prediction: &mut Prediction,
    model: &ThermalModel,
    schedule: &LoadSchedule,
    initial: &InitialState,
) -> Result<(), UseError> {
    let Some(covariance) = &model.uncertainty.theta_covariance else {
        prediction.warnings.push(
            "the report carries no covariance of Θ (`theta_covariance`): the prediction has \
             no band"
                .into(),
        );
        return Ok(());
    };
    let columns = model.state_count() + usize::from(prediction.field_derived);
    let run = |m: &ThermalModel, offset: Option<&DVector<f64>>| {
        predict_from(m, schedule, initial, offset).map(|p| flatten(&p))
    };
    let mut variance = linearise(model, covariance, |m| run(m, None))?.variances(covariance);
    let mut sources = vec!["parameters"];
    add_start(&mut variance, model, initial, &run)?;
    sources.push("initial state and reference");
    if let (true, Some(sigma)) = (prediction.field_derived, model.uncertainty.field_line_rms_k) {
        // The derived field winding's line scatters about the true temperature by σ_line.
        for row in variance.chunks_mut(columns) {
            row[columns - 1] += sigma * sigma;
        }
        sources.push("field line");
    }
    if let Some(q) = &model.uncertainty.process_noise {
        add_process_noise(&mut variance, model, q, columns);
        sources.push("process noise");
    }
    prediction.band_c = Some(Bands {
        half_width_k: variance
            .chunks(columns)
            .map(|c| c.iter().map(|v| Z95 * v.max(0.0).sqrt()).collect())
            .collect(),
        sources,
    });
    Ok(())
}

/// The start's share, each sample at the start moved by ±σ_j (the sensors' noise) and
/// the prediction run again, var += ((θ̂₊ − θ̂₋)/2)²: the measured start temperature
/// (decays with the model's modes) and, for a state measured from its own initial
/// temperature ([`Reference::Initial`]), the reference the rises are measured from
/// (stays: every predicted temperature is reference + rise). Started from the model's
/// measured temperatures, both are one sample and move together; a start given or
/// steady moves the reference alone (and a given start its own sample apart).
fn add_start<F>(
    variance: &mut [f64],
    model: &ThermalModel,
    initial: &InitialState,
    run: &F,
) -> Result<(), UseError>
where
    F: Fn(&ThermalModel, Option<&DVector<f64>>) -> Result<Vec<f64>, UseError>,
{
    let n = model.state_count();
    let mut add = |plus: Vec<f64>, minus: Vec<f64>| {
        for (v, (p, q)) in variance.iter_mut().zip(plus.iter().zip(&minus)) {
            let d = 0.5 * (p - q);
            if d.is_finite() {
                *v += d * d;
            }
        }
    };
    for j in 0..n {
        let sd = model.uncertainty.sensor_noise_k[j];
        if !(sd > 0.0) {
            continue;
        }
        let own_reference = model.states[j].reference == Reference::Initial;
        let moved = |delta: f64, start: bool, reference: bool| {
            let mut m = model.clone();
            if start {
                m.initial_temperature_c[j] += delta;
            }
            if reference {
                m.initial_reference_c[j] += delta;
            }
            m
        };
        match initial {
            InitialState::Measured => add(
                run(&moved(sd, true, own_reference), None)?,
                run(&moved(-sd, true, own_reference), None)?,
            ),
            InitialState::Temperatures(_) | InitialState::Steady => {
                if own_reference {
                    add(
                        run(&moved(sd, false, true), None)?,
                        run(&moved(-sd, false, true), None)?,
                    );
                }
                if matches!(initial, InitialState::Temperatures(_)) {
                    let step = DVector::from_fn(n, |i, _| {
                        if i == j {
                            sd / model.temperature_base_k
                        } else {
                            0.0
                        }
                    });
                    add(run(model, Some(&step))?, run(model, Some(&(-step)))?);
                }
            }
        }
    }
    Ok(())
}

/// The process noise's share, P(k+1) = Φ P(k) Φᵀ + Q from P(0) = 0, in K².
fn add_process_noise(variance: &mut [f64], model: &ThermalModel, q: &DMatrix<f64>, columns: usize) {
    let n = model.state_count();
    let base2 = model.temperature_base_k.powi(2);
    let derived_slope = match model.field_temperature {
        FieldTemperatureUse::FromStator { slope, .. } => Some(slope),
        _ => None,
    };
    let stator = model.state_of(crate::recording::Quantity::StatorWindingTemp);
    let mut p = DMatrix::<f64>::zeros(n, n);
    for row in variance.chunks_mut(columns) {
        for j in 0..n {
            row[j] += base2 * p[(j, j)];
        }
        if let (Some(s), Some(slope), true) = (stator, derived_slope, columns > n) {
            row[n] += slope * slope * base2 * p[(s, s)];
        }
        p = &model.phi * p * model.phi.transpose() + q;
    }
}
