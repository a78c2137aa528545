//! Fleets from Python: the reports a cluster's workers return, reduced into the fleet
//! table (`heatrun fleet summary`'s, by the library's one reduction) and compared
//! (`heatrun fleet compare`'s).

use std::path::Path;

use pyo3::prelude::*;

use heatrun::fleet::compare::{self, CompareOptions};
use heatrun::fleet::{self as table, FleetRow, ReportRow};

use crate::errors::{bad_input, to_py, HeatrunError};

/// `fleet-summary.csv` and the table as printed, of reports given as `(name, JSON text)`
/// in the fleet's order: what `heatrun fleet summary` writes and prints for the same
/// reports. A report that does not read is a row with its one-line reason.
#[pyfunction]
pub fn fleet_summary_csv(
    py: Python<'_>,
    reports: Vec<(String, String)>,
) -> PyResult<(String, String)> {
    let read: Vec<(String, Result<ReportRow, String>)> = py.detach(|| {
        reports
            .iter()
            .map(|(name, text)| {
                let row = ReportRow::from_json(text, Path::new(name))
                    .map_err(|e| crate::errors::one_line(&heatrun::Error::from(e)));
                (name.clone(), row)
            })
            .collect()
    });
    // The columns follow the model of the first report that reads.
    let Some(model) = read
        .iter()
        .find_map(|(_, r)| r.as_ref().ok().map(|r| &r.model))
    else {
        return Err(bad_input(match read.first() {
            None => "no reports given".to_owned(),
            Some((_, Err(e))) => format!("no report could be read: {e}"),
            Some(_) => "no report could be read".to_owned(),
        }));
    };
    let rows: Vec<FleetRow> = read
        .iter()
        .map(|(name, row)| FleetRow {
            recording: match row {
                Ok(r) => r.recording.clone(),
                Err(_) => name.clone(),
            },
            outcome: row
                .as_ref()
                .map(|r| r.figures.clone())
                .map_err(Clone::clone),
        })
        .collect();
    let csv = table::fleet_csv(&rows, &table::csv_header(model))
        .map_err(|e| HeatrunError::new_err(e.to_string()))?;
    let csv = String::from_utf8(csv).map_err(|e| HeatrunError::new_err(e.to_string()))?;
    Ok((csv, table::table_text(&rows, model)))
}

/// The fleet comparison of units given as `(label, report JSON text)`, as `heatrun fleet
/// compare` makes it: its JSON (`--json`) and its summary as printed. A report that is
/// none is named by its label.
#[pyfunction]
#[pyo3(signature = (units, *, threshold=None, floor=None))]
pub fn fleet_compare(
    py: Python<'_>,
    units: Vec<(String, String)>,
    threshold: Option<f64>,
    floor: Option<f64>,
) -> PyResult<(String, String)> {
    let defaults = CompareOptions::default();
    let options = CompareOptions {
        threshold: threshold.unwrap_or(defaults.threshold),
        floor: floor.unwrap_or(defaults.floor),
    };
    let comparison = py
        .detach(|| -> Result<_, heatrun::Error> {
            let read = units
                .iter()
                .map(|(label, text)| compare::unit_from_json(text, Path::new(label), label))
                .collect::<Result<Vec<_>, _>>()?;
            Ok(compare::compare(&read, &options)?)
        })
        .map_err(to_py)?;
    let json = serde_json::to_string_pretty(&comparison)
        .map_err(|e| HeatrunError::new_err(e.to_string()))?;
    Ok((json, comparison.summary()))
}
