//! Loss calculation stage: decimated currents, voltages and temperatures → the
//! thermal model's inputs (heat sources, pu of S_n) and states (temperature rises,
//! pu of the temperature base), following the profile's loss model.
//!
//! Input: a [`DecimatedRecording`] and a [`Nameplate`]. Output: [`ThermalSignals`].

use serde::Serialize;

use crate::decimate::DecimatedRecording;
use crate::error::{Error, Result};
use crate::recording::{Nameplate, Quantity};
use crate::series::Series;

/// The inverse temperature coefficient of copper, 235 K: R(θ) ∝ 235 + θ.
pub const COPPER_INFERRED_ZERO_C: f64 = 235.0;

/// The thermal model's states, in the profile's order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ThermalState {
    /// Armature (stator) winding copper temperature rise Δθ_Cu.
    StatorWinding,
    /// Stator iron core temperature rise Δθ_Fe.
    Core,
    /// Cooler outlet water temperature rise Δθ_cw.
    CoolingWaterOutlet,
}

impl ThermalState {
    /// The states in model order.
    pub const ALL: [ThermalState; 3] = [
        ThermalState::StatorWinding,
        ThermalState::Core,
        ThermalState::CoolingWaterOutlet,
    ];

    /// The measured quantity the state is the rise of (also its name in the report).
    pub fn quantity(self) -> Quantity {
        match self {
            ThermalState::StatorWinding => Quantity::StatorWindingTemp,
            ThermalState::Core => Quantity::CoreTemp,
            ThermalState::CoolingWaterOutlet => Quantity::CoolingWaterOutletTemp,
        }
    }

    /// The profile's name of the state (`stator_winding_temp`, …).
    pub fn name(self) -> &'static str {
        self.quantity().name()
    }

    /// The physical part the state stands for, for people.
    pub fn part(self) -> &'static str {
        match self {
            ThermalState::StatorWinding => "stator winding (copper)",
            ThermalState::Core => "iron core",
            ThermalState::CoolingWaterOutlet => "cooling water (cooler)",
        }
    }
}

/// The thermal model's inputs (heat sources), in the profile's order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum HeatSource {
    /// Armature copper loss 3·I_g²·R_a(θ_Cu) + ½·P_add·(I_g/I_n)².
    ArmatureCopperLoss,
    /// Field copper loss I_f²·R_f(θ_f).
    FieldCopperLoss,
    /// Iron loss (P_Fe + ½·P_add)·(U_g/U_n)².
    IronLoss,
}

impl HeatSource {
    /// The inputs in model order.
    pub const ALL: [HeatSource; 3] = [
        HeatSource::ArmatureCopperLoss,
        HeatSource::FieldCopperLoss,
        HeatSource::IronLoss,
    ];

    /// The profile's name of the input.
    pub fn name(self) -> &'static str {
        match self {
            HeatSource::ArmatureCopperLoss => "armature_copper_loss",
            HeatSource::FieldCopperLoss => "field_copper_loss",
            HeatSource::IronLoss => "iron_loss",
        }
    }
}

/// Where the field winding temperature θ_f comes from (the profile's order of preference).
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "method", rename_all = "snake_case")]
pub enum FieldTemperatureSource {
    /// Measured by a `field_winding_temp` channel.
    Measured,
    /// Resistance method: R_f = U_f / I_f from `field_voltage`.
    ResistanceMethod,
    /// The paper's method: θ_f = θ_Cu0 + s·(θ_Cu − θ_Cu0), with s chosen so that the
    /// final field temperature equals the nameplate's `field_winding_final_temp_c`.
    ScaledArmatureRise {
        /// The scale s.
        scale: f64,
        /// The final field winding temperature it is scaled to, in °C.
        final_temp_c: f64,
    },
}

