//! Tables the way historians also write them: the historian export of
//! [`crate::historian`] written as a long table (`Tag;Zeitstempel;Wert;Status`, sorted
//! by time and grouped by tag) and as Parquet (wide and long), each imported beside the
//! wide text export of the same run; and a night heat run in Europe/Zurich's wall-clock
//! time through the end of summer time (2023-10-29), replayed against its truth.

use crate::common;
use crate::historian::{historian_export, import, percent, samples, synth, time_constants, truth};

use std::collections::BTreeMap;
use std::fs::File;
use std::path::Path;
use std::sync::Arc;

use common::heatrun_ok;
use parquet::basic::{Compression, LogicalType, Repetition, TimeUnit, Type as Physical, ZstdLevel};
use parquet::data_type::{ByteArray, ByteArrayType, DoubleType, Int32Type, Int64Type};
use parquet::file::properties::WriterProperties;
use parquet::file::writer::SerializedFileWriter;
use parquet::schema::types::Type;

const S: u64 = 1_000_000_000;

/// The flaws of the historian's export: storage by exception, "I/O Timeout" cells on
/// the current, a drifting inlet.
const FLAWS: [&str; 8] = [
    "--deadband",
    "0.05",
    "--heartbeat",
    "600",
    "--inlet-drift",
    "1",
    "--input-timeouts",
    "20",
];

/// Bad stator samples in the exports (as in the historian test).
const BAD_STATOR: usize = 12;

/// One stored sample of a long table: tag, time after the first sample (ns), value
/// (`None`: missing) and whether it is flagged bad.
struct LongRow {
    quantity: String,
    t: u64,
    value: Option<f64>,
    bad: bool,
}

/// The recording's samples as long rows, in time order (each channel's in its order),
/// with `bad_stator` of the stator winding's stored values flagged bad: the same ones
/// the wide export flags (spread evenly over its rows with a stator value).
fn long_rows(path: &Path, bad_stator: usize) -> Vec<LongRow> {
    let channels = samples(path);
    let t0 = channels.values().map(|c| c[0].0).min().unwrap();
    let mut rows = Vec::new();
    for (topic, values) in &channels {
        let quantity = topic.trim_start_matches("/scada/").to_owned();
        let stored: Vec<u64> = values
            .iter()
            .filter(|(_, v)| v.is_some())
            .map(|(t, _)| *t)
            .collect();
        let bad: Vec<u64> = if quantity == "stator_winding_temp" {
            (0..bad_stator)
                .map(|i| stored[(i + 1) * stored.len() / (bad_stator + 1)])
                .collect()
        } else {
            Vec::new()
        };
        for &(t, value) in values {
            rows.push(LongRow {
                quantity: quantity.clone(),
                t: t - t0,
                value,
                bad: bad.contains(&t),
            });
        }
    }
    // Stable: rows of one time keep the channels' order.
    rows.sort_by_key(|r| r.t);
    rows
}

fn tag(quantity: &str) -> String {
    format!("G1.{quantity}")
}

/// The long rows as a historian's `;` table with decimal commas; flags spelt `Good`,
/// `Bad` and OPC codes (192 good) by turns. `by_tag`: grouped by tag, as PI exports
/// recorded values, instead of by time.
fn long_table(rows: &[LongRow], by_tag: bool) -> String {
    let mut order: Vec<&LongRow> = rows.iter().collect();
    if by_tag {
        order.sort_by(|a, b| a.quantity.cmp(&b.quantity));
    }
    let mut table = "Tag;Zeitstempel;Wert;Status\n".to_owned();
    for (i, r) in order.iter().enumerate() {
        let value = match r.value {
            Some(v) => format!("{v}").replace('.', ","),
            None if r.quantity == "armature_current" => "I/O Timeout".into(),
            None => String::new(),
        };
        let status = match (r.bad, i % 2) {
            (true, _) => "Bad",
            (false, 0) => "Good",
            (false, _) => "192",
        };
        table.push_str(&format!(
            "{};{},{:09};{value};{status}\n",
            tag(&r.quantity),
            r.t / S,
            r.t % S
        ));
    }
    table
}

