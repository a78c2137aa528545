//! Accuracy of the default method on the rc unit with and without each coolant
//! disturbance (issue 9): an inlet drifting by 0, 1 and 3 K, a start 10 K and 25 K above
//! the coolant, a pump switched to 0.85 and 0.6 of the flow half-way. Each row is
//! replayed with the default `--reference auto` and with `--reference initial` (the
//! paper's formulation, which also leaves the flow out), over five seeds at PT100-like
//! noise.
//!
//! `cargo bench --bench coolant` prints, per disturbance and formulation, the worst
//! time-constant error in % (median / worst seed) and the worst error of the predicted
//! steady-state temperature at the final inlet temperature in K (median), against the
//! truth's final inlet plus its steady-state rises above it. With a pump switch the
//! truth is the network after the switch (its time constants and steady state at the
//! final flow); the model's time constants there are those of A_c at the final flow
//! (`spec::coolant::a_c_at_flow`; the paper's model has one A_c), and a second table
//! compares A_c itself with the truth at the initial flow.

use heatrun::pipeline::{replay, Replay, ReplayOptions};
use heatrun::spec::coolant::{a_c_at_flow, ReferencePolicy};
use heatrun::spec::InputSource;
use heatrun::synth::{
    self, Disturbances, Machine, NetworkMachine, PumpSwitch, SynthOptions, Truth,
};
use heatrun::thermal::matrix::eigenvalues;

fn sorted(v: &[f64]) -> Vec<f64> {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    v
}

/// The worst relative error of time constants against the truth's.
fn worst(time_constants: &[f64], truth: &[f64]) -> f64 {
    sorted(time_constants)
        .iter()
        .zip(sorted(truth))
        .map(|(t, want)| (t / want - 1.0).abs())
        .fold(0.0, f64::max)
}

/// The model's time constants at the run's final flow: A_c with the flow input's column
/// fed back from the outlet state, κ = −c·ρ·(Q_end − Q₀)·θ_base/P_base (c·ρ and the
/// flows as the truth records them: the flow channel's values). A model without the flow
/// input has one A_c.
fn time_constants_at_final_flow(r: &Replay, truth: &Truth) -> Vec<f64> {
    let a_c = &r.analysis.continuous.a_c;
    let flow_input = r
        .model
        .inputs
        .iter()
        .position(|i| matches!(i.source, InputSource::CoolantFlow { .. }));
    let (Some(j), Some(network), Some(change)) = (flow_input, &truth.network, truth.changes.last())
    else {
        return r.analysis.spectrum.time_constants_s.clone();
    };
    let s = &r.signals;
    let kappa = -network.heat_per_litre_j_per_k
        * (change.flow_l_per_s - truth.coolant.flow_l_per_s)
        * s.temperature_base_k
        / s.power_base;
    let b: Vec<f64> = r
        .analysis
        .continuous
        .b_c
        .column(j)
        .iter()
        .copied()
        .collect();
    let a = a_c_at_flow(a_c, &b, network.outlet_state, kappa);
    eigenvalues(&a, "A_c")
        .expect("eigenvalues")
        .iter()
        .map(|l| -1.0 / l.re)
        .collect()
}

