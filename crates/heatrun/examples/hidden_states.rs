//! Identifies a model with hidden states from a recording and a spec, and validates it:
//!
//!   cargo run --release -p heatrun --example hidden_states -- SPEC RECORDING
//!       (--split-at SECONDS | --validate RECORDING) [--order N | --largest N]
//!       [--free] [--feedthrough]
//!
//! The spec's states are the measured outputs; the order (given, or chosen among
//! 1 ..= largest on the estimation part alone) adds the hidden states. Prints the orders
//! tried, the time constants, the steady-state gain and the NRMSE fit per output on the
//! estimation and validation data (each segment from its fitted initial state; with a
//! split also simulated through from the estimation part, no validation output used).
//!
//! With `--cv-methods iv,wls,oe` it also cross-validates the measured-state estimators
//! named (C = I, D = 0) on the estimation part's folds, as the order is, and validates them.
//!
//! With `--measured-report REPORT --measured-spec SPEC` it also prints the validation
//! fit of a measured-state replay's model (REPORT's Φ, Γ on SPEC's signals: C = I, D = 0)
//! under the same protocol (x0 fitted to the validation outputs), beside the hidden one.

use std::path::PathBuf;

use heatrun::estimate::IdentificationData;
use heatrun::hidden::order::{
    compare, fit_of, folds as folds_of, mean_fit_percent, without, Pooled,
};
use heatrun::hidden::{self, HiddenOptions, OrderChoice, OutputMatrix};
use heatrun::pipeline::{prepare, ReplayOptions};
use heatrun::spec::coolant::ReferencePolicy;
use heatrun::spec::ModelDescription;

fn main() {
    if let Err(e) = run() {
        eprintln!("hidden_states: {e}");
        std::process::exit(2);
    }
}

fn per_output(model: &hidden::HiddenStateModel, data: &IdentificationData) -> Vec<f64> {
    fit_of(model, data).nrmse_fit_percent
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (spec, recording) = match args.as_slice() {
        [s, r, ..] => (PathBuf::from(s), PathBuf::from(r)),
        _ => return Err("usage: SPEC RECORDING (--split-at S | --validate REC) …".into()),
    };
    let value = |flag: &str| {
        args.iter()
            .position(|a| a == flag)
            .and_then(|i| args.get(i + 1).cloned())
    };
    let mut options = HiddenOptions {
        output_matrix: if args.iter().any(|a| a == "--free") {
            OutputMatrix::Free
        } else {
            OutputMatrix::Measured
        },
        feedthrough: args.iter().any(|a| a == "--feedthrough"),
        ..HiddenOptions::default()
    };
    if let Some(n) = value("--order") {
        options.order = OrderChoice::Given(n.parse()?);
    }
    if let Some(n) = value("--largest") {
        options.order = OrderChoice::Chosen {
            largest: n.parse()?,
        };
    }
    let model = ModelDescription::from_toml_file(&spec)?;
    let replay = ReplayOptions {
        ts_s: model.sample_time_s.unwrap_or(1.0),
        model,
        ..ReplayOptions::default()
    };
    let prepared = prepare(&recording, &replay)?;
    let (estimation, validation, through) = match (value("--split-at"), value("--validate")) {
        (Some(t), _) => {
            let k = (t.parse::<f64>()? / replay.ts_s).round() as usize;
            let n = prepared.data.len();
            (prepared.data.slice(0..k), prepared.data.slice(k..n), true)
        }
        (_, Some(other)) => {
            let same = ReplayOptions {
                model: prepared.model.clone(),
                reference: ReferencePolicy::Initial,
                ..replay.clone()
            };
            (
                prepared.data.clone(),
                prepare(&PathBuf::from(other), &same)?.data,
                false,
            )
        }
        _ => return Err("give --split-at SECONDS or --validate RECORDING".into()),
    };
    let estimate = hidden::identify(&estimation, &options)?;
    for c in &estimate.candidates {
        println!(
            "order {:2}: cross-validated fit {:>7} %  AIC {:>10}  cost 2J/N {:>9}  {}",
            c.order,
            c.hold_back_fit_percent
                .map_or("-".into(), |f| format!("{f:.1}")),
            c.aic.map_or("-".into(), |a| format!("{a:.0}")),
            c.estimation_cost.map_or("-".into(), |a| format!("{a:.5}")),
            c.refused.as_deref().unwrap_or("")
        );
    }
    let m = &estimate.model;
    println!(
        "chosen order {} ({:?}, feedthrough {})",
        m.order(),
        options.output_matrix,
        options.feedthrough
    );
    println!(
        "estimation cost 2J/N: {:.6} ({} evaluations)",
        estimate.estimation_cost, estimate.evaluations
    );
    println!("time constants s: {:.2?}", m.time_constants_s());
    println!(
        "steady-state gain: {:.4?}",
        m.steady_state_gain().map(|g| g.as_slice().to_vec())
    );
    println!("estimation fit %: {:.1?}", per_output(m, &estimation));
    let v = per_output(m, &validation);
    println!(
        "validation fit % (x0 fitted): {:.1?} mean {:.1}",
        v,
        mean_fit_percent(m, &validation)
    );
    if through {
        // The state carried from the estimation part's start through to the end.
        let whole = &prepared.data;
        let x0 = m.fitted_initial_state(&estimation, 0..estimation.len());
        let sim = m.simulate(whole, 0..whole.len(), &x0);
        let k = estimation.len();
        let tail = sim.rows(k, whole.len() - k).into_owned();
        let f = compare(&validation, &tail).nrmse_fit_percent;
        let mean = f.iter().sum::<f64>() / f.len() as f64;
        println!("validation fit % (simulated through): {f:.1?} mean {mean:.1}");
    }
    if let Some(methods) = value("--cv-methods") {
        for method in methods.split(',') {
            measured_state_cv(method, &estimation, &validation, &replay, options.folds())?;
        }
    }
    if let (Some(report), Some(spec)) = (value("--measured-report"), value("--measured-spec")) {
        measured_state_fit(
            &report,
            &spec,
            &recording,
            &value("--split-at"),
            &value("--validate"),
        )?;
    }
    Ok(())
}

