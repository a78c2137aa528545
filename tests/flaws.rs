//! Glitches and stale values that no status marks (issue 22, item 3): the rc unit of known
//! truth at PT100-like noise (σ = 0.05 K at 0.01 K), with the flaws `heatrun synth` lays
//! on the written samples, replayed by the default method against the same run without
//! them (the same seed: the same noise everywhere else).

use std::path::Path;

use serde_json::Value;

use crate::common::{self, heatrun_ok};
use crate::outputs::ReportSchema;
use heatrun::pipeline::{replay, Replay, ReplayOptions};
use heatrun::screen::Why;
use heatrun::synth::{self, Flaws, Freeze, Machine, NetworkMachine, SynthOptions, Truth};

/// A noisy rc-unit heat run of `duration_s` (the default's 5.8 h if `None`) with `flaws`.
fn rc_run(path: &Path, duration_s: Option<f64>, seed: u64, flaws: Flaws) -> Truth {
    let base = SynthOptions::default();
    synth::write(
        path,
        &SynthOptions {
            machine: Machine::Network(NetworkMachine::rc_unit()),
            duration_s: duration_s.unwrap_or(base.duration_s),
            seed,
            flaws,
            ..base.with_noise_level(1.0)
        },
    )
    .unwrap()
}

fn replayed(path: &Path) -> Replay {
    // The flaws' effect on the model is under test, not the network: no rc fit.
    let options = ReplayOptions {
        network: heatrun::NetworkChoice::Nearest,
        ..ReplayOptions::default()
    };
    replay(path, &options).unwrap()
}

/// The largest relative difference between two replays' time constants.
fn moved(a: &Replay, b: &Replay) -> f64 {
    let (a, b) = (
        &a.analysis.spectrum.time_constants_s,
        &b.analysis.spectrum.time_constants_s,
    );
    a.iter()
        .zip(b)
        .map(|(x, y)| (x / y - 1.0).abs())
        .fold(0.0, f64::max)
}

/// Seconds of a left-out stretch's ends after the recording's first grid instant.
fn span_s(r: &Replay, from_ns: i64, to_ns: i64) -> (f64, f64) {
    let t0 = r.signals.time_ns[0];
    ((from_ns - t0) as f64 * 1e-9, (to_ns - t0) as f64 * 1e-9)
}

#[test]
fn ten_unflagged_glitches_move_the_time_constants_by_at_most_0_2_percent() {
    let dir = common::tempdir();
    let (clean, flawed) = (dir.path().join("clean.mcap"), dir.path().join("g.mcap"));
    rc_run(&clean, None, 1, Flaws::default());
    let truth = rc_run(
        &flawed,
        None,
        1,
        Flaws {
            glitches: 10,
            ..Flaws::default()
        },
    );
    let (clean, flawed) = (replayed(&clean), replayed(&flawed));
    assert!(clean.left_out.is_empty(), "{:?}", clean.left_out);
    let shift = moved(&flawed, &clean);
    assert!(shift <= 0.002, "moved {:.3} %", shift * 100.0);
    // The five +15 K glitches are left out where they were laid (the five fault codes
    // the recording stage drops as out of range).
    let laid: Vec<f64> = truth
        .flaws
        .unwrap()
        .glitches
        .iter()
        .filter(|g| g.value > 0.0)
        .map(|g| g.time_s)
        .collect();
    let found: Vec<f64> = flawed
        .left_out
        .iter()
        .map(|l| {
            assert_eq!(
                (l.why, l.channel.as_str(), l.instants()),
                (Why::Glitch, "core_temp", 1)
            );
            span_s(&flawed, l.from_ns, l.to_ns).0
        })
        .collect();
    assert_eq!(found.len(), laid.len(), "{found:?} against {laid:?}");
    for (f, t) in found.iter().zip(&laid) {
        assert!((f - t).abs() <= 0.5, "{found:?} against {laid:?}");
    }
}

