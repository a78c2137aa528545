//! The import map: a TOML file that says how a table's columns become channels.
//!
//! ```toml
//! [input]                      # all optional: guessed from the first lines
//! layout = "wide"              # "wide": a column per signal; "long": a row per sample
//! delimiter = ","              # ",", ";", "\t" (or "tab"), "whitespace"
//! header = true                # the first line names the columns
//! skip_lines = 0               # lines before the header (a title)
//! decimal_comma = false        # numbers written 20,5
//! comment = "#"                # lines starting with it are skipped
//! missing = ["-", "#N/A"]      # more cells that mean "no sample" (empty and NaN always do)
//!
//! [time]
//! column = "Time (sec)"        # header name or 1-based position
//! format = "seconds"           # or "timestamp" (RFC 3339 / ISO 8601); default: from the cells
//! unit = "s"                   # of a seconds column: s, ms, min, h
//! start = "2018-01-30T12:00:00Z"   # the instant of t = 0 (default: the Unix epoch)
//! zone = "Europe/Zurich"       # for timestamps without an offset: IANA name, UTC or +01:00
//! pattern = "%d.%m.%Y %H:%M:%S"    # timestamps in another layout (strftime)
//! # sample_time_s = 2.0        # instead of a column: row i is at start + i · Ts
//!
//! [[column]]
//! column = "Heater 1 (%)"      # header name or 1-based position
//! channel = "Q1"               # a free name, or quantity = "armature_current"
//! unit = "%"
//! sensor = "rtd3"              # optional: one sensor of several of a quantity
//! quality_column = "Q1 status" # optional: good/uncertain/bad or OPC codes
//! storage = "exception"        # optional: "sampled" (default) or "exception"
//! deadband = 0.1               # with exception: in the channel's unit
//! max_interval_s = 600         # with exception: the heartbeat
//! interpolation = "step"       # optional: "linear" (default) or "step" (a command, held
//!                              # from one sample to the next)
//! resolution = 0.1             # optional: the sensor's step, in the channel's unit
//!
//! # A long table (layout = "long") names the columns of its rows, and picks its
//! # signals by tag instead of by column:
//! # [long]
//! # tag = "Tag"                # the column that names the signal
//! # value = "Wert"             # the column of values
//! # quality = "Status"         # optional: good/uncertain/bad or OPC codes, per row
//! # quality_values = { OK = "good" }
//! # [[column]]
//! # tag = "G1 Temp Statorwicklung [°C]"
//! # quantity = "stator_winding_temp"
//! # unit = "degC"
//!
//! [nameplate]                  # the heatrun.nameplate record
//! rated_apparent_power_mva = 100
//!
//! [metadata."heatrun.test"]    # other metadata records
//! site = "lab"
//! ```
//!
//! Columns (or tags) the map does not list, or lists with `skip = true`, are not
//! imported. The same map reads a Parquet file (`[input]`'s text keys aside).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use jiff::tz::{Offset, TimeZone};
use serde::Deserialize;

use super::error::ImportError;
use crate::recording::Quantity;
use crate::writer::{ChannelSpec, Interpolation, Quality, Storage};

/// A column of the table, as the map names it.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Deserialize)]
#[serde(untagged)]
pub enum ColumnRef {
    /// By position, 1-based.
    Position(i64),
    /// By the header's name (compared after trimming spaces).
    Name(String),
}

impl std::fmt::Display for ColumnRef {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ColumnRef::Position(i) => write!(f, "{i}"),
            ColumnRef::Name(n) => write!(f, "`{n}`"),
        }
    }
}

/// What separates the fields of a line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Delimiter {
    /// One byte: `,`, `;` or a tab (quotes as in CSV).
    Byte(u8),
    /// Runs of spaces and tabs, leading and trailing ones ignored (DaISy `.dat`).
    Whitespace,
}

/// How the table is laid out; what is `None` is guessed from its first lines.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct InputLayout {
    /// The field separator.
    pub delimiter: Option<Delimiter>,
    /// Whether the first line (after `skip_lines`) names the columns.
    pub header: Option<bool>,
    /// Lines skipped before the header or the data.
    pub skip_lines: u64,
    /// Numbers with a decimal comma (`20,5`).
    pub decimal_comma: Option<bool>,
    /// Lines starting with this byte are skipped.
    pub comment: Option<u8>,
    /// Cells that mean a missing sample, besides the empty cell and `NaN`.
    pub missing: Vec<String>,
}

/// How a time column is written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TimeFormat {
    /// Decided from the first data row: a number is seconds, anything else a timestamp.
    Auto,
    /// A number of `unit`s after `start`.
    Seconds,
    /// An RFC 3339 / ISO 8601 timestamp (or one in `pattern`'s layout).
    Timestamp,
}

