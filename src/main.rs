//! The `heatrun` command: a thin layer over the library. This is the one place
//! that turns an outcome into an exit status: 0 ok, 1 failure, 2 usage or bad
//! input, 3 completed with data loss, 4 completed and the monitored machine raised
//! alarms (`heatrun monitor`). A command stopped by a signal (Ctrl-C) has no outcome: it
//! ends by that signal, its incomplete outputs removed.

// The options' doc comments are the command's `--help` text, where `<recording>` and
// `<state>` are placeholders a user reads, not HTML.
#![allow(rustdoc::invalid_html_tags)]

mod cli;
mod commands;

use std::process::ExitCode;

use clap::Parser;

use commands::Outcome;

/// Parses the command line, validates it, runs the command, and turns the outcome into
/// the exit status (printing the error, with its hint, as one line).
fn main() -> ExitCode {
    end_quietly_on_closed_pipe();
    return_large_blocks_to_the_system();
    remove_incomplete_outputs_when_stopped();
    // clap refuses what it can declare (and exits 2); the rest is checked once, here,
    // before any handler runs, and reported as every other error is.
    let command = cli::Cli::parse().command;
    match cli::Request::try_from(command).and_then(commands::dispatch) {
        Ok(Outcome::Complete) => ExitCode::SUCCESS,
        Ok(Outcome::DataLoss) => ExitCode::from(3),
        Ok(Outcome::Alarms) => ExitCode::from(4),
        Err(err) => {
            let bad_input = commands::is_bad_input(&err);
            // One line: what is wrong, then (where the command line can mend it) what to do.
            let message = commands::hint::one_line(&err);
            match commands::hint::for_error(&err) {
                Some(hint) => eprintln!("heatrun: {message}; {hint}"),
                None => eprintln!("heatrun: {message}"),
            }
            ExitCode::from(if bad_input { 2 } else { 1 })
        }
    }
}

/// Removes the temporary files of outputs not yet complete when the process is stopped by
/// Ctrl-C (SIGINT), SIGTERM or SIGHUP, then ends it by that signal (its default action: a
/// shell reports 128 + the signal's number, 130 for Ctrl-C, and a script's loop stops).
///
/// Without it a replay stopped while its .rrd was written left `.run.rrd.<random>.partial`
/// beside the destination, hidden, as large as the .rrd had grown, one more each time:
/// the signal ends the process without running the destructors that remove them. The
/// handler only wakes a thread (signal-hook's iterator), which does the removing outside
/// the signal's context; an output renamed into place meanwhile is complete and stays.
fn remove_incomplete_outputs_when_stopped() {
    #[cfg(unix)]
    {
        use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
        // Where the handlers cannot be installed the process keeps the default actions:
        // a stopped replay then leaves its temporary file, as before.
        let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
            return;
        };
        std::thread::spawn(move || {
            if let Some(signal) = signals.forever().next() {
                heatrun::atomic::remove_incomplete();
                let _ = signal_hook::low_level::emulate_default_handler(signal);
                // Reached only where the default action did not end the process.
                std::process::exit(128 + signal);
            }
        });
    }
}

/// Lets a closed pipe on stdout (`heatrun info f.mcap | head -1`) end the process as it
/// ends `cat` or `grep`: silently, by SIGPIPE.
///
/// Rust starts programs with SIGPIPE ignored, so a write to a closed pipe returns
/// `BrokenPipe` and `println!` panics on it. Restoring the default action here covers
/// every command and thread at once. It is safe because the commands print only after
/// their outputs are complete (renamed into place), so nothing is cut short but the
/// printing; socket writes (rerun's gRPC sinks) are not affected, as Rust's and tokio's
/// sockets send with `MSG_NOSIGNAL` or `SO_NOSIGPIPE`.
fn end_quietly_on_closed_pipe() {
    #[cfg(unix)]
    // SAFETY: called first thing in `main`, before any other thread exists; `signal` with
    // `SIG_DFL` installs no handler code.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

/// The size from which glibc's allocator maps a block of its own, returned to the system
/// when freed: 1 MiB, a grid series of 131,072 instants.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
const OWN_MAPPING_FROM_BYTES: libc::c_int = 1 << 20;

/// How much free memory each of glibc's heaps keeps at its top before returning it to the
/// system: 2 MiB, the blocks under [`OWN_MAPPING_FROM_BYTES`] that a thread frees and
/// allocates again.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
const KEPT_AT_TOP_BYTES: libc::c_int = 2 << 20;

/// Keeps the process's resident memory near what it holds: every block of at least
/// [`OWN_MAPPING_FROM_BYTES`] is mapped on its own and unmapped when freed.
///
/// glibc starts at 128 KiB but raises the threshold to the size of each mapped block
/// freed (up to 32 MiB), so after the grid's first temporary series is freed the next
/// ones come from the heap, whose freed pages stay resident. A week at 1 s (604,800
/// instants, 4.8 MB a series) then held 231–242 MB resident for a 191 MB peak of heap;
/// with the threshold fixed, 197 MB, in the same time (docs/src/validation/speed-and-scale.md).
///
/// Fixing it also leaves the trim threshold at glibc's first 128 KiB (which the moving
/// threshold would have raised with it): rerun's file writer frees each encoded chunk
/// (about 0.3 MB) and its heap's top went back to the system every time, to be faulted in
/// again, page by page, for the next chunk (two thirds of W0's 22,000 page faults, a tenth
/// of its wall time). At [`KEPT_AT_TOP_BYTES`] those pages stay with their thread.
fn return_large_blocks_to_the_system() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: called in `main` before any other thread exists; `mallopt` only sets
    // parameters of the allocator.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, OWN_MAPPING_FROM_BYTES);
        libc::mallopt(libc::M_TRIM_THRESHOLD, KEPT_AT_TOP_BYTES);
    }
}
