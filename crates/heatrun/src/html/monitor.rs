//! The monitoring page (`heatrun monitor --html`): the recording and the model
//! monitored, the verdict, per part the measured against the model's temperature with
//! the residual r = θ − θ̂ below in its ± band and the alarms shaded, the alarm table,
//! the residual statistics, the band rule, and the warnings.
//!
//! Built from the same pieces as the replay's page: [`Section`]s of a [`Page`], tables
//! of [`Markup`], [`Chart`]s drawn into inline SVG.

use super::markup::{fixed, sig, spoken};
use super::plot::{Chart, Line, Panel, TimeAxis};
use super::{HtmlError, Markup, Page, Section, Table};
use crate::colour;
use crate::monitor::alarm::CLEAR_SHARE_OF_HOLD;
use crate::monitor::{Alarm, MonitorResult};
use crate::recording::format_time;

/// Points per drawn line: enough for a day at 1 s to keep every peak.
const BUCKETS: usize = 1500;

/// The file name of a path, for titles (the whole path where it has none).
fn file_name(path: &std::path::Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into(),
    )
}

/// The verdict in words: "healthy, no alarm", "1 alarm", "N alarms".
fn verdict(result: &MonitorResult) -> String {
    match result.alarms.len() {
        0 => "healthy, no alarm".into(),
        1 => "1 alarm".into(),
        n => format!("{n} alarms"),
    }
}

/// A library warning (a clause for `warning: …` on stderr) as a sentence of the page.
fn sentence(clause: &str) -> String {
    let mut chars = clause.chars();
    let Some(first) = chars.next() else {
        return String::new();
    };
    let end = if clause.ends_with('.') { "" } else { "." };
    format!("{}{}{end}", first.to_uppercase(), chars.as_str())
}

/// The monitoring page of `result`.
pub fn monitor_page(result: &MonitorResult) -> Page<'_> {
    let time = &result.traces.time_ns;
    let end_ns = time.last().copied().unwrap_or(0);
    let mut page = Page::new(
        format!("{}: monitoring", file_name(&result.recording)),
        format!(
            "Monitored by heatrun {} with the model {}",
            env!("CARGO_PKG_VERSION"),
            result.model.display()
        ),
    );
    page.facts = vec![
        ("verdict".into(), verdict(result)),
        ("recording".into(), result.recording.display().to_string()),
        ("model".into(), result.model.display().to_string()),
        ("start".into(), format_time(result.start_ns() as u64)),
        (
            "span".into(),
            format!(
                "{} s ({} h)",
                fixed(result.seconds(end_ns), 0),
                sig(result.seconds(end_ns) / 3600.0, 3)
            ),
        ),
        ("sample time".into(), format!("{} s", result.ts_s)),
        ("instants".into(), time.len().to_string()),
    ];
    page.push(VerdictSection { result })
        .push(PartsSection { result })
        .push(AlarmsSection { result })
        .push(ResidualsSection { result })
        .push(BandSection { result })
        .push(WarningsSection { result });
    page
}

/// The verdict: healthy or how many alarms on which parts.
struct VerdictSection<'a> {
    result: &'a MonitorResult,
}

impl Section for VerdictSection<'_> {
    fn id(&self) -> &str {
        "verdict"
    }

    fn title(&self) -> String {
        "Verdict".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let r = self.result;
        let end_ns = r.traces.time_ns.last().copied().unwrap_or(0);
        out.paragraph(&format!(
            "The model {} ran beside the recording {} ({} instants over {} s at Ts = {} s), \
             from the recording's own first measured state, and each part's measured \
             temperature was compared with the model's.",
            r.model.display(),
            r.recording.display(),
            r.traces.time_ns.len(),
            fixed(r.seconds(end_ns), 0),
            r.ts_s
        ));
        if r.healthy() {
            out.note(
                "note",
                &format!(
                    "Healthy: no part left its band for longer than the hold time ({} s).",
                    r.hold_s
                ),
            );
        } else {
            let mut parts: Vec<String> = Vec::new();
            for a in &r.alarms {
                let part = spoken(&r.parts[a.state]);
                if !parts.contains(&part) {
                    parts.push(part);
                }
            }
            out.note(
                "warning",
                &format!(
                    "{}: a part left its band for longer than the hold time ({} s) — {}.",
                    verdict(r),
                    r.hold_s,
                    parts.join(", ")
                ),
            );
        }
        if r.restarts > 0 {
            out.paragraph(&format!(
                "The model restarted from the measured state after {} gap(s) in the inputs.",
                r.restarts
            ));
        }
        Ok(())
    }
}

