//! A table as rows of cells, whatever it is stored in: the delimited text tables of
//! [`super::table`] and the Parquet files of `super::parquet` (the `parquet` feature) both are a
//! [`RowSource`], which the wide and the long imports read alike.

use std::io::Read as _;
use std::path::Path;

use super::error::{ImportError, Place};
use super::time::Stamp;

/// Whether the file starts with Parquet's magic bytes `PAR1` (known whether or not this
/// build reads Parquet, so that a build without it can say so).
pub fn is_parquet(path: &Path) -> Result<bool, ImportError> {
    let mut magic = [0u8; 4];
    let mut file = std::fs::File::open(path).map_err(|error| ImportError::Read {
        path: path.to_owned(),
        error,
    })?;
    Ok(file.read_exact(&mut magic).is_ok() && &magic == b"PAR1")
}

/// One cell of a row, as the table holds it.
// Numbers, times and nulls come from Parquet alone: a build without it never makes them.
#[cfg_attr(not(feature = "parquet"), allow(dead_code))]
#[derive(Debug, Clone, PartialEq)]
pub enum Cell<'a> {
    /// Text, as a delimited table holds every cell (and Parquet its strings).
    Text(&'a str),
    /// A number stored as a number (Parquet's integers and floats).
    Number(f64),
    /// A time stored as one (Parquet's timestamps).
    Time(Stamp),
    /// No value (Parquet's null).
    Null,
}

/// A table read one row at a time; one row is in memory at a time (a Parquet row
/// group's pages at most).
pub trait RowSource {
    /// Moves to the next row; `false` at the end of the table.
    fn next_row(&mut self) -> Result<bool, ImportError>;
    /// Fields in the current row.
    fn width(&self) -> usize;
    /// The current row's field `index` (0-based, below [`RowSource::width`]).
    fn cell(&self, index: usize) -> Cell<'_>;
    /// Where the current row is, for messages.
    fn place(&self) -> Place;
}

impl Cell<'_> {
    /// The cell as text for messages (and for flags stored as numbers).
    pub fn text(&self) -> String {
        match self {
            Cell::Text(t) => (*t).to_owned(),
            Cell::Number(v) => format!("{v}"),
            Cell::Time(Stamp::Instant(ns)) => jiff::Timestamp::from_nanosecond(*ns)
                .map(|t| t.to_string())
                .unwrap_or_else(|_| format!("{ns} ns")),
            Cell::Time(Stamp::Civil(c)) => c.to_string(),
            Cell::Null => String::new(),
        }
    }
}
