//! Streaming a delimited text table row by row: CSV dialects through the `csv`
//! crate, whitespace-separated numbers (DaISy `.dat`) line by line. One row is in
//! memory at a time.

use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};

use super::error::{ImportError, Place};
use super::map::{Delimiter, InputLayout};
use super::source::{Cell, RowSource};

/// The layout of a table, every choice made.
#[derive(Debug, Clone, PartialEq)]
pub struct Dialect {
    /// The field separator.
    pub delimiter: Delimiter,
    /// Whether the first line names the columns.
    pub header: bool,
    /// Lines skipped before the header or the data.
    pub skip_lines: u64,
    /// Numbers with a decimal comma.
    pub decimal_comma: bool,
    /// Lines starting with this byte are skipped.
    pub comment: Option<u8>,
}

/// Lines read to guess a layout.
const SNIFF_LINES: usize = 20;

/// The first lines of a table (after `skip_lines`, without blank and comment lines),
/// for guessing its layout.
pub fn first_lines(
    path: &Path,
    skip_lines: u64,
    comment: Option<u8>,
) -> Result<Vec<String>, ImportError> {
    let read_error = |error| ImportError::Read {
        path: path.to_owned(),
        error,
    };
    let mut reader = BufReader::new(File::open(path).map_err(read_error)?);
    skip_byte_order_mark(&mut reader).map_err(read_error)?;
    let mut lines = Vec::new();
    let mut buf = Vec::new();
    let mut number = 0u64;
    while lines.len() < SNIFF_LINES {
        buf.clear();
        if reader.read_until(b'\n', &mut buf).map_err(read_error)? == 0 {
            break;
        }
        number += 1;
        let line = decode(&buf);
        let line = line.trim_end_matches(['\r', '\n']);
        if number <= skip_lines
            || line.trim().is_empty()
            || comment.is_some_and(|c| line.as_bytes().first() == Some(&c))
        {
            continue;
        }
        lines.push(line.to_owned());
    }
    Ok(lines)
}

/// Skips the UTF-8 byte order mark that spreadsheet exports put before the header.
fn skip_byte_order_mark(reader: &mut BufReader<File>) -> std::io::Result<()> {
    const BOM: &[u8] = b"\xEF\xBB\xBF";
    if reader.fill_buf()?.starts_with(BOM) {
        reader.consume(BOM.len());
    }
    Ok(())
}

/// Text of a field or line: UTF-8, or else Latin-1 (the other encoding of exports
/// with `°C` in their headers).
pub fn decode(bytes: &[u8]) -> String {
    match std::str::from_utf8(bytes) {
        Ok(s) => s.to_owned(),
        Err(_) => bytes.iter().map(|&b| b as char).collect(),
    }
}

/// Fills in what the map left open, from the table's first lines.
pub fn resolve_dialect(layout: &InputLayout, lines: &[String]) -> Dialect {
    let delimiter = layout.delimiter.unwrap_or_else(|| guess_delimiter(lines));
    let fields = |line: &str| split(line, delimiter);
    let header = layout.header.unwrap_or_else(|| {
        lines
            .first()
            .is_some_and(|l| fields(l).iter().any(|f| is_header_text(f)))
    });
    let decimal_comma = layout.decimal_comma.unwrap_or_else(|| {
        delimiter != Delimiter::Byte(b',')
            && lines
                .iter()
                .skip(usize::from(header))
                .flat_map(|l| fields(l))
                .any(|f| is_decimal_comma_number(&f))
    });
    Dialect {
        delimiter,
        header,
        skip_lines: layout.skip_lines,
        decimal_comma,
        comment: layout.comment,
    }
}

