//! heatrun: thermal system identification of hydro generators from heat-run
//! recordings in the heatrun SCADA MCAP profile.
//!
//! The library follows the data, one module per pipeline stage, each with a typed
//! input and output and no knowledge of the stages after it:
//!
//! | stage | module | input → output |
//! |---|---|---|
//! | recording | [`recording`] | MCAP file → [`recording::Sample`]s, nameplate |
//! | decimation | [`decimate`] | samples → [`decimate::DecimatedRecording`] on a grid of Ts |
//! | losses | [`losses`] | decimated quantities + nameplate → [`losses::ThermalSignals`] (pu) |
//! | estimation | [`estimate`] | [`estimate::IdentificationData`] → [`estimate::Estimate`] (Φ, Γ) |
//! | model analysis | [`model`] | estimate → [`model::ModelAnalysis`] (A_c, B_c, T_i, fit, …) |
//! | publishing | [`publish`] | everything → a rerun recording |
//! | report | [`report`] | everything → the profile's JSON report and a summary |
//!
//! [`pipeline`] runs the stages in order; [`synth`] writes synthetic heat runs,
//! [`import`] turns tables (CSV, historian exports) into recordings, and [`writer`]
//! writes any recording in the profile.

pub mod atomic;
pub mod decimate;
pub mod error;
pub mod estimate;
pub mod import;
pub mod losses;
pub mod model;
pub mod pipeline;
#[cfg(feature = "rerun")]
pub mod publish;
pub mod recording;
pub mod report;
pub mod series;
pub mod synth;
pub mod writer;

pub use error::{Error, Result};
