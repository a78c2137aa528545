//! The load schedule: a CSV of operating points against time, read with the `csv` crate.
//!
//! A header row, a `time_s` column (seconds from the start, increasing, any spacing),
//! and per row either the electrical point itself (`armature_current_a`,
//! `field_current_a`, `line_voltage_kv`) or the apparent power with its power factor
//! (`apparent_power_mva`, `power_factor`, optional `line_voltage_kv`, default the rated
//! voltage), whose field current follows the phasor diagram ([`super::phasor`]).
//! Optional: `coolant_inlet_temp_c`, and a column per channel a spec model's inputs read.
//! Each row holds until the next; the last row ends the schedule.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::phasor::PhasorMachine;
use crate::model_file::{ThermalModel, UseError};
use crate::spec::{InputSource, Reference};

/// The load schedule's column of the coolant inlet temperature.
pub const COOLANT_COLUMN: &str = "coolant_inlet_temp_c";

/// An operating point of the machine (and its surroundings).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct OperatingPoint {
    /// Armature current I_g, A.
    pub armature_current_a: f64,
    /// Field current I_f, A.
    pub field_current_a: f64,
    /// Line voltage U_g, V.
    pub line_voltage_v: f64,
    /// Coolant inlet temperature, °C, where given.
    pub coolant_inlet_c: Option<f64>,
    /// Other channels a spec model's inputs read, by channel name.
    pub channels: BTreeMap<String, f64>,
}

/// A load schedule: operating points from their times on.
#[derive(Debug, Clone)]
pub struct LoadSchedule {
    /// The file it came from.
    pub path: PathBuf,
    /// Times, s from the start, strictly increasing.
    pub time_s: Vec<f64>,
    /// The point held from each time until the next.
    pub points: Vec<OperatingPoint>,
    /// The apparent power of each row, MVA (given or computed), and its power factor.
    pub apparent_power: Vec<(f64, f64)>,
    /// What was assumed (typical reactances).
    pub warnings: Vec<String>,
}

impl LoadSchedule {
    /// The point held at `t_s` (the last row at or before it; the first before the start).
    pub fn point_at(&self, t_s: f64) -> &OperatingPoint {
        let k = self.time_s.partition_point(|&t| t <= t_s + 1e-9);
        &self.points[k.saturating_sub(1)]
    }

    /// Start and end of the schedule, s.
    pub fn span_s(&self) -> (f64, f64) {
        (
            self.time_s[0],
            *self.time_s.last().unwrap_or(&self.time_s[0]),
        )
    }
}

/// Which columns the file has, by role.
struct Columns {
    index: BTreeMap<String, usize>,
    direct: bool,
}

impl Columns {
    fn get(&self, name: &str) -> Option<usize> {
        self.index.get(name).copied()
    }
}

/// The channel columns a model's inputs (and references) read, beyond the standard ones.
fn channel_columns(model: &ThermalModel) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    let inlet = crate::recording::Quantity::CoolingWaterInletTemp.name();
    let mut add = |c: &str| {
        if c != inlet && !names.iter().any(|n| n == c) {
            names.push(c.to_owned());
        }
    };
    for i in &model.inputs {
        match &i.source {
            InputSource::Channel(c) | InputSource::BoundaryRise(c) => add(c.name()),
            InputSource::Expression(e) => e.channels().iter().for_each(|c| add(c.name())),
            InputSource::Loss(_) | InputSource::CoolantFlow { .. } => {}
        }
    }
    for s in &model.states {
        if let Reference::Channel(c) | Reference::InitialOf(c) = &s.reference {
            add(c.name());
        }
    }
    names
}

const STANDARD: [&str; 7] = [
    "time_s",
    "armature_current_a",
    "field_current_a",
    "line_voltage_kv",
    "apparent_power_mva",
    "power_factor",
    COOLANT_COLUMN,
];

