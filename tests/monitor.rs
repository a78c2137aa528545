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
/// hold (docs/src/guide/monitoring.md): the hold (600 s) plus up to 600 s for the residual to
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

/// A cooler fouling 30 % at [`FAULT_AT_S`] in a run made with `extra` (`--seed` and the
/// run's own conditions), monitored with `model`: flagged ([`assert_fault_flagged`]).
fn assert_fouling_flagged(dir: &Path, model: &str, extra: &[&str]) {
    let fault = FAULT_AT_S.to_string();
    let mut args = extra.to_vec();
    args.extend_from_slice(&["--fault-at", &fault, "--fault-conductance-drop", "0.3"]);
    synth(dir, "fault.mcap", &args);
    let (status, doc, stdout) = monitor(dir, model, "fault.mcap");
    assert_fault_flagged(status, &doc, &stdout);
}

/// A model identified from a run made with `extra` ([`identify`], `model.json`), whose
/// report names `input` among its inputs: the condition the run varied is carried.
fn identify_carrying(dir: &Path, extra: &[&str], input: &str) {
    identify(dir, "model.mcap", extra, "model.json");
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("model.json")).unwrap()).unwrap();
    assert!(
        report["inputs"]
            .as_array()
            .unwrap()
            .iter()
            .any(|i| i == input),
        "{input} not in {}",
        report["inputs"]
    );
}

/// `recording` monitored with `model`: exit 0 and no alarm. The monitor's document.
fn assert_quiet(dir: &Path, model: &str, recording: &str) -> Value {
    let (status, doc, stdout) = monitor(dir, model, recording);
    assert_eq!(status, Some(0), "{recording}: {stdout}");
    assert!(alarms(&doc).is_empty(), "{recording}: {stdout}");
    doc
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
    assert_fouling_flagged(d, "model.json", &["--seed", "3"]);
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

/// The shipped fixture's model was identified from a noise-free run: it knows no sensor
/// noise, so a band from what it knows would be about 0 K (every sample of a real
/// recording an alarm: 100 % outside before). It keeps the fixed band and says why; a noisy
/// run of the same machine is healthy.
#[test]
fn a_model_from_noise_free_data_keeps_the_fixed_band_and_says_why() {
    let dir = common::tempdir();
    let fixture = common::package_root().join("fixtures/paper_heat_run.mcap");
    common::heatrun_ok(
        &[
            "replay",
            fixture.to_str().unwrap(),
            "--report",
            "model.json",
            "-q",
        ],
        dir.path(),
    );
    common::heatrun_ok(
        &[
            "synth",
            "later.mcap",
            "--temperature-noise",
            "0.05",
            "--seed",
            "3",
        ],
        dir.path(),
    );
    let json = "later.json";
    let out = common::heatrun(
        &[
            "monitor",
            "--model",
            "model.json",
            "later.mcap",
            "--json",
            json,
        ],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(
        stderr.contains("the model reproduces its own recording exactly")
            && stderr.contains("the fixed band max(4 × RMSE, 0.5 K) is used instead"),
        "{stderr}"
    );
    let doc: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join(json)).unwrap()).unwrap();
    assert_eq!(doc["band"]["kind"], "fixed", "{}", doc["band"]);
    assert!(alarms(&doc).is_empty());
}

#[test]
fn a_coolant_referenced_model_follows_a_drifting_inlet_and_flags_the_fault() {
    let dir = common::tempdir();
    let d = dir.path();
    // The inlet drifts 3 K over a day: the replay measures the rises from the inlet's
    // initial level and takes its drift as an input.
    let drifting = ["--inlet-drift", "3"];
    identify_carrying(
        d,
        &["--seed", "6", drifting[0], drifting[1]],
        "cooling_water_inlet_rise",
    );
    synth(d, "drift.mcap", &["--seed", "5", drifting[0], drifting[1]]);
    let doc = assert_quiet(d, "model.json", "drift.mcap");
    // The model carries the drift: nothing to warn about.
    assert_eq!(
        doc["warnings"],
        serde_json::json!([]),
        "{}",
        doc["warnings"]
    );
    assert_fouling_flagged(
        d,
        "model.json",
        &[
            "--seed",
            "7",
            drifting[0],
            drifting[1],
            "--profile",
            "single-step",
        ],
    );
}

