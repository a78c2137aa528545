//! The fleet table: one row per recording (its time constants, fit and steady state, read
//! from its report), as text and as `fleet-summary.csv`.

use std::path::Path;

use serde::Deserialize;

use crate::model_file::{Report, UseError};
use crate::spec::{ModelDescription, StateDescription};

/// The fleet table's file name, in the fleet's output folder or prefix.
pub const SUMMARY_FILE: &str = "fleet-summary.csv";

/// The fleet table could not be written.
#[derive(Debug, thiserror::Error)]
#[error("{SUMMARY_FILE}: {0}")]
pub struct FleetError(String);

/// What the fleet table shows of one recording: its report's `time_constants_s`,
/// `fit.nrmse_fit_percent` and `steady_state.temperature_c`, and whether
/// `recording.data_loss` lists anything; so a table made by the fleet replay and one
/// gathered from a cluster's reports agree.
#[derive(Debug, Clone, PartialEq)]
pub struct FleetFigures {
    /// The model's time constants T_i = −Ts / ln λ_i, s.
    pub time_constants_s: Vec<f64>,
    /// Each state's fit, NRMSE % = 100 (1 − ‖y − ŷ‖ / ‖y − ȳ‖).
    pub nrmse_fit_percent: Vec<f64>,
    /// Each state's steady-state temperature at the rated input, °C.
    pub steady_state_c: Vec<f64>,
    /// Whether part of the recording was damaged and skipped.
    pub data_lost: bool,
}

/// A report as the fleet table reads it, from its JSON: the same text, parsed the same way,
/// whether the report was just made (the fleet replay) or written by a cluster's task
/// (`fleet summary`), so both tables agree to the last digit.
#[derive(Debug, Clone)]
pub struct ReportRow {
    /// The recording the report is of (`recording.path`), as its replay named it.
    pub recording: String,
    /// The model described (`model`): the table's columns.
    pub model: ModelDescription,
    /// Its figures.
    pub figures: FleetFigures,
}

/// The blocks of the report's JSON the table reads (the typed [`Report`] reads only what
/// the model's uses need).
#[derive(Deserialize)]
struct TableBlocks {
    time_constants_s: Vec<f64>,
    fit: FitBlock,
    steady_state: SteadyBlock,
    recording: RecordingBlock,
    model: ModelDescription,
}

#[derive(Deserialize)]
struct FitBlock {
    nrmse_fit_percent: Vec<f64>,
}

#[derive(Deserialize)]
struct SteadyBlock {
    temperature_c: Vec<f64>,
}

#[derive(Deserialize)]
struct RecordingBlock {
    path: String,
    data_loss: Vec<String>,
}

impl ReportRow {
    /// Reads a report's text (`name` names it in messages): checked as a report of this
    /// profile first ([`Report::from_json`]), then its table's blocks.
    pub fn from_json(text: &str, name: &Path) -> Result<ReportRow, UseError> {
        Report::from_json(text, name)?;
        let blocks: TableBlocks = serde_json::from_str(text).map_err(|e| UseError::NotAReport {
            path: name.to_owned(),
            message: e.to_string(),
        })?;
        Ok(ReportRow {
            recording: blocks.recording.path,
            model: blocks.model,
            figures: FleetFigures {
                time_constants_s: blocks.time_constants_s,
                nrmse_fit_percent: blocks.fit.nrmse_fit_percent,
                steady_state_c: blocks.steady_state.temperature_c,
                data_lost: !blocks.recording.data_loss.is_empty(),
            },
        })
    }
}

impl FleetFigures {
    /// The status column: `ok`, or `data lost`.
    pub fn status(&self) -> &'static str {
        if self.data_lost {
            "data lost"
        } else {
            "ok"
        }
    }
}

/// One recording of a fleet: its figures, or the one-line reason it failed.
#[derive(Debug, Clone, PartialEq)]
pub struct FleetRow {
    /// The recording (or report), as named.
    pub recording: String,
    /// Its figures, or why it failed.
    pub outcome: Result<FleetFigures, String>,
}

/// How a fleet's recordings ended.
#[derive(Debug, Default, PartialEq, Eq)]
pub struct FleetTally {
    /// Replayed whole.
    pub ok: usize,
    /// Replayed, with part of the recording skipped.
    pub data_lost: usize,
    /// Not replayed.
    pub failed: usize,
}

impl FleetTally {
    /// Counts the rows by outcome.
    pub fn of(rows: &[FleetRow]) -> FleetTally {
        let mut tally = FleetTally::default();
        for row in rows {
            match &row.outcome {
                Ok(f) if f.data_lost => tally.data_lost += 1,
                Ok(_) => tally.ok += 1,
                Err(_) => tally.failed += 1,
            }
        }
        tally
    }
}

