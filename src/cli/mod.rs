//! The command line, in two layers (as ripgrep's flags: `lowargs.rs`, `hiargs.rs`).
//!
//! - **What was typed**: clap's structs ([`Cli`], one `*Args` per command). clap checks
//!   what it can declare (types, required flags, flags that exclude or need each other)
//!   and refuses the rest of the line itself (exit status 2).
//! - **What is asked for**: a [`Request`], built once from them. Every check clap cannot
//!   declare is made here, raising [`Usage`] (exit status 2):
//!   ranges, combinations that depend on values, the recordings a replay names (one or a
//!   fleet). The values come out as the library takes them (its options, methods, sinks),
//!   so the handlers in [`crate::commands`] only do the work.
//!
//! Each command's file holds both layers for that command: its flags and its request.

mod fleet;
mod import;
mod method;
mod monitor;
mod outputs;
mod predict;
mod rating;
mod replay;
mod synth;
mod viewer;

#[cfg(test)]
mod tests;

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

pub use fleet::{FleetArgs, FleetCommand, FleetCompare, FleetSummary};
pub use import::{Import, ImportArgs};
pub use monitor::{Input, Monitor, MonitorArgs};
pub use predict::{Predict, PredictArgs};
pub use rating::{Rating, RatingArgs};
pub use replay::{stem, Fleet, One, Replay, ReplayArgs, SummaryFormat, Target};
pub use synth::{Synth, SynthArgs};

/// A command line that cannot run as given: a value out of range, a flag that needs
/// another (exit status 2, as the input's fault). Raised where the command line is
/// validated (here), and by a fleet some of whose recordings failed; the library
/// never raises it.
#[derive(Debug)]
pub struct Usage(pub String);

impl std::fmt::Display for Usage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Usage {}

/// Thermal system identification of hydro generators from MCAP heat-run recordings.
#[derive(Debug, Parser)]
#[command(name = "heatrun", version, about, long_about = None)]
pub struct Cli {
    /// The command to run (`heatrun <COMMAND> --help` for its options).
    #[command(subcommand)]
    pub command: Command,
}

/// heatrun's commands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Replay a heat-run recording into a thermal model, a report and a rerun recording.
    // A negative number is a value (`--ts -1`), for the command's own check to name
    // what the option takes, not clap's "unexpected argument '-1'".
    #[command(
        allow_negative_numbers = true,
        after_help = "Examples:\n  heatrun replay                                   # the shipped fixture\n  heatrun replay run.mcap --report run.json --rrd run.rrd\n  heatrun replay run.mcap --split-at 14400 --summary json | jq .validation\n  heatrun replay archive/ --out-dir results --jobs 4   # a fleet"
    )]
    Replay(ReplayArgs),
    /// Write a synthetic heat run simulated from a known model (the paper's by default).
    #[command(
        allow_negative_numbers = true,
        after_help = "Examples:\n  heatrun synth run.mcap --temperature-noise 0.05 --seed 7\n  heatrun synth drift.mcap --machine rc-unit --inlet-drift 3"
    )]
    Synth(SynthArgs),
    /// Show what a recording holds: channels, quantities, units, rates, span, gaps, nameplate.
    #[command(after_help = "Example:\n  heatrun info run.mcap --json")]
    Info(InfoArgs),
    /// Convert a table (CSV, historian export, whitespace-separated .dat) into a recording.
    #[command(
        after_help = "Examples:\n  heatrun import --guess export.csv > map.toml   # a starting map to edit\n  heatrun import export.csv --map map.toml --out run.mcap"
    )]
    Import(ImportArgs),
    /// Print a shell completion script (bash, zsh, fish, elvish, powershell).
    #[command(
        after_help = "Example:\n  heatrun completions bash > ~/.local/share/bash-completion/completions/heatrun"
    )]
    Completions(CompletionsArgs),
    /// Print heatrun's man pages (roff): every command's, with every option, or one command's.
    #[command(
        after_help = "Examples:\n  heatrun man | man -l -\n  heatrun man replay --out heatrun-replay.1 && man ./heatrun-replay.1\n  heatrun man --out-dir man && man -l man/heatrun-fleet-summary.1"
    )]
    Man(ManArgs),
    /// Predict every part's temperature under a load schedule, from a model report.
    #[command(allow_negative_numbers = true)]
    Predict(PredictArgs),
    /// The machine's thermal rating: largest continuous power, limiting part, overloads.
    #[command(allow_negative_numbers = true)]
    Rating(RatingArgs),
    /// Run a model beside a later recording of the machine; alarm where a part leaves the
    /// model's band.
    #[command(
        allow_negative_numbers = true,
        after_help = "Exit status: 0 healthy (no alarm), 4 alarms raised, 2 bad input (a report of \
another profile or without the needed blocks, a recording lacking a state's channel), 3 data \
lost from the recording (no alarm), 1 any other failure.\n\nExamples:\n  heatrun monitor --model model.json service.mcap\n  heatrun monitor --model model.json service.mcap --json alarms.json --rrd service.rrd --hold 300\n  tail -c +1 -f growing.mcap | heatrun monitor --model model.json - --connect"
    )]
    Monitor(MonitorArgs),
    /// Work with a fleet's reports: `summary` reduces them into the fleet table, `compare`
    /// names the units that differ from the fleet.
    #[command(
        after_help = "Examples:\n  heatrun fleet summary results/\n  heatrun fleet compare reports/*.json --json compare.json"
    )]
    Fleet(FleetArgs),
}

