//! Progress of long work, reported to an observer the caller chooses.
//!
//! The library draws nothing: the reader, the estimators and whoever runs a fleet call a
//! [`Progress`] observer, carried in the options as an [`Observer`] (silent by default).
//! The command line implements it with progress bars on a terminal; a test or a service
//! may count or log. Calls come from the thread doing the work, so an observer is
//! `Send + Sync` and must be cheap: the reader calls it at most every
//! [`Throttle::DEFAULT_INTERVAL`] or once per chunk, whichever is rarer.

use std::fmt;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// What long work reports as it goes. Every method has a no-op default, so an observer
/// implements only what it shows.
pub trait Progress: Send + Sync {
    /// A recording is being read: `bytes_done` of `bytes_total` (0 when the length is not
    /// known, a stream), with `messages` messages read so far.
    fn reading(&self, bytes_done: u64, bytes_total: u64, messages: u64) {
        let _ = (bytes_done, bytes_total, messages);
    }

    /// An estimator evaluated its objective for the `evaluation`-th time (counted from 1
    /// per fit): `cost` is the weighted sum of squared simulation errors J = Σ_k e(k)ᵀ W e(k)
    /// at that point (eq. 4), of the fit `method` (`oe`, `rc`).
    fn iteration(&self, method: &str, evaluation: usize, cost: f64) {
        let _ = (method, evaluation, cost);
    }

    /// A step without a count of its own began (`analysing the model`): shown until the
    /// next report.
    fn stage(&self, what: &str) {
        let _ = what;
    }

    /// `done` of `total` recordings of a fleet are finished.
    fn recording_done(&self, done: usize, total: usize) {
        let _ = (done, total);
    }
}

/// The observer that shows nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct Silent;

impl Progress for Silent {}

/// A shared [`Progress`] observer, as options carry it: cheap to clone, silent by
/// default. Two observers are equal when they are the same observer.
#[derive(Clone)]
pub struct Observer(Arc<dyn Progress>);

impl Observer {
    /// An observer around `progress`.
    pub fn new(progress: impl Progress + 'static) -> Observer {
        Observer(Arc::new(progress))
    }

    /// An observer already shared elsewhere (the caller keeps a handle to it).
    pub fn shared(progress: Arc<dyn Progress>) -> Observer {
        Observer(progress)
    }

    /// The observer that shows nothing.
    pub fn silent() -> Observer {
        Observer::new(Silent)
    }
}

impl Default for Observer {
    fn default() -> Observer {
        Observer::silent()
    }
}

impl std::ops::Deref for Observer {
    type Target = dyn Progress;

    fn deref(&self) -> &(dyn Progress + 'static) {
        self.0.as_ref()
    }
}

impl fmt::Debug for Observer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("Observer")
    }
}

impl PartialEq for Observer {
    fn eq(&self, other: &Observer) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

impl Eq for Observer {}

/// Lets a report through at most once per interval, so that a loop over millions of
/// messages calls its observer a few times a second, not once a message.
#[derive(Debug, Clone)]
pub struct Throttle {
    interval: Duration,
    last: Option<Instant>,
}

impl Throttle {
    /// About ten updates a second: smooth to the eye, nothing for the work.
    pub const DEFAULT_INTERVAL: Duration = Duration::from_millis(100);

    /// A throttle letting one report through per `interval` (the first at once).
    pub fn new(interval: Duration) -> Throttle {
        Throttle {
            interval,
            last: None,
        }
    }

    /// Whether a report is due at `now`; if so, the interval starts again from `now`.
    pub fn due_at(&mut self, now: Instant) -> bool {
        let due = self
            .last
            .is_none_or(|last| now.saturating_duration_since(last) >= self.interval);
        if due {
            self.last = Some(now);
        }
        due
    }

    /// Whether a report is due now.
    pub fn due(&mut self) -> bool {
        self.due_at(Instant::now())
    }
}

impl Default for Throttle {
    fn default() -> Throttle {
        Throttle::new(Throttle::DEFAULT_INTERVAL)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    #[derive(Default)]
    struct Count(Mutex<Vec<(u64, u64, u64)>>);

    impl Progress for Count {
        fn reading(&self, done: u64, total: u64, messages: u64) {
            self.0.lock().unwrap().push((done, total, messages));
        }
    }

    #[test]
    fn an_observer_reaches_its_progress_and_the_default_is_silent() {
        let count = Arc::new(Count::default());
        let observer = Observer::shared(count.clone());
        observer.reading(10, 100, 3);
        observer.iteration("oe", 1, 0.5); // the default method: ignored
        Observer::default().reading(1, 2, 3);
        assert_eq!(*count.0.lock().unwrap(), vec![(10, 100, 3)]);
        assert_eq!(observer.clone(), observer);
        assert_ne!(observer, Observer::default());
    }

    #[test]
    fn a_throttle_lets_one_report_through_per_interval() {
        let mut throttle = Throttle::new(Duration::from_millis(100));
        let t0 = Instant::now();
        let at = |ms| t0 + Duration::from_millis(ms);
        let due: Vec<bool> = [0, 50, 99, 100, 150, 250, 251]
            .into_iter()
            .map(|ms| throttle.due_at(at(ms)))
            .collect();
        assert_eq!(due, [true, false, false, true, false, true, false]);
    }
}
