//! `heatrun replay`: its flags, and the [`Replay`] they are validated into: the recordings
//! found (one, or a fleet), each output's path, and the library's options resolved once.

use std::path::{Path, PathBuf};

use clap::{Args, ValueEnum};
use heatrun::estimate::Method;
use heatrun::pipeline::{NetworkChoice, ReplayOptions, ValidationSource};
use heatrun::progress::Observer;
use heatrun::recording::RecordingError;
use heatrun::spec::coolant::ReferencePolicy;
use heatrun::spec::ModelDescription;
use heatrun::store::{self, Location};
use heatrun_rerun::RerunSink;

use super::outputs::{distinct, NamedFile};
use super::viewer::{Offer, ViewerArgs};
use super::Usage;

/// The fixture replayed when no file is named.
pub const DEFAULT_FIXTURE: &str = "fixtures/paper_heat_run.mcap";

/// What the rises are measured from.
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

/// Which network the replay prints beside the model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Default)]
pub enum NetworkArg {
    /// The nearest passive network where the data cannot tell it from the model, else
    /// rc's fit of C, G and K to the data (seconds longer on a noisy run).
    #[default]
    Best,
    /// The passive network nearest the identified model, without rc's fit: the fast replay.
    Nearest,
}

/// How `replay` prints its summary.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SummaryFormat {
    /// The paper-style tables.
    Text,
    /// The report (profile section "Report") as JSON.
    Json,
}

/// `replay`'s rerun outputs: an .rrd (by default), a running viewer or a spawned one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReplayViewer;

impl Offer for ReplayViewer {
    const RRD: (&'static str, &'static str) = (
        "PATH",
        "Save the rerun recording to this .rrd file (the default: <recording>.rrd here)",
    );
    const CONNECT: Option<&'static str> =
        Some("Stream to a running rerun viewer (optionally at this gRPC URL)");
    const SPAWN: Option<&'static str> = Some("Start a rerun viewer and stream to it");
}

/// Arguments of `heatrun replay`.
#[derive(Debug, Args)]
pub struct ReplayArgs {
    /// Recordings (MCAP, heatrun SCADA profile), or folders of them; paths or URLs
    /// (s3://, gs://, az://, https://; a prefix ends in `/`). Default: the shipped
    /// fixture. More than one recording (or a folder or prefix) replays a fleet in parallel.
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
    /// The thermal network printed beside an oe model: the best for the data, or the
    /// nearest passive network to the model (faster; rc's fit not run).
    #[arg(long, value_enum, default_value_t)]
    pub network: NetworkArg,
    /// Identification method (oe: unbiased under sensor noise, the most accurate)
    /// [default: the spec's, else oe].
    #[arg(long, value_parser = super::method::parser())]
    pub method: Option<Method>,
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
    /// `--rrd`, `--connect`, `--spawn`.
    #[command(flatten)]
    pub viewer: ViewerArgs<ReplayViewer>,
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
    /// Replay only the N-th recording (from 0) of a sorted listing: one FILE that is a
    /// folder, a prefix (`s3://bucket/runs/`) or a text file of paths or URLs, one a line;
    /// its outputs go to --out-dir as in a fleet (a Slurm array or Kubernetes Indexed Job
    /// task).
    #[arg(long, value_name = "N")]
    pub index: Option<usize>,
    /// Take --index from the cluster's task number: SLURM_ARRAY_TASK_ID (Slurm job
    /// arrays), else JOB_COMPLETION_INDEX (Kubernetes Indexed Jobs).
    #[arg(long, conflicts_with = "index")]
    pub index_from_env: bool,
    /// Do not print the summary.
    #[arg(long, short)]
    pub quiet: bool,
    /// How the summary is printed: `text` for people, `json` (the report's JSON on stdout,
    /// nothing else) for scripts.
    #[arg(long, value_enum, default_value_t = SummaryFormat::Text, conflicts_with = "quiet")]
    pub summary: SummaryFormat,
}