/// Copper resistance at temperature θ: R(θ) = R_ref · (235 + θ) / (235 + θ_ref).
pub fn copper_resistance(r_ref_ohm: f64, ref_temp_c: f64, temp_c: f64) -> f64 {
    r_ref_ohm * (COPPER_INFERRED_ZERO_C + temp_c) / (COPPER_INFERRED_ZERO_C + ref_temp_c)
}

/// Armature copper loss in W: 3·I_g²·R_a(θ_Cu) + ½·P_add·(I_g/I_n)².
pub fn armature_copper_loss_w(np: &Nameplate, current_a: f64, winding_temp_c: f64) -> f64 {
    let r = copper_resistance(
        np.armature_resistance_ohm,
        np.armature_resistance_ref_temp_c,
        winding_temp_c,
    );
    let i_pu = current_a / np.rated_current_a;
    3.0 * current_a * current_a * r + 0.5 * np.additional_losses_w * i_pu * i_pu
}

/// Field copper loss in W: I_f²·R_f(θ_f) (a DC winding: no factor 3).
pub fn field_copper_loss_w(np: &Nameplate, field_current_a: f64, field_temp_c: f64) -> f64 {
    let r = copper_resistance(
        np.field_resistance_ohm,
        np.field_resistance_ref_temp_c,
        field_temp_c,
    );
    field_current_a * field_current_a * r
}

/// Iron loss in W: (P_Fe + ½·P_add)·(U_g/U_n)².
pub fn iron_loss_w(np: &Nameplate, line_voltage_v: f64) -> f64 {
    let u_pu = line_voltage_v / np.rated_voltage_v;
    (np.iron_losses_w + 0.5 * np.additional_losses_w) * u_pu * u_pu
}

/// Field winding temperature from the resistance method: solves R_f(θ) = U_f / I_f for θ.
pub fn field_temp_from_resistance(
    np: &Nameplate,
    field_voltage_v: f64,
    field_current_a: f64,
) -> f64 {
    let r = field_voltage_v / field_current_a;
    r / np.field_resistance_ohm * (COPPER_INFERRED_ZERO_C + np.field_resistance_ref_temp_c)
        - COPPER_INFERRED_ZERO_C
}

/// The thermal model's signals on the grid: the loss stage's output.
#[derive(Debug, Clone)]
pub struct ThermalSignals {
    /// Sample time in s.
    pub ts_s: f64,
    /// Time of each grid instant, ns since the epoch.
    pub time_ns: Vec<i64>,
    /// Measured temperatures θ (°C), per state, `None` where missing.
    pub temperatures_c: [Series; 3],
    /// Initial temperatures θ_0 (°C) the rises are measured from.
    pub initial_temperatures_c: [f64; 3],
    /// Index of the instant the initial temperatures were taken at.
    pub initial_index: usize,
    /// Heat sources in pu of S_n, per input (held over [t_k, t_k + Ts)).
    pub inputs_pu: [Series; 3],
    /// Field winding temperature used for R_f (°C).
    pub field_temperature_c: Series,
    /// Where θ_f comes from.
    pub field_temperature_source: FieldTemperatureSource,
    /// Per-unit temperature base, K.
    pub temperature_base_k: f64,
    /// Power base S_n, VA.
    pub power_base_va: f64,
}

impl ThermalSignals {
    /// Number of grid instants.
    pub fn len(&self) -> usize {
        self.time_ns.len()
    }

    /// Whether there are no instants.
    pub fn is_empty(&self) -> bool {
        self.time_ns.is_empty()
    }

    /// State j's temperature rise (θ_j(k) − θ_j,0)/θ_base at instant k, in pu.
    pub fn rise_pu(&self, j: usize, k: usize) -> Option<f64> {
        self.temperatures_c[j]
            .get(k)
            .map(|t| (t - self.initial_temperatures_c[j]) / self.temperature_base_k)
    }

