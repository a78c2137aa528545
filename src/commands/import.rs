//! `heatrun import`: a table into a recording, or a starting map guessed from it.

use heatrun::import::{self, ImportError, ImportMap};
use heatrun::recording::format_time;

use super::Outcome;
use crate::cli::Import;

/// Prints a guessed map, or converts the table and prints what the recording holds.
pub fn run(request: &Import) -> anyhow::Result<Outcome> {
    let (input, map_path, out) = match request {
        Import::Guess { input } => {
            print!("{}", import::guess_map(input).map_err(library)?);
            return Ok(Outcome::Complete);
        }
        Import::Convert { input, map, out } => (input, map, out),
    };
    let map = ImportMap::load(map_path).map_err(library)?;
    let summary = import::import(input, &map, out).map_err(library)?;
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
    if summary.unlisted_rows > 0 {
        println!(
            "passed over {} rows of tags the map does not list",
            summary.unlisted_rows
        );
    }
    for change in &summary.clock_changes {
        println!("clock change crossed: {}", change.describe());
    }
    Ok(Outcome::Complete)
}

/// The library's error, where `main` finds its exit status (2 for bad input).
fn library(e: ImportError) -> anyhow::Error {
    heatrun::Error::Import(Box::new(e)).into()
}
