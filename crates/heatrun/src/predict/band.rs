//! The prediction's 95 % band: each predicted temperature ± 1.96 σ, σ² the sum of
//!
//! - the parameters' share, ∇θ̂(k)ᵀ C_Θ ∇θ̂(k), ∇ by central differences of the whole
//!   prediction (losses at the predicted temperatures, the phasor diagram, dead times
//!   and the derived field winding included: [`crate::confidence::linearise`]); for a
//!   model with hidden states Θ is θ_h = [Φ Γ; C D] and the prediction its measured
//!   outputs y = C x + D u, from x(0) = C⁺ (y(0) − D u(0)), which moves with C and D;
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
        prediction.warnings.push(if model.output.is_some() {
            "the model has hidden states and the report carries no covariance of their \
             parameters (`hidden.parameter_covariance`): the prediction has no band"
                .into()
        } else {
            "the report carries no covariance of Θ (`theta_covariance`): the prediction has \
             no band"
                .into()
        });
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::confidence::tests::one_state;
    use crate::predict::{predict, OperatingPoint};

    #[test]
    fn a_scalar_models_band_as_worked_by_hand_and_its_csv_columns() {
        // x(k+1) = a x(k) + b u from x(0) = 0 (started at the model test's own initial
        // temperature, its reference): θ̂(k) = 20 °C + b u (1 − a^k)/(1 − a). Its variance:
        // the parameters' (∂θ̂/∂a σ_a)² + (∂θ̂/∂b σ_b)² and the one start sample's σ² (the
        // start and the reference move together, so every instant moves with it).
        let (a, b, u) = (0.95, 0.1, 3.0);
        let sd = [1e-3, 2e-3];
        let model = one_state(a, b, sd);
        let schedule = LoadSchedule {
            path: "load.csv".into(),
            time_s: vec![0.0, 40.0],
            points: vec![
                OperatingPoint {
                    channels: [("heater_w".to_owned(), u)].into(),
                    ..OperatingPoint::default()
                };
                2
            ],
            apparent_power: vec![(0.0, 1.0); 2],
            warnings: Vec::new(),
        };
        let p = predict(&model, &schedule, &InitialState::Measured).unwrap();
        let bands = p.band_c.as_ref().expect("a band");
        for k in 0..=40 {
            let kf = k as f64;
            let theta = 20.0 + b * u * (1.0 - a.powi(k)) / (1.0 - a);
            let dxdb = u * (1.0 - a.powi(k)) / (1.0 - a);
            let dxda = if k == 0 {
                0.0
            } else {
                b * u * (1.0 - a.powi(k) - kf * a.powi(k - 1) * (1.0 - a)) / (1.0 - a).powi(2)
            };
            let var = (dxda * sd[0]).powi(2) + (dxdb * sd[1]).powi(2) + 0.05f64.powi(2);
            let k = k as usize;
            assert!((p.temperatures_c[k][0] - theta).abs() < 1e-9);
            let half = bands.half_width_k[k][0];
            assert!(
                (half / (Z95 * var.sqrt()) - 1.0).abs() < 1e-4,
                "k {k}: {half} vs {}",
                Z95 * var.sqrt()
            );
        }
        let csv = p.to_csv();
        let mut lines = csv.lines();
        assert_eq!(lines.next(), Some("time_s,part_c,part_c_lo95,part_c_hi95"));
        for line in lines {
            let v: Vec<f64> = line.split(',').map(|s| s.parse().unwrap()).collect();
            assert!(v[2] < v[1] && v[1] < v[3], "{line}");
        }
    }

    #[test]
    fn without_a_covariance_there_is_no_band_and_a_warning() {
        let mut model = one_state(0.9, 0.1, [1e-3, 1e-3]);
        model.uncertainty.theta_covariance = None;
        let schedule = LoadSchedule {
            path: "load.csv".into(),
            time_s: vec![0.0, 5.0],
            points: vec![
                OperatingPoint {
                    channels: [("heater_w".to_owned(), 1.0)].into(),
                    ..OperatingPoint::default()
                };
                2
            ],
            apparent_power: vec![(0.0, 1.0); 2],
            warnings: Vec::new(),
        };
        let p = predict(&model, &schedule, &InitialState::Measured).unwrap();
        assert!(p.band_c.is_none());
        assert!(p.warnings.iter().any(|w| w.contains("no band")));
        assert_eq!(p.to_csv().lines().next(), Some("time_s,part_c"));
    }
}
