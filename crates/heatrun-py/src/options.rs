//! `heatrun replay`'s options as keyword arguments, resolved into the library's
//! [`ReplayOptions`] exactly as the command line resolves its flags (src/cli/replay.rs).

use std::path::PathBuf;

use pyo3::PyResult;

use heatrun::estimate::Method;
use heatrun::pipeline::{NetworkChoice, ReplayOptions, ValidationSource};
use heatrun::progress::Observer;
use heatrun::spec::coolant::ReferencePolicy;
use heatrun::spec::ModelDescription;

use crate::errors::{bad_input, to_py};

/// The keyword arguments of `heatrun.replay`, one per flag of `heatrun replay` that
/// changes the model (the outputs' flags are Python's business).
pub struct ReplayRequest {
    /// `--method`: a method's name as the command line lists it.
    pub method: Option<String>,
    /// `--spec`.
    pub spec: Option<PathBuf>,
    /// `--field-state`.
    pub field_state: bool,
    /// `--reference`: `auto`, `initial` or `inlet`.
    pub reference: String,
    /// `--machine`.
    pub machine: Option<PathBuf>,
    /// `--network`: `best` or `nearest`.
    pub network: String,
    /// `--ts`, s.
    pub ts: Option<f64>,
    /// `--weights`.
    pub weights: Option<Vec<f64>>,
    /// `--forgetting`.
    pub forgetting: f64,
    /// `--holdout`.
    pub holdout: Option<f64>,
    /// `--split-at`, s.
    pub split_at: Option<f64>,
    /// `--validate`.
    pub validate: Option<PathBuf>,
}

impl ReplayRequest {
    /// The library's options: the spec read, the sample time and the method resolved (the
    /// argument's, then the spec's, then 1 s and oe, with oe or pem chosen by the data
    /// where neither names a method), as `heatrun replay` resolves them.
    pub fn library_options(&self) -> PyResult<ReplayOptions> {
        // The pairs clap refuses on the command line.
        if self.field_state && self.spec.is_some() {
            return Err(bad_input(
                "field_state=True cannot be used with spec= (a spec names its own states)",
            ));
        }
        if self.holdout.is_some() && (self.split_at.is_some() || self.validate.is_some()) {
            return Err(bad_input(
                "holdout= cannot be used with split_at= or validate=",
            ));
        }
        if self.split_at.is_some() && self.validate.is_some() {
            return Err(bad_input("split_at= cannot be used with validate="));
        }
        let model = match &self.spec {
            Some(path) => ModelDescription::from_toml_file(path)
                .map_err(|e| to_py(heatrun::Error::from(e)))?,
            None if self.field_state => ModelDescription::generator_with_field_state(),
            None => ModelDescription::generator(),
        };
        let method = match (self.method.as_deref(), model.method.as_deref()) {
            (Some(name), _) => name.parse::<Method>().map_err(|_| {
                bad_input(format!("method={name:?} is not one of {}", method_names()))
            })?,
            // A spec's bad key is the input's fault, as every other is.
            (None, Some(name)) => name.parse::<Method>().map_err(|_| {
                bad_input(format!(
                    "{}: method = \"{name}\" is not one of {}",
                    self.spec
                        .as_deref()
                        .unwrap_or(std::path::Path::new("spec"))
                        .display(),
                    method_names()
                ))
            })?,
            (None, None) => Method::Oe,
        };
        Ok(ReplayOptions {
            ts_s: self.ts.or(model.sample_time_s).unwrap_or(1.0),
            // Neither the argument nor the spec gives Ts: the grid follows temperatures
            // recorded slower than 1 s (the command line's default).
            choose_ts: self.ts.is_none() && model.sample_time_s.is_none(),
            machine: self.machine.clone(),
            method,
            // Neither the argument nor the spec names a method: oe, or pem where oe's
            // residuals are not white (the command line's default).
            choose_estimator: self.method.is_none() && model.method.is_none(),
            weights: self.weights.clone(),
            forgetting: self.forgetting,
            validation: match (&self.holdout, &self.split_at, &self.validate) {
                (Some(f), _, _) => Some(ValidationSource::HoldOut(*f)),
                (None, Some(t), _) => Some(ValidationSource::SplitAt(*t)),
                (None, None, Some(file)) => Some(ValidationSource::Recording(file.clone())),
                (None, None, None) => None,
            },
            model,
            reference: match self.reference.as_str() {
                "auto" => ReferencePolicy::Auto,
                "initial" => ReferencePolicy::Initial,
                "inlet" => ReferencePolicy::Inlet,
                other => {
                    return Err(bad_input(format!(
                        "reference={other:?} is not one of \"auto\", \"initial\", \"inlet\""
                    )))
                }
            },
            progress: Observer::silent(),
            network: match self.network.as_str() {
                "best" => NetworkChoice::Best,
                "nearest" => NetworkChoice::Nearest,
                other => {
                    return Err(bad_input(format!(
                        "network={other:?} is not one of \"best\", \"nearest\""
                    )))
                }
            },
        })
    }
}

/// The library's methods by name, as the command line lists them.
fn method_names() -> String {
    Method::EVERY.map(|m| m.name()).join(", ")
}