/// Per part: measured against model, the residual in its band, the alarms shaded.
struct PartsSection<'a> {
    result: &'a MonitorResult,
}

impl PartsSection<'_> {
    fn chart(&self, j: usize, axis: &TimeAxis) -> Chart {
        let r = self.result;
        let tr = &r.traces;
        let t = &tr.time_ns;
        let last = t.last().copied().unwrap_or(0);
        let spans: Vec<(f64, f64)> = r
            .alarms
            .iter()
            .filter(|a| a.state == j)
            .map(|a| (axis.x_ns(a.start_ns), axis.x_ns(a.end_ns.unwrap_or(last))))
            .collect();
        let mut top = Panel::new(
            format!("{}, °C", spoken(&r.parts[j])),
            vec![
                Line::measured(
                    "measured",
                    j,
                    axis.series_ns(t, BUCKETS, |k| tr.measured[j].get(k)),
                ),
                Line::new(
                    "model",
                    colour::part(j),
                    axis.series_ns(t, BUCKETS, |k| tr.predicted[j].get(k)),
                ),
            ],
        );
        top.weight = 2;
        top.spans = spans.clone();
        let band = r.band.half_width_k[j];
        let mut bottom = Panel::new(
            "residual θ − θ̂, K",
            vec![Line::new(
                "residual",
                colour::part(j),
                axis.series_ns(t, BUCKETS, |k| tr.residual(j, k)),
            )],
        );
        bottom.band = Some((-band, band));
        bottom.spans = spans;
        Chart::new(&axis.label, vec![top, bottom])
    }
}

impl Section for PartsSection<'_> {
    fn id(&self) -> &str {
        "parts"
    }

    fn title(&self) -> String {
        "Measured and model temperatures".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let r = self.result;
        let axis = TimeAxis::of_ns(&r.traces.time_ns);
        let n = r.states.len();
        let first = out.next_figure();
        out.paragraph(&format!(
            "Figures {first}–{} show each part's measured temperature against the model's, \
             with the residual θ − θ̂ below in its band (shaded grey); stretches that became \
             alarms are shaded red.",
            first + n.max(1) - 1
        ));
        for j in 0..n {
            let stats = &r.stats[j];
            let alarms = r.alarms.iter().filter(|a| a.state == j).count();
            let caption = format!(
                "{}: measured (wide, light) and model; below, the residual in its band ±{} K. \
                 RMS residual {} K, {} % of the instants outside, {}.",
                spoken(&r.parts[j]),
                fixed(r.band.half_width_k[j], 2),
                sig(stats.rms_k, 3),
                fixed(stats.outside_fraction * 100.0, 1),
                match alarms {
                    0 => "no alarm".to_owned(),
                    1 => "1 alarm".to_owned(),
                    n => format!("{n} alarms"),
                }
            );
            out.figure(&self.chart(j, &axis).to_svg()?, &caption);
        }
        Ok(())
    }
}

/// The alarms: part, start, end, when raised, the peak deviation.
struct AlarmsSection<'a> {
    result: &'a MonitorResult,
}

/// An alarm's cells: times in s from the first instant, the peak, the band.
fn alarm_row(r: &MonitorResult, a: &Alarm) -> Vec<String> {
    vec![
        fixed(r.seconds(a.start_ns), 0),
        a.end_ns.map_or("still outside at the end".into(), |t| {
            fixed(r.seconds(t), 0)
        }),
        fixed(r.seconds(a.raised_ns), 0),
        format!("{:+.2}", a.peak_deviation_k),
        fixed(r.seconds(a.peak_ns), 0),
        fixed(a.band_k, 2),
    ]
}

