//! `heatrun monitor`: a model identified from a healthy synthetic recording of the RC
//! machine (`synth --machine rc-unit`, PT100-like noise) run beside later recordings of
//! the same machine: healthy ones (another seed, another load schedule, a warm start)
//! raise nothing; a fouled cooler (`--fault-at`, `--fault-conductance-drop`) raises an
//! alarm on the cooler within the documented delay; bad input is one line and exit 2.

use std::path::Path;

use serde_json::Value;

use crate::common;

/// The time of the cooler fault, s.
const FAULT_AT_S: f64 = 10_000.0;
/// The documented delay from the fault to the first alarm with the default band and
/// hold (README, "Monitoring"): the hold (600 s) plus up to 600 s for the residual to
/// leave the band at a 30 % conductance drop.
const DOCUMENTED_DELAY_S: f64 = 1_200.0;

fn synth(dir: &Path, name: &str, extra: &[&str]) {
    let mut args = vec![
        "synth",
        name,
        "--machine",
        "rc-unit",
        "--temperature-noise",
        "0.05",
        "--resolution",
        "0.01",
        "--electrical-noise",
        "0.0005",
    ];
    args.extend_from_slice(extra);
    common::heatrun_ok(&args, dir);
}

/// A model identified from a healthy recording (`recording`, made with `extra`), its
/// last 30 % held out for the validation error the band is set from.
fn identify(dir: &Path, recording: &str, extra: &[&str], report: &str) {
    synth(dir, recording, extra);
    common::heatrun_ok(
        &[
            "replay",
            recording,
            "--report",
            report,
            "--holdout",
            "0.3",
            "-q",
        ],
        dir,
    );
}

/// Monitors `recording` with `model`, writing `<recording>.json`; the exit status, the
/// document and stdout.
fn monitor(dir: &Path, model: &str, recording: &str) -> (Option<i32>, Value, String) {
    let json = format!("{recording}.json");
    let out = common::heatrun(
        &["monitor", "--model", model, recording, "--json", &json],
        dir,
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        matches!(out.status.code(), Some(0 | 4)),
        "{:?}: {stderr}",
        out.status
    );
    let doc: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join(&json)).unwrap()).unwrap();
    (
        out.status.code(),
        doc,
        String::from_utf8_lossy(&out.stdout).into_owned(),
    )
}

fn alarms(doc: &Value) -> &Vec<Value> {
    doc["alarms"].as_array().unwrap()
}

/// The fault flagged on the right part within the documented delay, and nothing before it.
fn assert_fault_flagged(status: Option<i32>, doc: &Value, stdout: &str) {
    assert_eq!(status, Some(4), "{stdout}");
    assert_eq!(doc["healthy"], false);
    let alarms = alarms(doc);
    for a in alarms {
        assert!(
            a["start_s"].as_f64().unwrap() >= FAULT_AT_S,
            "before the fault: {a}"
        );
        assert!(
            a["peak_deviation_k"].as_f64().unwrap() > 0.0,
            "a fouled cooler runs hot: {a}"
        );
    }
    let first = &alarms[0];
    assert_eq!(first["state"], "cooling_water_outlet_temp", "{stdout}");
    let delay = first["raised_s"].as_f64().unwrap() - FAULT_AT_S;
    assert!(
        delay <= DOCUMENTED_DELAY_S,
        "raised {delay} s after the fault"
    );
    assert!(
        stdout.contains("ALARM cooling_water_outlet_temp: from "),
        "{stdout}"
    );
}