/// A state's short name in the fleet summary: the generator's parts as they have always
/// been named there (stator, core, water, field), any other state by its own name.
pub fn short_name(state: &StateDescription) -> String {
    use crate::recording::{Quantity, Signal};
    match &state.channel {
        Signal::Profile(Quantity::StatorWindingTemp) => "stator".into(),
        Signal::Profile(Quantity::CoreTemp) => "core".into(),
        Signal::Profile(Quantity::CoolingWaterOutletTemp) => "water".into(),
        Signal::Profile(Quantity::FieldWindingTemp) => "field".into(),
        _ => state.name.clone(),
    }
}

/// The columns of `fleet-summary.csv` for a model of n states: the recording, its status,
/// T1..Tn, then each state's fit and steady state.
pub fn csv_header(model: &ModelDescription) -> Vec<String> {
    let short: Vec<String> = model.states.iter().map(short_name).collect();
    let mut header = vec!["recording".to_owned(), "status".to_owned()];
    header.extend((1..=short.len()).map(|i| format!("t{i}_s")));
    header.extend(short.iter().map(|s| format!("fit_{s}_pct")));
    header.extend(short.iter().map(|s| format!("steady_{s}_c")));
    header
}

/// `fleet-summary.csv`: one line per recording, empty figures where it failed.
pub fn fleet_csv(rows: &[FleetRow], header: &[String]) -> Result<Vec<u8>, FleetError> {
    let error = |e: &dyn std::fmt::Display| FleetError(e.to_string());
    let mut csv = csv::Writer::from_writer(Vec::new());
    csv.write_record(header).map_err(|e| error(&e))?;
    for row in rows {
        let mut record = vec![row.recording.clone()];
        match &row.outcome {
            Ok(f) => {
                record.push(f.status().to_owned());
                let figures = [&f.time_constants_s, &f.nrmse_fit_percent, &f.steady_state_c];
                record.extend(figures.into_iter().flatten().map(f64::to_string));
            }
            Err(reason) => record.push(format!("failed: {reason}")),
        }
        record.resize(header.len(), String::new());
        csv.write_record(&record).map_err(|e| error(&e))?;
    }
    csv.into_inner().map_err(|e| error(e.error()))
}

/// The fleet table as text, one line per recording under a header.
pub fn table_text(rows: &[FleetRow], model: &ModelDescription) -> String {
    let n = model.states.len();
    let short: Vec<String> = model.states.iter().map(short_name).collect();
    let mut text = format!(
        "{:<32} {}  {:>22}  {:>22}  status\n",
        "recording",
        (1..=n)
            .map(|i| format!("{:>9}", format!("T{i} s")))
            .collect::<Vec<_>>()
            .join(" "),
        format!("NRMSE fit % ({})", short.join(" ")),
        "steady state °C"
    );
    for row in rows {
        let name = &row.recording;
        let line = match &row.outcome {
            Ok(f) => format!(
                "{name:<32} {}  {:>22}  {:>22}  {}",
                joined(&f.time_constants_s, |t| format!("{t:>9.2}")),
                joined(&f.nrmse_fit_percent, |v| format!("{v:.2}")),
                joined(&f.steady_state_c, |v| format!("{v:.2}")),
                f.status()
            ),
            Err(reason) => format!("{name:<32} failed: {reason}"),
        };
        text.push_str(&line);
        text.push('\n');
    }
    text
}

