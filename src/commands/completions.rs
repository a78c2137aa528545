//! `heatrun completions SHELL`: the shell's completion script, generated from the CLI's
//! own definitions by `clap_complete` (so it never lags behind a new flag).

use clap::CommandFactory;

use super::Outcome;
use crate::cli::{Cli, CompletionsArgs};

/// Prints the completion script for `args.shell` on stdout.
pub fn run(args: &CompletionsArgs) -> anyhow::Result<Outcome> {
    let mut command = Cli::command();
    clap_complete::generate(args.shell, &mut command, "heatrun", &mut std::io::stdout());
    Ok(Outcome::Complete)
}
