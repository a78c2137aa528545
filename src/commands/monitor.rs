//! `heatrun monitor`: a model report beside a later recording → alarms, streamed as the
//! recording is read (from a file, or from standard input for `-`), each stretch
//! published to rerun as it is sealed.

use heatrun::model_file::ThermalModel;
use heatrun::monitor::{self, MonitorOptions, MonitorResult, Source, Watchers};
use heatrun_rerun::monitor::LivePublisher;
use heatrun_rerun::RerunSink;

use super::Outcome;
use crate::cli::{Input, Monitor};

/// Monitors the recording as it is read, publishing each stretch as it is sealed; then
/// writes the outputs and prints the summary (or the alarm lines).
pub fn run(request: &Monitor) -> anyhow::Result<Outcome> {
    let model = ThermalModel::read(&request.model).map_err(heatrun::Error::from)?;
    let mut publisher = match &request.sink {
        Some(sink) => Some(open_publisher(
            sink,
            &request.name,
            &model,
            &request.options,
        )?),
        None => None,
    };
    let source = match &request.recording {
        Input::Stdin => Source::Stream {
            reader: Box::new(std::io::stdin()),
            name: "-".into(),
        },
        Input::File(path) => Source::File(path),
    };
    let mut live = Live {
        publisher: publisher.as_mut(),
        states: model.states.iter().map(|s| s.name.clone()).collect(),
        hold_ns: (request.options.hold_s * 1e9).round() as i64,
        print: !request.quiet,
    };
    let watchers = Watchers {
        observer: Some(&mut live),
        ..Default::default()
    };
    let result =
        monitor::monitor_stream(&model, source, &request.options, &request.stream, watchers)?;
    // Outputs first, then the printout: a closed stdout must not cut an output short.
    if let Some(path) = &request.json {
        result.write_json(path)?;
    }
    if let Some(path) = &request.html {
        // Written whatever the verdict: a page with alarms is the one most worth reading.
        heatrun::html::monitor_page(&result).write(path)?;
    }
    if let Some(publisher) = publisher {
        publisher.finish(&result)?;
    }
    print(&result, request.quiet);
    Ok(if !result.healthy() {
        Outcome::Alarms
    } else if !result.data_loss.is_empty() {
        Outcome::DataLoss
    } else {
        Outcome::Complete
    })
}

/// The summary on stdout (only the alarm lines if quiet); warnings and data lost on stderr.
fn print(result: &MonitorResult, quiet: bool) {
    if quiet {
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
