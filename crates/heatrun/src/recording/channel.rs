//! Heat-run channels: what a channel record says (signal, unit, sensor, how it was
//! stored), checked against the profile.
//!
//! A channel whose quantity (metadata `quantity`, else the topic's last segment) is one
//! of the profile's is read and converted to the quantity's canonical unit; a channel a
//! model spec names ([`ReadOptions::free_channels`](super::reader::ReadOptions)) is read
//! as a free signal, its unit kept as written; any other channel is listed and skipped.

use std::collections::{BTreeMap, BTreeSet};

use serde::Serialize;

use super::quantity::{Quantity, Signal};

/// Schema name of a heat-run sample channel.
pub const SAMPLE_SCHEMA_NAME: &str = "heatrun.Sample";
/// Schema encoding of a heat-run sample channel.
pub const SAMPLE_SCHEMA_ENCODING: &str = "jsonschema";
/// Message encoding of a heat-run sample channel.
pub const SAMPLE_MESSAGE_ENCODING: &str = "json";

/// Every channel metadata key the profile and heatrun read (the reference page lists the
/// same; a test holds them together). `resolution` is the sensor's quantisation step in the
/// channel's unit (optional).
pub const CHANNEL_METADATA_KEYS: [&str; 8] = [
    "quantity",
    "unit",
    "sensor",
    "storage",
    "deadband",
    "max_interval_s",
    "interpolation",
    "resolution",
];

/// How a channel's samples were stored (channel metadata `storage`).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Storage {
    /// Samples at a nominal rate (the profile's default): a longer silence is a gap.
    #[default]
    Sampled,
    /// Stored by exception, as historians do: a sample only when the value moved by more
    /// than `deadband` since the last stored one, or when `max_interval_s` passed without
    /// one. A silence shorter than that is an unchanged value, not a gap.
    Exception {
        /// The change that makes a new sample, in the channel's unit as written.
        deadband: f64,
        /// The longest time without a stored sample, s (`None`: no such limit).
        max_interval_s: Option<f64>,
    },
}

/// How a channel's value runs between two of its samples (channel metadata
/// `interpolation`), where the channel is slower than the grid or stored by exception.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Interpolation {
    /// A straight line from one sample to the next (the profile's default: a measured
    /// temperature or current moves continuously).
    #[default]
    Linear,
    /// Each sample's value stands until the next, y(t) = y(t_j) for t_j ≤ t < t_(j+1): a
    /// command or set point, which the plant holds between writes (a historian's "step"
    /// tag). Drawn as a line, a step on a 3 s record moves 1.5 s early on average.
    Step,
}

/// A heat-run channel: one sensor of one signal.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SensorChannel {
    /// Index of the channel in [`RecordingSummary::channels`](super::RecordingSummary)
    /// (and in [`Sample::channel`](super::Sample)).
    pub index: usize,
    /// The MCAP topic.
    pub topic: String,
    /// What it measures: a profile quantity, or a free channel a model spec names.
    pub signal: Signal,
    /// The `sensor` metadata value that tells several sensors of one signal apart.
    pub sensor: Option<String>,
    /// The unit as written in the recording.
    pub unit: String,
    /// Factor from `unit` to the quantity's canonical unit (1 for a free channel).
    #[serde(skip)]
    pub unit_scale: f64,
    /// How the samples were stored.
    pub storage: Storage,
    /// How the value runs between samples.
    pub interpolation: Interpolation,
    /// The sensor's resolution (the step its stored values are rounded to), in the
    /// quantity's canonical unit (metadata `resolution`, in `unit`), where the recording
    /// gives it: the decisions' noise model holds the rounding's variance r²/12.
    pub resolution: Option<f64>,
}

impl SensorChannel {
    /// The profile quantity it measures, if it is one.
    pub fn quantity(&self) -> Option<Quantity> {
        self.signal.quantity()
    }

    /// The unit of the values it delivers: the quantity's canonical unit, or for a free
    /// channel the unit as written.
    pub fn canonical_unit(&self) -> &str {
        match self.signal.quantity() {
            Some(q) => q.canonical_unit(),
            None => &self.unit,
        }
    }
}

/// A channel of the file that is not read as heat-run data, and why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IgnoredChannel {
    /// The MCAP topic.
    pub topic: String,
    /// Why it is not a heat-run channel.
    pub reason: String,
}

