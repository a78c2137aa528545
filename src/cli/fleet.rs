//! `heatrun fleet`: commands over a fleet's reports (`summary`: the fleet table of the
//! reports in a folder or prefix; `compare`: same-design units side by side,
//! [`FleetCompare`]).

use std::path::PathBuf;

use clap::{Args, Subcommand};
use heatrun::fleet::compare::CompareOptions;
use heatrun::store::Location;

use super::outputs::{distinct, NamedFile};
use super::Usage;

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
    /// Lay same-design units' reports side by side (time constants, steady-state rises,
    /// the network, fit) and name the units that differ from the fleet beyond its spread
    /// and their own uncertainty.
    #[command(
        after_help = "Examples:\n  heatrun fleet compare reports/*.json\n  heatrun fleet compare u1.json u2.json u3.json u4.json --json compare.json --html compare.html"
    )]
    Compare(CompareArgs),
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

/// Arguments of `heatrun fleet compare`.
#[derive(Debug, Args)]
pub struct CompareArgs {
    /// The units' reports (`heatrun replay --report`), at least four, of one design.
    #[arg(value_name = "REPORT.json", required = true)]
    pub reports: Vec<PathBuf>,
    /// Write the comparison as JSON (the table and the outliers) to this file.
    #[arg(long, value_name = "OUT.json")]
    pub json: Option<PathBuf>,
    /// Also write the comparison as one self-contained HTML page.
    #[arg(long, value_name = "PAGE.html")]
    pub html: Option<PathBuf>,
    /// A unit is an outlier in a quantity whose score exceeds this.
    #[arg(long, default_value_t = CompareOptions::default().threshold)]
    pub threshold: f64,
    /// The fleet's spread is at least this percentage of a quantity's scale.
    #[arg(long, value_name = "PCT", default_value_t = CompareOptions::default().floor * 100.0)]
    pub floor: f64,
}

/// `heatrun fleet compare` as validated.
#[derive(Debug)]
pub struct FleetCompare {
    /// The reports, as given (the outputs name each unit by its path as typed).
    pub reports: Vec<PathBuf>,
    /// How the fleet is judged.
    pub options: CompareOptions,
    /// The JSON output, if asked for.
    pub json: Option<PathBuf>,
    /// The HTML page, if asked for.
    pub html: Option<PathBuf>,
}

impl TryFrom<CompareArgs> for FleetCompare {
    type Error = anyhow::Error;

    /// The options in the library's units (the floor a fraction), once in range.
    fn try_from(args: CompareArgs) -> anyhow::Result<FleetCompare> {
        if !(args.threshold.is_finite() && args.threshold > 0.0) {
            return Err(Usage(format!(
                "--threshold {}: must be a positive number",
                args.threshold
            ))
            .into());
        }
        if !(0.0..100.0).contains(&args.floor) {
            return Err(Usage(format!("--floor {}: a percentage in [0, 100)", args.floor)).into());
        }
        let reads: Vec<NamedFile> = args
            .reports
            .iter()
            .map(|p| NamedFile::new("the report", p))
            .collect();
        let writes: Vec<NamedFile> = [("--json", &args.json), ("--html", &args.html)]
            .into_iter()
            .filter_map(|(what, p)| p.as_deref().map(|p| NamedFile::new(what, p)))
            .collect();
        distinct(&reads, &writes)?;
        Ok(FleetCompare {
            reports: args.reports,
            options: CompareOptions {
                threshold: args.threshold,
                floor: args.floor / 100.0,
            },
            json: args.json,
            html: args.html,
        })
    }
}
