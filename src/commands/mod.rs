//! One handler per command, behind [`dispatch`]: each takes its validated
//! [`crate::cli::Request`] and does the work (read, compute, write, print).

mod bars;
mod completions;
mod fleet;
mod fleet_compare;
mod fleet_summary;
pub mod hint;
mod import;
mod info;
mod man;
mod monitor;
mod predict;
mod rating;
mod replay;
mod staging;
mod synth;

use crate::cli::{Request, Target};

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

pub use crate::cli::Usage;

/// Whether a command's error is the input's fault (exit status 2) rather than the
/// machine's (1): a usage error of the command line, or a library error that says so.
pub fn is_bad_input(err: &anyhow::Error) -> bool {
    err.downcast_ref::<Usage>().is_some()
        || err
            .downcast_ref::<heatrun::Error>()
            .is_some_and(heatrun::Error::is_bad_input)
        || err
            .downcast_ref::<heatrun::store::StoreError>()
            .is_some_and(heatrun::store::StoreError::is_bad_input)
}

/// Runs a validated command.
pub fn dispatch(request: Request) -> anyhow::Result<Outcome> {
    match request {
        Request::Replay(replay) => match &replay.target {
            Target::One(one) => replay::run(&replay, one),
            Target::Fleet(fleet) => fleet::run(&replay, fleet),
        },
        Request::Synth(synth) => synth::run(&synth),
        Request::Info(args) => info::run(&args),
        Request::Import(import) => import::run(&import),
        Request::Completions(args) => completions::run(&args),
        Request::Man(args) => man::run(&args),
        Request::Predict(predict) => predict::run(&predict),
        Request::Rating(rating) => rating::run(&rating),
        Request::Monitor(monitor) => monitor::run(&monitor),
        Request::FleetSummary(summary) => fleet_summary::run(&summary),
        Request::FleetCompare(compare) => fleet_compare::run(&compare),
    }
}
