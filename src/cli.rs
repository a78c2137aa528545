//! Command-line definitions.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};

/// Thermal system identification of hydro generators from MCAP heat-run recordings.
#[derive(Debug, Parser)]
#[command(name = "heatrun", version, about, long_about = None)]
pub struct Cli {
    /// The command to run (`heatrun <COMMAND> --help` for its options).
    #[command(subcommand)]
    pub command: Command,
}

/// heatrun's commands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Replay a heat-run recording into a thermal model, a report and a rerun recording.
    #[command(
        after_help = "Examples:\n  heatrun replay                                   # the shipped fixture\n  heatrun replay run.mcap --report run.json --rrd run.rrd\n  heatrun replay run.mcap --split-at 14400 --summary json | jq .validation\n  heatrun replay archive/ --out-dir results --jobs 4   # a fleet"
    )]
    Replay(ReplayArgs),
    /// Write a synthetic heat run simulated from a known model (the paper's by default).
    #[command(
        after_help = "Examples:\n  heatrun synth run.mcap --temperature-noise 0.05 --seed 7\n  heatrun synth drift.mcap --machine rc-unit --inlet-drift 3"
    )]
    Synth(SynthArgs),
    /// Show what a recording holds: channels, quantities, units, rates, span, gaps, nameplate.
    #[command(after_help = "Example:\n  heatrun info run.mcap --json")]
    Info(InfoArgs),
    /// Convert a table (CSV, historian export, whitespace-separated .dat) into a recording.
    #[command(
        after_help = "Examples:\n  heatrun import --guess export.csv > map.toml   # a starting map to edit\n  heatrun import export.csv --map map.toml --out run.mcap"
    )]
    Import(ImportArgs),
    /// Print a shell completion script (bash, zsh, fish, elvish, powershell).
    #[command(
        after_help = "Example:\n  heatrun completions bash > ~/.local/share/bash-completion/completions/heatrun"
    )]
    Completions(CompletionsArgs),
    /// Print heatrun's man page (roff).
    #[command(after_help = "Example:\n  heatrun man --out heatrun.1 && man ./heatrun.1")]
    Man(ManArgs),
    /// Predict every part's temperature under a load schedule, from a model report.
    Predict(PredictArgs),
    /// The machine's thermal rating: largest continuous power, limiting part, overloads.
    Rating(RatingArgs),
    /// Run a model beside a later recording of the machine; alarm where a part leaves the
    /// model's band.
    #[command(
        after_help = "Exit status: 0 healthy (no alarm), 4 alarms raised, 2 bad input (a report of \
another profile or without the needed blocks, a recording lacking a state's channel), 3 data \
lost from the recording (no alarm), 1 any other failure.\n\nExamples:\n  heatrun monitor --model model.json service.mcap\n  heatrun monitor --model model.json service.mcap --json alarms.json --rrd service.rrd --hold 300\n  tail -c +1 -f growing.mcap | heatrun monitor --model model.json - --connect"
    )]
    Monitor(MonitorArgs),
}

/// Arguments of `heatrun monitor`.
#[derive(Debug, Args)]
pub struct MonitorArgs {
    /// The model: a report written by `heatrun replay --report`.
    #[arg(long, value_name = "REPORT.json")]
    pub model: PathBuf,
    /// The recording to monitor (MCAP, the heatrun SCADA profile), of the same machine;
    /// `-` reads it from standard input as it arrives (a recording still being written:
    /// `tail -c +1 -f growing.mcap | heatrun monitor --model m.json -`).
    #[arg(value_name = "RECORDING.mcap")]
    pub recording: PathBuf,
    /// Seconds of the grid monitored at once: each stretch is published (--connect,
    /// --rrd) as soon as the recording has been read past it.
    #[arg(long, value_name = "SECONDS", default_value_t = heatrun::monitor::stream::DEFAULT_STRETCH_S)]
    pub stretch: f64,
    /// Seconds a residual must stay outside its band before it is an alarm (returns inside
    /// shorter than a tenth of this do not end the excursion).
    #[arg(long, value_name = "SECONDS", default_value_t = heatrun::monitor::DEFAULT_HOLD_S)]
    pub hold: f64,
    /// The band per part is this multiple of the model's RMSE (validation, else fit).
    #[arg(long, value_name = "FACTOR", default_value_t = heatrun::monitor::BandRule::default().factor)]
    pub band_factor: f64,
    /// The narrowest band, K.
    #[arg(long, value_name = "K", default_value_t = heatrun::monitor::BandRule::default().floor_k)]
    pub band_floor: f64,
    /// Write the alarms and each part's residual statistics as JSON to this file.
    #[arg(long, value_name = "OUT.json")]
    pub json: Option<PathBuf>,
    /// Save measured against predicted temperature, residuals, bands and alarms to an .rrd.
    #[arg(long, value_name = "OUT.rrd", conflicts_with = "connect")]
    pub rrd: Option<PathBuf>,
    /// Stream them to a running rerun viewer (optionally at this gRPC URL).
    #[arg(long, value_name = "URL", num_args = 0..=1, default_missing_value = "")]
    pub connect: Option<String>,
    /// Write a self-contained HTML page (measured against model per part, residuals in
    /// their band, alarms shaded, the alarm and residual tables) to this file.
    #[arg(long, value_name = "PAGE.html")]
    pub html: Option<PathBuf>,
    /// Print only the alarm lines.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Where a prediction starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum InitialArg {
    /// The temperatures at the start of the model's recording.
    Measured,
    /// The steady state of the schedule's first row.
    Steady,
}

