//! `heatrun import`: each table format into a complete profile recording, the
//! guessed map, every bad input (exit 2, one line naming file, line and column, no
//! output, input untouched), the data sets' maps on slices of their files, and a
//! round trip of the shipped fixture through CSV that replays to the same estimate.

use crate::common;

use std::collections::BTreeMap;
use std::path::Path;

use common::{heatrun, heatrun_ok};
use serde_json::Value;

/// A channel of a written recording: metadata and (log time, message text) samples.
struct Channel {
    metadata: BTreeMap<String, String>,
    samples: Vec<(u64, String)>,
}

/// The channels of a recording by topic, in the order they appear, and its
/// metadata records by name.
struct Recording {
    topics: Vec<String>,
    channels: BTreeMap<String, Channel>,
    records: BTreeMap<String, BTreeMap<String, String>>,
    summary: mcap::Summary,
    profile: String,
}

fn read(path: &Path) -> Recording {
    let bytes = std::fs::read(path).unwrap();
    let summary = mcap::Summary::read(&bytes)
        .unwrap()
        .expect("a summary section");
    let mut topics = Vec::new();
    let mut channels: BTreeMap<String, Channel> = BTreeMap::new();
    for c in summary.channels.values() {
        channels.insert(
            c.topic.clone(),
            Channel {
                metadata: c.metadata.clone(),
                samples: Vec::new(),
            },
        );
    }
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        if !topics.contains(&m.channel.topic) {
            topics.push(m.channel.topic.clone());
        }
        channels
            .get_mut(&m.channel.topic)
            .unwrap()
            .samples
            .push((m.log_time, String::from_utf8(m.data.to_vec()).unwrap()));
    }
    let mut records = BTreeMap::new();
    let mut profile = String::new();
    for record in mcap::read::LinearReader::new(&bytes).unwrap() {
        match record.unwrap() {
            mcap::records::Record::Metadata(m) => {
                records.insert(m.name, m.metadata);
            }
            mcap::records::Record::Header(h) => profile = h.profile,
            _ => {}
        }
    }
    Recording {
        topics,
        channels,
        records,
        summary,
        profile,
    }
}

impl Recording {
    /// (time in ns, value) of a channel; `null` values are NaN.
    fn values(&self, topic: &str) -> Vec<(u64, f64)> {
        self.channels[topic]
            .samples
            .iter()
            .map(|(t, text)| {
                let v: Value = serde_json::from_str(text).unwrap();
                (*t, v["value"].as_f64().unwrap_or(f64::NAN))
            })
            .collect()
    }
}

/// Runs `heatrun import` in `dir`; asserts success and one summary line.
fn imports(dir: &Path, input: &str, map: &str, out: &str) -> String {
    let result = heatrun(&["import", input, "--map", map, "--out", out], dir);
    let stdout = String::from_utf8_lossy(&result.stdout).into_owned();
    assert!(
        result.status.success(),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );
    assert_eq!(stdout.trim_end().lines().count(), 1, "{stdout}");
    stdout
}

const S: u64 = 1_000_000_000;
/// 2024-03-01T09:00:00Z.
const T_2024: u64 = 1_709_283_600 * S;