/// `;` if the first line has one, else `,`, else a tab when every line splits at
/// tabs into as many fields as the first and the lines are not padded with spaces
/// (DaISy pads numbers into columns and ends lines with a tab), else whitespace.
fn guess_delimiter(lines: &[String]) -> Delimiter {
    let Some(first) = lines.first() else {
        return Delimiter::Byte(b',');
    };
    if first.contains(';') {
        return Delimiter::Byte(b';');
    }
    if first.contains(',') {
        return Delimiter::Byte(b',');
    }
    if first.contains('\t') {
        let count = |l: &String, d: Delimiter| split(l, d).len();
        let tab = Delimiter::Byte(b'\t');
        let same_under_tabs = lines.iter().all(|l| count(l, tab) == count(first, tab));
        let same_under_spaces = lines
            .iter()
            .all(|l| count(l, Delimiter::Whitespace) == count(first, Delimiter::Whitespace));
        let padded = lines.iter().any(|l| l.starts_with(' '));
        if same_under_tabs && (!padded || !same_under_spaces) {
            return tab;
        }
    }
    Delimiter::Whitespace
}

/// Splits a sniffed line (quotes are rare in headers; this is for guessing only).
pub fn split(line: &str, delimiter: Delimiter) -> Vec<String> {
    match delimiter {
        Delimiter::Whitespace => line.split_ascii_whitespace().map(str::to_owned).collect(),
        Delimiter::Byte(b) => line
            .split(b as char)
            .map(|f| f.trim().trim_matches('"').to_owned())
            .collect(),
    }
}

/// A header field: text that is neither a number nor a timestamp (which starts with
/// a digit) nor a missing-value marker.
fn is_header_text(field: &str) -> bool {
    let f = field.trim();
    !f.is_empty()
        && !f.eq_ignore_ascii_case("nan")
        && f.parse::<f64>().is_err()
        && !f.starts_with(|c: char| c.is_ascii_digit() || c == '-' || c == '+' || c == '.')
}

fn is_decimal_comma_number(field: &str) -> bool {
    let f = field.trim().trim_start_matches(['-', '+']);
    match f.split_once(',') {
        Some((a, b)) => {
            !a.is_empty()
                && !b.is_empty()
                && a.bytes().all(|c| c.is_ascii_digit())
                && b.bytes().all(|c| c.is_ascii_digit())
        }
        None => false,
    }
}

enum Source {
    Csv(csv::Reader<BufReader<File>>),
    Whitespace {
        reader: BufReader<File>,
        line: Vec<u8>,
        comment: Option<u8>,
    },
}

/// A table read one row at a time.
pub struct Table {
    path: PathBuf,
    source: Source,
    /// Lines skipped at the start (added to the CSV reader's line numbers).
    skipped: u64,
    /// The current line number (whitespace tables).
    line_number: u64,
    record: csv::ByteRecord,
    line: u64,
}

impl Table {
    /// Opens `path` in `dialect`.
    pub fn open(path: &Path, dialect: &Dialect) -> Result<Table, ImportError> {
        let read_error = |error| ImportError::Read {
            path: path.to_owned(),
            error,
        };
        let mut reader = BufReader::new(File::open(path).map_err(read_error)?);
        skip_byte_order_mark(&mut reader).map_err(read_error)?;
        let mut discard = Vec::new();
        for _ in 0..dialect.skip_lines {
            discard.clear();
            if reader.read_until(b'\n', &mut discard).map_err(read_error)? == 0 {
                break;
            }
        }
        let source = match dialect.delimiter {
            Delimiter::Byte(delimiter) => Source::Csv(
                csv::ReaderBuilder::new()
                    .delimiter(delimiter)
                    .has_headers(false)
                    .flexible(true)
                    .trim(csv::Trim::All)
                    .comment(dialect.comment)
                    .from_reader(reader),
            ),
            Delimiter::Whitespace => Source::Whitespace {
                reader,
                line: Vec::new(),
                comment: dialect.comment,
            },
        };
        Ok(Table {
            path: path.to_owned(),
            source,
            skipped: dialect.skip_lines,
            line_number: dialect.skip_lines,
            record: csv::ByteRecord::new(),
            line: 0,
        })
    }