fn header(
    path: &Path,
    record: &csv::StringRecord,
    model: &ThermalModel,
) -> Result<Columns, UseError> {
    let extra = channel_columns(model);
    let mut index = BTreeMap::new();
    for (i, cell) in record.iter().enumerate() {
        let name = cell.trim().trim_start_matches('\u{feff}');
        if !STANDARD.contains(&name) && !extra.iter().any(|e| e == name) {
            let known: Vec<&str> = STANDARD
                .iter()
                .copied()
                .chain(extra.iter().map(String::as_str))
                .collect();
            return Err(UseError::UnknownColumn {
                path: path.to_owned(),
                column: name.to_owned(),
                known: known.join(", "),
            });
        }
        index.insert(name.to_owned(), i);
    }
    let missing = |column: &str, why| UseError::MissingColumn {
        path: path.to_owned(),
        column: column.into(),
        why,
    };
    let has = |c: &str| index.contains_key(c);
    if !has("time_s") {
        return Err(missing("time_s", "seconds from the start of the schedule"));
    }
    let needs_electrical = model
        .inputs
        .iter()
        .any(|i| matches!(i.source, InputSource::Loss(_)));
    let direct = has("armature_current_a") || has("field_current_a");
    if needs_electrical {
        if direct {
            for c in ["armature_current_a", "field_current_a", "line_voltage_kv"] {
                if !has(c) {
                    return Err(missing(c, "the loss model needs I_g, I_f and U_g together"));
                }
            }
        } else if !has("apparent_power_mva") || !has("power_factor") {
            let c = if has("apparent_power_mva") {
                "power_factor"
            } else {
                "apparent_power_mva"
            };
            return Err(missing(
                c,
                "give armature_current_a, field_current_a and line_voltage_kv, or apparent_power_mva with power_factor",
            ));
        }
    }
    for c in &extra {
        if !has(c) {
            return Err(missing(c, "an input of the model reads this channel"));
        }
    }
    Ok(Columns { index, direct })
}

/// One row's cells, read by column name.
struct Row<'a> {
    path: &'a Path,
    line: u64,
    record: &'a csv::StringRecord,
    columns: &'a Columns,
}

impl Row<'_> {
    fn number(&self, column: &str) -> Result<Option<f64>, UseError> {
        let Some(i) = self.columns.get(column) else {
            return Ok(None);
        };
        let text = self.record.get(i).unwrap_or("").trim();
        match text.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(Some(v)),
            _ => Err(self.bad(column, text, "a finite number")),
        }
    }

    fn bad(&self, column: &str, value: &str, requirement: &'static str) -> UseError {
        UseError::BadCell {
            path: self.path.to_owned(),
            row: self.line,
            column: column.to_owned(),
            value: value.to_owned(),
            requirement,
        }
    }

    fn non_negative(&self, column: &str) -> Result<Option<f64>, UseError> {
        match self.number(column)? {
            Some(v) if v < 0.0 => Err(self.bad(column, &v.to_string(), "a number ≥ 0")),
            v => Ok(v),
        }
    }
}