#[test]
fn comma_with_header_and_rfc3339_times_keeps_spacing_and_skips_missing_cells() {
    // With the byte order mark of a spreadsheet export.
    let dir = common::tempdir();
    std::fs::write(
        dir.path().join("run.csv"),
        "\u{feff}timestamp,Winding (degC),Q1 [%]\n\
         2024-03-01T10:00:00+01:00,20.5,0\n\
         2024-03-01T10:00:01.5+01:00,20.625,50\n\
         2024-03-01T09:00:03Z,,50\n\
         2024-03-01T10:00:04+01:00,NaN,100\n\
         2024-03-01T10:00:10+01:00,21.0,\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("map.toml"),
        r#"
        [time]
        column = "timestamp"
        [[column]]
        column = "Winding (degC)"
        quantity = "stator_winding_temp"
        unit = "degC"
        [[column]]
        column = "Q1 [%]"
        channel = "Q1"
        unit = "%"
        [nameplate]
        rated_apparent_power_mva = 100
        [metadata."heatrun.test"]
        site = "lab"
        "#,
    )
    .unwrap();
    let summary = imports(dir.path(), "run.csv", "map.toml", "run.mcap");
    assert!(
        summary.contains("5 rows") && summary.contains("2 channels") && summary.contains("10.0 s"),
        "{summary}"
    );
    let r = read(&dir.path().join("run.mcap"));
    assert_eq!(r.profile, "heatrun-scada/1");
    // Missing cells are no samples, never zeros; the times are kept as written.
    assert_eq!(
        r.values("/scada/stator_winding_temp"),
        [
            (T_2024, 20.5),
            (T_2024 + 1_500_000_000, 20.625),
            (T_2024 + 10 * S, 21.0)
        ]
    );
    assert_eq!(
        r.values("/scada/Q1"),
        [
            (T_2024, 0.0),
            (T_2024 + 1_500_000_000, 50.0),
            (T_2024 + 3 * S, 50.0),
            (T_2024 + 4 * S, 100.0)
        ]
    );
    let meta = &r.channels["/scada/Q1"].metadata;
    assert_eq!(meta["quantity"], "Q1");
    assert_eq!(meta["unit"], "%");
    assert!(!meta.contains_key("storage"));
    assert_eq!(
        r.records["heatrun.nameplate"]["rated_apparent_power_mva"],
        "100"
    );
    assert_eq!(r.records["heatrun.test"]["site"], "lab");
    assert_eq!(r.records["heatrun.import"]["source"], "run.csv");
    // A complete file: zstd chunks with their indexes and statistics.
    assert!(!r.summary.chunk_indexes.is_empty());
    assert!(r
        .summary
        .chunk_indexes
        .iter()
        .all(|c| c.compression == "zstd"));
    assert_eq!(r.summary.stats.as_ref().unwrap().message_count, 7);
    // heatrun reads the profile channel back.
    let mut sink = CountingSink(0);
    let read = heatrun::recording::read_recording(&dir.path().join("run.mcap"), &mut sink).unwrap();
    assert_eq!(read.channels.len(), 1);
    assert_eq!(sink.0, 3);
}

struct CountingSink(u64);

impl heatrun::recording::SampleSink for CountingSink {
    fn channel(&mut self, _: &heatrun::recording::SensorChannel) {}
    fn sample(&mut self, _: heatrun::recording::Sample) {
        self.0 += 1;
    }
    fn retract(&mut self, _: heatrun::recording::Sample) {
        self.0 -= 1;
    }
}

#[test]
fn semicolon_with_decimal_commas_and_local_times_in_the_maps_zone() {
    let dir = common::tempdir();
    std::fs::write(
        dir.path().join("export.csv"),
        "Zeit;Kern\n01.03.2024 10:00:00;20,5\n  \n01.03.2024 10:00:30;20,75\n\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("map.toml"),
        r#"
        [time]
        column = "Zeit"
        pattern = "%d.%m.%Y %H:%M:%S"
        zone = "+01:00"
        [[column]]
        column = "Kern"
        quantity = "core_temp"
        unit = "degC"
        "#,
    )
    .unwrap();
    imports(dir.path(), "export.csv", "map.toml", "out.mcap");
    let r = read(&dir.path().join("out.mcap"));
    assert_eq!(
        r.values("/scada/core_temp"),
        [(T_2024, 20.5), (T_2024 + 30 * S, 20.75)]
    );
    // ISO 8601 without an offset, in the map's zone, and `;` guessed.
    std::fs::write(
        dir.path().join("iso.csv"),
        "time;T\n2024-03-01 11:00:00;1,5\n2024-03-01T11:00:01;2\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("iso.toml"),
        "[time]\ncolumn = \"time\"\nzone = \"+02:00\"\n[[column]]\ncolumn = \"T\"\nchannel = \"T\"\nunit = \"degC\"\n",
    )
    .unwrap();
    imports(dir.path(), "iso.csv", "iso.toml", "iso.mcap");
    assert_eq!(
        read(&dir.path().join("iso.mcap")).values("/scada/T"),
        [(T_2024, 1.5), (T_2024 + S, 2.0)]
    );
}