/// Where each row's time comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum TimeSource {
    /// A column of the table.
    Column {
        /// The column.
        column: ColumnRef,
        /// How it is written.
        format: TimeFormat,
        /// Nanoseconds in one unit of a seconds column (1e9 for `s`).
        unit_ns: i128,
        /// A strftime layout of the timestamps, when they are not RFC 3339 / ISO 8601.
        pattern: Option<String>,
    },
    /// No column: row i (from 0) is at `start + i · sample_time_ns`.
    SampleIndex {
        /// The sample time, ns.
        sample_time_ns: i128,
    },
}

/// The map's `[time]` table, checked.
#[derive(Debug, Clone, PartialEq)]
pub struct TimeSpec {
    /// Where the times come from.
    pub source: TimeSource,
    /// The instant of t = 0 for seconds and sample indexes, ns since the Unix epoch.
    pub start_ns: i128,
    /// The zone of timestamps that carry no offset.
    pub zone: Option<TimeZone>,
}

/// Where a quality flag of a column comes from.
#[derive(Debug, Clone, PartialEq)]
pub struct QualitySource {
    /// The column of flags.
    pub column: ColumnRef,
    /// Extra spellings of the flags (`OK` → good); `good`, `uncertain`, `bad` and
    /// OPC quality codes (≥ 192 good, 64–191 uncertain, < 64 bad) are always read.
    pub values: BTreeMap<String, Quality>,
}

/// Where an imported signal's values are in the table.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub enum ColumnSource {
    /// A column of a wide table.
    Column(ColumnRef),
    /// The rows of a long table whose tag column holds this text.
    Tag(String),
}

impl std::fmt::Display for ColumnSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ColumnSource::Column(c) => c.fmt(f),
            ColumnSource::Tag(t) => write!(f, "tag `{t}`"),
        }
    }
}

/// How the table holds its samples.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum Layout {
    /// A row per instant and a column per signal.
    #[default]
    Wide,
    /// A row per sample: the signal's tag, the time, the value (and its quality).
    Long(LongColumns),
}

/// The columns of a long table's rows.
#[derive(Debug, Clone, PartialEq)]
pub struct LongColumns {
    /// The column that names the signal.
    pub tag: ColumnRef,
    /// The column of values.
    pub value: ColumnRef,
    /// The column of quality flags, if any.
    pub quality: Option<QualitySource>,
}

/// One imported signal.
#[derive(Debug, Clone, PartialEq)]
pub struct ColumnMap {
    /// Where its values are: a column, or a long table's tag.
    pub source: ColumnSource,
    /// The channel it becomes.
    pub channel: ChannelSpec,
    /// Its quality flags, if the table has them.
    pub quality: Option<QualitySource>,
}