/// A measured-state estimator (`method`: iv, wls, oe, …) judged as the hidden order is:
/// cross-validated on `folds` contiguous folds of the estimation data (each simulated by
/// the model of the rest, x0 fitted to its outputs, errors pooled), then identified on all
/// of it and validated under the same protocol.
fn measured_state_cv(
    method: &str,
    estimation: &IdentificationData,
    validation: &IdentificationData,
    replay: &ReplayOptions,
    folds: usize,
) -> Result<(), Box<dyn std::error::Error>> {
    let options = ReplayOptions {
        method: method.parse()?,
        ..replay.clone()
    };
    let identify = |data: &IdentificationData| -> Result<hidden::HiddenStateModel, String> {
        let e = heatrun::pipeline::estimate(data, &options).map_err(|e| e.to_string())?;
        let n = e.model.phi.nrows();
        Ok(hidden::HiddenStateModel {
            phi: e.model.phi.clone(),
            gamma: e.model.gamma.clone(),
            c: nalgebra::DMatrix::identity(n, n),
            d: nalgebra::DMatrix::zeros(n, e.model.gamma.ncols()),
            ts_s: estimation.ts_s,
        })
    };
    let mut pooled = Pooled::new(estimation.states());
    for fold in folds_of(estimation.len(), folds) {
        let model = identify(&without(estimation, fold.clone()))?;
        let held = estimation.slice(fold);
        pooled.add(&held, &model.simulate_segments(&held));
    }
    let model = identify(estimation)?;
    println!(
        "measured-state {method}: cross-validated fit {:.1} %, estimation fit {:.1?}, \
         validation fit (x0 fitted) {:.1?}, time constants {:.1?}",
        pooled.fit_percent(),
        per_output(&model, estimation),
        per_output(&model, validation),
        model.time_constants_s()
    );
    Ok(())
}

/// The measured-state model of a replay's report (C = I, D = 0) validated as the hidden
/// model is: each validation segment from the initial state fitted to its outputs.
fn measured_state_fit(
    report: &str,
    spec: &str,
    recording: &std::path::Path,
    split_at: &Option<String>,
    validate: &Option<String>,
) -> Result<(), Box<dyn std::error::Error>> {
    let thermal = heatrun::model_file::ThermalModel::read(std::path::Path::new(report))?;
    let description = ModelDescription::from_toml_file(std::path::Path::new(spec))?;
    let replay = ReplayOptions {
        ts_s: description.sample_time_s.unwrap_or(1.0),
        model: description,
        ..ReplayOptions::default()
    };
    let prepared = prepare(recording, &replay)?;
    let validation = match (split_at, validate) {
        (Some(t), _) => {
            let k = (t.parse::<f64>()? / replay.ts_s).round() as usize;
            prepared.data.slice(k..prepared.data.len())
        }
        (_, Some(other)) => {
            let same = ReplayOptions {
                model: prepared.model.clone(),
                reference: ReferencePolicy::Initial,
                ..replay.clone()
            };
            prepare(&PathBuf::from(other), &same)?.data
        }
        _ => return Err("give --split-at SECONDS or --validate RECORDING".into()),
    };
    let n = thermal.phi.nrows();
    let model = hidden::HiddenStateModel {
        phi: thermal.phi.clone(),
        gamma: thermal.gamma.clone(),
        c: nalgebra::DMatrix::identity(n, n),
        d: nalgebra::DMatrix::zeros(n, thermal.gamma.ncols()),
        ts_s: thermal.ts_s,
    };
    println!(
        "measured-state model, validation fit % (x0 fitted): {:.1?} mean {:.1}",
        per_output(&model, &validation),
        mean_fit_percent(&model, &validation)
    );
    Ok(())
}