/// A model that carries the cooling-water flow (identified on a run whose pump switched to
/// 0.6 of the flow) follows a later run whose pump switches at another time and to another
/// flow, and still flags a fouled cooler; `predict` runs it at the test's initial flow
/// and says so.
#[test]
fn a_model_carrying_the_flow_follows_a_pump_switch_and_flags_the_fault() {
    let dir = common::tempdir();
    let d = dir.path();
    identify_carrying(
        d,
        &["--seed", "8", "--pump-switch", "10000:0.6"],
        "cooling_water_flow_heat",
    );
    let later = ["--pump-switch", "6000:0.75"];
    synth(d, "pump.mcap", &["--seed", "9", later[0], later[1]]);
    assert_quiet(d, "model.json", "pump.mcap");
    assert_fouling_flagged(d, "model.json", &["--seed", "10", later[0], later[1]]);

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
            // The band the whole-file oracle below sets.
            "--band",
            "fixed",
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
            // The band as the detector used it, at every instant.
            "residual/{s}/band_upper",
            "residual/{s}/band_lower",
        ] {
            let entity = format!("/monitor/{}", e.replace("{s}", state));
            assert_eq!(rows.get(&entity), Some(&instants), "{entity}: {rows:?}");
        }
    }
    let alarm = rows["/monitor/residual/cooling_water_outlet_temp/alarm"];
    // From the first instant outside the band (after the fault at 1800 s) to the end.
    assert!(
        alarm > 600 && alarm <= 7200 - 1800,
        "{alarm} instants in alarm"
    );
    // Drawn a stretch at a time as the alarms became known: exactly the instants the
    // whole-file monitor puts inside an alarm.
    let model = heatrun::model_file::ThermalModel::read(&d.join("model.json")).unwrap();
    let options = heatrun::monitor::MonitorOptions::default();
    let whole =
        common::oracle::monitor_whole_file(&model, &d.join("fault.mcap"), &options).unwrap();
    for (j, state) in whole.states.iter().enumerate() {
        let t = &whole.traces;
        let in_alarm = (0..t.time_ns.len())
            .filter(|&k| {
                let now = t.time_ns[k];
                t.residual(j, k).is_some()
                    && whole.alarms.iter().any(|a| {
                        a.state == j && now >= a.start_ns && a.end_ns.is_none_or(|e| now < e)
                    })
            })
            .count();
        let drawn = rows
            .get(&format!("/monitor/residual/{state}/alarm"))
            .copied()
            .unwrap_or(0);
        assert_eq!(drawn, in_alarm, "{state}");
    }
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
    // Channels without a sample.
    common::RecordingBuilder::heat_run(0.0, "").write(&d.join("empty.mcap"));
    let cases: [(Vec<String>, &[&str]); 5] = [
        (
            run("other.json", "model.mcap"),
            &["other.json", "heatrun-scada/2"],
        ),
        (
            run("model.json", "empty.mcap"),
            &["empty.mcap", "no heat-run samples"],
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
    let stretch = [
        "monitor",
        "--model",
        "model.json",
        "model.mcap",
        "--stretch=0",
        "--json",
        "out.json",
    ];
    assert_bad_input(d, &stretch, &["--stretch"]);
    assert_eq!(std::fs::read(d.join("model.mcap")).unwrap(), before);
}

/// A recording read back into a builder (its channels, samples and nameplate), to be
/// written again with samples removed or moved.
fn load(path: &Path) -> common::RecordingBuilder {
    let bytes = std::fs::read(path).unwrap();
    let mut r = common::RecordingBuilder::new();
    r.nameplate = None;
    let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
    for index in &summary.metadata_indexes {
        let m = mcap::read::metadata(&bytes, index).unwrap();
        if m.name == "heatrun.nameplate" {
            r.nameplate = Some(m.metadata);
        }
    }
    let mut channel: std::collections::BTreeMap<String, usize> = Default::default();
    for msg in mcap::MessageStream::new(&bytes).unwrap() {
        let msg = msg.unwrap();
        let topic = msg.channel.topic.clone();
        let i = *channel.entry(topic.clone()).or_insert_with(|| {
            r.channels
                .push((topic, msg.channel.metadata.clone(), Vec::new()));
            r.channels.len() - 1
        });
        let text = String::from_utf8(msg.data.to_vec()).unwrap();
        r.channels[i].2.push((msg.log_time, text));
    }
    r
}

/// The first sample time of a recording, ns.
fn start_ns(r: &common::RecordingBuilder) -> u64 {
    r.channels
        .iter()
        .flat_map(|c| c.2.iter().map(|s| s.0))
        .min()
        .unwrap()
}

/// Drops the samples of the channels whose topic ends with one of `quantities` (all
/// channels where empty) between `from_s` and `to_s` after the start.
fn cut(r: &mut common::RecordingBuilder, quantities: &[&str], from_s: u64, to_s: u64) {
    let t0 = start_ns(r);
    let (from, to) = (t0 + from_s * 1_000_000_000, t0 + to_s * 1_000_000_000);
    for (topic, _, samples) in r.channels.iter_mut() {
        if quantities.is_empty() || quantities.iter().any(|q| topic.ends_with(q)) {
            samples.retain(|s| s.0 < from || s.0 >= to);
        }
    }
}

/// Each sealed stretch's first and last instant and the samples read when it was sealed.
#[derive(Default)]
struct Seen(Vec<(i64, i64, u64)>);

impl heatrun::monitor::StretchObserver for Seen {
    fn stretch(
        &mut self,
        s: &heatrun::monitor::Stretch<'_>,
    ) -> Result<(), heatrun::monitor::ObserverError> {
        assert_eq!(s.measured[0].len(), s.time_ns.len());
        self.0
            .push((s.time_ns[0], *s.time_ns.last().unwrap(), s.samples_read));
        Ok(())
    }
}

/// Monitors `recording` streamed (stretches of `stretch_s`) and, as the oracle, whole;
/// asserts the same instants, alarms, residual statistics (to 1e-9 K) and restarts, and
/// stretches that follow each other on the grid. The stream's result and stretches.
fn streamed_as_whole(
    model: &Path,
    recording: &Path,
    stretch_s: f64,
) -> (heatrun::monitor::MonitorResult, Vec<(i64, i64, u64)>) {
    use crate::common::oracle as batch;
    use heatrun::monitor::{self, MonitorOptions, Source, StreamOptions, Watchers};
    let model = heatrun::model_file::ThermalModel::read(model).unwrap();
    let options = MonitorOptions::default();
    let whole = batch::monitor_whole_file(&model, recording, &options).unwrap();
    let mut seen = Seen::default();
    let stream = StreamOptions {
        stretch_s,
        ..StreamOptions::default()
    };
    let watchers = Watchers {
        observer: Some(&mut seen),
        ..Default::default()
    };
    let source = Source::File(recording);
    let streamed = monitor::monitor_stream(&model, source, &options, &stream, watchers).unwrap();
    let name = recording.display();
    assert_eq!(streamed.traces.time_ns, whole.traces.time_ns, "{name}");
    // Every instant's measured and predicted temperature (to rounding).
    let t = &whole.traces;
    for j in 0..t.measured.len() {
        for (series, of) in [
            (&streamed.traces.measured[j], &t.measured[j]),
            (&streamed.traces.predicted[j], &t.predicted[j]),
        ] {
            for k in 0..t.time_ns.len() {
                let (a, b) = (series.get(k), of.get(k));
                let same = match (a, b) {
                    (Some(a), Some(b)) => (a - b).abs() < 1e-9,
                    (a, b) => a == b,
                };
                assert!(same, "{name}: state {j} at {} s: {a:?} vs {b:?}", k);
            }
        }
    }
    assert_eq!(streamed.restarts, whole.restarts, "{name}");
    assert_eq!(streamed.alarms.len(), whole.alarms.len(), "{name}");
    for (a, b) in streamed.alarms.iter().zip(&whole.alarms) {
        assert_eq!(
            (a.state, a.start_ns, a.raised_ns, a.end_ns, a.peak_ns),
            (b.state, b.start_ns, b.raised_ns, b.end_ns, b.peak_ns),
            "{name}"
        );
        assert!((a.peak_deviation_k - b.peak_deviation_k).abs() < 1e-9);
    }
    for (a, b) in streamed.stats.iter().zip(&whole.stats) {
        assert_eq!(a.instants, b.instants, "{name}");
        for (x, y) in [
            (a.mean_k, b.mean_k),
            (a.rms_k, b.rms_k),
            (a.max_deviation_k, b.max_deviation_k),
            (a.outside_fraction, b.outside_fraction),
        ] {
            assert!((x - y).abs() < 1e-9, "{name}: {a:?} vs {b:?}");
        }
    }
    assert_eq!(streamed.warnings, whole.warnings, "{name}");
    // Every instant of the grid in exactly one stretch, in time order.
    let ts_ns = (model.ts_s * 1e9).round() as i64;
    let stretches = seen.0;
    assert_eq!(stretches[0].0, whole.traces.time_ns[0], "{name}");
    assert_eq!(
        stretches.last().unwrap().1,
        *whole.traces.time_ns.last().unwrap()
    );
    for pair in stretches.windows(2) {
        assert_eq!(pair[1].0, pair[0].1 + ts_ns, "{name}: {pair:?}");
        assert!(pair[1].2 >= pair[0].2);
    }
    (streamed, stretches)
}

/// The streamed monitor gives the whole-file monitor's result (the oracle) on healthy,
/// fouled, gapped and stored-by-exception recordings, at the default stretch and at an
/// odd short one; it publishes its first stretch early in the file; samples that come
/// after their instant was monitored are counted as data loss, not fatal.
#[test]
fn the_streamed_monitor_is_live_and_gives_the_whole_file_result() {
    let dir = common::tempdir();
    let d = dir.path();
    identify(d, "model.mcap", &["--seed", "1"], "model.json");
    let fault = FAULT_AT_S.to_string();
    let faulty = ["--fault-at", &fault, "--fault-conductance-drop", "0.3"];
    synth(
        d,
        "healthy.mcap",
        &["--seed", "2", "--profile", "single-step"],
    );
    synth(
        d,
        "fault.mcap",
        &[&["--seed", "3"][..], &faulty[..]].concat(),
    );
    let exception = ["--seed", "4", "--deadband", "0.1", "--heartbeat", "60"];
    synth(d, "exception.mcap", &[&exception[..], &faulty[..]].concat());
    // Gaps: every channel for 10 minutes, the stator winding's sensor for 2 hours.
    let mut gapped = load(&d.join("fault.mcap"));
    cut(&mut gapped, &[], 5_000, 5_600);
    cut(&mut gapped, &["stator_winding_temp"], 12_000, 19_200);
    gapped.write(&d.join("gapped.mcap"));
    let model = d.join("model.json");
    for name in [
        "healthy.mcap",
        "fault.mcap",
        "exception.mcap",
        "gapped.mcap",
    ] {
        let recording = d.join(name);
        let (result, stretches) = streamed_as_whole(&model, &recording, 600.0);
        assert_eq!(result.healthy(), name == "healthy.mcap", "{name}");
        // Liveness: a 5.8-hour recording, the first stretch out when about a tenth of it
        // was read (ten minutes of grid, the ten minutes its initial levels need).
        let all = stretches.last().unwrap().2;
        assert!(
            (stretches[0].2 as f64) < 0.15 * all as f64,
            "{name}: first stretch after {} of {all} samples",
            stretches[0].2
        );
        assert!(
            stretches.len() >= 30,
            "{name}: {} stretches",
            stretches.len()
        );
        streamed_as_whole(&model, &recording, 97.0);
    }
    let gapped = streamed_as_whole(&model, &d.join("gapped.mcap"), 600.0).0;
    assert!(gapped.restarts >= 1, "{}", gapped.restarts);

    // Late: 100 s of the core's samples stored at the end of the file.
    let late = load(&d.join("healthy.mcap"));
    let t0 = start_ns(&late);
    let mut order: Vec<(usize, usize, u64)> = Vec::new();
    let core = late.channel_of("core_temp");
    let (from, to) = (t0 + 3_600_000_000_000, t0 + 3_700_000_000_000);
    let moved = |c: usize, t: u64| c == core && (from..to).contains(&t);
    for (c, (_, _, samples)) in late.channels.iter().enumerate() {
        for (i, (t, _)) in samples.iter().enumerate() {
            order.push((c, i, *t));
        }
    }
    order.sort_by_key(|&(c, _, t)| (moved(c, t), t));
    let expected = order.iter().filter(|&&(c, _, t)| moved(c, t)).count();
    assert!(expected >= 10, "{expected}");
    late.write_in_order(&d.join("late.mcap"), &order);
    let out = common::heatrun(&["monitor", "--model", "model.json", "late.mcap"], d);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "{stderr}");
    let line = format!(
        "warning: data lost: {expected} samples of channel /scada/core_temp arrived after \
         their instant was monitored"
    );
    assert!(stderr.contains(&line), "{stderr}");

    // A reading far below zero, judged faulty only at the end of the file, after its
    // instant was monitored: counted the same way.
    let mut faulty = load(&d.join("healthy.mcap"));
    let current = faulty.channel_of("armature_current");
    faulty.channels[current].2[3600].1 = "{\"value\":-3}".into();
    faulty.write(&d.join("faulty.mcap"));
    let out = common::heatrun(&["monitor", "--model", "model.json", "faulty.mcap"], d);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "{stderr}");
    assert!(
        stderr.contains(
            "warning: data lost: 1 samples of channel /scada/armature_current were found \
             faulty at the end of the file after their instant was monitored"
        ),
        "{stderr}"
    );
}

