//! `heatrun replay`: one recording, or a fleet of them in parallel.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Instant;

use anyhow::Context;
use clap::ValueEnum;
use heatrun::atomic::write_atomically;
use heatrun::pipeline::{self, Method, Replay, ReplayOptions, ValidationSource};
use heatrun::progress::{Observer, Progress};
use heatrun_rerun::{Publisher, RerunSink};
use heatrun::report::Report;
use heatrun::spec::coolant::ReferencePolicy;
use heatrun::spec::ModelDescription;
use rayon::prelude::*;

use super::bars::{self, Bars};
use super::Outcome;
use crate::cli::{MethodArg, ReferenceArg, ReplayArgs, SummaryFormat};

/// The fixture replayed when no file is named.
pub const DEFAULT_FIXTURE: &str = "fixtures/paper_heat_run.mcap";

/// The fixture beside the current folder, else in the source tree this binary was built
/// from (so `cargo run -- replay` works from any folder of a clone).
fn default_fixture() -> PathBuf {
    let here = PathBuf::from(DEFAULT_FIXTURE);
    if here.exists() {
        return here;
    }
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(DEFAULT_FIXTURE)
}

/// The replay's options: the command line first, then the spec's own sample time and
/// method, then the defaults (1 s, `oe`).
fn options(args: &ReplayArgs) -> anyhow::Result<ReplayOptions> {
    let model = match &args.spec {
        Some(path) => ModelDescription::from_toml_file(path).map_err(heatrun::Error::from)?,
        None if args.field_state => ModelDescription::generator_with_field_state(),
        None => ModelDescription::generator(),
    };
    let method = match (args.method, model.method.as_deref()) {
        (Some(m), _) => m,
        (None, Some(name)) => MethodArg::from_str(name, true).map_err(|_| {
            anyhow::anyhow!(
                "{}: method = \"{name}\" is not one of oe, rc, iv, rls, wls, ls",
                args.spec.as_deref().unwrap_or(Path::new("spec")).display()
            )
        })?,
        (None, None) => MethodArg::Oe,
    };
    Ok(ReplayOptions {
        ts_s: args.ts.or(model.sample_time_s).unwrap_or(1.0),
        machine: args.machine.clone(),
        method: match method {
            MethodArg::Ls => Method::Ls,
            MethodArg::Wls => Method::Wls,
            MethodArg::Rls => Method::Rls,
            MethodArg::Iv => Method::Iv,
            MethodArg::Oe => Method::Oe,
            MethodArg::Rc => Method::Rc,
        },
        weights: args.weights.clone(),
        forgetting: args.forgetting,
        validation: match (&args.holdout, &args.split_at, &args.validate) {
            (Some(f), _, _) => Some(ValidationSource::HoldOut(*f)),
            (None, Some(t), _) => Some(ValidationSource::SplitAt(*t)),
            (None, None, Some(file)) => Some(ValidationSource::Recording(file.clone())),
            (None, None, None) => None,
        },
        model,
        reference: match args.reference {
            ReferenceArg::Auto => ReferencePolicy::Auto,
            ReferenceArg::Initial => ReferencePolicy::Initial,
            ReferenceArg::Inlet => ReferencePolicy::Inlet,
        },
        progress: Observer::silent(),
    })
}

/// The recordings a `replay` names.
struct Recordings {
    /// Files as given, folders expanded to their `.mcap` files (sorted).
    files: Vec<PathBuf>,
    /// Whether a folder was named: a fleet even if it holds one recording.
    from_folder: bool,
}

impl Recordings {
    /// The recordings named: files as given, folders expanded; the fixture if none.
    fn named(files: &[PathBuf]) -> anyhow::Result<Recordings> {
        if files.is_empty() {
            return Ok(Recordings {
                files: vec![default_fixture()],
                from_folder: false,
            });
        }
        let mut out = Vec::new();
        let mut from_folder = false;
        for f in files {
            if f.is_dir() {
                from_folder = true;
                out.extend(mcap_files_in(f)?);
            } else {
                out.push(f.clone());
            }
        }
        if out.is_empty() {
            return Err(
                super::Usage("no .mcap recordings in the folders given".into()).into(),
            );
        }
        Ok(Recordings {
            files: out,
            from_folder,
        })
    }

    /// Whether this is a fleet (outputs per recording in `--out-dir`, a summary table).
    fn is_fleet(&self) -> bool {
        self.files.len() > 1 || self.from_folder
    }
}

/// The `.mcap` files of a folder, sorted by name.
fn mcap_files_in(folder: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let mut found: Vec<PathBuf> = std::fs::read_dir(folder)
        .map_err(|source| {
            heatrun::Error::from(heatrun::recording::RecordingError::ReadInput {
                path: folder.to_owned(),
                source,
            })
        })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "mcap"))
        .collect();
    found.sort();
    Ok(found)
}

