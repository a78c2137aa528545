//! The command line's parsing (clap's layer) and its validation into requests.

use clap::error::ErrorKind;
use clap::{CommandFactory, Parser};

use std::path::Path;

use heatrun::estimate::Method;

use super::predict::InitialArg;
use super::rating::ClassArg;
use super::replay::{NetworkArg, ReferenceArg};
use super::synth::{FieldArg, MachineArg, ProfileArg};
use super::*;

fn parse(args: &[&str]) -> Result<Cli, clap::Error> {
    Cli::try_parse_from(std::iter::once("heatrun").chain(args.iter().copied()))
}

fn replay(args: &[&str]) -> ReplayArgs {
    match parse(&[&["replay"][..], args].concat()).unwrap().command {
        Command::Replay(r) => r,
        other => panic!("not a replay: {other:?}"),
    }
}

#[test]
fn the_summary_is_text_unless_json_is_asked_for_and_quiet_excludes_json() {
    assert_eq!(replay(&[]).summary, SummaryFormat::Text);
    assert_eq!(replay(&["--summary", "json"]).summary, SummaryFormat::Json);
    assert_eq!(
        error(&["replay", "--summary", "json", "--quiet"]),
        ErrorKind::ArgumentConflict
    );
}

fn error(args: &[&str]) -> ErrorKind {
    parse(args).expect_err("must not parse").kind()
}

#[test]
fn the_predictions_limits_go_with_its_page() {
    let base = [
        "predict", "--model", "r.json", "--load", "l.csv", "--out", "p.csv",
    ];
    let Command::Predict(p) = parse(
        &[
            &base[..],
            &[
                "--html",
                "p.html",
                "--class",
                "H",
                "--limit",
                "core_temp=99",
            ],
        ]
        .concat(),
    )
    .unwrap()
    .command
    else {
        panic!("not predict");
    };
    assert_eq!(p.html.as_deref(), Some(std::path::Path::new("p.html")));
    assert_eq!(p.class, Some(ClassArg::H));
    assert_eq!(p.limit, [("core_temp".to_owned(), 99.0)]);
    // Limits only draw on the page: without it they are refused, not ignored.
    assert_eq!(
        error(&[&base[..], &["--class", "F"]].concat()),
        ErrorKind::MissingRequiredArgument
    );
    let Command::Rating(r) = parse(&[
        "rating", "--model", "r.json", "--class", "F", "--html", "r.html",
    ])
    .unwrap()
    .command
    else {
        panic!("not rating");
    };
    assert_eq!(r.html.as_deref(), Some(std::path::Path::new("r.html")));
}

#[test]
fn the_definitions_are_consistent() {
    Cli::command().debug_assert();
}

#[test]
fn monitor_parses_its_options_with_the_documented_defaults() {
    let Command::Monitor(m) = parse(&["monitor", "--model", "r.json", "s.mcap"])
        .unwrap()
        .command
    else {
        panic!("not monitor");
    };
    assert_eq!((m.hold, m.band_factor, m.band_floor), (600.0, 4.0, 0.5));
    assert_eq!(m.band, super::monitor::BandChoice::Model);
    assert_eq!((m.json, m.viewer.rrd, m.viewer.connect), (None, None, None));
    let Command::Monitor(fixed) =
        parse(&["monitor", "--model", "r.json", "s.mcap", "--band", "fixed"])
            .unwrap()
            .command
    else {
        panic!("not monitor");
    };
    assert_eq!(fixed.band, super::monitor::BandChoice::Fixed);
    let Command::Monitor(m) = parse(&[
        "monitor",
        "--model",
        "r.json",
        "s.mcap",
        "--hold",
        "300",
        "--connect",
    ])
    .unwrap()
    .command
    else {
        panic!("not monitor");
    };
    assert_eq!((m.hold, m.viewer.connect.as_deref()), (300.0, Some("")));
    assert_eq!(
        error(&["monitor", "--model", "r.json"]),
        ErrorKind::MissingRequiredArgument
    );
    assert_eq!(
        error(&[
            "monitor",
            "--model",
            "r.json",
            "s.mcap",
            "--rrd",
            "o.rrd",
            "--connect"
        ]),
        ErrorKind::ArgumentConflict
    );
    assert_eq!(
        error(&[
            "predict", "--model", "r.json", "--load", "l.csv", "--out", "p.csv", "--class", "F"
        ]),
        ErrorKind::MissingRequiredArgument
    );
}

