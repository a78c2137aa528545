//! What to do next, for the errors the user can fix from the command line: the library's
//! errors name what is wrong (file, channel, row, key, time); the CLI edge names the flag,
//! file or command that mends it, in the style of ripgrep's messages.

use heatrun::decimate::DecimateError;
use heatrun::estimate::EstimationError;
use heatrun::import::ImportError;
use heatrun::losses::LossError;
use heatrun::model::ModelError;
use heatrun::model_file::UseError;
use heatrun::recording::RecordingError;
use heatrun::signals::SignalError;
use heatrun::Error;

/// The error as one line: its message, then each cause whose text the message does not
/// already hold (the library's messages carry their causes, so `{:#}` would say them
/// twice: "cannot read: No such file…: No such file…").
pub fn one_line(err: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in err.chain() {
        let text = cause.to_string();
        if line.contains(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}

/// A one-line hint for an error, where the command line can mend it.
pub fn for_error(err: &anyhow::Error) -> Option<String> {
    if let Some(e) = err.downcast_ref::<heatrun_rerun::PublishError>() {
        return for_viewer(e);
    }
    let e = err.downcast_ref::<Error>()?;
    let e = match e {
        Error::InRecording { error, .. } => error.as_ref(),
        other => other,
    };
    match e {
        Error::Estimation(e) => for_estimation(e),
        Error::Model(e) => for_model(e),
        Error::ModelUse(e) => for_model_use(e),
        Error::Decimate(e) => for_decimation(e),
        Error::Import(e) => for_import(e),
        Error::Recording(e) => for_recording(e),
        Error::Signals(e) => for_signals(e),
        other => for_replay(other),
    }
}

/// Hints for a viewer that cannot be reached: where one is started, or the file instead.
fn for_viewer(e: &heatrun_rerun::PublishError) -> Option<String> {
    let heatrun_rerun::PublishError::Rerun(message) = e else {
        return None;
    };
    message.contains("unable to connect").then(|| {
        "start a viewer there (`rerun` listens on rerun+http://127.0.0.1:9876/proxy), use \
         --spawn to start one, or save the recording with --rrd FILE.rrd"
            .into()
    })
}

/// Hints for the recording: its channels and nameplate.
fn for_recording(e: &RecordingError) -> Option<String> {
    Some(match e {
        RecordingError::MissingNameplateKeys { .. } | RecordingError::BadNameplateValue { .. } => {
            "give the key in a machine file with --machine FILE.toml".into()
        }
        RecordingError::BadMachineFile { message, .. } => {
            unknown_key(message).unwrap_or_else(|| {
                "a machine file holds the keys of the profile's `heatrun.nameplate` record \
             (docs/src/reference/recording-format.md)"
                    .into()
            })
        }
        RecordingError::Channel { .. } => {
            "mend the channel's metadata where the recording is written, or convert the table \
             again with `heatrun import` and the column's `unit` in the map"
                .into()
        }
        _ => return None,
    })
}

/// Hints for the signal stage: the channels and nameplate the model needs.
fn for_signals(e: &SignalError) -> Option<String> {
    Some(match e {
        SignalError::Losses(LossError::NoFieldTemperature | LossError::FieldScalingRise { .. }) => {
            "give `field_winding_final_temp_c` in a machine file with --machine FILE.toml".into()
        }
        SignalError::NoFieldState => {
            "replay it without --field-state, or record the field winding's temperature or voltage"
                .into()
        }
        SignalError::NameplateNeeded => {
            "give the nameplate in a machine file with --machine FILE.toml (the keys of the \
             SCADA profile's `heatrun.nameplate` record; see docs/src/reference/recording-format.md)"
                .into()
        }
        SignalError::MissingChannel { .. } | SignalError::Losses(LossError::MissingChannel { .. }) => {
            "`heatrun info FILE` lists the channels the recording has; a spec (--spec \
             SPEC.toml) names the ones its model reads"
                .into()
        }
        SignalError::ExpressionNeverFinite { .. } => {
            "mend the input's expression in the spec (docs/src/reference/spec.md)".into()
        }
        SignalError::NoCommonInstant { .. } => {
            "`heatrun info FILE` shows each channel's span and gaps; a longer --ts bridges \
             short gaps"
                .into()
        }
        _ => return None,
    })
}

/// Hints for the replay's own errors: the options and the spec.
fn for_replay(e: &Error) -> Option<String> {
    Some(match e {
        Error::HoldOutFraction { .. } => "give --holdout a fraction such as 0.3".into(),
        Error::SplitOutside { .. } => {
            "give --split-at a time inside the recording, in seconds from its start".into()
        }
        Error::Weights { .. } => "give --weights one positive number per state".into(),
        Error::Synth(heatrun::synth::SynthError::Options(message))
            if message.contains("simulates in memory") =>
        {
            "give a shorter --duration".into()
        }
        Error::Spec(heatrun::spec::SpecFileError::Bad { problem, .. }) => {
            unknown_key(&problem.to_string())
                .unwrap_or_else(|| "docs/src/reference/spec.md shows the spec's keys".into())
        }
        _ => return None,
    })
}

/// Hints for the estimators' refusals.
fn for_estimation(e: &EstimationError) -> Option<String> {
    Some(match e {
        EstimationError::InputNotHeat { .. } => {
            "identify it with --method oe (a black-box model takes any input)".into()
        }
        EstimationError::TooFewRows { .. } => {
            "a shorter --ts gives more instants; `heatrun info FILE` shows where the channels \
             have gaps"
                .into()
        }
        EstimationError::DependentInputs { constant: true, .. } => {
            "the inputs must change: replay a heat run with load steps".into()
        }
        EstimationError::DependentInputs { .. } => {
            "two proportional inputs are one heat: keep one of them in the spec (--spec \
             SPEC.toml)"
                .into()
        }
        EstimationError::ZeroRegressor { .. } | EstimationError::NoExcitation { .. } => {
            "the inputs must change, and change independently: replay a heat run with load \
             steps, or identify fewer inputs with --spec SPEC.toml"
                .into()
        }
        EstimationError::ForgettingFactor { .. } => {
            "give --forgetting a factor in (0, 1], such as 0.999".into()
        }
        EstimationError::WeightShape { .. } | EstimationError::InvalidWeight { .. } => {
            "give --weights one positive number per state".into()
        }
        EstimationError::UnstableStart { .. }
        | EstimationError::NoStableStep { .. }
        | EstimationError::MinimisationFailed { .. } => {
            "try another estimator (--method iv or --method wls) to see the start it gets, or a \
             shorter --ts"
                .into()
        }
        _ => return None,
    })
}

/// Hints for an estimate that is no thermal system.
fn for_model(e: &ModelError) -> Option<String> {
    Some(match e {
        ModelError::NoRealLogarithm { .. }
        | ModelError::Unstable { .. }
        | ModelError::UnstablePair { .. }
        | ModelError::ComplexEigenvalues { .. } => {
            "a shorter --ts resolves fast dynamics; --method oe is the least biased by sensor \
             noise"
                .into()
        }
        _ => return None,
    })
}

/// Hints for the decimator's refusals.
fn for_decimation(e: &DecimateError) -> Option<String> {
    Some(match e {
        DecimateError::SampleTime { .. } => {
            "give --ts a sample time between 0.001 s and 3600 s".into()
        }
        DecimateError::SparseSpan { .. } => {
            "`heatrun info FILE` shows each channel's span; a longer --ts shrinks the grid".into()
        }
        DecimateError::NoSamples => {
            "`heatrun info FILE` lists the channels and their samples".into()
        }
        _ => return None,
    })
}

/// Hints for `heatrun import`: the map and the table.
fn for_import(e: &ImportError) -> Option<String> {
    Some(match e {
        ImportError::AbsentColumn {
            column, available, ..
        } => {
            let names = available.replace('`', "");
            match closest(column.trim_matches('`'), &names) {
                Some(name) => format!("did you mean `{name}`? Mend the map's `column`"),
                None => "name one of the columns in the map, or give its position (1-based)".into(),
            }
        }
        ImportError::BadNumber { text, .. } => format!(
            "if `{text}` marks a missing value, add `missing = [\"{text}\"]` to the map's \
             [input]; `decimal_comma = true` reads 1,5"
        ),
        ImportError::RaggedRow { .. } => {
            "set the map's [input] `delimiter` (\",\", \";\", \"\\t\" or \"whitespace\"); \
             `heatrun import --guess FILE` shows what it finds"
                .into()
        }
        ImportError::BadTime { .. } => {
            "give the map's [time] `format` (\"seconds\" or \"timestamp\"), or a `pattern` \
             such as \"%d.%m.%Y %H:%M:%S\""
                .into()
        }
        ImportError::SkippedTime { .. } => {
            "if the table keeps standard time all year, give its fixed offset as the map's \
             [time] `zone` (such as \"+01:00\")"
                .into()
        }
        // Summer time's end puts a local clock back an hour; other steps back are rows out
        // of order.
        ImportError::TimeBackwards { back_s, .. } if !(2700.0..=4500.0).contains(back_s) => {
            format!(
                "the rows are out of time order ({back_s} s back): sort the table by its time \
                 column"
            )
        }
        ImportError::TimeBackwards { .. } => {
            "local wall-clock times go back an hour when summer time ends: give the map's \
             [time] `zone` (such as \"Europe/Zurich\") and the rows' order places them"
                .into()
        }
        ImportError::MapSyntax { message, .. } => {
            unknown_key(message).unwrap_or_else(|| MAP_HINT.into())
        }
        ImportError::MapValue { .. } => MAP_HINT.into(),
        _ => return None,
    })
}

/// Hints for `predict` and `rating`: the model report and the load schedule.
fn for_model_use(e: &UseError) -> Option<String> {
    Some(match e {
        UseError::NotAReport { .. } | UseError::MissingBlock { .. } | UseError::Shape { .. } => {
            "--model takes the JSON report of `heatrun replay FILE --report REPORT.json`".into()
        }
        UseError::ProfileVersion { .. } => {
            "replay the recording again with this heatrun (`heatrun replay FILE --report \
             REPORT.json`) for a report it reads"
                .into()
        }
        UseError::UnknownColumn { column, known, .. } => match closest(column, known) {
            Some(name) => format!("did you mean `{name}`? Rename the column in the file"),
            None => "rename or remove the column; docs/src/guide/predict-and-rating.md shows \
                     a schedule"
                .into(),
        },
        UseError::MissingColumn { .. } => {
            "docs/src/guide/predict-and-rating.md shows a schedule's columns".into()
        }
        UseError::BadCell { .. } => "mend that cell of the load file".into(),
        UseError::ScheduleTooLong { .. } => {
            "predict a shorter schedule, or a long one in parts, each started with \
             --initial-temps from the last row of the one before"
                .into()
        }
        UseError::TimeBackwards { .. } => {
            "mend that cell of the load file: its rows are in increasing time_s".into()
        }
        // Requests the command line mends (`predict::predict`, `rating::rate`); matched by
        // their wording, which the tests in `tests/bad_input.rs` hold.
        UseError::Request(message) if message.contains("initial temperatures given") => {
            "give --initial-temps one temperature per state, in the order listed".into()
        }
        UseError::Request(message) if message.contains("which is no part of the model") => {
            "--limit takes one of the parts listed: STATE=°C".into()
        }
        UseError::Request(message) if message.starts_with("no part has a limit") => {
            "give --class B, F or H, or --limit STATE=°C per part".into()
        }
        UseError::Request(message) if message.starts_with("the power factor") => {
            "give --power-factor a value such as 0.9 (or -0.95 leading)".into()
        }
        _ => return None,
    })
}

/// Where a map's keys are shown and a first map is had.
const MAP_HINT: &str = "`heatrun import --guess FILE` prints a map to start from; \
                        docs/src/reference/import-map.md shows its keys";

/// "did you mean `key`?" for serde's "unknown field `given`, expected one of `a`, `b`, …"
/// (or "expected `a` or `b`") where one of the keys it lists is near the one given.
fn unknown_key(message: &str) -> Option<String> {
    let rest = &message[message.find("unknown field `")? + "unknown field `".len()..];
    let (given, expected) = rest.split_once('`')?;
    let expected = expected.split_once("expected")?.1;
    let known: Vec<&str> = expected.split('`').skip(1).step_by(2).collect();
    // A key that holds every word of the one given (`rated_power_mva` in
    // `rated_apparent_power_mva`) is meant before one a few letters away
    // (`rated_power_factor`); where no one key holds them, the nearest spelling.
    let words = |key: &str| {
        key.to_lowercase()
            .split('_')
            .map(str::to_owned)
            .collect::<Vec<_>>()
    };
    let given_words = words(given);
    let mut holding = known
        .iter()
        .filter(|k| **k != given && given_words.iter().all(|w| words(k).contains(w)));
    let name = match (holding.next(), holding.next()) {
        (Some(only), None) => (*only).to_owned(),
        _ => closest(given, &known.join(","))?,
    };
    Some(format!("did you mean `{name}`?"))
}

/// The known name (from a comma-separated list) nearest `given`, if one is near: at most
/// a third of its letters differ (Levenshtein distance), ignoring case; `given` itself is
/// not a suggestion, but a name that differs from it only in case is (names are matched
/// case-sensitively).
fn closest(given: &str, known: &str) -> Option<String> {
    let lower = given.to_lowercase();
    known
        .split(',')
        .map(str::trim)
        .filter(|k| !k.is_empty() && *k != given)
        .map(|k| (strsim::levenshtein(&lower, &k.to_lowercase()), k))
        .filter(|(d, k)| *d * 3 <= k.len().max(lower.len()))
        .min_by_key(|(d, _)| *d)
        .map(|(_, k)| k.to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_unknown_key_near_a_known_one_is_named() {
        let machine = "line 2, column 1: unknown field `rated_votage_kv`, expected one of \
                       `rated_apparent_power_mva`, `rated_voltage_kv`, `name`";
        assert_eq!(
            unknown_key(machine).as_deref(),
            Some("did you mean `rated_voltage_kv`?")
        );
        // The key that holds every word given, not the one a few letters away.
        let words = "unknown field `rated_power_mva`, expected one of `rated_apparent_power_mva`, \
                     `rated_power_factor`";
        assert_eq!(
            unknown_key(words).as_deref(),
            Some("did you mean `rated_apparent_power_mva`?")
        );
        let two = "line 1, column 1: unknown field `nme`, expected `name` or `unit`";
        assert_eq!(unknown_key(two).as_deref(), Some("did you mean `name`?"));
        let far = "unknown field `colour`, expected one of `name`, `unit`";
        assert_eq!(unknown_key(far), None);
        assert_eq!(unknown_key("line 1, column 6: invalid array"), None);
    }

    #[test]
    fn a_cause_already_in_the_message_is_not_repeated() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "No such file");
        let err = anyhow::Error::from(Error::from(RecordingError::ReadInput {
            path: "a.mcap".into(),
            source: io,
        }));
        assert_eq!(one_line(&err), "a.mcap: cannot read: No such file");
        let wrapped = anyhow::Error::from(std::io::Error::other("disk full")).context("b.rrd");
        assert_eq!(one_line(&wrapped), "b.rrd: disk full");
    }

    #[test]
    fn a_misspelt_column_gets_the_nearest_known_name() {
        let known = "time_s, armature_current_a, apparent_power_mva, power_factor";
        assert_eq!(
            closest("pwer_factor", known).as_deref(),
            Some("power_factor")
        );
        assert_eq!(
            closest("Apparent_Power_MVA ", known.trim()).as_deref(),
            Some("apparent_power_mva")
        );
        assert_eq!(closest("pf", known), None, "too far from any");
        assert_eq!(
            closest("Power_Factor", known).as_deref(),
            Some("power_factor"),
            "a name that differs only in case"
        );
    }

    #[test]
    fn a_viewer_that_cannot_be_reached_gets_where_to_start_one() {
        let unreachable: anyhow::Error = heatrun_rerun::PublishError::Rerun(
            "gRPC has been unable to connect for 5s, uri: rerun+http://127.0.0.1:1/proxy".into(),
        )
        .into();
        let hint = for_error(&unreachable).unwrap();
        assert!(hint.contains("--spawn") && hint.contains("--rrd"), "{hint}");
        let other: anyhow::Error =
            heatrun_rerun::PublishError::Rerun("Invalid or missing scheme".into()).into();
        assert_eq!(
            for_error(&other),
            None,
            "the scheme's error says what to write"
        );
    }
}
