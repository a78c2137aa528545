//! Accuracy of the default method on the rc unit with and without each coolant
//! disturbance (issue 9): an inlet drifting by 0, 1 and 3 K, a start 10 K and 25 K above
//! the coolant. Each row is replayed with the default `--reference auto` and with
//! `--reference initial` (the paper's formulation), over five seeds at PT100-like noise.
//!
//! `cargo bench --bench coolant` prints, per disturbance and formulation, the worst
//! time-constant error in % (median / worst seed) and the worst error of the predicted
//! steady-state temperature at the final inlet temperature in K (median), against the
//! truth's final inlet plus its steady-state rises above it.

use heatrun::pipeline::{replay, Replay, ReplayOptions};
use heatrun::spec::coolant::ReferencePolicy;
use heatrun::synth::{self, Disturbances, Machine, NetworkMachine, SynthOptions, Truth};

/// Worst relative time-constant error and worst steady-state temperature error, K.
fn errors(r: &Replay, truth: &Truth) -> (f64, f64) {
    let sorted = |v: &[f64]| {
        let mut v = v.to_vec();
        v.sort_by(f64::total_cmp);
        v
    };
    let tc = sorted(&r.analysis.spectrum.time_constants_s)
        .iter()
        .zip(sorted(&truth.time_constants_s))
        .map(|(t, want)| (t / want - 1.0).abs())
        .fold(0.0, f64::max);
    let s = &r.signals;
    let inlet_final = truth.coolant.inlet_final_c;
    let ss = r
        .analysis
        .steady_state
        .iter()
        .zip(s.initial_references())
        .zip(&truth.steady_state_rise_k)
        .map(|((y, reference), want)| {
            (reference + y * s.temperature_base_k - (inlet_final + want)).abs()
        })
        .fold(0.0, f64::max);
    (tc, ss)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let seeds: Vec<u64> = (1..=5).collect();
    let dir = tempfile::tempdir().expect("temporary directory");
    let cases = [
        ("constant inlet, cold start", 0.0, 0.0),
        ("inlet drift 1 K", 1.0, 0.0),
        ("inlet drift 3 K", 3.0, 0.0),
        ("start 10 K above the coolant", 0.0, 10.0),
        ("start 25 K above the coolant", 0.0, 25.0),
    ];
    println!("| rc unit, PT100 noise, oe | `--reference auto` (default) | `--reference initial` (paper) |");
    println!("|---|---|---|");
    for (name, drift, warm) in cases {
        let mut cells = Vec::new();
        let mut results = [(Vec::new(), Vec::new()), (Vec::new(), Vec::new())];
        for &seed in &seeds {
            let path = dir.path().join(format!("run-{seed}.mcap"));
            let truth = synth::write(
                &path,
                &SynthOptions {
                    machine: Machine::Network(NetworkMachine::rc_unit()),
                    disturbances: Disturbances {
                        inlet_drift_k: drift,
                        start_above_k: warm,
                        ..Disturbances::default()
                    },
                    seed,
                    ..SynthOptions::default().with_noise_level(1.0)
                },
            )
            .expect("synthetic run");
            for (i, reference) in [ReferencePolicy::Auto, ReferencePolicy::Initial]
                .into_iter()
                .enumerate()
            {
                let options = ReplayOptions {
                    reference,
                    ..ReplayOptions::default()
                };
                match replay(&path, &options) {
                    Ok(r) => {
                        let (tc, ss) = errors(&r, &truth);
                        results[i].0.push(tc * 100.0);
                        results[i].1.push(ss);
                    }
                    Err(e) => eprintln!("{name}, seed {seed}: {e}"),
                }
            }
        }
        for (tc, ss) in results {
            cells.push(if tc.is_empty() {
                "refused".to_owned()
            } else {
                let worst = tc.iter().copied().fold(0.0, f64::max);
                format!("{:.2} / {:.2} % {:.3} K", median(tc), worst, median(ss))
            });
        }
        println!("| {name} | {} | {} |", cells[0], cells[1]);
    }
}