/// `heatrun replay` as validated: what to replay, where each output goes, and how.
#[derive(Debug)]
pub struct Replay {
    /// The library's options, the same for every recording: the spec read, the sample time
    /// and method resolved (the command line's, then the spec's, then 1 s and oe). Silent:
    /// each replay gives its own progress.
    pub options: ReplayOptions,
    /// Also publish every channel at its full rate.
    pub raw: bool,
    /// Print no summary and draw no progress.
    pub quiet: bool,
    /// How the summary is printed.
    pub summary: SummaryFormat,
    /// One recording, or a fleet.
    pub target: Target,
}

/// What is replayed: the outputs differ (named by the flags, or one of each per recording
/// in a folder).
#[derive(Debug)]
pub enum Target {
    /// One recording.
    One(One),
    /// Several recordings, or a folder of them.
    Fleet(Fleet),
}

/// One recording and its outputs.
#[derive(Debug)]
pub struct One {
    /// The recording.
    pub file: PathBuf,
    /// Where the rerun data go: the viewer flags', else `<stem>.rrd` here.
    pub sink: RerunSink,
    /// The JSON report, if asked for.
    pub report: Option<PathBuf>,
    /// The HTML report, if asked for.
    pub html: Option<PathBuf>,
    /// The folder the outputs are named in (`--index`'s `--out-dir`), created where it
    /// does not exist, as a fleet's is.
    pub out_dir: Option<PathBuf>,
}

/// A fleet: every output in `out_dir`, named after its recording.
#[derive(Debug)]
pub struct Fleet {
    /// The recordings: files as given, folders expanded to their `.mcap` files (sorted).
    pub files: Vec<PathBuf>,
    /// The folder of the outputs and the fleet summary.
    pub out_dir: PathBuf,
    /// Recordings replayed at once (at least 1).
    pub jobs: usize,
    /// Whether each recording also gets an HTML page.
    pub html: bool,
}

impl TryFrom<ReplayArgs> for Replay {
    type Error = anyhow::Error;

    /// Finds the recordings, checks the flags against one or many, then reads the spec:
    /// the command line's own faults are found before any file is read for the model.
    fn try_from(args: ReplayArgs) -> anyhow::Result<Replay> {
        // Found here, not when the folder is made after the arguments are read.
        if args.out_dir.is_file() {
            return Err(Usage(format!(
                "--out-dir {} is a file: name a folder for the outputs",
                args.out_dir.display()
            ))
            .into());
        }
        let named = match indexed(&args)? {
            Some(file) => return indexed_replay(args, file),
            None => named_recordings(&args.files)?,
        };
        let target = match named {
            Named::One(file) => Target::One(one(&args, file)?),
            Named::Fleet(files) => Target::Fleet(fleet(&args, files)?),
        };
        Ok(Replay {
            options: library_options(&args)?,
            raw: args.raw,
            quiet: args.quiet,
            summary: args.summary,
            target,
        })
    }
}

/// One task of a cluster's array: the N-th recording of the listing, its outputs named
/// after it in `--out-dir`, as a fleet's are.
fn indexed_replay(args: ReplayArgs, file: PathBuf) -> anyhow::Result<Replay> {
    let s = stem(&file);
    let in_out = |name: String| args.out_dir.join(name);
    let one = One {
        sink: args
            .viewer
            .sink()
            .unwrap_or_else(|| RerunSink::Rrd(in_out(format!("{s}.rrd")))),
        report: Some(
            args.report
                .clone()
                .unwrap_or_else(|| in_out(format!("{s}.report.json"))),
        ),
        html: args.html.as_ref().map(|h| {
            if h.is_empty() {
                in_out(format!("{s}.report.html"))
            } else {
                PathBuf::from(h)
            }
        }),
        file,
        out_dir: Some(args.out_dir.clone()),
    };
    one.files_distinct(&args)?;
    Ok(Replay {
        options: library_options(&args)?,
        raw: args.raw,
        quiet: args.quiet,
        summary: args.summary,
        target: Target::One(one),
    })
}

