//! A row's time from its time cell (or its index), as the map's `[time]` says, and
//! the messages for a time that cannot be placed. The wide and the long import share
//! it; each keeps its own [`RowClock`]s.

use std::path::Path;

use super::error::{ImportError, Place};
use super::map::{TimeFormat, TimeSource, TimeSpec};
use super::source::{Cell, RowSource};
use super::time::{self, ClockError, Stamp};
use crate::recording::format_time;

/// Where a row's time comes from, resolved against the table.
pub enum RowTime {
    /// A column of the table (0-based index, and its label for messages).
    Column {
        /// The column's index.
        index: usize,
        /// `2 (`Zeit`)`.
        label: String,
        /// Decided from the first row when the map leaves it open.
        format: TimeFormat,
        /// ns in one unit of a seconds column.
        unit_ns: i128,
        /// A strftime layout of the timestamps.
        pattern: Option<String>,
        /// The instant of t = 0 of a seconds column.
        start_ns: i128,
        /// Seconds written with a decimal comma.
        decimal_comma: bool,
    },
    /// No column: row i is at start + i · Ts.
    Index {
        /// The first row's instant.
        start_ns: i128,
        /// Ts.
        sample_time_ns: i128,
    },
}

impl RowTime {
    /// The map's time source, with the time column found by `find`.
    pub fn plan(
        spec: &TimeSpec,
        decimal_comma: bool,
        find: impl FnOnce(&super::map::ColumnRef) -> Result<(usize, String), ImportError>,
    ) -> Result<RowTime, ImportError> {
        Ok(match &spec.source {
            TimeSource::Column {
                column,
                format,
                unit_ns,
                pattern,
            } => {
                let (index, label) = find(column)?;
                RowTime::Column {
                    index,
                    label,
                    format: *format,
                    unit_ns: *unit_ns,
                    pattern: pattern.clone(),
                    start_ns: spec.start_ns,
                    decimal_comma,
                }
            }
            TimeSource::SampleIndex { sample_time_ns } => RowTime::Index {
                start_ns: spec.start_ns,
                sample_time_ns: *sample_time_ns,
            },
        })
    }

    /// The time column's label for messages.
    pub fn label(&self) -> String {
        match self {
            RowTime::Column { label, .. } => label.clone(),
            RowTime::Index { .. } => "(row index)".to_owned(),
        }
    }

    /// The row's time as written, and that text for messages. `row_index` counts the
    /// rows from 0.
    pub fn stamp(
        &mut self,
        row: &dyn RowSource,
        row_index: u64,
    ) -> (Result<Stamp, String>, String) {
        match self {
            RowTime::Index {
                start_ns,
                sample_time_ns,
            } => (
                Ok(Stamp::Instant(
                    *start_ns + row_index as i128 * *sample_time_ns,
                )),
                String::new(),
            ),
            RowTime::Column {
                index,
                format,
                unit_ns,
                pattern,
                start_ns,
                decimal_comma,
                ..
            } => {
                let cell = row.cell(*index);
                let text = cell.text();
                let stamp = match cell {
                    Cell::Time(stamp) => Ok(stamp),
                    Cell::Null => Err("the cell is empty".to_owned()),
                    // A number stored as one: seconds (or the map's unit) after start.
                    Cell::Number(v) if v.is_finite() => Ok(Stamp::Instant(
                        *start_ns + (v * *unit_ns as f64).round() as i128,
                    )),
                    Cell::Number(_) => Err("not a finite number".to_owned()),
                    Cell::Text(t) => text_stamp(
                        t,
                        format,
                        *unit_ns,
                        pattern.as_deref(),
                        *start_ns,
                        *decimal_comma,
                    ),
                };
                (stamp, text)
            }
        }
    }
}

/// A time cell written as text: seconds or a timestamp (decided on the first row
/// when the map leaves the format open).
fn text_stamp(
    text: &str,
    format: &mut TimeFormat,
    unit_ns: i128,
    pattern: Option<&str>,
    start_ns: i128,
    decimal_comma: bool,
) -> Result<Stamp, String> {
    // A table written with decimal commas writes its seconds so too.
    let text = if decimal_comma && !text.contains('.') {
        text.replacen(',', ".", 1)
    } else {
        text.to_owned()
    };
    if *format == TimeFormat::Auto {
        *format = if time::looks_like_seconds(&text) {
            TimeFormat::Seconds
        } else {
            TimeFormat::Timestamp
        };
    }
    match format {
        TimeFormat::Timestamp => time::parse_stamp(&text, pattern),
        _ => time::parse_decimal_ns(&text, unit_ns)
            .map(|t| Stamp::Instant(start_ns + t))
            .ok_or_else(|| "not a number of seconds, as the first row's time is".to_owned()),
    }
}

/// A time that could not be placed, as the import's error. `previous_row` says which
/// row the clock compared with (`on the row before`).
pub fn time_error(
    path: &Path,
    line: Place,
    column: String,
    text: String,
    error: ClockError,
    previous_row: &str,
) -> ImportError {
    match error {
        ClockError::Bad(reason) => ImportError::BadTime {
            path: path.to_owned(),
            line,
            column,
            text,
            reason,
        },
        ClockError::Skipped {
            zone,
            before,
            after,
        } => ImportError::SkippedTime {
            path: path.to_owned(),
            line,
            column,
            text,
            zone: format!("{zone} (the clock went forward from {before} to {after} there)"),
        },
        ClockError::Backwards { previous, current } => ImportError::TimeBackwards {
            path: path.to_owned(),
            line,
            column,
            previous: format!("{} {previous_row}", format_time(previous)),
            current: format_time(current),
            back_s: previous.saturating_sub(current) as f64 / 1e9,
        },
    }
}
