//! `replay --spec`: any thermal system of n states and m inputs, named by its channels.

use crate::common;

use std::path::Path;

use common::{heatrun, heatrun_ok, tempdir, RecordingBuilder};
use heatrun::thermal::matrix::discretize;
use nalgebra::DMatrix;
use serde_json::Value;

/// A two-node network (heater plate and sensor block) in physical units:
/// C = [40, 120] J/K, G_12 = 0.8 W/K, G_10 = 0.5 W/K, G_20 = 0.3 W/K, heater 1 into node 1,
/// heater 2 split 30/70 between the nodes.
fn two_node() -> (DMatrix<f64>, DMatrix<f64>) {
    let c = [40.0, 120.0];
    let (g12, g10, g20) = (0.8, 0.5, 0.3);
    let l = DMatrix::from_row_slice(2, 2, &[g12 + g10, -g12, -g12, g12 + g20]);
    let k = DMatrix::from_row_slice(2, 2, &[1.0, 0.3, 0.0, 0.7]);
    let cinv = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![1.0 / c[0], 1.0 / c[1]]));
    (-&cinv * l, cinv * k)
}

const AMBIENT_C: f64 = 21.0;
const DURATION_S: usize = 4000;

/// Heater commands (%) that step every few minutes, seeded, deterministic.
fn heater_command(seed: u64, k: usize) -> f64 {
    let block = (k / 240) as u64;
    let h =
        (block.wrapping_add(1) * 0x9E37_79B9_7F4A_7C15) ^ seed.wrapping_mul(0xD1B5_4A32_D192_ED03);
    (h >> 40) as f64 / (1u64 << 24) as f64 * 100.0
}

/// A recording of the two-node network: heater commands Q1 (%) and power P2 (W), the two
/// temperatures and a constant ambient, every channel at 1 Hz on the grid instants.
fn recording(path: &Path) -> (DMatrix<f64>, DMatrix<f64>) {
    let (a, b) = two_node();
    let (phi, gamma) = discretize(&a, &b, 1.0);
    let q1: Vec<f64> = (0..DURATION_S).map(|k| heater_command(1, k)).collect();
    let p2: Vec<f64> = (0..DURATION_S)
        .map(|k| 0.02 * heater_command(2, k))
        .collect();
    let mut x = vec![[0.0, 0.0]; DURATION_S];
    for k in 1..DURATION_S {
        let u = [0.01 * q1[k - 1] * 3.0, p2[k - 1]];
        for i in 0..2 {
            x[k][i] = (0..2).map(|j| phi[(i, j)] * x[k - 1][j]).sum::<f64>()
                + (0..2).map(|j| gamma[(i, j)] * u[j]).sum::<f64>();
        }
    }
    let at = |v: Vec<f64>| move |t: f64| v[t.round() as usize];
    let t1: Vec<f64> = x.iter().map(|x| AMBIENT_C + x[0]).collect();
    let t2: Vec<f64> = x.iter().map(|x| AMBIENT_C + x[1]).collect();
    let mut r = RecordingBuilder::new()
        .channel("Q1", "%", 1.0, DURATION_S as f64, at(q1))
        .channel("P2", "W", 1.0, DURATION_S as f64, at(p2))
        .channel("T1", "degC", 1.0, DURATION_S as f64, at(t1))
        .channel("T2", "degC", 1.0, DURATION_S as f64, at(t2))
        .channel("ambient", "degC", 1.0, DURATION_S as f64, |_| AMBIENT_C);
    r.nameplate = None;
    r.write(path);
    (phi, gamma)
}

const SPEC: &str = r#"
name = "two-node test rig"
sample_time_s = 1.0

[[state]]
name = "plate"
channel = "T1"
reference = "ambient"
part = "heater plate"

[[state]]
name = "block"
channel = "T2"
reference = "ambient"
part = "sensor block"

[[input]]
name = "heater_1_power"
expression = "0.01 * Q1 * 3.0"
unit = "W"

[[input]]
name = "heater_2_power"
channel = "P2"
unit = "W"
"#;

fn matrix(v: &Value) -> Vec<Vec<f64>> {
    v.as_array()
        .expect("a matrix")
        .iter()
        .map(|r| {
            r.as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect()
        })
        .collect()
}

