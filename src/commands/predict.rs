//! `heatrun predict`: a model report and a load schedule → predicted temperatures.

use heatrun::predict::{self, InitialState, ThermalModel};

use super::Outcome;
use crate::cli::{InitialArg, PredictArgs};

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
