//! The prediction's page (`heatrun predict --html`): the load schedule, the losses it
//! causes, each part's predicted temperature against its limit, and the peaks.
//!
//! Built from the same pieces as the replay's page: [`Section`]s of a [`Page`], tables
//! of [`Markup`], [`Chart`]s drawn into inline SVG.

use super::markup::{fixed, sig, spoken};
use super::plot::{Chart, Line, Panel, Rgb, TimeAxis};
use super::{HtmlError, Markup, Page, Section, Table};
use crate::colour;
use crate::model_file::ThermalModel;
use crate::predict::{LoadSchedule, Prediction};
use crate::rating::LimitedPart;
use crate::spec::InputSource;

/// Points per drawn line: enough for a day at 1 s to keep every peak.
const BUCKETS: usize = 1500;

/// The limit lines' colour: black, apart from every part's palette colour.
const LIMIT: Rgb = [0, 0, 0];

/// What the prediction's page shows: the model, the schedule, the prediction and the
/// parts' limits (empty when none were asked for).
#[derive(Clone, Copy)]
pub struct PredictionView<'a> {
    /// The model the prediction ran.
    pub model: &'a ThermalModel,
    /// The load schedule.
    pub schedule: &'a LoadSchedule,
    /// The predicted temperatures.
    pub prediction: &'a Prediction,
    /// Limits by part name (a state, or `field_winding_temp` derived from the stator).
    pub limits: &'a [LimitedPart],
}

impl PredictionView<'_> {
    /// The limit of the part `name`, where one was given.
    fn limit_of(&self, name: &str) -> Option<&LimitedPart> {
        self.limits.iter().find(|l| l.name == name)
    }

    /// The parts drawn: each state (index), then the derived field winding (`None`).
    fn parts(&self) -> Vec<(String, Option<usize>)> {
        let p = self.prediction;
        let mut parts: Vec<(String, Option<usize>)> = p
            .states
            .iter()
            .enumerate()
            .map(|(j, s)| (s.clone(), Some(j)))
            .collect();
        if p.field_derived {
            parts.push((
                crate::recording::Quantity::FieldWindingTemp.name().into(),
                None,
            ));
        }
        parts
    }

    /// The 95 % half-width of a part at instant k, K, where the prediction has a band.
    fn half_width(&self, part: Option<usize>, k: usize) -> Option<f64> {
        let column = part.unwrap_or(self.prediction.states.len());
        self.prediction
            .band_c
            .as_ref()
            .and_then(|b| b.half_width_k.get(k)?.get(column).copied())
    }

    /// The temperature of a part at instant k, °C.
    fn temperature(&self, part: Option<usize>, k: usize) -> Option<f64> {
        match part {
            Some(j) => self.prediction.temperatures_c[k].get(j).copied(),
            None => self.prediction.field_temperature_c[k],
        }
    }
}

/// The prediction's page.
pub fn predict_page<'a>(view: PredictionView<'a>) -> Page<'a> {
    let p = view.prediction;
    let (t0, t1) = (
        p.time_s.first().copied().unwrap_or(0.0),
        p.time_s.last().copied().unwrap_or(0.0),
    );
    let mut page = Page::new(
        format!("{}: predicted temperatures", view.model.name),
        format!(
            "Predicted by heatrun {} with the model {} for the load schedule {}",
            env!("CARGO_PKG_VERSION"),
            view.model.path.display(),
            view.schedule.path.display()
        ),
    );
    page.facts = vec![
        ("model".into(), view.model.path.display().to_string()),
        ("schedule".into(), view.schedule.path.display().to_string()),
        ("span".into(), format!("{t0} s to {t1} s")),
        ("sample time".into(), format!("{} s", view.model.ts_s)),
        ("instants".into(), p.time_s.len().to_string()),
    ];
    page.push(ScheduleSection { view })
        .push(LossesSection { view })
        .push(TemperaturesSection { view })
        .push(PeaksSection { view })
        .push(ModelSection { view });
    page
}

/// The load schedule: its rows and the apparent power over time.
struct ScheduleSection<'a> {
    view: PredictionView<'a>,
}

impl Section for ScheduleSection<'_> {
    fn id(&self) -> &str {
        "schedule"
    }

    fn title(&self) -> String {
        "Load schedule".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let s = self.view.schedule;
        out.paragraph(&format!(
            "{} rows from {}; each row holds until the next.",
            s.time_s.len(),
            s.path.display()
        ));
        let generator = s
            .points
            .iter()
            .any(|p| p.armature_current_a.is_normal() || p.line_voltage_v.is_normal());
        out.table(&if generator {
            generator_rows(s)
        } else {
            channel_rows(s)
        });
        for w in &self.view.prediction.warnings {
            out.note("warning", w);
        }
        Ok(())
    }
}

