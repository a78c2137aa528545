//! `heatrun fleet`: commands over a fleet's reports (`summary`: the fleet table of the
//! reports in a folder or prefix).

use std::path::PathBuf;

use clap::{Args, Subcommand};
use heatrun::store::Location;

/// Arguments of `heatrun fleet`.
#[derive(Debug, Args)]
pub struct FleetArgs {
    /// What to do with the fleet.
    #[command(subcommand)]
    pub command: FleetCommand,
}

/// `heatrun fleet`'s subcommands.
#[derive(Debug, Subcommand)]
pub enum FleetCommand {
    /// Reduce the reports (`*.report.json`) in a folder or prefix into the fleet table and
    /// its `fleet-summary.csv` (written there), as a fleet replay does.
    #[command(
        after_help = "Examples:\n  heatrun fleet summary results/\n  heatrun fleet summary s3://bucket/heatruns/2024-out/   # after a Slurm array or an Indexed Job"
    )]
    Summary(FleetSummaryArgs),
}

/// Arguments of `heatrun fleet summary`.
#[derive(Debug, Args)]
pub struct FleetSummaryArgs {
    /// The folder or prefix (`s3://bucket/out/`) holding the fleet's `*.report.json`.
    pub reports: PathBuf,
    /// Write the table here instead of `fleet-summary.csv` beside the reports.
    #[arg(long, value_name = "PATH|URL")]
    pub csv: Option<PathBuf>,
}

/// `heatrun fleet summary` as validated: where the reports are and where the table goes.
#[derive(Debug)]
pub struct FleetSummary {
    /// The folder or prefix of the reports.
    pub reports: Location,
    /// Where `fleet-summary.csv` goes.
    pub csv: Location,
}

impl TryFrom<FleetSummaryArgs> for FleetSummary {
    type Error = anyhow::Error;

    /// Reads both places as paths or URLs.
    fn try_from(args: FleetSummaryArgs) -> anyhow::Result<FleetSummary> {
        let reports = Location::from_path(&args.reports)?;
        let csv = match &args.csv {
            Some(path) => Location::from_path(path)?,
            None => reports.join(heatrun::fleet::SUMMARY_FILE),
        };
        Ok(FleetSummary { reports, csv })
    }
}