#[test]
fn predict_and_rating_parse_their_options() {
    let Command::Predict(p) = parse(&[
        "predict", "--model", "r.json", "--load", "l.csv", "--out", "p.csv",
    ])
    .unwrap()
    .command
    else {
        panic!("not predict");
    };
    assert_eq!((p.initial, p.initial_temps), (InitialArg::Measured, None));
    let Command::Predict(p) = parse(&[
        "predict",
        "--model",
        "r.json",
        "--load",
        "l.csv",
        "--out",
        "p.csv",
        "--initial-temps",
        "40,35.5,12",
    ])
    .unwrap()
    .command
    else {
        panic!("not predict");
    };
    assert_eq!(p.initial_temps, Some(vec![40.0, 35.5, 12.0]));
    assert_eq!(
        error(&["predict", "--model", "r.json", "--load", "l.csv"]),
        ErrorKind::MissingRequiredArgument
    );
    let Command::Rating(r) = parse(&[
        "rating",
        "--model",
        "r.json",
        "--class",
        "F",
        "--limit",
        "core_temp=120",
        "--limit",
        "stator_winding_temp = 130.5",
        "--power-factor",
        "-0.95",
    ])
    .unwrap()
    .command
    else {
        panic!("not rating");
    };
    assert_eq!(r.class, Some(ClassArg::F));
    assert_eq!(
        r.limit,
        [
            ("core_temp".to_owned(), 120.0),
            ("stator_winding_temp".to_owned(), 130.5)
        ]
    );
    assert_eq!(r.power_factor, Some(-0.95));
    assert_eq!(r.overloads, [110.0, 120.0, 130.0, 140.0, 150.0]);
    assert_eq!(
        error(&["rating", "--model", "r.json", "--limit", "core_temp"]),
        ErrorKind::ValueValidation
    );
    assert_eq!(
        error(&["rating", "--model", "r.json", "--class", "Q"]),
        ErrorKind::InvalidValue
    );
}

#[test]
fn replay_defaults_are_the_documented_ones() {
    let r = replay(&[]);
    assert!(r.files.is_empty(), "the fixture is chosen later");
    // Sample time and method: the spec's, else 1 s and oe (resolved by the command).
    assert_eq!((r.ts, r.method, r.spec), (None, None, None));
    assert_eq!(r.weights, None);
    assert_eq!(r.forgetting, 1.0);
    assert_eq!((r.holdout, r.split_at, r.validate), (None, None, None));
    assert_eq!(
        (r.viewer.rrd, r.report, r.viewer.connect),
        (None, None, None)
    );
    assert!(!r.viewer.spawn && !r.raw && !r.quiet && !r.field_state);
    assert_eq!(r.out_dir, PathBuf::from("."));
    assert_eq!(r.jobs, None);
}

#[test]
fn the_network_is_the_best_unless_the_nearest_is_asked_for() {
    assert_eq!(replay(&[]).network, NetworkArg::Best);
    assert_eq!(
        replay(&["--network", "nearest"]).network,
        NetworkArg::Nearest
    );
    assert_eq!(
        error(&["replay", "--network", "closest"]),
        ErrorKind::InvalidValue
    );
}

#[test]
fn the_field_state_is_a_flag_that_a_spec_excludes() {
    assert!(replay(&["--field-state"]).field_state);
    assert_eq!(
        error(&["replay", "--field-state", "--spec", "s.toml"]),
        ErrorKind::ArgumentConflict
    );
}