/// The task number of `--index` or `--index-from-env`, if either is given.
fn index_asked(args: &ReplayArgs) -> anyhow::Result<Option<usize>> {
    if let Some(n) = args.index {
        return Ok(Some(n));
    }
    if !args.index_from_env {
        return Ok(None);
    }
    for name in ["SLURM_ARRAY_TASK_ID", "JOB_COMPLETION_INDEX"] {
        if let Ok(value) = std::env::var(name) {
            return value.trim().parse().map(Some).map_err(|_| {
                Usage(format!(
                    "--index-from-env: {name}={value} is not a task number"
                ))
                .into()
            });
        }
    }
    Err(Usage(
        "--index-from-env: neither SLURM_ARRAY_TASK_ID nor JOB_COMPLETION_INDEX is set".into(),
    )
    .into())
}

/// The recording `--index N` picks: the N-th (from 0) of the sorted listing named.
fn indexed(args: &ReplayArgs) -> anyhow::Result<Option<PathBuf>> {
    let Some(n) = index_asked(args)? else {
        return Ok(None);
    };
    let [listing] = args.files.as_slice() else {
        return Err(Usage(
            "--index takes one listing: a folder, a prefix or a text file of recordings".into(),
        )
        .into());
    };
    let mut found = listing_of(listing)?;
    if n >= found.len() {
        return Err(Usage(format!(
            "--index {n}: {} lists {} recordings (0 to {})",
            listing.display(),
            found.len(),
            found.len().saturating_sub(1)
        ))
        .into());
    }
    Ok(Some(found.swap_remove(n)))
}

/// A listing's recordings, sorted: a folder's or prefix's `.mcap` files, or a text file's
/// lines (paths or URLs; blank lines and `#` comments skipped).
fn listing_of(listing: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let location = Location::from_path(listing)?;
    if store::is_folder(&location) {
        return Ok(store::list(&location, ".mcap")?
            .iter()
            .map(Location::to_path)
            .collect());
    }
    let text = listing_text(listing, &location)?;
    let mut found: Vec<PathBuf> = text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(PathBuf::from)
        .collect();
    found.sort();
    Ok(found)
}

/// A listing file's text; a recording or any other binary file named as the listing is
/// refused by what it is, from its first bytes (a recording is not read whole for it).
fn listing_text(listing: &Path, location: &Location) -> anyhow::Result<String> {
    use std::io::Read;
    let not_a_listing = |what: &str| {
        Usage(format!(
            "--index: {} is not a listing of recordings (a folder, a prefix, or a text file of \
             paths or URLs, one a line): it is {what}; replay it without --index",
            listing.display()
        ))
    };
    let mut reader = store::open(location)?.reader;
    let mut start = Vec::with_capacity(8);
    reader
        .by_ref()
        .take(8)
        .read_to_end(&mut start)
        .map_err(|e| anyhow::anyhow!("{}: cannot read: {e}", listing.display()))?;
    if start.starts_with(b"\x89MCAP") {
        return Err(not_a_listing("an MCAP recording").into());
    }
    let mut bytes = start;
    reader
        .read_to_end(&mut bytes)
        .map_err(|e| anyhow::anyhow!("{}: cannot read: {e}", listing.display()))?;
    String::from_utf8(bytes).map_err(|_| not_a_listing("not text").into())
}

/// The recordings a replay names.
enum Named {
    /// One file (or the fixture, when none is named).
    One(PathBuf),
    /// Several files, or any folder (a fleet even if it holds one recording).
    Fleet(Vec<PathBuf>),
}