/// The schedule of a generator: apparent power, power factor, currents and voltage.
fn generator_rows(s: &LoadSchedule) -> Table {
    {
        let mut table = Table::new(
            "The schedule's operating points (apparent power from the row, or from the \
             currents and voltage given).",
            [
                "from s",
                "S, MVA",
                "cos φ",
                "I_g, A",
                "I_f, A",
                "U_g, kV",
                "coolant inlet, °C",
            ]
            .map(String::from)
            .to_vec(),
        );
        for (k, (t, point)) in s.time_s.iter().zip(&s.points).enumerate() {
            let (mva, pf) = s
                .apparent_power
                .get(k)
                .copied()
                .unwrap_or((f64::NAN, f64::NAN));
            table.row(
                fixed(*t, 0),
                vec![
                    fixed(mva, 2),
                    fixed(pf, 3),
                    fixed(point.armature_current_a, 0),
                    fixed(point.field_current_a, 0),
                    fixed(point.line_voltage_v / 1e3, 3),
                    point.coolant_inlet_c.map_or("–".into(), |c| fixed(c, 1)),
                ],
            );
        }
        table
    }
}

/// The schedule of a spec's model: the channels its inputs read, as given.
fn channel_rows(s: &LoadSchedule) -> Table {
    let names: std::collections::BTreeSet<&String> =
        s.points.iter().flat_map(|p| p.channels.keys()).collect();
    let mut columns = vec!["from s".to_owned()];
    columns.extend(names.iter().map(|n| n.to_string()));
    let mut table = Table::new("The schedule's channels, as given.", columns);
    for (t, point) in s.time_s.iter().zip(&s.points) {
        let cells = names
            .iter()
            .map(|n| point.channels.get(*n).map_or("–".into(), |v| sig(*v, 4)))
            .collect();
        table.row(fixed(*t, 0), cells);
    }
    table
}

/// The model's inputs (the losses) over the prediction.
struct LossesSection<'a> {
    view: PredictionView<'a>,
}

impl Section for LossesSection<'_> {
    fn id(&self) -> &str {
        "losses"
    }

    fn title(&self) -> String {
        let m = self.view.model;
        if m.inputs
            .iter()
            .all(|i| matches!(i.source, InputSource::Loss(_)))
        {
            "Losses".into()
        } else {
            "Inputs".into()
        }
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let (m, p) = (self.view.model, self.view.prediction);
        let all_losses = m
            .inputs
            .iter()
            .all(|i| matches!(i.source, InputSource::Loss(_)));
        let (unit, scale) = if all_losses {
            ("kW", m.power_base_w / 1e3)
        } else {
            ("as the spec computes them", m.power_base_w)
        };
        let clock = TimeAxis::of_seconds(&p.time_s, "time of the schedule");
        let lines = p
            .inputs
            .iter()
            .enumerate()
            .map(|(i, name)| {
                let values = clock.series_s(&p.time_s, BUCKETS, |k| {
                    p.inputs_model[k].get(i).map(|v| v * scale)
                });
                Line::new(spoken(name), colour::input(i), values)
            })
            .collect();
        let label = if all_losses {
            format!("input, {unit}")
        } else {
            "input".to_owned()
        };
        let chart = Chart::new(&clock.label, vec![Panel::new(label, lines)]);
        out.paragraph(&format!(
            "Figure {} shows the model's inputs over the schedule{}.",
            out.next_figure(),
            if all_losses {
                ": the losses of the profile's loss model, with the resistances at the \
                 predicted temperatures"
            } else {
                ""
            }
        ));
        out.figure(
            &chart.to_svg()?,
            &format!("Inputs over the schedule, {unit}."),
        );
        Ok(())
    }
}

/// Each part's predicted temperature, with its limit where one was given.
struct TemperaturesSection<'a> {
    view: PredictionView<'a>,
}