/// Worst relative time-constant error at the final network, worst relative error of A_c's
/// own time constants against the initial network, worst steady-state temperature error, K.
fn errors(r: &Replay, truth: &Truth) -> (f64, f64, f64) {
    let (final_tc, final_rise) = match truth.changes.last() {
        Some(c) => (&c.time_constants_s, &c.steady_state_rise_k),
        None => (&truth.time_constants_s, &truth.steady_state_rise_k),
    };
    let tc = worst(&time_constants_at_final_flow(r, truth), final_tc);
    let initial = worst(
        &r.analysis.spectrum.time_constants_s,
        &truth.time_constants_s,
    );
    let s = &r.signals;
    let inlet_final = truth.coolant.inlet_final_c;
    let ss = r
        .analysis
        .steady_state
        .iter()
        .zip(s.initial_references())
        .zip(final_rise)
        .map(|((y, reference), want)| {
            (reference + y * s.temperature_base_k - (inlet_final + want)).abs()
        })
        .fold(0.0, f64::max);
    (tc, initial, ss)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// One disturbance: its name and what it sets.
struct Case {
    name: &'static str,
    disturbances: Disturbances,
}

fn cases() -> Vec<Case> {
    let d = |inlet_drift_k, start_above_k, pump: Option<f64>| Disturbances {
        inlet_drift_k,
        start_above_k,
        pump_switch: pump.map(|factor| PumpSwitch {
            time_s: 10_000.0,
            factor,
        }),
        ..Disturbances::default()
    };
    vec![
        Case {
            name: "constant inlet, cold start",
            disturbances: d(0.0, 0.0, None),
        },
        Case {
            name: "inlet drift 1 K",
            disturbances: d(1.0, 0.0, None),
        },
        Case {
            name: "inlet drift 3 K",
            disturbances: d(3.0, 0.0, None),
        },
        Case {
            name: "start 10 K above the coolant",
            disturbances: d(0.0, 10.0, None),
        },
        Case {
            name: "start 25 K above the coolant",
            disturbances: d(0.0, 25.0, None),
        },
        Case {
            name: "pump to 0.85 of the flow at 10,000 s",
            disturbances: d(0.0, 0.0, Some(0.85)),
        },
        Case {
            name: "pump to 0.6 of the flow at 10,000 s",
            disturbances: d(0.0, 0.0, Some(0.6)),
        },
    ]
}

fn main() {
    let seeds: Vec<u64> = (1..=5).collect();
    let dir = tempfile::tempdir().expect("temporary directory");
    let mut initial_rows = Vec::new();
    println!("| rc unit, PT100 noise, oe | `--reference auto` (default) | `--reference initial` (paper) |");
    println!("|---|---|---|");
    for case in cases() {
        let mut results = [Vec::new(), Vec::new()];
        let mut refused = [0, 0];
        for &seed in &seeds {
            let path = dir.path().join(format!("run-{seed}.mcap"));
            let truth = synth::write(
                &path,
                &SynthOptions {
                    machine: Machine::Network(NetworkMachine::rc_unit()),
                    disturbances: case.disturbances,
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
                    Ok(r) => results[i].push(errors(&r, &truth)),
                    Err(e) => {
                        refused[i] += 1;
                        eprintln!("{}, seed {seed}: {e}", case.name)
                    }
                }
            }
        }
        let cell = |r: &[(f64, f64, f64)], refused: usize, pick: fn(&(f64, f64, f64)) -> f64| {
            let note = if refused > 0 {
                format!(" ({refused} of {} refused)", seeds.len())
            } else {
                String::new()
            };
            if r.is_empty() {
                return format!("refused{note}");
            }
            let tc: Vec<f64> = r.iter().map(|e| 100.0 * pick(e)).collect();
            let worst = tc.iter().copied().fold(0.0, f64::max);
            let ss = median(r.iter().map(|e| e.2).collect());
            format!("{:.2} / {:.2} % {ss:.3} K{note}", median(tc), worst)
        };
        let final_cells: Vec<String> = (0..2)
            .map(|i| cell(&results[i], refused[i], |e| e.0))
            .collect();
        println!(
            "| {} | {} | {} |",
            case.name, final_cells[0], final_cells[1]
        );
        if case.disturbances.pump_switch.is_some() {
            let cells: Vec<String> = (0..2)
                .map(|i| cell(&results[i], refused[i], |e| e.1))
                .collect();
            initial_rows.push(format!("| {} | {} | {} |", case.name, cells[0], cells[1]));
        }
    }
    println!();
    println!("A_c's own time constants against the network at the initial flow (pump rows):");
    println!();
    println!("| rc unit, PT100 noise, oe | `--reference auto` (default) | `--reference initial` (paper) |");
    println!("|---|---|---|");
    for row in initial_rows {
        println!("{row}");
    }
}