#[test]
fn tab_separated_with_quality_flags_and_storage_by_exception() {
    let dir = common::tempdir();
    std::fs::write(
        dir.path().join("hist.tsv"),
        "t\tstator\tstator status\tflow\n\
         0\t40.0\tgood\t12.5\n\
         1.5\t40.2\tSUSP\t\n\
         600\t40.1\t0\t12.0\n\
         700\t40.4\t192\t12.1\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("map.toml"),
        r#"
        [time]
        column = "t"
        start = "2024-03-01T09:00:00Z"
        [[column]]
        column = "stator"
        quantity = "stator_winding_temp"
        unit = "degC"
        sensor = "rtd1"
        quality_column = "stator status"
        quality_values = { SUSP = "uncertain" }
        storage = "exception"
        deadband = 0.1
        max_interval_s = 600
        [[column]]
        column = 4
        quantity = "cooling_water_flow"
        unit = "l/s"
        "#,
    )
    .unwrap();
    imports(dir.path(), "hist.tsv", "map.toml", "out.mcap");
    let r = read(&dir.path().join("out.mcap"));
    let stator = &r.channels["/scada/stator_winding_temp/rtd1"];
    assert_eq!(stator.metadata["sensor"], "rtd1");
    assert_eq!(stator.metadata["storage"], "exception");
    assert_eq!(stator.metadata["deadband"], "0.1");
    assert_eq!(stator.metadata["max_interval_s"], "600");
    let texts: Vec<&str> = stator.samples.iter().map(|s| s.1.as_str()).collect();
    assert_eq!(
        texts,
        [
            r#"{"value":40}"#,
            r#"{"value":40.2,"quality":"uncertain"}"#,
            r#"{"value":40.1,"quality":"bad"}"#,
            r#"{"value":40.4}"#
        ]
    );
    assert_eq!(stator.samples[1].0, T_2024 + 1_500_000_000);
    assert_eq!(
        r.values("/scada/cooling_water_flow"),
        [
            (T_2024, 12.5),
            (T_2024 + 600 * S, 12.0),
            (T_2024 + 700 * S, 12.1)
        ]
    );
}

#[test]
fn whitespace_dat_without_header_with_a_sample_time() {
    let dir = common::tempdir();
    // DaISy layout: leading spaces, several spaces between fields, CRLF, a blank line.
    std::fs::write(
        dir.path().join("run.dat"),
        "   9.000  129.320\r\n   9.000  nan\r\n\r\n   6.000  129.564\r\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("map.toml"),
        "[time]\nsample_time_s = 2.0\nstart = \"2024-03-01T09:00:00Z\"\n\
         [[column]]\ncolumn = 1\nchannel = \"u\"\nunit = \"V\"\n\
         [[column]]\ncolumn = 2\nchannel = \"y\"\nunit = \"degC\"\n",
    )
    .unwrap();
    let summary = imports(dir.path(), "run.dat", "map.toml", "run.mcap");
    assert!(
        summary.contains("3 rows") && summary.contains("1 missing"),
        "{summary}"
    );
    let r = read(&dir.path().join("run.mcap"));
    assert_eq!(
        r.values("/scada/u"),
        [(T_2024, 9.0), (T_2024 + 2 * S, 9.0), (T_2024 + 4 * S, 6.0)]
    );
    assert_eq!(
        r.values("/scada/y"),
        [(T_2024, 129.32), (T_2024 + 4 * S, 129.564)]
    );
}

/// The first lines of each data set's file, as they are (`datasets/`; the DaISy files fetched by `scripts/fetch-datasets`).
const TCLAB_ESTIMATION: &str = "Time (sec), Heater 1 (%), Heater 2 (%), Temperature 1 (degC), Temperature 2 (degC), Set Point 1 (degC), Set Point 2 (degC)\n\
0.000000000000000000e+00,0.000000000000000000e+00,0.000000000000000000e+00,2.082999999999999829e+01,1.992999999999999972e+01,2.300000000000000000e+01,2.300000000000000000e+01\n\
1.001284599304199219e+00,0.000000000000000000e+00,0.000000000000000000e+00,2.080000000000000071e+01,1.996000000000000085e+01,2.300000000000000000e+01,2.300000000000000000e+01\n";
const TCLAB_VALIDATION: &str = "Time (sec), Heater 1, Heater 2, Temperature 1, Temperature 2\n\
0.000000000000000000e+00,7.020457251197791493e+01,0.000000000000000000e+00,2.108999999999999986e+01,1.971000000000000085e+01\n\
3.002565622329711914e+00,7.020457251197791493e+01,0.000000000000000000e+00,2.105999999999999872e+01,1.973999999999999844e+01\n";
const DAISY_HEATING: &str =
    "   0.00   9.000  129.320\r\n   2.00   9.000  129.320\r\n   4.00   9.000  129.564\r\n";