#[test]
fn a_fouled_cooler_raises_an_alarm_and_healthy_recordings_none() {
    let dir = common::tempdir();
    let d = dir.path();
    identify(d, "model.mcap", &["--seed", "1"], "model.json");
    // Another seed and another load schedule; a machine that starts 5 K warm.
    synth(
        d,
        "healthy.mcap",
        &["--seed", "2", "--profile", "single-step"],
    );
    synth(d, "warm.mcap", &["--seed", "4", "--start-above", "5"]);
    for healthy in ["healthy.mcap", "warm.mcap"] {
        let (status, doc, stdout) = monitor(d, "model.json", healthy);
        assert_eq!(status, Some(0), "{healthy}: {stdout}");
        assert_eq!(doc["healthy"], true);
        assert!(alarms(&doc).is_empty());
        assert!(stdout.contains("healthy, no alarm"), "{stdout}");
        // The model follows the healthy machine: its residual is about the sensor noise.
        for part in doc["parts"].as_array().unwrap() {
            let rms = part["rms_k"].as_f64().unwrap();
            assert!(rms < 0.1, "{healthy}: {part}");
        }
    }
    let fault = FAULT_AT_S.to_string();
    let faulty = [
        "--seed",
        "3",
        "--fault-at",
        &fault,
        "--fault-conductance-drop",
        "0.3",
    ];
    synth(d, "fault.mcap", &faulty);
    let (status, doc, stdout) = monitor(d, "model.json", "fault.mcap");
    assert_fault_flagged(status, &doc, &stdout);
    // A drifting inlet this model (rises above the initial values) does not carry: the
    // JSON and stderr say so, whatever the alarms.
    synth(d, "drift.mcap", &["--seed", "5", "--inlet-drift", "3"]);
    let args = [
        "monitor",
        "--model",
        "model.json",
        "drift.mcap",
        "--json",
        "drift.json",
    ];
    let out = common::heatrun(&args, d);
    assert!(matches!(out.status.code(), Some(0 | 4)), "{:?}", out.status);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("warning: the coolant inlet varies by"),
        "{stderr}"
    );
    let doc: Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("drift.json")).unwrap()).unwrap();
    assert!(
        doc["warnings"][0]
            .as_str()
            .is_some_and(|w| w.contains("the coolant inlet varies by")),
        "{}",
        doc["warnings"]
    );
}

#[test]
fn a_coolant_referenced_model_follows_a_drifting_inlet_and_flags_the_fault() {
    let dir = common::tempdir();
    let d = dir.path();
    // The inlet drifts 3 K over a day: the replay measures the rises from the inlet's
    // initial level and takes its drift as an input.
    identify(
        d,
        "model.mcap",
        &["--seed", "6", "--inlet-drift", "3"],
        "model.json",
    );
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("model.json")).unwrap()).unwrap();
    assert!(
        report["inputs"]
            .as_array()
            .unwrap()
            .iter()
            .any(|i| i == "cooling_water_inlet_rise"),
        "{}",
        report["inputs"]
    );
    synth(d, "drift.mcap", &["--seed", "5", "--inlet-drift", "3"]);
    let (status, doc, stdout) = monitor(d, "model.json", "drift.mcap");
    assert_eq!(status, Some(0), "{stdout}");
    assert!(alarms(&doc).is_empty());
    // The model carries the drift: nothing to warn about.
    assert_eq!(
        doc["warnings"],
        serde_json::json!([]),
        "{}",
        doc["warnings"]
    );
    let fault = FAULT_AT_S.to_string();
    let faulty = [
        "--seed",
        "7",
        "--inlet-drift",
        "3",
        "--profile",
        "single-step",
        "--fault-at",
        &fault,
        "--fault-conductance-drop",
        "0.3",
    ];
    synth(d, "fault.mcap", &faulty);
    let (status, doc, stdout) = monitor(d, "model.json", "fault.mcap");
    assert_fault_flagged(status, &doc, &stdout);
}

/// A model that carries the cooling-water flow (identified on a run whose pump switched to
/// 0.6 of the flow) follows a later run whose pump switches at another time and to another
/// flow, and still flags a fouled cooler; `predict` runs it at the test's initial flow
/// and says so.
#[test]
fn a_model_carrying_the_flow_follows_a_pump_switch_and_flags_the_fault() {
    let dir = common::tempdir();
    let d = dir.path();
    identify(
        d,
        "model.mcap",
        &["--seed", "8", "--pump-switch", "10000:0.6"],
        "model.json",
    );
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("model.json")).unwrap()).unwrap();
    assert!(
        report["inputs"]
            .as_array()
            .unwrap()
            .iter()
            .any(|i| i == "cooling_water_flow_heat"),
        "{}",
        report["inputs"]
    );
    synth(
        d,
        "pump.mcap",
        &["--seed", "9", "--pump-switch", "6000:0.75"],
    );
    let (status, doc, stdout) = monitor(d, "model.json", "pump.mcap");
    assert_eq!(status, Some(0), "{stdout}");
    assert!(alarms(&doc).is_empty());
    let fault = FAULT_AT_S.to_string();
    let faulty = [
        "--seed",
        "10",
        "--pump-switch",
        "6000:0.75",
        "--fault-at",
        &fault,
        "--fault-conductance-drop",
        "0.3",
    ];
    synth(d, "fault.mcap", &faulty);
    let (status, doc, stdout) = monitor(d, "model.json", "fault.mcap");
    assert_fault_flagged(status, &doc, &stdout);

    std::fs::write(
        d.join("load.csv"),
        "time_s,apparent_power_mva,power_factor\n0,80,0.9\n3600,80,0.9\n",
    )
    .unwrap();
    let out = common::heatrun_ok(
        &[
            "predict",
            "--model",
            "model.json",
            "--load",
            "load.csv",
            "--out",
            "p.csv",
        ],
        d,
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("holds the flow at the start of the model's test"),
        "{stderr}"
    );
    assert_eq!(
        std::fs::read_to_string(d.join("p.csv"))
            .unwrap()
            .lines()
            .count(),
        3602
    );
}