/// Arguments of `heatrun predict`.
#[derive(Debug, Args)]
// The limits are drawn: they need an output that draws them (.rrd or HTML).
#[command(group(clap::ArgGroup::new("drawn").args(["rrd", "html"]).multiple(true)))]
pub struct PredictArgs {
    /// The model: a report written by `heatrun replay --report`.
    #[arg(long, value_name = "REPORT.json")]
    pub model: PathBuf,
    /// The load schedule (CSV): time_s and either armature_current_a, field_current_a,
    /// line_voltage_kv, or apparent_power_mva with power_factor; optional coolant_inlet_temp_c.
    #[arg(long, value_name = "LOAD.csv")]
    pub load: PathBuf,
    /// The predicted temperatures (CSV: time_s and <state>_c per state).
    #[arg(long, value_name = "PRED.csv")]
    pub out: PathBuf,
    /// Where the prediction starts.
    #[arg(long, value_enum, default_value_t = InitialArg::Measured, conflicts_with = "initial_temps")]
    pub initial: InitialArg,
    /// Start from these temperatures, °C, one per state in the model's order.
    #[arg(long, value_delimiter = ',', value_name = "T1,T2,...")]
    pub initial_temps: Option<Vec<f64>>,
    /// Also save the schedule, the losses and the predicted temperatures (with the
    /// limits of --class and --limit) to this rerun .rrd file.
    #[arg(long, value_name = "OUT.rrd")]
    pub rrd: Option<PathBuf>,
    /// Insulation class whose limits (IEC 60034-1, Table 7) the .rrd and the HTML page
    /// draw (as `rating --class`).
    #[arg(long, value_enum, requires = "drawn")]
    pub class: Option<ClassArg>,
    /// A part's limit the .rrd and the HTML page draw, °C (repeatable; overrides the
    /// class's): STATE=°C.
    #[arg(long, value_name = "STATE=°C", value_parser = parse_limit, requires = "drawn")]
    pub limit: Vec<(String, f64)>,
    /// Do not print the summary.
    #[arg(long, short)]
    pub quiet: bool,
    /// Also write the prediction as one self-contained HTML page (schedule, losses,
    /// temperatures against the limits, peaks).
    #[arg(long, value_name = "PAGE.html")]
    pub html: Option<PathBuf>,
}

/// Insulation thermal class.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ClassArg {
    /// Class 130 (B).
    #[value(name = "B")]
    B,
    /// Class 155 (F).
    #[value(name = "F")]
    F,
    /// Class 180 (H).
    #[value(name = "H")]
    H,
}

/// Arguments of `heatrun rating`.
#[derive(Debug, Args)]
pub struct RatingArgs {
    /// The model: a report written by `heatrun replay --report`.
    #[arg(long, value_name = "REPORT.json")]
    pub model: PathBuf,
    /// Insulation class: the built-in limits (IEC 60034-1, Table 7) for the stator
    /// winding, the field winding and the core.
    #[arg(long, value_enum)]
    pub class: Option<ClassArg>,
    /// A part's limit, °C (repeatable; overrides the class's): STATE=°C.
    #[arg(long, value_name = "STATE=°C", value_parser = parse_limit)]
    pub limit: Vec<(String, f64)>,
    /// Power factor of the rating (negative: leading) [default: the nameplate's rated one].
    #[arg(long, allow_hyphen_values = true)]
    pub power_factor: Option<f64>,
    /// Line voltage, kV [default: rated].
    #[arg(long, value_name = "KV")]
    pub voltage: Option<f64>,
    /// Coolant (cooling-water inlet) temperature of the rating, °C [default: the model's test].
    #[arg(long, value_name = "°C", allow_hyphen_values = true)]
    pub coolant: Option<f64>,
    /// Overloads for the short-time ratings, % of rated current.
    #[arg(long, value_delimiter = ',', default_value = "110,120,130,140,150")]
    pub overloads: Vec<f64>,
    /// Write the rating as JSON to this file.
    #[arg(long, value_name = "OUT.json")]
    pub json: Option<PathBuf>,
    /// Also write the rating as one self-contained HTML page (limits, continuous rating,
    /// margins, overloads).
    #[arg(long, value_name = "PAGE.html")]
    pub html: Option<PathBuf>,
}

