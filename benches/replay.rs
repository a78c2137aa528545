//! Replay throughput and memory against the floor of reading the same file.
//!
//! `cargo bench --bench replay` makes W1, the paper's heat run at full rate (20,868 s,
//! electrical channels at 100 Hz, temperatures at 10 Hz, zstd chunks: about 9 million
//! messages), at ¼, ½ and 1 of its length, and replays each end to end (read, decode,
//! decimate, losses, estimate, .rrd and report written) as the `heatrun` binary does.
//! For each it prints messages/s, MB/s and peak resident memory of the replay, the
//! floor — iterating the same file's messages with the mcap crate and nothing else —
//! and the ratio replay / floor; medians of three runs.
//! `HEATRUN_BENCH_W2=1` adds W2, seven days at the same rates (about 260 million
//! messages, 8 GB on disk, several minutes). `HEATRUN_BENCH_DIR` keeps the workloads.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader};

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
// The child is reaped by `wait4` (which also gives its peak RSS), not `Child::wait`.
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
fn workload(dir: &Path, name: &str, duration_s: f64) -> PathBuf {
    let path = dir.join(format!("{name}.mcap"));
    if !path.exists() {
        let t = Instant::now();
        // The paper's heat run at full rate with PT100-like noise (noise level 1).
        let status = Command::new(env!("CARGO_BIN_EXE_heatrun"))
            .arg("synth")
            .arg(&path)
            .args(["--duration", &duration_s.to_string()])
            .args(["--electrical-rate", "100", "--temperature-rate", "10"])
            .args(["--temperature-noise", "0.05", "--resolution", "0.01"])
            .args(["--electrical-noise", "0.0005"])
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

fn main() {
    let keep = std::env::var_os("HEATRUN_BENCH_DIR").map(PathBuf::from);
    let temp = tempfile::tempdir().expect("temporary directory");
    let dir = keep.clone().unwrap_or_else(|| temp.path().to_owned());
    std::fs::create_dir_all(&dir).expect("bench directory");
    let out = tempfile::tempdir().expect("output directory");
    let mut cases: Vec<(String, f64, usize)> = vec![
        ("W1/4".into(), 20868.0 / 4.0, 3),
        ("W1/2".into(), 20868.0 / 2.0, 3),
        ("W1".into(), 20868.0, 3),
    ];
    if std::env::var_os("HEATRUN_BENCH_W2").is_some() {
        cases.push(("W2".into(), 7.0 * 86400.0, 1));
    }
    println!(
        "{:<6} {:>12} {:>9} {:>10} {:>12} {:>9} {:>10} {:>9} {:>7}",
        "case", "messages", "MB", "replay s", "messages/s", "MB/s", "peak MB", "floor s", "ratio"
    );
    for (name, duration, runs) in cases {
        let path = workload(&dir, &name.replace('/', "_"), duration);
        let bytes = std::fs::metadata(&path).expect("workload").len() as f64 / 1e6;
        let mut floors = Vec::new();
        let mut messages = 0;
        for _ in 0..runs {
            let t = Instant::now();
            messages = floor(&path);
            floors.push(t.elapsed().as_secs_f64());
        }
        let mut times = Vec::new();
        let mut peaks = Vec::new();
        for _ in 0..runs {
            let (t, peak) = replay(&path, out.path());
            times.push(t);
            peaks.push(peak);
        }
        let (t, f) = (median(times), median(floors));
        println!(
            "{:<6} {:>12} {:>9.0} {:>10.2} {:>12.0} {:>9.0} {:>10.1} {:>9.2} {:>7.2}",
            name,
            messages,
            bytes,
            t,
            messages as f64 / t,
            bytes / t,
            peaks.iter().cloned().fold(0.0, f64::max),
            f,
            t / f
        );
        if keep.is_none() {
            let _ = std::fs::remove_file(&path);
        }
    }
}