#[test]
fn a_frozen_hour_is_named_and_moves_the_time_constants_by_at_most_1_percent() {
    let dir = common::tempdir();
    rc_run(&dir.path().join("clean.mcap"), None, 1, Flaws::default());
    let truth = rc_run(
        &dir.path().join("frozen.mcap"),
        None,
        1,
        Flaws {
            freeze: Some(Freeze {
                from_s: 9000.0,
                to_s: 12600.0,
            }),
            ..Flaws::default()
        },
    );
    heatrun_ok(
        &["replay", "frozen.mcap", "--report", "report.json", "-q"],
        dir.path(),
    );
    let report: Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("report.json")).unwrap()).unwrap();
    ReportSchema::load()
        .check(&report)
        .unwrap_or_else(|e| panic!("the report breaks the schema:\n{e}"));
    let left_out = report["left_out"].as_array().unwrap();
    assert_eq!(left_out.len(), 1, "{left_out:?}");
    let frozen = &left_out[0];
    let held = truth.flaws.unwrap().freeze.unwrap().value;
    assert_eq!(frozen["channel"], "stator_winding_temp");
    assert_eq!(frozen["why"], "frozen");
    assert_eq!(frozen["samples"], 3600);
    assert_eq!(frozen["from"], "2019-06-03T08:30:00Z");
    assert_eq!(frozen["to"], "2019-06-03T09:29:59Z");
    assert_eq!(frozen["value"].as_f64(), Some(held));
    let warnings: Vec<&str> = report["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(Value::as_str)
        .filter(|w| w.contains("frozen"))
        .collect();
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(warnings[0].starts_with(
        "stator_winding_temp: 3600 sample(s) from 2019-06-03T08:30:00Z to 2019-06-03T09:29:59Z left out"
    ));
    // The estimator's copy of the stretch is the model's prediction (the inputs computed
    // from that channel follow it), but the state keeps its readings as measured: what
    // the summary, the report's residuals and rerun's "measured" trace show is the frozen
    // value the sensor sent, not a value heatrun made up.
    let r = replayed(&dir.path().join("frozen.mcap"));
    assert_eq!(r.left_out.len(), 1, "{:?}", r.left_out);
    let stretch = &r.left_out[0];
    let measured = &r.signals.states[stretch.state].measured;
    for k in stretch.from_index..=stretch.to_index {
        assert_eq!(measured.get(k), Some(held), "instant {k}");
    }
    let clean = replayed(&dir.path().join("clean.mcap"));
    let tc: Vec<f64> = report["time_constants_s"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    let shift = tc
        .iter()
        .zip(&clean.analysis.spectrum.time_constants_s)
        .map(|(x, y)| (x / y - 1.0).abs())
        .fold(0.0, f64::max);
    assert!(
        shift <= 0.01,
        "{tc:?} against {:?}",
        clean.analysis.spectrum.time_constants_s
    );
}

#[test]
fn clean_noisy_runs_and_the_fixture_leave_nothing_out() {
    let dir = common::tempdir();
    for seed in 1..=12 {
        let path = dir.path().join(format!("clean-{seed}.mcap"));
        rc_run(&path, Some(7200.0), seed, Flaws::default());
        let r = replayed(&path);
        assert!(r.left_out.is_empty(), "seed {seed}: {:?}", r.left_out);
    }
    for seed in 1..=4 {
        let path = dir.path().join(format!("paper-{seed}.mcap"));
        synth::write(
            &path,
            &SynthOptions {
                duration_s: 7200.0,
                seed,
                ..SynthOptions::default().with_noise_level(2.0)
            },
        )
        .unwrap();
        let r = replayed(&path);
        assert!(r.left_out.is_empty(), "paper seed {seed}: {:?}", r.left_out);
    }
    let fixture = replayed(&common::package_root().join("fixtures/paper_heat_run.mcap"));
    assert!(fixture.left_out.is_empty(), "{:?}", fixture.left_out);
}
