//! The model file: the versioned report a replay writes (`heatrun replay --report`), and
//! the model the uses of it — `predict`, `rating`, `monitor`, their HTML pages and rerun —
//! read back from it.
//!
//! It sits below every stage that uses a model and knows none of them: [`document`] is
//! the report's one type ([`Report`], serialised both ways, with the profile version
//! [`PROFILE`] it is read against), [`thermal_model`] the [`ThermalModel`] built from a
//! report, and [`error`] what is wrong with a report, a load schedule or a request made
//! of the model ([`UseError`]); [`hidden`] the output map y = C x + D u of a model
//! with hidden states. Building a report from a replay is
//! [`crate::report`]'s, above the pipeline, so that reading a model never reaches back
//! into the stages that made it.

pub mod document;
pub mod error;
pub mod hidden;
mod shape;
pub mod thermal_model;

pub use document::{Report, HIDDEN_COVARIANCE_LAYOUT, PROFILE};
pub use error::UseError;
pub use hidden::OutputMap;
pub use thermal_model::{
    FieldScaling, FieldTemperatureUse, ModelError, ModelUncertainty, ThermalModel,
};
