//! heatrun: thermal system identification of hydro generators from heat-run
//! recordings in the heatrun SCADA MCAP profile. This is the library; the `heatrun`
//! command and the rerun publisher (`heatrun-rerun`) are packages of their own above it.
//!
//! The library follows the data, one module per stage, each with a typed input, output
//! and error, and no knowledge of the stages after it; [`pipeline`] alone knows their
//! order, and [`Error`] alone combines their errors:
//!
//! | stage | module | input → output |
//! |---|---|---|
//! | recording | [`recording`] | MCAP file → [`Sample`]s to a [`recording::SampleSink`], [`RecordingSummary`], nameplate |
//! | decimation | [`decimate`] | samples → [`DecimatedRecording`] on a grid of Ts |
//! | plausibility | [`plausibility`] | the grid (channels exchanged mid-run swapped back; a wrong unit refused), the signals (the calorimetric balance), the network (exchanged labels) → findings |
//! | signals | [`signals`] | decimated channels + [`ModelDescription`] (+ the generator's [`losses`]) → [`ModelSignals`] |
//! | estimation | [`estimate`] | [`IdentificationData`] → [`Estimate`] (Φ, Γ) by a [`Method`] |
//! | screen | [`screen`] | data + a model's simulation → the glitches and frozen runs left out ([`screen::Screening`]); the pipeline estimates again without them |
//! | model analysis | [`model`] | estimate → [`ModelAnalysis`] (A_c, B_c, T_i, fit, …) |
//! | network | [`network`] | continuous model + signals → [`NetworkAnalysis`] |
//! | report | [`report`] | [`Replay`] → the profile's JSON [`Report`] and a summary |
//! | model file | [`model_file`] | the report read back → [`model_file::ThermalModel`] for [`predict`], [`rating`], [`monitor`] and [`html`] |
//!
//! Below the stages, [`thermal`] holds what estimation and analysis share (the discrete
//! and continuous model, ZOH, the passive network and its RC parametrisation, water).
//! The uses of an identified model read the report: [`predict`], [`rating`],
//! [`monitor`], and [`html`] draws any of them as one page. [`import`] turns tables into
//! recordings, [`synth`] simulates heat runs of known machines, and [`writer`] writes
//! any recording in the profile.
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
pub mod colour;
pub mod confidence;
pub mod decide;
pub mod decimate;
pub mod error;
pub mod estimate;
pub mod fleet;
pub mod grid;
pub mod hidden;
pub mod html;
pub mod import;
pub mod losses;
pub mod model;
pub mod model_file;
pub mod monitor;
pub mod network;
pub mod options;
pub mod pipeline;
pub mod plausibility;
pub mod predict;
pub mod progress;
pub mod rating;
pub mod recording;
pub mod report;
pub mod screen;
pub mod series;
pub mod signals;
pub mod spec;
pub mod store;
pub mod synth;
pub mod thermal;
mod toml_message;
pub mod warnings;
pub mod writer;

pub use decimate::DecimatedRecording;
pub use error::{Error, Result};
pub use estimate::{Estimate, IdentificationData, Method};
pub use model::ModelAnalysis;
pub use model_file::{Report, ThermalModel};
pub use network::NetworkAnalysis;
pub use pipeline::{replay, NetworkChoice, Replay, ReplayOptions};
pub use recording::{RecordingSummary, Sample};
pub use signals::ModelSignals;
pub use spec::ModelDescription;