/// A heat-run channel record that breaks the profile.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ChannelError {
    /// The channel's schema is not the profile's sample schema.
    #[error(
        "channel {topic} carries {signal} but has {found}; the profile wants schema \
         `{SAMPLE_SCHEMA_NAME}` with encoding `{SAMPLE_SCHEMA_ENCODING}`"
    )]
    WrongSchema {
        /// The topic.
        topic: String,
        /// What it carries.
        signal: Signal,
        /// The schema found (name and encoding), or "no schema".
        found: String,
    },
    /// The channel's message encoding is not JSON.
    #[error(
        "channel {topic} has message encoding `{encoding}`; the profile wants `{SAMPLE_MESSAGE_ENCODING}`"
    )]
    WrongMessageEncoding {
        /// The topic.
        topic: String,
        /// The encoding found.
        encoding: String,
    },
    /// A profile quantity's channel has no `unit` metadata.
    #[error("channel {topic} ({quantity}) has no `unit` metadata; one of {} is required", .quantity.accepted_units().join(", "))]
    NoUnit {
        /// The topic.
        topic: String,
        /// Its quantity.
        quantity: Quantity,
    },
    /// A unit outside the quantity's row of the profile.
    #[error(
        "channel {topic} ({quantity}) has unit `{unit}`, which the profile does not accept for \
         {quantity}; use one of {}", .quantity.accepted_units().join(", ")
    )]
    UnknownUnit {
        /// The topic.
        topic: String,
        /// Its quantity.
        quantity: Quantity,
        /// The unit found.
        unit: String,
    },
    /// A metadata value that is not one the profile allows (`storage`, `deadband`, ...).
    #[error("channel {topic}: metadata `{key}` is `{value}`, not {expected}")]
    BadMetadata {
        /// The topic.
        topic: String,
        /// The metadata key.
        key: &'static str,
        /// The value found.
        value: String,
        /// What the profile allows.
        expected: &'static str,
    },
}

/// What a channel record turns out to be.
#[derive(Debug, Clone, PartialEq)]
pub enum ChannelKind {
    /// A heat-run channel, read.
    Sensor(SensorChannel),
    /// Not heat-run data, skipped.
    Ignored(IgnoredChannel),
}

/// The schema a channel refers to: (name, encoding), if the file defines it.
pub type SchemaRef<'a> = Option<(&'a str, &'a str)>;

/// Classifies the channel record `channel` (with its schema) as the `index`-th sensor
/// channel, a free channel if its name is in `free_channels`, or an ignored one.
pub fn classify(
    channel: &mcap::records::Channel,
    schema: SchemaRef<'_>,
    index: usize,
    free_channels: &BTreeSet<String>,
) -> Result<ChannelKind, ChannelError> {
    let topic = &channel.topic;
    let signal = match signal_of(channel, free_channels) {
        Ok(signal) => signal,
        Err(reason) => {
            return Ok(ChannelKind::Ignored(IgnoredChannel {
                topic: topic.clone(),
                reason,
            }))
        }
    };
    check_encodings(channel, &signal, schema)?;
    let (unit, unit_scale) = unit_of(topic, &channel.metadata, &signal)?;
    Ok(ChannelKind::Sensor(SensorChannel {
        index,
        topic: topic.clone(),
        storage: storage_of(topic, &channel.metadata)?,
        interpolation: interpolation_of(topic, &channel.metadata)?,
        resolution: resolution_of(topic, &channel.metadata, unit_scale)?,
        signal,
        sensor: channel.metadata.get("sensor").cloned(),
        unit,
        unit_scale,
    }))
}

/// The channel's signal, or why it is not read.
fn signal_of(
    channel: &mcap::records::Channel,
    free_channels: &BTreeSet<String>,
) -> Result<Signal, String> {
    let declared = channel.metadata.get("quantity");
    let name = declared
        .cloned()
        .unwrap_or_else(|| channel.topic.rsplit('/').next().unwrap_or("").to_owned());
    match Signal::from_name(&name) {
        profile @ Signal::Profile(_) => Ok(profile),
        free if free_channels.contains(&name) => Ok(free),
        _ if declared.is_some() => Err(format!("quantity `{name}` is not one of the profile's")),
        _ => Err("no `quantity` metadata and the topic names no quantity".to_owned()),
    }
}

/// Checks the schema and message encoding against the profile's.
fn check_encodings(
    channel: &mcap::records::Channel,
    signal: &Signal,
    schema: SchemaRef<'_>,
) -> Result<(), ChannelError> {
    let schema_ok = schema
        .is_some_and(|(name, enc)| name == SAMPLE_SCHEMA_NAME && enc == SAMPLE_SCHEMA_ENCODING);
    if !schema_ok {
        return Err(ChannelError::WrongSchema {
            topic: channel.topic.clone(),
            signal: signal.clone(),
            found: match schema {
                Some((name, enc)) => format!("schema `{name}` ({enc})"),
                None => "no schema".to_owned(),
            },
        });
    }
    if channel.message_encoding != SAMPLE_MESSAGE_ENCODING {
        return Err(ChannelError::WrongMessageEncoding {
            topic: channel.topic.clone(),
            encoding: channel.message_encoding.clone(),
        });
    }
    Ok(())
}