#[test]
fn a_spec_identifies_a_known_two_node_network() {
    let dir = tempdir();
    let rec = dir.path().join("rig.mcap");
    let (phi, gamma) = recording(&rec);
    let spec = dir.path().join("rig.toml");
    std::fs::write(&spec, SPEC).unwrap();
    let out = heatrun(
        &[
            "replay",
            rec.to_str().unwrap(),
            "--spec",
            spec.to_str().unwrap(),
            "--report",
            "r.json",
            "--rrd",
            "r.rrd",
        ],
        dir.path(),
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}\n{stdout}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.starts_with("two-node test rig"), "{stdout}");
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("r.json")).unwrap()).unwrap();
    assert_eq!(report["states"], serde_json::json!(["plate", "block"]));
    assert_eq!(
        report["inputs"],
        serde_json::json!(["heater_1_power", "heater_2_power"])
    );
    let (got_phi, got_gamma) = (matrix(&report["phi"]), matrix(&report["gamma"]));
    for i in 0..2 {
        for j in 0..2 {
            assert!(
                (got_phi[i][j] - phi[(i, j)]).abs() < 1e-6,
                "Φ {got_phi:?} vs {phi}"
            );
            let rel = (got_gamma[i][j] - gamma[(i, j)]).abs() / gamma.amax();
            assert!(rel < 1e-5, "Γ {got_gamma:?} vs {gamma}");
        }
    }
    // The steady state in K over the ambient, for the last input: −A⁻¹B u by hand.
    let (a, b) = two_node();
    let u: Vec<f64> = report["steady_state"]["input_pu"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    let ss = -a.try_inverse().unwrap() * b * nalgebra::DVector::from_vec(u);
    let rise = report["steady_state"]["rise_k"].as_array().unwrap();
    let temp = report["steady_state"]["temperature_c"].as_array().unwrap();
    for i in 0..2 {
        assert!((rise[i].as_f64().unwrap() - ss[i]).abs() < 1e-3 * ss[i].abs().max(1.0));
        assert!((temp[i].as_f64().unwrap() - (AMBIENT_C + ss[i])).abs() < 1e-2);
    }
    assert!(
        report.get("nameplate").is_none(),
        "a spec needs no nameplate"
    );
    assert_eq!(report["model"]["states"][0]["part"], "heater plate");
}

#[test]
fn a_spec_naming_an_absent_channel_or_a_bad_key_stops_with_one_line() {
    let dir = tempdir();
    let rec = dir.path().join("rig.mcap");
    recording(&rec);
    for (spec, expect) in [
        (SPEC.replace("channel = \"P2\"", "channel = \"P3\""), "P3"),
        (
            SPEC.replace("part = \"sensor block\"", "colour = \"red\""),
            "colour",
        ),
        (
            SPEC.replace("0.01 * Q1 * 3.0", "0.01 * (Q1"),
            "heater_1_power",
        ),
        (
            SPEC.replace(
                "sample_time_s = 1.0",
                "sample_time_s = 1.0\nmethod = \"bj\"",
            ),
            "method = \"bj\" is not one of oe, pem, rc, iv, rls, wls, ls",
        ),
    ] {
        let path = dir.path().join("bad.toml");
        std::fs::write(&path, spec).unwrap();
        let out = heatrun(
            &[
                "replay",
                rec.to_str().unwrap(),
                "--spec",
                "bad.toml",
                "--rrd",
                "x.rrd",
            ],
            dir.path(),
        );
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{stderr}");
        assert!(stderr.contains(expect), "{expect}: {stderr}");
        assert!(!dir.path().join("x.rrd").exists());
    }
}

/// The ambient of [`drifting_recording`]: a ramp of 2 K over the run and a swing.
fn drifting_ambient_c(t: f64) -> f64 {
    AMBIENT_C + 2.0 * t / DURATION_S as f64 + 0.5 * (2.0 * std::f64::consts::PI * t / 1500.0).sin()
}

