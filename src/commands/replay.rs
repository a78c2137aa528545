//! `heatrun replay`: one recording into its model, report and rerun recording; a fleet
//! is [`super::fleet`]'s.

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use anyhow::Context as _;

use heatrun::atomic::write_atomically;
use heatrun::pipeline::{self, ReplayOptions};
use heatrun::progress::Observer;
use heatrun_rerun::{Publisher, RerunSink};

use super::bars::{self, Bars};
use super::staging::Staging;
use super::Outcome;
use crate::cli::{One, Replay, SummaryFormat};

/// Runs `heatrun replay` on one recording (a fleet is [`super::fleet::run`]'s, which
/// replays each recording through [`replay_one`]).
pub fn run(replay: &Replay, one: &One) -> anyhow::Result<Outcome> {
    single(replay, one)
}

pub use heatrun::report::Replayed;

/// Where one recording's outputs besides the rerun recording go.
pub struct Outputs<'a> {
    /// The JSON report, if asked for.
    pub report: Option<&'a Path>,
    /// The HTML report, if asked for.
    pub html: Option<&'a Path>,
}

/// Replays one recording, then prints its summary (or only its warnings, or its report as
/// JSON) and where the outputs went.
fn single(replay: &Replay, one: &One) -> anyhow::Result<Outcome> {
    let started = Instant::now();
    // A cluster task's folder, as a fleet's: made here (a remote prefix needs none).
    if let Some(dir) = &one.out_dir {
        if !heatrun::store::Location::from_path(dir)?.is_remote() {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("cannot create {}", dir.display()))?;
        }
    }
    // Everything is written before anything is printed: a closed stdout (`| head`)
    // ends the process at the first print and must not cut an output short.
    let outputs = Outputs {
        report: one.report.as_deref(),
        html: one.html.as_deref(),
    };
    let bars = Arc::new(Bars::new(bars::draw_here(replay.quiet)));
    let replayed = replay_one(
        replay,
        &one.file,
        &one.sink,
        outputs,
        Observer::shared(bars.clone()),
    );
    bars.clear();
    let replayed = replayed?;
    if replay.quiet || replay.summary == SummaryFormat::Json {
        for w in &replayed.replay.warnings {
            eprintln!("warning: {w}");
        }
        if replay.summary == SummaryFormat::Json {
            println!("{}", replayed.report.to_json());
        }
    } else {
        print!("{}", replayed.summary);
        match &one.sink {
            RerunSink::Rrd(p) => println!("rerun recording: {}", p.display()),
            RerunSink::Connect(url) => println!(
                "rerun: sent to {}",
                url.as_deref().unwrap_or("the local viewer")
            ),
            RerunSink::Spawn => println!("rerun: sent to a spawned viewer"),
        }
        if let Some(path) = &one.report {
            println!("report: {}", path.display());
        }
        if let Some(path) = &one.html {
            println!("html report: {}", path.display());
        }
        println!("replayed in {:.2} s", started.elapsed().as_secs_f64());
    }
    Ok(if replayed.replay.had_data_loss() {
        Outcome::DataLoss
    } else {
        Outcome::Complete
    })
}

/// Replays one recording into its sink and (if named) its report files, telling
/// `progress` how the reading and the estimation go.
pub fn replay_one(
    replay: &Replay,
    file: &Path,
    sink: &RerunSink,
    outputs: Outputs<'_>,
    progress: Observer,
) -> anyhow::Result<Replayed> {
    let options = ReplayOptions {
        progress,
        ..replay.options.clone()
    };
    let name = file
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    // Outputs named by URLs are written here complete, then uploaded whole.
    let mut staging = Staging::default();
    // The report and the page are written after the replay: a folder that is not there
    // is said now, not after a week's replay.
    for path in [outputs.report, outputs.html].into_iter().flatten() {
        if !heatrun::store::Location::from_path(path)?.is_remote() {
            heatrun::atomic::folder_exists(path)?;
        }
    }
    let sink = match sink {
        RerunSink::Rrd(path) => RerunSink::Rrd(staging.local(path)?),
        other => other.clone(),
    };
    let publisher = Publisher::open(&sink, &name)?;
    // The publisher sends each stage's series while the next stage runs.
    let mut full_rate = replay.raw.then(|| publisher.full_rate());
    let also = full_rate
        .as_mut()
        .map(|f| f as &mut dyn heatrun::recording::SampleSink);
    let found = pipeline::replay_observed(file, &options, also, &publisher)
        .map_err(|e| no_fourth_state(e, &options))?;
    if let Some(full_rate) = full_rate.as_mut() {
        full_rate.flush()?;
    }
    options.progress.stage("writing the outputs");
    let replayed = Replayed::new(found);
    publisher.finish(&replayed)?;
    if let Some(path) = outputs.report {
        write_atomically(&staging.local(path)?, replayed.report.to_json().as_bytes())?;
    }
    if let Some(path) = outputs.html {
        heatrun::html::replay_page(&replayed, &options).write(&staging.local(path)?)?;
    }
    staging.upload()?;
    Ok(replayed)
}

/// `--field-state` on a recording whose field winding's rise moves with the other parts'
/// (a machine of three parts, or U_f/I_f following the stator): the four states' regression
/// is rank deficient, which the estimator says of the inputs ("not persistently
/// exciting ... replay a heat run"), where the flag is what the data cannot carry.
fn no_fourth_state(error: heatrun::Error, options: &ReplayOptions) -> anyhow::Error {
    use heatrun::estimate::EstimationError;
    // The model `--field-state` asks for, by its name (a spec's own is another).
    let field_state =
        options.model.name == heatrun::spec::ModelDescription::generator_with_field_state().name;
    let (path, inner) = match &error {
        heatrun::Error::InRecording { path, error } => (Some(path), error.as_ref()),
        other => (None, other),
    };
    match inner {
        heatrun::Error::Estimation(EstimationError::NoExcitation {
            method,
            singular_value_ratio,
        }) if field_state => super::Usage(format!(
            "{}--field-state: the field winding's rise (its own channel, or U_f/I_f) does not \
             move apart from the other parts' rises, so the data hold no fourth state ({method}'s \
             regression is rank deficient, σ_min/σ_max = {singular_value_ratio:.1e}); replay \
             without --field-state",
            path.map(|p| format!("{}: ", p.display()))
                .unwrap_or_default()
        ))
        .into(),
        _ => error.into(),
    }
}
