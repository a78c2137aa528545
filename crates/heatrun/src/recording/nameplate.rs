//! The machine's nameplate: the `heatrun.nameplate` metadata record, overridden
//! key by key by a machine file (a flat TOML table of the same keys).

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::error::{RecordingError, Result};

/// Name of the MCAP metadata record that holds the nameplate.
pub const NAMEPLATE_RECORD: &str = "heatrun.nameplate";

/// One key of the `heatrun.nameplate` record: its unit, whether a generator replay needs
/// it, and what it feeds. The profile's reference page
/// (`docs/src/reference/recording-format.md`) lists these same keys; a test holds the two
/// together.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NameplateKey {
    /// The key, as the record and a machine file spell it.
    pub key: &'static str,
    /// The unit of its decimal value (`1` for a ratio or a per-unit value).
    pub unit: &'static str,
    /// Whether the loss model cannot run without it.
    pub required: bool,
    /// What the value feeds, in a few words.
    pub feeds: &'static str,
}

/// Every nameplate key the profile and heatrun know, required ones first, in the
/// profile's order.
pub const NAMEPLATE_KEYS: [NameplateKey; 17] = [
    NameplateKey {
        key: "rated_apparent_power_mva",
        unit: "MVA",
        required: true,
        feeds: "S_n, the per-unit power base every loss is divided by",
    },
    NameplateKey {
        key: "rated_voltage_kv",
        unit: "kV",
        required: true,
        feeds: "U_n, the iron loss's (U_g/U_n)^2",
    },
    NameplateKey {
        key: "rated_current_a",
        unit: "A",
        required: true,
        feeds: "I_n, the additional loss's (I_g/I_n)^2 and the rating's rated point",
    },
    NameplateKey {
        key: "armature_resistance_ohm",
        unit: "ohm",
        required: true,
        feeds: "R_a, the armature copper loss 3 I_g^2 R_a(theta)",
    },
    NameplateKey {
        key: "armature_resistance_ref_temp_c",
        unit: "degC",
        required: true,
        feeds: "the temperature R_a was measured at",
    },
    NameplateKey {
        key: "field_resistance_ohm",
        unit: "ohm",
        required: true,
        feeds: "R_f, the field copper loss I_f^2 R_f(theta_f)",
    },
    NameplateKey {
        key: "field_resistance_ref_temp_c",
        unit: "degC",
        required: true,
        feeds: "the temperature R_f was measured at",
    },
    NameplateKey {
        key: "iron_losses_kw",
        unit: "kW",
        required: true,
        feeds: "P_Fe, the iron loss at rated voltage",
    },
    NameplateKey {
        key: "additional_losses_kw",
        unit: "kW",
        required: true,
        feeds: "P_add, half to the armature loss, half to the iron loss",
    },
    NameplateKey {
        key: "temperature_base_k",
        unit: "K",
        required: true,
        feeds: "the per-unit temperature base (80 K in the paper)",
    },
    NameplateKey {
        key: "rated_field_current_a",
        unit: "A",
        required: false,
        feeds: "I_fn, the phasor diagram's rated field current (predict, rating)",
    },
    NameplateKey {
        key: "armature_copper_losses_kw",
        unit: "kW",
        required: false,
        feeds: "informative: the rated armature copper loss",
    },
    NameplateKey {
        key: "field_copper_losses_kw",
        unit: "kW",
        required: false,
        feeds: "informative: the rated field copper loss",
    },
    NameplateKey {
        key: "field_winding_final_temp_c",
        unit: "degC",
        required: false,
        feeds: "the paper's field-temperature method, where no field temperature or voltage is recorded",
    },
    NameplateKey {
        key: "direct_axis_reactance_pu",
        unit: "1",
        required: false,
        feeds: "x_d, the field current of a load point from its phasor diagram (predict, rating)",
    },
    NameplateKey {
        key: "quadrature_axis_reactance_pu",
        unit: "1",
        required: false,
        feeds: "x_q, the phasor diagram of a salient-pole machine (predict, rating)",
    },
    NameplateKey {
        key: "rated_power_factor",
        unit: "1",
        required: false,
        feeds: "cos phi_n, the rated point of the phasor diagram (predict, rating)",
    },
];

