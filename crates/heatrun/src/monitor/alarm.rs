//! The alarm detector: a residual r_j = θ_j − θ̂_j outside its band |r_j| > b_j for
//! longer than the hold time opens an alarm on part j.
//!
//! One excursion per part at a time: it starts at the first instant outside the band
//! and ends once the residual has stayed back inside it for a tenth of the hold time (the
//! clearing time: a noisy residual that dips inside for an instant while a fault builds
//! does not split one alarm into two), at the first instant of that return; instants
//! with no residual (a gap in the recording) neither end nor extend it. An excursion that
//! lasted longer than the hold time is an alarm, raised (as a live monitor would raise
//! it) the hold time after its start; shorter ones are noise or a transient the model
//! missed, and are forgotten. The detector holds one excursion per part, so it runs over
//! a recording of any length.

/// One alarm: part `state` was outside its band from `start_ns` to `end_ns`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Alarm {
    /// The state's index in the model.
    pub state: usize,
    /// The state's name.
    pub state_name: String,
    /// The first instant outside the band, ns since the epoch.
    pub start_ns: i64,
    /// When the alarm is raised: `start_ns` plus the hold time.
    pub raised_ns: i64,
    /// The first instant of the return inside the band that ended it (see the module on
    /// the clearing time); `None` if the recording ended outside it.
    pub end_ns: Option<i64>,
    /// The residual of largest magnitude θ − θ̂ during the excursion, K (signed: above
    /// the model is positive).
    pub peak_deviation_k: f64,
    /// When it occurred, ns since the epoch.
    pub peak_ns: i64,
    /// The band it left, K.
    pub band_k: f64,
}

/// An excursion in progress.
#[derive(Debug, Clone, Copy)]
struct Excursion {
    start_ns: i64,
    peak_k: f64,
    peak_ns: i64,
    /// The first instant of the current return inside the band, if back inside.
    inside_since_ns: Option<i64>,
}

/// The clearing time as a share of the hold time.
pub const CLEAR_SHARE_OF_HOLD: f64 = 0.1;

/// Watches each part's residual against its band.
#[derive(Debug, Clone)]
pub struct Detector {
    names: Vec<String>,
    band_k: Vec<f64>,
    hold_ns: i64,
    clear_ns: i64,
    open: Vec<Option<Excursion>>,
    alarms: Vec<Alarm>,
}

impl Detector {
    /// A detector for states `names` with half-widths `band_k` (K) and `hold_s` (s).
    pub fn new(names: Vec<String>, band_k: Vec<f64>, hold_s: f64) -> Detector {
        let n = names.len();
        Detector {
            names,
            band_k,
            hold_ns: (hold_s * 1e9).round() as i64,
            clear_ns: (CLEAR_SHARE_OF_HOLD * hold_s * 1e9).round() as i64,
            open: vec![None; n],
            alarms: Vec::new(),
        }
    }

    /// Sets each state's half-width from this instant on (a band that varies with what
    /// the model knows, [`super::BandKind::Model`]).
    pub fn set_band(&mut self, band_k: &[f64]) {
        self.band_k.copy_from_slice(band_k);
    }

    /// The residuals (K, `None` where unknown) of every state at `time_ns`, in time order.
    pub fn observe(&mut self, time_ns: i64, residuals: &[Option<f64>]) {
        for (j, r) in residuals.iter().enumerate() {
            let Some(r) = *r else { continue };
            let outside = r.abs() > self.band_k[j];
            match (&mut self.open[j], outside) {
                (Some(e), true) => {
                    e.inside_since_ns = None;
                    if r.abs() > e.peak_k.abs() {
                        e.peak_k = r;
                        e.peak_ns = time_ns;
                    }
                }
                (slot @ None, true) => {
                    *slot = Some(Excursion {
                        start_ns: time_ns,
                        peak_k: r,
                        peak_ns: time_ns,
                        inside_since_ns: None,
                    })
                }
                (Some(e), false) => {
                    let since = *e.inside_since_ns.get_or_insert(time_ns);
                    if time_ns - since >= self.clear_ns {
                        let e = self.open[j].take().expect("matched Some");
                        self.close(j, e, Some(since), time_ns);
                    }
                }
                (None, false) => {}
            }
        }
    }

    /// An excursion that ended at `end_ns` (or is still open at `last_ns`, the last
    /// instant seen) becomes an alarm if it lasted longer than the hold time.
    fn close(&mut self, j: usize, e: Excursion, end_ns: Option<i64>, last_ns: i64) {
        let lasted = end_ns.unwrap_or(last_ns) - e.start_ns;
        if lasted > self.hold_ns {
            self.alarms.push(Alarm {
                state: j,
                state_name: self.names[j].clone(),
                start_ns: e.start_ns,
                raised_ns: e.start_ns + self.hold_ns,
                end_ns,
                peak_deviation_k: e.peak_k,
                peak_ns: e.peak_ns,
                band_k: self.band_k[j],
            });
        }
    }

