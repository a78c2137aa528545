//! Replay throughput and memory against the floor of reading the same file.
//!
//! `cargo bench --bench replay` makes W0, the paper's heat run at 10 Hz electrical and
//! 1 Hz temperatures (20,868 s, about 0.94 million messages, 21 MB): small enough that
//! what a replay does once — the analysis, the network, the .rrd and the report —
//! weighs against the reading, so its ratio to the floor is the fixed costs' figure.
//! Then W1, the paper's heat run at full rate (20,868 s, electrical channels at 100 Hz,
//! temperatures at 10 Hz, zstd chunks: about 9 million messages), at ¼, ½ and 1 of its
//! length. Each is replayed end to end (read, decode, decimate, losses, estimate, .rrd
//! and report written) as the `heatrun` binary does. For each it prints messages/s, MB/s
//! and peak resident memory of the replay, the floor — iterating the same file's
//! messages with the mcap crate and nothing else — and the ratio replay / floor; medians
//! of three runs (W0: eleven), the floor read in the same turns as the replays and the
//! ratio the median of each turn's (a machine whose load drifts between the floors and
//! the replays moved W0's ratio by a tenth when all the floors came first). "W1 shuffled" is W1 with its messages stored in a random
//! order (zstd chunks of 1 MiB, metadata at the end): its replay must stay within 1.5×
//! of W1's time and within W1's memory, and give W1's report numbers.
//! `HEATRUN_BENCH_W2=1` adds W2, seven days at the same rates (about 260 million
//! messages, 8 GB on disk, several minutes). `HEATRUN_BENCH_DIR` keeps the workloads;
//! `HEATRUN_BENCH_CASES=W0,W1` runs only the cases named (a shuffled case needs its
//! source named too).

#[path = "../tests/layouts/mod.rs"]
mod layouts;

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader};

/// Set in the child process that shuffles a workload: `SOURCE|DESTINATION`.
const SHUFFLE_CHILD: &str = "HEATRUN_BENCH_SHUFFLE";

/// Iterates every message of the file with the mcap crate; returns the count.
fn floor(path: &Path) -> u64 {
    let mut file = std::fs::File::open(path).expect("workload");
    let mut reader = LinearReader::new();
    let mut messages = 0;
    while let Some(event) = reader.next_event() {
        match event.expect("valid workload") {
            LinearReadEvent::ReadRequest(need) => {
                let n = file.read(reader.insert(need.max(1 << 20))).expect("read");
                reader.notify_read(n);
            }
            LinearReadEvent::Record { opcode, .. } => {
                if opcode == mcap::records::op::MESSAGE {
                    messages += 1;
                }
            }
        }
    }
    messages
}

