//! Bad input ends with one line naming the file, channel or key, exit status 2,
//! no panic, no partial output, and the input untouched.

use crate::common;

use std::path::Path;

use common::{heatrun, heatrun_ok, RecordingBuilder};

/// Runs a replay that must fail with status 2; returns its one-line message.
fn fails_with_2(dir: &Path, file: &str) -> String {
    let before = std::fs::read(dir.join(file)).ok();
    let out = heatrun(
        &["replay", file, "--rrd", "out.rrd", "--report", "out.json"],
        dir,
    );
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "stderr: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "one line: {stderr}");
    assert!(stderr.contains(file), "names the file: {stderr}");
    assert!(
        !dir.join("out.rrd").exists() && !dir.join("out.json").exists(),
        "no output on failure"
    );
    assert_eq!(
        std::fs::read(dir.join(file)).ok(),
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

#[test]
fn a_file_that_is_not_mcap() {
    let dir = common::tempdir();
    std::fs::write(dir.path().join("notes.mcap"), "time,value\n1,2\n").unwrap();
    let msg = fails_with_2(dir.path(), "notes.mcap");
    assert!(msg.contains("not an MCAP file"), "{msg}");
}

#[test]
fn an_empty_file() {
    let dir = common::tempdir();
    std::fs::write(dir.path().join("empty.mcap"), "").unwrap();
    let msg = fails_with_2(dir.path(), "empty.mcap");
    assert!(msg.contains("empty"), "{msg}");
}

#[test]
fn a_missing_file() {
    let dir = common::tempdir();
    let out = heatrun(&["replay", "nowhere.mcap"], dir.path());
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("nowhere.mcap"));
    // The cause is said once, not again after the message that already holds it.
    let cause = std::io::Error::from(std::io::ErrorKind::NotFound).to_string();
    assert_eq!(stderr.matches("cannot read").count(), 1, "{stderr}");
    assert!(stderr.matches(&cause).count() <= 1, "{stderr}");
}

#[test]
fn a_missing_required_quantity_is_named() {
    let dir = common::tempdir();
    RecordingBuilder::heat_run(3000.0, "core_temp").write(&dir.path().join("r.mcap"));
    let msg = fails_with_2(dir.path(), "r.mcap");
    assert!(msg.contains("core_temp"), "{msg}");
}

#[test]
fn an_unknown_unit_names_the_channel() {
    let dir = common::tempdir();
    let mut r = RecordingBuilder::heat_run(3000.0, "line_voltage");
    r = r.channel("line_voltage", "MV", 1.0, 3000.0, |_| 0.0156);
    r.write(&dir.path().join("r.mcap"));
    let msg = fails_with_2(dir.path(), "r.mcap");
    assert!(
        msg.contains("/scada/line_voltage") && msg.contains("`MV`"),
        "{msg}"
    );
}

#[test]
fn a_missing_nameplate_value_names_the_key() {
    let dir = common::tempdir();
    let mut r = RecordingBuilder::heat_run(3000.0, "");
    r.nameplate.as_mut().unwrap().remove("rated_voltage_kv");
    r.write(&dir.path().join("r.mcap"));
    let msg = fails_with_2(dir.path(), "r.mcap");
    // The library names the key and the remedy; the CLI edge adds its option's name.
    assert!(
        msg.contains("rated_voltage_kv") && msg.contains("machine file"),
        "{msg}"
    );
}

#[test]
fn a_missing_nameplate_value_can_come_from_a_machine_file() {
    let dir = common::tempdir();
    let mut r = RecordingBuilder::heat_run(3000.0, "");
    r.nameplate.as_mut().unwrap().remove("rated_voltage_kv");
    r.write(&dir.path().join("r.mcap"));
    std::fs::write(dir.path().join("m.toml"), "rated_voltage_kv = 15.65\n").unwrap();
    heatrun_ok(
        &[
            "replay",
            "r.mcap",
            "--machine",
            "m.toml",
            "--rrd",
            "o.rrd",
            "--quiet",
        ],
        dir.path(),
    );
}

#[test]
fn a_message_that_is_not_a_sample_names_channel_and_time() {
    let dir = common::tempdir();
    let mut r = RecordingBuilder::heat_run(3000.0, "");
    r.channels[0].2[100].1 = "{\"val\": 3}".into();
    r.write(&dir.path().join("r.mcap"));
    let msg = fails_with_2(dir.path(), "r.mcap");
    assert!(
        msg.contains("/scada/armature_current") && msg.contains("2020-09-13T12:28:20Z"),
        "{msg}"
    );
}

#[test]
fn a_wrong_schema_names_the_channel() {
    let dir = common::tempdir();
    let mut r = RecordingBuilder::heat_run(3000.0, "");
    r.schema_name = "foxglove.Temperature".into();
    r.write(&dir.path().join("r.mcap"));
    let msg = fails_with_2(dir.path(), "r.mcap");
    assert!(msg.contains("foxglove.Temperature"), "{msg}");
}

#[test]
fn constant_inputs_are_not_persistently_exciting() {
    let dir = common::tempdir();
    let mut r = RecordingBuilder::new();
    let rise = |t: f64, tau: f64, k: f64| k * (1.0 - (-t / tau).exp());
    r = r
        .channel("armature_current", "A", 1.0, 3000.0, |_| 3000.0)
        .channel("field_current", "A", 1.0, 3000.0, |_| 1000.0)
        .channel("line_voltage", "V", 1.0, 3000.0, |_| 15650.0)
        .channel("field_voltage", "V", 1.0, 3000.0, |_| 150.0)
        .channel("stator_winding_temp", "degC", 1.0, 3000.0, move |t| {
            30.0 + rise(t, 700.0, 25.0)
        })
        .channel("core_temp", "degC", 1.0, 3000.0, move |t| {
            30.0 + rise(t, 3000.0, 17.0)
        })
        .channel("cooling_water_outlet_temp", "degC", 1.0, 3000.0, move |t| {
            10.0 + rise(t, 30.0, 3.0)
        });
    r.write(&dir.path().join("r.mcap"));
    let msg = fails_with_2(dir.path(), "r.mcap");
    assert!(
        msg.contains("are both constant") && msg.contains("replay a heat run with load steps"),
        "{msg}"
    );
}

/// What the MCAP conformance suite's `OneMessage` case holds: one schema, one channel
/// (`example`, not a heat-run channel) and one message, written in `options`' layout.
fn one_message(path: &Path, options: mcap::WriteOptions) {
    let file = std::fs::File::create(path).unwrap();
    let mut w = options.create(std::io::BufWriter::new(file)).unwrap();
    let schema = w.add_schema("Example", "c", &[4, 5, 6]).unwrap();
    let meta = [("foo".to_owned(), "bar".to_owned())].into();
    let channel = w.add_channel(schema, "example", "a", &meta).unwrap();
    let header = mcap::records::MessageHeader {
        channel_id: channel,
        sequence: 10,
        log_time: 2,
        publish_time: 1,
    };
    w.write_to_known_channel(&header, &[1, 2, 3]).unwrap();
    w.finish().unwrap();
}

#[test]
fn conformance_cases_hold_no_heat_run() {
    // The conformance suite's layouts of its one-message file, made here rather than read
    // from a checkout that may hold Git LFS pointers or be absent.
    let layouts: Vec<(&str, mcap::WriteOptions)> = vec![
        ("chunked", mcap::WriteOptions::new()),
        ("unchunked", mcap::WriteOptions::new().use_chunks(false)),
        (
            "lz4",
            mcap::WriteOptions::new().compression(Some(mcap::Compression::Lz4)),
        ),
        (
            "no-summary",
            mcap::WriteOptions::new()
                .emit_summary_records(false)
                .emit_summary_offsets(false)
                .emit_statistics(false)
                .emit_chunk_indexes(false)
                .emit_message_indexes(false),
        ),
    ];
    for (name, options) in layouts {
        let dir = common::tempdir();
        one_message(&dir.path().join("c.mcap"), options);
        let msg = fails_with_2(dir.path(), "c.mcap");
        assert!(
            msg.contains("holds no heat-run data") && msg.contains("example"),
            "{name}: {msg}"
        );
    }
}

#[test]
fn a_git_lfs_pointer_is_named_as_such() {
    // What a clone without `git lfs pull` holds in place of a recording.
    let dir = common::tempdir();
    std::fs::write(
        dir.path().join("c.mcap"),
        "version https://git-lfs.github.com/spec/v1\n\
         oid sha256:4d7a214614ab2935c943f9e0ff69d22eadbb8f32b1258daaa5e2ca24d17e2393\n\
         size 12345\n",
    )
    .unwrap();
    let msg = fails_with_2(dir.path(), "c.mcap");
    assert!(msg.contains("Git LFS pointer"), "{msg}");
    let info = heatrun(&["info", "c.mcap"], dir.path());
    assert_eq!(info.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&info.stderr).contains("Git LFS pointer"));
}