    /// The alarms closed so far, in the order they closed (a stream shows them as they
    /// close; [`Detector::finish`] adds those still open and orders them).
    pub fn closed(&self) -> &[Alarm] {
        &self.alarms
    }

    /// Part j's excursion in progress, if any: its first instant outside the band, and
    /// the first instant of its current return inside it (`None` while outside), ns.
    pub fn open_excursion(&self, j: usize) -> Option<(i64, Option<i64>)> {
        self.open[j].map(|e| (e.start_ns, e.inside_since_ns))
    }

    /// The hold time, ns.
    pub fn hold_ns(&self) -> i64 {
        self.hold_ns
    }

    /// The alarms, excursions still open at `last_ns` (the recording's last instant)
    /// included, in order of when they were raised.
    pub fn finish(mut self, last_ns: i64) -> Vec<Alarm> {
        for j in 0..self.open.len() {
            if let Some(e) = self.open[j].take() {
                let end = e.inside_since_ns;
                self.close(j, e, end, last_ns);
            }
        }
        self.alarms.sort_by_key(|a| (a.raised_ns, a.state));
        self.alarms
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const S: i64 = 1_000_000_000;

    fn run(residuals: &[f64], hold_s: f64) -> Vec<Alarm> {
        let mut d = Detector::new(vec!["a".into()], vec![1.0], hold_s);
        for (k, r) in residuals.iter().enumerate() {
            d.observe(k as i64 * S, &[Some(*r)]);
        }
        d.finish((residuals.len() as i64 - 1) * S)
    }

    #[test]
    fn a_short_excursion_is_not_an_alarm() {
        // Outside at t = 2, 3, 4 s, back inside at 5 s: 3 s outside, not longer than 3 s.
        assert!(run(&[0.0, 0.5, 1.5, 2.0, -1.5, 0.2, 0.0], 3.0).is_empty());
    }

    #[test]
    fn a_long_excursion_is_one_alarm_with_its_peak_and_end() {
        // Outside from 2 s to 6 s (back at 6 s): 4 s > 3 s.
        let alarms = run(&[0.0, 0.5, 1.5, 2.0, -2.5, 1.2, 0.9, 0.0], 3.0);
        assert_eq!(alarms.len(), 1);
        let a = &alarms[0];
        assert_eq!(
            (a.start_ns, a.raised_ns, a.end_ns),
            (2 * S, 5 * S, Some(6 * S))
        );
        assert_eq!((a.peak_deviation_k, a.peak_ns), (-2.5, 4 * S));
    }

    #[test]
    fn a_dip_inside_shorter_than_the_clearing_time_does_not_split_an_alarm() {
        // Hold 6 s, clearing 0.6 s: outside 0-4 s, inside at 5 s only, outside 6-9 s, back
        // at 10 s for good. Split at the dip, neither half (5 s, 4 s) would be an alarm.
        let r = [2.0, 2.0, 2.0, 2.0, 2.0, 0.0, 2.0, 2.0, 2.0, 3.0, 0.0, 0.0];
        let alarms = run(&r, 6.0);
        assert_eq!(alarms.len(), 1, "{alarms:?}");
        assert_eq!((alarms[0].start_ns, alarms[0].end_ns), (0, Some(10 * S)));
        assert_eq!(alarms[0].peak_deviation_k, 3.0);
    }

    #[test]
    fn an_excursion_open_at_the_end_is_an_alarm_without_an_end() {
        let alarms = run(&[0.0, 2.0, 2.0, 2.0, 2.0, 3.0], 2.0);
        assert_eq!(alarms.len(), 1);
        assert_eq!(alarms[0].end_ns, None);
        assert_eq!(alarms[0].peak_deviation_k, 3.0);
    }

    #[test]
    fn unknown_residuals_neither_end_nor_extend_an_excursion() {
        let mut d = Detector::new(vec!["a".into(), "b".into()], vec![1.0, 1.0], 2.0);
        d.observe(0, &[Some(2.0), Some(0.0)]);
        d.observe(S, &[None, Some(0.0)]);
        d.observe(2 * S, &[None, Some(0.0)]);
        d.observe(3 * S, &[Some(2.0), Some(0.0)]);
        d.observe(4 * S, &[Some(0.0), Some(0.0)]);
        let alarms = d.finish(4 * S);
        assert_eq!(alarms.len(), 1);
        assert_eq!((alarms[0].state, alarms[0].end_ns), (0, Some(4 * S)));
    }
}
