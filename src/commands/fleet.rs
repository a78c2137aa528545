//! A fleet of `heatrun replay`: many recordings replayed in parallel, each into its own
//! outputs in the out folder, and a summary table of them all.

use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use anyhow::Context;
use heatrun::fleet::{self as table, FleetRow, FleetTally, ReportRow};
use heatrun::progress::{Observer, Progress};
use heatrun::store::{self, Location};
use heatrun_rerun::RerunSink;
use rayon::prelude::*;

use super::bars::{self, Bars};
use super::replay::{replay_one, Outputs};
use super::{Outcome, Usage};
use crate::cli::{stem, Fleet, Replay};

/// Runs a fleet: every recording replayed, `jobs` at a time; each gets `<stem>.rrd` and
/// `<stem>.report.json` in the out folder, and the fleet a summary table (written as
/// `fleet-summary.csv`, then printed). Exit 2 if any failed, else 3 if any lost data.
pub fn run(replay: &Replay, fleet: &Fleet) -> anyhow::Result<Outcome> {
    let out = Location::from_path(&fleet.out_dir)?;
    if !out.is_remote() {
        std::fs::create_dir_all(&fleet.out_dir)
            .with_context(|| format!("cannot create {}", fleet.out_dir.display()))?;
    }
    let started = Instant::now();
    let bars = Bars::new(bars::draw_here(replay.quiet));
    let rows = replay_fleet(replay, fleet, &bars);
    bars.clear();
    let rows = rows?;
    let model = &replay.options.model;
    let csv = table::fleet_csv(&rows, &table::csv_header(model))?;
    store::put(&out.join(table::SUMMARY_FILE), &csv)?;
    let tally = FleetTally::of(&rows);
    // `-q`: the table is in fleet-summary.csv; only what failed is said (on stderr, below).
    if !replay.quiet {
        print!("{}", table::table_text(&rows, model));
        println!(
        "{} recordings in {:.2} s ({} jobs): {} ok, {} with data loss, {} failed; reports and .rrd files in {}",
        rows.len(),
        started.elapsed().as_secs_f64(),
        fleet.jobs,
        tally.ok,
        tally.data_lost,
        tally.failed,
        out
        );
    }
    if tally.failed > 0 {
        let table = if replay.quiet {
            format!("{}", out.join(table::SUMMARY_FILE))
        } else {
            "the table".to_owned()
        };
        return Err(Usage(format!(
            "{} of {} recordings failed (see {table})",
            tally.failed,
            rows.len()
        ))
        .into());
    }
    Ok(if tally.data_lost > 0 {
        Outcome::DataLoss
    } else {
        Outcome::Complete
    })
}

/// Replays every file on a pool of `jobs` threads; the rows come back in the files' order.
/// `progress` is told each recording done (the recordings' own reading and estimation,
/// `jobs` at once, are not shown).
fn replay_fleet(
    replay: &Replay,
    fleet: &Fleet,
    progress: &dyn Progress,
) -> anyhow::Result<Vec<FleetRow>> {
    let files = &fleet.files;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(fleet.jobs.min(files.len()))
        .thread_name(|i| format!("heatrun-fleet-{i}"))
        .build()
        .context("cannot start the fleet's threads")?;
    let done = AtomicUsize::new(0);
    progress.recording_done(0, files.len());
    Ok(pool.install(|| {
        files
            .par_iter()
            .map(|f| {
                let row = fleet_row(replay, fleet, f);
                let done = done.fetch_add(1, Ordering::Relaxed) + 1;
                progress.recording_done(done, files.len());
                row
            })
            .collect()
    }))
}

/// Replays one recording of a fleet into the out folder; a failure becomes its row's
/// reason.
fn fleet_row(replay: &Replay, fleet: &Fleet, file: &Path) -> FleetRow {
    // The out folder may be a prefix in object storage: `join` keeps a URL's text.
    let s = stem(file);
    let rrd = RerunSink::Rrd(fleet.out_dir.join(format!("{s}.rrd")));
    let report = fleet.out_dir.join(format!("{s}.report.json"));
    let html = fleet
        .html
        .then(|| fleet.out_dir.join(format!("{s}.report.html")));
    let outputs = Outputs {
        report: Some(&report),
        html: html.as_deref(),
    };
    FleetRow {
        recording: file.display().to_string(),
        // The figures as `fleet summary` reads them from the report written: one reduction.
        outcome: replay_one(replay, file, &rrd, outputs, Observer::silent())
            .and_then(|replayed| {
                let row = ReportRow::from_json(&replayed.report.to_json(), &report);
                Ok(row.map_err(heatrun::Error::from)?.figures)
            })
            .map_err(|e| match super::hint::for_error(&e) {
                Some(hint) => format!("{}; {hint}", super::hint::one_line(&e)),
                None => super::hint::one_line(&e),
            }),
    }
}
