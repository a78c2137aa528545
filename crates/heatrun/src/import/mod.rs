//! Importing tables (CSV, historian exports, DaISy `.dat`) into profile recordings.
//!
//! Input: a delimited text table and an [`ImportMap`] that says which column holds
//! the time and which become channels (a profile quantity or a free name, with unit,
//! sensor, quality and storage), plus the nameplate and other metadata records.
//! Output: a complete profile recording, written by [`crate::writer`] under a
//! temporary name and renamed when complete.
//!
//! The table streams through one row at a time. Every row becomes one message per
//! imported column at the row's time, in the row's order; times are kept as they
//! are (non-uniform spacing stays). An empty cell, `NaN` or one of the map's
//! `missing` markers is a missing sample: no message is written for it. On a
//! sampled channel the silence is then a gap, and on a channel stored by exception
//! it is what a historian export shows between stored samples; writing nothing
//! keeps both meanings, where a `null` dropout would say a sample was due.
//!
//! Any malformed cell, ragged row, unreadable or backward time, or column the map
//! names that the table lacks stops the import with one [`ImportError`] naming the
//! file, line and column, and nothing is written.

mod error;
mod guess;
mod map;
mod table;
mod time;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub use error::ImportError;
pub use guess::guess_map;
pub use map::ImportMap;

use map::{ColumnRef, Delimiter, TimeFormat, TimeSource};
use table::{Dialect, Table};

use crate::recording::format_time;
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

/// Imports the table `input` as `map` says into the recording `out`.
pub fn import(input: &Path, map: &ImportMap, out: &Path) -> Result<ImportSummary, ImportError> {
    if same_file(input, out) {
        return Err(ImportError::OutputIsInput {
            path: out.to_owned(),
        });
    }
    let lines = table::first_lines(input, map.input.skip_lines, map.input.comment)?;
    let dialect = table::resolve_dialect(&map.input, &lines);
    let mut table = Table::open(input, &dialect)?;
    let header = if dialect.header {
        if !table.next_row()? {
            return Err(ImportError::NoData {
                path: input.to_owned(),
            });
        }
        Some((table.fields(), table.line()))
    } else {
        None
    };
    if !table.next_row()? {
        return Err(ImportError::NoData {
            path: input.to_owned(),
        });
    }
    let shape = Shape {
        input,
        map,
        header: header.as_ref().map(|(h, _)| h.as_slice()),
        fields: header
            .as_ref()
            .map_or(table.record().len(), |(h, _)| h.len()),
        line: header.as_ref().map_or(table.line(), |(_, l)| *l),
    };
    let mut writer = RecordingWriter::create(out, WriterOptions::default())?;
    // The records first: a metadata record closes the open chunk, which would
    // otherwise hold only the channel records.
    write_records(&mut writer, input, map)?;
    let mut rows = Rows::plan(&shape, &dialect, &mut writer)?;
    loop {
        rows.convert(&table, &mut writer)?;
        if !table.next_row()? {
            break;
        }
    }
    let written = writer.finish()?;
    Ok(ImportSummary {
        out: out.to_owned(),
        rows: rows.count,
        channels: rows
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
        time_span_ns: (rows.first_time.unwrap_or(0), rows.previous.unwrap_or(0)),
        messages: written.messages,
    })
}

fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    }
}

/// The nameplate, the map's metadata records and a `heatrun.import` record naming
/// the source.
fn write_records(
    writer: &mut RecordingWriter,
    input: &Path,
    map: &ImportMap,
) -> Result<(), ImportError> {
    if !map.nameplate.is_empty() {
        writer.write_nameplate(&map.nameplate)?;
    }
    for (name, entries) in &map.metadata {
        writer.write_metadata(name, entries)?;
    }
    let file_name = |p: &Path| {
        p.file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default()
    };
    let record: BTreeMap<String, String> = [
        ("source".to_owned(), file_name(input)),
        ("map".to_owned(), file_name(&map.path)),
    ]
    .into();
    writer.write_metadata("heatrun.import", &record)?;
    Ok(())
}

/// The table's columns as far as the map needs them.
struct Shape<'a> {
    input: &'a Path,
    map: &'a ImportMap,
    /// The header's names, if there is a header.
    header: Option<&'a [String]>,
    /// Fields in the header (or the first row).
    fields: usize,
    /// The line of the header (or the first row).
    line: u64,
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
}

/// Where a row's time comes from, resolved against the table.
enum RowTime {
    Column {
        index: usize,
        label: String,
        format: TimeFormat,
        unit_ns: i128,
        pattern: Option<String>,
    },
    Index {
        sample_time_ns: i128,
    },
}

/// One imported column, resolved against the table.
struct ColumnPlan {
    index: usize,
    label: String,
    channel: ChannelId,
    quality: Option<QualityPlan>,
    samples: u64,
    missing: u64,
}

struct QualityPlan {
    index: usize,
    label: String,
    values: BTreeMap<String, Quality>,
}

/// The conversion of rows into messages.
struct Rows {
    path: PathBuf,
    time: RowTime,
    start_ns: i128,
    zone: Option<jiff::tz::TimeZone>,
    columns: Vec<ColumnPlan>,
    fields: usize,
    first_line: u64,
    decimal_comma: bool,
    missing: Vec<String>,
    count: u64,
    first_time: Option<u64>,
    previous: Option<u64>,
}

