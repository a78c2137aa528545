//! Regression checks on measured data: the TCLab MIMO heaters (Apache-2.0, shipped in
//! `datasets/tclab_mimo_heaters/` with its licence and notice), imported with the example's map and identified
//! with its spec, validated on the other experiment, as `examples/tclab_mimo_heaters/run`
//! does. The bounds sit just under the figures measured when the example was made (docs/src/validation/datasets.md,
//! "Measured data sets"): a change that makes heatrun fit real data worse fails here.
//!
//! The DaISy files and the PMSM slice state no licence that lets a slice of them into the
//! repository, so each has a stand-in generated here: a known model of the data set's shape
//! and sizes (its inputs, outputs, sample time, row count and split), seeded noise, written
//! in the data set's own file format (whitespace `.dat` with CRLF or tabs, CSV with its
//! header) and taken through the example's own map, spec and split, as its `run` script
//! does. Each must give back the model's time constants and a validation fit within a
//! hair of the true model's own fit on the same noisy data.

use std::fmt::Write as _;
use std::path::Path;

use crate::common::{self, heatrun, heatrun_ok, package_root};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};
use serde_json::Value;

fn numbers(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("an array")
        .iter()
        .map(|x| x.as_f64().expect("a number"))
        .collect()
}

fn import(root: &Path, dir: &Path, file: &str) -> String {
    let out = dir.join(file.replace(".csv", ".mcap"));
    let result = heatrun(
        &[
            "import",
            root.join("datasets/tclab_mimo_heaters")
                .join(file)
                .to_str()
                .unwrap(),
            "--map",
            root.join("examples/tclab_mimo_heaters/map.toml")
                .to_str()
                .unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        dir,
    );
    assert!(
        result.status.success(),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );
    out.to_str().unwrap().to_owned()
}

/// TCLab's two files imported with the example's map and replayed with the example's
/// `spec` (a file in examples/tclab_mimo_heaters/), estimated on the first and validated on
/// the other as the `run` script does; `extra` more arguments. The report, and the folder
/// it was written in.
fn replayed_tclab(spec: &str, extra: &[&str]) -> (Value, tempfile::TempDir) {
    let root = package_root();
    let dir = common::tempdir();
    let estimation = import(&root, dir.path(), "tclab_mimo_data.csv");
    let validation = import(&root, dir.path(), "tclab_mimo_step_data_3s.csv");
    let spec = root.join("examples/tclab_mimo_heaters").join(spec);
    let mut args = vec![
        "replay",
        &estimation,
        "--spec",
        spec.to_str().unwrap(),
        "--validate",
        &validation,
        "--report",
        "report.json",
        "-q",
    ];
    args.extend_from_slice(extra);
    heatrun_ok(&args, dir.path());
    let report =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("report.json")).unwrap())
            .unwrap();
    (report, dir)
}

#[test]
fn tclab_validation_fit_holds() {
    let (report, _dir) = replayed_tclab("spec.toml", &["--rrd", "tclab.rrd"]);
    // A spec's report follows the schema too, with its own state and input names.
    crate::outputs::ReportSchema::load()
        .check(&report)
        .unwrap_or_else(|e| panic!("{e}"));
    let fit = numbers(&report["validation"]["fit"]["nrmse_fit_percent"]);
    let rmse = numbers(&report["validation"]["fit"]["rmse_k"]);
    // Measured with heater 1's dead time of 10 s: 81.3 % and 88.6 %, RMSE 1.50 K and
    // 0.75 K, the heater commands held between samples (81.2 % and 89.0 %, 1.51 K and
    // 0.73 K, drawn as lines between them; 81.3 % and 87.8 % when the one empty instant cut the data; without the dead
    // time: 62.8 % and 86.6 %, 3.18 K and 0.90 K).
    assert!(fit[0] > 79.0 && fit[1] > 86.0, "validation fit {fit:?}");
    assert!(rmse[0] < 1.6 && rmse[1] < 0.9, "validation RMSE {rmse:?}");
    assert_eq!(report["model"]["inputs"][0]["delay_s"], 10.0);
    assert!(report["model"]["inputs"][1].get("delay_s").is_none());
    // Two real, stable time constants of the order the physics expects (1-4 min; measured
    // 152.5 s and 250.5 s since the one instant every channel lacks is simulated through
    // rather than cut; 149.7 s and 289.0 s with four segments, each with its own initial
    // state, which fitted the estimation data closer and validated at 81.3 / 87.8 %).
    let t = numbers(&report["time_constants_s"]);
    assert_eq!(t.len(), 2);
    for (got, measured) in t.iter().zip([152.5, 250.5]) {
        assert!((got - measured).abs() < 0.05 * measured, "{t:?}");
    }
    // Heater 1's static gain on T1, −(A_c⁻¹ B_c)_11 by the 2 × 2 inverse: measured
    // 62.8 K/W, 0.63 °C/% at the nominal 0.01 W/% (the course's FOPDT value: 0.9 °C/%;
    // nominal physics 0.65 °C/%).
    assert_eq!(report["states"], serde_json::json!(["T1", "T2"]));
    let a: Vec<Vec<f64>> = report["a_c"]
        .as_array()
        .unwrap()
        .iter()
        .map(numbers)
        .collect();
    let b: Vec<Vec<f64>> = report["b_c"]
        .as_array()
        .unwrap()
        .iter()
        .map(numbers)
        .collect();
    let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
    let gain_11 = -(a[1][1] * b[0][0] - a[0][1] * b[1][0]) / det;
    assert!((gain_11 - 62.8).abs() < 4.0, "gain {gain_11} K/W");
}

