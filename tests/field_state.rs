//! `replay --field-state`: the field winding as a fourth state, seen only through its
//! resistance U_f/I_f, identified from a machine of four known nodes (issue 9, item 3).

use std::path::Path;

use serde_json::Value;

use crate::common::{self, heatrun};
use crate::outputs::ReportSchema;
use heatrun::pipeline::{replay, ReplayOptions};
use heatrun::spec::ModelDescription;
use heatrun::synth::{self, FieldChannel, Machine, NetworkMachine, SynthOptions, Truth};

/// The rc-field machine at PT100-like noise (0.05 K, 0.01 K resolution; electrical
/// channels 0.05 %), its field winding recorded only as field_voltage.
fn field_run(path: &Path, seed: u64) -> Truth {
    synth::write(
        path,
        &SynthOptions {
            machine: Machine::Network(NetworkMachine::rc_field()),
            field_channel: FieldChannel::Voltage,
            seed,
            ..SynthOptions::default().with_noise_level(1.0)
        },
    )
    .unwrap()
}

#[test]
fn a_field_winding_seen_only_through_its_resistance_is_identified_as_a_fourth_state() {
    let dir = common::tempdir();
    let mcap = dir.path().join("field.mcap");
    let truth = field_run(&mcap, 11);
    assert_eq!(truth.time_constants_s.len(), 4);
    let out = heatrun(
        &[
            "replay",
            "field.mcap",
            "--field-state",
            "--report",
            "report.json",
            "--rrd",
            "field.rrd",
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
        serde_json::from_slice(&std::fs::read(dir.path().join("report.json")).unwrap()).unwrap();
    ReportSchema::load()
        .check(&report)
        .unwrap_or_else(|e| panic!("the 4-state report breaks the schema:\n{e}"));
    assert_eq!(report["states"][3], "field_winding_temp");
    let numbers = |v: &Value| -> Vec<f64> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    let time_constants = numbers(&report["time_constants_s"]);
    assert_eq!(time_constants.len(), 4);
    for (t, want) in time_constants.iter().zip(&truth.time_constants_s) {
        assert!(
            (t / want - 1.0).abs() < 0.05,
            "{time_constants:?} against {:?}",
            truth.time_constants_s
        );
    }
    // The model's steady state for the last input against the truth's (rises above the
    // constant inlet, where the machine started).
    let rise = numbers(&report["steady_state"]["rise_k"]);
    for (r, want) in rise.iter().zip(&truth.steady_state_rise_k) {
        assert!(
            (r - want).abs() < 1.0,
            "{rise:?} K against {:?} K",
            truth.steady_state_rise_k
        );
    }
    assert_eq!(report["assignment"].as_array().unwrap().len(), 4);
    assert!(
        std::fs::metadata(dir.path().join("field.rrd"))
            .unwrap()
            .len()
            > 0
    );
}

#[test]
fn the_noisier_field_temperature_is_weighted_by_its_own_noise() {
    let dir = common::tempdir();
    let mcap = dir.path().join("field.mcap");
    field_run(&mcap, 12);
    let r = replay(
        &mcap,
        &ReplayOptions {
            model: ModelDescription::generator_with_field_state(),
            ..ReplayOptions::default()
        },
    )
    .unwrap();
    // OE weights each output by 1/σ²: the field winding from U_f/I_f at 1 Hz (σ about
    // 0.2 K) is seen as noisier than the PT100s (0.05 K), so it weighs less.
    let v = &r.estimate.noise_variance;
    assert_eq!(v.len(), 4);
    let sigma_k: Vec<f64> = v.iter().map(|v| v.sqrt() * 80.0).collect();
    for pt100 in &sigma_k[..3] {
        assert!((0.04..0.07).contains(pt100), "{sigma_k:?} K");
    }
    assert!((0.12..0.35).contains(&sigma_k[3]), "{sigma_k:?} K");
}

#[test]
fn a_field_state_without_a_field_temperature_is_refused() {
    let dir = common::tempdir();
    synth::write(
        &dir.path().join("paper.mcap"),
        &SynthOptions {
            duration_s: 3000.0,
            field_channel: FieldChannel::Nameplate,
            ..SynthOptions::default()
        },
    )
    .unwrap();
    let out = heatrun(
        &[
            "replay",
            "paper.mcap",
            "--field-state",
            "--report",
            "r.json",
        ],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("paper.mcap")
            && stderr.contains("field_winding_temp")
            && stderr.contains("field_voltage"),
        "{stderr}"
    );
    assert!(!dir.path().join("r.json").exists());
}