/// The wide export's map turned into the long table's: the layout, `[long]`, the time
/// column, and each `[[column]]` picked by its tag.
fn long_map(wide_map: &str) -> String {
    let mut map = String::new();
    let mut in_time = false;
    for line in wide_map.lines() {
        match line {
            "[input]" => map.push_str("[input]\nlayout = \"long\"\n"),
            "[time]" => {
                map.push_str(
                    "[long]\ntag = \"Tag\"\nvalue = \"Wert\"\nquality = \"Status\"\n[time]\n",
                );
                in_time = true;
            }
            l if in_time && l.starts_with("column = ") => {
                map.push_str("column = \"Zeitstempel\"\n");
                in_time = false;
            }
            l if l.starts_with("column = ") => {
                let quantity = l.trim_start_matches("column = ").trim_matches('"');
                map.push_str(&format!("tag = \"{}\"\n", tag(quantity)));
            }
            l if l.starts_with("quality_column = ") => {}
            l => {
                map.push_str(l);
                map.push('\n');
            }
        }
    }
    map
}

/// Every channel's samples of a recording, each in time order.
fn sorted_samples(path: &Path) -> BTreeMap<String, Vec<(u64, Option<f64>)>> {
    let mut s = samples(path);
    for v in s.values_mut() {
        v.sort_by_key(|(t, _)| *t);
    }
    s
}

#[test]
fn a_long_export_replays_as_the_wide_one() {
    let dir = common::tempdir();
    let d = dir.path();
    synth(d, "stored.mcap", &FLAWS);
    let (wide, wide_map, _) = historian_export(&d.join("stored.mcap"), Some(0.05), BAD_STATOR);
    std::fs::write(d.join("wide.csv"), wide).unwrap();
    std::fs::write(d.join("wide.toml"), &wide_map).unwrap();
    import(d, "wide.csv", "wide.toml", "wide.mcap");

    let rows = long_rows(&d.join("stored.mcap"), BAD_STATOR);
    std::fs::write(d.join("long.toml"), long_map(&wide_map)).unwrap();
    for (name, by_tag) in [("long", false), ("grouped", true)] {
        std::fs::write(d.join(format!("{name}.csv")), long_table(&rows, by_tag)).unwrap();
        let out = heatrun_ok(
            &[
                "import",
                &format!("{name}.csv"),
                "--map",
                "long.toml",
                "--out",
                &format!("{name}.mcap"),
            ],
            d,
        );
        eprintln!("{}", String::from_utf8_lossy(&out.stdout));
        // The same samples as the wide import, channel by channel.
        assert!(
            sorted_samples(&d.join(format!("{name}.mcap"))) == sorted_samples(&d.join("wide.mcap")),
            "{name}: the samples differ from the wide import's"
        );
    }
    let wide = time_constants(d, "wide.mcap");
    for name in ["long", "grouped"] {
        let long = time_constants(d, &format!("{name}.mcap"));
        eprintln!("{name} against wide: {:?} %", percent(&long, &wide));
        for p in percent(&long, &wide) {
            assert!(p.abs() < 0.1, "{name} {long:?} against wide {wide:?}");
        }
    }
}