/// Values formatted one by one and joined by spaces.
fn joined(values: &[f64], format: impl Fn(f64) -> String) -> String {
    values
        .iter()
        .map(|&v| format(v))
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn figures(data_lost: bool) -> FleetFigures {
        FleetFigures {
            time_constants_s: vec![23.9, 737.25, 3305.5],
            nrmse_fit_percent: vec![99.5, 98.0, 97.25],
            steady_state_c: vec![55.5, 47.125, 13.0],
            data_lost,
        }
    }

    fn rows() -> Vec<FleetRow> {
        vec![
            FleetRow {
                recording: "unit 3, run 1.mcap".into(),
                outcome: Ok(figures(false)),
            },
            FleetRow {
                recording: "lossy.mcap".into(),
                outcome: Ok(figures(true)),
            },
            FleetRow {
                recording: "broken.mcap".into(),
                outcome: Err("broken.mcap: not an MCAP file, \"magic\" missing".into()),
            },
        ]
    }

    #[test]
    fn fleet_csv_quotes_what_needs_it_and_pads_failures() {
        let header = csv_header(&ModelDescription::generator());
        let csv = String::from_utf8(fleet_csv(&rows(), &header).unwrap()).unwrap();
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(
            lines[0],
            "recording,status,t1_s,t2_s,t3_s,fit_stator_pct,fit_core_pct,fit_water_pct,\
             steady_stator_c,steady_core_c,steady_water_c"
        );
        assert_eq!(
            lines[1],
            "\"unit 3, run 1.mcap\",ok,23.9,737.25,3305.5,99.5,98,97.25,55.5,47.125,13"
        );
        assert!(lines[2].starts_with("lossy.mcap,data lost,23.9,"), "{csv}");
        assert_eq!(
            lines[3],
            "broken.mcap,\"failed: broken.mcap: not an MCAP file, \"\"magic\"\" missing\",,,,,,,,,"
        );
        assert_eq!(lines.len(), 4);
    }

    #[test]
    fn fleet_csv_reads_back_with_every_column() {
        let header = csv_header(&ModelDescription::generator());
        let bytes = fleet_csv(&rows(), &header).unwrap();
        let mut reader = csv::Reader::from_reader(bytes.as_slice());
        let records: Vec<csv::StringRecord> = reader.records().map(|r| r.unwrap()).collect();
        assert_eq!(records.len(), 3);
        assert!(records.iter().all(|r| r.len() == header.len()));
        assert_eq!(&records[0][0], "unit 3, run 1.mcap");
        assert_eq!(
            &records[2][1],
            "failed: broken.mcap: not an MCAP file, \"magic\" missing"
        );
        assert_eq!(records[0][8].parse::<f64>().unwrap(), 55.5);
    }

    #[test]
    fn a_four_state_fleet_has_a_column_for_every_figure() {
        let header = csv_header(&ModelDescription::generator_with_field_state());
        assert_eq!(header.len(), 2 + 3 * 4);
        assert_eq!(&header[5..7], ["t4_s", "fit_stator_pct"]);
        assert_eq!(header.last().unwrap(), "steady_field_c");
        let row = FleetRow {
            recording: "field.mcap".into(),
            outcome: Ok(FleetFigures {
                time_constants_s: vec![70.0, 690.0, 1592.0, 4496.0],
                nrmse_fit_percent: vec![99.0, 98.0, 95.0, 98.5],
                steady_state_c: vec![31.9, 27.3, 14.6, 60.4],
                data_lost: false,
            }),
        };
        let csv = String::from_utf8(fleet_csv(&[row], &header).unwrap()).unwrap();
        assert_eq!(
            csv.lines().nth(1).unwrap(),
            "field.mcap,ok,70,690,1592,4496,99,98,95,98.5,31.9,27.3,14.6,60.4"
        );
    }

    #[test]
    fn a_fleet_is_tallied_by_outcome() {
        assert_eq!(
            FleetTally::of(&rows()),
            FleetTally {
                ok: 1,
                data_lost: 1,
                failed: 1
            }
        );
    }

    #[test]
    fn a_report_of_a_synthetic_run_gives_its_figures() {
        use crate::pipeline::{replay, ReplayOptions};
        use crate::report::Replayed;
        use crate::synth::{write, SynthOptions};
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("run.mcap");
        write(&file, &SynthOptions::default()).unwrap();
        let replayed = Replayed::new(replay(&file, &ReplayOptions::default()).unwrap());
        let row = ReportRow::from_json(&replayed.report.to_json(), Path::new("r.json")).unwrap();
        assert_eq!(row.recording, file.display().to_string());
        assert_eq!(row.model.states.len(), 3);
        let report = &replayed.report;
        let close = |a: &[f64], b: &[f64]| {
            a.len() == b.len()
                && a.iter()
                    .zip(b)
                    .all(|(x, y)| (x - y).abs() <= 1e-12 * y.abs())
        };
        assert!(close(
            &row.figures.time_constants_s,
            &report.time_constants_s
        ));
        assert!(close(
            &row.figures.nrmse_fit_percent,
            &report.fit.nrmse_fit_percent
        ));
        assert!(close(
            &row.figures.steady_state_c,
            &report.steady_state.temperature_c
        ));
        assert!(!row.figures.data_lost);
    }

    #[test]
    fn the_table_has_a_line_per_recording_and_names_failures() {
        let text = table_text(&rows(), &ModelDescription::generator());
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 4);
        assert!(lines[0].contains("T3 s") && lines[0].contains("stator core water"));
        assert!(lines[2].ends_with("data lost"));
        assert!(lines[3].contains("failed: broken.mcap"));
    }
}