#[test]
fn every_method_parses_and_others_are_refused() {
    for (name, method) in [
        ("ls", Method::Ls),
        ("wls", Method::Wls),
        ("rls", Method::Rls),
        ("iv", Method::Iv),
        ("oe", Method::Oe),
        ("rc", Method::Rc),
    ] {
        assert_eq!(replay(&["--method", name]).method, Some(method));
    }
    assert_eq!(
        error(&["replay", "--method", "kalman"]),
        ErrorKind::InvalidValue
    );
    assert_eq!(
        error(&["replay", "--method", "OE"]),
        ErrorKind::InvalidValue
    );
}

#[test]
fn the_reference_defaults_to_auto() {
    assert_eq!(replay(&[]).reference, ReferenceArg::Auto);
    assert_eq!(
        replay(&["--reference", "initial"]).reference,
        ReferenceArg::Initial
    );
    assert_eq!(
        replay(&["--reference", "inlet"]).reference,
        ReferenceArg::Inlet
    );
}

#[test]
fn holdout_and_validate_exclude_each_other() {
    assert_eq!(replay(&["--holdout", "0.25"]).holdout, Some(0.25));
    assert_eq!(
        replay(&["--validate", "b.mcap"]).validate,
        Some(PathBuf::from("b.mcap"))
    );
    assert_eq!(
        error(&["replay", "--holdout", "0.25", "--validate", "b.mcap"]),
        ErrorKind::ArgumentConflict
    );
}

#[test]
fn weights_are_a_comma_separated_list_of_numbers() {
    assert_eq!(
        replay(&["--weights", "1,2.5,1e-3"]).weights,
        Some(vec![1.0, 2.5, 0.001])
    );
    assert_eq!(replay(&["--weights", "4"]).weights, Some(vec![4.0]));
    assert_eq!(
        error(&["replay", "--weights", "1,x,3"]),
        ErrorKind::ValueValidation
    );
    assert_eq!(error(&["replay", "--weights"]), ErrorKind::InvalidValue);
}

#[test]
fn numbers_that_are_not_numbers_are_refused() {
    assert_eq!(replay(&["--ts", "0.5"]).ts, Some(0.5));
    for args in [
        &["replay", "--ts", "one"][..],
        &["replay", "--forgetting", "0,99"],
        &["replay", "--holdout", "25%"],
        &["replay", "--jobs=-1"],
        &["replay", "--jobs", "2.5"],
        &["synth", "out.mcap", "--seed=-3"],
        &["synth", "out.mcap", "--duration", "1h"],
    ] {
        assert_eq!(error(args), ErrorKind::ValueValidation, "{args:?}");
    }
}

#[test]
fn connect_takes_an_optional_url_and_files_may_be_many() {
    assert_eq!(replay(&["--connect"]).viewer.connect.as_deref(), Some(""));
    assert_eq!(
        replay(&["--connect", "rerun+http://host:9876/proxy"])
            .viewer
            .connect
            .as_deref(),
        Some("rerun+http://host:9876/proxy")
    );
    let r = replay(&[
        "a.mcap",
        "archive/",
        "--out-dir",
        "out",
        "--jobs",
        "3",
        "-q",
    ]);
    assert_eq!(
        r.files,
        [PathBuf::from("a.mcap"), PathBuf::from("archive/")]
    );
    assert_eq!(
        (r.out_dir, r.jobs, r.quiet),
        (PathBuf::from("out"), Some(3), true)
    );
}

#[test]
fn html_takes_an_optional_path() {
    assert_eq!(replay(&[]).html, None);
    assert_eq!(replay(&["--html"]).html.as_deref(), Some("".as_ref()));
    let r = replay(&["a.mcap", "--html", "out/page.html"]);
    assert_eq!(r.html.as_deref(), Some("out/page.html".as_ref()));
    assert_eq!(r.files, [PathBuf::from("a.mcap")]);
}

