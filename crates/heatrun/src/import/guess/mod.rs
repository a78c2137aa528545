//! A starting map guessed from a table's first lines, to be checked and edited: the
//! layout and dialect, the time column and its timestamps' layout ([`timestamp`]), each
//! column's quantity from its name and unit in English or German ([`quantity`]), each
//! guess marked `EDIT` for review, and the nameplate's keys with their units.

mod quantity;
mod timestamp;

use quantity::{guess_quantity, transliterate, QuantityGuess};
use timestamp::{guess_layout, TimestampLayout};

use std::fmt::Write;
use std::path::Path;

use super::error::ImportError;
use super::map::{is_channel_name, Delimiter, InputLayout};
#[cfg(feature = "parquet")]
use super::parquet::ParquetTable;
#[cfg(feature = "parquet")]
use super::source::RowSource;
use super::table::{self, Table};
use super::time;
use crate::recording::{Quantity, NAMEPLATE_KEYS};

/// Rows read to guess from.
const SAMPLE_ROWS: usize = 20;

/// A column as the guess sees it.
struct Column {
    /// The header's text (none without a header).
    header: Option<String>,
    /// A channel name made from it.
    name: String,
    /// The unit taken from `Name (unit)` or `Name [unit]`.
    unit: Option<String>,
    /// The first data rows' cells.
    cells: Vec<String>,
    /// The profile quantity its name and unit say, if they say one.
    guess: Option<QuantityGuess>,
}

/// The map text for the table at `input`: its layout, a time column (or a sample
/// time to fill in) and one `[[column]]` per other column, named after the header
/// with the unit it gives (`T1 (degC)`, `Q1 [%]`).
pub fn guess_map(input: &Path) -> Result<String, ImportError> {
    if super::source::is_parquet(input)? {
        return guess_parquet(input);
    }
    let lines = table::first_lines(input, 0, None)?;
    let dialect = table::resolve_dialect(&InputLayout::default(), &lines);
    let mut table = Table::open(input, &dialect)?;
    let mut header = None;
    let mut rows: Vec<Vec<String>> = Vec::new();
    while rows.len() < SAMPLE_ROWS && table.next_row()? {
        if dialect.header && header.is_none() {
            header = Some(table.fields());
        } else {
            rows.push(table.fields());
        }
    }
    let width = header
        .as_ref()
        .map_or_else(|| rows.first().map_or(0, Vec::len), Vec::len);
    if width == 0 || rows.is_empty() {
        return Err(ImportError::NoData {
            path: input.to_owned(),
        });
    }
    let columns = columns(header.as_deref(), &rows, width);
    let time = time_column(&columns);
    let mut out = preamble(input);
    write_input(
        &mut out,
        dialect.delimiter,
        dialect.header,
        dialect.decimal_comma,
    );
    match time.and_then(|t| long_table(&columns, t, dialect.decimal_comma)) {
        Some(long) => {
            let tags = list_tags(Table::open(input, &dialect)?, dialect.header, long.tag)?;
            out = out.replacen("[input]\n", "[input]\nlayout = \"long\"\n", 1);
            write_long(&mut out, &columns, &long);
            write_time(&mut out, &columns, time);
            write_tags(&mut out, &tags);
        }
        None => {
            write_time(&mut out, &columns, time);
            let guessed = guessed(&columns, time);
            for (i, c) in columns.iter().enumerate() {
                if Some(i) != time {
                    write_column(&mut out, c, i, header.is_some(), sensor_needed(c, &guessed));
                }
            }
        }
    }
    write_records_help(&mut out);
    Ok(out)
}

/// A build without the `parquet` feature refuses a Parquet table in one line.
#[cfg(not(feature = "parquet"))]
fn guess_parquet(input: &Path) -> Result<String, ImportError> {
    Err(ImportError::ParquetNotBuilt {
        path: input.to_owned(),
    })
}

