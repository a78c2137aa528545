//! Command-line definitions.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};

/// Thermal system identification of hydro generators from MCAP heat-run recordings.
#[derive(Debug, Parser)]
#[command(name = "heatrun", version, about, long_about = None)]
pub struct Cli {
    /// The command.
    #[command(subcommand)]
    pub command: Command,
}

/// heatrun's commands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Replay a heat-run recording into a thermal model, a report and a rerun recording.
    Replay(ReplayArgs),
    /// Write a synthetic heat run simulated from a known model (the paper's by default).
    Synth(SynthArgs),
    /// Show what a recording holds: channels, quantities, units, rates, span, gaps, nameplate.
    Info(InfoArgs),
    /// Convert a table (CSV, historian export, whitespace-separated .dat) into a recording.
    Import(ImportArgs),
}

/// Identification method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum MethodArg {
    /// Ordinary least squares (eq. 7); biased when the temperatures are noisy.
    Ls,
    /// Weighted least squares (eqs. 3-7) with --weights.
    Wls,
    /// Recursive least squares with --forgetting; its trajectory goes to rerun.
    Rls,
    /// Iterated instrumental variables (instruments from the simulated model).
    Iv,
    /// Output error: minimises the simulation error by Levenberg-Marquardt from IV.
    Oe,
}

/// Arguments of `heatrun replay`.
#[derive(Debug, Args)]
pub struct ReplayArgs {
    /// Recordings (MCAP, heatrun SCADA profile), or folders of them. Default: the shipped
    /// fixture. More than one recording (or a folder) replays a fleet in parallel.
    pub files: Vec<PathBuf>,
    /// Sample time Ts of the model in seconds.
    #[arg(long, default_value_t = 1.0)]
    pub ts: f64,
    /// Machine file (TOML) whose keys override the recording's nameplate.
    #[arg(long, value_name = "FILE.toml")]
    pub machine: Option<PathBuf>,
    /// Identification method (oe: unbiased under sensor noise, the most accurate).
    #[arg(long, value_enum, default_value_t = MethodArg::Oe)]
    pub method: MethodArg,
    /// Per-state weights w_i of wls and oe, comma-separated (oe default: 1/noise variance).
    #[arg(long, value_delimiter = ',', value_name = "W1,W2,W3")]
    pub weights: Option<Vec<f64>>,
    /// Forgetting factor of rls, in (0, 1].
    #[arg(long, default_value_t = 1.0)]
    pub forgetting: f64,
    /// Hold out the last FRACTION of the recording and report the model's fit on it.
    #[arg(long, value_name = "FRACTION", conflicts_with = "validate")]
    pub holdout: Option<f64>,
    /// Report the model's fit on another recording of the same machine.
    #[arg(long, value_name = "FILE")]
    pub validate: Option<PathBuf>,
    /// Save the rerun recording to this .rrd file (the default: <recording>.rrd here).
    #[arg(long, value_name = "PATH")]
    pub rrd: Option<PathBuf>,
    /// Stream to a running rerun viewer (optionally at this gRPC URL).
    #[arg(long, value_name = "URL", num_args = 0..=1, default_missing_value = "")]
    pub connect: Option<String>,
    /// Start a rerun viewer and stream to it.
    #[arg(long)]
    pub spawn: bool,
    /// Write the JSON report (profile section "Report") to this file.
    #[arg(long, value_name = "PATH")]
    pub report: Option<PathBuf>,
    /// Also publish every channel at its full rate (columns streamed as the file is read).
    #[arg(long)]
    pub raw: bool,
    /// Fleet mode: the folder for each recording's .rrd and report and the fleet summary.
    #[arg(long, value_name = "DIR", default_value = ".")]
    pub out_dir: PathBuf,
    /// Fleet mode: recordings replayed at once (default: the number of cores).
    #[arg(long)]
    pub jobs: Option<usize>,
    /// Do not print the summary.
    #[arg(long, short)]
    pub quiet: bool,
}

/// How the synthetic recording carries the field winding temperature.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FieldArg {
    /// A field_voltage channel (resistance method).
    Voltage,
    /// A field_winding_temp channel.
    Temperature,
    /// No channel: the nameplate's final field temperature (the paper's method).
    Nameplate,
}

/// Arguments of `heatrun synth`.
#[derive(Debug, Args)]
pub struct SynthArgs {
    /// The MCAP file to write; the true model goes to OUT.truth.json.
    pub out: PathBuf,
    /// Duration in seconds (the paper's heat run: 20868 s).
    #[arg(long, default_value_t = 20868.0)]
    pub duration: f64,
    /// Sample rate of the electrical channels, Hz.
    #[arg(long, default_value_t = 1.0)]
    pub electrical_rate: f64,
    /// Sample rate of the temperature channels, Hz.
    #[arg(long, default_value_t = 1.0)]
    pub temperature_rate: f64,
    /// Gaussian temperature noise σ, K (PT100-like: 0.05).
    #[arg(long, default_value_t = 0.0)]
    pub temperature_noise: f64,
    /// Gaussian electrical noise σ, relative (0.002 = 0.2 %).
    #[arg(long, default_value_t = 0.0)]
    pub electrical_noise: f64,
    /// Temperature resolution, K (0: none; PT100 transducers: 0.01).
    #[arg(long, default_value_t = 0.0)]
    pub resolution: f64,
    /// Random seed of the noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// How the field winding temperature is recorded.
    #[arg(long, value_enum, default_value_t = FieldArg::Voltage)]
    pub field: FieldArg,
    /// Operating profile.
    #[arg(long, value_enum, default_value_t = ProfileArg::LoadSteps)]
    pub profile: ProfileArg,
    /// Write uncompressed chunks instead of zstd.
    #[arg(long)]
    pub uncompressed: bool,
    /// Store the temperatures by exception, as a SCADA historian does: a sample only
    /// when it moved by more than this many kelvin since the last stored one (or the
    /// heartbeat passed).
    #[arg(long, value_name = "K")]
    pub deadband: Option<f64>,
    /// With --deadband: the heartbeat, the longest time between stored samples, s.
    #[arg(long, value_name = "S", default_value_t = 600.0, requires = "deadband")]
    pub heartbeat: f64,
}

/// Operating profile of a synthetic run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ProfileArg {
    /// A heat run with load and excitation steps (all three heat sources excited).
    LoadSteps,
    /// One step to the final operating point (the inputs are nearly collinear).
    SingleStep,
}

/// Arguments of `heatrun info`.
#[derive(Debug, Args)]
pub struct InfoArgs {
    /// The recording.
    pub file: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `heatrun import`.
#[derive(Debug, Args)]
pub struct ImportArgs {
    /// The table: comma, semicolon, tab or whitespace separated, with or without a header.
    pub input: PathBuf,
    /// The map (TOML) that names the time column and the channels.
    #[arg(long, value_name = "MAP.toml", required_unless_present = "guess")]
    pub map: Option<PathBuf>,
    /// The recording to write (MCAP, heatrun SCADA profile).
    #[arg(long, value_name = "OUT.mcap", required_unless_present = "guess")]
    pub out: Option<PathBuf>,
    /// Print a starting map guessed from the table's header instead, to be edited.
    #[arg(long, conflicts_with_all = ["map", "out"])]
    pub guess: bool,
}
