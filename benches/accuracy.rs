//! Accuracy of every method on synthetic heat runs, over seeds and noise levels.
//!
//! `cargo bench --bench accuracy` prints, per machine, a table of the worst
//! time-constant error in % (median and worst over the seeds) and the worst
//! steady-state error in K, per method × noise level, and the time the default
//! method takes on the paper-length recording. Noise 1× is PT100-like: σ = 0.05 K
//! at 1 Hz with 0.01 K resolution, 0.05 % on the electrical channels
//! (`SynthOptions::with_noise_level`). Steady state: predicted final temperatures.

use std::time::Instant;

use heatrun::estimate::DiscreteModel;
use heatrun::model::{ContinuousModel, Spectrum};
use heatrun::pipeline::{self, Method, ReplayOptions};
use heatrun::synth::{self, SynthOptions};

fn second_machine() -> DiscreteModel {
    synth::second_machine_model()
}

fn main() {
    let seeds: Vec<u64> = (1..=5).collect();
    let levels = [0.0, 0.5, 1.0, 2.0];
    let dir = tempfile::tempdir().expect("temporary directory");
    for (machine, truth_model, duration) in [
        ("paper (eqs. 19-20)", synth::paper_model(), 20868.0),
        ("second machine", second_machine(), 30000.0),
    ] {
        let spectrum = Spectrum::of(&truth_model).expect("stable truth");
        let _ = ContinuousModel::from_discrete(&truth_model).expect("continuous truth");
        println!(
            "\n## {machine}: true time constants {:?} s, {duration} s at 1 Hz, {} seeds",
            spectrum
                .time_constants_s
                .iter()
                .map(|t| (t * 100.0).round() / 100.0)
                .collect::<Vec<_>>(),
            seeds.len()
        );
        println!("worst time-constant error, % (median over seeds / worst seed); steady state: worst |error|, K");
        print!("{:<6}", "method");
        for l in levels {
            print!(" | {:>22}", format!("noise {l}x"));
        }
        println!();
        let mut rows: Vec<Vec<String>> = vec![Vec::new(); Method::ALL.len()];
        for level in levels {
            let mut per_method: Vec<Vec<(f64, f64)>> = vec![Vec::new(); Method::ALL.len()];
            for &seed in &seeds {
                let path = dir.path().join(format!("run-{seed}-{level}.mcap"));
                let options = SynthOptions {
                    machine: synth::Machine::from_model(truth_model.clone()),
                    duration_s: duration,
                    seed,
                    ..SynthOptions::default()
                }
                .with_noise_level(level);
                let truth = synth::write(&path, &options).expect("synthetic run");
                for (mi, method) in Method::ALL.iter().enumerate() {
                    let replay = pipeline::replay(
                        &path,
                        &ReplayOptions {
                            method: *method,
                            ..ReplayOptions::default()
                        },
                    );
                    let entry = match replay {
                        Ok(r) => {
                            let tc = r
                                .analysis
                                .spectrum
                                .time_constants_s
                                .iter()
                                .zip(&truth.time_constants_s)
                                .map(|(t, w)| ((t - w) / w).abs() * 100.0)
                                .fold(0.0, f64::max);
                            // Steady-state temperatures: θ_0 (measured) + predicted rise against the truth.
                            let ss = (0..3)
                                .map(|j| {
                                    (r.signals.initial_references()[j]
                                        + 80.0 * r.analysis.steady_state[j]
                                        - truth.initial_temperatures_c[j]
                                        - truth.steady_state_rise_k[j])
                                        .abs()
                                })
                                .fold(0.0, f64::max);
                            (tc, ss)
                        }
                        Err(_) => (f64::INFINITY, f64::INFINITY),
                    };
                    per_method[mi].push(entry);
                }
            }
            for (mi, results) in per_method.iter().enumerate() {
                let mut tc: Vec<f64> = results.iter().map(|r| r.0).collect();
                tc.sort_by(f64::total_cmp);
                let worst_ss = results.iter().map(|r| r.1).fold(0.0, f64::max);
                let cell = if tc[tc.len() - 1].is_finite() {
                    format!(
                        "{:.2}/{:.2}% {:.3}K",
                        tc[tc.len() / 2],
                        tc[tc.len() - 1],
                        worst_ss
                    )
                } else {
                    format!("{:.2}/failed", tc[tc.len() / 2])
                };
                rows[mi].push(cell);
            }
        }
        for (mi, method) in Method::ALL.iter().enumerate() {
            print!("{:<6}", method.name());
            for c in &rows[mi] {
                print!(" | {c:>22}");
            }
            println!();
        }
    }

    // Speed of the default method on the paper-length recording (20,868 instants).
    let path = dir.path().join("speed.mcap");
    synth::write(&path, &SynthOptions::default().with_noise_level(1.0)).expect("run");
    let replay = pipeline::replay(&path, &ReplayOptions::default()).expect("replay");
    let mut times = Vec::new();
    for _ in 0..7 {
        let t = Instant::now();
        let _ = pipeline::estimate(&replay.data, &ReplayOptions::default()).expect("estimate");
        times.push(t.elapsed().as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    println!("\ndefault method ({}) on {} instants, 3 states, 3 inputs: median {:.3} s over {} runs (min {:.3}, max {:.3})",
        ReplayOptions::default().method.name(), replay.data.len(), times[times.len() / 2], times.len(), times[0], times[times.len() - 1]);
}
