//! The uses of an identified model, read from its report's JSON text: `heatrun predict`
//! and `heatrun rating`, through the library's [`predict`](heatrun::predict) and
//! [`rating`](heatrun::rating) over [`ThermalModel`].

use std::path::{Path, PathBuf};

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use heatrun::model_file::{Report, ThermalModel, UseError};
use heatrun::predict::InitialState;
use heatrun::rating::{InsulationClass, RatingOptions};

use crate::errors::{bad_input, to_py};

/// The model of a report's text (`name` names the report in messages).
fn model_of(report_json: &str, name: &Path) -> Result<ThermalModel, UseError> {
    ThermalModel::from_report(&Report::from_json(report_json, name)?, name)
}

/// Predicts as `heatrun predict --model REPORT --load LOAD` does (`initial`: `measured`
/// or `steady`; `initial_temps`, °C per state, overrides it) and returns
/// `{"csv": the prediction's CSV with its 95 % bands, "warnings": [...]}`.
#[pyfunction]
#[pyo3(signature = (report_json, name, load_csv, *, initial="measured", initial_temps=None))]
pub fn predict<'py>(
    py: Python<'py>,
    report_json: &str,
    name: PathBuf,
    load_csv: PathBuf,
    initial: &str,
    initial_temps: Option<Vec<f64>>,
) -> PyResult<Bound<'py, PyDict>> {
    let initial = match (initial_temps, initial) {
        (Some(t), _) => InitialState::Temperatures(t),
        (None, "measured") => InitialState::Measured,
        (None, "steady") => InitialState::Steady,
        (None, other) => {
            return Err(bad_input(format!(
                "initial={other:?} is not one of \"measured\", \"steady\""
            )))
        }
    };
    let prediction = py
        .detach(|| -> Result<_, UseError> {
            let model = model_of(report_json, &name)?;
            let schedule = heatrun::predict::load::read(&load_csv, &model)?;
            heatrun::predict::predict(&model, &schedule, &initial)
        })
        .map_err(|e| to_py(e.into()))?;
    let out = PyDict::new(py);
    out.set_item("csv", prediction.to_csv())?;
    out.set_item("warnings", PyList::new(py, &prediction.warnings)?)?;
    Ok(out)
}

/// Rates the machine as `heatrun rating --model REPORT` does, and returns the rating's
/// JSON (`--json`) and its table as printed.
#[pyfunction]
#[pyo3(signature = (
    report_json, name, *, insulation_class=None, limits=Vec::new(), power_factor=None,
    voltage_kv=None, coolant_c=None, overloads_percent=vec![110.0, 120.0, 130.0, 140.0, 150.0]
))]
#[allow(clippy::too_many_arguments)]
pub fn rating(
    py: Python<'_>,
    report_json: &str,
    name: PathBuf,
    insulation_class: Option<&str>,
    limits: Vec<(String, f64)>,
    power_factor: Option<f64>,
    voltage_kv: Option<f64>,
    coolant_c: Option<f64>,
    overloads_percent: Vec<f64>,
) -> PyResult<(String, String)> {
    let class = match insulation_class {
        None => None,
        Some("B") => Some(InsulationClass::B),
        Some("F") => Some(InsulationClass::F),
        Some("H") => Some(InsulationClass::H),
        Some(other) => {
            return Err(bad_input(format!(
                "insulation_class={other:?} is not one of \"B\", \"F\", \"H\""
            )))
        }
    };
    let options = RatingOptions {
        class,
        limits_c: limits,
        power_factor,
        voltage_v: voltage_kv.map(|kv| kv * 1e3),
        coolant_c,
        overloads: overloads_percent.iter().map(|p| p / 100.0).collect(),
    };
    let rated = py
        .detach(|| -> Result<_, UseError> {
            let model = model_of(report_json, &name)?;
            heatrun::rating::rate(&model, &options)
        })
        .map_err(|e| to_py(e.into()))?;
    let json = serde_json::to_string_pretty(&rated)
        .map_err(|e| crate::errors::HeatrunError::new_err(e.to_string()))?;
    Ok((json, rated.table()))
}