#[test]
fn the_rrd_is_written_and_quiet_prints_only_the_alarms() {
    let dir = common::tempdir();
    let d = dir.path();
    identify(
        d,
        "model.mcap",
        &["--seed", "1", "--duration", "7200"],
        "model.json",
    );
    let faulty = [
        "--seed",
        "2",
        "--duration",
        "7200",
        "--fault-at",
        "1800",
        "--fault-conductance-drop",
        "0.5",
    ];
    synth(d, "fault.mcap", &faulty);
    let out = common::heatrun(
        &[
            "monitor",
            "--model",
            "model.json",
            "fault.mcap",
            "--rrd",
            "fault.rrd",
            "-q",
        ],
        d,
    );
    assert_eq!(
        out.status.code(),
        Some(4),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        !stdout.is_empty() && stdout.lines().all(|l| l.starts_with("ALARM ")),
        "{stdout}"
    );
    // Read back with rerun's decoder: per part the measured and predicted temperature and
    // the residual at every instant, the band's two ends, and the alarm's stretch.
    let (rows, blueprint) = crate::outputs::rows_per_entity(&d.join("fault.rrd"));
    assert!(blueprint);
    let instants = 7200;
    for state in [
        "stator_winding_temp",
        "core_temp",
        "cooling_water_outlet_temp",
    ] {
        for e in [
            "temperature/{s}/measured",
            "temperature/{s}/predicted",
            "residual/{s}/residual",
        ] {
            let entity = format!("/monitor/{}", e.replace("{s}", state));
            assert_eq!(rows.get(&entity), Some(&instants), "{entity}: {rows:?}");
        }
        for side in ["band_upper", "band_lower"] {
            assert_eq!(
                rows.get(&format!("/monitor/residual/{state}/{side}")),
                Some(&2)
            );
        }
    }
    let alarm = rows["/monitor/residual/cooling_water_outlet_temp/alarm"];
    // From the first instant outside the band (after the fault at 1800 s) to the end.
    assert!(
        alarm > 600 && alarm <= 7200 - 1800,
        "{alarm} instants in alarm"
    );
}

/// Runs a monitor that must fail on bad input: exit 2, one line naming `names`, no output.
fn assert_bad_input(dir: &Path, args: &[&str], names: &[&str]) {
    let out = common::heatrun(args, dir);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    for n in names {
        assert!(stderr.contains(n), "{args:?}: `{n}` not in {stderr}");
    }
    assert!(!dir.join("out.json").exists());
}

#[test]
fn bad_input_is_one_line_and_exit_2() {
    let dir = common::tempdir();
    let d = dir.path();
    identify(
        d,
        "model.mcap",
        &["--seed", "1", "--duration", "3600"],
        "model.json",
    );
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("model.json")).unwrap()).unwrap();
    let mut other = report.clone();
    other["profile"] = "heatrun-scada/2".into();
    std::fs::write(d.join("other.json"), other.to_string()).unwrap();
    let mut bare = report.clone();
    bare.as_object_mut().unwrap().remove("model");
    std::fs::write(d.join("bare.json"), bare.to_string()).unwrap();
    common::RecordingBuilder::heat_run(3600.0, "core_temp").write(&d.join("no_core.mcap"));
    let run = |model: &str, recording: &str| {
        ["monitor", "--model", model, recording, "--json", "out.json"]
            .map(str::to_owned)
            .to_vec()
    };
    let cases: [(Vec<String>, &[&str]); 4] = [
        (
            run("other.json", "model.mcap"),
            &["other.json", "heatrun-scada/2"],
        ),
        (run("bare.json", "model.mcap"), &["bare.json", "`model`"]),
        (
            run("model.json", "no_core.mcap"),
            &["no_core.mcap", "core_temp"],
        ),
        (run("model.json", "absent.mcap"), &["absent.mcap"]),
    ];
    for (args, names) in cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        assert_bad_input(d, &args, names);
    }
    let before = std::fs::read(d.join("model.mcap")).unwrap();
    assert_bad_input(
        d,
        &[
            "monitor",
            "--model",
            "model.json",
            "model.mcap",
            "--hold=-1",
            "--json",
            "out.json",
        ],
        &["--hold"],
    );
    assert_eq!(std::fs::read(d.join("model.mcap")).unwrap(), before);
}