impl NameplateKey {
    /// The key's entry in [`NAMEPLATE_KEYS`], if it is one.
    pub fn of(key: &str) -> Option<&'static NameplateKey> {
        NAMEPLATE_KEYS.iter().find(|k| k.key == key)
    }
}

/// Machine data used by the loss model and the per-unit system (profile, table
/// "Metadata record"). Powers are in W, resistances in Ω, temperatures in °C.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Nameplate {
    /// Rated apparent power S_n, in VA: the per-unit power base.
    pub rated_apparent_power_va: f64,
    /// Rated line voltage U_n, in V.
    pub rated_voltage_v: f64,
    /// Rated armature current I_n, in A.
    pub rated_current_a: f64,
    /// Rated field current I_fn, in A (informative).
    pub rated_field_current_a: Option<f64>,
    /// Armature resistance R_a at `armature_resistance_ref_temp_c`, in Ω.
    pub armature_resistance_ohm: f64,
    /// Reference temperature of R_a, in °C.
    pub armature_resistance_ref_temp_c: f64,
    /// Field resistance R_f at `field_resistance_ref_temp_c`, in Ω.
    pub field_resistance_ohm: f64,
    /// Reference temperature of R_f, in °C.
    pub field_resistance_ref_temp_c: f64,
    /// Rated armature copper losses, in W (informative).
    pub armature_copper_losses_w: Option<f64>,
    /// Rated field copper losses, in W (informative).
    pub field_copper_losses_w: Option<f64>,
    /// Rated iron losses P_Fe, in W.
    pub iron_losses_w: f64,
    /// Rated additional losses P_add, in W.
    pub additional_losses_w: f64,
    /// Per-unit temperature base, in K (80 K in the paper).
    pub temperature_base_k: f64,
    /// Known final field winding temperature, in °C (the paper's field-temperature method).
    pub field_winding_final_temp_c: Option<f64>,
    /// Unsaturated direct-axis synchronous reactance x_d, pu (the field current of a load
    /// point from its phasor diagram; optional).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub direct_axis_reactance_pu: Option<f64>,
    /// Quadrature-axis synchronous reactance x_q, pu (optional).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub quadrature_axis_reactance_pu: Option<f64>,
    /// Rated power factor cos φ_n (optional; the rated point of the phasor diagram).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rated_power_factor: Option<f64>,
}

/// Raw nameplate key/value pairs (decimal strings), merged from the recording and a
/// machine file before they are checked.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct NameplateEntries {
    /// Key → (value, where it came from).
    entries: BTreeMap<String, (String, String)>,
}

/// A machine file: a flat TOML table of the profile's nameplate keys, each a number or
/// a decimal string. A key outside the profile is refused (serde names it and lists the
/// keys), never ignored: a misspelt key must not silently leave the recording's value.
#[derive(Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct MachineFile {
    #[serde(skip_serializing_if = "Option::is_none")]
    rated_apparent_power_mva: Option<Decimal>,
    #[serde(skip_serializing_if = "Option::is_none")]
    rated_voltage_kv: Option<Decimal>,
    #[serde(skip_serializing_if = "Option::is_none")]
    rated_current_a: Option<Decimal>,
    #[serde(skip_serializing_if = "Option::is_none")]
    rated_field_current_a: Option<Decimal>,
    #[serde(skip_serializing_if = "Option::is_none")]
    armature_resistance_ohm: Option<Decimal>,
    #[serde(skip_serializing_if = "Option::is_none")]
    armature_resistance_ref_temp_c: Option<Decimal>,
    #[serde(skip_serializing_if = "Option::is_none")]
    field_resistance_ohm: Option<Decimal>,
    #[serde(skip_serializing_if = "Option::is_none")]
    field_resistance_ref_temp_c: Option<Decimal>,
    #[serde(skip_serializing_if = "Option::is_none")]
    armature_copper_losses_kw: Option<Decimal>,
    #[serde(skip_serializing_if = "Option::is_none")]
    field_copper_losses_kw: Option<Decimal>,
    #[serde(skip_serializing_if = "Option::is_none")]
    iron_losses_kw: Option<Decimal>,
    #[serde(skip_serializing_if = "Option::is_none")]
    additional_losses_kw: Option<Decimal>,
    #[serde(skip_serializing_if = "Option::is_none")]
    temperature_base_k: Option<Decimal>,
    #[serde(skip_serializing_if = "Option::is_none")]
    field_winding_final_temp_c: Option<Decimal>,
    #[serde(skip_serializing_if = "Option::is_none")]
    direct_axis_reactance_pu: Option<Decimal>,
    #[serde(skip_serializing_if = "Option::is_none")]
    quadrature_axis_reactance_pu: Option<Decimal>,
    #[serde(skip_serializing_if = "Option::is_none")]
    rated_power_factor: Option<Decimal>,
    /// Not a key of the profile's table, but the conventional extra a machine file carries.
    #[serde(skip_serializing_if = "Option::is_none")]
    name: Option<Decimal>,
}