#[test]
fn synth_defaults_are_the_fixtures_and_info_needs_a_file() {
    let Command::Synth(s) = parse(&["synth", "out.mcap"]).unwrap().command else {
        panic!("not synth");
    };
    assert_eq!(s.duration, 20868.0);
    assert_eq!((s.electrical_rate, s.temperature_rate), (1.0, 1.0));
    assert_eq!(
        (s.temperature_noise, s.electrical_noise, s.resolution),
        (0.0, 0.0, 0.0)
    );
    assert_eq!(s.seed, 1);
    assert_eq!(
        (s.field, s.profile),
        (FieldArg::Voltage, ProfileArg::LoadSteps)
    );
    assert!(!s.uncompressed);
    assert_eq!(s.machine, MachineArg::Paper);
    assert_eq!(
        (s.inlet_drift, s.start_above, s.pump_switch),
        (None, None, None)
    );
    assert_eq!((s.fault_at, s.fault_conductance_drop), (None, None));
    assert!(!s.no_coolant_channels);
    assert_eq!(error(&["synth"]), ErrorKind::MissingRequiredArgument);
    assert_eq!(error(&["info"]), ErrorKind::MissingRequiredArgument);
    assert_eq!(
        error(&[]),
        ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
    );
    assert_eq!(
        error(&["replay", "--no-such-option"]),
        ErrorKind::UnknownArgument
    );
}

#[test]
fn synth_disturbances_parse_and_bad_ones_are_refused() {
    let synth = |args: &[&str]| match parse(&[&["synth", "o.mcap"][..], args].concat())
        .unwrap()
        .command
    {
        Command::Synth(s) => s,
        other => panic!("not synth: {other:?}"),
    };
    let s = synth(&[
        "--machine",
        "rc-field",
        "--inlet-drift",
        "3",
        "--start-above",
        "25",
        "--pump-switch",
        "7200:0.7",
        "--fault-at",
        "9000",
        "--fault-conductance-drop",
        "0.3",
    ]);
    assert_eq!(s.machine, MachineArg::RcField);
    assert_eq!((s.inlet_drift, s.start_above), (Some(3.0), Some(25.0)));
    assert_eq!(s.pump_switch, Some((7200.0, 0.7)));
    assert_eq!(
        (s.fault_at, s.fault_conductance_drop),
        (Some(9000.0), Some(0.3))
    );
    assert_eq!(synth(&["--machine", "rc-unit"]).machine, MachineArg::RcUnit);
    for args in [
        &["synth", "o.mcap", "--pump-switch", "7200"][..],
        &["synth", "o.mcap", "--pump-switch", "7200:x"],
        &["synth", "o.mcap", "--inlet-drift", "3K"],
    ] {
        assert_eq!(error(args), ErrorKind::ValueValidation, "{args:?}");
    }
    assert_eq!(
        error(&["synth", "o.mcap", "--machine", "rc"]),
        ErrorKind::InvalidValue
    );
    assert_eq!(
        error(&["synth", "o.mcap", "--fault-at", "100"]),
        ErrorKind::MissingRequiredArgument
    );
}

// The validated layer: what each command's request holds, and what it refuses.

/// The request a command line makes, or why it cannot run.
fn request(args: &[&str]) -> anyhow::Result<Request> {
    Request::try_from(parse(args).expect("clap parses it").command)
}

/// The usage error a command line raises (exit status 2), as printed.
fn usage(args: &[&str]) -> String {
    let err = request(args).expect_err("must be refused");
    assert!(
        crate::commands::is_bad_input(&err) && err.downcast_ref::<crate::cli::Usage>().is_some(),
        "{args:?}: not a usage error: {err:#}"
    );
    err.to_string()
}

#[test]
fn method_lists_every_method_with_its_help() {
    let command = Cli::command();
    let replay = command.find_subcommand("replay").unwrap();
    let method = replay
        .get_arguments()
        .find(|a| a.get_id() == "method")
        .unwrap();
    let listed: Vec<(String, String)> = method
        .get_possible_values()
        .iter()
        .map(|v| {
            (
                v.get_name().to_owned(),
                v.get_help().map(|h| h.to_string()).unwrap_or_default(),
            )
        })
        .collect();
    let expected: Vec<(String, String)> = Method::EVERY
        .iter()
        .map(|&m| (m.name().to_owned(), method::method_help(m).to_owned()))
        .collect();
    assert_eq!(listed, expected);
    assert!(expected.iter().all(|(_, help)| !help.is_empty()));
}

