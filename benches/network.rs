//! The thermal network of a known machine from synthetic heat runs, over seeds.
//!
//! `cargo bench --bench network` writes heat runs of [`generator_like`] (not the paper's
//! model) at PT100-like noise (σ = 0.05 K, 0.01 K resolution, 0.05 % on the electrical
//! channels; `SynthOptions::with_noise_level(1.0)`), the paper's 20,868 s heat-run profile
//! at 1 Hz, and replays each with `oe` (the network of the identified model) and `rc`
//! (the network estimated in C, G and K). It prints, per method, a table of every C, G and
//! k_ij: the truth, the median over the seeds, the median and the worst error (relative
//! for C and G, absolute for k_ij), then how many seeds met the acceptance bar (every C
//! and G within 10 %, every k_ij within 0.05) and the median time of a replay.

use std::time::Instant;

use heatrun::estimate::DiscreteModel;
use heatrun::model::matrix::discretize;
use heatrun::network::example::{generator_like, rich_heat_run};
use heatrun::network::{Interval, Labels, Network, NetworkIntervals, Parts, ScaleSource, Scaling};
use heatrun::pipeline::{replay, Method, ReplayOptions};
use heatrun::recording::Nameplate;
use heatrun::synth::{self, SynthOptions};

/// One parameter: its name, unit factor for printing, truth, and whether its error is
/// relative.
struct Row {
    name: String,
    unit: &'static str,
    factor: f64,
    truth: f64,
    relative: bool,
    found: Vec<f64>,
}

fn rows(parts: &Parts, labels: &Labels) -> Vec<Row> {
    let short = |s: &str| s.split_whitespace().last().unwrap_or(s).to_owned();
    let mut rows = Vec::new();
    for (i, c) in parts.capacitance_j_per_k.iter().enumerate() {
        rows.push(Row {
            name: format!("C {}", labels.states[i]),
            unit: "MJ/K",
            factor: 1e-6,
            truth: *c,
            relative: true,
            found: Vec::new(),
        });
    }
    let n = labels.states.len();
    for i in 0..n {
        for j in i..n {
            let name = if i == j {
                format!("G {} to coolant", labels.states[i])
            } else {
                format!(
                    "G {}–{}",
                    short(&labels.states[i]),
                    short(&labels.states[j])
                )
            };
            rows.push(Row {
                name,
                unit: "kW/K",
                factor: 1e-3,
                truth: parts.conductance_w_per_k[(i, j)],
                relative: true,
                found: Vec::new(),
            });
        }
    }
    for j in 0..labels.inputs.len() {
        for i in 0..n {
            rows.push(Row {
                name: format!("k {} → {}", labels.inputs[j], short(&labels.states[i])),
                unit: "",
                factor: 1.0,
                truth: parts.loss_distribution[(i, j)],
                relative: false,
                found: Vec::new(),
            });
        }
    }
    rows
}

/// The network's values in the order of [`rows`].
fn values(network: &Network) -> Vec<f64> {
    let n = network.capacitance_j_per_k.len();
    let mut v = network.capacitance_j_per_k.clone();
    for i in 0..n {
        for j in i..n {
            v.push(network.conductance_w_per_k[i][j]);
        }
    }
    for j in 0..network.inputs.len() {
        for i in 0..n {
            v.push(network.loss_distribution[i][j]);
        }
    }
    v
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let k = v.len();
    if k % 2 == 1 {
        v[k / 2]
    } else {
        0.5 * (v[k / 2 - 1] + v[k / 2])
    }
}

fn error(row: &Row, x: f64) -> f64 {
    if row.relative {
        (x - row.truth).abs() / row.truth
    } else {
        (x - row.truth).abs()
    }
}

fn main() {
    let (parts, labels) = generator_like();
    println!(
        "# the network of `generator_like` (benches/network.rs), 10 seeds each, PT100-like noise"
    );
    for (scenario, profile, duration_s) in [
        (
            "the default heat run (20,868 s, the paper's profile)",
            synth::heat_run_with_load_steps(),
            20868.0,
        ),
        (
            "a heat run moving every loss (40,000 s, 32 points)",
            rich_heat_run(),
            40000.0,
        ),
    ] {
        println!("\n# {scenario}");
        run_scenario(&parts, &labels, profile, duration_s);
    }
}

