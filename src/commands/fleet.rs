//! A fleet of `heatrun replay`: many recordings replayed in parallel, each into its own
//! outputs in the out folder, and a summary table of them all.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use anyhow::Context;
use heatrun::atomic::write_atomically;
use heatrun::progress::{Observer, Progress};
use heatrun::spec::ModelDescription;
use heatrun_rerun::RerunSink;
use rayon::prelude::*;

use super::bars::{self, Bars};
use super::replay::{replay_one, Outputs, Replayed};
use super::{Outcome, Usage};
use crate::cli::{stem, Fleet, Replay};

/// What the fleet table and `fleet-summary.csv` show of one recording: its report's
/// `time_constants_s`, `fit.nrmse_fit_percent` and `steady_state.temperature_c`, so the
/// table made here and one gathered from a cluster's reports agree.
struct FleetFigures {
    /// The model's time constants, s.
    time_constants_s: Vec<f64>,
    /// Each state's fit, NRMSE %.
    nrmse_fit_percent: Vec<f64>,
    /// Each state's steady-state temperature, °C.
    steady_state_c: Vec<f64>,
    /// Whether part of the recording was damaged and skipped.
    data_lost: bool,
}

impl FleetFigures {
    /// The figures of one replayed recording.
    fn of(replayed: &Replayed) -> FleetFigures {
        let report = &replayed.report;
        FleetFigures {
            time_constants_s: report.time_constants_s.clone(),
            nrmse_fit_percent: report.fit.nrmse_fit_percent.clone(),
            steady_state_c: report.steady_state.temperature_c.clone(),
            data_lost: replayed.replay.had_data_loss(),
        }
    }

    /// The status column: `ok`, or `data lost`.
    fn status(&self) -> &'static str {
        if self.data_lost {
            "data lost"
        } else {
            "ok"
        }
    }
}

/// One recording of a fleet: its figures, or the one-line reason it failed.
struct FleetRow {
    /// The recording, as named.
    file: PathBuf,
    /// Its figures, or why it failed.
    outcome: Result<FleetFigures, String>,
}

/// How a fleet's recordings ended.
#[derive(Debug, Default, PartialEq, Eq)]
struct FleetTally {
    /// Replayed whole.
    ok: usize,
    /// Replayed, with part of the recording skipped.
    data_lost: usize,
    /// Not replayed.
    failed: usize,
}

impl FleetTally {
    /// Counts the rows by outcome.
    fn of(rows: &[FleetRow]) -> FleetTally {
        let mut tally = FleetTally::default();
        for row in rows {
            match &row.outcome {
                Ok(f) if f.data_lost => tally.data_lost += 1,
                Ok(_) => tally.ok += 1,
                Err(_) => tally.failed += 1,
            }
        }
        tally
    }
}

/// A state's short name in the fleet summary: the generator's parts as they have always
/// been named there (stator, core, water, field), any other state by its own name.
fn short_name(state: &heatrun::spec::StateDescription) -> String {
    use heatrun::recording::{Quantity, Signal};
    match &state.channel {
        Signal::Profile(Quantity::StatorWindingTemp) => "stator".into(),
        Signal::Profile(Quantity::CoreTemp) => "core".into(),
        Signal::Profile(Quantity::CoolingWaterOutletTemp) => "water".into(),
        Signal::Profile(Quantity::FieldWindingTemp) => "field".into(),
        _ => state.name.clone(),
    }
}

/// The columns of `fleet-summary.csv` for a model of n states: the recording, its status,
/// T1..Tn, then each state's fit and steady state.
fn fleet_csv_header(model: &ModelDescription) -> Vec<String> {
    let short: Vec<String> = model.states.iter().map(short_name).collect();
    let mut header = vec!["recording".to_owned(), "status".to_owned()];
    header.extend((1..=short.len()).map(|i| format!("t{i}_s")));
    header.extend(short.iter().map(|s| format!("fit_{s}_pct")));
    header.extend(short.iter().map(|s| format!("steady_{s}_c")));
    header
}