#[test]
fn guess_recognises_a_long_table_and_lists_its_tags() {
    let dir = common::tempdir();
    let d = dir.path();
    let tags = [
        "G1 Temp Statorwicklung [°C]",
        "G1 Strom [kA]",
        "G1 Kühlwasser Durchfluss [l/s]",
    ];
    let mut table = "Tag;Zeitstempel;Wert;Status\n".to_owned();
    for i in 0..40 {
        for (j, t) in tags.iter().enumerate() {
            table.push_str(&format!(
                "{t};2023-10-29 0{}:{:02}:00;{},5;Good\n",
                i / 60,
                i % 60,
                20 + j
            ));
        }
    }
    // A fourth tag first seen far beyond the rows the layout is guessed from.
    table.push_str("G1 Spannung [kV];2023-10-29 00:40:00;10,5;Good\n");
    std::fs::write(d.join("long.csv"), &table).unwrap();
    let out = heatrun_ok(&["import", "--guess", "long.csv"], d);
    let map = String::from_utf8(out.stdout).unwrap();
    for expected in [
        "layout = \"long\"",
        "delimiter = \";\"",
        "decimal_comma = true",
        "[long]\ntag = \"Tag\"\nvalue = \"Wert\"\nquality = \"Status\"",
        "column = \"Zeitstempel\"",
        "# 4 tags",
        "tag = \"G1 Temp Statorwicklung [°C]\"\nchannel = \"G1_Temp_Statorwicklung\"\nunit = \"degC\"",
        "tag = \"G1 Strom [kA]\"\nchannel = \"G1_Strom\"\nunit = \"kA\"",
        "unit = \"l/s\"",
        "tag = \"G1 Spannung [kV]\"\nchannel = \"G1_Spannung\"\nunit = \"kV\"",
    ] {
        assert!(map.contains(expected), "{expected:?} not in\n{map}");
    }
    // The guess imports once its zone is given.
    let map = map.replace("zone = \"UTC\"", "zone = \"Europe/Zurich\"");
    std::fs::write(d.join("long.toml"), map).unwrap();
    let out = heatrun_ok(
        &[
            "import",
            "long.csv",
            "--map",
            "long.toml",
            "--out",
            "long.mcap",
        ],
        d,
    );
    let said = String::from_utf8(out.stdout).unwrap();
    assert!(said.contains("121 rows, 4 channels"), "{said}");
}

/// 2023-10-29T01:00:00Z: Europe/Zurich's clocks went from 03:00 +02:00 back to 02:00
/// +01:00 (the EU's rule: the last Sunday of October, 01:00 UTC).
const FALL_BACK_S: u64 = 1_698_541_200;

/// A UTC instant (ns) as Zurich's wall-clock time on that night, by the EU's rule
/// (independent of the zone database heatrun reads): `2023-10-29T02:30:00`.
fn zurich_wall_clock(t_ns: u64) -> String {
    let offset_h = if t_ns < FALL_BACK_S * S { 2 } else { 1 };
    let text = heatrun::recording::format_time(t_ns + offset_h * 3600 * S);
    text.trim_end_matches('Z').to_owned()
}

/// The wide export with its seconds column rewritten as wall-clock times in Zurich,
/// the run starting at 23:00 local time on 2023-10-28, its map told the zone, and the
/// rows in the first and the second pass through 02:00-02:59.
fn night_export(path: &Path) -> (String, String, [u64; 2]) {
    let (table, map, _) = historian_export(path, None, 0);
    let start_ns = (FALL_BACK_S - 4 * 3600) * S;
    let mut lines = table.lines();
    let mut out = format!("{}\n", lines.next().unwrap());
    let mut passes = [0; 2];
    for line in lines {
        let (time, rest) = line.split_once(';').unwrap();
        let (s, ns) = time.split_once(',').unwrap();
        let t = start_ns + s.parse::<u64>().unwrap() * S + ns.parse::<u64>().unwrap();
        // The hour before the change and the hour after it show 02:00-02:59.
        if ((FALL_BACK_S - 3600) * S..(FALL_BACK_S + 3600) * S).contains(&t) {
            passes[usize::from(t >= FALL_BACK_S * S)] += 1;
        }
        out.push_str(&format!("{};{rest}\n", zurich_wall_clock(t)));
    }
    let mut night_map = String::new();
    for line in map.lines() {
        if line == "format = \"seconds\"" {
            night_map.push_str("format = \"timestamp\"\nzone = \"Europe/Zurich\"\n");
        } else if !line.starts_with("start = ") {
            night_map.push_str(line);
            night_map.push('\n');
        }
    }
    (out, night_map, passes)
}

/// The `heatrun.import` record of a recording.
fn import_record(path: &Path) -> BTreeMap<String, String> {
    let bytes = std::fs::read(path).unwrap();
    for record in mcap::read::LinearReader::new(&bytes).unwrap() {
        if let mcap::records::Record::Metadata(m) = record.unwrap() {
            if m.name == "heatrun.import" {
                return m.metadata;
            }
        }
    }
    panic!("no heatrun.import record in {}", path.display())
}

