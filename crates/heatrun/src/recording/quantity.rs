//! The measured quantities of the profile and their units.
//!
//! Every quantity has one SI-like canonical unit (A, V, °C, l/s); a channel's unit
//! is converted to it on read, and a unit not in the quantity's row of the profile
//! is an error, never a guess.

use serde::{Deserialize, Serialize};

/// How far below zero a reading of a non-negative quantity may be and still count as
/// transducer noise, as a fraction of the quantity's rated value (or, without one, of the
/// channel's largest reading). RMS transducers read a few tenths of a percent of their
/// range around zero; −81 % of the rated current is a fault.
pub const ZERO_NOISE_FRACTION: f64 = 0.02;

/// A quantity a heat-run channel can carry (the profile's table, in its order).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Quantity {
    /// Generator armature (stator) current I_g, RMS, in A.
    ArmatureCurrent,
    /// Field (rotor) current I_f, in A.
    FieldCurrent,
    /// Generator line-to-line voltage U_g, RMS, in V.
    LineVoltage,
    /// Field winding voltage U_f, in V (optional).
    FieldVoltage,
    /// Armature winding (copper) temperature θ_Cu, in °C.
    StatorWindingTemp,
    /// Stator iron core temperature θ_Fe, in °C.
    CoreTemp,
    /// Cooler outlet water temperature θ_cw, in °C.
    CoolingWaterOutletTemp,
    /// Cold water inlet temperature, in °C (optional).
    CoolingWaterInletTemp,
    /// Cooling water flow Q, in l/s (optional).
    CoolingWaterFlow,
    /// Field winding temperature θ_f, in °C (optional).
    FieldWindingTemp,
}

/// How a channel's samples are placed on the decimation grid.
///
/// The discrete model x(k) = Φ x(k−1) + Γ u(k−1) relates point values of the
/// states at the grid instants t_k = k·Ts to the input held over [t_{k−1}, t_k).
/// States (temperatures) are therefore averaged over a window centred on t_k (a point
/// value to O(Ts²·ẍ)), inputs over the interval [t_k, t_k + Ts). Which signal is which
/// is the model's knowledge, not the recording's: the decimator is given the map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Alignment {
    /// Window [t_k − Ts/2, t_k + Ts/2): the value at the instant t_k.
    Instant,
    /// Window [t_k, t_k + Ts): the mean over the interval that starts at t_k.
    Interval,
}

/// What a heat-run channel carries: a quantity of the profile, or a free channel that a
/// model spec names (any name, unit kept as written, no conversion, no plausibility range).
///
/// Ordered profile quantities first (in the profile's order), then free channels by name.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Signal {
    /// A quantity of the profile (converted to its canonical unit).
    Profile(Quantity),
    /// A channel outside the profile, read because a model spec names it.
    Free(String),
}

impl Signal {
    /// The name: the profile's quantity name, or the free channel's name.
    pub fn name(&self) -> &str {
        match self {
            Signal::Profile(q) => q.name(),
            Signal::Free(name) => name,
        }
    }

    /// The profile quantity, if the signal is one.
    pub fn quantity(&self) -> Option<Quantity> {
        match self {
            Signal::Profile(q) => Some(*q),
            Signal::Free(_) => None,
        }
    }

    /// The signal of a channel name: a profile quantity if the name is one, else free.
    pub fn from_name(name: &str) -> Signal {
        match Quantity::from_name(name) {
            Some(q) => Signal::Profile(q),
            None => Signal::Free(name.to_owned()),
        }
    }
}

impl From<Quantity> for Signal {
    fn from(q: Quantity) -> Signal {
        Signal::Profile(q)
    }
}

impl std::fmt::Display for Signal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A signal serialises as its name, as the report and `heatrun info --json` show it.
impl Serialize for Signal {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.name())
    }
}

/// A signal reads back from its name ([`Signal::from_name`]), as a report names channels.
impl<'de> Deserialize<'de> for Signal {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Signal, D::Error> {
        let name = String::deserialize(deserializer)?;
        Ok(Signal::from_name(&name))
    }
}

impl Quantity {
    /// All quantities, in the profile's order.
    pub const ALL: [Quantity; 10] = [
        Quantity::ArmatureCurrent,
        Quantity::FieldCurrent,
        Quantity::LineVoltage,
        Quantity::FieldVoltage,
        Quantity::StatorWindingTemp,
        Quantity::CoreTemp,
        Quantity::CoolingWaterOutletTemp,
        Quantity::CoolingWaterInletTemp,
        Quantity::CoolingWaterFlow,
        Quantity::FieldWindingTemp,
    ];

    /// The quantities every heat run must carry.
    pub const REQUIRED: [Quantity; 6] = [
        Quantity::ArmatureCurrent,
        Quantity::FieldCurrent,
        Quantity::LineVoltage,
        Quantity::StatorWindingTemp,
        Quantity::CoreTemp,
        Quantity::CoolingWaterOutletTemp,
    ];