/// The structure `examples/tclab_mimo_heaters/run` uses (issue 23): `hidden.toml`, the two
/// thermistors two states of a model whose order is chosen on the estimation file alone
/// (five-fold cross-validation, each order the best of several starts), heater 1 acting 12 s
/// late (the least estimation cost of 0…15 s). Measured at the commit that chose it
/// (docs/src/validation/datasets.md, "With hidden states"): order 4 (cross-validated fit
/// 80.5 % against 71.5 % for order 3; order 5 refused, no better on the estimation file),
/// validation T1 91.9 %, T2 89.1 % (the heater commands held between samples: the map's
/// `interpolation = "step"`) from the initial state fitted to the validation outputs,
/// the slowest time constant at the record's length (588 s, the bound on the poles), heater
/// 1's steady-state gain on T1 46.7 K/W. A change that makes the chosen structure fit the
/// real data worse, or chooses another order, fails here.
#[test]
fn tclab_hidden_state_model_holds_its_fit() {
    let (report, _dir) = replayed_tclab("hidden.toml", &[]);
    let hidden = &report["hidden"];
    assert_eq!(hidden["order"], 4, "{}", hidden["candidates"]);
    assert_eq!(report["model"]["inputs"][0]["delay_s"], 12.0);
    // The hidden model's validation: in the `hidden` block, or the report's own where the
    // hidden model is the replay's main model.
    let fit = report
        .pointer("/hidden/validation/fit/nrmse_fit_percent")
        .or_else(|| report.pointer("/validation/fit/nrmse_fit_percent"))
        .map(numbers)
        .unwrap();
    // Just under the measured 91.88 / 89.05 %: the heater commands drawn as lines between
    // the 3 s samples (91.65 / 88.75 %) fail here.
    assert!(fit[0] > 91.7 && fit[1] > 88.9, "validation fit {fit:?}");
    let tau = numbers(&hidden["time_constants_s"]);
    assert_eq!(tau.len(), 4);
    assert!(tau[3] <= 600.0, "{tau:?}");
    let gain_11 = hidden["steady_state_gain"][0][0].as_f64().unwrap();
    assert!((gain_11 - 46.7).abs() < 4.0, "gain {gain_11} K/W");
}