const DAISY_GLASSFURNACE: &str = "   1.0000000e+00\t  -1.4468000e-01\t   7.7596000e-02\t  -9.8246000e-02\t   5.4008000e-02\t  -1.3230000e-01\t  -1.2960000e-01\t  -1.5554000e-01\t  -9.9894000e-02\t  -2.4695000e-02\t\n   2.0000000e+00\t   9.4048000e-01\t  -1.1231000e+00\t  -1.0854000e+00\t  -3.7277000e-01\t  -2.7135000e-01\t  -2.6489000e-01\t  -7.4327000e-01\t  -1.8784000e-01\t  -1.8057000e-01\t\n";
const PMSM: &str = "ambient,coolant,u_d,u_q,motor_speed,torque,i_d,i_q,pm,stator_yoke,stator_tooth,stator_winding\n\
-0.75214297,-1.1184461,0.3279352,-1.2978575,-1.2224282,-0.2501821,1.0295724,-0.24586003,-2.522071,-1.8314217,-2.0661428,-2.0180326\n\
-0.77126324,-1.1170206,0.3296648,-1.2976865,-1.2224293,-0.2491333,1.029509,-0.24583231,-2.5224178,-1.8309687,-2.0648587,-2.0176313\n";

/// A data set's map on a slice of its file: (data set folder, file name, the slice,
/// (channel, unit, samples) expected, the last row's time in ns).
type SliceCase = (
    &'static str,
    &'static str,
    &'static str,
    &'static [(&'static str, &'static str, usize)],
    u64,
);

#[test]
fn the_data_sets_maps_read_slices_of_their_files() {
    let dir = common::tempdir();
    let examples = common::package_root().join("examples");
    let cases: [SliceCase; 5] = [
        (
            "tclab_mimo_heaters",
            "tclab_mimo_data.csv",
            TCLAB_ESTIMATION,
            &[
                ("Q1", "%", 2),
                ("Q2", "%", 2),
                ("T1", "degC", 2),
                ("T2", "degC", 2),
            ],
            1_001_284_599,
        ),
        (
            "tclab_mimo_heaters",
            "tclab_mimo_step_data_3s.csv",
            TCLAB_VALIDATION,
            &[("Q1", "%", 2), ("T2", "degC", 2)],
            3_002_565_622,
        ),
        (
            "daisy_heating_system",
            "heating_system.dat",
            DAISY_HEATING,
            &[("u", "V", 3), ("y", "degC", 3)],
            4 * S,
        ),
        (
            "daisy_glassfurnace",
            "glassfurnace.dat",
            DAISY_GLASSFURNACE,
            &[
                ("u1", "1", 2),
                ("u3", "1", 2),
                ("y1", "1", 2),
                ("y6", "1", 2),
            ],
            S,
        ),
        (
            "pmsm_motor_temperature_slice",
            "pmsm_temperature_data_red.csv",
            PMSM,
            &[
                ("ambient", "1", 2),
                ("i_q", "1", 2),
                ("stator_winding", "1", 2),
            ],
            S / 2,
        ),
    ];
    for (folder, file, text, expected, last_ns) in cases {
        std::fs::write(dir.path().join(file), text).unwrap();
        let map = examples.join(folder).join("map.toml");
        let out = format!("{file}.mcap");
        imports(dir.path(), file, map.to_str().unwrap(), &out);
        let r = read(&dir.path().join(&out));
        for (name, unit, samples) in expected {
            let topic = format!("/scada/{name}");
            let c = &r.channels[&topic];
            assert_eq!(c.metadata["unit"], *unit, "{folder} {name}");
            assert_eq!(c.samples.len(), *samples, "{folder} {name}");
            assert_eq!(c.samples.last().unwrap().0, last_ns, "{folder} {name}");
        }
    }
    // Values as written: the glass furnace's first y6, the TCLab %.18e temperatures.
    let glass = read(&dir.path().join("glassfurnace.dat.mcap"));
    assert_eq!(glass.values("/scada/y6")[0], (0, -2.4695e-2));
    assert_eq!(glass.topics.len(), 9, "k is skipped");
    let tclab = read(&dir.path().join("tclab_mimo_data.csv.mcap"));
    assert_eq!(tclab.values("/scada/T1")[0].1, 20.83);
    assert_eq!(tclab.topics.len(), 4, "the set points are skipped");
}

