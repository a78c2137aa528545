//! Importing tables (CSV, historian exports wide or long, DaISy `.dat`, Parquet) into
//! profile recordings.
//!
//! Input: a table and an [`ImportMap`] that says which column holds the time and
//! which become channels (a profile quantity or a free name, with unit, sensor,
//! quality and storage), plus the nameplate and other metadata records. The table is a
//! `source::RowSource`: delimited text (`table`) or Parquet (`parquet`, with the feature, known by
//! its magic bytes). Output: a complete profile recording, written by
//! [`crate::writer`] under a temporary name and renamed when complete.
//!
//! The table streams through one row at a time. A wide table's row becomes one
//! message per imported column at the row's time; a long table's row (`layout =
//! "long"`, `long`) one message on its tag's channel. Times are kept as they are
//! (non-uniform spacing stays); wall-clock times in the map's zone are placed by a
//! `RowClock`, which resolves the hour repeated when summer time ends by the rows'
//! order and names each change crossed in the summary and the `heatrun.import`
//! record. An empty cell, `NaN`, a null or one of the map's `missing` markers is a
//! missing sample: no message is written for it. On a sampled channel the silence is
//! then a gap, and on a channel stored by exception it is what a historian export
//! shows between stored samples; writing nothing keeps both meanings, where a `null`
//! dropout would say a sample was due.
//!
//! Any malformed cell, ragged row, unreadable, skipped or backward time, or column the
//! map names that the table lacks stops the import with one [`ImportError`] naming the
//! file, line (or row) and column, and nothing is written.

mod error;
mod guess;
mod long;
mod map;
#[cfg(feature = "parquet")]
mod parquet;
mod row_time;
mod source;
mod table;
mod time;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub use error::{ImportError, Place};
pub use guess::guess_map;
pub use map::ImportMap;
pub use time::ClockChange;

use map::{ColumnRef, ColumnSource, Delimiter, Layout, QualitySource};
use row_time::{time_error, RowTime};
use source::{Cell, RowSource};
use table::Table;
use time::{ClockError, RowClock};

use crate::writer::{ChannelId, Quality, RecordingWriter, WriterOptions};

/// What an import wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportSummary {
    /// The recording written.
    pub out: PathBuf,
    /// Data rows read.
    pub rows: u64,
    /// The channels, in the map's order.
    pub channels: Vec<ImportedChannel>,
    /// The first and last row's time, ns since the epoch.
    pub time_span_ns: (u64, u64),
    /// Messages written.
    pub messages: u64,
    /// The zone's changes of offset the rows crossed (a repeated or skipped hour),
    /// and how each was resolved; also in the recording's `heatrun.import` record.
    pub clock_changes: Vec<ClockChange>,
    /// Rows of a long table whose tag the map does not list (not imported).
    pub unlisted_rows: u64,
}

/// One channel of an import.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportedChannel {
    /// The MCAP topic.
    pub topic: String,
    /// The unit.
    pub unit: String,
    /// Samples written.
    pub samples: u64,
    /// Missing cells (no message).
    pub missing: u64,
}

/// What reading the rows gave, wide or long.
struct Read {
    rows: u64,
    channels: Vec<ImportedChannel>,
    span: Option<(u64, u64)>,
    clock_changes: Vec<ClockChange>,
    unlisted_rows: u64,
}

/// Imports the table `input` (delimited text, or Parquet) as `map` says into the
/// recording `out`.
pub fn import(input: &Path, map: &ImportMap, out: &Path) -> Result<ImportSummary, ImportError> {
    if same_file(input, out) {
        return Err(ImportError::OutputIsInput {
            path: out.to_owned(),
        });
    }
    let mut opened = open(input, map)?;
    let shape = Shape {
        input,
        map,
        header: opened.header.as_deref(),
        fields: opened.fields,
        line: opened.header_place,
    };
    let mut writer = RecordingWriter::create(out, WriterOptions::default())?;
    // The records first: a metadata record closes the open chunk, which would
    // otherwise hold only the channel records.
    write_records(&mut writer, map)?;
    let source = opened.source.as_mut();
    let read = match &map.layout {
        Layout::Wide => {
            let mut rows = Rows::plan(&shape, opened.decimal_comma, &mut writer)?;
            each_row(source, |row| rows.convert(row, &mut writer))?;
            rows.finish(map)
        }
        Layout::Long(columns) => {
            let mut rows =
                long::LongRows::plan(&shape, columns, opened.decimal_comma, &mut writer)?;
            each_row(source, |row| rows.convert(row, &mut writer))?;
            rows.finish(map)
        }
    };
    write_import_record(&mut writer, input, map, &read.clock_changes)?;
    let written = writer.finish()?;
    Ok(ImportSummary {
        out: out.to_owned(),
        rows: read.rows,
        channels: read.channels,
        time_span_ns: read.span.unwrap_or((0, 0)),
        messages: written.messages,
        clock_changes: read.clock_changes,
        unlisted_rows: read.unlisted_rows,
    })
}

