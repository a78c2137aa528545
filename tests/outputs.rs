//! The replay's outputs: the .rrd read back with rerun's own decoder, and the JSON
//! report checked against `schemas/report.schema.json`.

mod common;

use std::collections::BTreeMap;
use std::io::BufReader;

use heatrun::synth::{self, SynthOptions};
use serde_json::Value;

/// Rows per entity of the recording store (not the blueprint) in an .rrd file.
fn rows_per_entity(path: &std::path::Path) -> (BTreeMap<String, usize>, bool) {
    let file = std::fs::File::open(path).unwrap();
    let mut rows = BTreeMap::new();
    let mut saw_blueprint = false;
    for msg in re_log_encoding::DecoderApp::decode_eager(BufReader::new(file)).unwrap() {
        let msg = msg.unwrap();
        if let re_log_types::LogMsg::ArrowMsg(store, arrow) = &msg {
            if store.kind() == re_log_types::StoreKind::Blueprint {
                saw_blueprint = true;
                continue;
            }
            let chunk = re_chunk::Chunk::from_arrow_msg(arrow).unwrap();
            if chunk.is_static() {
                continue; // series styles and the summary text
            }
            *rows.entry(chunk.entity_path().to_string()).or_insert(0) += chunk.num_rows();
        }
    }
    (rows, saw_blueprint)
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
    let out = common::heatrun(
        &["replay", "run.mcap", "--rrd", "run.rrd", "--quiet"],
        dir.path(),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let (rows, saw_blueprint) = rows_per_entity(&dir.path().join("run.rrd"));
    assert!(saw_blueprint, "a blueprint is sent with the recording");
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
        assert_eq!(rows[&format!("/temperature/{state}/model")], n);
        assert_eq!(rows[&format!("/residual/{state}")], n);
        for i in 1..=3 {
            assert_eq!(rows[&format!("/sensitivity/T{i}/{state}")], n);
        }
    }
    for input in ["armature_copper_loss", "field_copper_loss", "iron_loss"] {
        assert_eq!(rows[&format!("/loss/{input}")], n);
    }
    for q in [
        "armature_current",
        "field_current",
        "line_voltage",
        "field_voltage",
    ] {
        assert_eq!(rows[&format!("/raw/{q}")], n);
    }
    assert!(!rows.contains_key("/summary"), "the summary is static");
    // No temporary file is left beside the output.
    let names: Vec<String> = common::files_in(dir.path())
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into())
        .collect();
    assert!(names.iter().all(|n| !n.contains("partial")), "{names:?}");
}

/// A small JSON Schema checker for the subset the report schema uses: type, required,
/// properties, items, const, enum, $ref to #/$defs.
fn check(schema: &Value, root: &Value, value: &Value, at: &str, errors: &mut Vec<String>) {
    if let Some(r) = schema.get("$ref").and_then(Value::as_str) {
        let name = r.trim_start_matches("#/$defs/");
        return check(&root["$defs"][name], root, value, at, errors);
    }
    if let Some(c) = schema.get("const") {
        if c != value {
            errors.push(format!("{at}: {value} is not {c}"));
        }
    }
    if let Some(e) = schema.get("enum").and_then(Value::as_array) {
        if !e.contains(value) {
            errors.push(format!("{at}: {value} not in {e:?}"));
        }
    }
    if let Some(t) = schema.get("type").and_then(Value::as_str) {
        let ok = match t {
            "object" => value.is_object(),
            "array" => value.is_array(),
            "number" => value.is_number(),
            "integer" => value.is_u64() || value.is_i64(),
            "string" => value.is_string(),
            _ => true,
        };
        if !ok {
            errors.push(format!("{at}: {value} is not of type {t}"));
            return;
        }
    }
    if let Some(req) = schema.get("required").and_then(Value::as_array) {
        for k in req {
            if value.get(k.as_str().unwrap()).is_none() {
                errors.push(format!("{at}: missing required key {k}"));
            }
        }
    }
    if let (Some(props), Some(obj)) = (
        schema.get("properties").and_then(Value::as_object),
        value.as_object(),
    ) {
        for (k, s) in props {
            if let Some(v) = obj.get(k) {
                check(s, root, v, &format!("{at}.{k}"), errors);
            }
        }
    }
    if let (Some(items), Some(arr)) = (schema.get("items"), value.as_array()) {
        for (i, v) in arr.iter().enumerate() {
            check(items, root, v, &format!("{at}[{i}]"), errors);
        }
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
    let out = common::heatrun(
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
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("time constants (eq. 26)") && stdout.contains("SNR, dB (eq. 25)"),
        "{stdout}"
    );
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("report.json")).unwrap())
            .unwrap();
    let schema: Value =
        serde_json::from_str(include_str!("../schemas/report.schema.json")).unwrap();
    let mut errors = Vec::new();
    check(&schema, &schema, &report, "$", &mut errors);
    assert!(errors.is_empty(), "{errors:#?}");
    // The checker itself rejects a report without a required key.
    let mut broken = report.clone();
    broken.as_object_mut().unwrap().remove("fit");
    let mut errors = Vec::new();
    check(&schema, &schema, &broken, "$", &mut errors);
    assert_eq!(errors.len(), 1);
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
    let out = common::heatrun(
        &["replay", "run.mcap", "--raw", "--rrd", "raw.rrd", "--quiet"],
        dir.path(),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let (rows, _) = rows_per_entity(&dir.path().join("raw.rrd"));
    assert_eq!(rows["/full_rate/scada/armature_current"], 10_000);
    assert_eq!(rows["/full_rate/scada/core_temp"], 2000);
    // The decimated traces are there too.
    assert_eq!(rows["/raw/armature_current"], 2000);
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
