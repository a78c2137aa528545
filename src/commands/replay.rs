//! `heatrun replay`: one recording, or a fleet of them in parallel.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use clap::ValueEnum;
use heatrun::atomic::write_atomically;
use heatrun::pipeline::{self, Method, Replay, ReplayOptions, ValidationSource};
use heatrun::publish::{Publisher, RerunSink};
use heatrun::report::Report;
use heatrun::spec::ModelDescription;

use super::Outcome;
use crate::cli::{MethodArg, ReplayArgs};

/// The fixture replayed when no file is named.
pub const DEFAULT_FIXTURE: &str = "fixtures/paper_heat_run.mcap";

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
        Some(path) => ModelDescription::from_toml_file(path)?,
        None => ModelDescription::generator(),
    };
    let method = match (args.method, model.method.as_deref()) {
        (Some(m), _) => m,
        (None, Some(name)) => MethodArg::from_str(name, true).map_err(|_| {
            anyhow::anyhow!(
                "{}: method = \"{name}\" is not one of oe, iv, rls, wls, ls",
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
    })
}

/// The recordings named: files as given, folders expanded to their .mcap files.
fn recordings(files: &[PathBuf]) -> anyhow::Result<(Vec<PathBuf>, bool)> {
    if files.is_empty() {
        return Ok((vec![default_fixture()], false));
    }
    let mut out = Vec::new();
    let mut folder = false;
    for f in files {
        if f.is_dir() {
            folder = true;
            let mut found: Vec<PathBuf> = std::fs::read_dir(f)
                .map_err(|e| heatrun::Error::ReadInput {
                    path: f.clone(),
                    source: e,
                })?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|x| x == "mcap"))
                .collect();
            found.sort();
            out.extend(found);
        } else {
            out.push(f.clone());
        }
    }
    if out.is_empty() {
        return Err(
            heatrun::Error::Usage("no .mcap recordings in the folders given".into()).into(),
        );
    }
    Ok((out, folder))
}

fn stem(file: &Path) -> String {
    file.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "heatrun".into())
}

/// Replays one recording into its sink and report; returns the replay and its summary text.
fn replay_one(
    args: &ReplayArgs,
    file: &Path,
    sink: &RerunSink,
    report: Option<&Path>,
) -> anyhow::Result<(Replay, String)> {
    let options = options(args)?;
    let name = file
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let publisher = Publisher::open(sink, &name)?;
    let replay = if args.raw {
        let mut full_rate = publisher.full_rate();
        let replay = pipeline::replay_with(file, &options, Some(&mut full_rate))?;
        full_rate.flush()?;
        replay
    } else {
        pipeline::replay(file, &options)?
    };
    let report_data = Report::new(&replay);
    let summary = report_data.summary();
    publisher.finish(&replay, &summary)?;
    if let Some(path) = report {
        write_atomically(path, report_data.to_json().as_bytes())?;
    }
    Ok((replay, summary))
}

pub fn run(args: ReplayArgs) -> anyhow::Result<Outcome> {
    let (files, folder) = recordings(&args.files)?;
    if files.len() > 1 || folder {
        return fleet(&args, &files);
    }
    let started = Instant::now();
    let file = &files[0];
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
    let (replay, summary) = replay_one(&args, file, &sink, args.report.as_deref())?;
    if args.quiet {
        for w in &replay.warnings {
            eprintln!("warning: {w}");
        }
    } else {
        print!("{summary}");
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
        println!("replayed in {:.2} s", started.elapsed().as_secs_f64());
    }
    Ok(if replay.had_data_loss() {
        Outcome::DataLoss
    } else {
        Outcome::Complete
    })
}

/// A CSV field (RFC 4180): quoted, with quotes doubled, when it holds a comma, a
/// quote or a line break.
fn csv_field(text: &str) -> String {
    if text.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_owned()
    }
}

/// One line of the fleet summary.
struct FleetRow {
    file: PathBuf,
    result: std::result::Result<(Vec<f64>, Vec<f64>, Vec<f64>, bool), String>,
}