/// A machine-file value as the decimal string the metadata record would hold.
#[derive(Debug, Clone, Serialize)]
#[serde(transparent)]
struct Decimal(String);

impl<'de> Deserialize<'de> for Decimal {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Decimal, D::Error> {
        struct Visitor;
        impl serde::de::Visitor<'_> for Visitor {
            type Value = Decimal;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("a number or a decimal string")
            }
            fn visit_i64<E>(self, v: i64) -> std::result::Result<Decimal, E> {
                Ok(Decimal(v.to_string()))
            }
            fn visit_u64<E>(self, v: u64) -> std::result::Result<Decimal, E> {
                Ok(Decimal(v.to_string()))
            }
            fn visit_f64<E>(self, v: f64) -> std::result::Result<Decimal, E> {
                Ok(Decimal(v.to_string()))
            }
            fn visit_str<E>(self, v: &str) -> std::result::Result<Decimal, E> {
                Ok(Decimal(v.to_owned()))
            }
        }
        d.deserialize_any(Visitor)
    }
}

impl NameplateEntries {
    /// Entries from a metadata record's map; `source` names the file for messages.
    pub fn from_map(map: &BTreeMap<String, String>, source: &str) -> Self {
        let entries = map
            .iter()
            .map(|(k, v)| (k.clone(), (v.trim().to_owned(), source.to_owned())))
            .collect();
        NameplateEntries { entries }
    }

    /// Entries from a TOML machine file: a flat table of the profile's keys with
    /// number or string values.
    pub fn from_toml_file(path: &Path) -> Result<Self> {
        let bad = |message: String| RecordingError::BadMachineFile {
            path: path.to_owned(),
            message,
        };
        let text = std::fs::read_to_string(path).map_err(|e| bad(format!("cannot read: {e}")))?;
        let file: MachineFile =
            toml::from_str(&text).map_err(|e| bad(crate::toml_message::located(&text, &e)))?;
        let table = toml::Table::try_from(&file).map_err(|e| bad(e.to_string()))?;
        let source = path.display().to_string();
        let entries = table
            .into_iter()
            .filter_map(|(key, value)| match value {
                toml::Value::String(text) => Some((key, (text, source.clone()))),
                _ => None,
            })
            .collect();
        Ok(NameplateEntries { entries })
    }

    /// These entries with every key of `overrides` replacing ours.
    pub fn overridden_by(mut self, overrides: &NameplateEntries) -> Self {
        for (k, v) in &overrides.entries {
            self.entries.insert(k.clone(), v.clone());
        }
        self
    }

    /// Whether no entry is present.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// The raw key/value pairs.
    pub fn iter(&self) -> impl Iterator<Item = (&str, &str)> {
        self.entries
            .iter()
            .map(|(k, (v, _))| (k.as_str(), v.as_str()))
    }

    /// The value of `key` as a number, if it is present and a finite decimal number.
    pub fn value(&self, key: &str) -> Option<f64> {
        let (text, _) = self.entries.get(key)?;
        text.parse::<f64>().ok().filter(|v| v.is_finite())
    }