/// The two-node network with its reference node, the ambient, drifting: C·dθ/dt =
/// −L·θ + g₀·θ_amb + K·P. Returns Φ and Γ of the rises above any constant, for the
/// inputs [heater 1, heater 2, the ambient's change]: the ambient's column of B_c is
/// C⁻¹g₀ = −A_c·1.
fn drifting_recording(path: &Path) -> (DMatrix<f64>, DMatrix<f64>) {
    let (a, b) = two_node();
    let g = -&a * nalgebra::DVector::from_element(2, 1.0);
    let mut b3 = DMatrix::zeros(2, 3);
    b3.columns_mut(0, 2).copy_from(&b);
    b3.column_mut(2).copy_from(&g);
    let (phi, gamma) = discretize(&a, &b3, 1.0);
    let q1: Vec<f64> = (0..DURATION_S).map(|k| heater_command(3, k)).collect();
    let p2: Vec<f64> = (0..DURATION_S)
        .map(|k| 0.02 * heater_command(4, k))
        .collect();
    // Absolute temperatures, starting where the ambient starts.
    let mut theta = vec![[AMBIENT_C, AMBIENT_C]; DURATION_S];
    for k in 1..DURATION_S {
        let u = [
            0.01 * q1[k - 1] * 3.0,
            p2[k - 1],
            drifting_ambient_c((k - 1) as f64),
        ];
        for i in 0..2 {
            // Φ and Γ act on rises above a constant (here 0 °C): the ambient's column
            // carries the reference node's temperature itself.
            theta[k][i] = (0..2).map(|j| phi[(i, j)] * theta[k - 1][j]).sum::<f64>()
                + (0..3).map(|j| gamma[(i, j)] * u[j]).sum::<f64>();
        }
    }
    let at = |v: Vec<f64>| move |t: f64| v[t.round() as usize];
    let t1: Vec<f64> = theta.iter().map(|x| x[0]).collect();
    let t2: Vec<f64> = theta.iter().map(|x| x[1]).collect();
    let mut r = RecordingBuilder::new()
        .channel("Q1", "%", 1.0, DURATION_S as f64, at(q1))
        .channel("P2", "W", 1.0, DURATION_S as f64, at(p2))
        .channel("T1", "degC", 1.0, DURATION_S as f64, at(t1))
        .channel("T2", "degC", 1.0, DURATION_S as f64, at(t2))
        .channel(
            "ambient",
            "degC",
            1.0,
            DURATION_S as f64,
            drifting_ambient_c,
        );
    r.nameplate = None;
    r.write(path);
    (phi, gamma)
}

#[test]
fn a_spec_measures_states_from_a_reference_channels_initial_level() {
    // The states from the ambient's initial level (`{ initial_of = "ambient" }`, the form
    // the report writes), the ambient's change a boundary input: the drifting reference
    // node is identified exactly, its column of Γ included.
    let dir = tempdir();
    let rec = dir.path().join("drift.mcap");
    let (phi, gamma) = drifting_recording(&rec);
    let spec = SPEC
        .replace("reference = \"ambient\"", "reference = { initial_of = \"ambient\" }")
        + "\n[[input]]\nname = \"ambient_rise\"\nchannel = \"ambient\"\nkind = \"boundary\"\nunit = \"K\"\n";
    std::fs::write(dir.path().join("drift.toml"), &spec).unwrap();
    heatrun_ok(
        &[
            "replay",
            "drift.mcap",
            "--spec",
            "drift.toml",
            "--report",
            "r.json",
            "--rrd",
            "r.rrd",
        ],
        dir.path(),
    );
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("r.json")).unwrap()).unwrap();
    assert_eq!(
        report["model"]["states"][0]["reference"],
        serde_json::json!({ "initial_of": "ambient" })
    );
    assert_eq!(
        report["model"]["inputs"][2]["source"],
        serde_json::json!({ "boundary_rise": "ambient" })
    );
    let (got_phi, got_gamma) = (matrix(&report["phi"]), matrix(&report["gamma"]));
    for i in 0..2 {
        for j in 0..2 {
            assert!(
                (got_phi[i][j] - phi[(i, j)]).abs() < 1e-6,
                "Φ {got_phi:?} vs {phi}"
            );
        }
        for j in 0..3 {
            let rel = (got_gamma[i][j] - gamma[(i, j)]).abs() / gamma.column(j).amax();
            assert!(rel < 1e-4, "Γ {got_gamma:?} vs {gamma}");
        }
    }
    // Rises above the ambient at each instant (`reference = "ambient"`) take its drift for
    // the rig's dynamics: the same data give another Φ.
    std::fs::write(dir.path().join("per_instant.toml"), SPEC).unwrap();
    let out = heatrun(
        &[
            "replay",
            "drift.mcap",
            "--spec",
            "per_instant.toml",
            "--report",
            "p.json",
            "--rrd",
            "p.rrd",
        ],
        dir.path(),
    );
    assert!(out.status.success());
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("p.json")).unwrap()).unwrap();
    let per_instant = matrix(&report["phi"]);
    let off = (0..4)
        .map(|q| (per_instant[q / 2][q % 2] - phi[(q / 2, q % 2)]).abs())
        .fold(0.0, f64::max);
    assert!(off > 1e-4, "Φ {per_instant:?} vs {phi}");
}