/// Runs the replay as a child process; returns (seconds, peak RSS in MB).
// The child is waited for with `wait4`, which `std` does not offer, for its peak memory.
#[allow(clippy::zombie_processes)]
fn replay(path: &Path, out: &Path) -> (f64, f64) {
    let start = Instant::now();
    let child = Command::new(env!("CARGO_BIN_EXE_heatrun"))
        .args(["replay", "-q", "--rrd"])
        .arg(out.join("w.rrd"))
        .arg("--report")
        .arg(out.join("w.json"))
        .arg(path)
        .spawn()
        .expect("heatrun runs");
    let pid = child.id() as libc::pid_t;
    let mut status = 0;
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: waits for our own child; `usage` is a valid out-pointer.
    let r = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    assert!(
        r == pid && libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0,
        "replay failed: {status}"
    );
    (
        start.elapsed().as_secs_f64(),
        usage.ru_maxrss as f64 / 1024.0,
    )
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Makes a workload with `heatrun synth` in a child process: synthesising in this
/// process would grow its memory, and a child's peak RSS as `wait4` reports it can
/// include pages of the parent it was forked from.
fn workload(dir: &Path, name: &str, synth: &[&str]) -> PathBuf {
    let path = dir.join(format!("{name}.mcap"));
    if !path.exists() {
        let t = Instant::now();
        let status = Command::new(env!("CARGO_BIN_EXE_heatrun"))
            .arg("synth")
            .arg(&path)
            .args(synth)
            .status()
            .expect("heatrun synth runs");
        assert!(status.success(), "heatrun synth failed");
        eprintln!(
            "made {} in {:.1} s",
            path.display(),
            t.elapsed().as_secs_f64()
        );
    }
    path
}

/// Makes `name` from `source` with its messages shuffled, in a child process (this bench
/// itself, run again): the shuffle holds the whole file in memory, which must not count
/// against the replays forked from this process.
fn shuffled_workload(dir: &Path, name: &str, source: &Path) -> PathBuf {
    let path = dir.join(format!("{name}.mcap"));
    if !path.exists() {
        let t = Instant::now();
        let status = Command::new(std::env::current_exe().expect("the bench binary"))
            .env(
                SHUFFLE_CHILD,
                format!("{}|{}", source.display(), path.display()),
            )
            .status()
            .expect("the shuffling child runs");
        assert!(status.success(), "shuffling failed");
        eprintln!(
            "made {} in {:.1} s",
            path.display(),
            t.elapsed().as_secs_f64()
        );
    }
    path
}

/// `heatrun synth`'s arguments as owned strings.
fn synth_args(args: &[&str]) -> Vec<String> {
    args.iter().map(|a| a.to_string()).collect()
}

/// The paper's heat run of `duration_s` at full rate (electrical channels at 100 Hz,
/// temperatures at 10 Hz) with PT100-like noise (noise level 1).
fn full_rate(duration_s: f64) -> Source {
    Source::Synth(synth_args(&[
        "--duration",
        &duration_s.to_string(),
        "--electrical-rate",
        "100",
        "--temperature-rate",
        "10",
        "--temperature-noise",
        "0.05",
        "--resolution",
        "0.01",
        "--electrical-noise",
        "0.0005",
    ]))
}

/// The report numbers compared between W1 and W1 shuffled: Φ, Γ, time constants.
fn report_numbers(out: &Path) -> Vec<f64> {
    let text = std::fs::read_to_string(out.join("w.json")).expect("the report");
    let report: serde_json::Value = serde_json::from_str(&text).expect("a JSON report");
    let mut numbers = Vec::new();
    for key in ["phi", "gamma", "time_constants_s"] {
        let flat = report[key].to_string().replace(['[', ']'], "");
        numbers.extend(flat.split(',').map(|x| x.parse::<f64>().expect(key)));
    }
    numbers
}

/// How a case's workload is made.
enum Source {
    /// `heatrun synth` with these arguments.
    Synth(Vec<String>),
    /// The workload of the named case, shuffled.
    Shuffled(&'static str),
}

/// The floor once: (messages, seconds).
fn timed_floor(path: &Path) -> (u64, f64) {
    let t = Instant::now();
    let messages = floor(path);
    (messages, t.elapsed().as_secs_f64())
}

/// A workload's replays: median seconds, peak MB, the report's numbers.
struct Measured {
    seconds: f64,
    peak_mb: f64,
    numbers: Vec<f64>,
}

/// The floor in the same turns as the replays: median seconds, and the median of each
/// turn's replay / floor (both under the load the machine had in that turn).
struct Floor {
    messages: u64,
    seconds: f64,
    ratio: f64,
}

/// Reads `path` (the floor) and replays it `runs` times, in turns, with `paired` in the
/// same turns when given (a reordered workload and its source then see the same load on
/// the machine, as the floor and the replay do).
fn measure(
    path: &Path,
    paired: Option<&Path>,
    out: &Path,
    runs: usize,
) -> (Measured, Option<Measured>, Floor) {
    let summary = |times: Vec<f64>, peaks: Vec<f64>, numbers| Measured {
        seconds: median(times),
        peak_mb: peaks.iter().cloned().fold(0.0, f64::max),
        numbers,
    };
    let (mut times, mut peaks, mut numbers) = (Vec::new(), Vec::new(), Vec::new());
    let (mut times_of, mut peaks_of, mut numbers_of) = (Vec::new(), Vec::new(), Vec::new());
    let (mut messages, mut floors, mut ratios) = (0, Vec::new(), Vec::new());
    for _ in 0..runs {
        let (m, f) = timed_floor(path);
        messages = m;
        floors.push(f);
        if let Some(of) = paired {
            let (t, peak) = replay(of, out);
            times_of.push(t);
            peaks_of.push(peak);
            numbers_of = report_numbers(out);
        }
        let (t, peak) = replay(path, out);
        times.push(t);
        ratios.push(t / f);
        peaks.push(peak);
        numbers = report_numbers(out);
    }
    let of = paired.map(|_| summary(times_of, peaks_of, numbers_of));
    let floor = Floor {
        messages,
        seconds: median(floors),
        ratio: median(ratios),
    };
    (summary(times, peaks, numbers), of, floor)
}

fn main() {
    if let Some(job) = std::env::var_os(SHUFFLE_CHILD) {
        let job = job.to_string_lossy().into_owned();
        let (from, to) = job.split_once('|').expect("SOURCE|DESTINATION");
        layouts::rewrite(Path::new(from), Path::new(to), layouts::Order::Shuffled(1));
        return;
    }
    let keep = std::env::var_os("HEATRUN_BENCH_DIR").map(PathBuf::from);
    let temp = tempfile::tempdir().expect("temporary directory");
    let dir = keep.clone().unwrap_or_else(|| temp.path().to_owned());
    std::fs::create_dir_all(&dir).expect("bench directory");
    let out = tempfile::tempdir().expect("output directory");
    let mut cases: Vec<(&str, Source, usize)> = vec![
        // The 5.8 h heat run at the rates of a plant historian (issue 21's small file).
        (
            "W0",
            Source::Synth(synth_args(&[
                "--electrical-rate",
                "10",
                "--temperature-rate",
                "1",
                "--temperature-noise",
                "0.05",
            ])),
            11,
        ),
        ("W1/4", full_rate(20868.0 / 4.0), 3),
        ("W1/2", full_rate(20868.0 / 2.0), 3),
        ("W1", full_rate(20868.0), 3),
        ("W1 shuffled", Source::Shuffled("W1"), 3),
    ];
    if std::env::var_os("HEATRUN_BENCH_W2").is_some() {
        cases.push(("W2", full_rate(7.0 * 86400.0), 1));
    }
    if let Some(only) = std::env::var_os("HEATRUN_BENCH_CASES") {
        let only = only.to_string_lossy().into_owned();
        let named: Vec<&str> = only.split(',').map(str::trim).collect();
        cases.retain(|(name, _, _)| named.contains(name));
    }
    println!(
        "{:<12} {:>12} {:>9} {:>10} {:>12} {:>9} {:>10} {:>9} {:>7}",
        "case", "messages", "MB", "replay s", "messages/s", "MB/s", "peak MB", "floor s", "ratio"
    );
    let mut made: Vec<(&str, PathBuf)> = Vec::new();
    for (name, source, runs) in cases {
        let file = name.replace(['/', ' '], "_");
        let source_of = match source {
            Source::Shuffled(of) => made.iter().find(|m| m.0 == of).cloned(),
            Source::Synth(_) => None,
        };
        let path = match (source, &source_of) {
            (Source::Synth(args), _) => {
                let args: Vec<&str> = args.iter().map(String::as_str).collect();
                workload(&dir, &file, &args)
            }
            (Source::Shuffled(_), Some((_, from))) => shuffled_workload(&dir, &file, from),
            (Source::Shuffled(of), None) => panic!("{of} is not made before {name}"),
        };
        let bytes = std::fs::metadata(&path).expect("workload").len() as f64 / 1e6;
        let paired = source_of.as_ref().map(|(_, p)| p.as_path());
        let (m, of, floor) = measure(&path, paired, out.path(), runs);
        let (t, messages, f) = (m.seconds, floor.messages, floor.seconds);
        println!(
            "{:<12} {:>12} {:>9.0} {:>10.2} {:>12.0} {:>9.0} {:>10.1} {:>9.2} {:>7.2}",
            name,
            messages,
            bytes,
            t,
            messages as f64 / t,
            bytes / t,
            m.peak_mb,
            f,
            floor.ratio
        );
        if let (Some(of), Some((of_name, _))) = (of, source_of) {
            let worst = m
                .numbers
                .iter()
                .zip(&of.numbers)
                .map(|(a, b)| (a - b).abs() / a.abs().max(b.abs()))
                .fold(0.0, f64::max);
            println!(
                "{name} against {of_name} in turns: replay {t:.2} s against {:.2} s ({:.2}×, \
                 bound 1.5), peak {:.1} MB against {:.1} MB, report numbers within {worst:.1e}",
                of.seconds,
                t / of.seconds,
                m.peak_mb,
                of.peak_mb
            );
        }
        made.push((name, path));
    }
    if keep.is_none() {
        for (_, path) in made {
            let _ = std::fs::remove_file(path);
        }
    }
}
