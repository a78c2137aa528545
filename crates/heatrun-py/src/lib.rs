//! `heatrun._heatrun`: the library's front for Python, the Rust half of the `heatrun`
//! package (its Python half, `python/heatrun`, turns what these functions return into
//! numpy arrays, pandas frames and the typed `Report`).
//!
//! Every function takes and gives plain values: paths, options, the report's JSON text and
//! the traces as little-endian bytes (read by `numpy.frombuffer` without a copy per
//! element). The library works with the GIL released ([`Python::detach`]), so threads of
//! one interpreter replay in parallel. Its errors become `HeatrunError` (or
//! `BadInputError`, the command line's exit status 2) carrying the command line's
//! one-line message.

mod errors;
mod fleet;
mod options;
mod traces;
mod uses;

use std::path::PathBuf;

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use heatrun::model_file::{Report, UseError};
use heatrun::report::Replayed;

use errors::{to_py, BadInputError, HeatrunError};
use options::ReplayRequest;

/// Replays one recording (a path or URL) as `heatrun replay` does with the same flags, and
/// returns `{"report_json", "summary", "warnings", "data_loss", "traces"}` (the traces as
/// [`traces::measured_and_model`] lays them out; omitted where `traces` is false).
#[pyfunction]
#[pyo3(signature = (
    path, *, method=None, spec=None, field_state=false, reference="auto", machine=None,
    network="best", ts=None, weights=None, forgetting=1.0, holdout=None, split_at=None,
    validate=None, traces=true
))]
#[allow(clippy::too_many_arguments)]
fn replay<'py>(
    py: Python<'py>,
    path: PathBuf,
    method: Option<String>,
    spec: Option<PathBuf>,
    field_state: bool,
    reference: &str,
    machine: Option<PathBuf>,
    network: &str,
    ts: Option<f64>,
    weights: Option<Vec<f64>>,
    forgetting: f64,
    holdout: Option<f64>,
    split_at: Option<f64>,
    validate: Option<PathBuf>,
    traces: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let request = ReplayRequest {
        method,
        spec,
        field_state,
        reference: reference.to_owned(),
        machine,
        network: network.to_owned(),
        ts,
        weights,
        forgetting,
        holdout,
        split_at,
        validate,
    };
    let options = request.library_options()?;
    // The whole pipeline runs without the GIL: other Python threads go on meanwhile.
    let (replayed, laid_out) = py
        .detach(|| -> Result<_, heatrun::Error> {
            let found = heatrun::pipeline::replay(&path, &options)?;
            let replayed = Replayed::new(found);
            let laid_out = traces.then(|| traces::measured_and_model(&replayed.replay));
            Ok((replayed, laid_out))
        })
        .map_err(to_py)?;
    let out = PyDict::new(py);
    out.set_item("report_json", replayed.report.to_json())?;
    out.set_item("summary", &replayed.summary)?;
    out.set_item("warnings", PyList::new(py, &replayed.replay.warnings)?)?;
    out.set_item("data_loss", replayed.replay.had_data_loss())?;
    if let Some(t) = laid_out {
        out.set_item("traces", t.into_dict(py)?)?;
    }
    Ok(out)
}

/// Imports a table as `heatrun import TABLE --map MAP --out OUT` does, the map given as
/// its TOML text (`map_name` names it in messages); returns the messages written.
#[pyfunction]
fn import_table(
    py: Python<'_>,
    table: PathBuf,
    map_toml: &str,
    map_name: PathBuf,
    out: PathBuf,
) -> PyResult<u64> {
    py.detach(|| -> Result<u64, heatrun::Error> {
        let map = heatrun::import::ImportMap::parse(map_toml, &map_name)?;
        Ok(heatrun::import::import(&table, &map, &out)?.messages)
    })
    .map_err(to_py)
}

