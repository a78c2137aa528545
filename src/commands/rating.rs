//! `heatrun rating`: a model report → the machine's thermal rating; and the limits a
//! prediction's page draws.

use std::path::Path;

use heatrun::model_file::ThermalModel;
use heatrun::predict::{LoadSchedule, Prediction};
use heatrun::rating::{self, InsulationClass, RatingOptions};

use super::Outcome;
use crate::cli::{ClassArg, PredictArgs, RatingArgs};

fn class(arg: Option<ClassArg>) -> Option<InsulationClass> {
    arg.map(|c| match c {
        ClassArg::B => InsulationClass::B,
        ClassArg::F => InsulationClass::F,
        ClassArg::H => InsulationClass::H,
    })
}

pub fn run(args: RatingArgs) -> anyhow::Result<Outcome> {
    let model = ThermalModel::read(&args.model).map_err(heatrun::Error::from)?;
    let options = RatingOptions {
        class: class(args.class),
        limits_c: args.limit.clone(),
        power_factor: args.power_factor,
        voltage_v: args.voltage.map(|kv| kv * 1e3),
        coolant_c: args.coolant,
        overloads: args.overloads.iter().map(|p| p / 100.0).collect(),
    };
    let rating = rating::rate(&model, &options).map_err(heatrun::Error::from)?;
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&rating)?;
        heatrun::atomic::write_atomically(path, text.as_bytes())?;
    }
    if let Some(path) = &args.html {
        // The plot's curve: every 2 % from rated to twice rated current.
        let curve = rating::rate(
            &model,
            &RatingOptions {
                overloads: (50..=100).map(|i| f64::from(i) / 50.0).collect(),
                ..options.clone()
            },
        )
        .map_err(heatrun::Error::from)?
        .overloads;
        heatrun::html::rating_page(&rating, &model.name, Some(&curve)).write(path)?;
    }
    print!("{}", rating.table());
    Ok(Outcome::Complete)
}

/// `heatrun predict --html`: the prediction's page, with the limits of `--class` and
/// `--limit` drawn where given.
pub fn write_prediction_page(
    args: &PredictArgs,
    model: &ThermalModel,
    schedule: &LoadSchedule,
    prediction: &Prediction,
    page: &Path,
) -> anyhow::Result<()> {
    let limits = if args.class.is_none() && args.limit.is_empty() {
        Vec::new()
    } else {
        let options = RatingOptions {
            class: class(args.class),
            limits_c: args.limit.clone(),
            power_factor: None,
            voltage_v: None,
            coolant_c: None,
            overloads: Vec::new(),
        };
        rating::parts(model, &options).map_err(heatrun::Error::from)?
    };
    let view = heatrun::html::PredictionView {
        model,
        schedule,
        prediction,
        limits: &limits,
    };
    heatrun::html::predict_page(view).write(page)?;
    Ok(())
}