/// Reads a load schedule for `model`.
pub fn read(path: &Path, model: &ThermalModel) -> Result<LoadSchedule, UseError> {
    let file = std::fs::File::open(path).map_err(|source| UseError::Read {
        path: path.to_owned(),
        source,
    })?;
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(true)
        .trim(csv::Trim::All)
        .from_reader(std::io::BufReader::new(file));
    let table_error = |e: csv::Error| UseError::BadTable {
        path: path.to_owned(),
        message: e.to_string(),
    };
    let head = reader.headers().map_err(table_error)?.clone();
    let columns = header(path, &head, model)?;
    let np = model.nameplate.as_ref();
    let phasor = match (columns.direct, np) {
        (false, Some(np)) if columns.get("apparent_power_mva").is_some() => {
            Some(PhasorMachine::from_nameplate(np).ok_or_else(|| {
                model.missing(
                    "nameplate.rated_field_current_a",
                    "the field current of an apparent-power schedule needs",
                )
            })?)
        }
        _ => None,
    };
    let mut schedule = LoadSchedule {
        path: path.to_owned(),
        time_s: Vec::new(),
        points: Vec::new(),
        apparent_power: Vec::new(),
        warnings: phasor.as_ref().map(|p| p.1.clone()).unwrap_or_default(),
    };
    let mut record = csv::StringRecord::new();
    while reader.read_record(&mut record).map_err(table_error)? {
        let line = record.position().map_or(0, |p| p.line());
        let row = Row {
            path,
            line,
            record: &record,
            columns: &columns,
        };
        let t = row.number("time_s")?.unwrap_or(0.0);
        if let Some(&previous_s) = schedule.time_s.last() {
            if t <= previous_s {
                return Err(UseError::TimeBackwards {
                    path: path.to_owned(),
                    row: line,
                    time_s: t,
                    previous_s,
                });
            }
        }
        if let Some(&first_s) = schedule.time_s.first() {
            let steps = (t - first_s) / model.ts_s;
            if steps > super::MAX_PREDICTION_STEPS as f64 {
                return Err(UseError::ScheduleTooLong {
                    path: path.to_owned(),
                    row: line,
                    time_s: t,
                    steps,
                    ts_s: model.ts_s,
                    max: super::MAX_PREDICTION_STEPS,
                });
            }
        }
        let (point, s) = operating_point(&row, model, phasor.as_ref().map(|p| &p.0))?;
        schedule.time_s.push(t);
        schedule.points.push(point);
        schedule.apparent_power.push(s);
    }
    if schedule.time_s.is_empty() {
        return Err(UseError::BadTable {
            path: path.to_owned(),
            message: "no rows under the header".into(),
        });
    }
    Ok(schedule)
}

/// One row's operating point and its (S in MVA, cos φ).
fn operating_point(
    row: &Row,
    model: &ThermalModel,
    phasor: Option<&PhasorMachine>,
) -> Result<(OperatingPoint, (f64, f64)), UseError> {
    let rated_voltage_v = model
        .nameplate
        .as_ref()
        .map_or(f64::NAN, |n| n.rated_voltage_v);
    let voltage_v = row
        .non_negative("line_voltage_kv")?
        .map_or(rated_voltage_v, |u| u * 1e3);
    let mut point = OperatingPoint {
        line_voltage_v: voltage_v,
        coolant_inlet_c: row.number(COOLANT_COLUMN)?,
        ..OperatingPoint::default()
    };
    for c in channel_columns(model) {
        if let Some(v) = row.number(&c)? {
            point.channels.insert(c, v);
        }
    }
    let sqrt3 = 3f64.sqrt();
    let apparent = if row.columns.direct {
        point.armature_current_a = row.non_negative("armature_current_a")?.unwrap_or(0.0);
        point.field_current_a = row.non_negative("field_current_a")?.unwrap_or(0.0);
        (sqrt3 * voltage_v * point.armature_current_a / 1e6, f64::NAN)
    } else if let Some(machine) = phasor {
        let s_mva = row.non_negative("apparent_power_mva")?.unwrap_or(0.0);
        let pf = row.number("power_factor")?.unwrap_or(f64::NAN);
        if !(pf.abs() > 0.0 && pf.abs() <= 1.0) {
            let text = row.record.get(row.columns.get("power_factor").unwrap_or(0));
            return Err(row.bad(
                "power_factor",
                text.unwrap_or(""),
                "a power factor in (0, 1] (negative: leading)",
            ));
        }
        let np = model.nameplate.as_ref();
        let (u_n, i_n) = np.map_or((f64::NAN, f64::NAN), |n| {
            (n.rated_voltage_v, n.rated_current_a)
        });
        if voltage_v <= 0.0 {
            return Err(row.bad("line_voltage_kv", "0", "a positive voltage"));
        }
        point.armature_current_a = s_mva * 1e6 / (sqrt3 * voltage_v);
        point.field_current_a =
            machine.field_current_a(voltage_v / u_n, point.armature_current_a / i_n, pf);
        (s_mva, pf)
    } else {
        (f64::NAN, f64::NAN)
    };
    Ok((point, apparent))
}
