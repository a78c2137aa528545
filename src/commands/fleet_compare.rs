//! `heatrun fleet compare`: units' reports → the fleet's table and its outliers.

use heatrun::fleet::compare;

use super::Outcome;
use crate::cli::FleetCompare;

/// Reads every report, compares the fleet, writes the JSON and the page, then prints the
/// table and a line for each unit that differs.
pub fn run(request: &FleetCompare) -> anyhow::Result<Outcome> {
    let units = request
        .reports
        .iter()
        .map(|path| compare::read_unit(path, &path.display().to_string()))
        .collect::<Result<Vec<_>, _>>()
        .map_err(heatrun::Error::from)?;
    let comparison = compare::compare(&units, &request.options).map_err(heatrun::Error::from)?;
    if let Some(path) = &request.json {
        let text = serde_json::to_string_pretty(&comparison)?;
        heatrun::atomic::write_atomically(path, text.as_bytes())?;
    }
    if let Some(path) = &request.html {
        heatrun::html::fleet_compare_page(&comparison)?.write(path)?;
    }
    print!("{}", comparison.summary());
    Ok(Outcome::Complete)
}