/// Arguments of `heatrun info`.
#[derive(Debug, Args)]
pub struct InfoArgs {
    /// The recording: a path, or a URL (s3://, gs://, az://, https://), of which only the
    /// footer, summary section and metadata are read, by ranged requests.
    pub file: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `heatrun completions`.
#[derive(Debug, Args)]
pub struct CompletionsArgs {
    /// The shell to complete for.
    pub shell: clap_complete::Shell,
}

/// Arguments of `heatrun man`.
#[derive(Debug, Args)]
pub struct ManArgs {
    /// The command whose page to print (`replay`, `fleet summary`); without one, one page
    /// that holds heatrun's and every command's, with every option.
    #[arg(value_name = "COMMAND")]
    pub command: Vec<String>,
    /// Write the page here instead of stdout.
    #[arg(long, value_name = "PATH", conflicts_with = "out_dir")]
    pub out: Option<PathBuf>,
    /// Write one page per command into this folder (heatrun.1, heatrun-replay.1, …),
    /// created where it does not exist.
    #[arg(long, value_name = "DIR")]
    pub out_dir: Option<PathBuf>,
}

/// A command as validated: what each handler takes. `info`, `completions` and `man` have
/// nothing to check beyond clap's, and take their flags as typed.
#[derive(Debug)]
#[expect(
    clippy::large_enum_variant,
    reason = "one request per process, made once and moved once: boxing saves nothing"
)]
pub enum Request {
    /// `heatrun replay`.
    Replay(Replay),
    /// `heatrun synth`.
    Synth(Synth),
    /// `heatrun info`.
    Info(InfoArgs),
    /// `heatrun import`.
    Import(Import),
    /// `heatrun completions`.
    Completions(CompletionsArgs),
    /// `heatrun man`.
    Man(ManArgs),
    /// `heatrun predict`.
    Predict(Predict),
    /// `heatrun rating`.
    Rating(Rating),
    /// `heatrun monitor`.
    Monitor(Monitor),
    /// `heatrun fleet summary`.
    FleetSummary(FleetSummary),
    /// `heatrun fleet compare`.
    FleetCompare(FleetCompare),
}

impl TryFrom<Command> for Request {
    type Error = anyhow::Error;

    /// Validates the command's flags once (a replay also finds its recordings and reads its
    /// spec): a usage error is [`Usage`], a file that cannot be
    /// read the library's error.
    fn try_from(command: Command) -> anyhow::Result<Request> {
        Ok(match command {
            Command::Replay(args) => Request::Replay(args.try_into()?),
            Command::Synth(args) => Request::Synth(args.try_into()?),
            Command::Info(args) => Request::Info(args),
            Command::Import(args) => Request::Import(args.try_into()?),
            Command::Completions(args) => Request::Completions(args),
            Command::Man(args) => Request::Man(args),
            Command::Predict(args) => Request::Predict(args.try_into()?),
            Command::Rating(args) => Request::Rating(args.try_into()?),
            Command::Monitor(args) => Request::Monitor(args.try_into()?),
            Command::Fleet(args) => match args.command {
                FleetCommand::Summary(args) => Request::FleetSummary(args.try_into()?),
                FleetCommand::Compare(args) => Request::FleetCompare(args.try_into()?),
            },
        })
    }
}