#[test]
fn the_viewer_flags_make_one_sink_and_each_command_takes_its_own() {
    use heatrun_rerun::RerunSink;
    let sink = |args: &[&str]| replay(args).viewer.sink();
    assert_eq!(sink(&[]), None);
    assert_eq!(
        sink(&["--rrd", "a.rrd"]),
        Some(RerunSink::Rrd("a.rrd".into()))
    );
    assert_eq!(sink(&["--connect"]), Some(RerunSink::Connect(None)));
    assert_eq!(
        sink(&["--connect", "rerun+http://h:9876/proxy"]),
        Some(RerunSink::Connect(Some("rerun+http://h:9876/proxy".into())))
    );
    // replay has always taken them together: the viewer wins over the file.
    assert_eq!(
        sink(&["--rrd", "a.rrd", "--connect", "--spawn"]),
        Some(RerunSink::Spawn)
    );
    assert_eq!(
        sink(&["--rrd", "a.rrd", "--connect"]),
        Some(RerunSink::Connect(None))
    );
    let monitor = ["monitor", "--model", "r.json", "s.mcap"];
    assert_eq!(
        error(&[&monitor[..], &["--spawn"]].concat()),
        ErrorKind::UnknownArgument
    );
    let predict = [
        "predict", "--model", "r.json", "--load", "l.csv", "--out", "p.csv",
    ];
    for flag in ["--connect", "--spawn"] {
        assert_eq!(
            error(&[&predict[..], &[flag]].concat()),
            ErrorKind::UnknownArgument,
            "{flag}"
        );
    }
    let Ok(Request::Predict(p)) = request(&[&predict[..], &["--rrd", "p.rrd"]].concat()) else {
        panic!("not predict");
    };
    assert_eq!(p.sink, Some(RerunSink::Rrd("p.rrd".into())));
}

#[test]
fn one_replay_gets_its_outputs_named_after_the_recording() {
    let Ok(Request::Replay(r)) = request(&["replay"]) else {
        panic!("not replay");
    };
    let Target::One(one) = &r.target else {
        panic!("the fixture alone is no fleet");
    };
    assert!(one.file.ends_with(replay::DEFAULT_FIXTURE));
    assert_eq!(
        one.sink,
        heatrun_rerun::RerunSink::Rrd("paper_heat_run.rrd".into())
    );
    assert_eq!((one.report.as_ref(), one.html.as_ref()), (None, None));
    // The defaults resolved: oe at 1 s on the generator.
    assert_eq!((r.options.method, r.options.ts_s), (Method::Oe, 1.0));
    assert_eq!(r.options.model.states.len(), 3);
    let Ok(Request::Replay(r)) = request(&[
        "replay",
        "run.mcap",
        "--html",
        "--method",
        "iv",
        "--ts",
        "2",
        "--field-state",
    ]) else {
        panic!("not replay");
    };
    let Target::One(one) = &r.target else {
        panic!("one recording");
    };
    assert_eq!(one.html.as_deref(), Some(Path::new("run.html")));
    assert_eq!((r.options.method, r.options.ts_s), (Method::Iv, 2.0));
    assert_eq!(r.options.model.states.len(), 4);
    assert!(usage(&["replay", "x.mcap", "--html", "run.mcap"]).contains("--html=PAGE.html"));
}