/// Imports `data` with `examples/<example>/map.toml` and replays it with the example's
/// spec, estimating before `split_at_s` and validating after, as the example's `run` does.
fn run_example(dir: &Path, example: &str, data: &Path, split_at_s: &str) -> Value {
    let root = package_root();
    let example = root.join("examples").join(example);
    let mcap = dir.join("standin.mcap");
    let imported = heatrun(
        &[
            "import",
            data.to_str().unwrap(),
            "--map",
            example.join("map.toml").to_str().unwrap(),
            "--out",
            mcap.to_str().unwrap(),
        ],
        dir,
    );
    let stderr = String::from_utf8_lossy(&imported.stderr);
    assert!(imported.status.success(), "{stderr}");
    let out = heatrun(
        &[
            "replay",
            mcap.to_str().unwrap(),
            "--split-at",
            split_at_s,
            "--spec",
            example.join("spec.toml").to_str().unwrap(),
            "--report",
            "report.json",
            "-q",
        ],
        dir,
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap();
    crate::outputs::ReportSchema::load()
        .check(&report)
        .unwrap_or_else(|e| panic!("{e}"));
    report
}

/// The NRMSE fit % of the true model on the same data: 100 (1 − ‖e‖ / ‖y − ȳ‖), with e the
/// measurement noise. No estimate can be expected to validate better than this by more
/// than chance, and a sound one comes close to it.
fn true_model_fit(measured: &[f64], noise: &[f64]) -> f64 {
    let mean = measured.iter().sum::<f64>() / measured.len() as f64;
    let spread = measured.iter().map(|y| (y - mean).powi(2)).sum::<f64>();
    let error = noise.iter().map(|e| e * e).sum::<f64>();
    100.0 * (1.0 - (error / spread).sqrt())
}

/// Input levels held for random spells of `spell` samples, drawn from `levels`.
fn steps(
    rng: &mut StdRng,
    n: usize,
    spell: std::ops::Range<usize>,
    mut level: impl FnMut(&mut StdRng) -> f64,
) -> Vec<f64> {
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let value = level(rng);
        let len = rng.random_range(spell.clone());
        out.extend(std::iter::repeat_n(value, len.min(n - out.len())));
    }
    out
}

/// Asserts each validation fit is within `slack` points of the true model's.
fn assert_fit_near_truth(report: &Value, truth_fits: &[f64], slack: f64) {
    let fit = numbers(&report["validation"]["fit"]["nrmse_fit_percent"]);
    assert_eq!(fit.len(), truth_fits.len());
    for (got, truth) in fit.iter().zip(truth_fits) {
        assert!(
            *got > truth - slack && *got < truth + slack,
            "validation fit {fit:?}, the true model's {truth_fits:?}"
        );
    }
}

/// Asserts the identified time constants, sorted, are within `tolerance` of the truth's.
fn assert_time_constants(report: &Value, truth: &[f64], tolerance: f64) {
    let mut t = numbers(&report["time_constants_s"]);
    t.sort_by(f64::total_cmp);
    assert_eq!(t.len(), truth.len(), "{t:?}");
    for (got, want) in t.iter().zip(truth) {
        assert!(
            (got - want).abs() < tolerance * want,
            "time constants {t:?}, truth {truth:?}"
        );
    }
}

/// The DaISy heating system's shape: 801 rows "t u y" at Ts = 2 s, leading spaces, CRLF;
/// a first-order plate, y(k) = φ y(k−1) + (1 − φ)(θ_a + K u(k−1)²), starting in the steady
/// state of u = 6 V as DaISy's does, with τ = 65 s, K = 1.5 K/V², θ_a = 70 °C (a range of
/// 83-192 °C, like the file's) and thermocouple noise of σ = 0.2 K.
#[test]
fn daisy_heating_system_standin_holds_its_fit() {
    let (tau, gain, ambient, ts, rows) = (65.0_f64, 1.5, 70.0, 2.0, 801);
    let mut rng = StdRng::seed_from_u64(14);
    let mut u = steps(&mut rng, rows, 15..60, |r| {
        (r.random_range(3.0..9.0_f64) * 1000.0).round() / 1000.0
    });
    u[..20].fill(9.0);
    let phi = (-ts / tau).exp();
    let noise = Normal::new(0.0, 0.2).unwrap();
    let mut plate = ambient + gain * 36.0;
    let (mut text, mut measured, mut errors) = (String::new(), vec![], vec![]);
    for k in 0..rows {
        if k > 0 {
            plate = phi * plate + (1.0 - phi) * (ambient + gain * u[k - 1].powi(2));
        }
        let e: f64 = noise.sample(&mut rng);
        let y = ((plate + e) * 1000.0).round() / 1000.0;
        write!(text, "{:7.2} {:7.3} {:8.3}\r\n", k as f64 * ts, u[k], y).unwrap();
        measured.push(y);
        errors.push(y - plate);
    }
    let dir = common::tempdir();
    let data = dir.path().join("heating_system.dat");
    std::fs::write(&data, text).unwrap();
    let report = run_example(dir.path(), "daisy_heating_system", &data, "800");
    assert_time_constants(&report, &[tau], 0.03);
    // The gain from u² is −B_c/A_c (1 × 1).
    let a = numbers(&report["a_c"][0])[0];
    let b = numbers(&report["b_c"][0]);
    assert!((-b[0] / a - gain).abs() < 0.03 * gain, "gain {}", -b[0] / a);
    let truth = true_model_fit(&measured[400..], &errors[400..]);
    assert_fit_near_truth(&report, &[truth], 1.5);
}

