//! The replay's outputs: the .rrd read back with rerun's own decoder, and the JSON
//! report checked against `schemas/report.schema.json` by a JSON Schema validator.

use crate::common;

use std::collections::BTreeMap;
use std::io::BufReader;

use heatrun::model_file::Report;
use heatrun::pipeline::{replay, ReplayOptions};
use heatrun::report::Replayed;
use heatrun::synth::{self, SynthOptions};
// rerun's own decoder, through the SDK the build already has (no second build of
// rerun's crates for the tests).
use heatrun_rerun::sdk::external::re_log_encoding::DecoderApp;
use heatrun_rerun::sdk::log::{Chunk, LogMsg};
use heatrun_rerun::sdk::StoreKind;
use serde_json::Value;

thread_local! {
    /// Static entities seen by the last [`rows_and_blueprint`] on this thread.
    static STATICS: std::cell::RefCell<std::collections::BTreeSet<String>> =
        Default::default();
}

/// Rows per entity of the recording store (not the blueprint) in an .rrd file.
pub(crate) fn rows_per_entity(path: &std::path::Path) -> (BTreeMap<String, usize>, bool) {
    let (rows, blueprint) = rows_and_blueprint(path);
    (rows, !blueprint.is_empty())
}

/// Rows per entity of the recording store, and the blueprint's entity paths.
fn rows_and_blueprint(
    path: &std::path::Path,
) -> (BTreeMap<String, usize>, std::collections::BTreeSet<String>) {
    let file = std::fs::File::open(path).unwrap();
    let mut rows = BTreeMap::new();
    let mut blueprint = std::collections::BTreeSet::new();
    for msg in DecoderApp::decode_eager(BufReader::new(file)).unwrap() {
        let msg = msg.unwrap();
        if let LogMsg::ArrowMsg(store, arrow) = &msg {
            if store.kind() == StoreKind::Blueprint {
                let chunk = Chunk::from_arrow_msg(arrow).unwrap();
                blueprint.insert(chunk.entity_path().to_string());
                continue;
            }
            let chunk = Chunk::from_arrow_msg(arrow).unwrap();
            if chunk.is_static() {
                // Series styles, the summary text and the network graph.
                STATICS.with(|s| s.borrow_mut().insert(chunk.entity_path().to_string()));
                continue;
            }
            *rows.entry(chunk.entity_path().to_string()).or_insert(0) += chunk.num_rows();
        }
    }
    (rows, blueprint)
}

#[test]
fn rrd_holds_the_expected_entities_and_rows() {
    let dir = common::tempdir();
    let mcap = dir.path().join("run.mcap");
    let duration = 3000.0;
    synth::write(
        &mcap,
        &SynthOptions {
            duration_s: duration,
            ..SynthOptions::default()
        },
    )
    .unwrap();
    common::heatrun_ok(
        &["replay", "run.mcap", "--rrd", "run.rrd", "--quiet"],
        dir.path(),
    );
    let (rows, blueprint) = rows_and_blueprint(&dir.path().join("run.rrd"));
    let statics = STATICS.with(|s| s.borrow().clone());
    assert!(
        blueprint.contains("/viewport"),
        "a blueprint is sent with the recording"
    );
    // Every time-series view shows the whole recording: three parts, residuals, inputs,
    // three sensitivities, three correlations, the decimated quantities, and the
    // calorimetric balance (the synthetic run records the cooling-water flow).
    let whole_range = blueprint
        .iter()
        .filter(|p| p.ends_with("/TimeAxis"))
        .count();
    assert_eq!(whole_range, 13, "{blueprint:?}");
    let n = duration as usize; // one instant per second
    for state in [
        "stator_winding_temp",
        "core_temp",
        "cooling_water_outlet_temp",
    ] {
        assert_eq!(
            rows[&format!("/temperature/{state}/measured")],
            n,
            "{rows:?}"
        );
        assert_eq!(rows[&format!("/residual/{state}")], n);
        // Smooth curves, sent as the polyline the plot draws (heatrun_rerun::curve): its
        // two ends at least, fewer rows than instants (the instants' values are checked
        // in the publisher's own tests).
        let model = rows[&format!("/temperature/{state}/model")];
        assert!((2..n).contains(&model), "{model}");
        for i in 1..=3 {
            let response = rows[&format!("/sensitivity/T{i}/{state}")];
            assert!((2..n).contains(&response), "T{i} {state}: {response}");
        }
    }
    for input in ["armature_copper_loss", "field_copper_loss", "iron_loss"] {
        assert_eq!(rows[&format!("/loss/{input}")], n);
    }
    // The calorimetric balance over time: the water's heat and the losses' sum.
    assert_eq!(rows["/calorimetry/heat_carried_away"], n);
    assert_eq!(rows["/calorimetry/losses"], n);
    for q in [
        "armature_current",
        "field_current",
        "line_voltage",
        "field_voltage",
    ] {
        assert_eq!(rows[&format!("/decimated/{q}")], n);
    }
    assert!(!rows.contains_key("/summary"), "the summary is static");
    // The thermal network is drawn as a graph, with a view of its own.
    assert!(
        statics.contains("/network/graph"),
        "the network graph is logged: {statics:?}"
    );
    // No temporary file is left beside the output.
    let names: Vec<String> = common::files_in(dir.path())
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into())
        .collect();
    assert!(names.iter().all(|n| !n.contains("partial")), "{names:?}");
}

