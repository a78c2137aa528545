//! Regression checks on measured data: the TCLab MIMO heaters (Apache-2.0, shipped in
//! `tests/datasets/tclab/` with its notice), imported with the example's map and identified
//! with its spec, validated on the other experiment, as `examples/tclab_mimo_heaters/run`
//! does. The bounds sit just under the figures measured when the example was made (README,
//! "Measured data sets"): a change that makes heatrun fit real data worse fails here.

use std::path::Path;

use crate::common::{self, heatrun, package_root};
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
            root.join("tests/datasets/tclab")
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

#[test]
fn tclab_validation_fit_holds() {
    let root = package_root();
    let dir = common::tempdir();
    let estimation = import(&root, dir.path(), "tclab_mimo_data.csv");
    let validation = import(&root, dir.path(), "tclab_mimo_step_data_3s.csv");
    let spec = root.join("examples/tclab_mimo_heaters/spec.toml");
    let out = heatrun(
        &[
            "replay",
            &estimation,
            "--spec",
            spec.to_str().unwrap(),
            "--validate",
            &validation,
            "--report",
            "report.json",
            "--rrd",
            "tclab.rrd",
            "-q",
        ],
        dir.path(),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("report.json")).unwrap())
            .unwrap();
    // A spec's report follows the schema too, with its own state and input names.
    crate::outputs::ReportSchema::load()
        .check(&report)
        .unwrap_or_else(|e| panic!("{e}"));
    let fit = numbers(&report["validation"]["fit"]["nrmse_fit_percent"]);
    let rmse = numbers(&report["validation"]["fit"]["rmse_k"]);
    // Measured: 62.8 % and 86.6 %, RMSE 3.18 K and 0.90 K.
    assert!(fit[0] > 60.0 && fit[1] > 84.0, "validation fit {fit:?}");
    assert!(rmse[0] < 3.4 && rmse[1] < 1.0, "validation RMSE {rmse:?}");
    // Two real, stable time constants of the order the physics expects (1-4 min; measured
    // 203.5 s and 306.7 s).
    let t = numbers(&report["time_constants_s"]);
    assert_eq!(t.len(), 2);
    for (got, measured) in t.iter().zip([203.5, 306.7]) {
        assert!((got - measured).abs() < 0.05 * measured, "{t:?}");
    }
    // Heater 1's static gain on T1, −(A_c⁻¹ B_c)_11 by the 2 × 2 inverse: measured
    // 83.8 K/W, 0.84 °C/% at the nominal 0.01 W/% (the course's FOPDT value: 0.9 °C/%).
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
    assert!((gain_11 - 83.8).abs() < 5.0, "gain {gain_11} K/W");
}
