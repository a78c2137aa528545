//! Calibration of the default estimator against `oe` on noisy heat runs of the RC unit
//! (its truth file's time constants, 70.8 / 709.9 / 4,503.5 s with the default schedule):
//! white sensor noise alone, and with an unmeasured heat walk into the cooling water.
//!
//! `cargo bench --bench calibration` prints, per case and estimator, for each time
//! constant: the bias and the spread over the seeds (% of the truth), the mean reported
//! standard error (the Cramér–Rao bound the estimator's covariance estimates, half the
//! 95 % interval over 1.96) and the 95 % intervals' coverage; then the worst steady-state
//! error (K) and its intervals' coverage, and which estimator the default chose; for
//! `oe` and `pem` given and for the default.
//! `HEATRUN_CAL_SEEDS` (default 12) sets the seeds of the white case, half as many for
//! each disturbed one; `HEATRUN_CAL_WALKS` the cases, kW/√h (default `0,3,30`; 0 is the
//! white case; 10 kW/√h wanders the outlet by 0.05–0.19 K over the run, seeds 1–5).

use heatrun::pipeline::{self, Method, ReplayOptions};
use heatrun::synth::{self, Disturbances, Machine, NetworkMachine, SynthOptions};

/// One replay's figures: time constants and their half-widths (s), steady-state
/// temperature errors and their half-widths (K), the method used.
struct Run {
    tc: Vec<f64>,
    tc_ci: Vec<f64>,
    ss_error: Vec<f64>,
    ss_ci: Vec<f64>,
    method: Method,
}

fn replay(path: &std::path::Path, truth: &synth::Truth, method: Method, choose: bool) -> Run {
    let r = pipeline::replay(
        path,
        &ReplayOptions {
            method,
            choose_estimator: choose,
            ..ReplayOptions::default()
        },
    )
    .expect("replay");
    let base = r.signals.temperature_base_k;
    let u = r.analysis.uncertainty.as_ref().expect("a covariance");
    let refs = r.signals.initial_references();
    Run {
        tc: r.analysis.spectrum.time_constants_s.clone(),
        tc_ci: u.time_constants_ci95_s.clone(),
        ss_error: (0..refs.len())
            .map(|j| {
                refs[j] + base * r.analysis.steady_state[j]
                    - truth.coolant.inlet_initial_c
                    - truth.steady_state_rise_k[j]
            })
            .collect(),
        ss_ci: u.steady_state_ci95.iter().map(|v| v * base).collect(),
        method: r.estimate.method,
    }
}

fn report(name: &str, runs: &[Run], truth: &[f64]) {
    let n = runs.len() as f64;
    println!("  {name}:");
    for (i, t) in truth.iter().enumerate() {
        let rel: Vec<f64> = runs.iter().map(|r| (r.tc[i] - t) / t * 100.0).collect();
        let mean = rel.iter().sum::<f64>() / n;
        let sd = (rel.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let se = runs
            .iter()
            .map(|r| r.tc_ci[i] / 1.96 / t * 100.0)
            .sum::<f64>()
            / n;
        let covered = runs
            .iter()
            .filter(|r| (r.tc[i] - t).abs() <= r.tc_ci[i])
            .count();
        println!(
            "    T{} {:>7.1} s: bias {:+.3} %, spread {:.3} %, reported σ {:.3} % (spread/σ {:.2}), 95 % coverage {}/{}, worst |error| {:.2} %",
            i + 1,
            t,
            mean,
            sd,
            se,
            sd / se,
            covered,
            runs.len(),
            rel.iter().fold(0.0_f64, |m, v| m.max(v.abs()))
        );
    }
    let worst_ss = runs
        .iter()
        .flat_map(|r| r.ss_error.iter())
        .fold(0.0_f64, |m, v| m.max(v.abs()));
    let (covered, all) = runs.iter().fold((0, 0), |(c, a), r| {
        let inside = r
            .ss_error
            .iter()
            .zip(&r.ss_ci)
            .filter(|(e, h)| e.abs() <= **h);
        (c + inside.count(), a + r.ss_error.len())
    });
    let pem = runs.iter().filter(|r| r.method == Method::Pem).count();
    println!(
        "    steady state: worst |error| {worst_ss:.3} K, 95 % coverage {covered}/{all}; estimator pem in {pem}/{} runs",
        runs.len()
    );
}

fn main() {
    let seeds: u64 = std::env::var("HEATRUN_CAL_SEEDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(12);
    let dir = tempfile::tempdir().expect("temporary directory");
    let walks: Vec<f64> = std::env::var("HEATRUN_CAL_WALKS")
        .ok()
        .map(|s| s.split(',').filter_map(|w| w.trim().parse().ok()).collect())
        .unwrap_or_else(|| vec![0.0, 3.0, 30.0]);
    let cases = walks.iter().map(|&walk| {
        if walk == 0.0 {
            (
                "white sensor noise (σ 0.05 K, 0.01 K resolution)".to_string(),
                0.0,
                seeds,
            )
        } else {
            (
                format!("with {walk} kW/√h unmeasured heat into the cooling water"),
                walk,
                seeds.div_ceil(2),
            )
        }
    });
    for (case, walk, count) in cases {
        let (mut oe, mut pem, mut default) = (Vec::new(), Vec::new(), Vec::new());
        let mut truth_tc = Vec::new();
        for seed in 1..=count {
            let path = dir.path().join(format!("run-{seed}-{walk}.mcap"));
            let options = SynthOptions {
                machine: Machine::Network(NetworkMachine::rc_unit()),
                disturbances: Disturbances {
                    coolant_heat_walk_kw_per_sqrt_h: walk,
                    ..Disturbances::default()
                },
                temperature_noise_k: 0.05,
                temperature_resolution_k: 0.01,
                seed,
                ..SynthOptions::default()
            };
            let truth = synth::write(&path, &options).expect("synthetic run");
            truth_tc = truth.time_constants_s.clone();
            oe.push(replay(&path, &truth, Method::Oe, false));
            pem.push(replay(&path, &truth, Method::Pem, false));
            default.push(replay(&path, &truth, Method::Oe, true));
        }
        println!("\n## rc-unit, {case}, {count} seeds");
        report("oe (given)", &oe, &truth_tc);
        report("pem (given)", &pem, &truth_tc);
        report(
            "default (oe, or pem with the disturbance state where oe's residuals are not white and the likelihood ratio rejects q = 0)",
            &default,
            &truth_tc,
        );
    }
}