#[test]
fn synth_refuses_disturbances_the_paper_model_cannot_take() {
    let dir = common::tempdir();
    for (args, flag) in [
        (&["--inlet-drift", "3"][..], "--inlet-drift"),
        (&["--start-above", "25"], "--start-above"),
        (&["--pump-switch", "7200:0.7"], "--pump-switch"),
        (
            &["--fault-at", "9000", "--fault-conductance-drop", "0.3"],
            "--fault-at",
        ),
    ] {
        let out = heatrun(&[&["synth", "out.mcap"][..], args].concat(), dir.path());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert_eq!(stderr.trim_end().lines().count(), 1, "one line: {stderr}");
        assert!(
            stderr.contains(flag) && stderr.contains("--machine rc-unit"),
            "{stderr}"
        );
        assert!(common::files_in(dir.path()).is_empty(), "no output");
    }
    let out = heatrun(
        &[
            "synth",
            "out.mcap",
            "--machine",
            "rc-field",
            "--field",
            "nameplate",
        ],
        dir.path(),
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--field voltage"));
    assert!(common::files_in(dir.path()).is_empty(), "no output");
    // A run too long to simulate in memory is refused before anything is allocated (a
    // duration of 1e9 s asked for 32 GB and aborted).
    let too_long = one_line_exit_2(&["synth", "out.mcap", "--duration", "1e9"], dir.path());
    assert!(
        too_long.contains("1000000000 steps of the plant's 1 s")
            && too_long.contains("; give a shorter --duration"),
        "{too_long}"
    );
    assert!(common::files_in(dir.path()).is_empty(), "no output");
    // A negative number reaches the command's own check (not clap's "unexpected argument").
    let negative = one_line_exit_2(
        &["synth", "out.mcap", "--temperature-noise", "-1"],
        dir.path(),
    );
    assert!(
        negative.contains("the temperature noise σ must be a number ≥ 0 (0: none), not -1"),
        "{negative}"
    );
    assert!(common::files_in(dir.path()).is_empty(), "no output");
}

/// Runs a command that must fail with status 2 in one line; returns the line.
fn one_line_exit_2(args: &[&str], dir: &Path) -> String {
    let out = heatrun(args, dir);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "heatrun {args:?}: {stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "one line: {stderr}");
    stderr
}

/// `predict` of `model.json` under the schedule `text` written to `name`: refused in one
/// line with exit 2, no prediction written; returns the line.
fn predict_refused(dir: &Path, name: &str, text: &str) -> String {
    std::fs::write(dir.join(name), text).unwrap();
    let line = one_line_exit_2(
        &[
            "predict",
            "--model",
            "model.json",
            "--load",
            name,
            "--out",
            "p.csv",
        ],
        dir,
    );
    assert!(!dir.join("p.csv").exists(), "{line}");
    line
}

/// The errors a user mends from the command line say how: the flag, file or command,
/// after what is wrong and where.
#[test]
fn errors_say_what_to_do_next() {
    let dir = common::tempdir();
    let fixture = common::package_root().join("fixtures/paper_heat_run.mcap");
    let fixture = fixture.to_str().unwrap();
    let rls = one_line_exit_2(
        &[
            "replay",
            fixture,
            "--method",
            "rls",
            "--forgetting",
            "2",
            "--rrd",
            "x.rrd",
        ],
        dir.path(),
    );
    assert!(
        rls.contains("forgetting factor 2") && rls.contains("; give --forgetting"),
        "{rls}"
    );
    assert!(!dir.path().join("x.rrd").exists());
    let negative = one_line_exit_2(
        &["replay", fixture, "--ts", "-1", "--rrd", "x.rrd"],
        dir.path(),
    );
    assert!(
        negative.contains("the sample time -1 s is outside") && negative.contains("; give --ts"),
        "{negative}"
    );

    // predict and rating: the model report and the load schedule.
    std::fs::write(dir.path().join("notes.json"), "{}").unwrap();
    let not_a_report = one_line_exit_2(
        &["rating", "--model", "notes.json", "--class", "F"],
        dir.path(),
    );
    assert!(
        not_a_report.contains("notes.json: not a heatrun model report")
            && not_a_report.contains("heatrun replay FILE --report REPORT.json"),
        "{not_a_report}"
    );
    let replayed = heatrun(
        &[
            "replay",
            fixture,
            "--rrd",
            "x.rrd",
            "--report",
            "model.json",
            "-q",
        ],
        dir.path(),
    );
    assert!(replayed.status.success());
    // The load schedule: a misspelt column, a schedule longer than a prediction holds in
    // memory (10¹² s aborted asking for 8 TB), a load so far beyond the model's that its
    // temperatures run away (printed before, not refused).
    let column = predict_refused(
        dir.path(),
        "load.csv",
        "time_s,apparent_power_mva,pwer_factor\n0,60,0.9\n",
    );
    assert!(
        column.contains("load.csv: row 1, column `pwer_factor`: not a load column")
            && column.contains("did you mean `power_factor`?"),
        "{column}"
    );
    let long = predict_refused(
        dir.path(),
        "long.csv",
        "time_s,apparent_power_mva,power_factor\n0,60,0.9\n1e12,60,0.9\n",
    );
    assert!(
        long.contains("long.csv: row 3, column `time_s`: 1000000000000 s is")
            && long.contains("; predict a shorter schedule"),
        "{long}"
    );
    let huge = predict_refused(
        dir.path(),
        "huge.csv",
        "time_s,apparent_power_mva,power_factor\n0,60,0.9\n3600,20000,0.9\n7200,60,0.9\n",
    );
    assert!(
        huge.contains("huge.csv: at 36")
            && huge.contains("(the row of time_s 3600): the predicted temperatures ran away"),
        "{huge}"
    );
    let no_limit = one_line_exit_2(&["rating", "--model", "model.json"], dir.path());
    assert!(
        no_limit.contains("; give --class B, F or H, or --limit"),
        "{no_limit}"
    );
    let unknown_part = one_line_exit_2(
        &["rating", "--model", "model.json", "--limit", "rotor=120"],
        dir.path(),
    );
    assert!(
        unknown_part.contains("`rotor`") && unknown_part.contains("--limit takes one of the parts"),
        "{unknown_part}"
    );

    // import: a misspelt column in the map, a marker of missing values in the table.
    std::fs::write(
        dir.path().join("t.csv"),
        "Time (sec),T1 (degC)\n0,20\n1,---\n",
    )
    .unwrap();
    let map = |time_column: &str| {
        format!(
            "[time]\ncolumn = \"{time_column}\"\n[[column]]\ncolumn = \"T1 (degC)\"\n\
             channel = \"T1\"\nunit = \"degC\"\n"
        )
    };
    std::fs::write(dir.path().join("typo.toml"), map("Tme (sec)")).unwrap();
    let typo = one_line_exit_2(
        &["import", "t.csv", "--map", "typo.toml", "--out", "o.mcap"],
        dir.path(),
    );
    assert!(
        typo.contains("no column `Tme (sec)`") && typo.contains("did you mean `Time (sec)`?"),
        "{typo}"
    );
    std::fs::write(dir.path().join("map.toml"), map("Time (sec)")).unwrap();
    let marker = one_line_exit_2(
        &["import", "t.csv", "--map", "map.toml", "--out", "o.mcap"],
        dir.path(),
    );
    assert!(
        marker.contains("line 3") && marker.contains("add `missing = [\"---\"]`"),
        "{marker}"
    );
    assert!(!dir.path().join("o.mcap").exists());

    // A spec's expression that is never finite (a division by zero) is named, not taken for
    // too few samples with a hint at --ts.
    std::fs::write(
        dir.path().join("zero.toml"),
        "[[state]]\nname = \"stator_winding_temp\"\n[[input]]\nname = \"q\"\n\
         expression = \"armature_current / 0\"\nunit = \"W\"\n",
    )
    .unwrap();
    let zero = one_line_exit_2(
        &["replay", fixture, "--spec", "zero.toml", "--rrd", "k.rrd"],
        dir.path(),
    );
    assert!(
        zero.contains("input `q`: its expression `armature_current / 0` is not a finite number")
            && zero.contains("; mend the input's expression in the spec"),
        "{zero}"
    );
    // Two proportional inputs are named as the regression's rank deficiency.
    std::fs::write(
        dir.path().join("twice.toml"),
        "[[state]]\nname = \"stator_winding_temp\"\n[[input]]\nname = \"q\"\n\
         expression = \"armature_current^2\"\nunit = \"kA2\"\n[[input]]\nname = \"q2\"\n\
         expression = \"2 * armature_current^2\"\nunit = \"kA2\"\n",
    )
    .unwrap();
    let twice = one_line_exit_2(
        &["replay", fixture, "--spec", "twice.toml", "--rrd", "k.rrd"],
        dir.path(),
    );
    assert!(
        twice.contains(
            "inputs `q` and `q2` are proportional (`q2` = 2.000000 × `q` at every instant)"
        ) && twice.contains("; two proportional inputs are one heat"),
        "{twice}"
    );
    // A misspelt key of a machine file, a spec or a map: the key it lists that was meant.
    std::fs::write(dir.path().join("machine.toml"), "rated_power_mva = 60\n").unwrap();
    let key = one_line_exit_2(
        &[
            "replay",
            fixture,
            "--machine",
            "machine.toml",
            "--rrd",
            "x.rrd",
        ],
        dir.path(),
    );
    assert!(
        key.contains("machine.toml: line 1, column 1: unknown field `rated_power_mva`")
            && key.ends_with("; did you mean `rated_apparent_power_mva`?\n"),
        "{key}"
    );
    std::fs::write(dir.path().join("spec.toml"), "[[states]]\nname = \"a\"\n").unwrap();
    let spec = one_line_exit_2(
        &["replay", fixture, "--spec", "spec.toml", "--rrd", "k.rrd"],
        dir.path(),
    );
    assert!(spec.ends_with("; did you mean `state`?\n"), "{spec}");
    std::fs::write(
        dir.path().join("colum.toml"),
        map("Time (sec)").replacen("column", "colum", 1),
    )
    .unwrap();
    let map_key = one_line_exit_2(
        &["import", "t.csv", "--map", "colum.toml", "--out", "o.mcap"],
        dir.path(),
    );
    assert!(map_key.ends_with("; did you mean `column`?\n"), "{map_key}");
    assert!(!dir.path().join("k.rrd").exists() && !dir.path().join("o.mcap").exists());
}

/// A build without object storage (the README's) refuses a URL in one line that says
/// how to build heatrun with it, and writes nothing.
#[cfg(not(feature = "object-store"))]
#[test]
fn a_storage_url_without_the_object_store_feature_says_how_to_build_it() {
    let dir = common::tempdir();
    let stderr = fails_with_2(dir.path(), "s3://heat-runs/unit1.mcap");
    assert!(
        stderr.contains("s3://heat-runs/unit1.mcap: this heatrun was built without object storage")
            && stderr.contains("--features object-store"),
        "{stderr}"
    );
}

/// A build without Parquet refuses a Parquet table in one line, exit 2, nothing written.
#[cfg(not(feature = "parquet"))]
#[test]
fn a_parquet_table_without_the_parquet_feature_says_how_to_build_it() {
    let dir = common::tempdir();
    let d = dir.path();
    // Parquet's magic bytes at both ends are all the build without it looks at.
    std::fs::write(d.join("export.parquet"), b"PAR1\0\0\0\0PAR1").unwrap();
    std::fs::write(
        d.join("map.toml"),
        "[time]\ncolumn = \"time\"\n[[column]]\ncolumn = \"T\"\nchannel = \"T\"\nunit = \"degC\"\n",
    )
    .unwrap();
    for args in [
        &[
            "import",
            "export.parquet",
            "--map",
            "map.toml",
            "--out",
            "run.mcap",
        ][..],
        &["import", "--guess", "export.parquet"][..],
    ] {
        let out = heatrun(args, d);
        let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert_eq!(stderr.trim_end().lines().count(), 1, "one line: {stderr}");
        assert!(
            stderr.contains(
                "export.parquet: a Parquet table, and this heatrun was built without Parquet"
            ) && stderr.contains("--features parquet"),
            "{stderr}"
        );
        assert!(!d.join("run.mcap").exists());
    }
}

/// An output named as an input (or as another output) is refused before anything is
/// read: every output is renamed over its destination, so `--rrd run.mcap` would have
/// replaced the recording with its own replay and exited 0.
#[test]
fn an_output_that_would_replace_an_input_or_another_output_is_refused() {
    let dir = common::tempdir();
    let fixture = common::package_root().join("fixtures/paper_heat_run.mcap");
    std::fs::copy(&fixture, dir.path().join("run.mcap")).unwrap();
    std::fs::copy(&fixture, dir.path().join("run.rrd")).unwrap();
    std::fs::create_dir_all(dir.path().join("a")).unwrap();
    std::fs::create_dir_all(dir.path().join("b")).unwrap();
    std::fs::copy(&fixture, dir.path().join("a/unit.mcap")).unwrap();
    std::fs::copy(&fixture, dir.path().join("b/unit.mcap")).unwrap();
    let recording = std::fs::read(&fixture).unwrap();
    std::fs::write(dir.path().join("map.toml"), "time_column = \"t\"\n").unwrap();
    let map = std::fs::read(dir.path().join("map.toml")).unwrap();
    let before = common::files_in(dir.path());
    let cases: [(&[&str], &str); 6] = [
        (
            &["replay", "run.mcap", "--rrd", "./run.mcap"],
            "--rrd ./run.mcap is the recording run.mcap",
        ),
        (
            &["replay", "run.rrd"],
            "--rrd's default run.rrd is the recording run.rrd",
        ),
        (
            &["replay", "run.mcap", "--report", "x.json", "--html=x.json"],
            "--report and --html both name x.json",
        ),
        (
            &["replay", "a/unit.mcap", "b/unit.mcap", "--out-dir", "out"],
            "a/unit.mcap and b/unit.mcap would both write unit.rrd",
        ),
        (
            &["rating", "--model", "run.mcap", "--json", "run.mcap"],
            "--json run.mcap is --model run.mcap",
        ),
        (
            &[
                "import", "run.rrd", "--map", "map.toml", "--out", "map.toml",
            ],
            "--out map.toml is --map map.toml",
        ),
    ];
    for (args, expected) in cases {
        let line = one_line_exit_2(args, dir.path());
        assert!(line.contains(expected), "heatrun {args:?}: {line}");
        assert_eq!(common::files_in(dir.path()), before, "nothing written");
        for input in ["run.mcap", "run.rrd", "a/unit.mcap", "b/unit.mcap"] {
            assert_eq!(
                std::fs::read(dir.path().join(input)).unwrap(),
                recording,
                "{input} untouched"
            );
        }
        assert_eq!(std::fs::read(dir.path().join("map.toml")).unwrap(), map);
    }
}

/// An output whose folder is missing fails before the replay runs, in one line naming
/// the output as given (rerun's sink named the temporary `.x.rrd.partial`; the report's
/// folder was found missing only after the replay, the .rrd written), with the exit
/// status of an output that cannot be written (1).
#[test]
fn an_output_into_a_missing_folder_is_named_by_its_own_path_before_the_replay() {
    let dir = common::tempdir();
    let fixture = common::package_root().join("fixtures/paper_heat_run.mcap");
    let fixture = fixture.to_str().unwrap();
    for (args, named) in [
        (
            ["--rrd", "missing/run.rrd", "--report", "run.json"],
            "missing/run.rrd",
        ),
        (
            ["--rrd", "run.rrd", "--report", "missing/run.json"],
            "missing/run.json",
        ),
        (
            ["--rrd", "run.rrd", "--html", "missing/run.html"],
            "missing/run.html",
        ),
    ] {
        let mut line = vec!["replay", fixture];
        line.extend(args);
        let out = heatrun(&line, dir.path());
        let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
        assert_eq!(out.status.code(), Some(1), "{stderr}");
        assert_eq!(stderr.trim_end().lines().count(), 1, "one line: {stderr}");
        assert!(
            stderr.starts_with(&format!("heatrun: {named}: cannot write:")),
            "{stderr}"
        );
        assert!(common::files_in(dir.path()).is_empty(), "nothing written");
    }
}

/// `fleet summary` of a folder none of whose reports reads says why, in the first
/// report's words, naming it (it said only that none could be read).
#[test]
fn a_fleet_summary_of_unreadable_reports_names_the_first_and_why() {
    let dir = common::tempdir();
    std::fs::create_dir(dir.path().join("out")).unwrap();
    std::fs::write(
        dir.path().join("out/unit.report.json"),
        r#"{"profile": "heatrun-scada/1"}"#,
    )
    .unwrap();
    let line = one_line_exit_2(&["fleet", "summary", "out"], dir.path());
    assert!(
        line.contains(
            "out: none of its 1 reports could be read (the first: out/unit.report.json: "
        ),
        "{line}"
    );
    assert!(
        !dir.path().join("out/fleet-summary.csv").exists(),
        "no table"
    );
}
