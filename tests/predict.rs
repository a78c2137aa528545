//! `heatrun predict` and `heatrun rating` on a model identified from a noisy synthetic
//! heat run, against the truth simulated from the truth file's matrices; bad load files.

use std::path::Path;

use crate::common;

use heatrun::losses;
use heatrun::recording::Nameplate;
use heatrun::synth::{self, SynthOptions, Truth};

/// The synthetic machine (the paper's model, the default heat run) at PT100-like noise
/// (σ = 0.05 K, 0.01 K resolution, 0.05 % on the electrical channels), seed 11, replayed
/// into a report by the CLI (oe). Returns the folder, the truth and the report's path.
fn identified_model() -> (tempfile::TempDir, Truth, std::path::PathBuf) {
    let dir = common::tempdir();
    let run = dir.path().join("heat_run.mcap");
    let options = SynthOptions {
        seed: 11,
        ..SynthOptions::default().with_noise_level(1.0)
    };
    let truth = synth::write(&run, &options).unwrap();
    common::heatrun_ok(
        &["replay", "heat_run.mcap", "--report", "model.json", "-q"],
        dir.path(),
    );
    let report = dir.path().join("model.json");
    (dir, truth, report)
}

/// A day the heat run never saw, in pu of the rated values (I_g, U_g, I_f) per quarter
/// hour: a night at low load, a morning ramp, a day near rated load with an overload hour
/// (116 % current, 17:00 to 18:00) and an evening at partial load.
fn daily_cycle() -> Vec<(f64, f64, f64, f64)> {
    (0..=96)
        .map(|q| {
            let h = q as f64 / 4.0;
            let (i, u, f) = match h {
                h if h < 6.0 => (0.35, 1.00, 0.78),
                h if h < 9.0 => (
                    0.35 + 0.55 * (h - 6.0) / 3.0,
                    1.02,
                    0.85 + 0.1 * (h - 6.0) / 3.0,
                ),
                h if h < 17.0 => (0.90, 1.04, 1.02),
                h if h < 18.0 => (1.16, 1.05, 1.18),
                h if h < 22.0 => (0.70, 1.01, 0.92),
                _ => (0.45, 1.00, 0.80),
            };
            (h * 3600.0, i, u, f)
        })
        .collect()
}

fn write_load(path: &Path, np: &Nameplate, cycle: &[(f64, f64, f64, f64)]) {
    let mut text = String::from("time_s,armature_current_a,field_current_a,line_voltage_kv\n");
    let i_fn = np.rated_field_current_a.unwrap();
    for (t, i, u, f) in cycle {
        text.push_str(&format!(
            "{t},{},{},{}\n",
            i * np.rated_current_a,
            f * i_fn,
            u * np.rated_voltage_v / 1e3
        ));
    }
    std::fs::write(path, text).unwrap();
}

/// The truth on the same schedule: x(k+1) = Φ x(k) + Γ u(k) with the truth file's Φ, Γ,
/// the loss model at the true temperatures, and synth's field winding temperature with a
/// field_voltage channel, θ_f = θ_Cu0 + s·(θ_Cu − θ_Cu0), s = (81 − θ_Cu0) / 26.3.
fn true_temperatures(
    truth: &Truth,
    np: &Nameplate,
    cycle: &[(f64, f64, f64, f64)],
) -> Vec<[f64; 3]> {
    let th0 = &truth.initial_temperatures_c;
    let s = (np.field_winding_final_temp_c.unwrap() - th0[0]) / 26.3;
    let base = np.temperature_base_k;
    let end = cycle.last().unwrap().0 as usize;
    let mut x = [0.0; 3];
    let mut out = Vec::with_capacity(end + 1);
    for k in 0..=end {
        let theta = [0, 1, 2].map(|j| th0[j] + base * x[j]);
        out.push(theta);
        let row = cycle.iter().rev().find(|r| r.0 <= k as f64).unwrap();
        let theta_f = th0[0] + s * (theta[0] - th0[0]);
        let u = [
            losses::armature_copper_loss_w(np, row.1 * np.rated_current_a, theta[0]),
            losses::field_copper_loss_w(np, row.3 * np.rated_field_current_a.unwrap(), theta_f),
            losses::iron_loss_w(np, row.2 * np.rated_voltage_v),
        ]
        .map(|p| p / np.rated_apparent_power_va);
        x = [0, 1, 2].map(|i| {
            (0..3)
                .map(|j| truth.phi[i][j] * x[j] + truth.gamma[i][j] * u[j])
                .sum()
        });
    }
    out
}

fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_owned)
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

#[test]
fn predict_follows_the_truth_within_1_k_on_a_day_the_model_never_saw_and_rating_holds() {
    let (dir, truth, _) = identified_model();
    let np = Nameplate::paper_table1();
    let cycle = daily_cycle();
    write_load(&dir.path().join("day.csv"), &np, &cycle);
    common::heatrun_ok(
        &[
            "predict",
            "--model",
            "model.json",
            "--load",
            "day.csv",
            "--out",
            "pred.csv",
        ],
        dir.path(),
    );
    let (header, rows) = read_csv(&dir.path().join("pred.csv"));
    // Each temperature, derived ones too, followed by its 95 % band.
    let parts = [
        "stator_winding_temp",
        "core_temp",
        "cooling_water_outlet_temp",
        "field_winding_temp",
    ];
    let mut expected = vec!["time_s".to_owned()];
    for p in parts {
        expected.extend([
            format!("{p}_c"),
            format!("{p}_c_lo95"),
            format!("{p}_c_hi95"),
        ]);
    }
    assert_eq!(header, expected);
    for row in &rows {
        for c in 0..parts.len() {
            let (v, lo, hi) = (row[1 + 3 * c], row[2 + 3 * c], row[3 + 3 * c]);
            assert!(lo <= v && v <= hi, "{row:?}");
        }
    }
    let want = true_temperatures(&truth, &np, &cycle);
    assert_eq!(rows.len(), want.len(), "one row a second over the day");
    let mut worst = [0.0f64; 3];
    for (row, theta) in rows.iter().zip(&want) {
        for j in 0..3 {
            worst[j] = worst[j].max((row[1 + 3 * j] - theta[j]).abs());
        }
    }
    eprintln!("largest |predicted − true| over the day, K: {worst:?}");
    assert!(worst.iter().all(|w| *w < 1.0), "{worst:?}");
    // The overload hour shows: the stator winding is hottest at its end.
    let peak = rows.iter().max_by(|a, b| a[1].total_cmp(&b[1])).unwrap();
    assert!(
        (peak[0] - 18.0 * 3600.0).abs() <= 1.0,
        "peak at {} s",
        peak[0]
    );

    rating_holds_against_predict(dir.path());
}

/// Holding the rating's largest continuous power for ten slowest time constants brings
/// the limiting part to its limit within 0.5 K and keeps the others below theirs.
fn rating_holds_against_predict(dir: &Path) {
    common::heatrun_ok(
        &[
            "rating",
            "--model",
            "model.json",
            "--class",
            "F",
            "--json",
            "rating.json",
        ],
        dir,
    );
    let rating: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("rating.json")).unwrap()).unwrap();
    let s_max = rating["max_continuous_apparent_power_mva"]
        .as_f64()
        .unwrap();
    let limiting = rating["limiting_state"].as_str().unwrap().to_owned();
    let pf = rating["power_factor"].as_f64().unwrap();
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("model.json")).unwrap()).unwrap();
    let slowest = report["time_constants_s"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t.as_f64().unwrap())
        .fold(0.0, f64::max);
    let hold = (10.0 * slowest).ceil();
    std::fs::write(
        dir.join("hold.csv"),
        format!("time_s,apparent_power_mva,power_factor\n0,{s_max},{pf}\n{hold},{s_max},{pf}\n"),
    )
    .unwrap();
    common::heatrun_ok(
        &[
            "predict",
            "--model",
            "model.json",
            "--load",
            "hold.csv",
            "--out",
            "hold_pred.csv",
            "-q",
        ],
        dir,
    );
    let (header, rows) = read_csv(&dir.join("hold_pred.csv"));
    let last = rows.last().unwrap();
    for part in rating["limits"].as_array().unwrap() {
        let name = part["name"].as_str().unwrap();
        let limit = part["limit_c"].as_f64().unwrap();
        let column = header
            .iter()
            .position(|h| *h == format!("{name}_c"))
            .unwrap();
        let theta = last[column];
        if name == limiting {
            assert!(
                (theta - limit).abs() < 0.5,
                "{name}: {theta} °C vs limit {limit} °C"
            );
        } else {
            assert!(
                theta < limit,
                "{name}: {theta} °C over its limit {limit} °C"
            );
        }
    }
    // Short-time ratings: a larger overload never lasts longer.
    let times: Vec<f64> = rating["overloads"]
        .as_array()
        .unwrap()
        .iter()
        .map(|o| o["time_to_limit_s"].as_f64().unwrap_or(f64::INFINITY))
        .collect();
    assert!(times.windows(2).all(|w| w[1] <= w[0]), "{times:?}");
}

