//! `heatrun rating`: a model report → the machine's thermal rating.

use heatrun::model_file::ThermalModel;
use heatrun::rating::{self, RatingOptions};

use super::Outcome;
use crate::cli::Rating;

/// Rates the machine, writes the JSON and the page, then prints the rating's table.
pub fn run(request: &Rating) -> anyhow::Result<Outcome> {
    let model = ThermalModel::read(&request.model).map_err(heatrun::Error::from)?;
    let rating = rating::rate(&model, &request.options).map_err(heatrun::Error::from)?;
    if let Some(path) = &request.json {
        let text = serde_json::to_string_pretty(&rating)?;
        heatrun::atomic::write_atomically(path, text.as_bytes())?;
    }
    if let Some(path) = &request.html {
        // The plot's curve: every 2 % from rated to twice rated current.
        let curve = rating::overload_curve(
            &model,
            &RatingOptions {
                overloads: (50..=100).map(|i| f64::from(i) / 50.0).collect(),
                ..request.options.clone()
            },
        )
        .map_err(heatrun::Error::from)?;
        heatrun::html::rating_page(&rating, &model.name, Some(&curve)).write(path)?;
    }
    print!("{}", rating.table());
    // Warnings on stderr, as predict and monitor print theirs: stdout holds the table alone.
    for w in &rating.warnings {
        eprintln!("warning: {w}");
    }
    Ok(Outcome::Complete)
}