/// The recordings named: files as given, folders expanded; the fixture if none.
fn named_recordings(files: &[PathBuf]) -> anyhow::Result<Named> {
    if files.is_empty() {
        return Ok(Named::One(default_fixture()?));
    }
    let mut found = Vec::new();
    let mut from_folder = false;
    for f in files {
        let location = Location::from_path(f)?;
        if location.is_remote() && store::is_folder(&location) {
            from_folder = true;
            let listed = store::list(&location, ".mcap")?;
            found.extend(listed.iter().map(Location::to_path));
        } else if f.is_dir() {
            from_folder = true;
            found.extend(mcap_files_in(f)?);
        } else {
            found.push(f.clone());
        }
    }
    if found.is_empty() {
        return Err(Usage("no .mcap recordings in the folders given".into()).into());
    }
    if found.len() == 1 && !from_folder {
        if let Some(file) = found.pop() {
            return Ok(Named::One(file));
        }
    }
    Ok(Named::Fleet(found))
}

/// The fixture beside the current folder, else in the source tree this binary was built
/// from (so `cargo run -- replay` works from any folder of a clone).
fn default_fixture() -> anyhow::Result<PathBuf> {
    example_from(&[
        PathBuf::from(DEFAULT_FIXTURE),
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(DEFAULT_FIXTURE),
    ])
}

/// The first of `candidates` that exists; a usage error where none does (a binary
/// installed from a tree since removed: `cargo install` builds in a temporary folder),
/// which would otherwise read as a file of the user's missing.
pub(super) fn example_from(candidates: &[PathBuf]) -> anyhow::Result<PathBuf> {
    match candidates.iter().find(|p| p.exists()) {
        Some(found) => Ok(found.clone()),
        None => Err(Usage(format!(
            "no recording given, and the example heat run replayed without one \
             ({DEFAULT_FIXTURE}) is not in this folder or in the source tree this binary \
             was built from: name a recording, `heatrun replay RUN.mcap`, or make one, \
             `heatrun synth RUN.mcap`"
        ))
        .into()),
    }
}