/// The DaISy glass furnace's shape: 1247 rows "k u1 u2 u3 y1 … y6", tab-separated in
/// `%.7e`, zero-mean binary inputs switching at random, Ts = 1; six sensors as a chain
/// (each heated by its neighbour upstream), real eigenvalues 0.3 … 0.97, noise σ = 0.01.
/// Each actuator acts spread over samples, as the example's spec allows: heating 1 at
/// lags 2-3, cooling at lags 2-4, heating 2 within the sample (lag 0: the row's own
/// value, the spec's `advance_s`) and at lag 1.
#[test]
fn daisy_glassfurnace_standin_holds_its_fit() {
    let lambda = [0.3, 0.5, 0.7, 0.85, 0.93, 0.97];
    let gamma = [
        [0.30, -0.10, 0.05],
        [0.10, -0.20, 0.10],
        [0.05, -0.15, 0.20],
        [0.02, -0.10, 0.30],
        [0.10, -0.05, 0.10],
        [0.05, -0.05, 0.05],
    ];
    // (input, lag, share of its column): y(k) receives u_j(k − lag).
    let spread = [
        (0, 2, 0.6),
        (0, 3, 0.4),
        (1, 2, 0.3),
        (1, 3, 0.4),
        (1, 4, 0.3),
        (2, 0, 0.5),
        (2, 1, 0.5),
    ];
    let rows = 1247;
    let mut rng = StdRng::seed_from_u64(6);
    let noise = Normal::new(0.0, 0.01).unwrap();
    let mut u: Vec<[f64; 3]> = Vec::with_capacity(rows);
    for k in 0..rows {
        let previous = u.last().copied().unwrap_or([0.0; 3]);
        u.push(previous.map(|held| {
            if k == 0 || rng.random_bool(0.5) {
                if rng.random_bool(0.5) {
                    1.0
                } else {
                    -1.0
                }
            } else {
                held
            }
        }));
    }
    let mut x = [0.0; 6];
    let (mut text, mut measured, mut errors) = (String::new(), vec![vec![]; 6], vec![vec![]; 6]);
    for k in 0..rows {
        if k > 0 {
            let previous = x;
            for i in 0..6 {
                let upstream = if i > 0 { 0.1 * previous[i - 1] } else { 0.0 };
                let heat: f64 = spread
                    .iter()
                    .filter(|(_, lag, _)| k >= *lag)
                    .map(|&(j, lag, share)| share * gamma[i][j] * u[k - lag][j])
                    .sum();
                x[i] = lambda[i] * previous[i] + upstream + heat;
            }
        }
        write!(text, "{:16.7e}\t", (k + 1) as f64).unwrap();
        for uj in u[k] {
            write!(text, "{uj:16.7e}\t").unwrap();
        }
        for i in 0..6 {
            let y = x[i] + noise.sample(&mut rng);
            write!(text, "{y:16.7e}\t").unwrap();
            measured[i].push(y);
            errors[i].push(y - x[i]);
        }
        text.push('\n');
    }
    let dir = common::tempdir();
    let data = dir.path().join("glassfurnace.dat");
    std::fs::write(&data, text).unwrap();
    let report = run_example(dir.path(), "daisy_glassfurnace", &data, "748");
    // Heating 2 within the sample: the spec's one advanced input, as the report says.
    let advanced: Vec<&str> = report["model"]["inputs"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|i| i["advance_s"] == 1.0)
        .map(|i| i["name"].as_str().unwrap())
        .collect();
    assert_eq!(advanced, ["heating_2_ahead"]);
    let mut truth: Vec<f64> = lambda.iter().map(|l: &f64| -1.0 / l.ln()).collect();
    truth.sort_by(f64::total_cmp);
    let mut t = numbers(&report["time_constants_s"]);
    t.sort_by(f64::total_cmp);
    assert_eq!(t.len(), truth.len(), "{t:?}");
    for (got, want) in t.iter().zip(&truth) {
        // A mode that has decayed within the inputs' four lags (τ < 4 samples: 0.3⁴ is
        // 0.008) is nearly collinear with them, and least squares under the noise puts it
        // faster (measured: 0.67 s for 0.83 s); it must stay a fast mode. The slower
        // ones are held to 5 %.
        if *want < 4.0 {
            assert!(*got < 4.0, "time constants {t:?}, truth {truth:?}");
        } else {
            assert!(
                (got - want).abs() < 0.05 * want,
                "time constants {t:?}, truth {truth:?}"
            );
        }
    }
    let fits: Vec<f64> = (0..6)
        .map(|i| true_model_fit(&measured[i][748..], &errors[i][748..]))
        .collect();
    assert_fit_near_truth(&report, &fits, 1.5);
}

