//! `heatrun import`: its flags, and the [`Import`] they ask for: a map guessed, or a table
//! converted with a map.

use std::path::PathBuf;

use clap::Args;

use super::outputs::{distinct, NamedFile};
use super::Usage;

/// Arguments of `heatrun import`.
#[derive(Debug, Args)]
pub struct ImportArgs {
    /// The table: comma, semicolon, tab or whitespace separated, with or without a
    /// header, a column per signal or a row per sample; or a Parquet file.
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

/// What `heatrun import` is asked for.
#[derive(Debug, PartialEq, Eq)]
pub enum Import {
    /// Print a starting map guessed from the table's header.
    Guess {
        /// The table.
        input: PathBuf,
    },
    /// Convert the table into a recording.
    Convert {
        /// The table.
        input: PathBuf,
        /// The map.
        map: PathBuf,
        /// The recording to write.
        out: PathBuf,
    },
}

impl TryFrom<ImportArgs> for Import {
    type Error = Usage;

    /// A map guessed, or a table converted with its map and output.
    fn try_from(args: ImportArgs) -> Result<Import, Usage> {
        if args.guess {
            return Ok(Import::Guess { input: args.input });
        }
        // clap requires both without --guess; this is its refusal should that change.
        let (Some(map), Some(out)) = (args.map, args.out) else {
            return Err(Usage(
                "give the map with --map MAP.toml and the output with --out OUT.mcap (--guess prints a starting map)".into(),
            ));
        };
        distinct(
            &[
                NamedFile::new("the table", &args.input),
                NamedFile::new("--map", &map),
            ],
            &[NamedFile::new("--out", &out)],
        )?;
        Ok(Import::Convert {
            input: args.input,
            map,
            out,
        })
    }
}