/// The map of a Parquet file: its columns from the schema, the first rows' cells as
/// text; no `[input]` text keys.
#[cfg(feature = "parquet")]
fn guess_parquet(input: &Path) -> Result<String, ImportError> {
    let mut table = ParquetTable::open(input)?;
    let header = table.header();
    let mut rows = Vec::new();
    while rows.len() < SAMPLE_ROWS && table.next_row()? {
        rows.push((0..table.width()).map(|i| table.cell(i).text()).collect());
    }
    if header.is_empty() || rows.is_empty() {
        return Err(ImportError::NoData {
            path: input.to_owned(),
        });
    }
    let columns = columns(Some(&header), &rows, header.len());
    let time = time_column(&columns);
    let mut out = preamble(input);
    let _ = writeln!(out, "# A Parquet file: the columns are the schema's.");
    if let Some(long) = time.and_then(|t| long_table(&columns, t, false)) {
        let mut tags = Vec::new();
        let mut seen = std::collections::HashSet::new();
        let mut table = ParquetTable::open(input)?;
        while tags.len() < MAX_TAGS && table.next_row()? {
            let t = table.cell(long.tag).text().trim().to_owned();
            if !t.is_empty() && seen.insert(t.clone()) {
                tags.push(t);
            }
        }
        let _ = writeln!(out, "[input]\nlayout = \"long\"");
        write_long(&mut out, &columns, &long);
        write_time(&mut out, &columns, time);
        write_tags(&mut out, &tags);
    } else {
        write_time(&mut out, &columns, time);
        let guessed = guessed(&columns, time);
        for (i, c) in columns.iter().enumerate() {
            if Some(i) != time {
                write_column(&mut out, c, i, true, sensor_needed(c, &guessed));
            }
        }
    }
    write_records_help(&mut out);
    Ok(out)
}

/// The map's opening comment: what to check and the command to run.
fn preamble(input: &Path) -> String {
    let mut out = String::new();
    let file = input
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let _ = writeln!(
        out,
        "# heatrun import map guessed from {file}: check every entry (EDIT marks guesses"
    );
    let _ = writeln!(
        out,
        "# to look at), delete the [[column]] tables you do not want, then run"
    );
    let _ = writeln!(
        out,
        "#   heatrun import {file} --map THIS.toml --out OUT.mcap"
    );
    let _ = writeln!(out);
    out
}

/// The quantities guessed for the columns other than the time.
fn guessed(columns: &[Column], time: Option<usize>) -> Vec<Quantity> {
    columns
        .iter()
        .enumerate()
        .filter(|(i, _)| Some(*i) != time)
        .filter_map(|(_, c)| Some(c.guess.as_ref()?.quantity))
        .collect()
}

/// The commented nameplate (every key with its unit, required ones first) and metadata
/// records at the map's end.
fn write_records_help(out: &mut String) {
    let _ = writeln!(
        out,
        "\n# For a generator heat run: the heatrun.nameplate record (docs/src/reference/\n\
         # recording-format.md). EDIT: uncomment [nameplate] and the keys, and give the\n\
         # machine's values (or give them at replay with --machine FILE.toml)."
    );
    let _ = writeln!(out, "# [nameplate]");
    let width = NAMEPLATE_KEYS
        .iter()
        .map(|k| k.key.len())
        .max()
        .unwrap_or(0);
    for k in NAMEPLATE_KEYS {
        let _ = writeln!(
            out,
            "# {:<width$} =    # {}, {}: {}",
            k.key,
            k.unit,
            if k.required { "required" } else { "optional" },
            k.feeds
        );
    }
    let _ = writeln!(out, "\n# Other metadata records, carried into the report");
    let _ = writeln!(out, "# [metadata.\"heatrun.test\"]\n# site = \"\"");
}

/// The columns of a long table's rows.
struct LongGuess {
    tag: usize,
    value: usize,
    quality: Option<usize>,
}

/// Tags listed at most (a long table of more is a plant's whole archive).
const MAX_TAGS: usize = 1000;

