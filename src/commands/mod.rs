//! One handler per command, behind [`dispatch`].

mod bars;
mod completions;
pub mod hint;
mod import;
mod info;
mod man;
mod monitor;
mod predict;
mod rating;
mod replay;
mod synth;

use crate::cli::Command;

/// How a command ended, when it did not fail.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Everything was read and done.
    Complete,
    /// Done, but part of the input was damaged and skipped (exit status 3).
    DataLoss,
    /// Done, and the monitored machine raised alarms (exit status 4).
    Alarms,
}

/// Runs a command.
pub fn dispatch(command: Command) -> anyhow::Result<Outcome> {
    match command {
        Command::Replay(args) => replay::run(args),
        Command::Synth(args) => synth::run(args),
        Command::Info(args) => info::run(args),
        Command::Import(args) => import::run(args),
        Command::Completions(args) => completions::run(args),
        Command::Man(args) => man::run(args),
        Command::Predict(args) => predict::run(args),
        Command::Rating(args) => rating::run(args),
        Command::Monitor(args) => monitor::run(args),
    }
}
