//! `heatrun monitor`: its flags, and the [`Monitor`] they are validated into (the band, the
//! hold and the stretch in range; the recording a file or standard input; the sink).

use std::path::{Path, PathBuf};

use clap::Args;
use heatrun::monitor::stream::StreamOptions;
use heatrun::monitor::{BandKind, BandRule, MonitorOptions};
use heatrun_rerun::RerunSink;

use super::outputs::{distinct, NamedFile};
use super::viewer::{Offer, ViewerArgs};
use super::Usage;

/// `monitor`'s rerun outputs: an .rrd or a running viewer, not both.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MonitorViewer;

impl Offer for MonitorViewer {
    const RRD: (&'static str, &'static str) = (
        "OUT.rrd",
        "Save measured against predicted temperature, residuals, bands and alarms to an .rrd",
    );
    const CONNECT: Option<&'static str> =
        Some("Stream them to a running rerun viewer (optionally at this gRPC URL)");
    const EXCLUSIVE: bool = true;
}

/// `--band`: which band the monitor compares against.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum BandChoice {
    /// From the model's prediction uncertainty at each instant, plus the sensors' noise.
    Model,
    /// One per part: FACTOR × the model's RMSE, at least the floor.
    Fixed,
}

/// Arguments of `heatrun monitor`.
#[derive(Debug, Args)]
pub struct MonitorArgs {
    /// The model: a report written by `heatrun replay --report`.
    #[arg(long, value_name = "REPORT.json")]
    pub model: PathBuf,
    /// The recording to monitor (MCAP, the heatrun SCADA profile), of the same machine;
    /// `-` reads it from standard input as it arrives (a recording still being written:
    /// `tail -c +1 -f growing.mcap | heatrun monitor --model m.json -`).
    #[arg(value_name = "RECORDING.mcap")]
    pub recording: PathBuf,
    /// Seconds of the grid monitored at once: each stretch is published (--connect,
    /// --rrd) as soon as the recording has been read past it.
    #[arg(long, value_name = "SECONDS", default_value_t = heatrun::monitor::stream::DEFAULT_STRETCH_S)]
    pub stretch: f64,
    /// Seconds a residual must stay outside its band before it is an alarm (returns inside
    /// shorter than a tenth of this do not end the excursion).
    #[arg(long, value_name = "SECONDS", default_value_t = heatrun::monitor::DEFAULT_HOLD_S)]
    pub hold: f64,
    /// The band per part is this multiple of the model's RMSE (validation, else fit), or
    /// of the prediction's standard deviation (`--band model`).
    #[arg(long, value_name = "FACTOR", default_value_t = heatrun::monitor::BandRule::default().factor)]
    pub band_factor: f64,
    /// The narrowest band, K (the fixed band's).
    #[arg(long, value_name = "K", default_value_t = heatrun::monitor::BandRule::default().floor_k)]
    pub band_floor: f64,
    /// The band: `model` at each instant from the model's prediction uncertainty and the
    /// sensors' noise (FACTOR × its standard deviation), or `fixed` (FACTOR × the
    /// model's RMSE, at least the floor, for the whole recording).
    #[arg(long, value_enum, value_name = "KIND", default_value = "model")]
    pub band: BandChoice,
    /// Write the alarms and each part's residual statistics as JSON to this file.
    #[arg(long, value_name = "OUT.json")]
    pub json: Option<PathBuf>,
    /// `--rrd`, `--connect`.
    #[command(flatten)]
    pub viewer: ViewerArgs<MonitorViewer>,
    /// Write a self-contained HTML page (measured against model per part, residuals in
    /// their band, alarms shaded, the alarm and residual tables) to this file.
    #[arg(long, value_name = "PAGE.html")]
    pub html: Option<PathBuf>,
    /// Print only the alarm lines.
    #[arg(long, short)]
    pub quiet: bool,
}

/// `heatrun monitor` as validated.
#[derive(Debug)]
pub struct Monitor {
    /// The model report.
    pub model: PathBuf,
    /// Where the recording is read from.
    pub recording: Input,
    /// The recording's name in rerun.
    pub name: String,
    /// The band and the hold.
    pub options: MonitorOptions,
    /// The stretch, and whether every instant is kept (only the HTML page draws them all;
    /// rerun is sent each stretch as it goes).
    pub stream: StreamOptions,
    /// Where the rerun data go, if anywhere.
    pub sink: Option<RerunSink>,
    /// The alarms as JSON, if asked for.
    pub json: Option<PathBuf>,
    /// The HTML page, if asked for.
    pub html: Option<PathBuf>,
    /// Print only the alarm lines.
    pub quiet: bool,
}

/// Where a monitored recording comes from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Input {
    /// A file.
    File(PathBuf),
    /// Standard input (`-`), as it arrives.
    Stdin,
}

impl TryFrom<MonitorArgs> for Monitor {
    type Error = anyhow::Error;

    /// Checks the band, the hold and the stretch (NaN fails every check, hence the
    /// negated comparisons).
    fn try_from(args: MonitorArgs) -> anyhow::Result<Monitor> {
        if !(args.hold >= 0.0 && args.band_factor > 0.0 && args.band_floor >= 0.0) {
            return Err(Usage(format!(
                "--hold {} --band-factor {} --band-floor {}: the hold and the floor must be \
                 0 or more, the factor more than 0",
                args.hold, args.band_factor, args.band_floor
            ))
            .into());
        }
        if !(args.stretch >= 1.0 && args.stretch.is_finite()) {
            return Err(Usage(format!(
                "--stretch {}: the stretch must be at least 1 s",
                args.stretch
            ))
            .into());
        }
        let (recording, name) = if args.recording == Path::new("-") {
            (Input::Stdin, "standard input".to_owned())
        } else {
            let name = args
                .recording
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            (Input::File(args.recording), name)
        };
        let monitor = Monitor {
            model: args.model,
            recording,
            name,
            options: MonitorOptions {
                band: BandRule {
                    factor: args.band_factor,
                    floor_k: args.band_floor,
                    kind: match args.band {
                        BandChoice::Model => BandKind::Model,
                        BandChoice::Fixed => BandKind::Fixed,
                    },
                },
                hold_s: args.hold,
            },
            stream: StreamOptions {
                stretch_s: args.stretch,
                keep_traces: args.html.is_some(),
                ..StreamOptions::default()
            },
            sink: args.viewer.sink(),
            json: args.json,
            html: args.html,
            quiet: args.quiet,
        };
        monitor.files_distinct()?;
        Ok(monitor)
    }
}

impl Monitor {
    /// Refuses outputs that would replace the model, the recording or each other.
    fn files_distinct(&self) -> Result<(), Usage> {
        let mut reads = vec![NamedFile::new("--model", &self.model)];
        if let Input::File(path) = &self.recording {
            reads.push(NamedFile::new("the recording", path));
        }
        let mut writes = Vec::new();
        if let Some(RerunSink::Rrd(path)) = &self.sink {
            writes.push(NamedFile::new("--rrd", path));
        }
        writes.extend(self.json.as_deref().map(|p| NamedFile::new("--json", p)));
        writes.extend(self.html.as_deref().map(|p| NamedFile::new("--html", p)));
        distinct(&reads, &writes)
    }
}