/// The two-node rig as a logger that stamps each interval's mean at its end records it:
/// heater 2's value at t_k is the power held over [t_{k−1}, t_k), so it acts within the
/// sample, x(k) = Φ x(k−1) + Γ_2 p2(k); heater 1 acts spread over two samples, 60 % at
/// k − 1 and 40 % at k − 2. Its commands switch every 3 s so the two lags can be told apart.
fn stamped_recording(path: &Path) -> (DMatrix<f64>, DMatrix<f64>) {
    let (a, b) = two_node();
    let (phi, gamma) = discretize(&a, &b, 1.0);
    let n = 1500;
    let q1: Vec<f64> = (0..n).map(|k| heater_command(3, 80 * k)).collect();
    let p2: Vec<f64> = (0..n).map(|k| 0.02 * heater_command(4, 80 * k)).collect();
    let mut x = vec![[0.0, 0.0]; n];
    for k in 1..n {
        let u1 = |j: usize| 0.01 * q1[j] * 3.0;
        let heat1 = 0.6 * u1(k - 1) + 0.4 * u1(k.saturating_sub(2));
        for i in 0..2 {
            x[k][i] = (0..2).map(|j| phi[(i, j)] * x[k - 1][j]).sum::<f64>()
                + gamma[(i, 0)] * heat1
                + gamma[(i, 1)] * p2[k];
        }
    }
    let at = |v: Vec<f64>| move |t: f64| v[t.round() as usize];
    let t1: Vec<f64> = x.iter().map(|x| AMBIENT_C + x[0]).collect();
    let t2: Vec<f64> = x.iter().map(|x| AMBIENT_C + x[1]).collect();
    let mut r = RecordingBuilder::new()
        .channel("Q1", "%", 1.0, n as f64, at(q1))
        .channel("P2", "W", 1.0, n as f64, at(p2))
        .channel("T1", "degC", 1.0, n as f64, at(t1))
        .channel("T2", "degC", 1.0, n as f64, at(t2));
    r.nameplate = None;
    r.write(path);
    (phi, gamma)
}