/// Calls `convert` on the current row and each after it.
fn each_row(
    source: &mut dyn RowSource,
    mut convert: impl FnMut(&dyn RowSource) -> Result<(), ImportError>,
) -> Result<(), ImportError> {
    loop {
        convert(source)?;
        if !source.next_row()? {
            return Ok(());
        }
    }
}

/// A table opened at its first data row.
struct Opened {
    source: Box<dyn RowSource>,
    header: Option<Vec<String>>,
    /// Fields in the header (or the first row).
    fields: usize,
    /// Where the header (or the first row) is.
    header_place: Place,
    /// Numbers written with a decimal comma.
    decimal_comma: bool,
}

/// A Parquet table with its header and first data row.
#[cfg(feature = "parquet")]
fn open_parquet(input: &Path) -> Result<Opened, ImportError> {
    let mut table = parquet::ParquetTable::open(input)?;
    let header = table.header();
    if !table.next_row()? {
        return Err(ImportError::NoData {
            path: input.to_owned(),
        });
    }
    Ok(Opened {
        fields: header.len(),
        header: Some(header),
        source: Box::new(table),
        // The schema names the columns; messages point at the first row.
        header_place: Place::Row(1),
        decimal_comma: false,
    })
}

/// A build without the `parquet` feature refuses a Parquet table in one line.
#[cfg(not(feature = "parquet"))]
fn open_parquet(input: &Path) -> Result<Opened, ImportError> {
    Err(ImportError::ParquetNotBuilt {
        path: input.to_owned(),
    })
}

/// Opens a Parquet file (known by its magic bytes) or a delimited text table, and
/// reads its header and first data row.
fn open(input: &Path, map: &ImportMap) -> Result<Opened, ImportError> {
    if source::is_parquet(input)? {
        return open_parquet(input);
    }
    let lines = table::first_lines(input, map.input.skip_lines, map.input.comment)?;
    let dialect = table::resolve_dialect(&map.input, &lines);
    let mut table = Table::open(input, &dialect)?;
    let no_data = || ImportError::NoData {
        path: input.to_owned(),
    };
    let header = if dialect.header {
        if !table.next_row()? {
            return Err(no_data());
        }
        Some((table.fields(), table.line()))
    } else {
        None
    };
    if !table.next_row()? {
        return Err(no_data());
    }
    Ok(Opened {
        fields: header
            .as_ref()
            .map_or(table.record().len(), |(h, _)| h.len()),
        header_place: Place::Line(header.as_ref().map_or(table.line(), |(_, l)| *l)),
        header: header.map(|(h, _)| h),
        source: Box::new(table),
        decimal_comma: dialect.decimal_comma && dialect.delimiter != Delimiter::Byte(b','),
    })
}

fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    }
}

/// The nameplate and the map's metadata records.
fn write_records(writer: &mut RecordingWriter, map: &ImportMap) -> Result<(), ImportError> {
    if !map.nameplate.is_empty() {
        writer.write_nameplate(&map.nameplate)?;
    }
    for (name, entries) in &map.metadata {
        writer.write_metadata(name, entries)?;
    }
    Ok(())
}