fn stem(file: &Path) -> String {
    file.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "heatrun".into())
}

/// One recording replayed, with its report and the summary printed from it.
struct Replayed {
    replay: Replay,
    report: Report,
    summary: String,
}

/// Where one recording's outputs besides the rerun recording go.
struct Outputs<'a> {
    /// The JSON report, if asked for.
    report: Option<&'a Path>,
    /// The HTML report, if asked for.
    html: Option<&'a Path>,
}

/// Replays one recording into its sink and (if named) its report files, telling
/// `progress` how the reading and the estimation go.
fn replay_one(
    args: &ReplayArgs,
    file: &Path,
    sink: &RerunSink,
    outputs: Outputs<'_>,
    progress: Observer,
) -> anyhow::Result<Replayed> {
    let options = ReplayOptions {
        progress,
        ..options(args)?
    };
    let name = file
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let publisher = Publisher::open(sink, &name)?;
    // The publisher sends each stage's series while the next stage runs.
    let replay = if args.raw {
        let mut full_rate = publisher.full_rate();
        let replay = pipeline::replay_observed(file, &options, Some(&mut full_rate), &publisher)?;
        full_rate.flush()?;
        replay
    } else {
        pipeline::replay_observed(file, &options, None, &publisher)?
    };
    options.progress.stage("writing the outputs");
    let report = Report::new(&replay);
    let summary = report.summary();
    publisher.finish(&replay, &report, &summary)?;
    if let Some(path) = outputs.report {
        write_atomically(path, report.to_json().as_bytes())?;
    }
    if let Some(path) = outputs.html {
        heatrun::html::replay_page(&replay, &report, &options).write(path)?;
    }
    Ok(Replayed {
        replay,
        report,
        summary,
    })
}