/// A long table: besides the time, a column of text that repeats (the tag; one named
/// like a tag if several), a column of numbers (the value), and at most one more (a
/// quality flag); so three or four columns in all.
fn long_table(columns: &[Column], time: usize, decimal_comma: bool) -> Option<LongGuess> {
    if !(3..=4).contains(&columns.len()) || columns.iter().any(|c| c.header.is_none()) {
        return None;
    }
    let number = |v: &String| {
        let v = if decimal_comma {
            v.replacen(',', ".", 1)
        } else {
            v.clone()
        };
        v.trim().parse::<f64>().is_ok()
    };
    let others: Vec<usize> = (0..columns.len()).filter(|&i| i != time).collect();
    let is_text = |i: usize| {
        let cells = &columns[i].cells;
        !cells.is_empty() && cells.iter().all(|v| !v.trim().is_empty() && !number(v))
    };
    let named = |i: usize, words: &[&str]| {
        let h = columns[i].header.as_deref().unwrap_or("").to_lowercase();
        words.iter().any(|w| h.contains(w))
    };
    let repeats = |i: usize| {
        let cells = &columns[i].cells;
        cells
            .iter()
            .collect::<std::collections::BTreeSet<_>>()
            .len()
            < cells.len()
    };
    // Flags repeat too (`Good`), but name no signal.
    let flags = |i: usize| {
        named(i, &["status", "quality", "qualit", "flag"])
            || columns[i].cells.iter().all(|v| {
                ["good", "bad", "uncertain", "ok", "gut", "schlecht"]
                    .contains(&v.trim().to_lowercase().as_str())
            })
    };
    let texts: Vec<usize> = others
        .iter()
        .copied()
        .filter(|&i| is_text(i) && repeats(i) && !flags(i))
        .collect();
    let tag = texts
        .iter()
        .copied()
        .find(|&i| named(i, &["tag", "name", "point", "signal", "variable", "item"]))
        .or_else(|| texts.first().copied())?;
    let value = others.iter().copied().find(|&i| {
        i != tag
            && columns[i].cells.iter().filter(|v| number(v)).count() * 2 > columns[i].cells.len()
    })?;
    let quality = others.iter().copied().find(|&i| i != tag && i != value);
    Some(LongGuess {
        tag,
        value,
        quality,
    })
}

/// Every tag of a long table in the order first seen (the whole table streams
/// through; only the tags are kept, at most [`MAX_TAGS`]).
fn list_tags(mut table: Table, header: bool, tag: usize) -> Result<Vec<String>, ImportError> {
    let mut seen = std::collections::HashSet::new();
    let mut tags = Vec::new();
    let mut skip_header = header;
    while tags.len() < MAX_TAGS && table.next_row()? {
        if std::mem::take(&mut skip_header) {
            continue;
        }
        if let Some(t) = table.record().get(tag) {
            let t = table::decode(t).trim().to_owned();
            if !t.is_empty() && seen.insert(t.clone()) {
                tags.push(t);
            }
        }
    }
    Ok(tags)
}

fn write_long(out: &mut String, columns: &[Column], long: &LongGuess) {
    let _ = writeln!(out, "\n[long]");
    let _ = writeln!(out, "tag = {}", reference(&columns[long.tag], long.tag));
    let _ = writeln!(
        out,
        "value = {}",
        reference(&columns[long.value], long.value)
    );
    if let Some(q) = long.quality {
        let _ = writeln!(
            out,
            "quality = {}   # EDIT: remove if it is not good/uncertain/bad or OPC codes",
            reference(&columns[q], q)
        );
    }
}

