//! `replay --field-state`: the field winding as a fourth state, seen only through its
//! resistance U_f/I_f, identified from a machine of four known nodes (issue 9, item 3).

use std::path::Path;

use serde_json::Value;

use crate::common::{self, heatrun, heatrun_ok};
use crate::outputs::ReportSchema;
use heatrun::model::ContinuousModel;
use heatrun::network::Scaling;
use heatrun::pipeline::{self, ReplayOptions};
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

/// `heatrun replay field.mcap --field-state` in `dir` with `extra` arguments, writing
/// report.json and field.rrd there; the report.
fn replay_field(dir: &Path, extra: &[&str]) -> Value {
    let mut args = vec![
        "replay",
        "field.mcap",
        "--field-state",
        "--report",
        "report.json",
        "--rrd",
        "field.rrd",
        "-q",
    ];
    args.extend_from_slice(extra);
    heatrun_ok(&args, dir);
    serde_json::from_slice(&std::fs::read(dir.join("report.json")).unwrap()).unwrap()
}

/// The bars of issue 9 for the field state, as met: T2–T4 (690 s, 1592 s and 4496 s:
/// stator winding, field winding, core) within 5 % and every steady-state rise within
/// 1 K. The fastest constant (70 s, the cooling water) is the least excited by this heat
/// run on this machine (most of the field loss enters the slow field node): over seeds
/// 1–5 at PT100-like noise its error was −2.7 % to +13.5 % (its own 95 % interval about
/// ±8 %), so it is held to 15 %, not 5 %. Over seeds 1–20 the errors' standard deviation
/// (4.2 %) matches the σ its interval reports (4.5 %), whatever the field sensor's noise:
/// the limit of this experiment, not of the estimator (docs/src/methods/field-state.md, "The field winding as a
/// fourth state").
fn assert_within_bars(time_constants: &[f64], rise_k: &[f64], truth: &Truth, what: &str) {
    assert_eq!(time_constants.len(), 4, "{what}");
    for (i, (t, want)) in time_constants
        .iter()
        .zip(&truth.time_constants_s)
        .enumerate()
    {
        let bar = if i == 0 { 0.15 } else { 0.05 };
        assert!(
            (t / want - 1.0).abs() < bar,
            "{what}: {time_constants:?} s against {:?} s",
            truth.time_constants_s
        );
    }
    // The model's steady state for the last input against the truth's (rises above the
    // constant inlet, where the machine started).
    for (r, want) in rise_k.iter().zip(&truth.steady_state_rise_k) {
        assert!(
            (r - want).abs() < 1.0,
            "{what}: {rise_k:?} K against {:?} K",
            truth.steady_state_rise_k
        );
    }
}

#[test]
fn a_field_winding_seen_only_through_its_resistance_is_a_fourth_state_in_every_output() {
    let dir = common::tempdir();
    let mcap = dir.path().join("field.mcap");
    let truth = field_run(&mcap, 1);
    assert_eq!(truth.time_constants_s.len(), 4);
    let report = replay_field(dir.path(), &["--network", "nearest"]);
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
    assert_within_bars(
        &numbers(&report["time_constants_s"]),
        &numbers(&report["steady_state"]["rise_k"]),
        &truth,
        "the report",
    );
    assert_eq!(report["assignment"].as_array().unwrap().len(), 4);
    assert_eq!(
        report["uncertainty"]["time_constants_ci95_s"]
            .as_array()
            .unwrap()
            .len(),
        4
    );
    // The .rrd carries the fourth state like the others: measured, model, residual and its
    // sensitivity to each of the four time constants.
    let (rows, _) = crate::outputs::rows_per_entity(&dir.path().join("field.rrd"));
    for entity in [
        "/temperature/field_winding_temp/measured".to_owned(),
        "/temperature/field_winding_temp/model".to_owned(),
        "/residual/field_winding_temp".to_owned(),
        "/sensitivity/T4/field_winding_temp".to_owned(),
    ] {
        assert!(
            rows.get(&entity).is_some_and(|&n| n > 0),
            "{entity}: {rows:?}"
        );
    }
}

/// The replay's model without its network: the recording prepared, the default
/// estimator's choice and the analysis, as `pipeline::replay_observed` makes them. The
/// network (rc's fit beside the analysis, seconds to tens of seconds on this machine) has
/// no part in these bars; `network_rc` holds it to its own.
fn model_of(mcap: &Path) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let options = ReplayOptions {
        model: ModelDescription::generator_with_field_state(),
        ..ReplayOptions::default()
    };
    let prepared = pipeline::prepare(mcap, &options).unwrap();
    let scaling = Scaling {
        theta_base_k: prepared.signals.temperature_base_k,
        p_base_w: prepared.signals.power_base,
    };
    let noise = heatrun::decide::NoiseFloor::of(
        &prepared.model,
        &prepared.signals,
        &prepared.recording.channels,
    );
    let (estimate, _) =
        pipeline::estimate_chosen(&prepared.data, &options, scaling, &noise).unwrap();
    let continuous = ContinuousModel::from_discrete(&estimate.model).unwrap();
    let steady_input = prepared
        .signals
        .steady_state_input(&continuous.a_c, &continuous.b_c)
        .unwrap();
    let analysis = heatrun::model::analyse(
        &estimate,
        Some(continuous),
        &prepared.data,
        0..prepared.data.len(),
        prepared.signals.temperature_base_k,
        &steady_input,
    )
    .unwrap();
    let base = prepared.signals.temperature_base_k;
    let sigma_k = estimate
        .noise_variance
        .iter()
        .map(|v| v.sqrt() * base)
        .collect();
    let rise_k = analysis.steady_state.iter().map(|x| x * base).collect();
    (analysis.spectrum.time_constants_s, rise_k, sigma_k)
}

