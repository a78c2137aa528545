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

use heatrun::estimate::{DiscreteModel, Estimate, Estimator, OutputError};
use heatrun::model::{propagate, Spectrum};
use heatrun::network::{Interval, Labels, Network, NetworkIntervals, Parts, ScaleSource, Scaling};
use heatrun::pipeline::{prepare, replay, Method, ReplayOptions};
use heatrun::recording::Nameplate;
use heatrun::synth::example::{generator_like, rich_heat_run};
use heatrun::synth::{self, SynthOptions};
use heatrun::thermal::matrix::discretize;

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
    // `cargo bench --bench network -- offset`: only the paper's time constants with and
    // without the output offset.
    if std::env::args().any(|a| a == "offset") {
        offset_on_the_paper_model();
        return;
    }
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

/// The paper's model (`SynthOptions::default()`, the fixture's machine) at PT100-like
/// noise, seeds 1–20: `oe`'s time constants with the output offset d
/// (`OutputError::refit_with_output_offset` from oe's start, what the network is fitted
/// to) and without it (`oe` as it reports its model), each constant's median and worst relative error, how many
/// seeds are within the accuracy bar's 2 %, and how often the 95 % interval holds the
/// truth.
fn offset_on_the_paper_model() {
    let seeds: Vec<u64> = (1..=20).collect();
    let dir = tempfile::tempdir().expect("temporary directory");
    let oe = OutputError::default();
    // Per variant (with d, without), per seed: relative errors and whether covered.
    let mut errors: [Vec<Vec<f64>>; 2] = [Vec::new(), Vec::new()];
    let mut covered: [Vec<Vec<bool>>; 2] = [Vec::new(), Vec::new()];
    let mut truth_tc = Vec::new();
    for &seed in &seeds {
        let path = dir.path().join(format!("paper-{seed}.mcap"));
        let truth = synth::write(
            &path,
            &SynthOptions {
                seed,
                ..SynthOptions::default()
            }
            .with_noise_level(1.0),
        )
        .expect("synthetic heat run");
        truth_tc.clone_from(&truth.time_constants_s);
        let prepared = prepare(&path, &ReplayOptions::default()).expect("prepare");
        let data = &prepared.data;
        let start = oe.start(data).expect("start");
        let with = oe
            .refit_with_output_offset(data, &start)
            .expect("oe with the offset");
        assert!(with.output_offset.is_some());
        let without = oe.estimate(data).expect("oe");
        let u = prepared.signals.last_inputs().expect("inputs").1;
        for (v, e) in [&with, &without].into_iter().enumerate() {
            let (err, cov) = time_constants(e, &truth.time_constants_s, &u);
            errors[v].push(err);
            covered[v].push(cov);
        }
    }
    println!(
        "# the paper's model, PT100-like noise, {} seeds: oe's time constants with and without the output offset",
        seeds.len()
    );
    println!("| time constant | truth, s | variant | median error | worst error | seeds within 2 % | worst of seeds 1–5 | 95 % interval holds the truth |");
    println!("|---|---|---|---|---|---|---|---|");
    for (i, tau) in truth_tc.iter().enumerate() {
        for (v, name) in ["with d", "without d"].iter().enumerate() {
            let mut e: Vec<f64> = errors[v].iter().map(|s| s[i].abs()).collect();
            let worst = e.iter().copied().fold(0.0, f64::max);
            let first5 = e[..5].iter().copied().fold(0.0, f64::max);
            let within = e.iter().filter(|x| **x < 0.02).count();
            let held = covered[v].iter().filter(|c| c[i]).count();
            println!(
                "| τ{} | {tau:.1} | {name} | {:.2} % | {:.2} % | {within} of {} | {:.2} % | {held} of {} |",
                i + 1,
                100.0 * median(&mut e),
                100.0 * worst,
                seeds.len(),
                100.0 * first5,
                seeds.len()
            );
        }
    }
    for (v, name) in ["with d", "without d"].iter().enumerate() {
        let per_seed: Vec<String> = errors[v]
            .iter()
            .map(|s| format!("{:+.2}", 100.0 * s[0]))
            .collect();
        println!(
            "fastest constant's error per seed, {name}, %: [{}]",
            per_seed.join(", ")
        );
    }
}

/// The relative error of each time constant (ascending) and whether its 95 % interval
/// holds the truth.
fn time_constants(e: &Estimate, truth: &[f64], u: &[f64]) -> (Vec<f64>, Vec<bool>) {
    let found = Spectrum::of(&e.model)
        .expect("real time constants")
        .time_constants_s;
    let ci = propagate(e, u).map(|u| u.time_constants_ci95_s);
    let err = found.iter().zip(truth).map(|(f, t)| (f - t) / t).collect();
    let cov = found
        .iter()
        .zip(truth)
        .enumerate()
        .map(|(i, (f, t))| ci.as_ref().is_some_and(|c| (f - t).abs() <= c[i]))
        .collect();
    (err, cov)
}
