//! `heatrun rating`: a model report → the machine's thermal rating.

use heatrun::predict::ThermalModel;
use heatrun::rating::{self, InsulationClass, RatingOptions};

use super::Outcome;
use crate::cli::{ClassArg, RatingArgs};

pub fn run(args: RatingArgs) -> anyhow::Result<Outcome> {
    let model = ThermalModel::read(&args.model).map_err(heatrun::Error::from)?;
    let options = RatingOptions {
        class: args.class.map(|c| match c {
            ClassArg::B => InsulationClass::B,
            ClassArg::F => InsulationClass::F,
            ClassArg::H => InsulationClass::H,
        }),
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
    print!("{}", rating.table());
    Ok(Outcome::Complete)
}