#[test]
fn publishing_stage_by_stage_writes_what_publishing_the_whole_replay_writes() {
    // The command line's publisher sends each stage's series beside the next stage
    // (`replay_observed`); `publish` sends them all from the finished replay.
    let dir = common::tempdir();
    let mcap = dir.path().join("run.mcap");
    synth::write(
        &mcap,
        &SynthOptions {
            duration_s: 2000.0,
            ..SynthOptions::default()
        },
    )
    .unwrap();
    let options = ReplayOptions::default();
    let staged = dir.path().join("staged.rrd");
    let publisher =
        heatrun_rerun::Publisher::open(&heatrun_rerun::RerunSink::Rrd(staged.clone()), "run")
            .unwrap();
    let replayed = heatrun::pipeline::replay_observed(&mcap, &options, None, &publisher).unwrap();
    publisher.finish(&Replayed::new(replayed)).unwrap();
    let whole = dir.path().join("whole.rrd");
    let replayed = Replayed::new(replay(&mcap, &options).unwrap());
    heatrun_rerun::publish(&replayed, &heatrun_rerun::RerunSink::Rrd(whole.clone())).unwrap();
    let (staged_rows, staged_blueprint) = rows_and_blueprint(&staged);
    let staged_statics = STATICS.with(|s| std::mem::take(&mut *s.borrow_mut()));
    let (whole_rows, whole_blueprint) = rows_and_blueprint(&whole);
    let whole_statics = STATICS.with(|s| s.borrow().clone());
    assert_eq!(staged_rows, whole_rows);
    assert!(
        staged_rows.contains_key("/sensitivity/T1/core_temp"),
        "{staged_rows:?}"
    );
    assert_eq!(staged_statics, whole_statics);
    assert_eq!(staged_blueprint, whole_blueprint);
}

/// `schemas/report.schema.json`, compiled by a JSON Schema (draft 2020-12) validator.
pub(crate) struct ReportSchema {
    schemas: boon::Schemas,
    index: boon::SchemaIndex,
}

impl ReportSchema {
    pub(crate) fn load() -> ReportSchema {
        let path = common::package_root().join("schemas/report.schema.json");
        let mut schemas = boon::Schemas::new();
        let index = boon::Compiler::new()
            .compile(path.to_str().unwrap(), &mut schemas)
            .unwrap_or_else(|e| panic!("{e:#}"));
        ReportSchema { schemas, index }
    }

    /// Every violation, one a line: `- at '<where in the report>' [S#<schema keyword>]: what`.
    pub(crate) fn check(&self, report: &Value) -> Result<(), String> {
        self.schemas
            .validate(report, self.index)
            .map_err(|e| format!("{e:#}"))
    }
}

#[test]
fn report_follows_the_profile_and_its_schema() {
    let dir = common::tempdir();
    let mcap = dir.path().join("run.mcap");
    synth::write(
        &mcap,
        &SynthOptions {
            duration_s: 8000.0,
            ..SynthOptions::default()
        },
    )
    .unwrap();
    let out = common::heatrun_ok(
        &[
            "replay",
            "run.mcap",
            "--rrd",
            "run.rrd",
            "--report",
            "report.json",
        ],
        dir.path(),
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("time constants (eq. 26)") && stdout.contains("SNR, dB (eq. 25)"),
        "{stdout}"
    );
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("report.json")).unwrap())
            .unwrap();
    ReportSchema::load().check(&report).unwrap();
    // Time constants ascending, assignment one per time constant.
    let t: Vec<f64> = report["time_constants_s"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert!(t.windows(2).all(|w| w[0] < w[1]));
    assert_eq!(report["assignment"].as_array().unwrap().len(), 3);
    assert_eq!(
        report["recording"]["metadata"]["heatrun.test"]["test_id"],
        "synthetic-seed-1"
    );
}