/// The `.mcap` files of a folder, sorted by name.
fn mcap_files_in(folder: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let mut found: Vec<PathBuf> = std::fs::read_dir(folder)
        .map_err(|source| {
            heatrun::Error::from(RecordingError::ReadInput {
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

/// A recording's name without its extension: what its outputs are named after.
pub fn stem(file: &Path) -> String {
    file.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "heatrun".into())
}

/// One recording's outputs: the flags', else `<stem>.rrd` here.
fn one(args: &ReplayArgs, file: PathBuf) -> anyhow::Result<One> {
    let html = html_path(args, &file)?;
    let sink = args
        .viewer
        .sink()
        .unwrap_or_else(|| RerunSink::Rrd(PathBuf::from(format!("{}.rrd", stem(&file)))));
    let one = One {
        sink,
        report: args.report.clone(),
        html,
        file,
        out_dir: None,
    };
    one.files_distinct(args)?;
    Ok(one)
}

impl One {
    /// Refuses outputs that would replace the recording, the spec or the machine file, or
    /// each other (`--rrd run.mcap`, `--report x --html x`).
    fn files_distinct(&self, args: &ReplayArgs) -> Result<(), Usage> {
        let mut reads = vec![NamedFile::new("the recording", &self.file)];
        reads.extend(args.spec.as_deref().map(|p| NamedFile::new("--spec", p)));
        reads.extend(
            args.machine
                .as_deref()
                .map(|p| NamedFile::new("--machine", p)),
        );
        let mut writes = Vec::new();
        if let RerunSink::Rrd(path) = &self.sink {
            let what = if args.viewer.is_given() {
                "--rrd"
            } else {
                "--rrd's default"
            };
            writes.push(NamedFile::new(what, path));
        }
        writes.extend(
            self.report
                .as_deref()
                .map(|p| NamedFile::new("--report", p)),
        );
        writes.extend(self.html.as_deref().map(|p| NamedFile::new("--html", p)));
        distinct(&reads, &writes)
    }
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
        return Err(Usage(format!(
            "--html would write the page over the recording {}; write --html=PAGE.html, \
             or put --html after the recordings",
            path.display()
        ))
        .into());
    }
    Ok(Some(path))
}

/// A fleet's outputs go to `--out-dir`: the options that name one output do not apply.
fn fleet(args: &ReplayArgs, files: Vec<PathBuf>) -> anyhow::Result<Fleet> {
    let html_named = args.html.as_ref().is_some_and(|h| !h.is_empty());
    if args.viewer.is_given() || args.report.is_some() || html_named {
        return Err(Usage(
            "with several recordings, outputs go to --out-dir (one .rrd and report each, and \
             an HTML page each with a bare --html); --rrd, --report, --html PATH, --spawn and \
             --connect name one output"
                .into(),
        )
        .into());
    }
    stems_distinct(&files, &args.out_dir)?;
    Ok(Fleet {
        files,
        out_dir: args.out_dir.clone(),
        jobs: args
            .jobs
            .unwrap_or_else(|| std::thread::available_parallelism().map_or(2, |n| n.get()))
            .max(1),
        html: args.html.is_some(),
    })
}

/// A fleet's outputs are named after their recordings' stems in one folder: two
/// recordings of one stem (`a/run.mcap`, `b/run.mcap`) would write the same files, the
/// second replacing the first's.
fn stems_distinct(files: &[PathBuf], out_dir: &Path) -> Result<(), Usage> {
    let mut seen = std::collections::HashMap::new();
    for file in files {
        let s = stem(file);
        if let Some(first) = seen.insert(s.clone(), file) {
            return Err(Usage(format!(
                "{} and {} would both write {s}.rrd and {s}.report.json in {}: a fleet's \
                 outputs are named after the recording; replay one of them on its own, or \
                 give it another name",
                first.display(),
                file.display(),
                out_dir.display()
            )));
        }
    }
    Ok(())
}

/// The replay's library options: the command line first, then the spec's own sample time
/// and method, then the defaults (1 s, `oe`).
fn library_options(args: &ReplayArgs) -> anyhow::Result<ReplayOptions> {
    let model = match &args.spec {
        Some(path) => ModelDescription::from_toml_file(path).map_err(heatrun::Error::from)?,
        None if args.field_state => ModelDescription::generator_with_field_state(),
        None => ModelDescription::generator(),
    };
    let method = match (args.method, model.method.as_deref()) {
        (Some(m), _) => m,
        // A spec's bad key is the input's fault (exit status 2), as every other is.
        (None, Some(name)) => name.parse::<Method>().map_err(|_| {
            Usage(format!(
                "{}: method = \"{name}\" is not one of oe, pem, rc, iv, rls, wls, ls",
                args.spec.as_deref().unwrap_or(Path::new("spec")).display()
            ))
        })?,
        (None, None) => Method::Oe,
    };
    Ok(ReplayOptions {
        ts_s: args.ts.or(model.sample_time_s).unwrap_or(1.0),
        // Neither the flag nor the spec gives Ts: the grid follows temperatures recorded
        // slower than 1 s (decide::sample_time), and the summary says so.
        choose_ts: args.ts.is_none() && model.sample_time_s.is_none(),
        machine: args.machine.clone(),
        method,
        // Neither the flag nor the spec names a method: oe, or pem with the disturbance
        // state where oe's residuals are not white and the likelihood ratio rejects a zero
        // intensity (decide::estimator::estimate_chosen; measured in benches/calibration.rs and
        // docs/src/validation/unmeasured-heat.md).
        choose_estimator: args.method.is_none() && model.method.is_none(),
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
        network: match args.network {
            NetworkArg::Best => NetworkChoice::Best,
            NetworkArg::Nearest => NetworkChoice::Nearest,
        },
    })
}