impl Section for AlarmsSection<'_> {
    fn id(&self) -> &str {
        "alarms"
    }

    fn title(&self) -> String {
        "Alarms".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let r = self.result;
        if r.alarms.is_empty() {
            out.paragraph("No alarm was raised.");
            return Ok(());
        }
        let mut table = Table::new(
            format!(
                "The alarms in the order raised, times in s from the first instant ({}): \
                 the first instant outside the band, the first instant back inside (or still \
                 outside at the end), when the alarm was raised (start + hold), and the \
                 largest deviation θ − θ̂ (positive: hotter than the model).",
                format_time(r.start_ns() as u64)
            ),
            [
                "part",
                "start, s",
                "end, s",
                "raised at, s",
                "peak deviation, K",
                "peak at, s",
                "band, ± K",
            ]
            .map(String::from)
            .to_vec(),
        );
        for a in &r.alarms {
            table.row(spoken(&r.parts[a.state]), alarm_row(r, a));
        }
        out.table(&table);
        Ok(())
    }
}

/// Each part's residual over the recording.
struct ResidualsSection<'a> {
    result: &'a MonitorResult,
}

impl Section for ResidualsSection<'_> {
    fn id(&self) -> &str {
        "residuals"
    }

    fn title(&self) -> String {
        "Residual statistics".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let r = self.result;
        let mut table = Table::new(
            "Each part's residual θ − θ̂ over the recording: its band, mean, RMS, the \
             largest deviation (signed) and when, and the share of instants outside the band.",
            [
                "part",
                "band, ± K",
                "instants",
                "mean, K",
                "RMS, K",
                "largest, K",
                "at, s",
                "outside, %",
            ]
            .map(String::from)
            .to_vec(),
        );
        for p in &r.stats {
            table.row(
                spoken(&p.part),
                vec![
                    fixed(p.band_k, 2),
                    p.instants.to_string(),
                    fixed(p.mean_k, 3),
                    fixed(p.rms_k, 3),
                    fixed(p.max_deviation_k, 2),
                    fixed(p.max_deviation_at_s, 0),
                    fixed(p.outside_fraction * 100.0, 1),
                ],
            );
        }
        out.table(&table);
        Ok(())
    }
}

/// How the band and the hold were set.
struct BandSection<'a> {
    result: &'a MonitorResult,
}

impl Section for BandSection<'_> {
    fn id(&self) -> &str {
        "band"
    }

    fn title(&self) -> String {
        "The band rule".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let r = self.result;
        let b = &r.band;
        let rule = match b.kind {
            crate::monitor::BandKind::Fixed => format!(
                "Each part's band is b = max({} × RMSE, {} K), the RMSE the model's own error \
                 ({}).",
                b.factor, b.floor_k, b.source
            ),
            crate::monitor::BandKind::Model => format!(
                "Each part's band is set at each instant from what the model knows then: \
                 b(k) = {} × √(var θ̂(k) + σ²), the prediction's variance from the \
                 identification's covariance, the noise of the start it ran from (and the \
                 process noise where the model has one), σ the sensors' noise; the table and \
                 the figures give its mean over the recording.",
                b.factor
            ),
        };
        out.paragraph(&format!(
            "{rule} A residual outside its band for longer than the hold time, {} s, is an \
             alarm, raised the hold time after it left the band; it ends once the residual \
             has stayed inside for {} s.",
            r.hold_s,
            sig(CLEAR_SHARE_OF_HOLD * r.hold_s, 3)
        ));
        let mut table = Table::new(
            format!(
                "The model's error per part ({}) and the band set from it.",
                b.source
            ),
            ["part", "model RMSE, K", "band, ± K"]
                .map(String::from)
                .to_vec(),
        );
        for (j, part) in r.parts.iter().enumerate() {
            table.row(
                spoken(part),
                vec![
                    b.model_rmse_k.get(j).map_or("–".into(), |v| sig(*v, 3)),
                    fixed(b.half_width_k[j], 2),
                ],
            );
        }
        out.table(&table);
        Ok(())
    }
}

/// What the user should know: the comparison's warnings and damage to the recording.
struct WarningsSection<'a> {
    result: &'a MonitorResult,
}

impl Section for WarningsSection<'_> {
    fn id(&self) -> &str {
        "warnings"
    }

    fn title(&self) -> String {
        "Warnings".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let r = self.result;
        if r.warnings.is_empty() && r.data_loss.is_empty() {
            out.paragraph("None: the recording was read whole and the comparison needs no caveat.");
        }
        for w in &r.warnings {
            out.note("warning", &sentence(w));
        }
        for line in &r.data_loss {
            out.note("warning", &format!("Data lost: {line}"));
        }
        Ok(())
    }
}