#[test]
fn guess_prints_a_map_with_units_from_the_header_that_imports() {
    let dir = common::tempdir();
    std::fs::write(
        dir.path().join("lab.csv"),
        "Time (sec),T1 (degC),Q1 [%],Flow\n0,20.1,0,1\n1,20.2,50,1\n2,20.4,50,1\n",
    )
    .unwrap();
    let out = heatrun(&["import", "--guess", "lab.csv"], dir.path());
    assert!(out.status.success());
    let map = String::from_utf8(out.stdout).unwrap();
    for line in [
        "delimiter = \",\"",
        "header = true",
        "column = \"Time (sec)\"",
        "format = \"seconds\"",
        "column = \"T1 (degC)\"\nchannel = \"T1\"\nunit = \"degC\"",
        "column = \"Q1 [%]\"\nchannel = \"Q1\"\nunit = \"%\"",
        "channel = \"Flow\"\nunit = \"1\"   # EDIT",
    ] {
        assert!(map.contains(line), "{line:?} not in\n{map}");
    }
    assert!(
        dir.path().read_dir().unwrap().count() == 1,
        "--guess writes nothing"
    );
    std::fs::write(dir.path().join("map.toml"), &map).unwrap();
    imports(dir.path(), "lab.csv", "map.toml", "lab.mcap");
    let r = read(&dir.path().join("lab.mcap"));
    assert_eq!(r.values("/scada/Q1"), [(0, 0.0), (S, 50.0), (2 * S, 50.0)]);

    // Timestamps without an offset: the guess asks for a zone.
    std::fs::write(
        dir.path().join("hist.csv"),
        "Date;Core\n2024-03-01 10:00:00;20,5\n",
    )
    .unwrap();
    let out = heatrun(&["import", "--guess", "hist.csv"], dir.path());
    let map = String::from_utf8(out.stdout).unwrap();
    assert!(
        map.contains("delimiter = \";\"")
            && map.contains("decimal_comma = true")
            && map.contains("format = \"timestamp\"")
            && map.contains("zone = \"UTC\"   # EDIT"),
        "{map}"
    );
}

/// Runs an import that must fail with status 2; returns its one-line message.
fn fails_with_2(dir: &Path, input: &str, map: &str) -> String {
    let before = std::fs::read(dir.join(input)).unwrap();
    let out = heatrun(&["import", input, "--map", map, "--out", "out.mcap"], dir);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "stderr: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "one line: {stderr}");
    assert!(!dir.join("out.mcap").exists(), "no output on failure");
    assert_eq!(
        std::fs::read(dir.join(input)).unwrap(),
        before,
        "input unchanged"
    );
    for f in common::files_in(dir) {
        assert!(
            !f.to_string_lossy().contains("partial"),
            "{f:?} left behind"
        );
    }
    stderr
}

const GOOD_MAP: &str = "[time]\ncolumn = \"time\"\n[[column]]\ncolumn = \"T1\"\nchannel = \"T1\"\nunit = \"degC\"\n[[column]]\ncolumn = \"Q1\"\nchannel = \"Q1\"\nunit = \"%\"\n";

