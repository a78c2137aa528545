//! `heatrun monitor`: a model report beside a later recording → alarms.

use heatrun::monitor::{self, BandRule, MonitorOptions};
use heatrun::predict::ThermalModel;
use heatrun::publish::RerunSink;

use super::Outcome;
use crate::cli::MonitorArgs;

pub fn run(args: MonitorArgs) -> anyhow::Result<Outcome> {
    if !(args.hold >= 0.0 && args.band_factor > 0.0 && args.band_floor >= 0.0) {
        return Err(heatrun::Error::Usage(format!(
            "--hold {} --band-factor {} --band-floor {}: the hold and the floor must be \
             0 or more, the factor more than 0",
            args.hold, args.band_factor, args.band_floor
        ))
        .into());
    }
    let model = ThermalModel::read(&args.model).map_err(heatrun::Error::from)?;
    let options = MonitorOptions {
        band: BandRule {
            factor: args.band_factor,
            floor_k: args.band_floor,
        },
        hold_s: args.hold,
    };
    let sink = match (&args.rrd, &args.connect) {
        (Some(path), _) => Some(RerunSink::Rrd(path.clone())),
        (None, Some(url)) => Some(RerunSink::Connect((!url.is_empty()).then(|| url.clone()))),
        (None, None) => None,
    };
    let result = monitor::monitor(&model, &args.recording, &options, None)?;
    // Outputs first, then the printout: a closed stdout must not cut an output short.
    if let Some(path) = &args.json {
        result.write_json(path)?;
    }
    if let Some(path) = &args.html {
        // Written whatever the verdict: a page with alarms is the one most worth reading.
        heatrun::html::monitor_page(&result).write(path)?;
    }
    if let Some(sink) = &sink {
        heatrun::publish::monitor::publish(&result, sink)?;
    }
    if args.quiet {
        for a in &result.alarms {
            println!("{}", result.alarm_line(a));
        }
    } else {
        print!("{}", result.summary());
    }
    for w in &result.warnings {
        eprintln!("warning: {w}");
    }
    for line in &result.data_loss {
        eprintln!("warning: data lost: {line}");
    }
    Ok(if !result.healthy() {
        Outcome::Alarms
    } else if !result.data_loss.is_empty() {
        Outcome::DataLoss
    } else {
        Outcome::Complete
    })
}