/// A `[[column]]` per tag, with the unit its name gives (`G1 Strom [kA]`, `T1.degC`).
fn write_tags(out: &mut String, tags: &[String]) {
    let _ = writeln!(out, "\n# {} tags in the table", tags.len());
    let guessed: Vec<Quantity> = tags
        .iter()
        .filter_map(|t| {
            let (base, unit) = tag_unit(t);
            Some(guess_quantity(&base, unit.as_deref())?.quantity)
        })
        .collect();
    let mut used = std::collections::BTreeSet::new();
    for (i, tag) in tags.iter().enumerate() {
        let (base, unit) = tag_unit(tag);
        let mut name = channel_name(&base, i);
        if !used.insert(name.clone()) {
            name = format!("{name}_{}", i + 1);
            used.insert(name.clone());
        }
        let guess = guess_quantity(&base, unit.as_deref());
        let column = Column {
            header: Some(tag.clone()),
            name,
            unit,
            cells: Vec::new(),
            guess,
        };
        let mut text = String::new();
        write_column(
            &mut text,
            &column,
            i,
            true,
            sensor_needed(&column, &guessed),
        );
        // The same table as a wide column, but picked by tag.
        let _ = write!(out, "{}", text.replacen("\ncolumn = ", "\ntag = ", 1));
    }
}

/// A tag's name and unit: `G1 Strom [kA]` → (`G1 Strom`, `kA`); `G1.Strom.kA` or
/// `G1_Temp_degC` → the last part when it is a unit the profile knows.
fn tag_unit(tag: &str) -> (String, Option<String>) {
    let (base, unit) = split_unit(tag);
    if unit.is_some() {
        return (base, unit);
    }
    const UNITS: [&str; 12] = [
        "degC", "°C", "kA", "A", "kV", "V", "l/s", "l/min", "m3/h", "MW", "Mvar", "%",
    ];
    match tag.rfind(['.', '_', ' ']) {
        Some(at) if UNITS.contains(&&tag[at + 1..]) => {
            (tag[..at].to_owned(), Some(normalise_unit(&tag[at + 1..])))
        }
        _ => (base, None),
    }
}

fn columns(header: Option<&[String]>, rows: &[Vec<String>], width: usize) -> Vec<Column> {
    let mut used = std::collections::BTreeSet::new();
    (0..width)
        .map(|i| {
            let text = header.and_then(|h| h.get(i)).cloned();
            let (base, unit) = match &text {
                Some(t) => split_unit(t),
                None => (String::new(), None),
            };
            let mut name = channel_name(&base, i);
            if !used.insert(name.clone()) {
                name = format!("{name}_{}", i + 1);
                used.insert(name.clone());
            }
            let guess = text
                .as_ref()
                .and_then(|_| guess_quantity(&base, unit.as_deref()));
            Column {
                header: text,
                name,
                unit,
                cells: rows.iter().filter_map(|r| r.get(i).cloned()).collect(),
                guess,
            }
        })
        .collect()
}

/// `T1 (degC)` → (`T1`, `degC`); `Q1 [%]` → (`Q1`, `%`).
fn split_unit(header: &str) -> (String, Option<String>) {
    let h = header.trim();
    for (open, close) in [('(', ')'), ('[', ']')] {
        if let Some(inner) = h.strip_suffix(close) {
            if let Some(at) = inner.rfind(open) {
                let unit = normalise_unit(inner[at + 1..].trim());
                return (
                    inner[..at].trim().to_owned(),
                    Some(unit).filter(|u| !u.is_empty()),
                );
            }
        }
    }
    (h.to_owned(), None)
}

fn normalise_unit(unit: &str) -> String {
    match unit {
        "°C" | "ºC" | "deg C" | "degC" | "C" | "celsius" | "Celsius" | "grd C" | "Grad C" => {
            "degC".into()
        }
        "m³/h" | "m^3/h" => "m3/h".into(),
        "l/sec" => "l/s".into(),
        "sec" | "secs" | "seconds" | "s" => "s".into(),
        other => other.to_owned(),
    }
}

/// A channel name from a header: letters outside ASCII written out (`ü` → `ue`, `é` →
/// `e`), runs of other characters become `_`; a name that would start with a digit gets
/// `c_` in front; no header gives `column_<n>`.
fn channel_name(base: &str, index: usize) -> String {
    let mut name = String::new();
    for c in base.chars() {
        if c.is_ascii_alphanumeric() {
            name.push(c);
        } else if let Some(t) = transliterate(c) {
            name.push_str(t);
        } else if !name.ends_with('_') && !name.is_empty() {
            name.push('_');
        }
    }
    let name = name.trim_end_matches('_').to_owned();
    if name.is_empty() {
        format!("column_{}", index + 1)
    } else if is_channel_name(&name) {
        name
    } else {
        format!("c_{name}")
    }
}