/// A checked import map.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportMap {
    /// The map file, for messages.
    pub path: PathBuf,
    /// The table's text layout.
    pub input: InputLayout,
    /// Wide (a column per signal) or long (a row per sample).
    pub layout: Layout,
    /// The rows' times.
    pub time: TimeSpec,
    /// The imported columns, in the map's order.
    pub columns: Vec<ColumnMap>,
    /// The `heatrun.nameplate` record (empty: none written).
    pub nameplate: BTreeMap<String, String>,
    /// Other metadata records, by name.
    pub metadata: BTreeMap<String, BTreeMap<String, String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMap {
    #[serde(default)]
    input: RawInput,
    time: Option<RawTime>,
    long: Option<RawLong>,
    #[serde(default, rename = "column")]
    columns: Vec<RawColumn>,
    #[serde(default)]
    nameplate: BTreeMap<String, toml::Value>,
    #[serde(default)]
    metadata: BTreeMap<String, BTreeMap<String, toml::Value>>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RawInput {
    layout: Option<String>,
    delimiter: Option<String>,
    header: Option<bool>,
    #[serde(default)]
    skip_lines: u64,
    decimal_comma: Option<bool>,
    comment: Option<String>,
    #[serde(default)]
    missing: Vec<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLong {
    tag: ColumnRef,
    value: ColumnRef,
    quality: Option<ColumnRef>,
    #[serde(default)]
    quality_values: BTreeMap<String, String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTime {
    column: Option<ColumnRef>,
    format: Option<String>,
    unit: Option<String>,
    start: Option<String>,
    zone: Option<String>,
    pattern: Option<String>,
    sample_time_s: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawColumn {
    column: Option<ColumnRef>,
    tag: Option<String>,
    #[serde(default)]
    skip: bool,
    channel: Option<String>,
    quantity: Option<String>,
    unit: Option<String>,
    sensor: Option<String>,
    quality_column: Option<ColumnRef>,
    #[serde(default)]
    quality_values: BTreeMap<String, String>,
    storage: Option<String>,
    deadband: Option<f64>,
    max_interval_s: Option<f64>,
    interpolation: Option<String>,
    resolution: Option<f64>,
}

impl ImportMap {
    /// Reads and checks the map at `path`.
    pub fn load(path: &Path) -> Result<ImportMap, ImportError> {
        let text = std::fs::read_to_string(path).map_err(|error| ImportError::Read {
            path: path.to_owned(),
            error,
        })?;
        ImportMap::parse(&text, path)
    }

    /// Checks a map's text; `path` names it in messages.
    pub fn parse(text: &str, path: &Path) -> Result<ImportMap, ImportError> {
        let raw: RawMap = toml::from_str(text).map_err(|e| ImportError::MapSyntax {
            path: path.to_owned(),
            line: e.span().map_or(1, |s| {
                1 + text.as_bytes()[..s.start.min(text.len())]
                    .iter()
                    .filter(|&&b| b == b'\n')
                    .count()
            }),
            message: e.message().replace('\n', " "),
        })?;
        let bad = |key: &str, message: String| ImportError::MapValue {
            path: path.to_owned(),
            key: key.to_owned(),
            message,
        };
        let layout_name = raw.input.layout.clone();
        let input = input_layout(raw.input, &bad)?;
        let layout = layout(layout_name.as_deref(), raw.long, &bad)?;
        let time = time_spec(
            raw.time
                .ok_or_else(|| bad("time", "the map has no [time] table: give `column` (the time column) or `sample_time_s`".into()))?,
            &bad,
        )?;
        let mut columns = Vec::new();
        for c in raw.columns.into_iter().filter(|c| !c.skip) {
            columns.push(column_map(c, &layout, &bad)?);
        }
        if columns.is_empty() {
            return Err(bad(
                "column",
                "the map imports no column: add a [[column]] table for each".into(),
            ));
        }
        check_unique(&columns, &bad)?;
        let nameplate = nameplate_record(raw.nameplate, &bad)?;
        let mut metadata = BTreeMap::new();
        for (name, record) in raw.metadata {
            let mut entries = BTreeMap::new();
            for (k, v) in record {
                entries.insert(
                    k.clone(),
                    value_text(&v).ok_or_else(|| {
                        bad(
                            &format!("metadata.{name}.{k}"),
                            format!("a {} is not a text or a number", v.type_str()),
                        )
                    })?,
                );
            }
            metadata.insert(name, entries);
        }
        Ok(ImportMap {
            path: path.to_owned(),
            input,
            layout,
            time,
            columns,
            nameplate,
            metadata,
        })
    }
}

type Bad<'a> = dyn Fn(&str, String) -> ImportError + 'a;

/// Each channel once, each column or tag once.
fn check_unique(columns: &[ColumnMap], bad: &Bad) -> Result<(), ImportError> {
    let mut topics = std::collections::BTreeSet::new();
    for c in columns {
        if !topics.insert(c.channel.topic.clone()) {
            return Err(bad(
                &format!("[[column]] {}", c.source),
                format!(
                    "a second column becomes channel `{}`; give each a `sensor` to tell them apart",
                    c.channel.name
                ),
            ));
        }
    }
    let mut sources = std::collections::BTreeSet::new();
    for c in columns {
        if !sources.insert(c.source.clone()) {
            return Err(bad(
                &format!("[[column]] {}", c.source),
                "listed twice: one [[column]] table for each".into(),
            ));
        }
    }
    Ok(())
}

fn input_layout(raw: RawInput, bad: &Bad) -> Result<InputLayout, ImportError> {
    let delimiter = match raw.delimiter.as_deref() {
        None => None,
        Some(",") => Some(Delimiter::Byte(b',')),
        Some(";") => Some(Delimiter::Byte(b';')),
        Some("\t" | "tab") => Some(Delimiter::Byte(b'\t')),
        Some("whitespace" | " ") => Some(Delimiter::Whitespace),
        Some(other) => {
            return Err(bad(
                "input.delimiter",
                format!("`{other}` is not one of \",\", \";\", \"\\t\", \"whitespace\""),
            ))
        }
    };
    let comment = match raw.comment.as_deref() {
        None => None,
        Some(c) if c.len() == 1 => Some(c.as_bytes()[0]),
        Some(c) => return Err(bad("input.comment", format!("`{c}` must be one character"))),
    };
    Ok(InputLayout {
        delimiter,
        header: raw.header,
        skip_lines: raw.skip_lines,
        decimal_comma: raw.decimal_comma,
        comment,
        missing: raw.missing,
    })
}

/// `[input] layout` and the `[long]` table, which go together.
fn layout(name: Option<&str>, long: Option<RawLong>, bad: &Bad) -> Result<Layout, ImportError> {
    match (name.unwrap_or("wide"), long) {
        ("wide", None) => Ok(Layout::Wide),
        ("wide", Some(_)) => Err(bad(
            "long",
            "a [long] table describes a long table: add `layout = \"long\"` under [input]".into(),
        )),
        ("long", None) => Err(bad(
            "long",
            "layout = \"long\" needs a [long] table naming the `tag` and `value` columns".into(),
        )),
        ("long", Some(raw)) => {
            check_ref(&raw.tag, bad, "long.tag")?;
            check_ref(&raw.value, bad, "long.value")?;
            let quality = quality_source(
                raw.quality,
                raw.quality_values,
                &|f| format!("long.{f}"),
                bad,
            )?;
            Ok(Layout::Long(LongColumns {
                tag: raw.tag,
                value: raw.value,
                quality,
            }))
        }
        (other, _) => Err(bad(
            "input.layout",
            format!(
                "`{other}` is not \"wide\" (a column per signal) or \"long\" (a row per sample)"
            ),
        )),
    }
}

fn time_spec(raw: RawTime, bad: &Bad) -> Result<TimeSpec, ImportError> {
    let zone = raw
        .zone
        .as_deref()
        .map(|z| parse_zone(z).map_err(|m| bad("time.zone", m)))
        .transpose()?;
    let start_ns = match raw.start.as_deref() {
        None => 0,
        Some(s) => parse_start(s, zone.as_ref()).map_err(|m| bad("time.start", m))?,
    };
    let source = match (raw.column, raw.sample_time_s) {
        (Some(_), Some(_)) => {
            return Err(bad(
                "time",
                "give either `column` or `sample_time_s`, not both".into(),
            ))
        }
        (None, None) => {
            return Err(bad(
                "time",
                "give `column` (the time column) or `sample_time_s` (rows at a fixed step)".into(),
            ))
        }
        (None, Some(ts)) => {
            let sample_time_ns = (ts * 1e9).round();
            if !(ts.is_finite() && sample_time_ns >= 1.0) {
                return Err(bad(
                    "time.sample_time_s",
                    format!("{ts} is not a positive number of seconds"),
                ));
            }
            if raw.format.is_some() || raw.unit.is_some() || raw.pattern.is_some() {
                return Err(bad(
                    "time",
                    "`format`, `unit` and `pattern` describe a time column; there is none with `sample_time_s`".into(),
                ));
            }
            TimeSource::SampleIndex {
                sample_time_ns: sample_time_ns as i128,
            }
        }
        (Some(column), None) => time_column(column, raw.format, raw.unit, raw.pattern, bad)?,
    };
    Ok(TimeSpec {
        source,
        start_ns,
        zone,
    })
}

/// A time column: how it is written and in which unit.
fn time_column(
    column: ColumnRef,
    format: Option<String>,
    unit: Option<String>,
    pattern: Option<String>,
    bad: &Bad,
) -> Result<TimeSource, ImportError> {
    check_ref(&column, bad, "time.column")?;
    let format = match (format.as_deref(), &pattern) {
        (None, None) => TimeFormat::Auto,
        (None | Some("timestamp"), _) => TimeFormat::Timestamp,
        (Some("seconds"), None) => TimeFormat::Seconds,
        (Some("seconds"), Some(_)) => {
            return Err(bad(
                "time.pattern",
                "a pattern describes timestamps, not seconds".into(),
            ))
        }
        (Some(other), _) => {
            return Err(bad(
                "time.format",
                format!("`{other}` is not \"seconds\" or \"timestamp\""),
            ))
        }
    };
    let unit_ns = match unit.as_deref().unwrap_or("s") {
        "s" => 1_000_000_000,
        "ms" => 1_000_000,
        "us" => 1_000,
        "min" => 60_000_000_000,
        "h" => 3_600_000_000_000,
        other => {
            return Err(bad(
                "time.unit",
                format!("`{other}` is not one of s, ms, us, min, h"),
            ))
        }
    };
    Ok(TimeSource::Column {
        column,
        format,
        unit_ns,
        pattern,
    })
}

/// A zone: `UTC`, a fixed offset `+01:00`, or an IANA name.
fn parse_zone(text: &str) -> Result<TimeZone, String> {
    if text == "UTC" || text == "Z" {
        return Ok(TimeZone::UTC);
    }
    if let Some(sign) = text.strip_prefix(['+', '-']).map(|_| text.as_bytes()[0]) {
        let rest = &text[1..];
        let (h, m) = rest.split_once(':').unwrap_or((rest, "0"));
        let (h, m): (i32, i32) = match (h.parse(), m.parse()) {
            (Ok(h), Ok(m)) if h <= 25 && m < 60 => (h, m),
            _ => return Err(format!("`{text}` is not an offset like +01:00")),
        };
        let seconds = (h * 3600 + m * 60) * if sign == b'-' { -1 } else { 1 };
        let offset = Offset::from_seconds(seconds).map_err(|e| e.to_string())?;
        return Ok(TimeZone::fixed(offset));
    }
    TimeZone::get(text).map_err(|e| {
        format!("`{text}` is not a time zone (an IANA name such as Europe/Zurich, UTC, or an offset such as +01:00): {e}")
    })
}

/// The start instant: RFC 3339 with an offset, or a civil time in `zone`.
fn parse_start(text: &str, zone: Option<&TimeZone>) -> Result<i128, String> {
    super::time::parse_timestamp(text, zone, None)
}

fn check_ref(column: &ColumnRef, bad: &Bad, key: &str) -> Result<(), ImportError> {
    match column {
        ColumnRef::Position(i) if *i < 1 => {
            Err(bad(key, format!("column positions count from 1, not {i}")))
        }
        ColumnRef::Name(n) if n.trim().is_empty() => {
            Err(bad(key, "a column name must not be empty".into()))
        }
        _ => Ok(()),
    }
}

/// Whether a name can stand in a spec's expression: a letter or `_`, then letters,
/// digits and `_`.
pub fn is_channel_name(name: &str) -> bool {
    let mut chars = name.chars();
    chars
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// Where a `[[column]]` table's values are: `column` in a wide table, `tag` in a
/// long one.
fn column_source(raw: &RawColumn, layout: &Layout, bad: &Bad) -> Result<ColumnSource, ImportError> {
    match (layout, &raw.column, &raw.tag) {
        (Layout::Wide, Some(column), None) => {
            check_ref(column, bad, &format!("[[column]] {column}.column"))?;
            Ok(ColumnSource::Column(column.clone()))
        }
        (Layout::Wide, _, Some(tag)) => Err(bad(
            &format!("[[column]] tag `{tag}`"),
            "`tag` picks a long table's signal: set `layout = \"long\"` under [input] and add [long], or give `column`".into(),
        )),
        (Layout::Long(_), None, Some(tag)) if !tag.trim().is_empty() => {
            Ok(ColumnSource::Tag(tag.trim().to_owned()))
        }
        (Layout::Long(_), Some(column), _) => Err(bad(
            &format!("[[column]] {column}"),
            "a long table's signals are picked by `tag`, not `column`".into(),
        )),
        (Layout::Long(_), None, _) => Err(bad(
            "[[column]].tag",
            "each [[column]] of a long table needs a non-empty `tag` (the tag column's text)".into(),
        )),
        (Layout::Wide, None, None) => Err(bad(
            "[[column]].column",
            "each [[column]] needs `column` (a header name or 1-based position)".into(),
        )),
    }
}

fn column_map(raw: RawColumn, layout: &Layout, bad: &Bad) -> Result<ColumnMap, ImportError> {
    let source = column_source(&raw, layout, bad)?;
    let key = |field: &str| format!("[[column]] {source}.{field}");
    if matches!(layout, Layout::Long(_)) && raw.quality_column.is_some() {
        return Err(bad(
            &key("quality_column"),
            "a long table's quality is per row: give `quality` under [long]".into(),
        ));
    }
    let name = channel_name(&raw, &key, bad)?;
    let unit = raw.unit.clone().ok_or_else(|| {
        bad(
            &key("unit"),
            "no unit: give it (\"1\" for a dimensionless value)".into(),
        )
    })?;
    if let Some(q) = Quantity::from_name(&name) {
        if q.unit_scale(&unit).is_none() {
            return Err(bad(
                &key("unit"),
                format!(
                    "`{unit}` is not a unit the profile accepts for {name}: use one of {}",
                    q.accepted_units().join(", ")
                ),
            ));
        }
    }
    let storage = storage(&raw.storage, raw.deadband, raw.max_interval_s, &key, bad)?;
    let interpolation = match raw.interpolation.as_deref() {
        None | Some("linear") => Interpolation::Linear,
        Some("step") => Interpolation::Step,
        Some(other) => {
            return Err(bad(
                &key("interpolation"),
                format!(
                    "`{other}` is not \"linear\" or \"step\" (a command or set point, held \
                     between samples)"
                ),
            ))
        }
    };
    let mut channel = ChannelSpec::new(&name, &unit)
        .with_storage(storage)
        .with_interpolation(interpolation);
    if let Some(r) = raw.resolution {
        if !(r.is_finite() && r > 0.0) {
            return Err(bad(
                &key("resolution"),
                format!("{r} is not a positive step in the channel's unit (e.g. 0.01)"),
            ));
        }
        channel = channel.with_resolution(r);
    }
    if let Some(sensor) = &raw.sensor {
        if sensor.is_empty() || sensor.contains('/') {
            return Err(bad(
                &key("sensor"),
                format!("`{sensor}` must be a non-empty name without /"),
            ));
        }
        channel = channel.with_sensor(sensor);
    }
    let quality = quality_source(raw.quality_column, raw.quality_values, &key, bad)?;
    Ok(ColumnMap {
        source,
        channel,
        quality,
    })
}

/// The channel's name: a profile quantity (`quantity`) or a free name (`channel`).
fn channel_name(
    raw: &RawColumn,
    key: &dyn Fn(&str) -> String,
    bad: &Bad,
) -> Result<String, ImportError> {
    match (&raw.channel, &raw.quantity) {
        (Some(_), Some(_)) => Err(bad(
            &key("channel"),
            "give `channel` (a free name) or `quantity` (a profile quantity), not both".into(),
        )),
        (None, None) => Err(bad(
            &key("channel"),
            "give `channel` (a free name such as T1) or `quantity` (a profile quantity), or `skip = true`".into(),
        )),
        (None, Some(q)) if Quantity::from_name(q).is_none() => Err(bad(
            &key("quantity"),
            format!(
                "`{q}` is not a profile quantity ({}); a free name goes in `channel`",
                Quantity::ALL.map(|q| q.name()).join(", ")
            ),
        )),
        (Some(c), None) if !is_channel_name(c) => Err(bad(
            &key("channel"),
            format!("`{c}` is not a channel name: a letter or _, then letters, digits or _"),
        )),
        (Some(name), None) | (None, Some(name)) => Ok(name.clone()),
    }
}

fn quality_source(
    column: Option<ColumnRef>,
    spellings: BTreeMap<String, String>,
    key: &dyn Fn(&str) -> String,
    bad: &Bad,
) -> Result<Option<QualitySource>, ImportError> {
    let Some(column) = column else {
        if spellings.is_empty() {
            return Ok(None);
        }
        return Err(bad(
            &key("quality_values"),
            "there is no `quality_column` for them to read".into(),
        ));
    };
    check_ref(&column, bad, &key("quality_column"))?;
    let mut values = BTreeMap::new();
    for (text, flag) in spellings {
        let q = match flag.as_str() {
            "good" => Quality::Good,
            "uncertain" => Quality::Uncertain,
            "bad" => Quality::Bad,
            other => {
                return Err(bad(
                    &key(&format!("quality_values.{text}")),
                    format!("`{other}` is not good, uncertain or bad"),
                ))
            }
        };
        values.insert(text, q);
    }
    Ok(Some(QualitySource { column, values }))
}

fn storage(
    kind: &Option<String>,
    deadband: Option<f64>,
    max_interval_s: Option<f64>,
    key: &dyn Fn(&str) -> String,
    bad: &Bad,
) -> Result<Storage, ImportError> {
    match kind.as_deref() {
        None | Some("sampled") => {
            if deadband.is_some() || max_interval_s.is_some() {
                return Err(bad(
                    &key("deadband"),
                    "`deadband` and `max_interval_s` go with storage = \"exception\"".into(),
                ));
            }
            Ok(Storage::Sampled)
        }
        Some("exception") => {
            let deadband = deadband.ok_or_else(|| {
                bad(
                    &key("deadband"),
                    "storage = \"exception\" needs a deadband (in the channel's unit)".into(),
                )
            })?;
            let max_interval_s = max_interval_s.ok_or_else(|| {
                bad(
                    &key("max_interval_s"),
                    "storage = \"exception\" needs max_interval_s (the heartbeat, s)".into(),
                )
            })?;
            if !(deadband.is_finite() && deadband >= 0.0) {
                return Err(bad(
                    &key("deadband"),
                    format!("{deadband} is not a number ≥ 0"),
                ));
            }
            if !(max_interval_s.is_finite() && max_interval_s > 0.0) {
                return Err(bad(
                    &key("max_interval_s"),
                    format!("{max_interval_s} is not a positive number of seconds"),
                ));
            }
            Ok(Storage::Exception {
                deadband,
                max_interval_s: Some(max_interval_s),
            })
        }
        Some(other) => Err(bad(
            &key("storage"),
            format!("`{other}` is not \"sampled\" or \"exception\""),
        )),
    }
}

/// A TOML value as a metadata string (texts as they are, numbers in decimal).
fn value_text(v: &toml::Value) -> Option<String> {
    match v {
        toml::Value::String(s) => Some(s.clone()),
        toml::Value::Integer(i) => Some(i.to_string()),
        toml::Value::Float(f) => Some(f.to_string()),
        toml::Value::Boolean(b) => Some(b.to_string()),
        toml::Value::Datetime(d) => Some(d.to_string()),
        _ => None,
    }
}

fn nameplate_record(
    raw: BTreeMap<String, toml::Value>,
    bad: &Bad,
) -> Result<BTreeMap<String, String>, ImportError> {
    let mut record = BTreeMap::new();
    for (k, v) in raw {
        let text = value_text(&v).unwrap_or_default();
        if k != "name" && text.trim().parse::<f64>().is_err() {
            return Err(bad(
                &format!("nameplate.{k}"),
                format!("`{text}` is not a number"),
            ));
        }
        record.insert(k, text);
    }
    Ok(record)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<ImportMap, ImportError> {
        ImportMap::parse(text, Path::new("map.toml"))
    }

    #[test]
    fn a_full_map_is_read() {
        let m = parse(
            r#"
            [input]
            delimiter = ";"
            header = true
            decimal_comma = true
            [time]
            column = "Zeit"
            zone = "+01:00"
            [[column]]
            column = 2
            quantity = "stator_winding_temp"
            unit = "degC"
            sensor = "rtd1"
            storage = "exception"
            deadband = 0.1
            max_interval_s = 600
            quality_column = "Q"
            quality_values = { OK = "good", SUSP = "uncertain" }
            [[column]]
            column = "x"
            skip = true
            [nameplate]
            rated_apparent_power_mva = 100
            [metadata."heatrun.test"]
            site = "lab"
            "#,
        )
        .unwrap();
        assert_eq!(m.input.delimiter, Some(Delimiter::Byte(b';')));
        assert_eq!(m.columns.len(), 1);
        let c = &m.columns[0];
        assert_eq!(c.channel.topic, "/scada/stator_winding_temp/rtd1");
        assert_eq!(
            c.channel.storage,
            Storage::Exception {
                deadband: 0.1,
                max_interval_s: Some(600.0)
            }
        );
        assert_eq!(
            c.quality.as_ref().unwrap().values["SUSP"],
            Quality::Uncertain
        );
        assert_eq!(c.channel.interpolation, Interpolation::Linear);
        assert!(!c.channel.metadata().contains_key("interpolation"));
        assert_eq!(m.nameplate["rated_apparent_power_mva"], "100");
        assert_eq!(m.metadata["heatrun.test"]["site"], "lab");
        let step = parse(
            "[time]\ncolumn = 1\n[[column]]\ncolumn = 2\nchannel = \"Q1\"\nunit = \"%\"\ninterpolation = \"step\"",
        )
        .unwrap();
        let q1 = &step.columns[0].channel;
        assert_eq!(q1.interpolation, Interpolation::Step);
        assert_eq!(q1.metadata()["interpolation"], "step");
        assert!(!q1.metadata().contains_key("resolution"));
        assert_eq!(m.time.start_ns, 0);
        // A sensor's resolution goes to the channel's metadata, in its unit; a step that is
        // not positive is refused, naming the key.
        let rounded = parse(
            "[time]\ncolumn = 1\n[[column]]\ncolumn = 2\nquantity = \"core_temp\"\nunit = \"degC\"\nresolution = 0.1",
        )
        .unwrap();
        assert_eq!(rounded.columns[0].channel.metadata()["resolution"], "0.1");
        let zero = parse(
            "[time]\ncolumn = 1\n[[column]]\ncolumn = 2\nquantity = \"core_temp\"\nunit = \"degC\"\nresolution = 0",
        );
        let message = zero.expect_err("refused").to_string();
        assert!(message.contains("resolution"), "{message}");
    }

    #[test]
    fn mistakes_name_their_key() {
        let cases = [
            ("[time]\ncolumn = 1\n[[column]]\ncolumn = 2\nchanel = \"T\"\nunit = \"1\"", "line 5"),
            ("[time]\ncolumn = 1\n[[column]]\ncolumn = 2\nquantity = \"stator_temp\"\nunit = \"degC\"", "[[column]] 2.quantity"),
            ("[time]\ncolumn = 1\n[[column]]\ncolumn = 2\nquantity = \"line_voltage\"\nunit = \"MV\"", "[[column]] 2.unit"),
            ("[time]\ncolumn = 1\n[[column]]\ncolumn = 2\nchannel = \"T 1\"\nunit = \"1\"", "[[column]] 2.channel"),
            ("[time]\ncolumn = 1\n[[column]]\ncolumn = 2\nchannel = \"T\"\nunit = \"1\"\nstorage = \"exception\"\ndeadband = 0.1", "max_interval_s"),
            ("[time]\ncolumn = 0\n[[column]]\ncolumn = 2\nchannel = \"T\"\nunit = \"1\"", "time.column"),
            ("[time]\nzone = \"Mars/Olympus\"\ncolumn = 1\n[[column]]\ncolumn = 2\nchannel = \"T\"\nunit = \"1\"", "time.zone"),
            ("[time]\ncolumn = 1\nsample_time_s = 1\n[[column]]\ncolumn = 2\nchannel = \"T\"\nunit = \"1\"", "time:"),
            ("[time]\ncolumn = 1", "column:"),
            ("[time]\ncolumn = 1\n[[column]]\ncolumn = 2\nchannel = \"Q\"\nunit = \"%\"\ninterpolation = \"held\"", "[[column]] 2.interpolation"),
            ("[time]\ncolumn = 1\n[[column]]\ncolumn = 2\nchannel = \"T\"\nunit = \"1\"\n[[column]]\ncolumn = 3\nchannel = \"T\"\nunit = \"1\"", "sensor"),
        ];
        for (text, expected) in cases {
            let msg = parse(text).unwrap_err().to_string();
            assert!(msg.starts_with("map.toml: "), "{msg}");
            assert!(msg.contains(expected), "{expected:?} not in {msg}");
            assert_eq!(msg.lines().count(), 1, "{msg}");
        }
    }

    #[test]
    fn a_long_map_is_read() {
        let m = parse(
            r#"
            [input]
            layout = "long"
            delimiter = ";"
            decimal_comma = true
            [long]
            tag = "Tag"
            value = "Wert"
            quality = "Status"
            [time]
            column = "Zeitstempel"
            zone = "Europe/Zurich"
            [[column]]
            tag = "G1 Temp Statorwicklung [°C]"
            quantity = "stator_winding_temp"
            unit = "degC"
            "#,
        )
        .unwrap();
        let Layout::Long(long) = &m.layout else {
            panic!("{:?}", m.layout)
        };
        assert_eq!(long.tag, ColumnRef::Name("Tag".into()));
        assert_eq!(long.value, ColumnRef::Name("Wert".into()));
        assert_eq!(
            long.quality.as_ref().unwrap().column,
            ColumnRef::Name("Status".into())
        );
        assert_eq!(
            m.columns[0].source,
            ColumnSource::Tag("G1 Temp Statorwicklung [°C]".into())
        );
        let long = "[input]\nlayout = \"long\"\n[long]\ntag = 1\nvalue = 3\n[time]\ncolumn = 2\n";
        let cases = [
            (format!("{long}[[column]]\ncolumn = 2\nchannel = \"T\"\nunit = \"1\""), "not `column`"),
            (format!("{long}[[column]]\ntag = \"A\"\nchannel = \"T\"\nunit = \"1\"\nquality_column = 4"), "under [long]"),
            (format!("{long}[[column]]\ntag = \"A\"\nchannel = \"T\"\nunit = \"1\"\n[[column]]\ntag = \"A\"\nchannel = \"U\"\nunit = \"1\""), "listed twice"),
            ("[input]\nlayout = \"long\"\n[time]\ncolumn = 2\n[[column]]\ntag = \"A\"\nchannel = \"T\"\nunit = \"1\"".into(), "[long] table"),
            ("[time]\ncolumn = 2\n[[column]]\ntag = \"A\"\nchannel = \"T\"\nunit = \"1\"".into(), "layout = \"long\""),
            ("[input]\nlayout = \"tall\"\n[time]\ncolumn = 2\n[[column]]\ncolumn = 1\nchannel = \"T\"\nunit = \"1\"".into(), "input.layout"),
        ];
        for (text, expected) in cases {
            let msg = parse(&text).unwrap_err().to_string();
            assert!(msg.contains(expected), "{expected:?} not in {msg}");
            assert_eq!(msg.lines().count(), 1, "{msg}");
        }
    }

    #[test]
    fn zones_and_starts() {
        let m = parse(
            "[time]\nsample_time_s = 0.5\nstart = \"2024-01-01T01:00:00\"\nzone = \"+01:00\"\n[[column]]\ncolumn = 1\nchannel = \"T\"\nunit = \"1\"",
        )
        .unwrap();
        // 2024-01-01T00:00:00Z = 1704067200 s.
        assert_eq!(m.time.start_ns, 1_704_067_200_000_000_000);
        assert_eq!(
            m.time.source,
            TimeSource::SampleIndex {
                sample_time_ns: 500_000_000
            }
        );
    }
}