impl Section for TemperaturesSection<'_> {
    fn id(&self) -> &str {
        "temperatures"
    }

    fn title(&self) -> String {
        "Predicted temperatures".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let v = self.view;
        let p = v.prediction;
        let clock = TimeAxis::of_seconds(&p.time_s, "time of the schedule");
        let (x0, x1) = (
            clock.x_s(p.time_s.first().copied().unwrap_or(0.0)),
            clock.x_s(p.time_s.last().copied().unwrap_or(0.0)),
        );
        let panels = v
            .parts()
            .into_iter()
            .enumerate()
            .map(|(i, (name, part))| {
                let mut lines = Vec::new();
                if p.band_c.is_some() {
                    // The band's edges first, so the prediction is drawn over them.
                    for (edge, sign) in [("95 % band", -1.0), ("", 1.0)] {
                        let values = clock.series_s(&p.time_s, BUCKETS, |k| {
                            Some(v.temperature(part, k)? + sign * v.half_width(part, k)?)
                        });
                        lines.push(Line::new(edge, colour::part(i), values).dashed());
                    }
                }
                lines.push(Line::new(
                    "predicted",
                    colour::part(i),
                    clock.series_s(&p.time_s, BUCKETS, |k| v.temperature(part, k)),
                ));
                if let Some(limit) = v.limit_of(&name) {
                    lines.push(
                        Line::new(
                            format!("limit ({})", limit.limit_from),
                            LIMIT,
                            vec![vec![(x0, limit.limit_c), (x1, limit.limit_c)]],
                        )
                        .dashed(),
                    );
                }
                Panel::new(format!("{}, °C", spoken(&name)), lines)
            })
            .collect();
        let chart = Chart::new(&clock.label, panels);
        out.paragraph(&format!(
            "Figure {} shows each part's predicted temperature{}{}.",
            out.next_figure(),
            match &p.band_c {
                Some(b) => format!(
                    " between the edges of its 95 % band (thin dashed: from the {}; mean \
                     half-width {} K)",
                    b.sources.join(", "),
                    fixed(b.mean_half_width_k(), 3)
                ),
                None => String::new(),
            },
            if v.limits.is_empty() {
                "; no insulation class or limit was given, so no limits are drawn"
            } else {
                ", with its limit dashed"
            }
        ));
        out.figure(
            &chart.to_svg()?,
            "Predicted temperature per part over the schedule, °C.",
        );
        Ok(())
    }
}

/// The peak temperatures, when they occur, and the margins to the limits.
struct PeaksSection<'a> {
    view: PredictionView<'a>,
}

impl Section for PeaksSection<'_> {
    fn id(&self) -> &str {
        "peaks"
    }

    fn title(&self) -> String {
        "Peak temperatures".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let v = self.view;
        let p = v.prediction;
        let mut table = Table::new(
            "Each part's start and peak temperature, when the peak occurs, and its margin to \
             the limit (limit − peak); the smallest margin emphasised.",
            [
                "part",
                "start, °C",
                "peak, °C",
                "at, s",
                "limit, °C",
                "margin, K",
            ]
            .map(String::from)
            .to_vec(),
        );
        let mut least: Option<(f64, usize)> = None;
        for (row, (name, part)) in v.parts().into_iter().enumerate() {
            let (peak, at) = (0..p.time_s.len())
                .filter_map(|k| v.temperature(part, k).map(|t| (t, p.time_s[k])))
                .fold(
                    (f64::NEG_INFINITY, f64::NAN),
                    |m, x| if x.0 > m.0 { x } else { m },
                );
            let start = v.temperature(part, 0).unwrap_or(f64::NAN);
            let limit = v.limit_of(&name).map(|l| l.limit_c);
            let margin = limit.map(|l| l - peak);
            if let Some(m) = margin {
                if least.is_none_or(|(b, _)| m < b) {
                    least = Some((m, row));
                }
            }
            table.row(
                spoken(&name),
                vec![
                    fixed(start, 2),
                    fixed(peak, 2),
                    fixed(at, 0),
                    limit.map_or("–".into(), |l| fixed(l, 1)),
                    margin.map_or("–".into(), |m| fixed(m, 2)),
                ],
            );
        }
        if let Some((_, row)) = least {
            table.emphasised.push((row, 4));
        }
        out.table(&table);
        if let Some((m, _)) = least.filter(|(m, _)| *m < 0.0) {
            out.note(
                "warning",
                &format!(
                    "A part exceeds its limit, by {} K at its peak.",
                    fixed(-m, 2)
                ),
            );
        }
        Ok(())
    }
}

/// The model the prediction used: its time constants and its own error.
struct ModelSection<'a> {
    view: PredictionView<'a>,
}

impl Section for ModelSection<'_> {
    fn id(&self) -> &str {
        "model"
    }

    fn title(&self) -> String {
        "The model".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let m = self.view.model;
        out.paragraph(&format!(
            "The model of {} ({} states, {} inputs, Ts = {} s), from the report {}; \
             time constants {} s. Its error ({}) bounds what a prediction can promise.",
            m.name,
            m.states.len(),
            m.inputs.len(),
            m.ts_s,
            m.path.display(),
            m.time_constants_s
                .iter()
                .map(|t| sig(*t, 4))
                .collect::<Vec<_>>()
                .join(", "),
            m.error.source
        ));
        let mut table = Table::new(
            format!("The model's error per state ({}).", m.error.source),
            ["state", "part", "RMSE, K", "largest error, K"]
                .map(String::from)
                .to_vec(),
        );
        for (j, s) in m.states.iter().enumerate() {
            table.row(
                spoken(&s.name),
                vec![
                    s.part.clone(),
                    m.error.rmse_k.get(j).map_or("–".into(), |v| sig(*v, 3)),
                    m.error
                        .max_abs_error_k
                        .get(j)
                        .map_or("–".into(), |v| sig(*v, 3)),
                ],
            );
        }
        out.table(&table);
        Ok(())
    }
}
