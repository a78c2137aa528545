//! `heatrun man`: the man page (roff), generated from the CLI's own definitions by
//! `clap_mangen`.

use clap::CommandFactory;

use super::Outcome;
use crate::cli::{Cli, ManArgs};
use heatrun::atomic::write_atomically;

/// Renders the page to stdout, or to `--out` (complete or absent).
pub fn run(args: &ManArgs) -> anyhow::Result<Outcome> {
    let mut page = Vec::new();
    clap_mangen::Man::new(Cli::command()).render(&mut page)?;
    match &args.out {
        Some(path) => write_atomically(path, &page)?,
        None => {
            use std::io::Write as _;
            std::io::stdout().write_all(&page)?;
        }
    }
    Ok(Outcome::Complete)
}