/// Replays many recordings, `--jobs` at a time; each gets `<stem>.rrd` and
/// `<stem>.report.json` in `--out-dir`, and the fleet a summary table (printed, and
/// written as `fleet-summary.csv`).
fn fleet(args: &ReplayArgs, files: &[PathBuf]) -> anyhow::Result<Outcome> {
    if args.rrd.is_some() || args.report.is_some() || args.spawn || args.connect.is_some() {
        return Err(heatrun::Error::Usage(
            "with several recordings, outputs go to --out-dir (one .rrd and report each); \
             --rrd, --report, --spawn and --connect name one output"
                .into(),
        )
        .into());
    }
    std::fs::create_dir_all(&args.out_dir)
        .with_context(|| format!("cannot create {}", args.out_dir.display()))?;
    let jobs = args
        .jobs
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(2, |n| n.get()))
        .max(1);
    let next = std::sync::atomic::AtomicUsize::new(0);
    let rows = std::sync::Mutex::new(Vec::new());
    let started = Instant::now();
    std::thread::scope(|scope| {
        for _ in 0..jobs.min(files.len()) {
            scope.spawn(|| loop {
                let i = next.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                let Some(file) = files.get(i) else { break };
                let s = stem(file);
                let rrd = RerunSink::Rrd(args.out_dir.join(format!("{s}.rrd")));
                let report = args.out_dir.join(format!("{s}.report.json"));
                let result = replay_one(args, file, &rrd, Some(&report))
                    .map(|(r, _)| {
                        let a = &r.analysis;
                        let temps: Vec<f64> = (0..3)
                            .map(|j| {
                                r.signals.initial_temperatures_c[j]
                                    + r.signals.temperature_base_k * a.steady_state[j]
                            })
                            .collect();
                        (
                            a.spectrum.time_constants_s.clone(),
                            a.fit.nrmse_fit_percent.clone(),
                            temps,
                            r.had_data_loss(),
                        )
                    })
                    .map_err(|e| format!("{e:#}"));
                if let Ok(mut rows) = rows.lock() {
                    rows.push((
                        i,
                        FleetRow {
                            file: file.clone(),
                            result,
                        },
                    ));
                }
            });
        }
    });
    let mut rows = rows.into_inner().unwrap_or_default();
    rows.sort_by_key(|r| r.0);
    let mut csv = String::from("recording,status,t1_s,t2_s,t3_s,fit_stator_pct,fit_core_pct,fit_water_pct,steady_stator_c,steady_core_c,steady_water_c\n");
    println!(
        "{:<32} {:>9} {:>9} {:>9}  {:>22}  {:>22}  status",
        "recording", "T1 s", "T2 s", "T3 s", "NRMSE fit % (Cu Fe cw)", "steady state °C"
    );
    let (mut failed, mut lossy) = (0, 0);
    for (_, row) in &rows {
        let name = row.file.display().to_string();
        match &row.result {
            Ok((t, fit, ss, loss)) => {
                let status = if *loss { "data lost" } else { "ok" };
                lossy += usize::from(*loss);
                let f3 = |v: &[f64], d: usize| {
                    v.iter()
                        .map(|x| format!("{x:.d$}"))
                        .collect::<Vec<_>>()
                        .join(" ")
                };
                println!(
                    "{name:<32} {:>9.2} {:>9.2} {:>9.2}  {:>22}  {:>22}  {status}",
                    t[0],
                    t[1],
                    t[2],
                    f3(fit, 2),
                    f3(ss, 2)
                );
                csv.push_str(&format!(
                    "{},{status},{},{},{},{},{},{},{},{},{}\n",
                    csv_field(&name),
                    t[0],
                    t[1],
                    t[2],
                    fit[0],
                    fit[1],
                    fit[2],
                    ss[0],
                    ss[1],
                    ss[2]
                ));
            }
            Err(e) => {
                failed += 1;
                println!("{name:<32} failed: {e}");
                csv.push_str(&format!(
                    "{},{},,,,,,,,,\n",
                    csv_field(&name),
                    csv_field(&format!("failed: {e}"))
                ));
            }
        }
    }
    write_atomically(&args.out_dir.join("fleet-summary.csv"), csv.as_bytes())?;
    println!(
        "{} recordings in {:.2} s ({} jobs): {} ok, {} with data loss, {} failed; reports and .rrd files in {}",
        rows.len(),
        started.elapsed().as_secs_f64(),
        jobs,
        rows.len() - failed - lossy,
        lossy,
        failed,
        args.out_dir.display()
    );
    Ok(if failed > 0 {
        return Err(heatrun::Error::Usage(format!(
            "{failed} of {} recordings failed (see the table)",
            rows.len()
        ))
        .into());
    } else if lossy > 0 {
        Outcome::DataLoss
    } else {
        Outcome::Complete
    })
}

#[cfg(test)]
mod tests {
    use super::csv_field;

    #[test]
    fn csv_fields_are_quoted_only_when_needed() {
        assert_eq!(csv_field("run-1.mcap"), "run-1.mcap");
        assert_eq!(csv_field("unit 3, run 1.mcap"), "\"unit 3, run 1.mcap\"");
        assert_eq!(csv_field("say \"hi\""), "\"say \"\"hi\"\"\"");
    }
}
