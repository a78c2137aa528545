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
//! | signals | [`signals`] | decimated channels + [`spec::ModelDescription`] (+ the generator's [`losses`]) → [`signals::ModelSignals`] |
//! | estimation | [`estimate`] | [`estimate::IdentificationData`] → [`estimate::Estimate`] (Φ, Γ) |
//! | model analysis | [`model`] | estimate → [`model::ModelAnalysis`] (A_c, B_c, T_i, fit, …) |
//! | report | [`report`] | everything → the profile's JSON report ([`model_file::Report`]) and a summary |
//! | use of the model | [`model_file`] | the report read back → [`model_file::ThermalModel`] for [`predict`], [`rating`] and [`monitor`] |
//! | HTML report | [`html`] | the replay and its report → one self-contained page |
//!
//! [`pipeline`] runs the stages in order; [`synth`] writes synthetic heat runs,
//! [`import`] turns tables (CSV, historian exports) into recordings, and [`writer`]
//! writes any recording in the profile.
//!
//! # A replay in a few lines
//!
//! The shipped fixture is a heat run simulated from the paper's model; replaying it
//! identifies that model again, with the paper's three time constants:
//!
//! ```
//! use heatrun::pipeline::{replay, ReplayOptions};
//! use heatrun::model_file::Report;
//!
//! let fixture = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/paper_heat_run.mcap");
//! let replayed = replay(fixture.as_ref(), &ReplayOptions::default())?;
//! let report = Report::new(&replayed);
//! for a in &report.assignment {
//!     println!("T = {:8.2} s  -> {}", a.time_constant_s, a.part);
//! }
//! // eq. 26 from the paper's Φ: 23.90 s, 737.21 s, 3305.73 s
//! assert!((report.time_constants_s[1] - 737.21).abs() < 0.01);
//! # Ok::<(), heatrun::Error>(())
//! ```
//!
//! [`model_file::Report::summary`] gives the whole paper-style table; the `heatrun-rerun`
//! package sends everything to a rerun viewer or an `.rrd` file.

#![warn(missing_docs)]
// `!(x > 0.0)` is how this crate rejects NaN along with the out-of-range values: the
// negated comparison is the point, not an oversight.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod atomic;
pub mod decimate;
pub mod error;
pub mod estimate;
pub mod html;
pub mod import;
pub mod losses;
pub mod model;
pub mod model_file;
pub mod monitor;
pub mod network;
pub mod pipeline;
pub mod predict;
pub mod progress;
pub mod rating;
pub mod recording;
pub mod report;
pub mod series;
pub mod signals;
pub mod spec;
pub mod synth;
pub mod thermal;
pub mod warnings;
pub mod writer;

pub use error::{Error, Result};