/// The PMSM slice's shape: 3000 rows at Ts = 0.5 s of the twelve z-scored columns under the
/// file's header. The magnet and the stator winding are a continuous two-node model
/// (τ = 490 s and 160 s; the winding heats the magnet) driven by the coolant, the copper
/// losses i_d² + i_q² and the speed, simulated in 100 steps a sample from its steady state;
/// noise σ = 0.002 (z-units). The other columns are filled so the file is complete.
#[test]
fn pmsm_standin_holds_its_fit() {
    let (rows, ts, substeps) = (3000, 0.5, 100);
    // dx/dt = A x + B u, x = (pm, winding) rises, u = (coolant, i², speed) changes.
    let a = [[-1.0 / 490.0, 0.0008], [0.0, -1.0 / 160.0]];
    let b = [[0.001, 0.0, 0.002], [0.003, 0.004, 0.0005]];
    let mut rng = StdRng::seed_from_u64(4);
    let coolant = steps(&mut rng, rows, 300..700, |r| r.random_range(-1.2..-0.6));
    let i_d = steps(&mut rng, rows, 150..500, |r| r.random_range(-0.5..1.0));
    let i_q = steps(&mut rng, rows, 150..500, |r| r.random_range(-0.5..0.5));
    let speed = steps(&mut rng, rows, 200..600, |r| r.random_range(-1.2..1.2));
    let inputs = |k: usize| [coolant[k], i_d[k].powi(2) + i_q[k].powi(2), speed[k]];
    let start = (inputs(0), [-2.5, -2.0]);
    let noise = Normal::new(0.0, 0.002).unwrap();
    let mut x = [0.0_f64; 2];
    let mut text = "ambient,coolant,u_d,u_q,motor_speed,torque,i_d,i_q,pm,stator_yoke,\
stator_tooth,stator_winding\n"
        .to_owned();
    let (mut measured, mut errors) = (vec![vec![]; 2], vec![vec![]; 2]);
    for k in 0..rows {
        if k > 0 {
            let u = inputs(k - 1);
            let du: Vec<f64> = (0..3).map(|j| u[j] - start.0[j]).collect();
            let h = ts / substeps as f64;
            for _ in 0..substeps {
                let dx: Vec<f64> = (0..2)
                    .map(|i| {
                        let free: f64 = (0..2).map(|j| a[i][j] * x[j]).sum();
                        free + (0..3).map(|j| b[i][j] * du[j]).sum::<f64>()
                    })
                    .collect();
                x[0] += h * dx[0];
                x[1] += h * dx[1];
            }
        }
        let y: Vec<f64> = (0..2)
            .map(|i| start.1[i] + x[i] + noise.sample(&mut rng))
            .collect();
        for i in 0..2 {
            measured[i].push(y[i]);
            errors[i].push(y[i] - start.1[i] - x[i]);
        }
        writeln!(
            text,
            "-0.75,{},0.33,-1.29,{},{},{},{},{},{},{},{}",
            coolant[k],
            speed[k],
            0.5 * i_q[k],
            i_d[k],
            i_q[k],
            y[0],
            0.5 * (y[0] + y[1]),
            0.8 * y[1],
            y[1]
        )
        .unwrap();
    }
    let dir = common::tempdir();
    let data = dir.path().join("pmsm_temperature_data_red.csv");
    std::fs::write(&data, text).unwrap();
    let report = run_example(dir.path(), "pmsm_motor_temperature_slice", &data, "1000");
    assert_eq!(
        report["states"],
        serde_json::json!(["pm", "stator_winding"])
    );
    assert_time_constants(&report, &[160.0, 490.0], 0.05);
    let fits: Vec<f64> = (0..2)
        .map(|i| true_model_fit(&measured[i][2000..], &errors[i][2000..]))
        .collect();
    // Two points: the validation starts from the measured (noisy) state, and with τ = 490 s
    // that start's error fades slowly over the 500 s validated (measured: 0.2 and 1.3 points
    // under the true model).
    assert_fit_near_truth(&report, &fits, 2.0);
}