/// Bad load files and model reports: exit 2, one line naming the file and the row and
/// column (or the key), and no prediction written.
#[test]
fn bad_load_files_and_reports_are_one_line_naming_row_and_column() {
    let dir = common::tempdir();
    let d = dir.path();
    let fixture = common::package_root().join("fixtures/paper_heat_run.mcap");
    common::heatrun_ok(
        &[
            "replay",
            fixture.to_str().unwrap(),
            "--report",
            "model.json",
            "--rrd",
            "model.rrd",
            "-q",
        ],
        d,
    );
    let mut report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("model.json")).unwrap()).unwrap();
    report["profile"] = "heatrun-scada/9".into();
    std::fs::write(d.join("other.json"), report.to_string()).unwrap();
    let header = "time_s,armature_current_a,field_current_a,line_voltage_kv";
    let files = [
        (
            "unknown.csv",
            format!("{header},fan_speed\n0,3000,1000,15.6,1\n"),
            "model.json",
            &["unknown.csv", "row 1", "column `fan_speed`"][..],
        ),
        (
            "cell.csv",
            format!("{header}\n0,3000,1000,15.6\n600,3000,lots,15.6\n"),
            "model.json",
            &["cell.csv", "row 3", "column `field_current_a`", "`lots`"][..],
        ),
        (
            "backwards.csv",
            format!("{header}\n0,3000,1000,15.6\n600,3000,1000,15.6\n300,3000,1000,15.6\n"),
            "model.json",
            &["backwards.csv", "row 4", "column `time_s`", "300"][..],
        ),
        (
            "good.csv",
            format!("{header}\n0,3000,1000,15.6\n600,3000,1000,15.6\n"),
            "other.json",
            &["other.json", "profile `heatrun-scada/9`"][..],
        ),
    ];
    for (name, text, model, expected) in files {
        std::fs::write(d.join(name), &text).unwrap();
        let out = common::heatrun(
            &[
                "predict", "--model", model, "--load", name, "--out", "pred.csv",
            ],
            d,
        );
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{name}: {stderr}");
        assert_eq!(stderr.trim_end().lines().count(), 1, "{name}: {stderr}");
        for e in expected {
            assert!(stderr.contains(e), "{name}: `{e}` not in {stderr}");
        }
        assert!(
            !d.join("pred.csv").exists(),
            "{name}: an output was written"
        );
        assert_eq!(std::fs::read_to_string(d.join(name)).unwrap(), text);
    }
}

/// `predict --rrd`: the schedule, the losses and the temperatures with the class's limits.
#[test]
fn predict_publishes_the_schedule_losses_and_temperatures_with_limits() {
    let dir = common::tempdir();
    let d = dir.path();
    let fixture = common::package_root().join("fixtures/paper_heat_run.mcap");
    let fixture = fixture.to_str().unwrap();
    let args = [
        "replay",
        fixture,
        "--report",
        "model.json",
        "--rrd",
        "m.rrd",
        "-q",
    ];
    common::heatrun_ok(&args, d);
    let day = "time_s,apparent_power_mva,power_factor\n0,60,0.9\n3600,115,0.9\n7200,80,0.9\n";
    std::fs::write(d.join("day.csv"), day).unwrap();
    common::heatrun_ok(
        &[
            "predict",
            "--model",
            "model.json",
            "--load",
            "day.csv",
            "--out",
            "pred.csv",
            "--rrd",
            "pred.rrd",
            "--class",
            "F",
            "-q",
        ],
        d,
    );
    let (rows, blueprint) = crate::outputs::rows_per_entity(&d.join("pred.rrd"));
    assert!(blueprint);
    let instants = 7201;
    for e in [
        "temperature/stator_winding_temp",
        "temperature/core_temp",
        "temperature/cooling_water_outlet_temp",
        "temperature/field_winding_temp",
        "losses/armature_copper_loss",
        "losses/field_copper_loss",
        "losses/iron_loss",
        "schedule/currents/armature_current",
        "schedule/voltage/line_voltage",
    ] {
        let entity = format!("/prediction/{e}");
        assert_eq!(rows.get(&entity), Some(&instants), "{entity}: {rows:?}");
    }
    // Class F: the stator winding, the core and the derived field winding have limits.
    for part in ["stator_winding_temp", "core_temp", "field_winding_temp"] {
        let entity = format!("/prediction/temperature/{part}_limit");
        assert_eq!(rows.get(&entity), Some(&2), "{entity}: {rows:?}");
    }
    assert!(!rows.contains_key("/prediction/temperature/cooling_water_outlet_temp_limit"));
}