/// The fixture's report, as a JSON value.
fn fixture_report() -> Value {
    let fixture = common::package_root().join("fixtures/paper_heat_run.mcap");
    let replayed = replay(&fixture, &ReplayOptions::default()).unwrap();
    serde_json::from_str(&Report::new(&replayed).to_json()).unwrap()
}

/// The report a replay writes reads back as the one document type: every key a use of
/// the model reads is written again as it was, and the model's description is the
/// report's own.
#[test]
fn the_report_reads_back_as_it_was_written() {
    let fixture = common::package_root().join("fixtures/paper_heat_run.mcap");
    let replayed = replay(&fixture, &ReplayOptions::default()).unwrap();
    let written = Report::new(&replayed);
    let path = std::path::Path::new("model.json");
    let read = Report::from_json(&written.to_json(), path).unwrap();
    let (w, r): (Value, Value) = (
        serde_json::from_str(&written.to_json()).unwrap(),
        serde_json::to_value(&read).unwrap(),
    );
    for key in [
        "profile",
        "sample_time_s",
        "states",
        "inputs",
        "phi",
        "gamma",
        "time_constants_s",
        "nameplate",
        "model",
        "validation",
    ] {
        assert_eq!(r[key], w[key], "{key}");
    }
    for (block, key) in [
        ("fit", "rmse_k"),
        ("fit", "max_abs_error_k"),
        ("estimation", "initial_temperature_c"),
        ("estimation", "initial_reference_c"),
        ("estimation", "temperature_base_k"),
        ("estimation", "power_base_mva"),
        ("estimation", "coolant_inlet_temp_c"),
        ("estimation", "field_temperature"),
    ] {
        assert_eq!(r[block][key], w[block][key], "{block}.{key}");
    }
    let f = "field_temperature_from_stator";
    assert_eq!(r["estimation"][f]["slope"], w["estimation"][f]["slope"]);
    let model = heatrun::model_file::ThermalModel::from_report(&read, path).unwrap();
    assert_eq!(model.states, replayed.model.states);
    assert_eq!(
        model.initial_reference_c,
        replayed.signals.initial_references()
    );
}