/// `STATE=°C`.
fn parse_limit(text: &str) -> Result<(String, f64), String> {
    let (name, value) = text
        .split_once('=')
        .ok_or_else(|| format!("`{text}` is not STATE=°C"))?;
    let value: f64 = value
        .trim()
        .parse()
        .map_err(|_| format!("`{value}` is not a temperature in °C"))?;
    Ok((name.trim().to_owned(), value))
}

/// Identification method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum MethodArg {
    /// Ordinary least squares (eq. 7); biased when the temperatures are noisy.
    Ls,
    /// Weighted least squares (eqs. 3-7) with --weights.
    Wls,
    /// Recursive least squares with --forgetting; its trajectory goes to rerun.
    Rls,
    /// Iterated instrumental variables (instruments from the simulated model).
    Iv,
    /// Output error: minimises the simulation error by Levenberg-Marquardt from IV.
    Oe,
    /// Grey-box output error in the thermal network's C, G and K (passive by
    /// construction, 95 % intervals on each), started from oe's network; heat inputs only.
    Rc,
}

/// What the temperature rises are measured from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Default)]
pub enum ReferenceArg {
    /// The coolant inlet where cooling_water_inlet_temp varies or the machine starts warm
    /// (its outlet above the inlet); elsewhere each temperature's initial value.
    #[default]
    Auto,
    /// Each temperature's initial value, the losses the only inputs (the paper).
    Initial,
    /// The coolant inlet's initial level, its drift an input where it varies.
    Inlet,
}

/// Arguments of `heatrun replay`.
#[derive(Debug, Args)]
pub struct ReplayArgs {
    /// Recordings (MCAP, heatrun SCADA profile), or folders of them. Default: the shipped
    /// fixture. More than one recording (or a folder) replays a fleet in parallel.
    pub files: Vec<PathBuf>,
    /// Sample time Ts of the model in seconds [default: the spec's, else 1].
    #[arg(long)]
    pub ts: Option<f64>,
    /// Model spec (TOML): the states, inputs and sample time of any thermal system
    /// [default: the hydro generator of the profile and its loss model].
    #[arg(long, value_name = "SPEC.toml")]
    pub spec: Option<PathBuf>,
    /// Identify the field winding as a fourth state (its rise, from field_winding_temp or
    /// by the resistance method U_f/I_f from field_voltage).
    #[arg(long, conflicts_with = "spec")]
    pub field_state: bool,
    /// What the rises are measured from: the coolant inlet (auto: where it varies or the
    /// machine starts warm) or each temperature's initial value (the paper).
    #[arg(long, value_enum, default_value_t)]
    pub reference: ReferenceArg,
    /// Machine file (TOML) whose keys override the recording's nameplate.
    #[arg(long, value_name = "FILE.toml")]
    pub machine: Option<PathBuf>,
    /// Identification method (oe: unbiased under sensor noise, the most accurate)
    /// [default: the spec's, else oe].
    #[arg(long, value_enum)]
    pub method: Option<MethodArg>,
    /// Per-state weights w_i of wls and oe, comma-separated (oe default: 1/noise variance).
    #[arg(long, value_delimiter = ',', value_name = "W1,W2,W3")]
    pub weights: Option<Vec<f64>>,
    /// Forgetting factor of rls, in (0, 1].
    #[arg(long, default_value_t = 1.0)]
    pub forgetting: f64,
    /// Hold out the last FRACTION of the recording and report the model's fit on it.
    #[arg(long, value_name = "FRACTION", conflicts_with_all = ["validate", "split_at"])]
    pub holdout: Option<f64>,
    /// Estimate on the recording before SECONDS (from its start) and report the fit on the
    /// rest, simulated from the measured state there.
    #[arg(long, value_name = "SECONDS", conflicts_with = "validate")]
    pub split_at: Option<f64>,
    /// Report the model's fit on another recording of the same machine.
    #[arg(long, value_name = "FILE")]
    pub validate: Option<PathBuf>,
    /// Save the rerun recording to this .rrd file (the default: <recording>.rrd here).
    #[arg(long, value_name = "PATH")]
    pub rrd: Option<PathBuf>,
    /// Stream to a running rerun viewer (optionally at this gRPC URL).
    #[arg(long, value_name = "URL", num_args = 0..=1, default_missing_value = "")]
    pub connect: Option<String>,
    /// Start a rerun viewer and stream to it.
    #[arg(long)]
    pub spawn: bool,
    /// Write the JSON report (profile section "Report") to this file.
    #[arg(long, value_name = "PATH")]
    pub report: Option<PathBuf>,
    /// Write the HTML report, one self-contained page that prints to PDF (without PATH:
    /// <recording>.html here; in fleet mode, <stem>.report.html beside each report in
    /// --out-dir).
    #[arg(
        long,
        value_name = "PATH",
        num_args = 0..=1,
        default_missing_value = "",
        value_parser = clap::value_parser!(std::ffi::OsString)
    )]
    pub html: Option<std::ffi::OsString>,
    /// Also publish every channel at its full rate (columns streamed as the file is read).
    #[arg(long)]
    pub raw: bool,
    /// Fleet mode: the folder for each recording's .rrd and report and the fleet summary.
    #[arg(long, value_name = "DIR", default_value = ".")]
    pub out_dir: PathBuf,
    /// Fleet mode: recordings replayed at once (default: the number of cores).
    #[arg(long)]
    pub jobs: Option<usize>,
    /// Do not print the summary.
    #[arg(long, short)]
    pub quiet: bool,
    /// How the summary is printed: `text` for people, `json` (the report's JSON on stdout,
    /// nothing else) for scripts.
    #[arg(long, value_enum, default_value_t = SummaryFormat::Text, conflicts_with = "quiet")]
    pub summary: SummaryFormat,
}

