//! Tables the way historians also write them: the historian export of
//! [`crate::historian`] written as a long table (`Tag;Zeitstempel;Wert;Status`, sorted
//! by time and grouped by tag) and as Parquet (wide and long), each imported beside the
//! wide text export of the same run; and a night heat run in Europe/Zurich's wall-clock
//! time through the end of summer time (2023-10-29), replayed against its truth.

use crate::common;
use crate::historian::{historian_export, import, percent, samples, synth, time_constants, truth};

use std::collections::BTreeMap;
use std::path::Path;

use common::heatrun_ok;

pub(crate) const S: u64 = 1_000_000_000;

/// The flaws of the historian's export: storage by exception, "I/O Timeout" cells on
/// the current, a drifting inlet.
pub(crate) const FLAWS: [&str; 8] = [
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
pub(crate) const BAD_STATOR: usize = 12;

/// One stored sample of a long table: tag, time after the first sample (ns), value
/// (`None`: missing) and whether it is flagged bad.
pub(crate) struct LongRow {
    pub(crate) quantity: String,
    pub(crate) t: u64,
    pub(crate) value: Option<f64>,
    pub(crate) bad: bool,
}

/// The recording's samples as long rows, in time order (each channel's in its order),
/// with `bad_stator` of the stator winding's stored values flagged bad: the same ones
/// the wide export flags (spread evenly over its rows with a stator value).
pub(crate) fn long_rows(path: &Path, bad_stator: usize) -> Vec<LongRow> {
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

pub(crate) fn tag(quantity: &str) -> String {
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
pub(crate) fn long_map(wide_map: &str) -> String {
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
pub(crate) fn sorted_samples(path: &Path) -> BTreeMap<String, Vec<(u64, Option<f64>)>> {
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
        "tag = \"G1 Temp Statorwicklung [°C]\"\nquantity = \"stator_winding_temp\"   # EDIT: guessed from the name \"G1 Temp Statorwicklung [°C]\"; or channel = \"G1_Temp_Statorwicklung\"\nunit = \"degC\"",
        "tag = \"G1 Strom [kA]\"\nquantity = \"armature_current\"   # EDIT: guessed from the name \"G1 Strom [kA]\"; or channel = \"G1_Strom\"\nunit = \"kA\"",
        "quantity = \"cooling_water_flow\"   # EDIT: guessed from the name \"G1 Kühlwasser Durchfluss [l/s]\"; or channel = \"G1_Kuehlwasser_Durchfluss\"\nunit = \"l/s\"",
        "tag = \"G1 Spannung [kV]\"\nquantity = \"line_voltage\"   # EDIT: guessed from the name \"G1 Spannung [kV]\"; or channel = \"G1_Spannung\"\nunit = \"kV\"",
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
pub(crate) const FALL_BACK_S: u64 = 1_698_541_200;

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
    // An hour back is summer time's end: the hint names the zone.
    assert!(err.contains("give the map's [time] `zone`"), "{err}");
    assert!(!d.join("fixed.mcap").exists());
    // Five seconds back is rows out of order: the hint says to sort them.
    std::fs::write(
        d.join("shuffled.csv"),
        "Zeit,T\n2024-03-01 10:00:00,45.1\n2024-03-01 10:00:10,45.2\n2024-03-01 10:00:05,45.3\n",
    )
    .unwrap();
    std::fs::write(
        d.join("utc.toml"),
        "[time]\ncolumn = \"Zeit\"\nzone = \"UTC\"\n[[column]]\ncolumn = \"T\"\n\
         channel = \"T\"\nunit = \"degC\"\n",
    )
    .unwrap();
    let out = common::heatrun(
        &[
            "import",
            "shuffled.csv",
            "--map",
            "utc.toml",
            "--out",
            "s.mcap",
        ],
        d,
    );
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains(
            "; the rows are out of time order (5 s back): sort the table by its time column"
        ) && !err.contains("zone"),
        "{err}"
    );
    assert!(!d.join("s.mcap").exists());
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