/// A system with an oscillating mode, as a user's CSV: two sensors that exchange heat
/// through a loop (a complex pair of Φ, r = 0.97, 0.1 rad a sample: τ = −1/ln r = 32.8 s,
/// period 2π/0.1 = 62.8 s) and a third with a real mode (λ = 0.9, τ = 9.49 s). The report
/// gives the pair's time constant twice with its period, null for the real mode, and
/// follows the schema's entries for them.
#[test]
fn oscillating_modes_are_in_the_report_and_its_schema() {
    let (r, w, real, rows) = (0.97_f64, 0.1_f64, 0.9, 2000);
    let phi = [
        [r * w.cos(), -r * w.sin(), 0.0],
        [r * w.sin(), r * w.cos(), 0.0],
        [0.0, 0.0, real],
    ];
    let gamma = [0.1, 0.05, 0.2];
    let mut rng = StdRng::seed_from_u64(3);
    let u = steps(&mut rng, rows, 5..30, |r| r.random_range(0.0..10.0));
    let noise = Normal::new(0.0, 0.005).unwrap();
    let mut x = [0.0; 3];
    let mut text = "t,u,a,b,c\n".to_owned();
    for k in 0..rows {
        if k > 0 {
            let p = x;
            for i in 0..3 {
                x[i] = (0..3).map(|j| phi[i][j] * p[j]).sum::<f64>() + gamma[i] * u[k - 1];
            }
        }
        let y: Vec<f64> = x.iter().map(|v| v + noise.sample(&mut rng)).collect();
        writeln!(text, "{k},{},{},{},{}", u[k], y[0], y[1], y[2]).unwrap();
    }
    let dir = common::tempdir();
    std::fs::write(dir.path().join("loop.csv"), text).unwrap();
    let mut map = "[input]\ndelimiter = \",\"\nheader = true\n[time]\ncolumn = \"t\"\n\
                   format = \"seconds\"\n"
        .to_owned();
    let mut spec = "name = \"loop\"\nsample_time_s = 1.0\n".to_owned();
    for c in ["u", "a", "b", "c"] {
        write!(
            map,
            "[[column]]\ncolumn = \"{c}\"\nchannel = \"{c}\"\nunit = \"degC\"\n"
        )
        .unwrap();
    }
    for c in ["a", "b", "c"] {
        write!(spec, "[[state]]\nname = \"{c}\"\nreference = \"none\"\n").unwrap();
    }
    spec.push_str("[[input]]\nname = \"drive\"\nchannel = \"u\"\nkind = \"exogenous\"\n");
    std::fs::write(dir.path().join("map.toml"), map).unwrap();
    std::fs::write(dir.path().join("spec.toml"), spec).unwrap();
    let run = |args: &[&str]| {
        let out = heatrun(args, dir.path());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{stderr}");
    };
    run(&[
        "import",
        "loop.csv",
        "--map",
        "map.toml",
        "--out",
        "loop.mcap",
    ]);
    run(&[
        "replay",
        "loop.mcap",
        "--spec",
        "spec.toml",
        "--report",
        "report.json",
        "-q",
    ]);
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("report.json")).unwrap())
            .unwrap();
    crate::outputs::ReportSchema::load()
        .check(&report)
        .unwrap_or_else(|e| panic!("{e}"));
    let tau_pair = -1.0 / r.ln();
    assert_time_constants(&report, &[-1.0 / real.ln(), tau_pair, tau_pair], 0.03);
    let periods: Vec<Option<f64>> = report["oscillation_periods_s"]
        .as_array()
        .expect("periods reported for an oscillating model")
        .iter()
        .map(Value::as_f64)
        .collect();
    assert_eq!(
        periods.iter().filter(|p| p.is_none()).count(),
        1,
        "{periods:?}"
    );
    for p in periods.into_iter().flatten() {
        let truth = 2.0 * std::f64::consts::PI / w;
        assert!((p - truth).abs() < 0.03 * truth, "period {p} s");
    }
    let imag = numbers(&report["eigenvalues_continuous_imag"]);
    assert_eq!(imag.len(), 3);
    assert!(
        imag.iter().any(|v| (v.abs() - w).abs() < 0.03 * w),
        "{imag:?}"
    );
}

