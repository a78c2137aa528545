//! `heatrun man`: the man pages (roff), generated from the CLI's own definitions by
//! `clap_mangen`: one page holding heatrun's and every command's (each with every option),
//! one command's page, or a page per command in a folder.

use std::path::Path;

use anyhow::Context as _;
use clap::CommandFactory;

use super::Outcome;
use crate::cli::{Cli, ManArgs, Usage};
use heatrun::atomic::write_atomically;

/// Renders the pages asked for to stdout, `--out` or `--out-dir` (each complete or absent).
pub fn run(args: &ManArgs) -> anyhow::Result<Outcome> {
    let mut root = Cli::command().disable_help_subcommand(true);
    // Built, every subcommand knows its full name (`heatrun-replay`) for its page's title.
    root.build();
    if let Some(dir) = &args.out_dir {
        let start = find(&root, &args.command)?;
        if dir.exists() && !dir.is_dir() {
            return Err(Usage(format!(
                "--out-dir {} is a file: name a folder for the pages",
                dir.display()
            ))
            .into());
        }
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        for command in with_subcommands(start) {
            let page = render(command)?;
            let man = clap_mangen::Man::new(command.clone());
            write_atomically(&dir.join(man.get_filename()), &page)?;
        }
        return Ok(Outcome::Complete);
    }
    let page = if args.command.is_empty() {
        // One page that holds them all: heatrun's, then each command's, in order.
        let mut all = Vec::new();
        for command in with_subcommands(&root) {
            all.extend(render(command)?);
        }
        all
    } else {
        let command = find(&root, &args.command)?;
        let mut pages = Vec::new();
        for c in with_subcommands(command) {
            pages.extend(render(c)?);
        }
        pages
    };
    write(args.out.as_deref(), &page)?;
    Ok(Outcome::Complete)
}

/// The command `path` names under `root` (`["fleet", "summary"]`), or a usage error that
/// lists the commands there are.
fn find<'a>(root: &'a clap::Command, path: &[String]) -> anyhow::Result<&'a clap::Command> {
    let mut command = root;
    for name in path {
        command = command.find_subcommand(name).ok_or_else(|| {
            Usage(format!(
                "`{}` is not a heatrun command; the commands: {}",
                path.join(" "),
                command
                    .get_subcommands()
                    .map(clap::Command::get_name)
                    .collect::<Vec<_>>()
                    .join(", ")
            ))
        })?;
    }
    Ok(command)
}

/// A command and, after it, every command below it, depth first.
fn with_subcommands(command: &clap::Command) -> Vec<&clap::Command> {
    let mut out = vec![command];
    for sub in command.get_subcommands().filter(|s| !s.is_hide_set()) {
        out.extend(with_subcommands(sub));
    }
    out
}

/// One command's page: its synopsis, description, every option and its examples, and a
/// roff comment naming the options as typed. roff writes a hyphen as `\-` (so that `man`
/// shows an ASCII minus one can copy), which `grep -- --holdout` on the page's source does
/// not find; the comment, which `man` does not show, is for that grep.
fn render(command: &clap::Command) -> anyhow::Result<Vec<u8>> {
    let mut page = Vec::new();
    clap_mangen::Man::new(command.clone()).render(&mut page)?;
    let options: Vec<String> = command
        .get_arguments()
        .filter(|a| !a.is_hide_set() && !a.is_positional())
        .map(|a| match (a.get_long(), a.get_short()) {
            (Some(long), _) => format!("--{long}"),
            (None, Some(short)) => format!("-{short}"),
            (None, None) => a.get_id().to_string(),
        })
        .collect();
    if !options.is_empty() {
        use std::io::Write as _;
        writeln!(
            page,
            ".\\\" options of {}: {}",
            display_name(command),
            options.join(" ")
        )?;
    }
    Ok(page)
}

/// A command's full name (`heatrun-replay`), as its page is titled.
fn display_name(command: &clap::Command) -> String {
    command
        .get_display_name()
        .unwrap_or_else(|| command.get_name())
        .to_owned()
}

fn write(out: Option<&Path>, page: &[u8]) -> anyhow::Result<()> {
    match out {
        Some(path) => write_atomically(path, page)?,
        None => {
            use std::io::Write as _;
            std::io::stdout().write_all(page)?;
        }
    }
    Ok(())
}