#[test]
fn a_night_run_through_the_clock_change_replays_to_its_truth() {
    let dir = common::tempdir();
    let d = dir.path();
    synth(d, "night.mcap", &[]);
    let (table, map, [first, second]) = night_export(&d.join("night.mcap"));
    assert!(table.contains("\n2023-10-29T02:59:59;") && table.contains("\n2023-10-29T03:00:00;"));
    std::fs::write(d.join("night.csv"), &table).unwrap();
    std::fs::write(d.join("night.toml"), &map).unwrap();
    let out = heatrun_ok(
        &[
            "import",
            "night.csv",
            "--map",
            "night.toml",
            "--out",
            "local.mcap",
        ],
        d,
    );
    let said = String::from_utf8(out.stdout).unwrap();
    eprintln!("{said}");
    let change = format!(
        "2023-10-29T01:00:00Z, +02:00 to +01:00: the repeated hour resolved by row order \
         ({first} rows in its first pass, {second} in its second)"
    );
    assert!(
        said.contains(&format!("clock change crossed: {change}")),
        "{said}"
    );
    let record = import_record(&d.join("local.mcap"));
    assert_eq!(record["time_zone"], "Europe/Zurich");
    assert_eq!(record["clock_changes"], change);
    // The same samples as the run written in UTC, an instant for an instant.
    let shifted: BTreeMap<_, Vec<_>> = sorted_samples(&d.join("night.mcap"))
        .into_iter()
        .map(|(k, v)| (k, v.into_iter().map(|(_, x)| x).collect()))
        .collect();
    let local: BTreeMap<_, Vec<_>> = sorted_samples(&d.join("local.mcap"))
        .into_iter()
        .map(|(k, v)| (k, v.into_iter().map(|(_, x)| x).collect()))
        .collect();
    assert!(shifted == local, "the samples differ");
    let truth = truth(d, "night.mcap");
    let local = time_constants(d, "local.mcap");
    eprintln!("truth {truth:?}\nlocal {:?} %", percent(&local, &truth));
    for p in percent(&local, &truth) {
        assert!(p.abs() < 1.0, "{local:?} against the truth {truth:?}");
    }
    // Read at a fixed offset, the second pass goes back in time: one line, exit 2.
    std::fs::write(d.join("fixed.toml"), map.replace("Europe/Zurich", "+02:00")).unwrap();
    let out = common::heatrun(
        &[
            "import",
            "night.csv",
            "--map",
            "fixed.toml",
            "--out",
            "fixed.mcap",
        ],
        d,
    );
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("time goes backwards"), "{err}");
    assert!(!d.join("fixed.mcap").exists());
}

#[test]
fn a_skipped_hour_is_an_error_only_where_a_row_falls_in_it() {
    let dir = common::tempdir();
    let d = dir.path();
    let map = "[time]\ncolumn = \"Zeit\"\nzone = \"Europe/Zurich\"\n[[column]]\ncolumn = \"T\"\nchannel = \"T\"\nunit = \"degC\"\n";
    std::fs::write(d.join("map.toml"), map).unwrap();
    // 2023-03-26: 02:00 +01:00 became 03:00 +02:00.
    std::fs::write(
        d.join("spring.csv"),
        "Zeit,T\n2023-03-26 01:59:59,20\n2023-03-26 03:00:00,21\n",
    )
    .unwrap();
    let out = heatrun_ok(
        &[
            "import",
            "spring.csv",
            "--map",
            "map.toml",
            "--out",
            "spring.mcap",
        ],
        d,
    );
    let said = String::from_utf8(out.stdout).unwrap();
    assert!(
        said.contains("clock change crossed: 2023-03-26T01:00:00Z, +01:00 to +02:00: the skipped hour holds no row"),
        "{said}"
    );
    assert!(said.contains("1.0 s from 2023-03-26T00:59:59Z"), "{said}");
    std::fs::write(
        d.join("gap.csv"),
        "Zeit,T\n2023-03-26 01:59:59,20\n2023-03-26 02:30:00,21\n",
    )
    .unwrap();
    let out = common::heatrun(
        &[
            "import", "gap.csv", "--map", "map.toml", "--out", "gap.mcap",
        ],
        d,
    );
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.lines().next().unwrap().contains("gap.csv: line 3, column 1 (`Zeit`): `2023-03-26 02:30:00` does not exist in Europe/Zurich"),
        "{err}"
    );
    assert!(!d.join("gap.mcap").exists());
}