impl Rows {
    /// Resolves the map's columns and adds their channels to the recording.
    fn plan(
        shape: &Shape,
        dialect: &Dialect,
        writer: &mut RecordingWriter,
    ) -> Result<Rows, ImportError> {
        let map = shape.map;
        let time = match &map.time.source {
            TimeSource::Column {
                column,
                format,
                unit_ns,
                pattern,
            } => {
                let (index, label) = shape.find(column)?;
                RowTime::Column {
                    index,
                    label,
                    format: *format,
                    unit_ns: *unit_ns,
                    pattern: pattern.clone(),
                }
            }
            TimeSource::SampleIndex { sample_time_ns } => RowTime::Index {
                sample_time_ns: *sample_time_ns,
            },
        };
        let mut columns = Vec::new();
        for c in &map.columns {
            let (index, label) = shape.find(&c.column)?;
            let quality = match &c.quality {
                Some(q) => {
                    let (index, label) = shape.find(&q.column)?;
                    Some(QualityPlan {
                        index,
                        label,
                        values: q.values.clone(),
                    })
                }
                None => None,
            };
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
            path: shape.input.to_owned(),
            time,
            start_ns: map.time.start_ns,
            zone: map.time.zone.clone(),
            columns,
            fields: shape.fields,
            first_line: shape.line,
            decimal_comma: dialect.decimal_comma && dialect.delimiter != Delimiter::Byte(b','),
            missing: map.input.missing.clone(),
            count: 0,
            first_time: None,
            previous: None,
        })
    }

    /// Writes the messages of the table's current row.
    fn convert(&mut self, table: &Table, writer: &mut RecordingWriter) -> Result<(), ImportError> {
        let record = table.record();
        let line = table.line();
        if record.len() != self.fields {
            return Err(ImportError::RaggedRow {
                path: self.path.clone(),
                line,
                found: record.len(),
                expected: self.fields,
                first_line: self.first_line,
            });
        }
        let t = self.row_time(record, line)?;
        for c in &mut self.columns {
            let text = cell(record, c.index);
            let value = parse_value(text, self.decimal_comma, &self.missing).ok_or_else(|| {
                ImportError::BadNumber {
                    path: self.path.clone(),
                    line,
                    column: c.label.clone(),
                    text: text.to_owned(),
                }
            })?;
            let Some(value) = value else {
                c.missing += 1;
                continue;
            };
            let quality = match &c.quality {
                Some(q) => parse_quality(cell(record, q.index), &q.values).ok_or_else(|| {
                    ImportError::BadQuality {
                        path: self.path.clone(),
                        line,
                        column: q.label.clone(),
                        text: cell(record, q.index).to_owned(),
                        accepted: quality_words(&q.values),
                    }
                })?,
                None => Quality::Good,
            };
            writer.write_flagged(c.channel, t, Some(value), quality)?;
            c.samples += 1;
        }
        self.count += 1;
        Ok(())
    }

    /// The row's time, ns since the epoch, checked to be in range and not earlier
    /// than the row before.
    fn row_time(&mut self, record: &csv::ByteRecord, line: u64) -> Result<u64, ImportError> {
        let (ns, text, label) = match &mut self.time {
            RowTime::Index { sample_time_ns } => (
                Ok(self.start_ns + self.count as i128 * *sample_time_ns),
                String::new(),
                "(row index)".to_owned(),
            ),
            RowTime::Column {
                index,
                label,
                format,
                unit_ns,
                pattern,
            } => {
                let text = cell(record, *index).to_owned();
                // A table written with decimal commas writes its seconds so too.
                let text = if self.decimal_comma && !text.contains('.') {
                    text.replacen(',', ".", 1)
                } else {
                    text
                };
                if *format == TimeFormat::Auto {
                    *format = if time::looks_like_seconds(&text) {
                        TimeFormat::Seconds
                    } else {
                        TimeFormat::Timestamp
                    };
                }
                let ns = match format {
                    TimeFormat::Timestamp => {
                        time::parse_timestamp(&text, self.zone.as_ref(), pattern.as_deref())
                    }
                    _ => time::parse_decimal_ns(&text, *unit_ns)
                        .map(|t| self.start_ns + t)
                        .ok_or_else(|| {
                            "not a number of seconds, as the first row's time is".to_owned()
                        }),
                };
                (ns, text, label.clone())
            }
        };
        let bad = |reason: String| ImportError::BadTime {
            path: self.path.clone(),
            line,
            column: label.clone(),
            text: text.clone(),
            reason,
        };
        let ns = ns.map_err(bad)?;
        let t = u64::try_from(ns).map_err(|_| {
            bad(if ns < 0 {
                "it is before 1970-01-01T00:00:00Z, where recording times start; give `start` under [time]".into()
            } else {
                "it is after 2554, beyond what a recording can hold".into()
            })
        })?;
        if let Some(previous) = self.previous.filter(|p| t < *p) {
            return Err(ImportError::TimeBackwards {
                path: self.path.clone(),
                line,
                column: label,
                previous: format_time(previous),
                current: format_time(t),
            });
        }
        self.first_time.get_or_insert(t);
        self.previous = Some(t);
        Ok(t)
    }
}

/// A field as text (numbers and times are ASCII; anything else reads as Latin-1 in
/// messages).
fn cell(record: &csv::ByteRecord, index: usize) -> &str {
    std::str::from_utf8(&record[index]).unwrap_or("<not UTF-8>")
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
