//! `heatrun predict`: a model report and a load schedule → predicted temperatures.

use heatrun::model_file::ThermalModel;
use heatrun::predict::{self, Prediction};
use heatrun::rating;

use super::Outcome;
use crate::cli::Predict;

/// Predicts, writes the CSV (and the page and the .rrd, with the limits drawn), then prints
/// each part's start and peak.
pub fn run(request: &Predict) -> anyhow::Result<Outcome> {
    let model = ThermalModel::read(&request.model).map_err(heatrun::Error::from)?;
    let schedule = predict::load::read(&request.load, &model).map_err(heatrun::Error::from)?;
    let prediction =
        predict::predict(&model, &schedule, &request.initial).map_err(heatrun::Error::from)?;
    // The limits, per part, once for both outputs that draw them; a limit naming no part is
    // refused before anything is written.
    let limits = match &request.limits {
        Some(options) => rating::parts(&model, options).map_err(heatrun::Error::from)?,
        None => Vec::new(),
    };
    if let Some(page) = &request.html {
        let view = heatrun::html::PredictionView {
            model: &model,
            schedule: &schedule,
            prediction: &prediction,
            limits: &limits,
        };
        heatrun::html::predict_page(view).write(page)?;
    }
    prediction.write_csv(&request.out)?;
    if let Some(sink) = &request.sink {
        let limits: Vec<(String, f64)> =
            limits.iter().map(|p| (p.name.clone(), p.limit_c)).collect();
        heatrun_rerun::prediction::publish(&prediction, &schedule, &model, &limits, sink)?;
    }
    for w in &prediction.warnings {
        eprintln!("warning: {w}");
    }
    if !request.quiet {
        print_summary(request, &model, &prediction);
    }
    Ok(Outcome::Complete)
}

/// What was predicted, from when to when, and each part's start and peak.
fn print_summary(request: &Predict, model: &ThermalModel, prediction: &Prediction) {
    let (t0, t1) = (
        prediction.time_s[0],
        prediction.time_s[prediction.time_s.len() - 1],
    );
    println!(
        "predicted {} instants, {t0} s to {t1} s at Ts = {} s, with the model {} -> {}",
        prediction.time_s.len(),
        model.ts_s,
        request.model.display(),
        request.out.display()
    );
    println!(
        "  {:<28}{:>10}{:>12}{:>12}",
        "state", "start °C", "peak °C", "at s"
    );
    for (j, (peak, at)) in prediction.peaks().into_iter().enumerate() {
        println!(
            "  {:<28}{:>10.2}{:>12.2}{:>12.0}",
            prediction.states[j], prediction.temperatures_c[0][j], peak, at
        );
    }
}