/// A column of a Parquet file for the tests.
enum Column {
    /// Timestamps, ns, UTC-adjusted.
    Time(Vec<i64>),
    /// Local timestamps, ms: wall-clock times stored as if they were UTC.
    LocalTime(Vec<i64>),
    /// Doubles, `None` a null.
    Double(Vec<Option<f64>>),
    /// Strings, `None` a null.
    Text(Vec<Option<String>>),
    /// OPC quality codes.
    Code(Vec<i32>),
}

impl Column {
    fn schema(&self, name: &str) -> Type {
        let (physical, logical, repetition) = match self {
            Column::Time(_) => (
                Physical::INT64,
                Some(LogicalType::Timestamp {
                    is_adjusted_to_u_t_c: true,
                    unit: TimeUnit::NANOS,
                }),
                Repetition::REQUIRED,
            ),
            Column::LocalTime(_) => (
                Physical::INT64,
                Some(LogicalType::Timestamp {
                    is_adjusted_to_u_t_c: false,
                    unit: TimeUnit::MILLIS,
                }),
                Repetition::REQUIRED,
            ),
            Column::Double(_) => (Physical::DOUBLE, None, Repetition::OPTIONAL),
            Column::Text(_) => (
                Physical::BYTE_ARRAY,
                Some(LogicalType::String),
                Repetition::OPTIONAL,
            ),
            Column::Code(_) => (Physical::INT32, None, Repetition::REQUIRED),
        };
        Type::primitive_type_builder(name, physical)
            .with_repetition(repetition)
            .with_logical_type(logical)
            .build()
            .unwrap()
    }
}

/// Definition levels and the present values of an optional column's rows.
fn optional<T: Clone>(cells: &[Option<T>]) -> (Vec<i16>, Vec<T>) {
    let levels = cells.iter().map(|c| i16::from(c.is_some())).collect();
    (levels, cells.iter().flatten().cloned().collect())
}

/// Writes `columns` as a Parquet file in row groups of `group` rows.
fn write_parquet(
    path: &Path,
    columns: &[(String, Column)],
    compression: Compression,
    group: usize,
) {
    let fields = columns.iter().map(|(n, c)| Arc::new(c.schema(n))).collect();
    let schema = Arc::new(
        Type::group_type_builder("table")
            .with_fields(fields)
            .build()
            .unwrap(),
    );
    let props = Arc::new(
        WriterProperties::builder()
            .set_compression(compression)
            .build(),
    );
    let mut writer = SerializedFileWriter::new(File::create(path).unwrap(), schema, props).unwrap();
    let rows = match &columns[0].1 {
        Column::Time(v) | Column::LocalTime(v) => v.len(),
        Column::Text(v) => v.len(),
        _ => unreachable!(),
    };
    for start in (0..rows).step_by(group) {
        let range = start..(start + group).min(rows);
        let mut row_group = writer.next_row_group().unwrap();
        for (_, column) in columns {
            let mut w = row_group.next_column().unwrap().unwrap();
            match column {
                Column::Time(v) | Column::LocalTime(v) => {
                    w.typed::<Int64Type>()
                        .write_batch(&v[range.clone()], None, None)
                        .unwrap();
                }
                Column::Code(v) => {
                    w.typed::<Int32Type>()
                        .write_batch(&v[range.clone()], None, None)
                        .unwrap();
                }
                Column::Double(v) => {
                    let (levels, values) = optional(&v[range.clone()]);
                    w.typed::<DoubleType>()
                        .write_batch(&values, Some(&levels), None)
                        .unwrap();
                }
                Column::Text(v) => {
                    let (levels, values) = optional(&v[range.clone()]);
                    let values: Vec<ByteArray> =
                        values.iter().map(|s| ByteArray::from(s.as_str())).collect();
                    w.typed::<ByteArrayType>()
                        .write_batch(&values, Some(&levels), None)
                        .unwrap();
                }
            }
            w.close().unwrap();
        }
        row_group.close().unwrap();
    }
    writer.close().unwrap();
}