/// The model carrying the cooling-water flow (its input smoothed over ±30 s around each
/// instant, from the flow's initial level Q₀) streamed gives the whole file's result; so
/// does a recording read from standard input.
#[test]
fn a_flow_carrying_model_streamed_and_standard_input_give_the_whole_file_result() {
    let dir = common::tempdir();
    let d = dir.path();
    identify(
        d,
        "model.mcap",
        &["--seed", "8", "--pump-switch", "10000:0.6"],
        "model.json",
    );
    let fault = FAULT_AT_S.to_string();
    let pump = [
        "--seed",
        "9",
        "--pump-switch",
        "7000:0.7",
        "--fault-at",
        &fault,
        "--fault-conductance-drop",
        "0.3",
    ];
    synth(d, "pump.mcap", &pump);
    let model = d.join("model.json");
    let (result, _) = streamed_as_whole(&model, &d.join("pump.mcap"), 600.0);
    assert!(!result.healthy());
    streamed_as_whole(&model, &d.join("pump.mcap"), 97.0);
    // The same file from standard input: the same document.
    let (status, file_doc, _) = monitor(d, "model.json", "pump.mcap");
    let stdin = std::fs::File::open(d.join("pump.mcap")).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_heatrun"))
        .args([
            "monitor",
            "--model",
            "model.json",
            "-",
            "--json",
            "stdin.json",
        ])
        .current_dir(d)
        .stdin(stdin)
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        status,
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdin_doc: Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("stdin.json")).unwrap()).unwrap();
    assert_eq!(stdin_doc["alarms"], file_doc["alarms"]);
    assert_eq!(stdin_doc["parts"], file_doc["parts"]);
}
