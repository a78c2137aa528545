//! Parquet tables, wide or long, read with arrow-rs's `parquet` crate one row group
//! at a time through its row reader: the header is the schema's top-level column
//! names, numbers stay numbers, nulls are missing cells, and timestamps come from
//! Parquet's timestamp types (UTC-adjusted ones as instants, local ones as wall-clock
//! times for the map's zone).

use std::fs::File;
use std::path::{Path, PathBuf};

use parquet::basic::{LogicalType, TimeUnit};
use parquet::file::reader::{FileReader, SerializedFileReader};
use parquet::record::reader::RowIter;
use parquet::record::Field;

use super::error::{ImportError, Place};
use super::source::{Cell, RowSource};
use super::time::Stamp;

/// How a column's integers are to be read.
#[derive(Debug, Clone, Copy)]
enum TimeKind {
    /// Not a timestamp.
    None,
    /// A timestamp in units of this many ns; UTC-adjusted or local.
    Timestamp { unit_ns: i128, utc: bool },
}

/// A cell of the current row, owned.
enum Owned {
    Text(String),
    Number(f64),
    Time(Stamp),
    Null,
}

/// A Parquet file read one row at a time.
pub struct ParquetTable {
    path: PathBuf,
    names: Vec<String>,
    kinds: Vec<TimeKind>,
    rows: RowIter<'static>,
    current: Vec<Owned>,
    row: u64,
}

impl ParquetTable {
    /// Opens `path` and reads its footer (the schema and the row groups' places).
    pub fn open(path: &Path) -> Result<ParquetTable, ImportError> {
        let file = File::open(path).map_err(|error| ImportError::Read {
            path: path.to_owned(),
            error,
        })?;
        let reader = SerializedFileReader::new(file).map_err(|e| parquet_error(path, e))?;
        let schema = reader.metadata().file_metadata().schema_descr_ptr();
        let root = schema.root_schema();
        let names = root
            .get_fields()
            .iter()
            .map(|f| f.name().to_owned())
            .collect();
        let kinds = root
            .get_fields()
            .iter()
            .map(|f| match f.get_basic_info().logical_type_ref() {
                Some(LogicalType::Timestamp {
                    is_adjusted_to_u_t_c,
                    unit,
                }) => TimeKind::Timestamp {
                    unit_ns: match unit {
                        TimeUnit::MILLIS => 1_000_000,
                        TimeUnit::MICROS => 1_000,
                        TimeUnit::NANOS => 1,
                    },
                    utc: *is_adjusted_to_u_t_c,
                },
                _ => TimeKind::None,
            })
            .collect();
        Ok(ParquetTable {
            path: path.to_owned(),
            names,
            kinds,
            rows: RowIter::from_file_into(Box::new(reader)),
            current: Vec::new(),
            row: 0,
        })
    }

    /// The schema's top-level column names.
    pub fn header(&self) -> Vec<String> {
        self.names.clone()
    }
}

fn parquet_error(path: &Path, e: parquet::errors::ParquetError) -> ImportError {
    ImportError::Parquet {
        path: path.to_owned(),
        message: e.to_string().replace('\n', " "),
    }
}

/// A field as a cell: numbers as numbers, strings as text, timestamps (by their
/// converted or logical type) as times, anything else as its text.
fn owned(field: Field, kind: TimeKind) -> Owned {
    let time = |value: i64, unit_ns: i128, utc: bool| {
        let ns = i128::from(value) * unit_ns;
        if utc {
            return Owned::Time(Stamp::Instant(ns));
        }
        // A local timestamp is stored as if its wall-clock time were UTC.
        match jiff::Timestamp::from_nanosecond(ns) {
            Ok(t) => Owned::Time(Stamp::Civil(t.to_zoned(jiff::tz::TimeZone::UTC).datetime())),
            Err(_) => Owned::Text(format!("{value}")),
        }
    };
    let utc = match kind {
        TimeKind::Timestamp { utc, .. } => utc,
        TimeKind::None => true,
    };
    match field {
        Field::Null => Owned::Null,
        Field::Str(s) => Owned::Text(s),
        Field::TimestampMillis(v) => time(v, 1_000_000, utc),
        Field::TimestampMicros(v) => time(v, 1_000, utc),
        Field::Long(v) => match kind {
            TimeKind::Timestamp { unit_ns, utc } => time(v, unit_ns, utc),
            TimeKind::None => Owned::Number(v as f64),
        },
        Field::Double(v) => Owned::Number(v),
        Field::Float(v) => Owned::Number(f64::from(v)),
        Field::Int(v) => Owned::Number(f64::from(v)),
        Field::Short(v) => Owned::Number(f64::from(v)),
        Field::Byte(v) => Owned::Number(f64::from(v)),
        Field::UByte(v) => Owned::Number(f64::from(v)),
        Field::UShort(v) => Owned::Number(f64::from(v)),
        Field::UInt(v) => Owned::Number(f64::from(v)),
        Field::ULong(v) => Owned::Number(v as f64),
        other => Owned::Text(other.to_string()),
    }
}

impl RowSource for ParquetTable {
    fn next_row(&mut self) -> Result<bool, ImportError> {
        let Some(row) = self.rows.next() else {
            return Ok(false);
        };
        let row = row.map_err(|e| parquet_error(&self.path, e))?;
        self.current.clear();
        for ((_, field), kind) in row.into_columns().into_iter().zip(&self.kinds) {
            self.current.push(owned(field, *kind));
        }
        self.row += 1;
        Ok(true)
    }

    fn width(&self) -> usize {
        self.current.len()
    }

    fn cell(&self, index: usize) -> Cell<'_> {
        match &self.current[index] {
            Owned::Text(t) => Cell::Text(t),
            Owned::Number(v) => Cell::Number(*v),
            Owned::Time(s) => Cell::Time(*s),
            Owned::Null => Cell::Null,
        }
    }

    fn place(&self) -> Place {
        Place::Row(self.row)
    }
}