/// The wide text export's rows as Parquet columns: the time as a UTC timestamp, a
/// double per channel (null where the text is empty or "I/O Timeout"), the status as
/// a string (null where empty).
fn wide_parquet(table: &str, t0: u64) -> Vec<(String, Column)> {
    let mut lines = table.lines();
    let header: Vec<&str> = lines.next().unwrap().split(';').collect();
    let mut time = Vec::new();
    let mut values: Vec<Vec<Option<f64>>> = vec![Vec::new(); header.len() - 2];
    let mut status = Vec::new();
    for line in lines {
        let cells: Vec<&str> = line.split(';').collect();
        let (s, ns) = cells[0].split_once(',').unwrap();
        time.push((t0 + s.parse::<u64>().unwrap() * S + ns.parse::<u64>().unwrap()) as i64);
        for (j, v) in values.iter_mut().enumerate() {
            v.push(cells[j + 1].replace(',', ".").parse().ok());
        }
        let last = cells[header.len() - 1];
        status.push((!last.is_empty()).then(|| last.to_owned()));
    }
    let mut columns = vec![("Zeit".to_owned(), Column::Time(time))];
    for (name, v) in header[1..header.len() - 1].iter().zip(values) {
        columns.push(((*name).to_owned(), Column::Double(v)));
    }
    columns.push((header[header.len() - 1].to_owned(), Column::Text(status)));
    columns
}

/// The long rows as Parquet columns: tag, UTC timestamp, value (null when missing),
/// OPC quality code (0 bad, 192 good).
fn long_parquet(rows: &[LongRow], t0: u64) -> Vec<(String, Column)> {
    vec![
        (
            "Tag".to_owned(),
            Column::Text(rows.iter().map(|r| Some(tag(&r.quantity))).collect()),
        ),
        (
            "Zeitstempel".to_owned(),
            Column::Time(rows.iter().map(|r| (t0 + r.t) as i64).collect()),
        ),
        (
            "Wert".to_owned(),
            Column::Double(rows.iter().map(|r| r.value).collect()),
        ),
        (
            "Status".to_owned(),
            Column::Code(rows.iter().map(|r| if r.bad { 0 } else { 192 }).collect()),
        ),
    ]
}

/// A text map for Parquet: the time column is a timestamp, so no `format` or `start`.
fn parquet_map(map: &str) -> String {
    map.lines()
        .filter(|l| !l.starts_with("format = ") && !l.starts_with("start = "))
        .map(|l| format!("{l}\n"))
        .collect()
}