/// The `heatrun.import` record, written after the rows: the source and the map, and
/// with a zone, `time_zone` and `clock_changes` (each change crossed and how its rows
/// were placed, `; `-separated, or `none`).
fn write_import_record(
    writer: &mut RecordingWriter,
    input: &Path,
    map: &ImportMap,
    changes: &[ClockChange],
) -> Result<(), ImportError> {
    let file_name = |p: &Path| {
        p.file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default()
    };
    let mut record: BTreeMap<String, String> = [
        ("source".to_owned(), file_name(input)),
        ("map".to_owned(), file_name(&map.path)),
    ]
    .into();
    if let Some(zone) = &map.time.zone {
        let name = zone.iana_name().map_or_else(
            || time::offset_text(zone.to_offset(jiff::Timestamp::UNIX_EPOCH).seconds()),
            str::to_owned,
        );
        record.insert("time_zone".to_owned(), name);
        let described: Vec<String> = changes.iter().map(ClockChange::describe).collect();
        record.insert(
            "clock_changes".to_owned(),
            if described.is_empty() {
                "none".to_owned()
            } else {
                described.join("; ")
            },
        );
    }
    writer.write_metadata("heatrun.import", &record)?;
    Ok(())
}

/// The table's columns as far as the map needs them.
pub(crate) struct Shape<'a> {
    input: &'a Path,
    map: &'a ImportMap,
    /// The header's names, if there is a header.
    header: Option<&'a [String]>,
    /// Fields in the header (or the first row).
    fields: usize,
    /// Where the header (or the first row) is.
    line: Place,
}

impl Shape<'_> {
    /// The 0-based index of a column the map names, and its label for messages.
    fn find(&self, column: &ColumnRef) -> Result<(usize, String), ImportError> {
        let absent = || ImportError::AbsentColumn {
            path: self.input.to_owned(),
            line: self.line,
            map: self.map.path.clone(),
            column: column.to_string(),
            available: self.available(),
        };
        let index = match column {
            ColumnRef::Position(p) => {
                let i = usize::try_from(*p - 1).map_err(|_| absent())?;
                if i >= self.fields {
                    return Err(absent());
                }
                i
            }
            ColumnRef::Name(name) => {
                let header = self.header.ok_or_else(|| ImportError::NoHeader {
                    map: self.map.path.clone(),
                    path: self.input.to_owned(),
                    column: name.clone(),
                })?;
                let name = name.trim();
                let mut matches = header.iter().enumerate().filter(|(_, h)| h.trim() == name);
                let (i, _) = matches.next().ok_or_else(absent)?;
                if matches.next().is_some() {
                    return Err(ImportError::MapValue {
                        path: self.map.path.clone(),
                        key: format!("column `{name}`"),
                        message: format!(
                            "{} has several columns of this name; give its position (1-based)",
                            self.input.display()
                        ),
                    });
                }
                i
            }
        };
        Ok((index, self.label(index)))
    }

    /// `3 (`T1 (degC)`)` with a header, `3` without.
    fn label(&self, index: usize) -> String {
        match self.header.and_then(|h| h.get(index)) {
            Some(name) => format!("{} (`{name}`)", index + 1),
            None => format!("{}", index + 1),
        }
    }

    fn available(&self) -> String {
        const SHOWN: usize = 16;
        let mut names: Vec<String> = match self.header {
            Some(h) => h.iter().take(SHOWN).map(|n| format!("`{n}`")).collect(),
            None => vec![format!("1 to {} (no header)", self.fields)],
        };
        if self.header.is_some_and(|h| h.len() > SHOWN) {
            names.push(format!("and {} more", self.fields - SHOWN));
        }
        names.join(", ")
    }

    /// A row with another number of fields than the header: an error.
    fn check_width(&self, row: &dyn RowSource) -> Result<(), ImportError> {
        if row.width() == self.fields {
            return Ok(());
        }
        // Only text tables have rows of their own width; a row number serves otherwise.
        let number = |p: Place| match p {
            Place::Line(n) | Place::Row(n) => n,
        };
        let (line, first_line) = (number(row.place()), number(self.line));
        Err(ImportError::RaggedRow {
            path: self.input.to_owned(),
            line,
            found: row.width(),
            expected: self.fields,
            first_line,
        })
    }
}

/// One imported column of a wide table, resolved against the table.
struct ColumnPlan {
    index: usize,
    label: String,
    channel: ChannelId,
    quality: Option<QualityPlan>,
    samples: u64,
    missing: u64,
}

/// A column of quality flags, resolved.
pub(crate) struct QualityPlan {
    index: usize,
    label: String,
    values: BTreeMap<String, Quality>,
}