    fn bad_value(&self, key: &str, requirement: &'static str) -> RecordingError {
        let (value, source) = self.entries.get(key).cloned().unwrap_or_default();
        RecordingError::BadNameplateValue {
            path: source.into(),
            key: key.to_owned(),
            value,
            requirement,
        }
    }

    fn number(&self, key: &str) -> Result<Option<f64>> {
        let Some((text, _)) = self.entries.get(key) else {
            return Ok(None);
        };
        match text.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(Some(v)),
            Ok(_) => Err(self.bad_value(key, "a finite number")),
            Err(_) => Err(self.bad_value(key, "a decimal number")),
        }
    }

    fn required(&self, key: &str, recording: &str) -> Result<f64> {
        self.number(key)?
            .ok_or_else(|| RecordingError::MissingNameplateKeys {
                path: recording.into(),
                keys: key.to_owned(),
                count: 1,
            })
    }

    fn positive(&self, key: &str, recording: &str) -> Result<f64> {
        let v = self.required(key, recording)?;
        if v <= 0.0 {
            return Err(self.bad_value(key, "positive"));
        }
        Ok(v)
    }

    fn optional_positive(&self, key: &str) -> Result<Option<f64>> {
        match self.number(key)? {
            Some(v) if v <= 0.0 => Err(self.bad_value(key, "positive")),
            v => Ok(v),
        }
    }

    /// The required keys ([`NAMEPLATE_KEYS`]) these entries lack, in the profile's order.
    pub fn missing_required(&self) -> Vec<&'static NameplateKey> {
        NAMEPLATE_KEYS
            .iter()
            .filter(|k| k.required && !self.entries.contains_key(k.key))
            .collect()
    }

    /// Checks the entries and converts them to a [`Nameplate`]; `recording` names
    /// the recording in the message for missing keys, which are named all at once.
    pub fn resolve(&self, recording: &str) -> Result<Nameplate> {
        let missing = self.missing_required();
        if !missing.is_empty() {
            return Err(RecordingError::MissingNameplateKeys {
                path: recording.into(),
                keys: missing
                    .iter()
                    .map(|k| format!("{} ({}: {})", k.key, k.unit, k.feeds))
                    .collect::<Vec<_>>()
                    .join("; "),
                count: missing.len(),
            });
        }
        let r = recording;
        let nonneg = |key: &str| -> Result<f64> {
            let v = self.required(key, r)?;
            if v < 0.0 {
                return Err(self.bad_value(key, "not negative"));
            }
            Ok(v)
        };
        Ok(Nameplate {
            rated_apparent_power_va: self.positive("rated_apparent_power_mva", r)? * 1e6,
            rated_voltage_v: self.positive("rated_voltage_kv", r)? * 1e3,
            rated_current_a: self.positive("rated_current_a", r)?,
            rated_field_current_a: self.number("rated_field_current_a")?,
            armature_resistance_ohm: self.positive("armature_resistance_ohm", r)?,
            armature_resistance_ref_temp_c: self.required("armature_resistance_ref_temp_c", r)?,
            field_resistance_ohm: self.positive("field_resistance_ohm", r)?,
            field_resistance_ref_temp_c: self.required("field_resistance_ref_temp_c", r)?,
            armature_copper_losses_w: self.number("armature_copper_losses_kw")?.map(|v| v * 1e3),
            field_copper_losses_w: self.number("field_copper_losses_kw")?.map(|v| v * 1e3),
            iron_losses_w: nonneg("iron_losses_kw")? * 1e3,
            additional_losses_w: nonneg("additional_losses_kw")? * 1e3,
            temperature_base_k: self.positive("temperature_base_k", r)?,
            field_winding_final_temp_c: self.number("field_winding_final_temp_c")?,
            direct_axis_reactance_pu: self.optional_positive("direct_axis_reactance_pu")?,
            quadrature_axis_reactance_pu: self.optional_positive("quadrature_axis_reactance_pu")?,
            rated_power_factor: match self.number("rated_power_factor")? {
                Some(v) if !(v > 0.0 && v <= 1.0) => {
                    return Err(self.bad_value("rated_power_factor", "in (0, 1]"))
                }
                v => v,
            },
        })
    }
}

