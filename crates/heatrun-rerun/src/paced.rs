//! A recording stream whose queue to rerun's writer is bounded by rows, not waited for
//! after every slice.
//!
//! rerun's file sink encodes (Arrow IPC, LZ4) on a thread of its own, behind a queue
//! that a producer faster than the encoder fills without bound. Waiting for the writer
//! after every slice of a series keeps that queue at one slice, but then the series are
//! computed and encoded one after the other: on W0 (the paper's heat run at 1 Hz) the
//! waits were 0.06 s of a 0.34 s replay. [`PacedStream`] waits only once more than
//! [`BACKLOG_ROWS`] rows are queued, so the encoder works beside whatever computes the
//! next series, and a week's replay still holds at most that many rows in the queue.

use std::ops::Deref;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

use crate::sdk::RecordingStream;
use crate::{publish_err, Result};

/// Rows (a time, a value and a row id: about 36 bytes each as Arrow) that may wait in
/// rerun's queue before a sender waits for the writer: about 4.7 MB. Twice as many did
/// not make W0 faster and left the week at 100 Hz (peak 184–202 MB resident) at its
/// 200 MB bar; this many, 193 MB.
pub const BACKLOG_ROWS: usize = 1 << 17;

/// A [`RecordingStream`] with a count of the rows sent since the writer last caught up,
/// shared by its clones (the series of one recording are sent from several threads).
#[derive(Clone)]
pub struct PacedStream {
    rec: RecordingStream,
    queued_rows: Arc<AtomicUsize>,
}

impl PacedStream {
    /// Paces `rec`, with nothing queued yet.
    pub fn new(rec: RecordingStream) -> PacedStream {
        PacedStream {
            rec,
            queued_rows: Arc::default(),
        }
    }

    /// Notes `rows` rows sent; where more than [`BACKLOG_ROWS`] are now queued, waits
    /// until the writer has taken every one of them.
    pub fn sent(&self, rows: usize) -> Result<()> {
        let queued = self.queued_rows.fetch_add(rows, Ordering::Relaxed) + rows;
        if queued > BACKLOG_ROWS {
            // Whoever crosses the bound waits; the rows other threads send meanwhile are
            // written by the same wait or counted towards the next one.
            self.queued_rows.store(0, Ordering::Relaxed);
            self.rec.flush_blocking().map_err(publish_err)?;
        }
        Ok(())
    }
}

impl Deref for PacedStream {
    type Target = RecordingStream;

    fn deref(&self) -> &RecordingStream {
        &self.rec
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sdk::RecordingStreamBuilder;

    fn queued(paced: &PacedStream) -> usize {
        paced.queued_rows.load(Ordering::Relaxed)
    }

    #[test]
    fn a_sender_waits_only_once_the_backlog_is_over_its_bound_and_clones_share_it() {
        let (rec, _storage) = RecordingStreamBuilder::new("paced").memory().unwrap();
        let paced = PacedStream::new(rec);
        let other = paced.clone();
        paced.sent(BACKLOG_ROWS / 2).unwrap();
        other.sent(BACKLOG_ROWS / 2).unwrap();
        // At the bound, not over it: nothing waited for yet, the count the clones' sum.
        assert_eq!(queued(&paced), BACKLOG_ROWS);
        other.sent(1).unwrap();
        assert_eq!(queued(&paced), 0);
        paced.sent(7).unwrap();
        assert_eq!(queued(&other), 7);
    }
}