/// Reads a report (path or URL) and checks it against the profile; returns its text as
/// written, so that every section, known to this build or not, reaches Python.
#[pyfunction]
fn read_report(py: Python<'_>, path: PathBuf) -> PyResult<String> {
    py.detach(|| -> Result<String, UseError> {
        // As `Report::read`: a URL from its store, whole; a path from the disk.
        let location = heatrun::store::Location::from_path(&path)?;
        let text = if location.is_remote() {
            heatrun::store::read_to_string(&location)?
        } else {
            std::fs::read_to_string(&path).map_err(|source| UseError::Read {
                path: path.clone(),
                source,
            })?
        };
        Report::from_json(&text, &path)?;
        Ok(text)
    })
    .map_err(|e| to_py(e.into()))
}

/// Checks a report's JSON text against the profile (`name` names it in messages).
#[pyfunction]
fn check_report(text: &str, name: PathBuf) -> PyResult<()> {
    Report::from_json(text, &name)
        .map(|_| ())
        .map_err(|e| to_py(e.into()))
}

/// The channels a model spec reads (its states', its inputs' and their references'), each
/// with the unit a table's column of it is taken in where the caller names none: a
/// profile quantity's canonical unit, a state's unit as the spec gives it (°C by
/// default), else `1`. With `spec` None, the profile's generator (or with its field
/// winding as a fourth state).
#[pyfunction]
#[pyo3(signature = (spec=None, field_state=false))]
fn spec_channels(spec: Option<PathBuf>, field_state: bool) -> PyResult<Vec<(String, String)>> {
    use heatrun::recording::Signal;
    use heatrun::spec::ModelDescription;
    let model = match &spec {
        Some(path) => {
            ModelDescription::from_toml_file(path).map_err(|e| to_py(heatrun::Error::from(e)))?
        }
        None if field_state => ModelDescription::generator_with_field_state(),
        None => ModelDescription::generator(),
    };
    Ok(model
        .alignments()
        .into_keys()
        .map(|signal| {
            let unit = match &signal {
                Signal::Profile(q) => q.canonical_unit().to_owned(),
                Signal::Free(_) => model
                    .states
                    .iter()
                    .find(|s| s.channel == signal)
                    .map_or_else(|| "1".to_owned(), |s| s.unit.clone()),
            };
            (signal.name().to_owned(), unit)
        })
        .collect())
}

/// The recordings (`.mcap`) of a folder or an object-store prefix (a URL ending in `/`),
/// sorted by name: the fleet `heatrun replay FOLDER` replays.
#[pyfunction]
fn list_recordings(py: Python<'_>, folder: PathBuf) -> PyResult<Vec<String>> {
    py.detach(|| -> Result<Vec<String>, heatrun::store::StoreError> {
        let location = heatrun::store::Location::from_path(&folder)?;
        let listed = heatrun::store::list(&location, ".mcap")?;
        Ok(listed
            .iter()
            .map(|l| l.to_path().to_string_lossy().into_owned())
            .collect())
    })
    .map_err(|e| to_py(heatrun::recording::RecordingError::from(e).into()))
}

/// The library's version (the report's `heatrun_version`).
#[pyfunction]
fn version() -> &'static str {
    env!("CARGO_PKG_VERSION")
}

/// The module: its functions and its two exceptions.
#[pymodule]
fn _heatrun(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("HeatrunError", m.py().get_type::<HeatrunError>())?;
    m.add("BadInputError", m.py().get_type::<BadInputError>())?;
    m.add_function(wrap_pyfunction!(replay, m)?)?;
    m.add_function(wrap_pyfunction!(import_table, m)?)?;
    m.add_function(wrap_pyfunction!(read_report, m)?)?;
    m.add_function(wrap_pyfunction!(check_report, m)?)?;
    m.add_function(wrap_pyfunction!(version, m)?)?;
    m.add_function(wrap_pyfunction!(spec_channels, m)?)?;
    m.add_function(wrap_pyfunction!(list_recordings, m)?)?;
    m.add_function(wrap_pyfunction!(uses::predict, m)?)?;
    m.add_function(wrap_pyfunction!(uses::rating, m)?)?;
    m.add_function(wrap_pyfunction!(fleet::fleet_summary_csv, m)?)?;
    m.add_function(wrap_pyfunction!(fleet::fleet_compare, m)?)?;
    Ok(())
}