impl Nameplate {
    /// Table 1 of the paper (the refurbished 100 MVA hydro generator), with the
    /// paper's 80 K temperature base and 81 °C final field winding temperature.
    pub fn paper_table1() -> Nameplate {
        Nameplate {
            rated_apparent_power_va: 100e6,
            rated_voltage_v: 15.65e3,
            rated_current_a: 3689.14,
            rated_field_current_a: Some(1092.0),
            armature_resistance_ohm: 0.005155,
            armature_resistance_ref_temp_c: 20.0,
            field_resistance_ohm: 0.1422,
            field_resistance_ref_temp_c: 21.0,
            armature_copper_losses_w: Some(272.4e3),
            field_copper_losses_w: Some(222.5e3),
            iron_losses_w: 244.8e3,
            additional_losses_w: 143.6e3,
            temperature_base_k: 80.0,
            field_winding_final_temp_c: Some(81.0),
            direct_axis_reactance_pu: None,
            quadrature_axis_reactance_pu: None,
            rated_power_factor: None,
        }
    }

    /// The nameplate as the profile's metadata record (decimal strings).
    pub fn to_record(&self) -> BTreeMap<String, String> {
        let mut m = BTreeMap::new();
        let mut put = |k: &str, v: f64| {
            m.insert(k.to_owned(), format!("{v}"));
        };
        put(
            "rated_apparent_power_mva",
            self.rated_apparent_power_va / 1e6,
        );
        put("rated_voltage_kv", self.rated_voltage_v / 1e3);
        put("rated_current_a", self.rated_current_a);
        if let Some(v) = self.rated_field_current_a {
            put("rated_field_current_a", v);
        }
        put("armature_resistance_ohm", self.armature_resistance_ohm);
        put(
            "armature_resistance_ref_temp_c",
            self.armature_resistance_ref_temp_c,
        );
        put("field_resistance_ohm", self.field_resistance_ohm);
        put(
            "field_resistance_ref_temp_c",
            self.field_resistance_ref_temp_c,
        );
        if let Some(v) = self.armature_copper_losses_w {
            put("armature_copper_losses_kw", v / 1e3);
        }
        if let Some(v) = self.field_copper_losses_w {
            put("field_copper_losses_kw", v / 1e3);
        }
        put("iron_losses_kw", self.iron_losses_w / 1e3);
        put("additional_losses_kw", self.additional_losses_w / 1e3);
        put("temperature_base_k", self.temperature_base_k);
        for (key, value) in [
            (
                "field_winding_final_temp_c",
                self.field_winding_final_temp_c,
            ),
            ("direct_axis_reactance_pu", self.direct_axis_reactance_pu),
            (
                "quadrature_axis_reactance_pu",
                self.quadrature_axis_reactance_pu,
            ),
            ("rated_power_factor", self.rated_power_factor),
        ] {
            if let Some(v) = value {
                put(key, v);
            }
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn record_round_trips() {
        let np = Nameplate::paper_table1();
        let entries = NameplateEntries::from_map(&np.to_record(), "x.mcap");
        assert_eq!(entries.resolve("x.mcap").unwrap(), np);
    }

    #[test]
    fn missing_key_is_named() {
        let mut rec = Nameplate::paper_table1().to_record();
        rec.remove("iron_losses_kw");
        let err = NameplateEntries::from_map(&rec, "x.mcap")
            .resolve("x.mcap")
            .unwrap_err();
        let msg = err.to_string();
        assert!(
            msg.contains("iron_losses_kw") && msg.starts_with("x.mcap"),
            "{msg}"
        );
    }

    #[test]
    fn machine_file_overrides_keys() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.toml");
        std::fs::write(
            &path,
            "temperature_base_k = 100\nrated_voltage_kv = \"16.0\"\n",
        )
        .unwrap();
        let file = NameplateEntries::from_toml_file(&path).unwrap();
        let merged = NameplateEntries::from_map(&Nameplate::paper_table1().to_record(), "x.mcap")
            .overridden_by(&file);
        let np = merged.resolve("x.mcap").unwrap();
        assert_eq!(np.temperature_base_k, 100.0);
        assert_eq!(np.rated_voltage_v, 16000.0);
        assert_eq!(np.rated_current_a, 3689.14);
    }

    #[test]
    fn machine_file_with_unknown_key_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.toml");
        std::fs::write(&path, "rated_power = 100\n").unwrap();
        let err = NameplateEntries::from_toml_file(&path)
            .unwrap_err()
            .to_string();
        assert!(err.contains("rated_power"), "{err}");
    }