    /// Reads the next row; `false` at the end of the table. Blank lines are skipped.
    pub fn next_row(&mut self) -> Result<bool, ImportError> {
        match &mut self.source {
            Source::Csv(reader) => match reader.read_byte_record(&mut self.record) {
                // A line of spaces only is blank too.
                Ok(true) if self.record.len() == 1 && self.record[0].is_empty() => self.next_row(),
                Ok(more) => {
                    self.line = self.skipped + self.record.position().map_or(0, |p| p.line());
                    Ok(more)
                }
                Err(e) => {
                    let line = self.skipped + e.position().map_or(0, |p| p.line());
                    let message = e.to_string();
                    Err(match e.into_kind() {
                        csv::ErrorKind::Io(error) => ImportError::Read {
                            path: self.path.clone(),
                            error,
                        },
                        _ => ImportError::Table {
                            path: self.path.clone(),
                            line,
                            message,
                        },
                    })
                }
            },
            Source::Whitespace {
                reader,
                line,
                comment,
            } => loop {
                line.clear();
                let n = reader
                    .read_until(b'\n', line)
                    .map_err(|error| ImportError::Read {
                        path: self.path.clone(),
                        error,
                    })?;
                if n == 0 {
                    return Ok(false);
                }
                self.line_number += 1;
                if comment.is_some_and(|c| line.first() == Some(&c)) {
                    continue;
                }
                self.record.clear();
                for field in line
                    .split(u8::is_ascii_whitespace)
                    .filter(|f| !f.is_empty())
                {
                    self.record.push_field(field);
                }
                if !self.record.is_empty() {
                    self.line = self.line_number;
                    return Ok(true);
                }
            },
        }
    }

    /// The fields of the current row.
    pub fn record(&self) -> &csv::ByteRecord {
        &self.record
    }

    /// The line the current row starts on, 1-based.
    pub fn line(&self) -> u64 {
        self.line
    }

    /// The current row's fields as text.
    pub fn fields(&self) -> Vec<String> {
        self.record.iter().map(decode).collect()
    }
}

impl RowSource for Table {
    fn next_row(&mut self) -> Result<bool, ImportError> {
        Table::next_row(self)
    }

    fn width(&self) -> usize {
        self.record.len()
    }

    fn cell(&self, index: usize) -> Cell<'_> {
        // Numbers and times are ASCII; anything else reads as such in messages.
        Cell::Text(std::str::from_utf8(&self.record[index]).unwrap_or("<not UTF-8>"))
    }

    fn place(&self) -> Place {
        Place::Line(self.line)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines(text: &str) -> Vec<String> {
        text.lines().map(str::to_owned).collect()
    }

    #[test]
    fn dialects_are_guessed_from_the_first_lines() {
        let d = resolve_dialect(
            &InputLayout::default(),
            &lines("Time (sec), T1 (degC)\n0,20.5"),
        );
        assert_eq!(
            (d.delimiter, d.header, d.decimal_comma),
            (Delimiter::Byte(b','), true, false)
        );
        let d = resolve_dialect(
            &InputLayout::default(),
            &lines("Zeit;T1\n2024-01-01T00:00:00Z;20,5"),
        );
        assert_eq!(
            (d.delimiter, d.header, d.decimal_comma),
            (Delimiter::Byte(b';'), true, true)
        );
        let d = resolve_dialect(&InputLayout::default(), &lines("t\tT1\n0\t20.5"));
        assert_eq!((d.delimiter, d.header), (Delimiter::Byte(b'\t'), true));
        // Names with spaces and an empty cell: still tabs.
        let d = resolve_dialect(
            &InputLayout::default(),
            &lines("t\tT 1\tT 1 status\n0\t20.5\tgood\n1\t\t"),
        );
        assert_eq!((d.delimiter, d.header), (Delimiter::Byte(b'\t'), true));
        // DaISy: leading spaces, tabs and a trailing tab.
        let d = resolve_dialect(
            &InputLayout::default(),
            &lines("   1.0000000e+00\t  -1.4468000e-01\t\n   2.0000000e+00\t   9.4048000e-01\t"),
        );
        assert_eq!((d.delimiter, d.header), (Delimiter::Whitespace, false));
        let d = resolve_dialect(
            &InputLayout::default(),
            &lines("   0.00   9.000  129.320\r"),
        );
        assert_eq!((d.delimiter, d.header), (Delimiter::Whitespace, false));
        // Timestamps in the first line are data, not a header.
        let d = resolve_dialect(&InputLayout::default(), &lines("2024-01-01T00:00:00Z,1,2"));
        assert!(!d.header);
    }
}
