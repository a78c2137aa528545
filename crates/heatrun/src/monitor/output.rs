//! A [`MonitorResult`] for people (one line per alarm, a short summary) and as JSON
//! (`heatrun monitor --json`: the alarms and each part's residual, written complete or
//! not at all).

use std::fmt::Write as _;
use std::path::Path;

use super::{Alarm, Band, MonitorResult, PartStats};
use crate::recording::format_time;

/// The JSON document's `kind`: what the file is, versioned like the profile.
pub const KIND: &str = "heatrun-monitor/1";

/// One alarm in the JSON document: times in s from the recording's first grid instant
/// and as RFC 3339.
#[derive(Debug, Clone, serde::Serialize)]
pub struct AlarmEntry {
    /// The state's name.
    pub state: String,
    /// The physical part.
    pub part: String,
    /// First instant outside the band, s.
    pub start_s: f64,
    /// The same, RFC 3339.
    pub start_time: String,
    /// When raised (start + hold), s.
    pub raised_s: f64,
    /// First instant back inside, s; `null` if still outside at the recording's end.
    pub end_s: Option<f64>,
    /// The same, RFC 3339.
    pub end_time: Option<String>,
    /// Largest θ − θ̂ during the alarm, K (positive: hotter than the model).
    pub peak_deviation_k: f64,
    /// When, s.
    pub peak_s: f64,
    /// The band it left, K.
    pub band_k: f64,
}

/// The JSON document of `heatrun monitor --json`.
#[derive(Debug, Clone, serde::Serialize)]
pub struct MonitorDocument {
    /// Always [`KIND`].
    pub kind: &'static str,
    /// heatrun's version.
    pub heatrun_version: &'static str,
    /// The recording monitored.
    pub recording: String,
    /// The model's report.
    pub model: String,
    /// Ts, s.
    pub sample_time_s: f64,
    /// First grid instant, RFC 3339.
    pub start_time: String,
    /// Span of the grid, s.
    pub duration_s: f64,
    /// Whether no alarm was raised.
    pub healthy: bool,
    /// The band and how it was set.
    pub band: Band,
    /// The hold time, s.
    pub hold_s: f64,
    /// The alarms, in the order raised.
    pub alarms: Vec<AlarmEntry>,
    /// Each part's residual.
    pub parts: Vec<PartStats>,
    /// Restarts of the model from the measured state after gaps.
    pub restarts: usize,
    /// Damage to the recording.
    pub data_loss: Vec<String>,
    /// Warnings about the comparison.
    pub warnings: Vec<String>,
}

impl MonitorResult {
    fn entry(&self, a: &Alarm) -> AlarmEntry {
        AlarmEntry {
            state: a.state_name.clone(),
            part: self.parts[a.state].clone(),
            start_s: self.seconds(a.start_ns),
            start_time: format_time(a.start_ns as u64),
            raised_s: self.seconds(a.raised_ns),
            end_s: a.end_ns.map(|t| self.seconds(t)),
            end_time: a.end_ns.map(|t| format_time(t as u64)),
            peak_deviation_k: a.peak_deviation_k,
            peak_s: self.seconds(a.peak_ns),
            band_k: a.band_k,
        }
    }

    /// The JSON document.
    pub fn document(&self) -> MonitorDocument {
        let end = self.traces.time_ns.last().copied().unwrap_or(0);
        MonitorDocument {
            kind: KIND,
            heatrun_version: env!("CARGO_PKG_VERSION"),
            recording: self.recording.display().to_string(),
            model: self.model.display().to_string(),
            sample_time_s: self.ts_s,
            start_time: format_time(self.start_ns() as u64),
            duration_s: self.seconds(end),
            healthy: self.healthy(),
            band: self.band.clone(),
            hold_s: self.hold_s,
            alarms: self.alarms.iter().map(|a| self.entry(a)).collect(),
            parts: self.stats.clone(),
            restarts: self.restarts,
            data_loss: self.data_loss.clone(),
            warnings: self.warnings.clone(),
        }
    }

    /// Writes [`Self::document`] to `path`, complete or not at all.
    pub fn write_json(&self, path: &Path) -> Result<(), crate::atomic::WriteError> {
        let text = serde_json::to_string_pretty(&self.document())
            .map_err(|e| crate::atomic::WriteError::new(path, e))?;
        crate::atomic::write_atomically(path, text.as_bytes())
    }

    /// One line for an alarm: part, start, end, peak.
    pub fn alarm_line(&self, a: &Alarm) -> String {
        let e = self.entry(a);
        let end = match (e.end_s, &e.end_time) {
            (Some(s), Some(t)) => format!("until {s:.0} s ({t})"),
            _ => "still outside at the end".into(),
        };
        format!(
            "ALARM {}: from {:.0} s ({}) {end}, raised at {:.0} s; peak {:+.2} K at {:.0} s (band ±{:.2} K)",
            e.state, e.start_s, e.start_time, e.raised_s, e.peak_deviation_k, e.peak_s, e.band_k
        )
    }

    /// The alarm lines and a short summary: per part the residual against its band.
    pub fn summary(&self) -> String {
        let mut s = String::new();
        for a in &self.alarms {
            let _ = writeln!(s, "{}", self.alarm_line(a));
        }
        let end = self.traces.time_ns.last().copied().unwrap_or(0);
        let _ = writeln!(
            s,
            "monitored {} ({} instants, {:.0} s at Ts = {} s) with the model {}: {}",
            self.recording.display(),
            self.traces.time_ns.len(),
            self.seconds(end),
            self.ts_s,
            self.model.display(),
            match self.alarms.len() {
                0 => "healthy, no alarm".to_owned(),
                1 => "1 alarm".to_owned(),
                n => format!("{n} alarms"),
            }
        );
        let _ = match self.band.kind {
            super::BandKind::Fixed => writeln!(
                s,
                "band: {} × the model's RMSE ({}), at least {} K; hold {} s",
                self.band.factor, self.band.source, self.band.floor_k, self.hold_s
            ),
            super::BandKind::Model => writeln!(
                s,
                "band: {} × the standard deviation of the model's prediction and the sensors' \
                 noise at each instant (the column: its mean); hold {} s",
                self.band.factor, self.hold_s
            ),
        };
        let _ = writeln!(
            s,
            "  {:<28}{:>9}{:>10}{:>10}{:>12}{:>10}",
            "state", "band K", "mean K", "RMS K", "largest K", "outside"
        );
        for p in &self.stats {
            let _ = writeln!(
                s,
                "  {:<28}{:>9.2}{:>10.3}{:>10.3}{:>12.2}{:>9.1}%",
                p.state,
                p.band_k,
                p.mean_k,
                p.rms_k,
                p.max_deviation_k,
                p.outside_fraction * 100.0
            );
        }
        if self.restarts > 0 {
            let _ = writeln!(
                s,
                "the model restarted from the measured state after {} gap(s)",
                self.restarts
            );
        }
        s
    }
}
