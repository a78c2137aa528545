//! A replay's traces on its grid: per state the measured value, the model's and the
//! residual, the values the rerun recording draws (`heatrun-rerun`'s `traces` module),
//! here at every instant (the recording sends the model's smooth curve as its polyline:
//! `heatrun_rerun::curve`):
//!
//! - model θ̂_j(k) = θ_ref,j(k) + T_base · ŷ_j(k), ŷ the replay's model simulated from
//!   the initial state (the hidden-state model's C x + D u where the spec declares one);
//! - residual r_j(k) = T_base · (y_j(k) − ŷ_j(k)), K, where the estimator compared (an
//!   entry screened out as a glitch or frozen run is in the measured trace alone).
//!
//! Missing values are NaN. Each series goes to Python as little-endian bytes.

use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList};

use heatrun::pipeline::Replay;

/// One state's three series.
pub struct StateTraces {
    /// The state's name.
    pub name: String,
    /// The unit of the measured and model values (°C for temperatures).
    pub unit: String,
    /// θ_j(k), as measured.
    pub measured: Vec<f64>,
    /// θ̂_j(k), the model's.
    pub model: Vec<f64>,
    /// y − ŷ, K (the rise's unit).
    pub residual: Vec<f64>,
}

/// The grid's instants and every state's traces.
pub struct Traces {
    /// t_k, ns since the Unix epoch.
    pub time_ns: Vec<i64>,
    /// Per state, in the model's order.
    pub states: Vec<StateTraces>,
}

/// The traces of a replay (see the module's documentation for the equations).
pub fn measured_and_model(r: &Replay) -> Traces {
    let s = &r.signals;
    let base = s.temperature_base_k;
    let hidden = r.hidden.as_ref().map(|h| {
        heatrun::hidden::traces::simulated_outputs(
            &h.estimate.model,
            &r.data,
            r.estimation_range.clone(),
        )
    });
    let sim = |k: usize, j: usize| match &hidden {
        Some(h) => h[(k, j)],
        None => r.analysis.simulated[(k, j)],
    };
    let states = s
        .states
        .iter()
        .enumerate()
        .map(|(j, state)| StateTraces {
            name: state.name.clone(),
            unit: r
                .model
                .states
                .get(j)
                .map_or_else(|| "degC".to_owned(), |d| d.unit.clone()),
            measured: (0..s.len())
                .map(|k| state.measured.get(k).unwrap_or(f64::NAN))
                .collect(),
            model: (0..s.len())
                .map(|k| {
                    state
                        .reference_at(k)
                        .map_or(f64::NAN, |reference| reference + base * sim(k, j))
                })
                .collect(),
            residual: (0..s.len())
                .map(|k| {
                    s.rise_pu(j, k)
                        .filter(|_| r.data.observed(k, j))
                        .map_or(f64::NAN, |y| base * (y - sim(k, j)))
                })
                .collect(),
        })
        .collect();
    Traces {
        time_ns: s.time_ns.clone(),
        states,
    }
}

/// A series as little-endian bytes (`numpy.frombuffer(b, "<f8")`).
fn f64_bytes(values: &[f64]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

impl Traces {
    /// `{"time_ns": bytes, "states": [{"name", "unit", "measured", "model", "residual"}]}`.
    pub fn into_dict(self, py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
        let out = PyDict::new(py);
        let time: Vec<u8> = self.time_ns.iter().flat_map(|t| t.to_le_bytes()).collect();
        out.set_item("time_ns", PyBytes::new(py, &time))?;
        let states = PyList::empty(py);
        for st in self.states {
            let d = PyDict::new(py);
            d.set_item("name", st.name)?;
            d.set_item("unit", st.unit)?;
            d.set_item("measured", PyBytes::new(py, &f64_bytes(&st.measured)))?;
            d.set_item("model", PyBytes::new(py, &f64_bytes(&st.model)))?;
            d.set_item("residual", PyBytes::new(py, &f64_bytes(&st.residual)))?;
            states.append(d)?;
        }
        out.set_item("states", states)?;
        Ok(out)
    }
}