#[test]
fn a_fleet_refuses_the_flags_that_name_one_output() {
    for flag in [
        &["--rrd", "o.rrd"][..],
        &["--connect"],
        &["--spawn"],
        &["--report", "r.json"],
        &["--html=page.html"],
    ] {
        let message = usage(&[&["replay", "a.mcap", "b.mcap"][..], flag].concat());
        assert!(
            message.contains("outputs go to --out-dir"),
            "{flag:?}: {message}"
        );
    }
    let Ok(Request::Replay(r)) = request(&[
        "replay",
        "a.mcap",
        "b.mcap",
        "--html",
        "--jobs",
        "0",
        "--out-dir",
        "out",
    ]) else {
        panic!("not replay");
    };
    let Target::Fleet(fleet) = &r.target else {
        panic!("two recordings are a fleet");
    };
    assert_eq!(
        fleet.files,
        [PathBuf::from("a.mcap"), PathBuf::from("b.mcap")]
    );
    assert_eq!((fleet.jobs, fleet.html), (1, true), "at least one job");
    assert_eq!(fleet.out_dir, PathBuf::from("out"));
    let empty = tempfile::tempdir().unwrap();
    let folder = empty.path().to_str().unwrap();
    assert_eq!(
        usage(&["replay", folder]),
        "no .mcap recordings in the folders given"
    );
}

#[test]
fn monitor_refuses_a_band_hold_or_stretch_out_of_range() {
    let base = ["monitor", "--model", "r.json", "s.mcap"];
    for (flags, named) in [
        (&["--stretch", "0"][..], "--stretch 0"),
        (&["--stretch", "NaN"], "--stretch NaN"),
        (&["--stretch", "inf"], "--stretch inf"),
        (&["--hold=-1"], "--hold -1"),
        (&["--band-factor", "0"], "--band-factor 0"),
        (&["--band-floor=-0.5"], "--band-floor -0.5"),
    ] {
        let message = usage(&[&base[..], flags].concat());
        assert!(message.contains(named), "{flags:?}: {message}");
    }
    let Ok(Request::Monitor(m)) = request(&[
        "monitor",
        "--model",
        "r.json",
        "-",
        "--stretch",
        "60",
        "--hold",
        "300",
        "--html",
        "p.html",
        "--connect",
    ]) else {
        panic!("not monitor");
    };
    assert_eq!(
        (m.recording, m.name.as_str()),
        (Input::Stdin, "standard input")
    );
    assert_eq!((m.stream.stretch_s, m.stream.keep_traces), (60.0, true));
    assert_eq!(m.options.hold_s, 300.0);
    assert_eq!(m.sink, Some(heatrun_rerun::RerunSink::Connect(None)));
    let Ok(Request::Monitor(m)) = request(&base) else {
        panic!("not monitor");
    };
    assert_eq!(m.recording, Input::File("s.mcap".into()));
    assert_eq!(
        (m.name.as_str(), m.stream.keep_traces, m.sink),
        ("s.mcap", false, None)
    );
}

#[test]
fn synth_refuses_disturbances_the_machine_cannot_take() {
    for flags in [
        &["--inlet-drift", "3"][..],
        &["--start-above", "20"],
        &["--pump-switch", "7200:0.7"],
        &["--fault-at", "100", "--fault-conductance-drop", "0.3"],
    ] {
        let message = usage(&[&["synth", "o.mcap"][..], flags].concat());
        assert!(message.starts_with(flags[0]), "{message}");
        assert!(message.contains("--machine rc-unit"), "{message}");
    }
    assert!(usage(&[
        "synth",
        "o.mcap",
        "--machine",
        "rc-field",
        "--field",
        "nameplate"
    ])
    .starts_with("--machine rc-field records its field winding node"));
    let Ok(Request::Synth(s)) = request(&[
        "synth",
        "o.mcap",
        "--machine",
        "rc-unit",
        "--inlet-drift",
        "3",
        "--profile",
        "single-step",
    ]) else {
        panic!("not synth");
    };
    assert_eq!(s.options.disturbances.inlet_drift_k, 3.0);
    assert_eq!(s.options.profile.len(), 1);
    assert_eq!(s.options.profile[0].start_fraction, 0.0);
}