/// Runs a fleet: every recording replayed, `jobs` at a time; each gets `<stem>.rrd` and
/// `<stem>.report.json` in the out folder, and the fleet a summary table (written as
/// `fleet-summary.csv`, then printed). Exit 2 if any failed, else 3 if any lost data.
pub fn run(replay: &Replay, fleet: &Fleet) -> anyhow::Result<Outcome> {
    std::fs::create_dir_all(&fleet.out_dir)
        .with_context(|| format!("cannot create {}", fleet.out_dir.display()))?;
    let started = Instant::now();
    let bars = Bars::new(bars::draw_here(replay.quiet));
    let rows = replay_fleet(replay, fleet, &bars);
    bars.clear();
    let rows = rows?;
    let model = &replay.options.model;
    write_atomically(
        &fleet.out_dir.join("fleet-summary.csv"),
        &fleet_csv(&rows, &fleet_csv_header(model))?,
    )?;
    print_fleet_table(&rows, model);
    let tally = FleetTally::of(&rows);
    println!(
        "{} recordings in {:.2} s ({} jobs): {} ok, {} with data loss, {} failed; reports and .rrd files in {}",
        rows.len(),
        started.elapsed().as_secs_f64(),
        fleet.jobs,
        tally.ok,
        tally.data_lost,
        tally.failed,
        fleet.out_dir.display()
    );
    if tally.failed > 0 {
        return Err(Usage(format!(
            "{} of {} recordings failed (see the table)",
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
        file: file.to_owned(),
        outcome: replay_one(replay, file, &rrd, outputs, Observer::silent())
            .map(|replayed| FleetFigures::of(&replayed))
            .map_err(|e| match super::hint::for_error(&e) {
                Some(hint) => format!("{}; {hint}", super::hint::one_line(&e)),
                None => super::hint::one_line(&e),
            }),
    }
}

/// `fleet-summary.csv`: one line per recording, empty figures where it failed.
fn fleet_csv(rows: &[FleetRow], header: &[String]) -> anyhow::Result<Vec<u8>> {
    let mut csv = csv::Writer::from_writer(Vec::new());
    csv.write_record(header)?;
    for row in rows {
        let mut record = vec![row.file.display().to_string()];
        match &row.outcome {
            Ok(f) => {
                record.push(f.status().to_owned());
                let figures = [&f.time_constants_s, &f.nrmse_fit_percent, &f.steady_state_c];
                record.extend(figures.into_iter().flatten().map(f64::to_string));
            }
            Err(reason) => record.push(format!("failed: {reason}")),
        }
        record.resize(header.len(), String::new());
        csv.write_record(&record)?;
    }
    csv.into_inner()
        .map_err(|e| anyhow::anyhow!("fleet summary: {}", e.error()))
}

/// The fleet table on stdout, one line per recording.
fn print_fleet_table(rows: &[FleetRow], model: &ModelDescription) {
    let n = model.states.len();
    let short: Vec<String> = model.states.iter().map(short_name).collect();
    println!(
        "{:<32} {}  {:>22}  {:>22}  status",
        "recording",
        (1..=n)
            .map(|i| format!("{:>9}", format!("T{i} s")))
            .collect::<Vec<_>>()
            .join(" "),
        format!("NRMSE fit % ({})", short.join(" ")),
        "steady state °C"
    );
    for row in rows {
        let name = row.file.display().to_string();
        match &row.outcome {
            Ok(f) => println!(
                "{name:<32} {}  {:>22}  {:>22}  {}",
                joined(&f.time_constants_s, |t| format!("{t:>9.2}")),
                joined(&f.nrmse_fit_percent, |v| format!("{v:.2}")),
                joined(&f.steady_state_c, |v| format!("{v:.2}")),
                f.status()
            ),
            Err(reason) => println!("{name:<32} failed: {reason}"),
        }
    }
}

/// Values formatted one by one and joined by spaces.
fn joined(values: &[f64], format: impl Fn(f64) -> String) -> String {
    values
        .iter()
        .map(|&v| format(v))
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn figures(data_lost: bool) -> FleetFigures {
        FleetFigures {
            time_constants_s: vec![23.9, 737.25, 3305.5],
            nrmse_fit_percent: vec![99.5, 98.0, 97.25],
            steady_state_c: vec![55.5, 47.125, 13.0],
            data_lost,
        }
    }

    fn rows() -> Vec<FleetRow> {
        vec![
            FleetRow {
                file: "unit 3, run 1.mcap".into(),
                outcome: Ok(figures(false)),
            },
            FleetRow {
                file: "lossy.mcap".into(),
                outcome: Ok(figures(true)),
            },
            FleetRow {
                file: "broken.mcap".into(),
                outcome: Err("broken.mcap: not an MCAP file, \"magic\" missing".into()),
            },
        ]
    }

    #[test]
    fn fleet_csv_quotes_what_needs_it_and_pads_failures() {
        let header = fleet_csv_header(&ModelDescription::generator());
        let csv = String::from_utf8(fleet_csv(&rows(), &header).unwrap()).unwrap();
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(
            lines[0],
            "recording,status,t1_s,t2_s,t3_s,fit_stator_pct,fit_core_pct,fit_water_pct,\
             steady_stator_c,steady_core_c,steady_water_c"
        );
        assert_eq!(
            lines[1],
            "\"unit 3, run 1.mcap\",ok,23.9,737.25,3305.5,99.5,98,97.25,55.5,47.125,13"
        );
        assert!(lines[2].starts_with("lossy.mcap,data lost,23.9,"), "{csv}");
        assert_eq!(
            lines[3],
            "broken.mcap,\"failed: broken.mcap: not an MCAP file, \"\"magic\"\" missing\",,,,,,,,,"
        );
        assert_eq!(lines.len(), 4);
    }

    #[test]
    fn fleet_csv_reads_back_with_every_column() {
        let header = fleet_csv_header(&ModelDescription::generator());
        let bytes = fleet_csv(&rows(), &header).unwrap();
        let mut reader = csv::Reader::from_reader(bytes.as_slice());
        let records: Vec<csv::StringRecord> = reader.records().map(|r| r.unwrap()).collect();
        assert_eq!(records.len(), 3);
        assert!(records.iter().all(|r| r.len() == header.len()));
        assert_eq!(&records[0][0], "unit 3, run 1.mcap");
        assert_eq!(
            &records[2][1],
            "failed: broken.mcap: not an MCAP file, \"magic\" missing"
        );
        assert_eq!(records[0][8].parse::<f64>().unwrap(), 55.5);
    }

    #[test]
    fn a_four_state_fleet_has_a_column_for_every_figure() {
        let header = fleet_csv_header(&ModelDescription::generator_with_field_state());
        assert_eq!(header.len(), 2 + 3 * 4);
        assert_eq!(&header[5..7], ["t4_s", "fit_stator_pct"]);
        assert_eq!(header.last().unwrap(), "steady_field_c");
        let row = FleetRow {
            file: "field.mcap".into(),
            outcome: Ok(FleetFigures {
                time_constants_s: vec![70.0, 690.0, 1592.0, 4496.0],
                nrmse_fit_percent: vec![99.0, 98.0, 95.0, 98.5],
                steady_state_c: vec![31.9, 27.3, 14.6, 60.4],
                data_lost: false,
            }),
        };
        let csv = String::from_utf8(fleet_csv(&[row], &header).unwrap()).unwrap();
        assert_eq!(
            csv.lines().nth(1).unwrap(),
            "field.mcap,ok,70,690,1592,4496,99,98,95,98.5,31.9,27.3,14.6,60.4"
        );
    }

    #[test]
    fn a_fleet_is_tallied_by_outcome() {
        assert_eq!(
            FleetTally::of(&rows()),
            FleetTally {
                ok: 1,
                data_lost: 1,
                failed: 1
            }
        );
    }
}