/// Runs `heatrun replay`: one recording, or a fleet when several (or a folder) are named.
pub fn run(args: ReplayArgs) -> anyhow::Result<Outcome> {
    let recordings = Recordings::named(&args.files)?;
    if recordings.is_fleet() {
        return fleet(&args, &recordings.files);
    }
    let started = Instant::now();
    let file = &recordings.files[0];
    let sink = if args.spawn {
        RerunSink::Spawn
    } else if let Some(url) = &args.connect {
        RerunSink::Connect((!url.is_empty()).then(|| url.clone()))
    } else {
        RerunSink::Rrd(
            args.rrd
                .clone()
                .unwrap_or_else(|| PathBuf::from(format!("{}.rrd", stem(file)))),
        )
    };
    // Everything is written before anything is printed: a closed stdout (`| head`)
    // ends the process at the first print and must not cut an output short.
    let html = html_path(&args, file)?;
    let outputs = Outputs {
        report: args.report.as_deref(),
        html: html.as_deref(),
    };
    let bars = Arc::new(Bars::new(bars::draw_here(args.quiet)));
    let replayed = replay_one(&args, file, &sink, outputs, Observer::shared(bars.clone()));
    bars.clear();
    let replayed = replayed?;
    if args.quiet || args.summary == SummaryFormat::Json {
        for w in &replayed.replay.warnings {
            eprintln!("warning: {w}");
        }
        if args.summary == SummaryFormat::Json {
            println!("{}", replayed.report.to_json());
        }
    } else {
        print!("{}", replayed.summary);
        match &sink {
            RerunSink::Rrd(p) => println!("rerun recording: {}", p.display()),
            RerunSink::Connect(url) => println!(
                "rerun: sent to {}",
                url.as_deref().unwrap_or("the local viewer")
            ),
            RerunSink::Spawn => println!("rerun: sent to a spawned viewer"),
        }
        if let Some(path) = &args.report {
            println!("report: {}", path.display());
        }
        if let Some(path) = &html {
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

/// The HTML report's path of a single replay: as given, or `<stem>.html` here for a bare
/// `--html`. A path that names a recording is refused: `--html run.mcap` means the
/// option took the recording as its value.
fn html_path(args: &ReplayArgs, file: &Path) -> anyhow::Result<Option<PathBuf>> {
    let Some(given) = &args.html else {
        return Ok(None);
    };
    if given.is_empty() {
        return Ok(Some(PathBuf::from(format!("{}.html", stem(file)))));
    }
    let path = PathBuf::from(given);
    if path.extension().is_some_and(|x| x == "mcap") {
        return Err(super::Usage(format!(
            "--html would write the page over the recording {}; write --html=PAGE.html, \
             or put --html after the recordings",
            path.display()
        ))
        .into());
    }
    Ok(Some(path))
}

/// What the fleet table and `fleet-summary.csv` show of one recording: its report's
/// `time_constants_s`, `fit.nrmse_fit_percent` and `steady_state.temperature_c`, so the
/// table made here and one gathered from a cluster's reports agree.
struct FleetFigures {
    time_constants_s: Vec<f64>,
    nrmse_fit_percent: Vec<f64>,
    steady_state_c: Vec<f64>,
    data_lost: bool,
}

impl FleetFigures {
    fn of(replayed: &Replayed) -> FleetFigures {
        let report = &replayed.report;
        FleetFigures {
            time_constants_s: report.time_constants_s.clone(),
            nrmse_fit_percent: report.fit.nrmse_fit_percent.clone(),
            steady_state_c: report.steady_state.temperature_c.clone(),
            data_lost: replayed.replay.had_data_loss(),
        }
    }

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
    file: PathBuf,
    outcome: Result<FleetFigures, String>,
}

/// How a fleet's recordings ended.
#[derive(Debug, Default, PartialEq, Eq)]
struct FleetTally {
    ok: usize,
    data_lost: usize,
    failed: usize,
}

impl FleetTally {
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

/// Replays many recordings, `--jobs` at a time; each gets `<stem>.rrd` and
/// `<stem>.report.json` in `--out-dir`, and the fleet a summary table (written as
/// `fleet-summary.csv`, then printed). Exit 2 if any failed, else 3 if any lost data.
fn fleet(args: &ReplayArgs, files: &[PathBuf]) -> anyhow::Result<Outcome> {
    check_fleet_args(args)?;
    std::fs::create_dir_all(&args.out_dir)
        .with_context(|| format!("cannot create {}", args.out_dir.display()))?;
    let jobs = args
        .jobs
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(2, |n| n.get()))
        .max(1);
    let started = Instant::now();
    let bars = Bars::new(bars::draw_here(args.quiet));
    let rows = replay_fleet(args, files, jobs, &bars);
    bars.clear();
    let rows = rows?;
    let model = options(args)?.model;
    write_atomically(
        &args.out_dir.join("fleet-summary.csv"),
        &fleet_csv(&rows, &fleet_csv_header(&model))?,
    )?;
    print_fleet_table(&rows, &model);
    let tally = FleetTally::of(&rows);
    println!(
        "{} recordings in {:.2} s ({} jobs): {} ok, {} with data loss, {} failed; reports and .rrd files in {}",
        rows.len(),
        started.elapsed().as_secs_f64(),
        jobs,
        tally.ok,
        tally.data_lost,
        tally.failed,
        args.out_dir.display()
    );
    if tally.failed > 0 {
        return Err(super::Usage(format!(
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

/// A fleet's outputs go to `--out-dir`: the options that name one output do not apply.
fn check_fleet_args(args: &ReplayArgs) -> anyhow::Result<()> {
    let html_named = args.html.as_ref().is_some_and(|h| !h.is_empty());
    if args.rrd.is_some()
        || args.report.is_some()
        || html_named
        || args.spawn
        || args.connect.is_some()
    {
        return Err(super::Usage(
            "with several recordings, outputs go to --out-dir (one .rrd and report each, and \
             an HTML page each with a bare --html); --rrd, --report, --html PATH, --spawn and \
             --connect name one output"
                .into(),
        )
        .into());
    }
    Ok(())
}

/// Replays every file on a pool of `jobs` threads; the rows come back in the files' order.
/// `progress` is told each recording done (the recordings' own reading and estimation,
/// `jobs` at once, are not shown).
fn replay_fleet(
    args: &ReplayArgs,
    files: &[PathBuf],
    jobs: usize,
    progress: &dyn Progress,
) -> anyhow::Result<Vec<FleetRow>> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs.min(files.len()))
        .thread_name(|i| format!("heatrun-fleet-{i}"))
        .build()
        .context("cannot start the fleet's threads")?;
    let done = AtomicUsize::new(0);
    progress.recording_done(0, files.len());
    Ok(pool.install(|| {
        files
            .par_iter()
            .map(|f| {
                let row = fleet_row(args, f);
                let done = done.fetch_add(1, Ordering::Relaxed) + 1;
                progress.recording_done(done, files.len());
                row
            })
            .collect()
    }))
}

/// Replays one recording of a fleet into `--out-dir`; a failure becomes its row's reason.
fn fleet_row(args: &ReplayArgs, file: &Path) -> FleetRow {
    let s = stem(file);
    let rrd = RerunSink::Rrd(args.out_dir.join(format!("{s}.rrd")));
    let report = args.out_dir.join(format!("{s}.report.json"));
    let html = args
        .html
        .is_some()
        .then(|| args.out_dir.join(format!("{s}.report.html")));
    let outputs = Outputs {
        report: Some(&report),
        html: html.as_deref(),
    };
    FleetRow {
        file: file.to_owned(),
        outcome: replay_one(args, file, &rrd, outputs, Observer::silent())
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
