//! `heatrun replay`.

use std::path::PathBuf;
use std::time::Instant;

use heatrun::atomic::write_atomically;
use heatrun::pipeline::{self, Method, ReplayOptions, ValidationSource};
use heatrun::publish::{self, RerunSink};
use heatrun::report::Report;

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

pub fn run(args: ReplayArgs) -> anyhow::Result<Outcome> {
    let started = Instant::now();
    let file = args.file.clone().unwrap_or_else(default_fixture);
    let options = ReplayOptions {
        ts_s: args.ts,
        machine: args.machine.clone(),
        method: match args.method {
            MethodArg::Ls => Method::Ls,
            MethodArg::Wls => Method::Wls,
            MethodArg::Rls => Method::Rls,
            MethodArg::Iv => Method::Iv,
            MethodArg::Oe => Method::Oe,
        },
        weights: args.weights.clone(),
        forgetting: args.forgetting,
        validation: match (&args.holdout, &args.validate) {
            (Some(f), _) => Some(ValidationSource::HoldOut(*f)),
            (None, Some(file)) => Some(ValidationSource::Recording(file.clone())),
            (None, None) => None,
        },
    };
    let replay = pipeline::replay(&file, &options)?;
    let report = Report::new(&replay);
    let summary = report.summary();

    let sink = if args.spawn {
        RerunSink::Spawn
    } else if let Some(url) = &args.connect {
        RerunSink::Connect((!url.is_empty()).then(|| url.clone()))
    } else {
        let path = args.rrd.clone().unwrap_or_else(|| {
            let stem = file.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or("heatrun".into());
            PathBuf::from(format!("{stem}.rrd"))
        });
        RerunSink::Rrd(path)
    };
    publish::publish(&replay, &summary, &sink)?;
    if let Some(path) = &args.report {
        write_atomically(path, report.to_json().as_bytes())?;
    }
    if !args.quiet {
        print!("{summary}");
        match &sink {
            RerunSink::Rrd(p) => println!("rerun recording: {}", p.display()),
            RerunSink::Connect(url) => println!("rerun: sent to {}", url.as_deref().unwrap_or("the local viewer")),
            RerunSink::Spawn => println!("rerun: sent to a spawned viewer"),
        }
        if let Some(path) = &args.report {
            println!("report: {}", path.display());
        }
        println!("replayed in {:.2} s", started.elapsed().as_secs_f64());
    }
    for w in &replay.warnings {
        if args.quiet {
            eprintln!("warning: {w}");
        }
    }
    Ok(if replay.had_data_loss() { Outcome::DataLoss } else { Outcome::Complete })
}
