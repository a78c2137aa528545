//! `heatrun predict`: its flags, and the [`Predict`] they are turned into (where the
//! prediction starts, the limits drawn, the sink).

use std::path::PathBuf;

use clap::{Args, ValueEnum};
use heatrun::predict::InitialState;
use heatrun::rating::RatingOptions;
use heatrun_rerun::RerunSink;

use super::outputs::{distinct, NamedFile};
use super::rating::{parse_limit, ClassArg};
use super::viewer::{Offer, ViewerArgs};
use super::Usage;

/// Where a prediction starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum InitialArg {
    /// The temperatures at the start of the model's recording.
    Measured,
    /// The steady state of the schedule's first row.
    Steady,
}

/// `predict`'s rerun output: an .rrd only (a prediction is a file's worth, not a stream).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PredictViewer;

impl Offer for PredictViewer {
    const RRD: (&'static str, &'static str) = (
        "OUT.rrd",
        "Also save the schedule, the losses and the predicted temperatures (with the limits \
         of --class and --limit) to this rerun .rrd file",
    );
}

/// Arguments of `heatrun predict`.
#[derive(Debug, Args)]
// The limits are drawn: they need an output that draws them (.rrd or HTML).
#[command(group(clap::ArgGroup::new("drawn").args(["rrd", "html"]).multiple(true)))]
pub struct PredictArgs {
    /// The model: a report written by `heatrun replay --report`.
    #[arg(long, value_name = "REPORT.json")]
    pub model: PathBuf,
    /// The load schedule (CSV): time_s and either armature_current_a, field_current_a,
    /// line_voltage_kv, or apparent_power_mva with power_factor; optional coolant_inlet_temp_c.
    #[arg(long, value_name = "LOAD.csv")]
    pub load: PathBuf,
    /// The predicted temperatures (CSV: time_s and <state>_c per state).
    #[arg(long, value_name = "PRED.csv")]
    pub out: PathBuf,
    /// Where the prediction starts.
    #[arg(long, value_enum, default_value_t = InitialArg::Measured, conflicts_with = "initial_temps")]
    pub initial: InitialArg,
    /// Start from these temperatures, °C, one per state in the model's order.
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "T1,T2,...",
        allow_hyphen_values = true
    )]
    pub initial_temps: Option<Vec<f64>>,
    /// `--rrd`.
    #[command(flatten)]
    pub viewer: ViewerArgs<PredictViewer>,
    /// Insulation class whose limits (IEC 60034-1, Table 7) the .rrd and the HTML page
    /// draw (as `rating --class`).
    #[arg(long, value_enum, requires = "drawn")]
    pub class: Option<ClassArg>,
    /// A part's limit the .rrd and the HTML page draw, °C (repeatable; overrides the
    /// class's): STATE=°C.
    #[arg(long, value_name = "STATE=°C", value_parser = parse_limit, requires = "drawn")]
    pub limit: Vec<(String, f64)>,
    /// Do not print the summary.
    #[arg(long, short)]
    pub quiet: bool,
    /// Also write the prediction as one self-contained HTML page (schedule, losses,
    /// temperatures against the limits, peaks).
    #[arg(long, value_name = "PAGE.html")]
    pub html: Option<PathBuf>,
}

/// `heatrun predict` as the library takes it.
#[derive(Debug)]
pub struct Predict {
    /// The model report.
    pub model: PathBuf,
    /// The load schedule.
    pub load: PathBuf,
    /// The predicted temperatures' CSV.
    pub out: PathBuf,
    /// Where the prediction starts.
    pub initial: InitialState,
    /// The limits drawn (`--class`, `--limit`), as `rating` takes them; `None`: none given.
    pub limits: Option<RatingOptions>,
    /// Where the rerun data go, if anywhere.
    pub sink: Option<RerunSink>,
    /// The HTML page, if asked for.
    pub html: Option<PathBuf>,
    /// Print no summary.
    pub quiet: bool,
}

impl TryFrom<PredictArgs> for Predict {
    type Error = Usage;

    /// The starting state and the limits as the library takes them; the sink of `--rrd`.
    /// Outputs that would replace the model, the schedule or each other are refused.
    fn try_from(args: PredictArgs) -> Result<Predict, Usage> {
        let predict = Predict {
            initial: match (args.initial_temps, args.initial) {
                (Some(t), _) => InitialState::Temperatures(t),
                (None, InitialArg::Measured) => InitialState::Measured,
                (None, InitialArg::Steady) => InitialState::Steady,
            },
            limits: super::rating::limits_only(args.class, args.limit),
            sink: args.viewer.sink(),
            model: args.model,
            load: args.load,
            out: args.out,
            html: args.html,
            quiet: args.quiet,
        };
        let mut writes = vec![NamedFile::new("--out", &predict.out)];
        if let Some(RerunSink::Rrd(path)) = &predict.sink {
            writes.push(NamedFile::new("--rrd", path));
        }
        writes.extend(predict.html.as_deref().map(|p| NamedFile::new("--html", p)));
        distinct(
            &[
                NamedFile::new("--model", &predict.model),
                NamedFile::new("--load", &predict.load),
            ],
            &writes,
        )?;
        Ok(predict)
    }
}