/// How `replay` prints its summary.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SummaryFormat {
    /// The paper-style tables.
    Text,
    /// The report (profile section "Report") as JSON.
    Json,
}

/// Arguments of `heatrun completions`.
#[derive(Debug, Args)]
pub struct CompletionsArgs {
    /// The shell to complete for.
    pub shell: clap_complete::Shell,
}

/// Arguments of `heatrun man`.
#[derive(Debug, Args)]
pub struct ManArgs {
    /// Write the page here instead of stdout.
    #[arg(long, value_name = "PATH")]
    pub out: Option<PathBuf>,
}

/// How the synthetic recording carries the field winding temperature.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FieldArg {
    /// A field_voltage channel (resistance method).
    Voltage,
    /// A field_winding_temp channel.
    Temperature,
    /// No channel: the nameplate's final field temperature (the paper's method).
    Nameplate,
}

/// Arguments of `heatrun synth`.
#[derive(Debug, Args)]
pub struct SynthArgs {
    /// The MCAP file to write; the true model goes to OUT.truth.json.
    pub out: PathBuf,
    /// Duration in seconds (the paper's heat run: 20868 s).
    #[arg(long, default_value_t = 20868.0)]
    pub duration: f64,
    /// Sample rate of the electrical channels, Hz.
    #[arg(long, default_value_t = 1.0)]
    pub electrical_rate: f64,
    /// Sample rate of the temperature channels, Hz.
    #[arg(long, default_value_t = 1.0)]
    pub temperature_rate: f64,
    /// Gaussian temperature noise σ, K (PT100-like: 0.05).
    #[arg(long, default_value_t = 0.0)]
    pub temperature_noise: f64,
    /// Gaussian electrical noise σ, relative (0.002 = 0.2 %).
    #[arg(long, default_value_t = 0.0)]
    pub electrical_noise: f64,
    /// Temperature resolution, K (0: none; PT100 transducers: 0.01).
    #[arg(long, default_value_t = 0.0)]
    pub resolution: f64,
    /// Random seed of the noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// How the field winding temperature is recorded.
    #[arg(long, value_enum, default_value_t = FieldArg::Voltage)]
    pub field: FieldArg,
    /// Operating profile.
    #[arg(long, value_enum, default_value_t = ProfileArg::LoadSteps)]
    pub profile: ProfileArg,
    /// Write uncompressed chunks instead of zstd.
    #[arg(long)]
    pub uncompressed: bool,
    /// The machine simulated: the paper's model, or a thermal RC network (required for
    /// the disturbances below).
    #[arg(long, value_enum, default_value_t = MachineArg::Paper)]
    pub machine: MachineArg,
    /// Network machines: the coolant inlet warms by K kelvin as river water over a day (a
    /// ramp of 0.6·K over the run and a daily swing of 0.4·K).
    #[arg(long, value_name = "K")]
    pub inlet_drift: Option<f64>,
    /// Network machines: every part starts K kelvin above the coolant (a warm start).
    #[arg(long, value_name = "K")]
    pub start_above: Option<f64>,
    /// Network machines: the flow is multiplied by FACTOR from T seconds (a pump switch;
    /// the coolant conductance c·ρ·Q follows it).
    #[arg(long, value_name = "T:FACTOR", value_parser = parse_pump_switch)]
    pub pump_switch: Option<(f64, f64)>,
    /// Network machines: a fouled cooler from T seconds (with --fault-conductance-drop).
    #[arg(long, value_name = "T", requires = "fault_conductance_drop")]
    pub fault_at: Option<f64>,
    /// With --fault-at: the fraction, in [0, 1), the conductances to the coolant fall by.
    #[arg(long, value_name = "F", requires = "fault_at")]
    pub fault_conductance_drop: Option<f64>,
    /// Leave out the cooling_water_inlet_temp and cooling_water_flow channels.
    #[arg(long)]
    pub no_coolant_channels: bool,
    /// Store the temperatures by exception, as a SCADA historian does: a sample only
    /// when it moved by more than this many kelvin since the last stored one (or the
    /// heartbeat passed).
    #[arg(long, value_name = "K")]
    pub deadband: Option<f64>,
    /// With --deadband: the heartbeat, the longest time between stored samples, s.
    #[arg(long, value_name = "S", default_value_t = 600.0, requires = "deadband")]
    pub heartbeat: f64,
}