#[test]
fn parquet_tables_wide_and_long_import_as_the_text_export() {
    let dir = common::tempdir();
    let d = dir.path();
    synth(d, "stored.mcap", &FLAWS);
    let (wide, wide_map, t0) = historian_export(&d.join("stored.mcap"), Some(0.05), BAD_STATOR);
    std::fs::write(d.join("wide.csv"), &wide).unwrap();
    std::fs::write(d.join("wide.toml"), &wide_map).unwrap();
    import(d, "wide.csv", "wide.toml", "wide.mcap");
    let reference = sorted_samples(&d.join("wide.mcap"));

    // Wide, snappy (pyarrow's default), row groups of 4096 rows.
    write_parquet(
        &d.join("wide.parquet"),
        &wide_parquet(&wide, t0),
        Compression::SNAPPY,
        4096,
    );
    std::fs::write(d.join("wide_parquet.toml"), parquet_map(&wide_map)).unwrap();
    import(d, "wide.parquet", "wide_parquet.toml", "wide_parquet.mcap");
    assert!(
        sorted_samples(&d.join("wide_parquet.mcap")) == reference,
        "wide Parquet"
    );

    // Long, zstd (polars' default).
    let rows = long_rows(&d.join("stored.mcap"), BAD_STATOR);
    write_parquet(
        &d.join("long.parquet"),
        &long_parquet(&rows, t0),
        Compression::ZSTD(ZstdLevel::default()),
        10_000,
    );
    std::fs::write(
        d.join("long_parquet.toml"),
        parquet_map(&long_map(&wide_map)),
    )
    .unwrap();
    import(d, "long.parquet", "long_parquet.toml", "long_parquet.mcap");
    assert!(
        sorted_samples(&d.join("long_parquet.mcap")) == reference,
        "long Parquet"
    );

    // --guess reads Parquet too: the wide file's columns, the long file's tags.
    let guessed =
        |file: &str| String::from_utf8(heatrun_ok(&["import", "--guess", file], d).stdout).unwrap();
    let wide_guess = guessed("wide.parquet");
    assert!(
        wide_guess.contains("[time]\ncolumn = \"Zeit\"\nformat = \"timestamp\"\n")
            && wide_guess.contains("[[column]]\ncolumn = \"core_temp\""),
        "{wide_guess}"
    );
    let long_guess = guessed("long.parquet");
    let channels = rows
        .iter()
        .map(|r| &r.quantity)
        .collect::<std::collections::BTreeSet<_>>();
    assert!(
        long_guess.contains(
            "layout = \"long\"\n\n[long]\ntag = \"Tag\"\nvalue = \"Wert\"\nquality = \"Status\""
        ) && long_guess.contains(&format!("# {} tags", channels.len()))
            && long_guess.contains("tag = \"G1.core_temp\""),
        "{long_guess}"
    );

    // The replays agree as the samples do.
    let wide = time_constants(d, "wide.mcap");
    let long = time_constants(d, "long_parquet.mcap");
    for p in percent(&long, &wide) {
        assert!(p.abs() < 0.1, "{long:?} against {wide:?}");
    }

    // A damaged file: one line, exit 2, nothing written.
    let bytes = std::fs::read(d.join("long.parquet")).unwrap();
    std::fs::write(d.join("cut.parquet"), &bytes[..bytes.len() / 2]).unwrap();
    let out = common::heatrun(
        &[
            "import",
            "cut.parquet",
            "--map",
            "long_parquet.toml",
            "--out",
            "cut.mcap",
        ],
        d,
    );
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.starts_with("error: cut.parquet: not a Parquet file heatrun can read")
            || err.contains("cut.parquet: not a Parquet file heatrun can read"),
        "{err}"
    );
    assert!(!d.join("cut.mcap").exists());
}

#[test]
fn parquet_local_timestamps_cross_the_clock_change() {
    let dir = common::tempdir();
    let d = dir.path();
    // Wall-clock times of 2023-10-29 in Zurich, stored as local timestamps (ms):
    // 02:30 and 02:59 in the first pass, 02:10 in the second, then 03:00.
    // 03:00 on the wall is 01:00Z + 2 h as if UTC.
    let wall_ms = |h: i64, m: i64| (FALL_BACK_S as i64 + (h - 1) * 3600 + m * 60) * 1000;
    let times = vec![
        wall_ms(2, 30),
        wall_ms(2, 59),
        wall_ms(2, 10),
        wall_ms(3, 0),
    ];
    let columns = vec![
        ("Zeit".to_owned(), Column::LocalTime(times)),
        (
            "T".to_owned(),
            Column::Double(vec![Some(20.0), Some(21.0), None, Some(22.0)]),
        ),
    ];
    write_parquet(&d.join("local.parquet"), &columns, Compression::SNAPPY, 2);
    let map = "[time]\ncolumn = \"Zeit\"\nzone = \"Europe/Zurich\"\n[[column]]\ncolumn = \"T\"\nchannel = \"T\"\nunit = \"degC\"\n";
    std::fs::write(d.join("map.toml"), map).unwrap();
    let out = heatrun_ok(
        &[
            "import",
            "local.parquet",
            "--map",
            "map.toml",
            "--out",
            "local.mcap",
        ],
        d,
    );
    let said = String::from_utf8(out.stdout).unwrap();
    assert!(
        said.contains("+02:00 to +01:00: the repeated hour resolved by row order (2 rows in its first pass, 1 in its second)"),
        "{said}"
    );
    // 02:30 +02:00, 02:59 +02:00, (02:10 +01:00 missing), 03:00 +01:00.
    let got: Vec<u64> = samples(&d.join("local.mcap"))["/scada/T"]
        .iter()
        .map(|(t, _)| *t)
        .collect();
    let utc = |s: u64| s * S;
    assert_eq!(
        got,
        [
            utc(FALL_BACK_S - 1800),
            utc(FALL_BACK_S - 60),
            utc(FALL_BACK_S + 3600)
        ]
    );
}