impl QualityPlan {
    fn new(shape: &Shape, source: &QualitySource) -> Result<QualityPlan, ImportError> {
        let (index, label) = shape.find(&source.column)?;
        Ok(QualityPlan {
            index,
            label,
            values: source.values.clone(),
        })
    }

    /// The current row's flag.
    fn read(&self, row: &dyn RowSource, path: &Path) -> Result<Quality, ImportError> {
        let cell = row.cell(self.index);
        parse_quality_cell(&cell, &self.values).ok_or_else(|| ImportError::BadQuality {
            path: path.to_owned(),
            line: row.place(),
            column: self.label.clone(),
            text: cell.text(),
            accepted: quality_words(&self.values),
        })
    }
}

/// The conversion of a wide table's rows into messages.
struct Rows<'a> {
    shape: &'a Shape<'a>,
    time: RowTime,
    clock: RowClock,
    columns: Vec<ColumnPlan>,
    decimal_comma: bool,
    count: u64,
}

impl<'a> Rows<'a> {
    /// Resolves the map's columns and adds their channels to the recording.
    fn plan(
        shape: &'a Shape<'a>,
        decimal_comma: bool,
        writer: &mut RecordingWriter,
    ) -> Result<Rows<'a>, ImportError> {
        let map = shape.map;
        let time = RowTime::plan(&map.time, decimal_comma, |c| shape.find(c))?;
        let mut columns = Vec::new();
        for c in &map.columns {
            // A map read from a file is checked for this; one built in code may not be.
            let ColumnSource::Column(column) = &c.source else {
                return Err(ImportError::MapValue {
                    path: map.path.clone(),
                    key: format!("[[column]] {}", c.source),
                    message: "a wide table's signals are picked by `column`, not `tag`".into(),
                });
            };
            let (index, label) = shape.find(column)?;
            let quality = c
                .quality
                .as_ref()
                .map(|q| QualityPlan::new(shape, q))
                .transpose()?;
            columns.push(ColumnPlan {
                index,
                label,
                channel: writer.add_channel(&c.channel)?,
                quality,
                samples: 0,
                missing: 0,
            });
        }
        Ok(Rows {
            shape,
            time,
            clock: RowClock::new(map.time.zone.clone()),
            columns,
            decimal_comma,
            count: 0,
        })
    }

    /// Writes the messages of the table's current row.
    fn convert(
        &mut self,
        row: &dyn RowSource,
        writer: &mut RecordingWriter,
    ) -> Result<(), ImportError> {
        self.shape.check_width(row)?;
        let path = self.shape.input;
        let (stamp, text) = self.time.stamp(row, self.count);
        let t = stamp
            .map_err(ClockError::Bad)
            .and_then(|s| self.clock.place(s))
            .map_err(|e| {
                time_error(
                    path,
                    row.place(),
                    self.time.label(),
                    text,
                    e,
                    "on the row before",
                )
            })?;
        let missing = &self.shape.map.input.missing;
        for c in &mut self.columns {
            let cell = row.cell(c.index);
            let value = parse_value_cell(&cell, self.decimal_comma, missing).ok_or_else(|| {
                ImportError::BadNumber {
                    path: path.to_owned(),
                    line: row.place(),
                    column: c.label.clone(),
                    text: cell.text(),
                }
            })?;
            let Some(value) = value else {
                c.missing += 1;
                continue;
            };
            let quality = match &c.quality {
                Some(q) => q.read(row, path)?,
                None => Quality::Good,
            };
            writer.write_flagged(c.channel, t, Some(value), quality)?;
            c.samples += 1;
        }
        self.count += 1;
        Ok(())
    }

    fn finish(self, map: &ImportMap) -> Read {
        Read {
            rows: self.count,
            channels: self
                .columns
                .iter()
                .zip(&map.columns)
                .map(|(c, m)| ImportedChannel {
                    topic: m.channel.topic.clone(),
                    unit: m.channel.unit.clone(),
                    samples: c.samples,
                    missing: c.missing,
                })
                .collect(),
            span: self.clock.span(),
            clock_changes: self.clock.changes().to_vec(),
            unlisted_rows: 0,
        }
    }
}