/// The unit as written and its factor to the canonical unit. A free channel keeps its
/// unit (or none) with factor 1.
fn unit_of(
    topic: &str,
    metadata: &BTreeMap<String, String>,
    signal: &Signal,
) -> Result<(String, f64), ChannelError> {
    let unit = metadata.get("unit").cloned();
    let Some(quantity) = signal.quantity() else {
        return Ok((unit.unwrap_or_default(), 1.0));
    };
    let Some(unit) = unit else {
        return Err(ChannelError::NoUnit {
            topic: topic.to_owned(),
            quantity,
        });
    };
    match quantity.unit_scale(&unit) {
        Some(scale) => Ok((unit, scale)),
        None => Err(ChannelError::UnknownUnit {
            topic: topic.to_owned(),
            quantity,
            unit,
        }),
    }
}

/// The channel's storage from its `storage`, `deadband` and `max_interval_s` metadata.
fn storage_of(topic: &str, metadata: &BTreeMap<String, String>) -> Result<Storage, ChannelError> {
    let bad = |key: &'static str, value: &str, expected: &'static str| ChannelError::BadMetadata {
        topic: topic.to_owned(),
        key,
        value: value.to_owned(),
        expected,
    };
    match metadata.get("storage").map(|s| s.trim()) {
        None | Some("sampled") => Ok(Storage::Sampled),
        Some("exception") => {
            let number = |key: &'static str, ok: fn(f64) -> bool, expected: &'static str| {
                metadata
                    .get(key)
                    .map(|text| match text.trim().parse::<f64>() {
                        Ok(v) if v.is_finite() && ok(v) => Ok(v),
                        _ => Err(bad(key, text, expected)),
                    })
                    .transpose()
            };
            Ok(Storage::Exception {
                deadband: number("deadband", |v| v >= 0.0, "a decimal number ≥ 0")?.unwrap_or(0.0),
                max_interval_s: number(
                    "max_interval_s",
                    |v| v > 0.0,
                    "a positive number of seconds",
                )?,
            })
        }
        Some(other) => Err(bad("storage", other, "`sampled` or `exception`")),
    }
}

/// The channel's resolution from its `resolution` metadata (a positive number in the
/// channel's `unit`), in the canonical unit: r · `unit_scale`.
fn resolution_of(
    topic: &str,
    metadata: &BTreeMap<String, String>,
    unit_scale: f64,
) -> Result<Option<f64>, ChannelError> {
    let Some(text) = metadata.get("resolution") else {
        return Ok(None);
    };
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(Some(v * unit_scale.abs())),
        _ => Err(ChannelError::BadMetadata {
            topic: topic.to_owned(),
            key: "resolution",
            value: text.to_owned(),
            expected: "a positive decimal number in the channel's unit",
        }),
    }
}