/// The time column: one named like a time, else the first whose cells are
/// timestamps, else (without a header) a first column that increases.
fn time_column(columns: &[Column]) -> Option<usize> {
    let named = columns.iter().position(|c| {
        c.header.as_ref().is_some_and(|h| {
            let h = h.to_ascii_lowercase();
            h.contains("time")
                || h.contains("date")
                || h.contains("zeit")
                || h.contains("datum")
                || h.trim() == "t"
        })
    });
    named
        .or_else(|| {
            columns.iter().position(|c| {
                c.cells
                    .first()
                    .is_some_and(|v| !time::looks_like_seconds(v) && v.contains(':'))
                    && guess_layout(&c.cells).is_some()
            })
        })
        .or_else(|| {
            let first = columns.first()?;
            let values: Vec<f64> = first.cells.iter().filter_map(|v| v.parse().ok()).collect();
            let increasing = values.len() >= 3
                && values.len() == first.cells.len()
                && values.windows(2).all(|w| w[1] > w[0]);
            (first.header.is_none() && increasing).then_some(0)
        })
}

fn quoted(text: &str) -> String {
    toml::Value::String(text.to_owned()).to_string()
}

/// How the map refers to a column: its header name, else its position.
fn reference(c: &Column, index: usize) -> String {
    match &c.header {
        Some(h) => quoted(h),
        None => format!("{}", index + 1),
    }
}

fn write_input(out: &mut String, delimiter: Delimiter, header: bool, decimal_comma: bool) {
    let delimiter = match delimiter {
        Delimiter::Byte(b'\t') => "\\t".to_owned(),
        Delimiter::Byte(b) => (b as char).to_string(),
        Delimiter::Whitespace => "whitespace".to_owned(),
    };
    let _ = writeln!(
        out,
        "[input]\ndelimiter = \"{delimiter}\"\nheader = {header}"
    );
    if decimal_comma {
        let _ = writeln!(out, "decimal_comma = true");
    }
}

fn write_time(out: &mut String, columns: &[Column], time: Option<usize>) {
    let _ = writeln!(out, "\n[time]");
    let Some(i) = time else {
        let _ = writeln!(
            out,
            "# No time column found: rows at a fixed step. EDIT the sample time."
        );
        let _ = writeln!(out, "sample_time_s = 1.0");
        let _ = writeln!(
            out,
            "# start = \"2024-01-01T00:00:00Z\"   # the instant of the first row"
        );
        return;
    };
    let c = &columns[i];
    let _ = writeln!(out, "column = {}", reference(c, i));
    let first = c.cells.first().map_or("", String::as_str);
    if time::looks_like_seconds(first) {
        let unit = c
            .unit
            .as_deref()
            .filter(|u| ["ms", "us", "min", "h"].contains(u))
            .unwrap_or("s");
        let _ = writeln!(out, "format = \"seconds\"\nunit = \"{unit}\"");
        if c.header.is_none() {
            let _ = writeln!(
                out,
                "# EDIT: column 1 increases, so it is taken as the time; if it is a sample"
            );
            let _ = writeln!(
                out,
                "# index, use `sample_time_s` instead of `column` and skip it."
            );
        }
        let _ = writeln!(
            out,
            "# start = \"2024-01-01T00:00:00Z\"   # the instant of t = 0 (default: the Unix epoch)"
        );
    } else {
        let _ = writeln!(out, "format = \"timestamp\"");
        let layout = guess_layout(&c.cells);
        let pattern = layout.as_ref().and_then(TimestampLayout::pattern);
        match &layout {
            Some(TimestampLayout::Pattern { pattern, ambiguous }) => {
                let _ = writeln!(
                    out,
                    "pattern = {}   # EDIT: guessed from {}{}",
                    quoted(pattern),
                    quoted(first),
                    ambiguous.map_or(String::new(), |a| format!(
                        "; the cells read as {} too (day and month swapped)",
                        quoted(a)
                    ))
                );
            }
            Some(TimestampLayout::Iso) => {}
            None => {
                let _ = writeln!(
                    out,
                    "# EDIT: {} reads in no layout known here: give its strftime `pattern`",
                    quoted(first)
                );
            }
        }
        if matches!(time::parse_stamp(first, pattern), Ok(time::Stamp::Civil(_)))
            || layout.is_none()
        {
            let _ = writeln!(
                out,
                "zone = \"UTC\"   # EDIT: the times carry no offset; the zone they were written in (\"Europe/Berlin\")"
            );
        }
    }
}

