//! `heatrun import`.

use heatrun::import::{self, ImportError, ImportMap};
use heatrun::recording::format_time;

use super::Outcome;
use crate::cli::ImportArgs;

pub fn run(args: ImportArgs) -> anyhow::Result<Outcome> {
    if args.guess {
        print!("{}", import::guess_map(&args.input).map_err(library)?);
        return Ok(Outcome::Complete);
    }
    let (Some(map_path), Some(out)) = (&args.map, &args.out) else {
        anyhow::bail!(super::Usage(
            "give the map with --map MAP.toml and the output with --out OUT.mcap (--guess prints a starting map)".into()
        ));
    };
    let map = ImportMap::load(map_path).map_err(library)?;
    let summary = import::import(&args.input, &map, out).map_err(library)?;
    let (first, last) = summary.time_span_ns;
    let missing: u64 = summary.channels.iter().map(|c| c.missing).sum();
    let empty: Vec<&str> = summary
        .channels
        .iter()
        .filter(|c| c.samples == 0)
        .map(|c| c.topic.as_str())
        .collect();
    println!(
        "wrote {}: {} rows, {} channels, {:.1} s from {} to {}; {} samples, {} missing{}",
        out.display(),
        summary.rows,
        summary.channels.len(),
        (last - first) as f64 * 1e-9,
        format_time(first),
        format_time(last),
        summary.messages,
        missing,
        if empty.is_empty() {
            String::new()
        } else {
            format!("; no samples on {}", empty.join(", "))
        }
    );
    Ok(Outcome::Complete)
}

/// The library's error, where `main` finds its exit status (2 for bad input).
fn library(e: ImportError) -> anyhow::Error {
    heatrun::Error::Import(Box::new(e)).into()
}
