//! The machine's nameplate: the `heatrun.nameplate` metadata record, overridden
//! key by key by a machine file (`--machine FILE.toml`).

use std::collections::BTreeMap;
use std::path::Path;

use serde::Serialize;

use crate::error::{Error, Result};

/// Name of the MCAP metadata record that holds the nameplate.
pub const NAMEPLATE_RECORD: &str = "heatrun.nameplate";

/// Machine data used by the loss model and the per-unit system (profile, table
/// "Metadata record"). Powers are in W, resistances in Ω, temperatures in °C.
#[derive(Debug, Clone, PartialEq, Serialize)]
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
}

/// Raw nameplate key/value pairs (decimal strings), merged from the recording and a
/// machine file before they are checked.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct NameplateEntries {
    /// Key → (value, where it came from).
    entries: BTreeMap<String, (String, String)>,
}

/// Every key the profile defines, with whether the loss model needs it.
const KEYS: [(&str, bool); 15] = [
    ("rated_apparent_power_mva", true),
    ("rated_voltage_kv", true),
    ("rated_current_a", true),
    ("rated_field_current_a", false),
    ("armature_resistance_ohm", true),
    ("armature_resistance_ref_temp_c", true),
    ("field_resistance_ohm", true),
    ("field_resistance_ref_temp_c", true),
    ("armature_copper_losses_kw", false),
    ("field_copper_losses_kw", false),
    ("iron_losses_kw", true),
    ("additional_losses_kw", true),
    ("temperature_base_k", true),
    ("field_winding_final_temp_c", false),
    // Not a key of the profile's table, but the conventional extra a machine file may carry.
    ("name", false),
];

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
        let bad = |message: String| Error::BadMachineFile {
            path: path.to_owned(),
            message,
        };
        let text = std::fs::read_to_string(path).map_err(|e| bad(format!("cannot read: {e}")))?;
        let table: toml::Table = text
            .parse()
            .map_err(|e: toml::de::Error| bad(format!("not TOML: {}", e.message())))?;
        let source = path.display().to_string();
        let mut entries = BTreeMap::new();
        for (key, value) in table {
            if !KEYS.iter().any(|(k, _)| *k == key) {
                return Err(bad(format!(
                    "unknown key `{key}`; the nameplate keys are {}",
                    KEYS.iter().map(|(k, _)| *k).collect::<Vec<_>>().join(", ")
                )));
            }
            let text = match value {
                toml::Value::Integer(i) => i.to_string(),
                toml::Value::Float(f) => f.to_string(),
                toml::Value::String(s) => s,
                other => {
                    return Err(bad(format!(
                        "key `{key}` must be a number, not a {}",
                        other.type_str()
                    )))
                }
            };
            entries.insert(key, (text, source.clone()));
        }
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

    fn number(&self, key: &str, recording: &str) -> Result<Option<f64>> {
        let Some((text, source)) = self.entries.get(key) else {
            return Ok(None);
        };
        let value: f64 = text.parse().map_err(|_| Error::BadRecording {
            path: source.into(),
            message: format!("nameplate key `{key}` is `{text}`, not a decimal number"),
        })?;
        if !value.is_finite() {
            return Err(Error::BadRecording {
                path: source.into(),
                message: format!("nameplate key `{key}` is `{text}`, not a finite number"),
            });
        }
        let _ = recording;
        Ok(Some(value))
    }

    fn required(&self, key: &str, recording: &str) -> Result<f64> {
        self.number(key, recording)?.ok_or_else(|| Error::BadRecording {
            path: recording.into(),
            message: format!(
                "nameplate key `{key}` is missing: the recording's `{NAMEPLATE_RECORD}` record does not \
                 have it; give it in a machine file with --machine FILE.toml"
            ),
        })
    }

    fn positive(&self, key: &str, recording: &str) -> Result<f64> {
        let v = self.required(key, recording)?;
        if v <= 0.0 {
            let source = self
                .entries
                .get(key)
                .map(|(_, s)| s.clone())
                .unwrap_or_default();
            return Err(Error::BadRecording {
                path: source.into(),
                message: format!("nameplate key `{key}` must be positive, is {v}"),
            });
        }
        Ok(v)
    }

    /// Checks the entries and converts them to a [`Nameplate`]; `recording` names
    /// the recording in the message for a missing key.
    pub fn resolve(&self, recording: &str) -> Result<Nameplate> {
        let r = recording;
        let nonneg = |key: &str| -> Result<f64> {
            let v = self.required(key, r)?;
            if v < 0.0 {
                return Err(Error::BadRecording {
                    path: r.into(),
                    message: format!("nameplate key `{key}` must not be negative, is {v}"),
                });
            }
            Ok(v)
        };
        Ok(Nameplate {
            rated_apparent_power_va: self.positive("rated_apparent_power_mva", r)? * 1e6,
            rated_voltage_v: self.positive("rated_voltage_kv", r)? * 1e3,
            rated_current_a: self.positive("rated_current_a", r)?,
            rated_field_current_a: self.number("rated_field_current_a", r)?,
            armature_resistance_ohm: self.positive("armature_resistance_ohm", r)?,
            armature_resistance_ref_temp_c: self.required("armature_resistance_ref_temp_c", r)?,
            field_resistance_ohm: self.positive("field_resistance_ohm", r)?,
            field_resistance_ref_temp_c: self.required("field_resistance_ref_temp_c", r)?,
            armature_copper_losses_w: self
                .number("armature_copper_losses_kw", r)?
                .map(|v| v * 1e3),
            field_copper_losses_w: self.number("field_copper_losses_kw", r)?.map(|v| v * 1e3),
            iron_losses_w: nonneg("iron_losses_kw")? * 1e3,
            additional_losses_w: nonneg("additional_losses_kw")? * 1e3,
            temperature_base_k: self.positive("temperature_base_k", r)?,
            field_winding_final_temp_c: self.number("field_winding_final_temp_c", r)?,
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
        if let Some(v) = self.field_winding_final_temp_c {
            put("field_winding_final_temp_c", v);
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
}