/// The machine of a synthetic run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum MachineArg {
    /// The paper's Φ and Γ (eqs. 19-20) from its initial temperatures.
    Paper,
    /// A 3-node thermal RC network (stator winding, core, cooling-water outlet).
    RcUnit,
    /// The RC unit with a fourth node, the field winding.
    RcField,
}

/// `T:FACTOR`, two numbers.
fn parse_pump_switch(s: &str) -> Result<(f64, f64), String> {
    let (t, f) = s
        .split_once(':')
        .ok_or_else(|| format!("`{s}` is not T:FACTOR (e.g. 7200:0.7)"))?;
    let num = |v: &str| {
        v.trim()
            .parse::<f64>()
            .map_err(|_| format!("`{v}` in `{s}` is not a number"))
    };
    Ok((num(t)?, num(f)?))
}

/// Operating profile of a synthetic run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ProfileArg {
    /// A heat run with load and excitation steps (all three heat sources excited).
    LoadSteps,
    /// One step to the final operating point (the inputs are nearly collinear).
    SingleStep,
}

/// Arguments of `heatrun info`.
#[derive(Debug, Args)]
pub struct InfoArgs {
    /// The recording.
    pub file: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `heatrun import`.
#[derive(Debug, Args)]
pub struct ImportArgs {
    /// The table: comma, semicolon, tab or whitespace separated, with or without a header.
    pub input: PathBuf,
    /// The map (TOML) that names the time column and the channels.
    #[arg(long, value_name = "MAP.toml", required_unless_present = "guess")]
    pub map: Option<PathBuf>,
    /// The recording to write (MCAP, heatrun SCADA profile).
    #[arg(long, value_name = "OUT.mcap", required_unless_present = "guess")]
    pub out: Option<PathBuf>,
    /// Print a starting map guessed from the table's header instead, to be edited.
    #[arg(long, conflicts_with_all = ["map", "out"])]
    pub guess: bool,
}

#[cfg(test)]
mod tests {
    use clap::error::ErrorKind;
    use clap::{CommandFactory, Parser};

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
        assert_eq!((m.json, m.rrd, m.connect), (None, None, None));
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
        assert_eq!((m.hold, m.connect.as_deref()), (300.0, Some("")));
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
        assert_eq!((r.rrd, r.report, r.connect), (None, None, None));
        assert!(!r.spawn && !r.raw && !r.quiet && !r.field_state);
        assert_eq!(r.out_dir, PathBuf::from("."));
        assert_eq!(r.jobs, None);
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
            ("ls", MethodArg::Ls),
            ("wls", MethodArg::Wls),
            ("rls", MethodArg::Rls),
            ("iv", MethodArg::Iv),
            ("oe", MethodArg::Oe),
            ("rc", MethodArg::Rc),
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
        assert_eq!(replay(&["--connect"]).connect.as_deref(), Some(""));
        assert_eq!(
            replay(&["--connect", "rerun+http://host:9876/proxy"])
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
}
