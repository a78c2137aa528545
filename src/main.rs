//! The `heatrun` command: a thin layer over the library. This is the one place
//! that turns an outcome into an exit status: 0 ok, 1 failure, 2 usage or bad
//! input, 3 completed with data loss.

mod cli;
mod commands;

use std::process::ExitCode;

use clap::Parser;

use commands::Outcome;

fn main() -> ExitCode {
    let cli = cli::Cli::parse();
    match commands::dispatch(cli.command) {
        Ok(Outcome::Complete) => ExitCode::SUCCESS,
        Ok(Outcome::DataLoss) => ExitCode::from(3),
        Err(err) => {
            let bad_input = err
                .downcast_ref::<heatrun::Error>()
                .is_some_and(|e| e.is_bad_input());
            eprintln!("heatrun: {err:#}");
            ExitCode::from(if bad_input { 2 } else { 1 })
        }
    }
}