/// Replays `csv` (columns t, u1, u2, y1, y2) with a two-state spec whose first input has
/// the dead time `delay_s`, estimating before 1400 s and validating after; the report.
fn replay_with_delay(dir: &Path, csv: &Path, delay_s: f64) -> Value {
    let map = dir.join("map.toml");
    let mut text = String::from(
        "[input]\ndelimiter = \",\"\nheader = true\n[time]\ncolumn = 1\nformat = \"seconds\"\n",
    );
    for (i, name) in ["u1", "u2", "y1", "y2"].iter().enumerate() {
        write!(
            text,
            "[[column]]\ncolumn = {}\nchannel = \"{name}\"\nunit = \"1\"\n",
            i + 2
        )
        .unwrap();
    }
    std::fs::write(&map, text).unwrap();
    let mcap = dir.join("delayed.mcap");
    let args = [
        "import",
        csv.to_str().unwrap(),
        "--map",
        map.to_str().unwrap(),
    ];
    heatrun_ok(
        &[&args[..], &["--out", mcap.to_str().unwrap()]].concat(),
        dir,
    );
    let spec = dir.join("spec.toml");
    let mut text = String::from("name = \"delayed\"\nsample_time_s = 1.0\nmethod = \"oe\"\n");
    for y in ["y1", "y2"] {
        write!(
            text,
            "[[state]]\nname = \"{y}\"\nreference = \"none\"\nunit = \"1\"\n"
        )
        .unwrap();
    }
    for (u, d) in [("u1", delay_s), ("u2", 0.0)] {
        write!(
            text,
            "[[input]]\nname = \"{u}\"\nchannel = \"{u}\"\nunit = \"1\"\n"
        )
        .unwrap();
        write!(text, "kind = \"exogenous\"\ndelay_s = {d:.1}\n").unwrap();
    }
    std::fs::write(&spec, text).unwrap();
    let report = dir.join(format!("report-{delay_s}.json"));
    let args = ["replay", mcap.to_str().unwrap(), "--split-at", "1400"];
    let rest = [
        "--spec",
        spec.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
        "-q",
    ];
    heatrun_ok(&[&args[..], &rest[..]].concat(), dir);
    let report: Value = serde_json::from_str(&std::fs::read_to_string(report).unwrap()).unwrap();
    crate::outputs::ReportSchema::load()
        .check(&report)
        .unwrap_or_else(|e| panic!("{e}"));
    report
}

