//! Errors of the commands that use an identified model (predict, rating, monitor): the
//! model report or the load file at fault, named with its key, row or column.

use std::path::PathBuf;

/// What is wrong with a model report, a load file or a request made of the model.
#[derive(Debug, thiserror::Error)]
pub enum UseError {
    /// The file could not be read.
    #[error("{path}: cannot read: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// A report in object storage could not be read: the store's error names the URL.
    #[error(transparent)]
    Store(#[from] crate::store::StoreError),
    /// The model file is not a report of `heatrun replay --report` (not JSON, or a key of
    /// the wrong type).
    #[error("{path}: not a heatrun model report: {message}")]
    NotAReport {
        /// The file.
        path: PathBuf,
        /// serde's message (it names the key and line).
        message: String,
    },
    /// The report is of another profile version.
    #[error("{path}: a report of profile `{found}`; this heatrun reads `{expected}`")]
    ProfileVersion {
        /// The file.
        path: PathBuf,
        /// The report's `profile`.
        found: String,
        /// The profile this heatrun writes.
        expected: &'static str,
    },
    /// The report lacks a block or key the command needs.
    #[error("{path}: the report has no `{key}`, which {needed_for}")]
    MissingBlock {
        /// The file.
        path: PathBuf,
        /// The key (dotted path).
        key: String,
        /// What needs it.
        needed_for: String,
    },
    /// The report's matrices and names do not agree in size.
    #[error("{path}: `{key}` is {found}; the model of {states} states and {inputs} inputs needs {expected}")]
    Shape {
        /// The file.
        path: PathBuf,
        /// The key.
        key: &'static str,
        /// What it holds.
        found: String,
        /// What it should hold.
        expected: String,
        /// n.
        states: usize,
        /// m.
        inputs: usize,
    },
    /// An input or reference the command cannot compute from a load schedule.
    #[error("{path}: {what} `{name}` is {source_kind}, which a load schedule cannot give")]
    Unsupported {
        /// The file.
        path: PathBuf,
        /// `input` or `state reference`.
        what: &'static str,
        /// Its name.
        name: String,
        /// How the report describes it.
        source_kind: String,
    },
    /// A column of the load file is not one the model reads.
    #[error("{path}: row 1, column `{column}`: not a load column (known: {known})")]
    UnknownColumn {
        /// The load file.
        path: PathBuf,
        /// The header cell.
        column: String,
        /// The columns this model reads.
        known: String,
    },
    /// A column the schedule needs is missing.
    #[error("{path}: row 1: no column `{column}` ({why})")]
    MissingColumn {
        /// The load file.
        path: PathBuf,
        /// The column.
        column: String,
        /// Why it is needed.
        why: &'static str,
    },
    /// A cell is not a number (or not one the column admits).
    #[error("{path}: row {row}, column `{column}`: `{value}` is not {requirement}")]
    BadCell {
        /// The load file.
        path: PathBuf,
        /// Line in the file (the header is row 1).
        row: u64,
        /// The column.
        column: String,
        /// The cell as written.
        value: String,
        /// What the column needs.
        requirement: &'static str,
    },
    /// Time goes backwards (or stands still) between rows.
    #[error("{path}: row {row}, column `time_s`: {time_s} s is not after the previous row's {previous_s} s")]
    TimeBackwards {
        /// The load file.
        path: PathBuf,
        /// Line in the file.
        row: u64,
        /// This row's time.
        time_s: f64,
        /// The previous row's.
        previous_s: f64,
    },
    /// The schedule runs longer than a prediction holds in memory (`max` steps of the
    /// model's sample time).
    #[error(
        "{path}: row {row}, column `time_s`: {time_s} s is {steps:.0} steps of the model's {ts_s} s \
         after the schedule's start, over the {max} a prediction holds in memory (about 1.5 kB a step)"
    )]
    ScheduleTooLong {
        /// The load file.
        path: PathBuf,
        /// Line in the file.
        row: u64,
        /// This row's time.
        time_s: f64,
        /// Its steps after the schedule's first row.
        steps: f64,
        /// The model's sample time, s.
        ts_s: f64,
        /// The steps a prediction may span.
        max: usize,
    },
    /// The load file is malformed CSV or has no rows.
    #[error("{path}: {message}")]
    BadTable {
        /// The load file.
        path: PathBuf,
        /// What is wrong (the csv crate's message names the row).
        message: String,
    },
    /// A request the model cannot answer (an initial-temperature list of the wrong length,
    /// a limit for no state, a rating with no limit).
    #[error("{0}")]
    Request(String),
}