#[test]
fn the_field_state_meets_its_bars_over_seeds_and_is_weighted_by_its_own_noise() {
    let dir = common::tempdir();
    for seed in 2..=5 {
        let mcap = dir.path().join(format!("field-{seed}.mcap"));
        let truth = field_run(&mcap, seed);
        let (time_constants_s, rise_k, sigma_k) = model_of(&mcap);
        assert_within_bars(&time_constants_s, &rise_k, &truth, &format!("seed {seed}"));
        // OE weights each output by 1/σ²: the field winding from U_f/I_f at 1 Hz (σ about
        // 0.2 K) is seen as noisier than the PT100s (0.05 K), so it weighs less.
        assert_eq!(sigma_k.len(), 4);
        for pt100 in &sigma_k[..3] {
            assert!((0.04..0.07).contains(pt100), "seed {seed}: {sigma_k:?} K");
        }
        assert!(
            (0.12..0.35).contains(&sigma_k[3]),
            "seed {seed}: {sigma_k:?} K"
        );
    }
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

/// The entry of one of the report's lists whose `key` is `value`.
fn entry<'a>(list: &'a Value, key: &str, value: &str) -> &'a Value {
    let found = list.as_array().unwrap().iter().find(|e| e[key] == value);
    found.unwrap_or_else(|| panic!("no entry with {key} = {value:?} in {list}"))
}

/// Seed 23 of the noisy four-node run (issue 33): rc's held fit (heat leaving only through
/// the cooling water) run first on the coarse grid stops short of its minimum there (its
/// likelihood ratio against the free fit 10.5, which rejects it, and the free network's G
/// is then 12.2 % off; its own Gauss–Newton step would still gain 6.4 χ² units, and its
/// winding's C is 2.6 standard errors off). The held fit at the full rate, continued from
/// where the coarse one stopped short, is kept by the score test at it (4.72 on 3 degrees
/// of freedom),
/// its network within issue 33's bars and every capacitance's 95 % interval holding the
/// truth.
#[test]
fn a_held_network_the_coarse_grid_left_short_is_refitted_at_the_full_rate() {
    let dir = common::tempdir();
    let truth = field_run(&dir.path().join("field.mcap"), 23);
    let report = replay_field(dir.path(), &[]);
    let network = &report["network"];
    let said = network["fitted_from"].as_str().unwrap();
    assert!(
        said.contains("heat leaves only through the cooling water"),
        "{said}"
    );
    assert!(said.contains("score test"), "{said}");
    // The decision names the test and its figures beside rc's fit.
    let decision = entry(&report["decisions"], "what", "network");
    let rc = entry(
        &decision["candidates"],
        "name",
        "rc's fit of C, G, K to the data",
    );
    let figure = |name: &str| {
        rc["figures"]
            .as_array()
            .unwrap()
            .iter()
            .find(|f| f["name"].as_str().unwrap().starts_with(name))
            .and_then(|f| f["value"].as_f64())
    };
    let statistic = figure("score test of heat through the cooling water alone").unwrap();
    let p = figure("its p").unwrap();
    assert!(statistic < 7.81 && p > 0.05, "S {statistic}, p {p}");
    let truth_network = truth.network.as_ref().unwrap();
    let intervals = &network["intervals_95"]["capacitance_j_per_k"];
    for (i, &want) in truth_network.capacitance_j_per_k.iter().enumerate() {
        let got = network["capacitance_j_per_k"][i].as_f64().unwrap();
        let se = intervals[i]["standard_error"].as_f64().unwrap();
        assert!(
            (got - want).abs() < 1.96 * se,
            "C[{i}] {got:.4e} J/K ± {se:.2e} against {want:.4e} J/K: {said}"
        );
    }
    let g = &network["conductance_w_per_k"];
    for (i, row) in truth_network.conductance_w_per_k.iter().enumerate() {
        for (j, &want) in row.iter().enumerate().filter(|(_, &w)| w > 0.0) {
            let got = g[i][j].as_f64().unwrap();
            assert!(
                (got / want - 1.0).abs() < 0.10,
                "G[{i}][{j}] {got:.0} W/K against {want:.0} W/K: {said}"
            );
        }
    }
}

/// `--field-state` on the paper's three-part machine (its U_f/I_f moves with the other
/// parts): one line that names the flag and says the data hold no fourth state, exit 2,
/// nothing written; it blamed the inputs ("not persistently exciting … replay a heat run").
#[test]
fn a_machine_without_a_fourth_state_is_told_to_replay_without_the_flag() {
    let dir = common::tempdir();
    let fixture = common::package_root().join("fixtures/paper_heat_run.mcap");
    let out = heatrun(
        &[
            "replay",
            fixture.to_str().unwrap(),
            "--field-state",
            "--rrd",
            "run.rrd",
        ],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "one line: {stderr}");
    assert!(
        stderr.contains("--field-state: the field winding's rise")
            && stderr.contains("no fourth state")
            && stderr.trim_end().ends_with("replay without --field-state"),
        "{stderr}"
    );
    assert!(common::files_in(dir.path()).is_empty(), "nothing written");
}
