//! A command stopped by Ctrl-C (SIGINT), SIGTERM or SIGHUP while it writes its outputs
//! removes their temporary files and ends by that signal: nothing hidden is left beside
//! the destination, and no output is left incomplete.

#[cfg(unix)]
mod on_unix {
    use std::os::unix::process::ExitStatusExt;
    use std::path::Path;
    use std::process::{Command, Stdio};
    use std::time::{Duration, Instant};

    use crate::common;

    /// The entries of `dir` whose names start with a dot: the outputs' temporary files.
    fn hidden_in(dir: &Path) -> Vec<String> {
        common::files_in(dir)
            .iter()
            .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
            .filter(|n| n.starts_with('.'))
            .collect()
    }

    #[test]
    fn a_replay_stopped_while_it_writes_leaves_no_temporary_file() {
        let fixture = common::package_root().join("fixtures/paper_heat_run.mcap");
        for signal in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP] {
            let dir = common::tempdir();
            let mut child = Command::new(env!("CARGO_BIN_EXE_heatrun"))
                .args(["replay", "-q", fixture.to_str().unwrap()])
                .args(["--rrd", "run.rrd", "--report", "report.json"])
                .current_dir(dir.path())
                .stderr(Stdio::null())
                .spawn()
                .expect("heatrun starts");
            // The .rrd's temporary file is made before the recording is read: once it is
            // there, the replay is writing.
            let started = Instant::now();
            while hidden_in(dir.path()).is_empty() {
                assert!(
                    child.try_wait().unwrap().is_none(),
                    "the replay ended before its .rrd was begun"
                );
                assert!(started.elapsed() < Duration::from_secs(60));
                std::thread::sleep(Duration::from_millis(1));
            }
            let pid = child.id() as libc::pid_t;
            // Held still while the signal is sent, so that it arrives mid-replay however
            // fast the machine: it is delivered as the process continues.
            // SAFETY: signals to our own child, which has not been waited for.
            unsafe {
                libc::kill(pid, libc::SIGSTOP);
                libc::kill(pid, signal);
                libc::kill(pid, libc::SIGCONT);
            }
            let status = child.wait().unwrap();
            assert_eq!(status.signal(), Some(signal), "{status:?}");
            assert_eq!(
                hidden_in(dir.path()),
                Vec::<String>::new(),
                "signal {signal}"
            );
            // The report is written after the .rrd is renamed into place: stopped before
            // that, neither is there.
            assert_eq!(
                common::files_in(dir.path()),
                Vec::<std::path::PathBuf>::new()
            );
        }
    }
}