#[test]
fn synth_flaws_become_the_librarys_flaws_and_bad_freezes_are_refused() {
    let Ok(Request::Synth(s)) = request(&[
        "synth",
        "o.mcap",
        "--dropout-every",
        "97",
        "--input-timeouts",
        "20",
        "--glitches",
        "10",
        "--freeze",
        "9000:12600",
    ]) else {
        panic!("not synth");
    };
    let f = &s.options.flaws;
    assert_eq!(
        (f.dropout_every, f.input_timeouts, f.glitches),
        (Some(97), 20, 10)
    );
    assert_eq!(
        f.freeze,
        Some(heatrun::synth::Freeze {
            from_s: 9000.0,
            to_s: 12600.0
        })
    );
    let Ok(Request::Synth(clean)) = request(&["synth", "o.mcap"]) else {
        panic!("not synth");
    };
    assert!(!clean.options.flaws.any());
    for freeze in ["9000", "9000:x", "12600:9000", "-1:5"] {
        assert_eq!(
            error(&["synth", "o.mcap", &format!("--freeze={freeze}")]),
            ErrorKind::ValueValidation,
            "{freeze}"
        );
    }
}

#[test]
fn predict_rating_and_import_requests_are_in_the_librarys_terms() {
    use heatrun::predict::InitialState;
    use heatrun::rating::InsulationClass;
    let predict = [
        "predict", "--model", "r.json", "--load", "l.csv", "--out", "p.csv",
    ];
    let Ok(Request::Predict(p)) = request(&predict) else {
        panic!("not predict");
    };
    assert_eq!(
        (p.initial, p.limits.is_none(), p.sink),
        (InitialState::Measured, true, None)
    );
    let Ok(Request::Predict(p)) = request(
        &[
            &predict[..],
            &[
                "--initial-temps",
                "40,30",
                "--html",
                "p.html",
                "--limit",
                "core_temp=99",
            ],
        ]
        .concat(),
    ) else {
        panic!("not predict");
    };
    assert_eq!(p.initial, InitialState::Temperatures(vec![40.0, 30.0]));
    let limits = p.limits.expect("a limit given");
    assert_eq!(
        (limits.class, limits.limits_c),
        (None, vec![("core_temp".to_owned(), 99.0)])
    );
    let Ok(Request::Rating(r)) = request(&[
        "rating",
        "--model",
        "r.json",
        "--class",
        "H",
        "--voltage",
        "15.75",
        "--overloads",
        "110,150",
    ]) else {
        panic!("not rating");
    };
    assert_eq!(r.options.class, Some(InsulationClass::H));
    assert_eq!(r.options.voltage_v, Some(15750.0));
    assert_eq!(r.options.overloads, [1.1, 1.5]);
    let Ok(Request::Import(i)) = request(&["import", "t.csv", "--guess"]) else {
        panic!("not import");
    };
    assert_eq!(
        i,
        Import::Guess {
            input: "t.csv".into()
        }
    );
    let Ok(Request::Import(i)) =
        request(&["import", "t.csv", "--map", "m.toml", "--out", "o.mcap"])
    else {
        panic!("not import");
    };
    assert_eq!(
        i,
        Import::Convert {
            input: "t.csv".into(),
            map: "m.toml".into(),
            out: "o.mcap".into()
        }
    );
}

#[test]
fn index_picks_the_nth_recording_of_a_sorted_folder_or_listing_into_out_dir() {
    let folder = tempfile::tempdir().unwrap();
    for name in ["c.mcap", "a.mcap", "b.mcap", "notes.txt"] {
        std::fs::write(folder.path().join(name), b"").unwrap();
    }
    let dir = folder.path().to_str().unwrap();
    let Ok(Request::Replay(r)) = request(&["replay", "--index", "1", dir, "--out-dir", "out"])
    else {
        panic!("not replay");
    };
    let Target::One(one) = &r.target else {
        panic!("--index replays one recording");
    };
    assert_eq!(one.file, folder.path().join("b.mcap"));
    assert_eq!(one.report.as_deref(), Some(Path::new("out/b.report.json")));
    assert_eq!(
        one.sink,
        heatrun_rerun::RerunSink::Rrd(PathBuf::from("out/b.rrd"))
    );

    // A listing: lines sorted, blank lines and comments skipped.
    let listing = folder.path().join("runs.txt");
    std::fs::write(&listing, "z/run.mcap\n\n# old\na/run.mcap\n").unwrap();
    let listing = listing.to_str().unwrap();
    let Ok(Request::Replay(r)) = request(&["replay", "--index", "1", listing]) else {
        panic!("not replay");
    };
    let Target::One(one) = &r.target else {
        panic!("--index replays one recording");
    };
    assert_eq!(one.file, PathBuf::from("z/run.mcap"));

    assert_eq!(
        usage(&["replay", "--index", "3", dir]),
        format!("--index 3: {dir} lists 3 recordings (0 to 2)")
    );
    assert!(usage(&["replay", "--index", "0", dir, listing]).starts_with("--index takes one"));
    assert_eq!(
        error(&["replay", "--index", "0", "--index-from-env", dir]),
        ErrorKind::ArgumentConflict
    );
}