/// A known model with a dead time of 5 samples on its first input,
/// x(k) = Φ x(k−1) + Γ₁ u1(k−1−5) + Γ₂ u2(k−1), Ts = 1 s, 2000 rows, noise σ = 0.01:
/// identified with `delay_s = 5` in the spec, Φ and Γ come back within 0.01 (entries up
/// to 0.95) and the validation fit is the true model's; without the delay the same data
/// validate measurably worse, most on the output the delayed input drives most.
#[test]
fn a_known_dead_time_is_recovered() {
    let phi = [[0.90, 0.05], [0.03, 0.95]];
    let gamma = [[0.50, 0.10], [0.05, 0.20]];
    let (rows, d) = (2000, 5);
    let mut rng = StdRng::seed_from_u64(15);
    let u1 = steps(&mut rng, rows, 20..80, |r| r.random_range(0.0..1.0));
    let u2 = steps(&mut rng, rows, 20..80, |r| r.random_range(0.0..1.0));
    let noise = Normal::new(0.0, 0.01).unwrap();
    let mut x = [0.0_f64; 2];
    let (mut text, mut measured, mut errors) = (
        String::from("t,u1,u2,y1,y2\n"),
        vec![vec![]; 2],
        vec![vec![]; 2],
    );
    for k in 0..rows {
        if k > 0 {
            let late = if k > d { u1[k - 1 - d] } else { 0.0 };
            let p = x;
            for i in 0..2 {
                x[i] = phi[i][0] * p[0]
                    + phi[i][1] * p[1]
                    + gamma[i][0] * late
                    + gamma[i][1] * u2[k - 1];
            }
        }
        let y: Vec<f64> = x.iter().map(|x| x + noise.sample(&mut rng)).collect();
        writeln!(
            text,
            "{k},{:.6},{:.6},{:.6},{:.6}",
            u1[k], u2[k], y[0], y[1]
        )
        .unwrap();
        for i in 0..2 {
            measured[i].push(y[i]);
            errors[i].push(y[i] - x[i]);
        }
    }
    let dir = common::tempdir();
    let csv = dir.path().join("delayed.csv");
    std::fs::write(&csv, text).unwrap();
    let with = replay_with_delay(dir.path(), &csv, d as f64);
    assert_eq!(with["model"]["inputs"][0]["delay_s"], 5.0);
    for (name, truth) in [("phi", phi), ("gamma", gamma)] {
        for i in 0..2 {
            let row = numbers(&with[name][i]);
            for j in 0..2 {
                assert!(
                    (row[j] - truth[i][j]).abs() < 0.01,
                    "{name}: {row:?} against {truth:?}"
                );
            }
        }
    }
    let truth: Vec<f64> = (0..2)
        .map(|i| true_model_fit(&measured[i][1400..], &errors[i][1400..]))
        .collect();
    assert_fit_near_truth(&with, &truth, 1.0);
    let without = replay_with_delay(dir.path(), &csv, 0.0);
    let (fit_with, fit_without) = (
        numbers(&with["validation"]["fit"]["nrmse_fit_percent"]),
        numbers(&without["validation"]["fit"]["nrmse_fit_percent"]),
    );
    // y1, which the delayed input drives most (Γ₁₁ = 0.5), loses more than 5 points
    // (measured: 99.5 % → 91.0 %); y2 (Γ₂₁ = 0.05) a little (99.5 % → 98.7 %).
    assert!(
        fit_without[0] < fit_with[0] - 5.0 && fit_without[1] < fit_with[1],
        "with {fit_with:?}, without {fit_without:?}"
    );
    // Predictions simulate the dead time: from the steady state of u = 0 (x = 0), a step
    // of u1 at t = 10 s is applied at k = 15 and first moves y1 at k = 16, by Γ₁₁ (the
    // report's own, worked by hand from x(k+1) = Φ x(k) + Γ u(k − d)).
    std::fs::write(
        dir.path().join("load.csv"),
        "time_s,u1,u2\n0,0,0\n10,1,0\n30,1,0\n",
    )
    .unwrap();
    let args = ["predict", "--model", "report-5.json", "--load", "load.csv"];
    let out = heatrun(
        &[&args[..], &["--out", "p.csv", "--initial", "steady", "-q"]].concat(),
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let predicted = std::fs::read_to_string(dir.path().join("p.csv")).unwrap();
    let y1: Vec<f64> = predicted
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
        .collect();
    let gamma_11 = numbers(&with["gamma"][0])[0];
    assert!(y1[..=15].iter().all(|v| v.abs() < 1e-9), "{:?}", &y1[..17]);
    assert!(
        (y1[16] - gamma_11).abs() < 1e-4,
        "{} against Γ₁₁ {gamma_11}",
        y1[16]
    );
    // A delay off the grid of the caller's Ts (the spec names none) is refused by the
    // signal stage, naming the input.
    let spec = dir.path().join("spec.toml");
    let text = std::fs::read_to_string(&spec).unwrap();
    let text =
        text.replace("sample_time_s = 1.0\n", "")
            .replacen("delay_s = 0.0", "delay_s = 2.5", 1);
    std::fs::write(&spec, text).unwrap();
    let args = [
        "replay",
        "delayed.mcap",
        "--spec",
        "spec.toml",
        "--report",
        "r.json",
    ];
    let out = heatrun(&args, dir.path());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("input `u1`: delay_s = 2.5 s is not a whole number of samples"),
        "{stderr}"
    );
    assert!(!dir.path().join("r.json").exists());
}