    /// The last instant at which every input is known, with those inputs (pu).
    pub fn last_inputs(&self) -> Option<(usize, [f64; 3])> {
        (0..self.len()).rev().find_map(|k| {
            Some((
                k,
                [
                    self.inputs_pu[0].get(k)?,
                    self.inputs_pu[1].get(k)?,
                    self.inputs_pu[2].get(k)?,
                ],
            ))
        })
    }

    /// The last instant at which every temperature is known, with those temperatures (°C).
    pub fn last_temperatures(&self) -> Option<(usize, [f64; 3])> {
        (0..self.len()).rev().find_map(|k| {
            Some((
                k,
                [
                    self.temperatures_c[0].get(k)?,
                    self.temperatures_c[1].get(k)?,
                    self.temperatures_c[2].get(k)?,
                ],
            ))
        })
    }
}

/// Computes the model's states and inputs from a decimated recording.
///
/// `recording` names the file in messages. Errors when a required quantity is
/// missing, or when no field temperature source is available.
pub fn compute(
    decimated: &DecimatedRecording,
    np: &Nameplate,
    recording: &str,
) -> Result<ThermalSignals> {
    let missing = |q: Quantity| {
        Error::BadRecording {
        path: recording.into(),
        message: format!(
            "no channel carries the required quantity `{q}` (metadata `quantity` or a topic ending in /{q})"
        ),
    }
    };
    let series = |q: Quantity| {
        decimated
            .get(q)
            .map(|s| &s.values)
            .ok_or_else(|| missing(q))
    };
    let i_g = series(Quantity::ArmatureCurrent)?;
    let i_f = series(Quantity::FieldCurrent)?;
    let u_g = series(Quantity::LineVoltage)?;
    let temps = [
        series(Quantity::StatorWindingTemp)?.clone(),
        series(Quantity::CoreTemp)?.clone(),
        series(Quantity::CoolingWaterOutletTemp)?.clone(),
    ];
    let n = decimated.len;
    let initial_index = (0..n)
        .find(|&k| temps.iter().all(|t| t.get(k).is_some()))
        .ok_or_else(|| {
            Error::InsufficientData(format!(
                "{recording}: the three temperatures are never known at the same instant"
            ))
        })?;
    let theta0 = [0, 1, 2].map(|s| temps[s].get(initial_index).unwrap_or(f64::NAN));
    let base = np.temperature_base_k;

    // Field winding temperature, in the profile's order of preference.
    let (field_temperature_c, field_temperature_source) = if let Some(measured) =
        decimated.get(Quantity::FieldWindingTemp)
    {
        (measured.values.clone(), FieldTemperatureSource::Measured)
    } else if let Some(u_f) = decimated.get(Quantity::FieldVoltage) {
        let theta: Series = (0..n)
            .map(|k| match (u_f.values.get(k), i_f.get(k)) {
                (Some(u), Some(i))
                    if i.abs() > 1e-3 * np.rated_field_current_a.unwrap_or(1000.0) =>
                {
                    Some(field_temp_from_resistance(np, u, i))
                }
                _ => None,
            })
            .collect();
        (theta, FieldTemperatureSource::ResistanceMethod)
    } else if let Some(final_temp_c) = np.field_winding_final_temp_c {
        let last_cu = (0..n)
            .rev()
            .find_map(|k| temps[0].get(k))
            .unwrap_or(theta0[0]);
        let rise = last_cu - theta0[0];
        if rise < 1.0 {
            return Err(Error::InsufficientData(format!(
                "{recording}: the stator winding rises only {rise:.2} K, too little to scale \
                     the field winding temperature to {final_temp_c} °C; record field_voltage or \
                     field_winding_temp"
            )));
        }
        let scale = (final_temp_c - theta0[0]) / rise;
        let theta = temps[0]
            .iter()
            .map(|t| t.map(|t| theta0[0] + scale * (t - theta0[0])))
            .collect();
        (
            theta,
            FieldTemperatureSource::ScaledArmatureRise {
                scale,
                final_temp_c,
            },
        )
    } else {
        return Err(Error::BadRecording {
                path: recording.into(),
                message: "no field winding temperature: the recording has neither a `field_winding_temp` \
                          nor a `field_voltage` channel, and nameplate key `field_winding_final_temp_c` \
                          is missing (give it with --machine FILE.toml)"
                    .into(),
            });
    };

    let s_n = np.rated_apparent_power_va;
    let mut inputs_pu: [Series; 3] = [Series::unknown(n), Series::unknown(n), Series::unknown(n)];
    for k in 0..n {
        inputs_pu[0].set(
            k,
            match (i_g.get(k), temps[0].get(k)) {
                (Some(i), Some(t)) => Some(armature_copper_loss_w(np, i, t) / s_n),
                _ => None,
            },
        );
        inputs_pu[1].set(
            k,
            match (i_f.get(k), field_temperature_c.get(k)) {
                (Some(i), Some(t)) => Some(field_copper_loss_w(np, i, t) / s_n),
                _ => None,
            },
        );
        inputs_pu[2].set(k, u_g.get(k).map(|u| iron_loss_w(np, u) / s_n));
    }
    Ok(ThermalSignals {
        ts_s: decimated.ts_s(),
        time_ns: (0..n).map(|i| decimated.time_ns(i)).collect(),
        temperatures_c: temps,
        initial_temperatures_c: theta0,
        initial_index,
        inputs_pu,
        field_temperature_c,
        field_temperature_source,
        temperature_base_k: base,
        power_base_va: s_n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, rel: f64) -> bool {
        (a - b).abs() <= rel * b.abs()
    }

    #[test]
    fn resistance_correction_by_hand() {
        // R_a(75 °C) = 0.005155 · 310 / 255 = 0.0062668… Ω.
        let r = copper_resistance(0.005155, 20.0, 75.0);
        assert!(close(r, 0.005155 * 310.0 / 255.0, 1e-15));
        assert_eq!(copper_resistance(0.1422, 21.0, 21.0), 0.1422);
    }

    #[test]
    fn table1_losses_at_rated_point_by_hand() {
        let np = Nameplate::paper_table1();
        // Armature at I_n and 63 °C: 3 · 3689.14² · 0.005155·298/255 + 71.8 kW.
        let r63 = 0.005155 * 298.0 / 255.0;
        let expect = 3.0 * 3689.14f64.powi(2) * r63 + 71_800.0;
        let got = armature_copper_loss_w(&np, 3689.14, 63.0);
        assert!(close(got, expect, 1e-12), "{got} vs {expect}");
        assert!(close(got, 317_760.0, 1e-3), "about 317.8 kW: {got}");
        // Field at I_fn = 1092 A and 81 °C: 1092² · 0.1422 · 316/256 = 209.3 kW.
        let got = field_copper_loss_w(&np, 1092.0, 81.0);
        assert!(close(
            got,
            1092.0f64.powi(2) * 0.1422 * 316.0 / 256.0,
            1e-12
        ));
        assert!(close(got, 209_316.0, 1e-4), "{got}");
        // Iron at U_n: P_Fe + ½ P_add = 244.8 + 71.8 kW.
        assert!(close(iron_loss_w(&np, 15_650.0), 316_600.0, 1e-12));
        // In pu of S_n = 100 MVA the iron loss of eq. (30), 0.003592 pu, means U_g ≈ 1.0652 U_n.
        let u = 15_650.0 * (0.003592f64 / 0.003166).sqrt();
        assert!(close(iron_loss_w(&np, u) / 100e6, 0.003592, 1e-12));
    }

    #[test]
    fn resistance_method_inverts_the_resistance_law() {
        let np = Nameplate::paper_table1();
        let theta = 81.0;
        let i = 1100.0;
        let u = i * copper_resistance(
            np.field_resistance_ohm,
            np.field_resistance_ref_temp_c,
            theta,
        );
        assert!((field_temp_from_resistance(&np, u, i) - theta).abs() < 1e-10);
    }
}
