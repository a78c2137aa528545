//! heatrun's integration tests, one binary with a module per file: linking rerun's tree
//! into a test binary takes longer than compiling most tests, so it is done once.
//!
//! | module | what it checks |
//! |---|---|
//! | [`paper`] | the paper's printed numbers, with worked-out rounding bounds |
//! | [`recovery`] | known models recovered from synthetic files, end to end |
//! | [`estimators`] | every estimator against the accuracy bar on seeded noisy runs |
//! | [`outputs`] | the .rrd read back with rerun's decoder; the report against its schema; fleets |
//! | [`bad_input`] | every bad-input path: exit 2, one line, no output, input untouched |
//! | [`corpus`] | generated damaged and odd recordings, each with its documented outcome |
//! | [`import`] | `heatrun import`: every table format, bad cells and rows, the fixture round trip |
//! | [`datasets`] | measured data: the TCLab validation fit, as its example runs it |
//! | [`spec`] | `replay --spec`: a known two-node network through a TOML spec; bad specs |
//! | [`broken_pipe`] | a closed pipe (`heatrun info f.mcap \| head -1`) ends a command quietly |
//!
//! A new test file `tests/NAME.rs` becomes `mod NAME;` here; shared helpers are in
//! [`common`].

mod common;

mod bad_input;
mod broken_pipe;
mod corpus;
mod datasets;
mod estimators;
mod import;
mod layouts;
mod outputs;
mod paper;
mod predict;
mod recovery;
mod spec;