/// The channel's [`Interpolation`] from its `interpolation` metadata (`linear` when absent).
fn interpolation_of(
    topic: &str,
    metadata: &BTreeMap<String, String>,
) -> Result<Interpolation, ChannelError> {
    match metadata.get("interpolation").map(|s| s.trim()) {
        None | Some("linear") => Ok(Interpolation::Linear),
        Some("step") => Ok(Interpolation::Step),
        Some(other) => Err(ChannelError::BadMetadata {
            topic: topic.to_owned(),
            key: "interpolation",
            value: other.to_owned(),
            expected: "`linear` or `step`",
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(topic: &str, meta: &[(&str, &str)]) -> mcap::records::Channel {
        mcap::records::Channel {
            id: 1,
            schema_id: 1,
            topic: topic.into(),
            message_encoding: "json".into(),
            metadata: meta
                .iter()
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect(),
        }
    }

    const SCHEMA: SchemaRef<'static> = Some((SAMPLE_SCHEMA_NAME, SAMPLE_SCHEMA_ENCODING));

    fn sensor(kind: ChannelKind) -> SensorChannel {
        match kind {
            ChannelKind::Sensor(s) => s,
            ChannelKind::Ignored(i) => panic!("ignored: {i:?}"),
        }
    }

    #[test]
    fn profile_free_and_ignored_channels() {
        let none = BTreeSet::new();
        let free: BTreeSet<String> = ["T1".to_owned()].into();
        let core = sensor(
            classify(
                &record("/scada/core_temp", &[("unit", "degC")]),
                SCHEMA,
                0,
                &none,
            )
            .unwrap(),
        );
        assert_eq!(core.signal, Signal::Profile(Quantity::CoreTemp));
        assert_eq!(core.storage, Storage::Sampled);
        let t1 = record("/lab/T1", &[("unit", "degC")]);
        assert!(matches!(
            classify(&t1, SCHEMA, 0, &none).unwrap(),
            ChannelKind::Ignored(_)
        ));
        let t1 = sensor(classify(&t1, SCHEMA, 3, &free).unwrap());
        assert_eq!(
            (t1.signal.name(), t1.unit.as_str(), t1.unit_scale, t1.index),
            ("T1", "degC", 1.0, 3)
        );
        assert_eq!(t1.canonical_unit(), "degC");
        // A free channel by its `quantity` metadata; no unit is not an error for it.
        let q1 = record("/lab/heater", &[("quantity", "T1")]);
        assert_eq!(sensor(classify(&q1, SCHEMA, 0, &free).unwrap()).unit, "");
        // A free channel still has to be a sample channel.
        assert!(matches!(
            classify(&q1, Some(("x", "protobuf")), 0, &free),
            Err(ChannelError::WrongSchema { .. })
        ));
    }

    #[test]
    fn storage_metadata_is_read_and_checked() {
        let none = BTreeSet::new();
        let meta = [
            ("unit", "degC"),
            ("storage", "exception"),
            ("deadband", "0.1"),
            ("max_interval_s", "900"),
        ];
        let ch = sensor(classify(&record("/scada/core_temp", &meta), SCHEMA, 0, &none).unwrap());
        assert_eq!(
            ch.storage,
            Storage::Exception {
                deadband: 0.1,
                max_interval_s: Some(900.0)
            }
        );
        let meta = [("unit", "degC"), ("storage", "exception")];
        let ch = sensor(classify(&record("/scada/core_temp", &meta), SCHEMA, 0, &none).unwrap());
        assert_eq!(
            ch.storage,
            Storage::Exception {
                deadband: 0.0,
                max_interval_s: None
            }
        );
        for (key, value) in [
            ("storage", "sometimes"),
            ("deadband", "-1"),
            ("max_interval_s", "0"),
            ("max_interval_s", "soon"),
        ] {
            let mut meta = vec![("unit", "degC"), ("storage", "exception")];
            meta.retain(|(k, _)| *k != key);
            meta.push((key, value));
            let err = classify(&record("/scada/core_temp", &meta), SCHEMA, 0, &none).unwrap_err();
            let msg = err.to_string();
            assert!(
                msg.contains("/scada/core_temp") && msg.contains(key) && msg.contains(value),
                "{msg}"
            );
        }
    }

    #[test]
    fn interpolation_metadata_is_read_and_checked() {
        let none = BTreeSet::new();
        let free: BTreeSet<String> = ["Q1".to_owned()].into();
        let of = |meta: &[(&str, &str)]| classify(&record("/lab/Q1", meta), SCHEMA, 0, &free);
        assert_eq!(
            sensor(of(&[]).unwrap()).interpolation,
            Interpolation::Linear
        );
        let step = of(&[("interpolation", "step")]).unwrap();
        assert_eq!(sensor(step).interpolation, Interpolation::Step);
        let linear = of(&[("interpolation", "linear")]).unwrap();
        assert_eq!(sensor(linear).interpolation, Interpolation::Linear);
        let msg = of(&[("interpolation", "held")]).unwrap_err().to_string();
        assert!(
            msg.contains("/lab/Q1") && msg.contains("interpolation") && msg.contains("held"),
            "{msg}"
        );
        let core = record("/scada/core_temp", &[("unit", "degC")]);
        let core = sensor(classify(&core, SCHEMA, 0, &none).unwrap());
        assert_eq!(core.interpolation, Interpolation::Linear);
    }

    #[test]
    fn units_outside_the_profile_are_named() {
        let none = BTreeSet::new();
        let err = classify(
            &record("/scada/line_voltage", &[("unit", "MV")]),
            SCHEMA,
            0,
            &none,
        )
        .unwrap_err();
        assert!(
            err.to_string().contains("`MV`") && err.to_string().contains("V, kV"),
            "{err}"
        );
        let err = classify(&record("/scada/line_voltage", &[]), SCHEMA, 0, &none).unwrap_err();
        assert_eq!(
            err,
            ChannelError::NoUnit {
                topic: "/scada/line_voltage".into(),
                quantity: Quantity::LineVoltage
            }
        );
    }
}