#[test]
fn fleet_compare_takes_reports_and_refuses_a_bad_threshold_or_floor() {
    let request = |args: &[&str]| {
        Request::try_from(
            parse(&[&["fleet", "compare"][..], args].concat())
                .unwrap()
                .command,
        )
    };
    match request(&["a.json", "b.json", "c.json", "d.json", "--json", "o.json"]).unwrap() {
        Request::FleetCompare(c) => {
            assert_eq!(c.reports.len(), 4);
            assert_eq!(
                c.options,
                heatrun::fleet::compare::CompareOptions::default()
            );
            assert_eq!(c.json.as_deref(), Some(Path::new("o.json")));
        }
        other => panic!("not a fleet compare: {other:?}"),
    }
    for bad in [
        &["a.json", "--threshold", "0"][..],
        &["a.json", "--floor", "100"],
    ] {
        let err = request(bad).unwrap_err();
        assert!(err.downcast_ref::<Usage>().is_some(), "{err}");
    }
    assert_eq!(
        error(&["fleet", "compare"]),
        ErrorKind::MissingRequiredArgument
    );
}

#[test]
fn synth_spread_needs_a_network_machine_and_a_percentage_in_range() {
    let synth = |args: &[&str]| match parse(&[&["synth", "u.mcap"][..], args].concat())
        .unwrap()
        .command
    {
        Command::Synth(s) => Synth::try_from(s),
        other => panic!("not a synth: {other:?}"),
    };
    assert!(synth(&["--machine", "rc-unit", "--spread", "3", "--unit-seed", "4"]).is_ok());
    for bad in [
        &["--spread", "3"][..],
        &["--machine", "rc-unit", "--spread", "60"],
    ] {
        let err = synth(bad).unwrap_err();
        assert!(err.downcast_ref::<Usage>().is_some(), "{err}");
    }
}

#[test]
fn a_limit_is_a_state_and_a_temperature_above_absolute_zero() {
    use super::rating::parse_limit;
    assert_eq!(
        parse_limit("core_temp = 130").unwrap(),
        ("core_temp".to_owned(), 130.0)
    );
    assert_eq!(parse_limit("core_temp=-20").unwrap().1, -20.0);
    for bad in [
        "core_temp",
        "core_temp=hot",
        "core_temp=-300",
        "core_temp=inf",
    ] {
        assert!(parse_limit(bad).is_err(), "{bad}");
    }
}

#[test]
fn replay_without_a_recording_and_without_the_example_says_to_name_one() {
    let dir = tempfile::tempdir().unwrap();
    let missing = [dir.path().join("a.mcap"), dir.path().join("b.mcap")];
    let err = super::replay::example_from(&missing).unwrap_err();
    assert!(err.downcast_ref::<Usage>().is_some(), "exit 2: {err}");
    let message = err.to_string();
    assert!(message.starts_with("no recording given"), "{message}");
    assert!(message.contains("heatrun replay RUN.mcap"), "{message}");
    std::fs::write(&missing[1], b"").unwrap();
    assert_eq!(
        super::replay::example_from(&missing).unwrap(),
        missing[1].clone()
    );
}