#[test]
fn reports_that_break_the_schema_are_rejected() {
    let schema = ReportSchema::load();
    let report = fixture_report();
    schema.check(&report).unwrap();
    // Each edit breaks one rule of the schema; the validator must name where in the
    // report and which keyword.
    type Edit = (&'static str, fn(&mut Value), &'static str, &'static str);
    let edits: [Edit; 6] = [
        (
            "a zero sample time",
            |r| r["sample_time_s"] = 0.0.into(),
            "/sample_time_s",
            "/exclusiveMinimum]",
        ),
        (
            "no fit block",
            |r| {
                r.as_object_mut().unwrap().remove("fit");
            },
            "",
            "/required]",
        ),
        (
            "another profile",
            |r| r["profile"] = "heatrun-scada/2".into(),
            "/profile",
            "/const]",
        ),
        (
            "states out of order",
            |r| r["states"].as_array_mut().unwrap().swap(0, 1),
            "/states",
            // The generator's three states, or four with the field winding.
            "/enum]",
        ),
        (
            "a time constant that is not a number",
            |r| r["time_constants_s"][1] = "737 s".into(),
            "/time_constants_s/1",
            "/type]",
        ),
        (
            "a matrix row that is not an array",
            |r| r["phi"][0] = 1.0.into(),
            "/phi/0",
            "/type]",
        ),
    ];
    for (what, edit, at, keyword) in edits {
        let mut broken = report.clone();
        edit(&mut broken);
        let err = schema
            .check(&broken)
            .expect_err(&format!("{what} is accepted"));
        let named = err.lines().any(|l| {
            l.trim_start().starts_with(&format!("- at '{at}' [S#")) && l.contains(keyword)
        });
        assert!(named, "{what}: {err}");
    }
}

#[test]
fn raw_publishes_every_sample_at_full_rate() {
    let dir = common::tempdir();
    let mcap = dir.path().join("run.mcap");
    synth::write(
        &mcap,
        &SynthOptions {
            duration_s: 2000.0,
            electrical_rate_hz: 5.0,
            ..SynthOptions::default()
        },
    )
    .unwrap();
    common::heatrun_ok(
        &["replay", "run.mcap", "--raw", "--rrd", "raw.rrd", "--quiet"],
        dir.path(),
    );
    let (rows, _) = rows_per_entity(&dir.path().join("raw.rrd"));
    assert_eq!(rows["/full_rate/scada/armature_current"], 10_000);
    assert_eq!(rows["/full_rate/scada/core_temp"], 2000);
    // The decimated traces are there too.
    assert_eq!(rows["/decimated/armature_current"], 2000);
}

#[test]
fn a_fleet_gets_one_report_each_and_a_summary() {
    let dir = common::tempdir();
    let input = dir.path().join("archive");
    std::fs::create_dir(&input).unwrap();
    for seed in 1..=2 {
        synth::write(
            &input.join(format!("unit{seed}.mcap")),
            &SynthOptions {
                duration_s: 4000.0,
                seed,
                ..SynthOptions::default()
            },
        )
        .unwrap();
    }
    std::fs::write(input.join("broken.mcap"), "not mcap").unwrap();
    let out = common::heatrun(
        &["replay", "archive", "--out-dir", "out", "--jobs", "2"],
        dir.path(),
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(2),
        "one recording is broken: {stdout}"
    );
    for seed in 1..=2 {
        assert!(dir.path().join(format!("out/unit{seed}.rrd")).exists());
        let report: Value = serde_json::from_str(
            &std::fs::read_to_string(dir.path().join(format!("out/unit{seed}.report.json")))
                .unwrap(),
        )
        .unwrap();
        assert_eq!(report["profile"], "heatrun-scada/1");
    }
    let csv = std::fs::read_to_string(dir.path().join("out/fleet-summary.csv")).unwrap();
    assert_eq!(csv.lines().count(), 4, "{csv}");
    assert!(
        csv.contains("broken.mcap,failed: ") && csv.contains("unit2.mcap,ok,"),
        "{csv}"
    );
    assert!(
        stdout.contains("3 recordings") && stdout.contains("2 ok") && stdout.contains("1 failed"),
        "{stdout}"
    );
}

/// `replay --index N --out-dir DIR` makes DIR, as a fleet makes its own; `-q` on a fleet
/// prints nothing (the table is in fleet-summary.csv).
#[test]
fn an_indexed_replay_makes_its_folder_and_a_quiet_fleet_prints_no_table() {
    let dir = common::tempdir();
    let input = dir.path().join("archive");
    std::fs::create_dir(&input).unwrap();
    for seed in 1..=2 {
        synth::write(
            &input.join(format!("unit{seed}.mcap")),
            &SynthOptions {
                duration_s: 3000.0,
                seed,
                ..SynthOptions::default()
            },
        )
        .unwrap();
    }
    common::heatrun_ok(
        &[
            "replay",
            "--index",
            "1",
            "archive",
            "--out-dir",
            "idx/new",
            "-q",
        ],
        dir.path(),
    );
    assert!(dir.path().join("idx/new/unit2.rrd").is_file());
    assert!(dir.path().join("idx/new/unit2.report.json").is_file());
    let quiet = common::heatrun_ok(&["replay", "archive", "--out-dir", "out", "-q"], dir.path());
    assert_eq!(String::from_utf8_lossy(&quiet.stdout), "");
    assert!(dir.path().join("out/fleet-summary.csv").is_file());
    // A recording named as the listing is refused by what it is (it was read as text:
    // "invalid utf-8 sequence of 1 bytes from index 0").
    let out = common::heatrun(
        &[
            "replay",
            "--index",
            "0",
            "archive/unit1.mcap",
            "--out-dir",
            "o",
            "-q",
        ],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("--index: archive/unit1.mcap is not a listing of recordings")
            && stderr.contains("it is an MCAP recording")
            && stderr.contains("replay it without --index"),
        "{stderr}"
    );
    assert!(!dir.path().join("o").exists());
}
