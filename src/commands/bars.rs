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

/// One progress bar on stderr that follows the work's stages; hidden when not drawn.
pub struct Bars {
    bar: ProgressBar,
    stage: Mutex<Stage>,
    started: Instant,
}

impl Bars {
    /// A bar drawn on stderr (at most ten times a second) if `draw`, else hidden.
    pub fn new(draw: bool) -> Bars {
        let target = if draw {
            ProgressDrawTarget::stderr_with_hz(10)
        } else {
            ProgressDrawTarget::hidden()
        };
        Bars {
            bar: ProgressBar::with_draw_target(None, target),
            stage: Mutex::new(Stage::Idle),
            started: Instant::now(),
        }
    }

    /// Removes the bar, before the summary is printed.
    pub fn clear(&self) {
        self.bar.finish_and_clear();
    }

    /// Switches the bar's style when the stage changes; `true` if it did.
    fn enter(&self, stage: Stage, template: &str) -> bool {
        let mut now = self.stage.lock().unwrap_or_else(|e| e.into_inner());
        if *now == stage {
            return false;
        }
        *now = stage;
        self.bar.disable_steady_tick();
        self.bar.set_message("");
        let style = ProgressStyle::with_template(template)
            .expect("the templates are fixed and valid")
            .progress_chars("=> ");
        self.bar.set_style(style);
        self.bar.reset();
        true
    }
}

impl Progress for Bars {
    fn reading(&self, bytes_done: u64, bytes_total: u64, messages: u64) {
        self.enter(
            Stage::Reading,
            "reading   [{wide_bar}] {bytes}/{total_bytes} {binary_bytes_per_sec} {msg}",
        );
        // The message first, the position last: each call may draw, and the line drawn
        // should be whole.
        let seconds = self.started.elapsed().as_secs_f64().max(1e-3);
        self.bar.set_message(format!(
            "{messages} messages ({:.0}/s)",
            messages as f64 / seconds
        ));
        self.bar.set_length(bytes_total.max(bytes_done));
        self.bar.set_position(bytes_done);
    }

    fn iteration(&self, method: &str, evaluation: usize, cost: f64) {
        if self.enter(
            Stage::Estimating(method.to_owned()),
            "{spinner} estimating {prefix}: evaluation {pos}, J = {msg} ({elapsed})",
        ) {
            self.bar.set_prefix(method.to_owned());
            self.bar.unset_length();
        }
        self.bar.set_message(format!("{cost:.6e}"));
        self.bar.set_position(evaluation as u64);
    }

    fn stage(&self, what: &str) {
        if self.enter(Stage::Step, "{spinner} {msg} ({elapsed})") {
            self.bar.unset_length();
            // A step reports once: the spinner turns by itself (a hidden bar needs no
            // ticking thread).
            if !self.bar.is_hidden() {
                self.bar
                    .enable_steady_tick(std::time::Duration::from_millis(100));
            }
        }
        self.bar.set_message(what.to_owned());
    }

    fn recording_done(&self, done: usize, total: usize) {
        self.enter(
            Stage::Fleet,
            "replaying [{wide_bar}] {pos}/{len} recordings ({elapsed}, about {eta} left)",
        );
        self.bar.set_length(total as u64);
        self.bar.set_position(done as u64);
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
        assert!(bars.bar.is_hidden());
        bars.reading(10, 100, 5);
        assert_eq!((bars.bar.position(), bars.bar.length()), (10, Some(100)));
        bars.iteration("oe", 7, 0.25);
        assert_eq!(bars.bar.position(), 7);
        assert_eq!(*bars.stage.lock().unwrap(), Stage::Estimating("oe".into()));
        bars.stage("analysing the model");
        assert_eq!(bars.bar.message(), "analysing the model");
        assert_eq!(*bars.stage.lock().unwrap(), Stage::Step);
        bars.recording_done(2, 3);
        assert_eq!((bars.bar.position(), bars.bar.length()), (2, Some(3)));
        bars.clear();
        assert!(bars.bar.is_finished());
    }
}