/// Rows of a load schedule from a recording (its electrical channels and, with
/// `inlet`, its coolant inlet every `every_s`), and its temperatures at those rows.
fn schedule_of(recording: &Path, every_s: usize, inlet: bool) -> (String, Vec<(f64, Vec<f64>)>) {
    use heatrun::recording::Quantity;
    let prepared = heatrun::pipeline::prepare(recording, &Default::default()).unwrap();
    let d = &prepared.decimated;
    let at = |q: Quantity, k: usize| d.get(q).unwrap().values.get(k).unwrap();
    let mut text = String::from("time_s,armature_current_a,field_current_a,line_voltage_kv");
    if inlet {
        text.push_str(",coolant_inlet_temp_c");
    }
    text.push('\n');
    let states = [
        Quantity::StatorWindingTemp,
        Quantity::CoreTemp,
        Quantity::CoolingWaterOutletTemp,
    ];
    let mut truth = Vec::new();
    for k in (0..d.len).step_by(every_s) {
        let t = k as f64 * d.ts_s();
        text.push_str(&format!(
            "{t},{},{},{}",
            at(Quantity::ArmatureCurrent, k),
            at(Quantity::FieldCurrent, k),
            at(Quantity::LineVoltage, k) / 1e3
        ));
        if inlet {
            text.push_str(&format!(",{}", at(Quantity::CoolingWaterInletTemp, k)));
        }
        text.push('\n');
        truth.push((t, states.iter().map(|&q| at(q, k)).collect()));
    }
    (text, truth)
}

/// A model identified with the coolant inlet as its reference (a noisy heat run of the RC
/// machine whose inlet drifts 3 K over a day: `initial_of` states and a
/// `cooling_water_inlet_rise` input) predicts another, noise-free run of the machine with
/// the same drift from its load and inlet columns; without the inlet column it cannot.
#[test]
fn a_coolant_referenced_model_predicts_a_drifting_inlet_from_the_schedule() {
    let dir = common::tempdir();
    let d = dir.path();
    let synth = |name: &str, extra: &[&str]| {
        let mut args = vec!["synth", name, "--machine", "rc-unit", "--inlet-drift", "3"];
        args.extend_from_slice(extra);
        common::heatrun_ok(&args, d);
    };
    // PT100-like noise, as `with_noise_level(1.0)`.
    let noisy = [
        "--temperature-noise",
        "0.05",
        "--resolution",
        "0.01",
        "--electrical-noise",
        "0.0005",
        "--seed",
        "6",
    ];
    synth("model.mcap", &noisy);
    synth("truth.mcap", &["--profile", "single-step"]);
    common::heatrun_ok(
        &[
            "replay",
            "model.mcap",
            "--report",
            "model.json",
            "--rrd",
            "m.rrd",
            "-q",
        ],
        d,
    );
    let report = std::fs::read_to_string(d.join("model.json")).unwrap();
    assert!(
        report.contains("\"boundary_rise\""),
        "not a coolant-referenced model"
    );
    let mut worst = Vec::new();
    for inlet in [true, false] {
        let (text, truth) = schedule_of(&d.join("truth.mcap"), 10, inlet);
        std::fs::write(d.join("load.csv"), text).unwrap();
        let start: Vec<String> = truth[0].1.iter().map(|v| v.to_string()).collect();
        common::heatrun_ok(
            &[
                "predict",
                "--model",
                "model.json",
                "--load",
                "load.csv",
                "--out",
                "pred.csv",
                "--initial-temps",
                &start.join(","),
                "-q",
            ],
            d,
        );
        let (_, rows) = read_csv(&d.join("pred.csv"));
        let error = truth
            .iter()
            .map(|(t, theta)| {
                let row = rows.iter().find(|r| (r[0] - t).abs() < 1e-6).unwrap();
                // Each `<state>_c` is followed by its band's two columns.
                (0..3)
                    .map(|j| (row[1 + 3 * j] - theta[j]).abs())
                    .fold(0.0, f64::max)
            })
            .fold(0.0, f64::max);
        println!("inlet column {inlet}: largest error {error:.3} K");
        worst.push(error);
    }
    assert!(worst[0] < 1.0, "with the inlet column: {} K", worst[0]);
    assert!(
        worst[1] > 2.0 * worst[0],
        "the inlet column made no difference: {worst:?}"
    );
}