    /// The profile's name of the quantity (channel metadata `quantity`).
    pub fn name(self) -> &'static str {
        match self {
            Quantity::ArmatureCurrent => "armature_current",
            Quantity::FieldCurrent => "field_current",
            Quantity::LineVoltage => "line_voltage",
            Quantity::FieldVoltage => "field_voltage",
            Quantity::StatorWindingTemp => "stator_winding_temp",
            Quantity::CoreTemp => "core_temp",
            Quantity::CoolingWaterOutletTemp => "cooling_water_outlet_temp",
            Quantity::CoolingWaterInletTemp => "cooling_water_inlet_temp",
            Quantity::CoolingWaterFlow => "cooling_water_flow",
            Quantity::FieldWindingTemp => "field_winding_temp",
        }
    }

    /// The quantity of a profile name, if it is one.
    pub fn from_name(name: &str) -> Option<Quantity> {
        Quantity::ALL.into_iter().find(|q| q.name() == name)
    }

    /// The canonical unit values are converted to.
    pub fn canonical_unit(self) -> &'static str {
        match self {
            Quantity::ArmatureCurrent | Quantity::FieldCurrent => "A",
            Quantity::LineVoltage | Quantity::FieldVoltage => "V",
            Quantity::CoolingWaterFlow => "l/s",
            _ => "degC",
        }
    }

    /// The units the profile accepts for this quantity.
    pub fn accepted_units(self) -> &'static [&'static str] {
        match self {
            Quantity::ArmatureCurrent | Quantity::FieldCurrent => &["A", "kA"],
            Quantity::LineVoltage => &["V", "kV"],
            Quantity::FieldVoltage => &["V"],
            Quantity::CoolingWaterFlow => &["l/s", "l/min", "m3/h"],
            _ => &["degC"],
        }
    }

    /// The factor that converts a value in `unit` to the canonical unit, if the
    /// profile accepts `unit` for this quantity.
    pub fn unit_scale(self, unit: &str) -> Option<f64> {
        if !self.accepted_units().contains(&unit) {
            return None;
        }
        Some(match unit {
            "kA" | "kV" => 1e3,
            "l/min" => 1.0 / 60.0,
            "m3/h" => 1e3 / 3600.0,
            _ => 1.0,
        })
    }

    /// The physically possible values in the canonical unit. A sample outside is a
    /// transducer or export fault (10⁹ °C, an RMS current of minus most of its rating)
    /// and is dropped. For a quantity that cannot be negative ([`Quantity::is_non_negative`])
    /// a reading slightly below zero is transducer noise, not a fault: see
    /// `ZERO_NOISE_FRACTION`.
    pub fn plausible_range(self) -> (f64, f64) {
        match self {
            // RMS quantities and flows are not negative; a generator's are below 1 MA, 1 MV.
            Quantity::ArmatureCurrent | Quantity::LineVoltage => (0.0, 1e6),
            // A DC field may be driven either way during field forcing or de-excitation.
            Quantity::FieldCurrent | Quantity::FieldVoltage => (-1e5, 1e5),
            Quantity::CoolingWaterFlow => (0.0, 1e5),
            // Machine and water temperatures: below freezing sites to insulation failure.
            _ => (-60.0, 300.0),
        }
    }

    /// Whether the quantity cannot be negative (RMS values, flows). Its transducer still
    /// reads slightly negative around zero: that is noise, kept so that the average at
    /// zero load is not biased upwards by dropping one side of it.
    pub fn is_non_negative(self) -> bool {
        self.plausible_range().0 == 0.0
    }

    /// The nameplate key of the quantity's rated value and the factor from the key's unit
    /// to the canonical unit: the scale the zero noise of its transducer is judged on.
    pub fn rated_key(self) -> Option<(&'static str, f64)> {
        match self {
            Quantity::ArmatureCurrent => Some(("rated_current_a", 1.0)),
            Quantity::LineVoltage => Some(("rated_voltage_kv", 1e3)),
            Quantity::FieldCurrent => Some(("rated_field_current_a", 1.0)),
            _ => None,
        }
    }

    /// Whether the quantity is a temperature (a state-like signal).
    pub fn is_temperature(self) -> bool {
        self.canonical_unit() == "degC"
    }
}

impl std::fmt::Display for Quantity {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for q in Quantity::ALL {
            assert_eq!(Quantity::from_name(q.name()), Some(q));
        }
        assert_eq!(Quantity::from_name("rotor_speed"), None);
    }

    #[test]
    fn units_convert_to_canonical() {
        assert_eq!(Quantity::ArmatureCurrent.unit_scale("kA"), Some(1000.0));
        assert_eq!(Quantity::LineVoltage.unit_scale("kV"), Some(1000.0));
        assert_eq!(
            Quantity::CoolingWaterFlow.unit_scale("l/min"),
            Some(1.0 / 60.0)
        );
        // 3.6 m³/h is one litre per second.
        assert!((Quantity::CoolingWaterFlow.unit_scale("m3/h").unwrap() * 3.6 - 1.0).abs() < 1e-15);
        assert_eq!(Quantity::CoreTemp.unit_scale("degC"), Some(1.0));
        // Units outside a quantity's row are refused, never guessed.
        assert_eq!(Quantity::FieldVoltage.unit_scale("kV"), None);
        assert_eq!(Quantity::CoreTemp.unit_scale("K"), None);
        assert_eq!(Quantity::ArmatureCurrent.unit_scale("mA"), None);
    }
}