    #[test]
    fn non_numeric_value_is_named() {
        let mut rec = Nameplate::paper_table1().to_record();
        rec.insert("rated_current_a".into(), "lots".into());
        let err = NameplateEntries::from_map(&rec, "x.mcap")
            .resolve("x.mcap")
            .unwrap_err();
        assert!(err.to_string().contains("rated_current_a"));
    }

    #[test]
    fn machine_file_values_are_numbers_or_decimal_strings() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.toml");
        std::fs::write(
            &path,
            "rated_current_a = 3689\niron_losses_kw = 244.8\nname = \"G1\"\n",
        )
        .unwrap();
        let file = NameplateEntries::from_toml_file(&path).unwrap();
        let entries: Vec<(&str, &str)> = file.iter().collect();
        assert_eq!(
            entries,
            vec![
                ("iron_losses_kw", "244.8"),
                ("name", "G1"),
                ("rated_current_a", "3689")
            ]
        );
        std::fs::write(&path, "rated_current_a = true\n").unwrap();
        let err = NameplateEntries::from_toml_file(&path)
            .unwrap_err()
            .to_string();
        assert!(err.contains("a number or a decimal string"), "{err}");
        std::fs::write(&path, "[machine]\nrated_current_a = 3\n").unwrap();
        let err = NameplateEntries::from_toml_file(&path)
            .unwrap_err()
            .to_string();
        assert!(err.contains("machine"), "{err}");
    }

    #[test]
    fn resolve_errors_carry_key_value_and_source() {
        let mut rec = Nameplate::paper_table1().to_record();
        rec.insert("temperature_base_k".into(), "-80".into());
        let err = NameplateEntries::from_map(&rec, "x.mcap")
            .resolve("x.mcap")
            .unwrap_err();
        let RecordingError::BadNameplateValue {
            path,
            key,
            value,
            requirement,
        } = &err
        else {
            panic!("{err}");
        };
        assert_eq!(
            (path.to_str(), key.as_str(), value.as_str(), *requirement),
            (Some("x.mcap"), "temperature_base_k", "-80", "positive")
        );
        rec.remove("rated_voltage_kv");
        let err = NameplateEntries::from_map(&rec, "x.mcap")
            .resolve("y.mcap")
            .unwrap_err();
        assert!(
            matches!(&err, RecordingError::MissingNameplateKeys { path, keys, count: 1 } if path.to_str() == Some("y.mcap") && keys.starts_with("rated_voltage_kv (kV")),
            "{err}"
        );
    }

    #[test]
    fn every_missing_key_is_named_at_once() {
        let err = NameplateEntries::default().resolve("x.mcap").unwrap_err();
        let msg = err.to_string();
        let required: Vec<&str> = NAMEPLATE_KEYS
            .iter()
            .filter(|k| k.required)
            .map(|k| k.key)
            .collect();
        assert_eq!(required.len(), 10);
        for key in &required {
            assert!(msg.contains(&format!("{key} (")), "{key} not in {msg}");
        }
        assert!(
            msg.contains("10 required key(s)") && !msg.contains('\n'),
            "{msg}"
        );
        // Every key the resolver reads is in the table, and no other.
        let record = Nameplate {
            rated_field_current_a: Some(1.0),
            direct_axis_reactance_pu: Some(1.0),
            quadrature_axis_reactance_pu: Some(0.6),
            rated_power_factor: Some(0.9),
            ..Nameplate::paper_table1()
        }
        .to_record();
        let mut keys: Vec<&str> = record.keys().map(String::as_str).collect();
        let mut table: Vec<&str> = NAMEPLATE_KEYS.iter().map(|k| k.key).collect();
        keys.sort_unstable();
        table.sort_unstable();
        assert_eq!(keys, table);
    }
}