/// A value cell: `Some(None)` when missing (empty, NaN, null, a `missing` marker),
/// `Some(Some(v))` for a finite number, `None` when malformed.
fn parse_value_cell(cell: &Cell, decimal_comma: bool, missing: &[String]) -> Option<Option<f64>> {
    match cell {
        Cell::Text(text) => parse_value(text, decimal_comma, missing),
        Cell::Number(v) if v.is_nan() => Some(None),
        Cell::Number(v) if v.is_finite() => Some(Some(*v)),
        Cell::Null => Some(None),
        Cell::Number(_) | Cell::Time(_) => None,
    }
}

/// A quality cell, as text or as an OPC code stored as a number; null is good.
fn parse_quality_cell(cell: &Cell, values: &BTreeMap<String, Quality>) -> Option<Quality> {
    match cell {
        Cell::Text(text) => parse_quality(text, values),
        Cell::Null => Some(Quality::Good),
        other => parse_quality(&other.text(), values),
    }
}

/// A value cell: `Some(None)` when missing (empty, NaN, a `missing` marker),
/// `Some(Some(v))` for a finite number, `None` when malformed.
fn parse_value(text: &str, decimal_comma: bool, missing: &[String]) -> Option<Option<f64>> {
    let text = text.trim();
    if text.is_empty() || text.eq_ignore_ascii_case("nan") || missing.iter().any(|m| m == text) {
        return Some(None);
    }
    let parsed = if decimal_comma && text.contains(',') {
        text.replacen(',', ".", 1).parse::<f64>()
    } else {
        text.parse::<f64>()
    };
    match parsed {
        Ok(v) if v.is_finite() => Some(Some(v)),
        _ => None,
    }
}

/// A quality cell: the map's own spellings, `good`/`uncertain`/`bad` in any case,
/// or an OPC quality code (bits 7–6: 11 good, 01 or 10 uncertain, 00 bad); an empty
/// cell is good.
fn parse_quality(text: &str, values: &BTreeMap<String, Quality>) -> Option<Quality> {
    let text = text.trim();
    if let Some(q) = values.get(text) {
        return Some(*q);
    }
    match text.to_ascii_lowercase().as_str() {
        "" | "good" => return Some(Quality::Good),
        "uncertain" => return Some(Quality::Uncertain),
        "bad" => return Some(Quality::Bad),
        _ => {}
    }
    match text.parse::<u8>() {
        Ok(code) if code >= 192 => Some(Quality::Good),
        Ok(code) if code >= 64 => Some(Quality::Uncertain),
        Ok(_) => Some(Quality::Bad),
        Err(_) => None,
    }
}

fn quality_words(values: &BTreeMap<String, Quality>) -> String {
    let mut words: Vec<String> = values.keys().map(|k| format!("`{k}`")).collect();
    words.extend(["good, uncertain, bad or an OPC code 0-255".to_owned()]);
    words.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells() {
        assert_eq!(parse_value("20.5", false, &[]), Some(Some(20.5)));
        assert_eq!(parse_value("", false, &[]), Some(None));
        assert_eq!(parse_value("NaN", false, &[]), Some(None));
        assert_eq!(parse_value("nan", false, &[]), Some(None));
        assert_eq!(parse_value("-", false, &["-".into()]), Some(None));
        assert_eq!(parse_value("20,5", true, &[]), Some(Some(20.5)));
        assert_eq!(parse_value("20,5", false, &[]), None);
        assert_eq!(parse_value("inf", false, &[]), None);
        assert_eq!(parse_value("1e999", false, &[]), None);
        assert_eq!(parse_value("abc", false, &[]), None);
    }

    #[test]
    fn quality_flags() {
        let none = BTreeMap::new();
        assert_eq!(parse_quality("", &none), Some(Quality::Good));
        assert_eq!(parse_quality("Uncertain", &none), Some(Quality::Uncertain));
        assert_eq!(parse_quality("192", &none), Some(Quality::Good));
        assert_eq!(parse_quality("64", &none), Some(Quality::Uncertain));
        assert_eq!(parse_quality("0", &none), Some(Quality::Bad));
        assert_eq!(parse_quality("ERR", &none), None);
        let own: BTreeMap<String, Quality> = [("ERR".to_owned(), Quality::Bad)].into();
        assert_eq!(parse_quality("ERR", &own), Some(Quality::Bad));
    }
}