/// Whether a column guessed as a quantity shares it with another column (six stator
/// RTDs): each then needs its `sensor`.
fn sensor_needed(c: &Column, guessed: &[Quantity]) -> bool {
    c.guess
        .as_ref()
        .is_some_and(|g| guessed.iter().filter(|q| **q == g.quantity).count() > 1)
}

fn write_column(out: &mut String, c: &Column, index: usize, has_header: bool, sensor: bool) {
    let _ = writeln!(out, "\n[[column]]");
    let _ = writeln!(out, "column = {}", reference(c, index));
    let mut unit = c.unit.clone();
    match (Quantity::from_name(&c.name), &c.guess) {
        (Some(q), _) if unit.as_deref().is_some_and(|u| q.unit_scale(u).is_some()) => {
            let _ = writeln!(out, "quantity = \"{}\"", c.name);
        }
        (_, Some(g)) => {
            let _ = writeln!(
                out,
                "quantity = \"{}\"   # EDIT: guessed from the name {}; or channel = \"{}\"",
                g.quantity.name(),
                quoted(c.header.as_deref().unwrap_or_default()),
                c.name
            );
            if sensor {
                let _ = writeln!(
                    out,
                    "sensor = \"{}\"   # several columns carry this quantity: they are averaged",
                    c.name
                );
            }
            if g.unit_assumed {
                let _ = writeln!(
                    out,
                    "unit = {}   # EDIT: the header gives no unit; the quantity's is assumed",
                    quoted(&g.unit)
                );
                return;
            }
            unit = Some(g.unit.clone());
        }
        _ => {
            let _ = writeln!(out, "channel = \"{}\"", c.name);
        }
    }
    match unit {
        Some(u) => {
            let _ = writeln!(out, "unit = {}", quoted(&u));
        }
        None if has_header => {
            let _ = writeln!(out, "unit = \"1\"   # EDIT: the header gives no unit");
        }
        None => {
            let _ = writeln!(out, "unit = \"1\"   # EDIT: the unit");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_and_names_from_headers() {
        assert_eq!(split_unit("T1 (degC)"), ("T1".into(), Some("degC".into())));
        assert_eq!(split_unit(" Q1 [%]"), ("Q1".into(), Some("%".into())));
        assert_eq!(split_unit("Time (sec)"), ("Time".into(), Some("s".into())));
        assert_eq!(split_unit("T (°C)"), ("T".into(), Some("degC".into())));
        assert_eq!(split_unit("pm"), ("pm".into(), None));
        assert_eq!(channel_name("Temperature 1", 3), "Temperature_1");
        assert_eq!(channel_name("1st sensor", 0), "c_1st_sensor");
        assert_eq!(channel_name("", 4), "column_5");
        assert_eq!(channel_name("U/V-phase", 0), "U_V_phase");
        assert_eq!(
            tag_unit("G1 Temp Statorwicklung [°C]"),
            ("G1 Temp Statorwicklung".into(), Some("degC".into()))
        );
        assert_eq!(
            tag_unit("G1.Strom.kA"),
            ("G1.Strom".into(), Some("kA".into()))
        );
        assert_eq!(
            tag_unit("G1_Durchfluss_l/s"),
            ("G1_Durchfluss".into(), Some("l/s".into()))
        );
        assert_eq!(tag_unit("G1 Status"), ("G1 Status".into(), None));
    }
}