#[test]
fn bad_tables_stop_with_one_line_naming_file_line_and_column() {
    let dir = common::tempdir();
    std::fs::write(dir.path().join("map.toml"), GOOD_MAP).unwrap();
    let cases = [
        (
            "ragged.csv",
            "time,T1,Q1\n0,20,0\n1,21\n2,22,0\n",
            &["ragged.csv", "line 3", "2 fields", "line 1 has 3"][..],
        ),
        (
            "cell.csv",
            "time,T1,Q1\n0,20,0\n1,21,0\n2,2O.5,0\n",
            &["cell.csv", "line 4", "column 2 (`T1`)", "`2O.5`"],
        ),
        (
            "stamp.csv",
            "time,T1,Q1\n2024-03-01T10:00:00Z,20,0\n2024-03-01T25:00:00Z,21,0\n",
            &[
                "stamp.csv",
                "line 3",
                "column 1 (`time`)",
                "2024-03-01T25:00:00Z",
            ],
        ),
        (
            "backwards.csv",
            "time,T1,Q1\n0,20,0\n10,21,0\n5,22,0\n",
            &[
                "backwards.csv",
                "line 4",
                "column 1 (`time`)",
                "backwards",
                "00:00:10Z",
            ],
        ),
        (
            "absent.csv",
            "time,T1,Q2\n0,20,0\n",
            &["absent.csv", "line 1", "`Q1`", "map.toml", "`Q2`"],
        ),
        (
            "zone.csv",
            "time,T1,Q1\n2024-03-01T10:00:00,20,0\n",
            &["zone.csv", "line 2", "column 1 (`time`)", "zone"],
        ),
    ];
    for (file, text, expected) in cases {
        std::fs::write(dir.path().join(file), text).unwrap();
        let msg = fails_with_2(dir.path(), file, "map.toml");
        for e in expected {
            assert!(msg.contains(e), "{e:?} not in {msg}");
        }
    }
}

