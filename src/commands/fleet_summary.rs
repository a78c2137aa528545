//! `heatrun fleet summary`: the reports of a fleet's tasks (a Slurm array, a Kubernetes
//! Indexed Job, or a fleet replay) reduced into the fleet table, by the same reduction as
//! the fleet replay (`heatrun::fleet`).

use heatrun::fleet::{self as table, FleetRow, FleetTally, ReportRow};
use heatrun::store::{self, Location};

use super::{Outcome, Usage};
use crate::cli::FleetSummary;

/// The suffix of the reports a fleet writes (`<stem>.report.json`).
const REPORT_SUFFIX: &str = ".report.json";

/// Reads every report in the folder or prefix, writes `fleet-summary.csv` and prints the
/// table. Exit 2 if a report could not be read, else 3 if any recording lost data.
pub fn run(summary: &FleetSummary) -> anyhow::Result<Outcome> {
    let found = store::list(&summary.reports, REPORT_SUFFIX)?;
    if found.is_empty() {
        return Err(Usage(format!(
            "{}: no *{REPORT_SUFFIX} reports there",
            summary.reports
        ))
        .into());
    }
    let read: Vec<(Location, Result<ReportRow, String>)> = found
        .into_iter()
        .map(|location| {
            let row = read_row(&location).map_err(|e| super::hint::one_line(&e));
            (location, row)
        })
        .collect();
    // The columns follow the model of the first report that reads.
    let Some(model) = read
        .iter()
        .find_map(|(_, r)| r.as_ref().ok().map(|r| &r.model))
    else {
        // Why, in the first report's words (each names its own file).
        let first = read
            .iter()
            .find_map(|(_, r)| r.as_ref().err())
            .map(|why| format!(" (the first: {why})"))
            .unwrap_or_default();
        return Err(Usage(format!(
            "{}: none of its {} reports could be read{first}",
            summary.reports,
            read.len()
        ))
        .into());
    };
    let rows: Vec<FleetRow> = read
        .iter()
        .map(|(location, row)| FleetRow {
            recording: match row {
                Ok(r) => r.recording.clone(),
                Err(_) => location.to_string(),
            },
            outcome: row
                .as_ref()
                .map(|r| r.figures.clone())
                .map_err(Clone::clone),
        })
        .collect();
    let csv = table::fleet_csv(&rows, &table::csv_header(model))?;
    store::put(&summary.csv, &csv)?;
    print!("{}", table::table_text(&rows, model));
    let tally = FleetTally::of(&rows);
    println!(
        "{} reports: {} ok, {} with data loss, {} unreadable; table in {}",
        rows.len(),
        tally.ok,
        tally.data_lost,
        tally.failed,
        summary.csv
    );
    if tally.failed > 0 {
        return Err(Usage(format!(
            "{} of {} reports could not be read",
            tally.failed,
            rows.len()
        ))
        .into());
    }
    Ok(if tally.data_lost > 0 {
        Outcome::DataLoss
    } else {
        Outcome::Complete
    })
}

/// One report, read from its folder or store.
fn read_row(location: &Location) -> anyhow::Result<ReportRow> {
    let text = store::read_to_string(location)?;
    Ok(ReportRow::from_json(&text, &location.to_path()).map_err(heatrun::Error::from)?)
}
