//! Parquet tables, wide and long, imported as the text export they hold (the `parquet`
//! feature: `cargo test --features parquet`; `.ci/run` runs them).

use std::fs::File;
use std::path::Path;
use std::sync::Arc;

use parquet::basic::{Compression, LogicalType, Repetition, TimeUnit, Type as Physical, ZstdLevel};
use parquet::data_type::{ByteArray, ByteArrayType, DoubleType, Int32Type, Int64Type};
use parquet::file::properties::WriterProperties;
use parquet::file::writer::SerializedFileWriter;
use parquet::schema::types::Type;

use crate::common::{self, heatrun_ok};
use crate::historian::{historian_export, import, percent, samples, synth, time_constants};
use crate::tables::{
    long_map, long_rows, sorted_samples, tag, LongRow, BAD_STATOR, FALL_BACK_S, FLAWS, S,
};

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
