//! The generator's loss model: decimated currents, voltages and temperatures → the
//! heat sources (pu of S_n) of the profile's "Loss model", with temperature-corrected
//! resistances and the field winding temperature methods.
//!
//! Input: a [`DecimatedRecording`] and a [`Nameplate`]. Output: [`GeneratorLosses`],
//! which the signal stage ([`crate::signals`]) reads for the generator's inputs.

use serde::{Deserialize, Serialize};

use crate::decimate::DecimatedRecording;
/// Why the generator's losses cannot be computed from a recording.
#[derive(Debug, thiserror::Error)]
pub enum LossError {
    /// A quantity the loss model needs is not in the recording.
    #[error(
        "no channel carries `{channel}` (metadata `quantity` or a topic ending in /{channel})"
    )]
    MissingChannel {
        /// The quantity's name.
        channel: String,
    },
    /// No source of the generator's field winding temperature.
    #[error(
        "no field winding temperature: the recording has neither a `field_winding_temp` \
         nor a `field_voltage` channel, and nameplate key `field_winding_final_temp_c` is missing"
    )]
    NoFieldTemperature,
    /// The paper's field-temperature scaling needs a stator rise to scale.
    #[error(
        "the stator winding rises only {rise_k:.2} K, too little to scale the field \
         winding temperature to {final_temp_c} °C; record field_voltage or field_winding_temp"
    )]
    FieldScalingRise {
        /// The stator winding's rise over the recording, K.
        rise_k: f64,
        /// The nameplate's final field winding temperature, °C.
        final_temp_c: f64,
    },
}

type Result<T> = std::result::Result<T, LossError>;
use crate::recording::{Nameplate, Quantity};
use crate::series::Series;

/// The inverse temperature coefficient of copper, 235 K: R(θ) ∝ 235 + θ.
pub const COPPER_INFERRED_ZERO_C: f64 = 235.0;

/// The thermal model's inputs (heat sources), in the profile's order; by
/// [`HeatSource::name`] in the report.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
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
/// Read back from a report: one written before `field_temperature_from_stator` holds the
/// paper's scale here.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
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

/// The generator's heat sources on the grid: the loss model's output.
#[derive(Debug, Clone)]
pub struct GeneratorLosses {
    /// Armature copper, field copper and iron loss in pu of S_n, in [`HeatSource::ALL`]'s
    /// order, held over [t_k, t_k + Ts).
    pub inputs_pu: [Series; 3],
    /// Field winding temperature used for R_f (°C).
    pub field_temperature_c: Series,
    /// Where θ_f comes from.
    pub field_temperature_source: FieldTemperatureSource,
}

impl GeneratorLosses {
    /// The series of one heat source, pu of S_n.
    pub fn heat_source(&self, source: HeatSource) -> &Series {
        &self.inputs_pu[source as usize]
    }
}

/// Computes the loss model's heat sources from a decimated recording (the profile's
/// "Loss model"): u_1 = (3·I_g²·R_a(θ_Cu) + ½·P_add·(I_g/I_n)²)/S_n,
/// u_2 = I_f²·R_f(θ_f)/S_n, u_3 = (P_Fe + ½·P_add)·(U_g/U_n)²/S_n.
///
/// `initial_index` is the instant the model's rises start from (the paper's field
/// scaling is relative to the stator temperature there). Errors when a required
/// quantity is missing, or when no field temperature source is available.
pub fn compute(
    decimated: &DecimatedRecording,
    np: &Nameplate,
    initial_index: usize,
) -> Result<GeneratorLosses> {
    let series = |q: Quantity| {
        decimated
            .get(q)
            .map(|s| &s.values)
            .ok_or_else(|| LossError::MissingChannel {
                channel: q.name().into(),
            })
    };
    let i_g = series(Quantity::ArmatureCurrent)?;
    let i_f = series(Quantity::FieldCurrent)?;
    let u_g = series(Quantity::LineVoltage)?;
    let theta_cu = series(Quantity::StatorWindingTemp)?;
    let (field_temperature_c, field_temperature_source) =
        field_temperature(decimated, np, (theta_cu, initial_index), i_f)?;
    let s_n = np.rated_apparent_power_va;
    let n = decimated.len;
    let mut inputs_pu: [Series; 3] = [Series::unknown(n), Series::unknown(n), Series::unknown(n)];
    for k in 0..n {
        let armature = i_g.get(k).zip(theta_cu.get(k));
        let field = i_f.get(k).zip(field_temperature_c.get(k));
        inputs_pu[0].set(
            k,
            armature.map(|(i, t)| armature_copper_loss_w(np, i, t) / s_n),
        );
        inputs_pu[1].set(k, field.map(|(i, t)| field_copper_loss_w(np, i, t) / s_n));
        inputs_pu[2].set(k, u_g.get(k).map(|u| iron_loss_w(np, u) / s_n));
    }
    Ok(GeneratorLosses {
        inputs_pu,
        field_temperature_c,
        field_temperature_source,
    })
}

/// θ_f on the grid by the resistance method, R_f(θ_f) = U_f / I_f, where the recording
/// has `field_voltage` (`None` otherwise); unknown where I_f is below 0.1 % of its rated
/// value, where U_f / I_f is noise over noise.
pub fn field_temperature_by_resistance(
    decimated: &DecimatedRecording,
    np: &Nameplate,
    i_f: &Series,
) -> Option<Series> {
    let u_f = decimated.get(Quantity::FieldVoltage)?;
    let floor = 1e-3 * np.rated_field_current_a.unwrap_or(1000.0);
    Some(
        (0..decimated.len)
            .map(|k| match (u_f.values.get(k), i_f.get(k)) {
                (Some(u), Some(i)) if i.abs() > floor => Some(field_temp_from_resistance(np, u, i)),
                _ => None,
            })
            .collect(),
    )
}

/// The field winding temperature θ_f, in the profile's order of preference: measured,
/// the resistance method U_f / I_f, or the paper's scaling of the armature rise.
fn field_temperature(
    decimated: &DecimatedRecording,
    np: &Nameplate,
    (theta_cu, initial_index): (&Series, usize),
    i_f: &Series,
) -> Result<(Series, FieldTemperatureSource)> {
    if let Some(measured) = decimated.get(Quantity::FieldWindingTemp) {
        return Ok((measured.values.clone(), FieldTemperatureSource::Measured));
    }
    if let Some(theta) = field_temperature_by_resistance(decimated, np, i_f) {
        return Ok((theta, FieldTemperatureSource::ResistanceMethod));
    }
    let final_temp_c = np
        .field_winding_final_temp_c
        .ok_or(LossError::NoFieldTemperature)?;
    let theta0 = theta_cu.get(initial_index).unwrap_or(f64::NAN);
    let last_cu = theta_cu.iter().flatten().last().unwrap_or(theta0);
    let rise = last_cu - theta0;
    if !(rise >= 1.0) {
        return Err(LossError::FieldScalingRise {
            rise_k: rise,
            final_temp_c,
        });
    }
    let scale = (final_temp_c - theta0) / rise;
    let theta = theta_cu
        .iter()
        .map(|t| t.map(|t| theta0 + scale * (t - theta0)))
        .collect();
    Ok((
        theta,
        FieldTemperatureSource::ScaledArmatureRise {
            scale,
            final_temp_c,
        },
    ))
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