#[test]
fn an_input_stamped_at_its_intervals_end_is_advanced_and_predicted_one_sample_ahead() {
    let dir = tempdir();
    let (phi, gamma) = stamped_recording(&dir.path().join("stamped.mcap"));
    // Heater 1 at d = 0 and d = 1 (one channel, two inputs), heater 2 advanced one sample.
    let spec = SPEC
        .replace("reference = \"ambient\"", "reference = \"initial\"")
        .replace("sample_time_s = 1.0", "sample_time_s = 1.0\nmethod = \"wls\"")
        + "\n[[input]]\nname = \"heater_1_late\"\nexpression = \"0.01 * Q1 * 3.0\"\nunit = \"W\"\ndelay_s = 1.0\n";
    let spec = spec.replace(
        "channel = \"P2\"\nunit = \"W\"",
        "channel = \"P2\"\nunit = \"W\"\nadvance_s = 1.0",
    );
    std::fs::write(dir.path().join("stamped.toml"), &spec).unwrap();
    let replay = |spec: &str, report: &str| {
        heatrun_ok(
            &[
                "replay",
                "stamped.mcap",
                "--spec",
                spec,
                "--report",
                report,
                "--rrd",
                "r.rrd",
                "-q",
            ],
            dir.path(),
        );
        let text = std::fs::read_to_string(dir.path().join(report)).unwrap();
        serde_json::from_str::<Value>(&text).unwrap()
    };
    let report = replay("stamped.toml", "r.json");
    assert_eq!(report["model"]["inputs"][1]["advance_s"], 1.0);
    assert!(report["model"]["inputs"][1].get("delay_s").is_none());
    assert_eq!(report["model"]["inputs"][2]["delay_s"], 1.0);
    // Φ and Γ come back: heater 1's column split 60/40 over its two lags.
    let (got_phi, got_gamma) = (matrix(&report["phi"]), matrix(&report["gamma"]));
    for i in 0..2 {
        for j in 0..2 {
            assert!(
                (got_phi[i][j] - phi[(i, j)]).abs() < 1e-6,
                "Φ {got_phi:?} vs {phi}"
            );
        }
        for (j, want) in [
            (0, 0.6 * gamma[(i, 0)]),
            (1, gamma[(i, 1)]),
            (2, 0.4 * gamma[(i, 0)]),
        ] {
            let rel = (got_gamma[i][j] - want).abs() / gamma.amax();
            assert!(rel < 1e-5, "Γ {got_gamma:?} vs {gamma}");
        }
    }
    // Without the advance heater 2 is read a sample late: the same data fit worse.
    std::fs::write(
        dir.path().join("late.toml"),
        spec.replace("advance_s = 1.0", ""),
    )
    .unwrap();
    let late = replay("late.toml", "late.json");
    let fit = |r: &Value| r["fit"]["nrmse_fit_percent"][0].as_f64().unwrap();
    assert!(
        fit(&report) > 99.9 && fit(&late) < 99.0,
        "{} {}",
        fit(&report),
        fit(&late)
    );

    // predict reads heater 2 one sample ahead of the schedule: at step k the applied
    // inputs are (u1(k), p2(k + 1), u1(k − 1)), heater 1 holding its first value before.
    let rows: [(f64, f64); 6] = [
        (50.0, 1.0),
        (50.0, 1.0),
        (80.0, 0.0),
        (0.0, 2.0),
        (20.0, 2.0),
        (20.0, 0.5),
    ];
    let mut load = String::from("time_s,Q1,P2\n");
    for (k, (q, p)) in rows.iter().enumerate() {
        load.push_str(&format!("{k},{q},{p}\n"));
    }
    std::fs::write(dir.path().join("load.csv"), load).unwrap();
    heatrun_ok(
        &[
            "predict",
            "--model",
            "r.json",
            "--load",
            "load.csv",
            "--out",
            "pred.csv",
            "--initial-temps",
            "21,21",
        ],
        dir.path(),
    );
    let pred = std::fs::read_to_string(dir.path().join("pred.csv")).unwrap();
    let predicted: Vec<Vec<f64>> = pred
        .lines()
        .skip(1)
        // Each `<state>_c`, its band's two columns after it.
        .map(|l| {
            l.split(',')
                .skip(1)
                .step_by(3)
                .map(|v| v.parse().unwrap())
                .collect()
        })
        .collect();
    let u1 = |k: usize| 0.01 * rows[k.min(rows.len() - 1)].0 * 3.0;
    let p2 = |k: usize| rows[k.min(rows.len() - 1)].1;
    let mut x = [0.0, 0.0];
    for (k, row) in predicted.iter().enumerate() {
        for i in 0..2 {
            assert!((row[i] - (21.0 + x[i])).abs() < 1e-3, "step {k}: {pred}");
        }
        let u = [u1(k), p2(k + 1), u1(k.saturating_sub(1))];
        x = [0, 1].map(|i| {
            (0..2).map(|j| got_phi[i][j] * x[j]).sum::<f64>()
                + (0..3).map(|j| got_gamma[i][j] * u[j]).sum::<f64>()
        });
    }
    assert_eq!(predicted.len(), rows.len(), "{pred}");

    // monitor, streamed in stretches of 7 s, reads heater 2 one sample ahead across every
    // stretch's end as the whole-file monitor does, and the exact model stays on the data.
    use crate::common::oracle as batch;
    use heatrun::monitor::{self, MonitorOptions, Source, StreamOptions, Watchers};
    let model = heatrun::model_file::ThermalModel::read(&dir.path().join("r.json")).unwrap();
    let recording = dir.path().join("stamped.mcap");
    let options = MonitorOptions::default();
    let whole = batch::monitor_whole_file(&model, &recording, &options).unwrap();
    let stream = StreamOptions {
        stretch_s: 7.0,
        ..StreamOptions::default()
    };
    let source = Source::File(&recording);
    let streamed =
        monitor::monitor_stream(&model, source, &options, &stream, Watchers::default()).unwrap();
    assert_eq!(streamed.traces.time_ns, whole.traces.time_ns);
    assert_eq!((streamed.restarts, whole.restarts), (1, 1));
    for j in 0..2 {
        for k in 0..whole.traces.time_ns.len() {
            let (a, b) = (
                streamed.traces.predicted[j].get(k),
                whole.traces.predicted[j].get(k),
            );
            assert!(
                (a.unwrap() - b.unwrap()).abs() < 1e-9,
                "state {j} at {k} s: {a:?} {b:?}"
            );
            assert!(
                streamed.traces.residual(j, k).unwrap().abs() < 1e-3,
                "state {j} at {k} s"
            );
        }
    }
}