fn run_scenario(
    parts: &Parts,
    labels: &Labels,
    profile: Vec<synth::OperatingPoint>,
    duration_s: f64,
) {
    let seeds: Vec<u64> = (1..=10).collect();
    let nameplate = Nameplate::paper_table1();
    let scaling = Scaling {
        theta_base_k: nameplate.temperature_base_k,
        p_base_w: nameplate.rated_apparent_power_va,
    };
    let network = Network::from_parts(parts, scaling, ScaleSource::EnergyConservation, labels)
        .expect("a valid network");
    let (a, b) = network.to_continuous();
    let (phi, gamma) = discretize(&a, &b, 1.0);
    let truth = DiscreteModel {
        phi,
        gamma,
        ts_s: 1.0,
    };
    let dir = tempfile::tempdir().expect("temporary directory");
    let paths: Vec<_> = seeds
        .iter()
        .map(|&seed| {
            let path = dir.path().join(format!("rc-{seed}.mcap"));
            synth::write(
                &path,
                &SynthOptions {
                    machine: synth::Machine::from_model(truth.clone()),
                    seed,
                    profile: profile.clone(),
                    duration_s,
                    ..SynthOptions::default()
                }
                .with_noise_level(1.0),
            )
            .expect("synthetic heat run");
            path
        })
        .collect();
    for method in [Method::Oe, Method::Rc] {
        let mut found: Vec<Vec<f64>> = Vec::new();
        let mut other: Vec<Vec<f64>> = Vec::new();
        let mut other_from = None;
        let mut outside = Vec::new();
        let mut distances = Vec::new();
        let mut times = Vec::new();
        for path in &paths {
            let start = Instant::now();
            let r = replay(
                path,
                &ReplayOptions {
                    method,
                    ..ReplayOptions::default()
                },
            )
            .expect("replay");
            times.push(start.elapsed().as_secs_f64());
            let Ok(network) = r.network.network.as_ref() else {
                println!("{}: no network on {}", method.name(), path.display());
                continue;
            };
            let v = values(network);
            if let Some(d) = &network.minimum_distance {
                distances.push((
                    d.distance,
                    d.degrees_of_freedom,
                    d.p_value,
                    d.weighting.clone(),
                ));
            }
            // The other scale multiplies every C, G and k_ij by one factor.
            if let Some(alt) = &network.alternative_scale {
                other.push(v.iter().map(|x| x * alt.ratio_to_chosen).collect());
                other_from = Some(alt.scale_from);
            }
            if let Some(iv) = &network.intervals_95 {
                let truth = rows(parts, labels);
                let held = intervals(iv)
                    .iter()
                    .zip(&truth)
                    .filter(|(i, row)| i.is_none_or(|i| row.truth < i.low || row.truth > i.high))
                    .count();
                outside.push(held);
            }
            found.push(v);
        }
        let title = if method == Method::Rc {
            "the grey-box fit in C, G, K".to_owned()
        } else {
            "the identified model (the passive network nearest it, minimum distance; the calorimetric scale, the runs record the flow)"
                .to_owned()
        };
        table(parts, labels, method.name(), &title, &found, &mut times);
        if !distances.is_empty() {
            let rejected = distances
                .iter()
                .filter(|(_, _, p, _)| p.is_some_and(|p| p < 0.05))
                .count();
            let regularised = distances
                .iter()
                .filter(|(_, _, _, w)| w.contains("regularised"))
                .count();
            let per_seed: Vec<String> = distances
                .iter()
                .map(|(d, _, _, _)| format!("{d:.1}"))
                .collect();
            println!(
                "minimum distance to the identified model (χ², {} degrees of freedom) per seed: [{}]; \
                 p < 0.05 on {rejected} of {}; Σ̂ regularised on {regularised}",
                distances[0].1,
                per_seed.join(", "),
                distances.len()
            );
        }
        if let Some(from) = other_from {
            let title = match from {
                ScaleSource::EnergyConservation => {
                    "the identified model, scaled by energy conservation instead (each column of K sums to 1)"
                }
                ScaleSource::Calorimetric => {
                    "the grey-box fit, scaled by the calorimetric balance instead (G_out,0 = c·ρ·Q)"
                }
            };
            table(parts, labels, method.name(), title, &other, &mut times);
        }
        if !outside.is_empty() {
            let entries = rows(parts, labels).len();
            println!(
                "truth outside its 95 % interval: {} of {} entries over the seeds (per seed: {:?})",
                outside.iter().sum::<usize>(),
                entries * outside.len(),
                outside
            );
        }
    }
}

/// The intervals in the order of [`rows`].
fn intervals(iv: &NetworkIntervals) -> Vec<Option<Interval>> {
    let n = iv.capacitance_j_per_k.len();
    let mut v = iv.capacitance_j_per_k.clone();
    for i in 0..n {
        for j in i..n {
            v.push(iv.conductance_w_per_k[i][j]);
        }
    }
    let m = iv.loss_distribution.first().map_or(0, Vec::len);
    for j in 0..m {
        for row in &iv.loss_distribution {
            v.push(row[j]);
        }
    }
    v
}

/// Prints the table of one method over the seeds: truth, median, median and worst error,
/// and the seeds meeting the bar.
fn table(
    parts: &Parts,
    labels: &Labels,
    method: &str,
    title: &str,
    found: &[Vec<f64>],
    times: &mut [f64],
) {
    let mut table = rows(parts, labels);
    let mut met = 0;
    for v in found {
        let ok = table
            .iter()
            .zip(v)
            .all(|(row, x)| error(row, *x) <= if row.relative { 0.10 } else { 0.05 });
        met += usize::from(ok);
        for (row, x) in table.iter_mut().zip(v) {
            row.found.push(*x);
        }
    }
    println!(
        "\n## {method} ({} seeds, PT100-like noise): the network of {title}",
        found.len()
    );
    println!(
        "| parameter | unit | truth | median | median error | worst error |\n|---|---|---|---|---|---|"
    );
    for row in &table {
        let mut errs: Vec<f64> = row.found.iter().map(|x| error(row, *x)).collect();
        let worst = errs.iter().copied().fold(0.0, f64::max);
        let med_err = median(&mut errs);
        let mut found = row.found.clone();
        let med = median(&mut found);
        let e = |x: f64| {
            if row.relative {
                format!("{:.1} %", 100.0 * x)
            } else {
                format!("{x:.3}")
            }
        };
        println!(
            "| {} | {} | {:.3} | {:.3} | {} | {} |",
            row.name,
            row.unit,
            row.truth * row.factor,
            med * row.factor,
            e(med_err),
            e(worst)
        );
    }
    println!(
        "seeds meeting the bar (C, G within 10 %, k_ij within 0.05): {met} of {}; median replay {:.2} s",
        found.len(),
        median(times)
    );
}
