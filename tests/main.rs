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
//! | [`historian`] | a historian's `;`/decimal-comma export (storage by exception, timeouts, Bad flags, a drifting inlet) and an on-change export imported as sampled, beside the run they came from |
//! | [`datasets`] | measured data: the TCLab validation fit, as its example runs it |
//! | [`plausibility`] | data that contradict physics (a unit off, sensors exchanged mid-run, labels exchanged, a wandering final load): refused or named, corrected where said, beside the same run without the flaw |
//! | [`flaws`] | unflagged glitches and a frozen sensor left out, named, the time constants unmoved; nothing left out of clean runs |
//! | [`fleet_compare`] | `heatrun fleet compare`: nine units of one design, the fouled cooler named and no healthy unit; bad input |
//! | [`field_state`] | `replay --field-state`: a four-node machine whose field winding is seen through U_f/I_f |
//! | [`network_rc`] | a known RC machine's C, G and K from the identified model and from `--method rc` |
//! | [`spec`] | `replay --spec`: a known two-node network through a TOML spec; bad specs |
//! | [`html`] | `replay --html`: the page parsed, its sections, figures and tables; nothing outside it |
//! | [`monitor`] | `heatrun monitor`: healthy recordings raise nothing, a fouled cooler an alarm in time; bad input |
//! | [`tables`] | long tables (sorted by time, grouped by tag) imported as the wide text export; a night run in Zurich's wall-clock time through the clock change, against its truth; a skipped hour; a Parquet table refused in one line by a build without Parquet |
//! | `parquet` | (feature `parquet`) Parquet tables (wide, long) imported as the text export; local timestamps through the clock change |
//! | [`profile`] | the recording profile's page against the code's lists: quantities and units, nameplate keys, channel metadata keys, the report's keys; no page names a path outside the repository; `scripts/fetch-datasets` keeps only files of the pinned SHA-256 |
//! | [`plant_export`] | a hand-written German historian export (`;`, decimal comma, day-first local times) through `import --guess`, the import and the replay, with only the nameplate and the zone filled in |
//! | [`broken_pipe`] | a closed pipe (`heatrun info f.mcap \| head -1`) ends a command quietly |
//! | [`interrupted`] | a replay stopped by Ctrl-C, SIGTERM or SIGHUP while it writes ends by that signal and leaves no temporary file |
//! | `object_store` | (feature `object-store`) `s3://` recordings, prefixes as fleets, `--index`, `fleet summary` and store errors, against moto's S3 server on loopback |
//!
//! A new test file `tests/NAME.rs` becomes `mod NAME;` here; shared helpers are in
//! [`common`]. The two feature-gated files run with `cargo test --release --all-features`
//! (as `.ci/run` does); the README's `cargo test --release` builds without them.

mod common;

mod bad_input;
mod broken_pipe;
mod comfort;
mod coolant;
mod corpus;
mod datasets;
mod estimators;
mod field_state;
mod flaws;
mod fleet_compare;
mod historian;
mod html;
mod import;
mod interrupted;
mod layouts;
mod monitor;
mod network_rc;
#[cfg(feature = "object-store")]
mod object_store;
mod outputs;
mod paper;
#[cfg(feature = "parquet")]
mod parquet;
mod plant_export;
mod plausibility;
mod predict;
mod profile;
mod recovery;
mod spec;
mod tables;
