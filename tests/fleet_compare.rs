//! `heatrun fleet compare`: nine synthesized heat runs of one design (the rc unit), eight
//! with a ±3 % manufacturing spread in C and G and one, of the same spread, whose
//! conductances to the coolant are 30 % lower (a fouled cooler): the comparison names
//! the fouled unit and no healthy one. Bad input: too few reports, a file that is none.

use std::path::Path;

use crate::common;

/// The unit whose cooler is fouled.
const FOULED: usize = 9;

/// Nine runs of 12000 s (a few seconds in all), PT100-like noise, each unit its own
/// noise seed and manufacturing draw, replayed as a fleet into `res/`. Shorter runs say
/// less: at 8000 s the final load is held half the slowest time constant, and one healthy
/// unit's network fit misses its cooler's capacitance twofold (which the comparison
/// names, rightly: that unit's model differs).
fn fleet(dir: &Path) {
    std::fs::create_dir(dir.join("runs")).unwrap();
    for unit in 1..=9 {
        let (seed, out) = (unit.to_string(), format!("runs/u{unit}.mcap"));
        let mut args = vec![
            "synth",
            &out,
            "--duration",
            "12000",
            "--machine",
            "rc-unit",
            "--temperature-noise",
            "0.05",
            "--seed",
            &seed,
            "--spread",
            "3",
            "--unit-seed",
            &seed,
        ];
        if unit == FOULED {
            args.extend(["--fault-at", "0", "--fault-conductance-drop", "0.3"]);
        }
        common::heatrun_ok(&args, dir);
    }
    common::heatrun_ok(
        &["replay", "runs", "--out-dir", "res", "--jobs", "2", "-q"],
        dir,
    );
}

#[test]
fn the_fouled_unit_is_named_and_no_healthy_one() {
    let dir = common::tempdir();
    fleet(dir.path());
    let reports: Vec<String> = (1..=9).map(|u| format!("res/u{u}.report.json")).collect();
    let mut args = vec!["fleet", "compare"];
    args.extend(reports.iter().map(String::as_str));
    args.extend(["--json", "compare.json", "--html", "compare.html"]);
    let out = common::heatrun_ok(&args, dir.path());
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("compare.json")).unwrap()).unwrap();
    let schema_path = common::package_root().join("schemas/fleet-compare.schema.json");
    let mut schemas = boon::Schemas::new();
    let index = boon::Compiler::new()
        .compile(schema_path.to_str().unwrap(), &mut schemas)
        .unwrap_or_else(|e| panic!("{e:#}"));
    if let Err(e) = schemas.validate(&json, index) {
        panic!("compare.json against its schema: {e:#}");
    }
    let outliers = json["outliers"].as_array().unwrap();
    let fouled = &reports[FOULED - 1];
    assert!(!outliers.is_empty(), "the fouled unit is not named");
    for o in outliers {
        assert_eq!(
            o["report"].as_str(),
            Some(fouled.as_str()),
            "a healthy unit named: {o}"
        );
        for key in ["quantity", "value", "centre", "spread", "score"] {
            assert!(!o[key].is_null(), "{key} missing: {o}");
        }
        assert!(o["score"].as_f64().unwrap() > json["options"]["threshold"].as_f64().unwrap());
    }
    // The cooler's own rise is the fouling's direct mark: the heat the water carries over
    // 0.7 of the conductance, 1/0.7 of the fleet's, at the run's final load and at the
    // rated one.
    for quantity in [
        "steady_state_rise_k.cooling_water_outlet_temp",
        "rated_rise_k.cooling_water_outlet_temp",
    ] {
        let cooler = outliers
            .iter()
            .find(|o| o["quantity"] == quantity)
            .unwrap_or_else(|| panic!("{quantity} is not among the outliers"));
        let ratio = cooler["value"].as_f64().unwrap() / cooler["centre"].as_f64().unwrap();
        assert!((ratio - 1.0 / 0.7).abs() < 0.03, "{quantity}: {ratio}");
    }
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains(&format!("{fouled} differs from the fleet")),
        "{stdout}"
    );
    let page = std::fs::read_to_string(dir.path().join("compare.html")).unwrap();
    assert!(page.contains(fouled.as_str()) && page.contains("<svg"));
}

#[test]
fn too_few_reports_or_a_file_that_is_none_are_bad_input() {
    let dir = common::tempdir();
    std::fs::write(dir.path().join("notes.json"), "{\"hello\": 1}").unwrap();
    let fixture = common::package_root().join("fixtures/paper_heat_run.mcap");
    std::fs::copy(&fixture, dir.path().join("run.mcap")).unwrap();
    // `heatrun synth`'s truth, which a glob of a folder's `*.json` picks up.
    std::fs::copy(
        common::package_root().join("fixtures/paper_heat_run.mcap.truth.json"),
        dir.path().join("run.mcap.truth.json"),
    )
    .unwrap();
    for (args, names) in [
        (vec!["fleet", "compare", "notes.json"], "notes.json"),
        (
            vec!["fleet", "compare", "a.json", "b.json", "c.json", "d.json"],
            "a.json",
        ),
        (
            vec![
                "fleet", "compare", "run.mcap", "run.mcap", "run.mcap", "run.mcap",
            ],
            "run.mcap: not a heatrun model report: it is an MCAP recording",
        ),
        (
            vec![
                "fleet",
                "compare",
                "run.mcap.truth.json",
                "a.json",
                "b.json",
                "c.json",
            ],
            "run.mcap.truth.json: not a heatrun model report: it is the true model `heatrun \
             synth` writes beside a recording",
        ),
    ] {
        let out = common::heatrun(&args, dir.path());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{stderr}");
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(stderr.contains(names), "{stderr}");
    }
}
