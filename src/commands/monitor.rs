//! `heatrun monitor`: a model report beside a later recording → alarms, streamed as the
//! recording is read (from a file, or from standard input for `-`), each stretch
//! published to rerun as it is sealed.

use std::path::Path;

use heatrun::model_file::ThermalModel;
use heatrun::monitor::{self, BandRule, MonitorOptions, Source, StreamOptions, Watchers};
use heatrun_rerun::monitor::LivePublisher;
use heatrun_rerun::RerunSink;

use super::Outcome;
use crate::cli::MonitorArgs;

pub fn run(args: MonitorArgs) -> anyhow::Result<Outcome> {
    if !(args.hold >= 0.0 && args.band_factor > 0.0 && args.band_floor >= 0.0) {
        return Err(super::Usage(format!(
            "--hold {} --band-factor {} --band-floor {}: the hold and the floor must be \
             0 or more, the factor more than 0",
            args.hold, args.band_factor, args.band_floor
        ))
        .into());
    }
    if !(args.stretch >= 1.0 && args.stretch.is_finite()) {
        return Err(super::Usage(format!(
            "--stretch {}: the stretch must be at least 1 s",
            args.stretch
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
    let stdin = args.recording == Path::new("-");
    let name = if stdin {
        "standard input".to_owned()
    } else {
        args.recording
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default()
    };
    let mut publisher = match &sink {
        Some(sink) => Some(open_publisher(sink, &name, &model, &options)?),
        None => None,
    };
    let source = if stdin {
        Source::Stream {
            reader: Box::new(std::io::stdin()),
            name: "-".into(),
        }
    } else {
        Source::File(&args.recording)
    };
    let stream = StreamOptions {
        stretch_s: args.stretch,
        // Only the HTML page draws every instant; rerun is sent each stretch as it goes.
        keep_traces: args.html.is_some(),
        ..StreamOptions::default()
    };
    let mut live = Live {
        publisher: publisher.as_mut(),
        states: model.states.iter().map(|s| s.name.clone()).collect(),
        hold_ns: (args.hold * 1e9).round() as i64,
        print: !args.quiet,
    };
    let watchers = Watchers {
        observer: Some(&mut live),
        ..Default::default()
    };
    let result = monitor::monitor_stream(&model, source, &options, &stream, watchers)?;
    // Outputs first, then the printout: a closed stdout must not cut an output short.
    if let Some(path) = &args.json {
        result.write_json(path)?;
    }
    if let Some(path) = &args.html {
        // Written whatever the verdict: a page with alarms is the one most worth reading.
        heatrun::html::monitor_page(&result).write(path)?;
    }
    if let Some(publisher) = publisher {
        publisher.finish(&result)?;
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

/// What each sealed stretch goes to: the rerun recording, and a line on stderr for each
/// alarm as it is raised (the summary on stdout comes when the recording has ended).
struct Live<'p> {
    publisher: Option<&'p mut LivePublisher>,
    states: Vec<String>,
    hold_ns: i64,
    print: bool,
}

impl monitor::StretchObserver for Live<'_> {
    fn stretch(&mut self, stretch: &monitor::Stretch<'_>) -> Result<(), monitor::ObserverError> {
        if self.print {
            for &(j, start_ns) in stretch.raised {
                let at = |ns: i64| heatrun::recording::format_time(ns.max(0) as u64);
                eprintln!(
                    "alarm raised: {} outside its band since {}, raised at {}",
                    self.states[j],
                    at(start_ns),
                    at(start_ns + self.hold_ns)
                );
            }
        }
        match self.publisher.as_deref_mut() {
            Some(p) => p.stretch(stretch),
            None => Ok(()),
        }
    }
}

/// The rerun recording, opened before the recording is read so each stretch goes out as
/// it is sealed.
fn open_publisher(
    sink: &RerunSink,
    name: &str,
    model: &ThermalModel,
    options: &MonitorOptions,
) -> anyhow::Result<LivePublisher> {
    let states: Vec<String> = model.states.iter().map(|s| s.name.clone()).collect();
    let parts: Vec<String> = model.states.iter().map(|s| s.part.clone()).collect();
    let band = monitor::Band::from_model_error(&model.error, options.band);
    Ok(LivePublisher::open(sink, name, (&states, &parts), &band)?)
}