#[test]
fn bad_maps_stop_with_one_line_naming_the_key_or_column() {
    let dir = common::tempdir();
    std::fs::write(dir.path().join("run.dat"), "0 20 1\n1 21 1\n").unwrap();
    let cases = [
        (
            "position.toml",
            "[time]\ncolumn = 1\n[[column]]\ncolumn = 4\nchannel = \"T\"\nunit = \"degC\"\n",
            &["run.dat", "line 1", "no column 4", "1 to 3"][..],
        ),
        (
            "name.toml",
            "[time]\ncolumn = 1\n[[column]]\ncolumn = \"T1\"\nchannel = \"T\"\nunit = \"degC\"\n",
            &["name.toml", "`T1`", "no header line"],
        ),
        (
            "typo.toml",
            "[time]\ncolumn = 1\n[[column]]\ncolumn = 2\nchanel = \"T\"\nunit = \"degC\"\n",
            &["typo.toml", "line 5", "chanel"],
        ),
        (
            "unit.toml",
            "[time]\ncolumn = 1\n[[column]]\ncolumn = 2\nquantity = \"armature_current\"\nunit = \"MA\"\n",
            &["unit.toml", "[[column]] 2.unit", "`MA`", "A, kA"],
        ),
    ];
    for (map, text, expected) in cases {
        std::fs::write(dir.path().join(map), text).unwrap();
        let msg = fails_with_2(dir.path(), "run.dat", map);
        for e in expected {
            assert!(msg.contains(e), "{e:?} not in {msg}");
        }
    }
    std::fs::write(
        dir.path().join("ok.toml"),
        "[time]\ncolumn = 1\n[[column]]\ncolumn = 2\nchannel = \"T\"\nunit = \"degC\"\n",
    )
    .unwrap();
    // A table that is not there.
    let out = heatrun(
        &[
            "import",
            "nothere.dat",
            "--map",
            "ok.toml",
            "--out",
            "out.mcap",
        ],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    assert!(stderr.contains("nothere.dat: cannot read"), "{stderr}");
    assert!(!dir.path().join("out.mcap").exists());
    // An output that would replace the input.
    let out = heatrun(
        &["import", "run.dat", "--map", "ok.toml", "--out", "run.dat"],
        dir.path(),
    );
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(
        std::fs::read_to_string(dir.path().join("run.dat")).unwrap(),
        "0 20 1\n1 21 1\n"
    );
}

/// The fixture as a CSV table: one row per distinct time (seconds after the first,
/// exact decimals), one column per channel with its values as the messages write
/// them, empty where a channel has no sample at that time; and a map for it.
fn fixture_as_csv(fixture: &Recording, dir: &Path) {
    let t0 = fixture
        .channels
        .values()
        .map(|c| c.samples[0].0)
        .min()
        .unwrap();
    let mut rows: BTreeMap<u64, Vec<String>> = BTreeMap::new();
    let n = fixture.topics.len();
    for (j, topic) in fixture.topics.iter().enumerate() {
        for (t, text) in &fixture.channels[topic].samples {
            // The number as the message writes it: {"value":<number>}.
            let number = text
                .strip_prefix("{\"value\":")
                .and_then(|s| s.strip_suffix('}'))
                .unwrap();
            rows.entry(*t).or_insert_with(|| vec![String::new(); n])[j] = number.to_owned();
        }
    }
    let quantity = |topic: &str| fixture.channels[topic].metadata["quantity"].clone();
    let mut csv = format!(
        "time_s,{}\n",
        fixture
            .topics
            .iter()
            .map(|t| quantity(t))
            .collect::<Vec<_>>()
            .join(",")
    );
    for (t, cells) in rows {
        let d = t - t0;
        csv.push_str(&format!("{}.{:09},{}\n", d / S, d % S, cells.join(",")));
    }
    std::fs::write(dir.join("fixture.csv"), csv).unwrap();

    let start = heatrun::recording::format_time(t0);
    let mut map = format!("[time]\ncolumn = \"time_s\"\nstart = \"{start}\"\n");
    for topic in &fixture.topics {
        let q = quantity(topic);
        let unit = &fixture.channels[topic].metadata["unit"];
        map.push_str(&format!(
            "[[column]]\ncolumn = \"{q}\"\nquantity = \"{q}\"\nunit = \"{unit}\"\n"
        ));
    }
    for (name, record) in &fixture.records {
        let table = if name == "heatrun.nameplate" {
            "[nameplate]".to_owned()
        } else {
            format!("[metadata.\"{name}\"]")
        };
        map.push_str(&format!("{table}\n"));
        for (k, v) in record {
            map.push_str(&format!("{k} = \"{v}\"\n"));
        }
    }
    std::fs::write(dir.join("fixture.toml"), map).unwrap();
}

#[test]
fn the_fixture_through_csv_replays_to_the_same_estimate() {
    let dir = common::tempdir();
    let fixture_path = common::package_root().join("fixtures/paper_heat_run.mcap");
    let fixture = read(&fixture_path);
    fixture_as_csv(&fixture, dir.path());
    imports(dir.path(), "fixture.csv", "fixture.toml", "imported.mcap");

    // The same messages, channel by channel.
    let imported = read(&dir.path().join("imported.mcap"));
    assert_eq!(imported.topics, fixture.topics);
    for topic in &fixture.topics {
        assert_eq!(
            imported.channels[topic].samples, fixture.channels[topic].samples,
            "{topic}"
        );
        assert_eq!(
            imported.channels[topic].metadata,
            fixture.channels[topic].metadata
        );
    }

    let report = |mcap: &Path, name: &str| -> Value {
        heatrun_ok(
            &[
                "replay",
                mcap.to_str().unwrap(),
                "--report",
                &format!("{name}.json"),
                "--rrd",
                &format!("{name}.rrd"),
                "--quiet",
            ],
            dir.path(),
        );
        serde_json::from_str(
            &std::fs::read_to_string(dir.path().join(format!("{name}.json"))).unwrap(),
        )
        .unwrap()
    };
    let a = report(&fixture_path, "fixture");
    let b = report(&dir.path().join("imported.mcap"), "imported");
    let mut compared = 0;
    for key in ["phi", "gamma", "time_constants_s", "steady_state"] {
        compared += assert_close(&a[key], &b[key], key);
    }
    assert!(compared >= 9 + 9 + 3 + 9, "{compared} numbers compared");
}

/// Asserts two JSON values hold the same numbers to 1e-9 relative; returns how many.
fn assert_close(a: &Value, b: &Value, path: &str) -> usize {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => {
            let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            assert!(
                (x - y).abs() <= 1e-9 * x.abs().max(1e-12),
                "{path}: {x} vs {y}"
            );
            1
        }
        (Value::Array(x), Value::Array(y)) => {
            assert_eq!(x.len(), y.len(), "{path}");
            x.iter()
                .zip(y)
                .enumerate()
                .map(|(i, (x, y))| assert_close(x, y, &format!("{path}[{i}]")))
                .sum()
        }
        (Value::Object(x), Value::Object(y)) => {
            assert_eq!(
                x.keys().collect::<Vec<_>>(),
                y.keys().collect::<Vec<_>>(),
                "{path}"
            );
            x.iter()
                .map(|(k, v)| assert_close(v, &y[k], &format!("{path}.{k}")))
                .sum()
        }
        _ => {
            assert_eq!(a, b, "{path}");
            0
        }
    }
}
