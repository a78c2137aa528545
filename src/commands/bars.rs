//! Progress bars on the terminal (`indicatif`) for the library's [`Progress`] reports:
//! reading a recording (bytes, messages per second), the estimator's evaluations, a
//! fleet's recordings. Drawn only where a person watches: stderr a terminal and no
//! `--quiet`; never into a pipe or a CI log.

use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::Instant;

use heatrun::progress::Progress;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Whether progress is drawn: on a terminal only, and not when asked to be quiet.
pub fn should_draw(stderr_is_terminal: bool, quiet: bool) -> bool {
    stderr_is_terminal && !quiet
}

/// [`should_draw`] for this process's stderr.
pub fn draw_here(quiet: bool) -> bool {
    should_draw(std::io::stderr().is_terminal(), quiet)
}

/// What the one bar shows now.
#[derive(Debug, Clone, PartialEq)]
enum Stage {
    Idle,
    Reading,
    Estimating(String),
    Step,
    Fleet,
}

/// The progress line on stderr: one bar per stage of the work, each made whole (style,
/// prefix) before it is first drawn; hidden when not drawn.
pub struct Bars {
    draw: bool,
    current: Mutex<(Stage, ProgressBar)>,
    started: Instant,
}

impl Bars {
    /// Bars drawn on stderr (at most ten times a second) if `draw`, else hidden.
    pub fn new(draw: bool) -> Bars {
        Bars {
            draw,
            current: Mutex::new((Stage::Idle, ProgressBar::hidden())),
            started: Instant::now(),
        }
    }

    /// Removes the bar, before the summary is printed.
    pub fn clear(&self) {
        self.bar().finish_and_clear();
    }

    /// The current stage's bar.
    fn bar(&self) -> ProgressBar {
        self.lock().1.clone()
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, (Stage, ProgressBar)> {
        self.current.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The bar of `stage`: the current one, or (when the stage changes) a new one in the
    /// stage's `template` with `prefix`, replacing the last.
    fn enter(&self, stage: Stage, template: &str, prefix: &str) -> ProgressBar {
        let mut current = self.lock();
        if current.0 == stage {
            return current.1.clone();
        }
        current.1.finish_and_clear();
        let target = if self.draw {
            ProgressDrawTarget::stderr_with_hz(10)
        } else {
            ProgressDrawTarget::hidden()
        };
        let style = ProgressStyle::with_template(template)
            .expect("the templates are fixed and valid")
            .progress_chars("=> ");
        let bar = ProgressBar::with_draw_target(None, target)
            .with_style(style)
            .with_prefix(prefix.to_owned());
        *current = (stage, bar.clone());
        bar
    }
}

impl Progress for Bars {
    fn reading(&self, bytes_done: u64, bytes_total: u64, messages: u64) {
        let bar = self.enter(
            Stage::Reading,
            "reading   [{wide_bar}] {bytes}/{total_bytes} {binary_bytes_per_sec} {msg}",
            "",
        );
        // The message last: each call may draw, and the last draw of a report should be
        // whole (the position is shared, so a draw shows the newest).
        bar.set_length(bytes_total.max(bytes_done));
        bar.set_position(bytes_done);
        let seconds = self.started.elapsed().as_secs_f64().max(1e-3);
        bar.set_message(format!(
            "{messages} messages ({:.0}/s)",
            messages as f64 / seconds
        ));
    }

    fn iteration(&self, method: &str, evaluation: usize, cost: f64) {
        let bar = self.enter(
            Stage::Estimating(method.to_owned()),
            "{spinner} estimating {prefix}: evaluation {pos}, J = {msg} ({elapsed})",
            method,
        );
        bar.set_position(evaluation as u64);
        bar.set_message(format!("{cost:.6e}"));
    }

    fn stage(&self, what: &str) {
        let bar = self.enter(Stage::Step, "{spinner} {msg} ({elapsed})", "");
        bar.set_message(what.to_owned());
        // A step reports once: its spinner turns by itself (a hidden bar needs no ticking
        // thread).
        if self.draw {
            bar.enable_steady_tick(std::time::Duration::from_millis(100));
        }
    }

    fn recording_done(&self, done: usize, total: usize) {
        let bar = self.enter(
            Stage::Fleet,
            "replaying [{wide_bar}] {pos}/{len} recordings ({elapsed}, about {eta} left)",
            "",
        );
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn progress_is_drawn_on_a_terminal_unless_quiet() {
        assert!(should_draw(true, false));
        assert!(!should_draw(true, true));
        assert!(!should_draw(false, false));
        assert!(!should_draw(false, true));
    }

    #[test]
    fn a_hidden_bar_follows_the_stages_without_drawing() {
        let bars = Bars::new(false);
        bars.reading(10, 100, 5);
        let bar = bars.bar();
        assert!(bar.is_hidden());
        assert_eq!((bar.position(), bar.length()), (10, Some(100)));
        assert!(
            bar.message().starts_with("5 messages ("),
            "{}",
            bar.message()
        );
        bars.iteration("oe", 7, 0.25);
        assert!(bar.is_finished(), "the reading bar is gone");
        assert_eq!(
            (bars.bar().position(), bars.bar().prefix()),
            (7, "oe".into())
        );
        assert_eq!(bars.lock().0, Stage::Estimating("oe".into()));
        bars.stage("analysing the model");
        assert_eq!(bars.bar().message(), "analysing the model");
        assert_eq!(bars.lock().0, Stage::Step);
        bars.recording_done(2, 3);
        assert_eq!((bars.bar().position(), bars.bar().length()), (2, Some(3)));
        bars.clear();
        assert!(bars.bar().is_finished());
    }
}
