//! What can go wrong in an import, each naming the file, line and column it is about.

use std::path::PathBuf;

/// Where in a table a row is: a text line (CSV), or a row (Parquet, counted from 1
/// after the header, across row groups).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Place {
    /// A line of a text table, 1-based, as an editor numbers it.
    Line(u64),
    /// A row of a Parquet file, 1-based.
    Row(u64),
}

impl std::fmt::Display for Place {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Place::Line(n) => write!(f, "line {n}"),
            Place::Row(n) => write!(f, "row {n}"),
        }
    }
}

/// An import that could not be done. Every message is one line naming the file and,
/// where there is one, the line and column; no output is left behind.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    /// A file (the table or the map) could not be opened or read.
    #[error("{path}: cannot read: {error}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The operating-system error (not a `source`: the message already says it).
        error: std::io::Error,
    },
    /// The map is not valid TOML or has a key it does not know.
    #[error("{path}: line {line}: {message}")]
    MapSyntax {
        /// The map file.
        path: PathBuf,
        /// The line of the map, 1-based.
        line: usize,
        /// What the TOML parser found.
        message: String,
    },
    /// A value of the map is out of its range or contradicts another.
    #[error("{path}: {key}: {message}")]
    MapValue {
        /// The map file.
        path: PathBuf,
        /// The key, as `column 3 (T1).deadband` or `time.zone`.
        key: String,
        /// What is wrong and what is accepted.
        message: String,
    },
    /// The map names a column by header name, but the table has no header line.
    #[error("{map}: column `{column}` is named, but {path} has no header line; give its position (1-based) instead")]
    NoHeader {
        /// The map file.
        map: PathBuf,
        /// The table.
        path: PathBuf,
        /// The name the map gives.
        column: String,
    },
    /// The map names a column the table does not have.
    #[error("{path}: {line}: no column {column} (named in {map}); the columns are {available}")]
    AbsentColumn {
        /// The table.
        path: PathBuf,
        /// The line that shows the columns (the header, or the first data line).
        line: Place,
        /// The map file.
        map: PathBuf,
        /// The column as the map names it (`Heater 3` or `12`).
        column: String,
        /// The table's columns, for the reader to choose from.
        available: String,
    },
    /// A row has another number of fields than the header (or the first row).
    #[error("{path}: line {line} has {found} fields where line {first_line} has {expected}")]
    RaggedRow {
        /// The table.
        path: PathBuf,
        /// The line of the row.
        line: u64,
        /// Fields found on it.
        found: usize,
        /// Fields of the first row (or the header).
        expected: usize,
        /// The line that set the expected count.
        first_line: u64,
    },
    /// A value cell that is neither a number nor missing (empty, `NaN`).
    #[error("{path}: {line}, column {column}: `{text}` is not a number (an empty cell or NaN is a missing sample)")]
    BadNumber {
        /// The table.
        path: PathBuf,
        /// The line of the row.
        line: Place,
        /// The column, by position and header name.
        column: String,
        /// The cell as written.
        text: String,
    },
    /// A quality cell that is none of the accepted flags.
    #[error("{path}: {line}, column {column}: `{text}` is not a quality flag ({accepted})")]
    BadQuality {
        /// The table.
        path: PathBuf,
        /// The line of the row.
        line: Place,
        /// The quality column, by position and header name.
        column: String,
        /// The cell as written.
        text: String,
        /// What the column may hold.
        accepted: String,
    },
    /// A time cell that cannot be read as the map's time format says.
    #[error("{path}: {line}, column {column}: `{text}` is not a time: {reason}")]
    BadTime {
        /// The table.
        path: PathBuf,
        /// The line of the row.
        line: Place,
        /// The time column, by position and header name.
        column: String,
        /// The cell as written.
        text: String,
        /// Why it was not read.
        reason: String,
    },
    /// A row's time is earlier than the row before it.
    #[error("{path}: {line}, column {column}: time goes backwards, from {previous} to {current}")]
    TimeBackwards {
        /// The table.
        path: PathBuf,
        /// The line of the row.
        line: Place,
        /// The time column, by position and header name.
        column: String,
        /// The previous row's time (RFC 3339, UTC) and which row that was:
        /// `2024-01-01T00:00:00Z on the line before`.
        previous: String,
        /// This row's time (RFC 3339, UTC).
        current: String,
        /// How far it goes back, s (about 3600 where summer time ended on a local clock).
        back_s: f64,
    },
    /// The CSV reader could not read a record (a broken quote).
    #[error("{path}: line {line}: {message}")]
    Table {
        /// The table.
        path: PathBuf,
        /// The line where the record starts.
        line: u64,
        /// What the CSV reader found.
        message: String,
    },
    /// A Parquet table, given to a build without the `parquet` feature.
    #[error(
        "{path}: a Parquet table, and this heatrun was built without Parquet; build it with \
         `cargo build --release --features parquet` (or export the table as CSV)"
    )]
    ParquetNotBuilt {
        /// The table.
        path: PathBuf,
    },
    /// The table holds no data rows.
    #[error("{path}: no data rows")]
    NoData {
        /// The table.
        path: PathBuf,
    },
    /// The output would replace the input.
    #[error("{path}: the output would replace the input")]
    OutputIsInput {
        /// The file named as both.
        path: PathBuf,
    },
    /// A Parquet file that its reader rejects (not Parquet, a damaged page, an
    /// unsupported encoding or compression).
    #[error("{path}: not a Parquet file heatrun can read: {message}")]
    Parquet {
        /// The file.
        path: PathBuf,
        /// What the Parquet reader said.
        message: String,
    },
    /// A row's local time falls in the hour skipped when the clock went forward: no
    /// instant has that wall-clock time.
    #[error("{path}: {line}, column {column}: `{text}` does not exist in {zone}; the table's times are not that zone's wall-clock time")]
    SkippedTime {
        /// The table.
        path: PathBuf,
        /// The row.
        line: Place,
        /// The time column, by position and header name.
        column: String,
        /// The cell as written.
        text: String,
        /// The zone and its change: `Europe/Zurich (the clock went forward from +01:00
        /// to +02:00 there)`.
        zone: String,
    },
    /// Writing the recording failed.
    #[error(transparent)]
    Write(#[from] crate::atomic::WriteError),
}

impl ImportError {
    /// Whether the error is the input's fault (a bad table or map) rather than the
    /// machine's (the output could not be written).
    pub fn is_bad_input(&self) -> bool {
        !matches!(self, ImportError::Write(_))
    }
}
