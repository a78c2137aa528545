//! `heatrun predict`: a model report and a load schedule → predicted temperatures.

use heatrun::model_file::ThermalModel;
use heatrun::predict::{self, InitialState};

use super::Outcome;
use crate::cli::{ClassArg, InitialArg, PredictArgs};

pub fn run(args: PredictArgs) -> anyhow::Result<Outcome> {
    let model = ThermalModel::read(&args.model).map_err(heatrun::Error::from)?;
    let schedule = predict::load::read(&args.load, &model).map_err(heatrun::Error::from)?;
    let initial = match (&args.initial_temps, args.initial) {
        (Some(t), _) => InitialState::Temperatures(t.clone()),
        (None, InitialArg::Measured) => InitialState::Measured,
        (None, InitialArg::Steady) => InitialState::Steady,
    };
    let prediction = predict::predict(&model, &schedule, &initial).map_err(heatrun::Error::from)?;
    if let Some(page) = &args.html {
        super::rating::write_prediction_page(&args, &model, &schedule, &prediction, page)?;
    }
    prediction.write_csv(&args.out)?;
    if let Some(rrd) = &args.rrd {
        let limits = limits(&model, &args)?;
        heatrun_rerun::prediction::publish(
            &prediction,
            &schedule,
            &model,
            &limits,
            &heatrun_rerun::RerunSink::Rrd(rrd.clone()),
        )?;
    }
    for w in &prediction.warnings {
        eprintln!("warning: {w}");
    }
    if !args.quiet {
        let (t0, t1) = (
            prediction.time_s[0],
            prediction.time_s[prediction.time_s.len() - 1],
        );
        println!(
            "predicted {} instants, {t0} s to {t1} s at Ts = {} s, with the model {} -> {}",
            prediction.time_s.len(),
            model.ts_s,
            args.model.display(),
            args.out.display()
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
    Ok(Outcome::Complete)
}

/// The limits of `--class` and `--limit`, per part, as `rating` takes them.
fn limits(model: &ThermalModel, args: &PredictArgs) -> anyhow::Result<Vec<(String, f64)>> {
    if args.class.is_none() && args.limit.is_empty() {
        return Ok(Vec::new());
    }
    let options = heatrun::rating::RatingOptions {
        class: args.class.map(|c| match c {
            ClassArg::B => heatrun::rating::InsulationClass::B,
            ClassArg::F => heatrun::rating::InsulationClass::F,
            ClassArg::H => heatrun::rating::InsulationClass::H,
        }),
        limits_c: args.limit.clone(),
        power_factor: None,
        voltage_v: None,
        coolant_c: None,
        overloads: Vec::new(),
    };
    let parts = heatrun::rating::parts(model, &options).map_err(heatrun::Error::from)?;
    Ok(parts.into_iter().map(|p| (p.name, p.limit_c)).collect())
}
