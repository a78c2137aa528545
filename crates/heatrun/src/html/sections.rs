//! The sections of the replay's page, in the order of the paper's results section: each
//! a struct over the [`Report`] (tables) and, for the time series, the [`Replay`].

use std::fmt::Write as _;

use super::markup::{fixed, si, sig, Markup, Table};
use super::network::{diagram, short_name};
use super::plot::{Chart, Line, Panel, Thinning, TimeAxis, GREY};
use super::{HtmlError, Section};
use crate::colour;
use crate::estimate::Method;
use crate::model_file::document::{FitEntry, NetworkEntry};
use crate::model_file::Report;
use crate::pipeline::{Replay, ReplayOptions, ValidationSource};
use crate::spec::Scaling;

/// Buckets a time series is thinned to (up to four points each): enough for a page's width.
const BUCKETS: usize = 800;

/// Whether the report's model is a hidden-state one (the spec declares `[hidden]`): Φ,
/// Γ, A_c, B_c, the residuals and the network are then the measured-state model's, and
/// the page says so where it shows them.
fn hidden_is_the_model(r: &Report) -> bool {
    r.hidden.as_ref().is_some_and(|h| h.replay_model)
}

/// The page's subtitle: which heatrun, which recording, how the model was estimated (the
/// hidden-state model's own way where it is the report's model, not the measured-state
/// model's estimator beside it) and at which sample time.
pub(super) fn subtitle(r: &Report) -> String {
    let how = if hidden_is_the_model(r) {
        "hidden-state model: subspace start, output error".to_string()
    } else {
        format!("{} estimate", r.method)
    };
    format!(
        "Identified by heatrun {} from {} ({how}, Ts = {} s)",
        r.heatrun_version, r.recording.path, r.sample_time_s
    )
}

/// " of the measured-state model" where the report's model is a hidden-state one, else
/// nothing: for the captions of what stays the measured-state model's.
fn of_the_measured_state_model(r: &Report) -> &'static str {
    if hidden_is_the_model(r) {
        " of the measured-state model"
    } else {
        ""
    }
}

/// The page's title: the heat run's test id or file, or the spec's name.
pub fn recording_title(report: &Report) -> String {
    let file = std::path::Path::new(&report.recording.path)
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_else(|| report.recording.path.clone());
    match report.model.scaling {
        Scaling::NameplatePerUnit => format!("Heat run {file}"),
        Scaling::AsRecorded => format!("{} ({file})", report.model.name),
    }
}

/// A metadata value of the recording (`heatrun.test` → `test_id`).
fn metadata<'a>(report: &'a Report, record: &str, key: &str) -> Option<&'a str> {
    report
        .recording
        .metadata
        .get(record)
        .and_then(|r| r.get(key))
        .map(String::as_str)
}

/// The recording's span in seconds, from its first to its last sample.
fn span_s(report: &Report) -> f64 {
    report.estimation.instants as f64 * report.sample_time_s
}

/// The facts at the top of the page: test id, site, machine, span, method, constants.
pub fn header_facts(report: &Report) -> Vec<(String, String)> {
    let mut facts = Vec::new();
    for (label, key) in [("test id", "test_id"), ("site", "site"), ("test", "kind")] {
        if let Some(v) = metadata(report, "heatrun.test", key) {
            facts.push((label.to_owned(), v.to_owned()));
        }
    }
    if let Some(np) = &report.nameplate {
        facts.push((
            "machine".into(),
            format!(
                "{} MVA, {} kV, {} A",
                sig(np.rated_apparent_power_va / 1e6, 4),
                sig(np.rated_voltage_v / 1e3, 4),
                sig(np.rated_current_a, 4)
            ),
        ));
    } else {
        facts.push(("system".into(), report.model.name.clone()));
    }
    facts.push((
        "recorded".into(),
        format!(
            "{} ({:.2} h)",
            report.recording.start.as_deref().unwrap_or("?"),
            span_s(report) / 3600.0
        ),
    ));
    facts.push((
        "time constants".into(),
        report
            .time_constants_s
            .iter()
            .map(|t| format!("{} s", sig(*t, 4)))
            .collect::<Vec<_>>()
            .join(", "),
    ));
    let fit: Vec<String> = report
        .fit
        .nrmse_fit_percent
        .iter()
        .map(|v| fixed(*v, 1))
        .collect();
    facts.push(("NRMSE fit, %".into(), fit.join(", ")));
    match report.hidden.as_ref().filter(|h| h.replay_model) {
        // The time constants and fit above are the hidden-state model's; the method is
        // the measured-state model's estimator.
        Some(h) => {
            facts.push((
                "model".into(),
                format!(
                    "hidden states: {} states, {} measured (subspace start, output error)",
                    h.order,
                    report.model.states.len()
                ),
            ));
            facts.push((
                "measured-state model".into(),
                format!("{} (heatrun {})", report.method, report.heatrun_version),
            ));
        }
        None => facts.push((
            "estimator".into(),
            format!("{} (heatrun {})", report.method, report.heatrun_version),
        )),
    }
    facts
}

/// The unit of a state's values for people (`degC` → °C) and of its rise (K).
fn state_units(unit: &str) -> (String, String) {
    match unit {
        "degC" | "°C" | "C" => ("°C".into(), "K".into()),
        "K" => ("K".into(), "K".into()),
        "degF" | "°F" => ("°F".into(), "°F".into()),
        other => (other.to_owned(), other.to_owned()),
    }
}

/// The states' short names (table columns).
fn state_labels(report: &Report) -> Vec<String> {
    report
        .model
        .states
        .iter()
        .map(|s| short_name(&s.part).to_owned())
        .collect()
}

/// A series on the replay's grid, thinned for drawing.
fn grid_series(
    replay: &Replay,
    axis: &TimeAxis,
    values: impl Iterator<Item = Option<f64>>,
) -> Vec<Vec<(f64, f64)>> {
    let t = &replay.signals.time_ns;
    let mut thin = Thinning::new(t.len(), BUCKETS);
    for (k, v) in values.enumerate().take(t.len()) {
        thin.push(k, axis.x_ns(t[k]), v);
    }
    thin.finish()
}

/// The recording: its file, span, metadata, nameplate, channels and data quality.
pub struct RecordingSection<'a> {
    /// The report.
    pub report: &'a Report,
}

impl Section for RecordingSection<'_> {
    fn id(&self) -> &str {
        "recording"
    }

    fn title(&self) -> String {
        "The recording".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let r = self.report;
        let rec = &r.recording;
        out.paragraph(&format!(
            "{} ({:.1} MB) holds {} heat-run channels from {} to {} ({:.0} s, {:.2} h). \
             They are laid on a grid of Ts = {} s: {} instants in {} contiguous segment(s).",
            rec.path,
            rec.file_bytes as f64 / 1e6,
            rec.channels.len(),
            rec.start.as_deref().unwrap_or("?"),
            rec.end.as_deref().unwrap_or("?"),
            span_s(r),
            span_s(r) / 3600.0,
            r.sample_time_s,
            r.estimation.instants,
            r.estimation.segments
        ));
        for (name, record) in &rec.metadata {
            let mut t = Table::new(
                format!("Metadata record {name}."),
                vec!["key".into(), "value".into()],
            );
            for (k, v) in record {
                t.row(k.clone(), vec![v.clone()]);
            }
            out.table(&t);
        }
        nameplate_table(out, r);
        channels_table(out, r);
        data_quality(out, r);
        Ok(())
    }
}

fn nameplate_table(out: &mut Markup, r: &Report) {
    let Some(np) = &r.nameplate else {
        out.note(
            "note",
            "The model needs no nameplate: states and inputs are in the channels' units.",
        );
        return;
    };
    let mut t = Table::new(
        "Nameplate (the recording's heatrun.nameplate record, with any machine file's keys).",
        vec!["key".into(), "value".into()],
    );
    if let Ok(serde_json::Value::Object(map)) = serde_json::to_value(np) {
        for (k, v) in map {
            let v = match v {
                serde_json::Value::Null => continue,
                serde_json::Value::Number(n) => n.as_f64().map_or(n.to_string(), |x| sig(x, 6)),
                other => other.to_string(),
            };
            t.row(k, vec![v]);
        }
    }
    out.table(&t);
}

fn channels_table(out: &mut Markup, r: &Report) {
    let mut t = Table::new(
        "Channels read: samples, median sample period and gaps.",
        [
            "topic",
            "quantity",
            "sensor",
            "unit",
            "samples",
            "period, s",
            "gaps",
        ]
        .map(String::from)
        .to_vec(),
    );
    for c in &r.recording.channels {
        t.row(
            c.topic.clone(),
            vec![
                c.quantity.clone(),
                c.sensor.clone().unwrap_or_else(|| "–".into()),
                c.unit.clone(),
                c.samples.to_string(),
                sig(c.nominal_period_s, 4),
                c.gaps.to_string(),
            ],
        );
    }
    out.table(&t);
    if !r.recording.ignored_channels.is_empty() {
        out.subheading("Channels not read");
        let items: Vec<String> = r
            .recording
            .ignored_channels
            .iter()
            .map(|c| format!("{}: {}", c.topic, c.reason))
            .collect();
        out.list(&items);
    }
}

fn data_quality(out: &mut Markup, r: &Report) {
    out.subheading("Data quality");
    let rec = &r.recording;
    let mut items: Vec<String> = rec
        .data_loss
        .iter()
        .map(|d| format!("data lost: {d}"))
        .collect();
    if rec.bad_quality_dropped > 0 {
        items.push(format!(
            "{} samples marked bad were dropped",
            rec.bad_quality_dropped
        ));
    }
    items.extend(r.warnings.iter().cloned());
    if items.is_empty() {
        out.note(
            "ok",
            "No warnings: no data lost, no bad samples, no gaps or implausible values found.",
        );
    } else {
        out.raw("<div class=\"warning\">\n");
        out.list(&items);
        out.raw("</div>\n");
    }
}

/// The inputs (heat sources) over time (the paper's Fig. 2).
pub struct InputsSection<'a> {
    /// The replay.
    pub replay: &'a Replay,
}

/// The inputs' plotted unit and the factor from the model's scaling to it.
fn input_unit(replay: &Replay) -> (String, f64) {
    let s = &replay.signals;
    match replay.model.scaling {
        Scaling::NameplatePerUnit => ("kW".into(), s.power_base / 1e3),
        Scaling::AsRecorded => {
            let mut units: Vec<&str> = s.inputs.iter().map(|i| i.unit.as_str()).collect();
            units.dedup();
            (units.join(", "), s.power_base)
        }
    }
}

impl Section for InputsSection<'_> {
    fn id(&self) -> &str {
        "inputs"
    }

    fn title(&self) -> String {
        "Inputs".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let r = self.replay;
        let axis = TimeAxis::of_ns(&r.signals.time_ns);
        let (unit, scale) = input_unit(r);
        let lines = r
            .signals
            .inputs
            .iter()
            .enumerate()
            .map(|(j, input)| {
                let values = input.values.iter().map(|v| v.map(|v| v * scale));
                Line::new(
                    input.name.replace('_', " "),
                    colour::input(j),
                    grid_series(r, &axis, values),
                )
            })
            .collect();
        let chart = Chart::new(
            &axis.label,
            vec![Panel::new(format!("input, {unit}"), lines)],
        );
        let what = match r.model.scaling {
            Scaling::NameplatePerUnit => {
                "the armature and field copper losses and the iron losses, as the loss model \
                 computes them from the recorded currents, voltages and temperatures"
            }
            Scaling::AsRecorded => "the model's inputs, as the spec computes them",
        };
        out.paragraph(&format!(
            "Figure {} shows the excitation applied to the thermal system (the paper's Fig. 2): {what}.",
            out.next_figure()
        ));
        out.figure(
            &chart.to_svg()?,
            &format!("Inputs over the recording, {unit}."),
        );
        Ok(())
    }
}

/// Measured against model temperature per part, with the residual below (Figs. 3–5).
pub struct TemperaturesSection<'a> {
    /// The replay.
    pub replay: &'a Replay,
    /// Its report (the fit figures of the captions).
    pub report: &'a Report,
}

impl TemperaturesSection<'_> {
    /// State `j` measured against the replay's model's simulated rises `sim` (N × states,
    /// pu), its residual below; with `[hidden]`, `sim` is the hidden-state model's outputs
    /// and the measured-state model's simulation is drawn beside it in grey.
    fn chart(&self, j: usize, axis: &TimeAxis, sim: &nalgebra::DMatrix<f64>) -> Chart {
        let r = self.replay;
        let s = &r.signals;
        let state = &s.states[j];
        let base = s.temperature_base_k;
        let (unit, rise_unit) = state_units(&r.model.states[j].unit);
        let measured = grid_series(r, axis, state.measured.iter());
        let temperature = |sim: &nalgebra::DMatrix<f64>| {
            grid_series(
                r,
                axis,
                (0..s.len()).map(|k| Some(state.reference_at(k)? + base * sim[(k, j)])),
            )
        };
        let residual = grid_series(
            r,
            axis,
            (0..s.len()).map(|k| s.rise_pu(j, k).map(|y| base * (y - sim[(k, j)]))),
        );
        let mut lines = vec![Line::measured("measured", j, measured)];
        if r.hidden.is_some() {
            lines.push(Line::new(
                "measured-state model",
                GREY,
                temperature(&r.analysis.simulated),
            ));
            lines.push(Line::new(
                "hidden-state model",
                colour::part(j),
                temperature(sim),
            ));
        } else {
            lines.push(Line::new("model", colour::part(j), temperature(sim)));
        }
        let mut top = Panel::new(format!("{}, {unit}", short_name(&state.part)), lines);
        top.weight = 2;
        let bottom = Panel::new(
            format!("residual, {rise_unit}"),
            vec![Line::new("", colour::part(j), residual)],
        );
        Chart::new(&axis.label, vec![top, bottom])
    }
}

/// How the temperature figures draw a part, said under either model's paragraph.
const KEPT_COLOURS: &str = "Each part keeps its colour in every figure and in the rerun \
                            recording: the measured trace wide and light, the model's line over \
                            it in the full colour.";

impl Section for TemperaturesSection<'_> {
    fn id(&self) -> &str {
        "temperatures"
    }

    fn title(&self) -> String {
        "Measured and model temperatures".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let r = self.replay;
        let axis = TimeAxis::of_ns(&r.signals.time_ns);
        let n = r.signals.states.len();
        let first = out.next_figure();
        // The replay's model: the hidden-state one's outputs where the spec declares it,
        // each segment from the state fitted to it, as its fit and validation are taken.
        let hidden = r.hidden.as_ref().map(|h| {
            crate::hidden::traces::simulated_outputs(
                &h.estimate.model,
                &r.data,
                r.estimation_range.clone(),
            )
        });
        let sim = hidden.as_ref().unwrap_or(&r.analysis.simulated);
        if hidden.is_some() {
            out.paragraph(&format!(
                "Figures {first}–{} compare each measured temperature with the replay's model, \
                 the hidden-state model's output ŷ = C x + D u, simulated through each \
                 segment from the initial state fitted to its outputs (the estimation instants \
                 and the validation apart), with its residual y − ŷ below; the measured-state \
                 model (eq. 8, from the measured initial state) is drawn in grey beside it. \
                 {KEPT_COLOURS}",
                first + n - 1
            ));
        } else {
            out.paragraph(&format!(
                "Figures {first}–{} compare each measured temperature with the model simulated \
                 from the initial state through the whole recording (eq. 8; the paper's Figs. 3–5), \
                 with the residual y − ŷ below. {KEPT_COLOURS}",
                first + n - 1
            ));
        }
        if r.estimation_range.end < r.signals.len() {
            let t_ns = r.signals.time_ns[r.estimation_range.end];
            out.note(
                "note",
                &format!(
                    "The model was estimated on the instants before {} {}; the rest is validation.",
                    fixed(axis.x_ns(t_ns), 2),
                    axis.unit()
                ),
            );
        }
        for (j, state) in r.signals.states.iter().enumerate() {
            let fit = &self.report.fit;
            let model = if hidden.is_some() {
                "hidden-state model (grey: the measured-state model)"
            } else {
                "model"
            };
            let caption = format!(
                "{}: measured and {model}; below, the residual. NRMSE fit {} %, SNR {} dB, RMSE {} K.",
                state.part,
                fixed(fit.nrmse_fit_percent[j], 2),
                fixed(fit.snr_db[j], 1),
                sig(fit.rmse_k[j], 3)
            );
            out.figure(&self.chart(j, &axis, sim).to_svg()?, &caption);
        }
        Ok(())
    }
}

/// The model: Φ, Γ, eigenvalues of Φ, A_c, B_c and eigenvalues of A_c (eqs. 19–24).
pub struct ModelSection<'a> {
    /// The report.
    pub report: &'a Report,
}

impl Section for ModelSection<'_> {
    fn id(&self) -> &str {
        "model"
    }

    fn title(&self) -> String {
        "The identified model".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let r = self.report;
        let states = state_labels(r);
        let inputs: Vec<String> = r.inputs.iter().map(|i| i.replace('_', " ")).collect();
        let unit = match r.model.scaling {
            Scaling::NameplatePerUnit => {
                "per unit (rises in pu of the temperature base, losses in pu of S_n)"
            }
            Scaling::AsRecorded => "the channels' units",
        };
        let num = |v: f64| sig(v, 6);
        hidden_model_tables(out, r, &inputs, unit);
        let whose = of_the_measured_state_model(r);
        if hidden_is_the_model(r) {
            out.paragraph(&format!(
                "Beside it, the measured-state model (every state a measured temperature): \
                 x(k) = Φ x(k−1) + Γ u(k−1) and dx/dt = A_c x + B_c u, in {unit}; rows are the \
                 states, in model order. Its residuals and thermal network are the ones shown \
                 below."
            ));
        } else {
            out.paragraph(&format!(
                "The discrete model x(k) = Φ x(k−1) + Γ u(k−1) and its continuous equivalent \
                 dx/dt = A_c x + B_c u, in {unit}; rows are the states, in model order."
            ));
        }
        out.table(&Table::matrix(
            format!("Φ (eq. 19){whose}."),
            "Φ",
            &states,
            &states,
            &r.phi,
            num,
        ));
        out.table(&Table::matrix(
            format!("Γ (eq. 20){whose}."),
            "Γ",
            &states,
            &inputs,
            &r.gamma,
            num,
        ));
        out.table(&Table::matrix(
            format!("A_c (eq. 22){whose}, 1/s."),
            "A_c",
            &states,
            &states,
            &r.a_c,
            num,
        ));
        out.table(&Table::matrix(
            format!("B_c (eq. 23){whose}, 1/s."),
            "B_c",
            &states,
            &inputs,
            &r.b_c,
            num,
        ));
        let mut t = Table::new(
            format!("Eigenvalues of Φ (eq. 21) and of A_c (eq. 24){whose}."),
            vec!["".into(), "of Φ".into(), "of A_c, 1/s".into()],
        );
        for (i, (d, c)) in r
            .eigenvalues_discrete
            .iter()
            .zip(&r.eigenvalues_continuous)
            .enumerate()
        {
            t.row(format!("λ{}", i + 1), vec![sig(*d, 8), sig(*c, 6)]);
        }
        out.table(&t);
        Ok(())
    }
}

/// The hidden-state model's Φ, Γ, C (and D where not zero) where it is the report's
/// model; nothing otherwise.
fn hidden_model_tables(out: &mut Markup, r: &Report, inputs: &[String], unit: &str) {
    let Some(h) = r.hidden.as_ref().filter(|h| h.replay_model) else {
        return;
    };
    let hidden: Vec<&str> = (h.state_names.iter().zip(&h.measured))
        .filter(|(_, &m)| !m)
        .map(|(n, _)| n.as_str())
        .collect();
    out.paragraph(&format!(
        "The replay's model has hidden states (the spec's `[hidden]`): x(k+1) = Φ x(k) + Γ u(k), \
         y(k) = C x(k) + D u(k), in {unit}, with {} states of which the {} measured temperatures \
         are the outputs y (C {}; order {}){}. Its time constants, sensitivities, fit, steady \
         state and validation are the ones this page gives.",
        h.order,
        r.model.states.len(),
        h.output_matrix,
        h.order_source,
        if hidden.is_empty() {
            String::new()
        } else {
            format!("; states no sensor reads: {}", hidden.join(", "))
        }
    ));
    let num = |v: f64| sig(v, 6);
    let outputs = state_labels(r);
    let states = &h.state_names;
    out.table(&Table::matrix(
        "Φ of the hidden-state model.",
        "Φ",
        states,
        states,
        &h.phi,
        num,
    ));
    out.table(&Table::matrix(
        "Γ of the hidden-state model.",
        "Γ",
        states,
        inputs,
        &h.gamma,
        num,
    ));
    out.table(&Table::matrix(
        "C of the hidden-state model: rows the measured outputs, columns the states.",
        "C",
        &outputs,
        states,
        &h.c,
        num,
    ));
    if h.d.iter().flatten().any(|v| *v != 0.0) {
        out.table(&Table::matrix(
            "D of the hidden-state model.",
            "D",
            &outputs,
            inputs,
            &h.d,
            num,
        ));
    }
}

/// Time constants with their intervals and parts, the sensitivity norms and responses
/// (eqs. 26–29, the paper's Figs. 6–8).
pub struct TimeConstantsSection<'a> {
    /// The replay (its analysis keeps the sensitivity responses drawn here).
    pub replay: &'a Replay,
    /// Its report.
    pub report: &'a Report,
}

impl TimeConstantsSection<'_> {
    fn tables(&self, out: &mut Markup) {
        let r = self.report;
        let (caption, rows, corner) = if hidden_is_the_model(r) {
            (
                "Time constants T_i = −1/λ_i (eq. 26) of the hidden-state model, with 95 % intervals \
                 where the report has them, and the part each belongs to: the measured output whose \
                 response T_i C ∂x/∂T_i it changes most (eqs. 27–29 through C; several may share one)."
                    .to_string(),
                "rows the measured outputs",
                "output",
            )
        } else {
            // Where Θ's covariance is the sandwich, say over how many instants it takes the
            // residuals' correlation.
            let covariance = r.theta_covariance_window.map_or(String::new(), |w| {
                format!(
                    " of Θ's sandwich covariance, the residuals' correlation taken over a \
                     Bartlett window of {w} instants"
                )
            });
            (
                format!(
                    "Time constants T_i = −1/λ_i (eq. 26) with 95 % intervals (delta method{covariance}), \
                     and the part each belongs to: the state whose response it changes most (eqs. 27–29)."
                ),
                "rows the states",
                "state",
            )
        };
        let mut t = Table::new(
            caption,
            [
                "",
                "T, s",
                "95 % interval, ± s",
                "T, h",
                "part",
                "‖T ∂y/∂T‖",
            ]
            .map(String::from)
            .to_vec(),
        );
        for (i, a) in r.assignment.iter().enumerate() {
            let ci = r
                .uncertainty
                .as_ref()
                .map_or("–".into(), |u| sig(u.time_constants_ci95_s[i], 3));
            t.row(
                format!("T{}", i + 1),
                vec![
                    fixed(a.time_constant_s, 2),
                    ci,
                    fixed(a.time_constant_s / 3600.0, 3),
                    a.part.clone(),
                    sig(a.sensitivity_norm, 4),
                ],
            );
        }
        out.table(&t);
        let labels = state_labels(r);
        let columns: Vec<String> = (1..=r.time_constants_s.len())
            .map(|i| format!("T{i}"))
            .collect();
        let mut norms = Table::matrix(
            format!(
                "Sensitivity norms ‖T_i ∂y_k/∂T_i‖ (RMS over the estimation instants, in the states' \
                 unit): {rows}, columns the time constants; the largest of each column is marked."
            ),
            corner,
            &labels,
            &columns,
            &r.sensitivity_norms,
            |v| sig(v, 4),
        );
        for i in 0..columns.len() {
            let best = (0..labels.len())
                .max_by(|&a, &b| r.sensitivity_norms[a][i].total_cmp(&r.sensitivity_norms[b][i]));
            norms.emphasised.extend(best.map(|k| (k, i)));
        }
        out.table(&norms);
    }

    /// One chart per time constant: T_i ∂ŷ_k/∂T_i of every state over time; with
    /// `[hidden]`, of every measured output to the hidden-state model's time constants
    /// (T_i C ∂x/∂T_i), none where its Φ has no real logarithm.
    fn charts(&self) -> Vec<Chart> {
        let r = self.replay;
        let Some(h) = &r.hidden else {
            let a = &r.analysis;
            let tcs = &a.spectrum.time_constants_s;
            return self.charts_of(tcs, |i, visit| {
                a.sensitivities.responses.for_each(i, &r.data, visit)
            });
        };
        let Ok(responses) = crate::hidden::traces::OutputSensitivities::new(&h.estimate.model)
        else {
            return Vec::new();
        };
        self.charts_of(responses.time_constants_s(), |i, visit| {
            responses.for_each(i, &r.data, r.estimation_range.clone(), visit)
        })
    }

    /// One chart per time constant of `tcs`, of the responses `responses(i, visit)` gives
    /// (`visit(k, values)`, one value per state or measured output, at instant k).
    fn charts_of(
        &self,
        tcs: &[f64],
        responses: impl Fn(usize, &mut dyn FnMut(usize, &[f64])),
    ) -> Vec<Chart> {
        let r = self.replay;
        let t = &r.signals.time_ns;
        let axis = TimeAxis::of_ns(t);
        let unit = match r.model.scaling {
            Scaling::NameplatePerUnit => "pu",
            Scaling::AsRecorded => "K",
        };
        let mut charts = Vec::new();
        for (i, tc) in tcs.iter().enumerate() {
            let mut thin: Vec<Thinning> = r
                .signals
                .states
                .iter()
                .map(|_| Thinning::new(t.len(), BUCKETS))
                .collect();
            responses(i, &mut |k, rel| {
                for (state, th) in thin.iter_mut().enumerate() {
                    th.push(k, axis.x_ns(t[k]), Some(rel[state]));
                }
            });
            let lines = thin
                .into_iter()
                .zip(&r.signals.states)
                .enumerate()
                .map(|(k, (th, st))| Line::new(short_name(&st.part), colour::part(k), th.finish()))
                .collect();
            let y = format!(
                "T{} ∂y/∂T{} (T{} = {} s), {unit}",
                i + 1,
                i + 1,
                i + 1,
                sig(*tc, 4)
            );
            charts.push(Chart::new(&axis.label, vec![Panel::new(y, lines)]));
        }
        charts
    }
}

impl Section for TimeConstantsSection<'_> {
    fn id(&self) -> &str {
        "time-constants"
    }

    fn title(&self) -> String {
        "Time constants and sensitivities".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        self.tables(out);
        let charts = self.charts();
        let first = out.next_figure();
        let what = if hidden_is_the_model(self.report) {
            "T_i ∂ŷ/∂T_i = T_i C ∂x/∂T_i of every measured output to each time constant of the \
             hidden-state model (the paper's Figs. 6–8 through C): the output that responds most"
        } else {
            "T_i ∂ŷ/∂T_i of every state to each time constant (the paper's Figs. 6–8): the state \
             that responds most"
        };
        if !charts.is_empty() {
            out.paragraph(&format!(
                "Figures {first}–{} show the sensitivity responses {what} is the part the time \
                 constant belongs to.",
                first + charts.len() - 1
            ));
        }
        // The charts are the replay's model's responses, as the tables above: with
        // `[hidden]` the hidden-state model's, whose assignment the report's is.
        let assignment = &self.report.assignment;
        for (i, chart) in charts.iter().enumerate() {
            let Some(a) = assignment.get(i) else {
                break;
            };
            out.figure(
                &chart.to_svg()?,
                &format!(
                    "Sensitivity responses to T{} = {} s, which belongs to the {}.",
                    i + 1,
                    fixed(a.time_constant_s, 2),
                    a.part
                ),
            );
        }
        Ok(())
    }
}

/// The fit of the simulated model per part (eq. 25).
pub struct FitSection<'a> {
    /// The report.
    pub report: &'a Report,
}

impl Section for FitSection<'_> {
    fn id(&self) -> &str {
        "fit"
    }

    fn title(&self) -> String {
        "Fit".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let r = self.report;
        let model = if hidden_is_the_model(r) {
            "The hidden-state model's outputs, simulated through each segment from the initial \
             state fitted to its outputs,"
        } else {
            "The model simulated from the measured initial state"
        };
        out.paragraph(&format!(
            "{model} against the measurements, over the {} instants it was estimated on.",
            r.fit.samples
        ));
        let caption = if hidden_is_the_model(r) {
            "Fit per part of the hidden-state model's outputs."
        } else {
            "Fit per part of the simulated model (eq. 8)."
        };
        out.table(&fit_table(caption, r, &r.fit));
        Ok(())
    }
}

fn fit_table(caption: &str, r: &Report, fit: &FitEntry) -> Table {
    let mut columns = vec!["".to_owned()];
    columns.extend(state_labels(r));
    let mut t = Table::new(caption, columns);
    let rows: [(&str, &Vec<f64>, usize); 5] = [
        ("SNR, dB (eq. 25)", &fit.snr_db, 2),
        ("NRMSE fit, %", &fit.nrmse_fit_percent, 2),
        ("RMSE, K", &fit.rmse_k, 4),
        ("largest error, K", &fit.max_abs_error_k, 4),
        ("MSE, K²", &fit.mse_k2, 4),
    ];
    for (label, values, digits) in rows {
        let cells = values
            .iter()
            .map(|v| {
                if digits == 2 {
                    fixed(*v, 2)
                } else {
                    sig(*v, digits)
                }
            })
            .collect();
        t.row(label, cells);
    }
    t
}

/// The steady state against the measured final temperatures (eqs. 30–35) and whether
/// the recording reached equilibrium.
pub struct SteadyStateSection<'a> {
    /// The report.
    pub report: &'a Report,
}

impl Section for SteadyStateSection<'_> {
    fn id(&self) -> &str {
        "steady-state"
    }

    fn title(&self) -> String {
        "Steady state".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let r = self.report;
        let ss = &r.steady_state;
        let inputs: Vec<String> = r
            .model
            .inputs
            .iter()
            .zip(&ss.input_pu)
            .map(|(i, u)| format!("{} = {} {}", i.name.replace('_', " "), sig(*u, 5), i.unit))
            .collect();
        let formula = if hidden_is_the_model(r) {
            "of the hidden-state model's outputs, y_ss = (C (I − Φ)⁻¹ Γ + D) u,"
        } else {
            "−A_c⁻¹B_c u"
        };
        out.paragraph(&format!(
            "The steady state {formula} for the last measured input ({}), against the measured end \
             of the recording.",
            inputs.join(", ")
        ));
        let mut columns = vec!["".to_owned()];
        columns.extend(state_labels(r));
        let mut t = Table::new("Steady state (eqs. 30–35).", columns);
        let three = |v: &Vec<f64>| v.iter().map(|x| fixed(*x, 3)).collect::<Vec<_>>();
        t.row("predicted rise, K (eq. 32)", three(&ss.rise_k));
        if let Some(u) = &r.uncertainty {
            t.row("95 % interval, ± K", three(&u.steady_state_ci95_k));
        }
        t.row(
            "measured final rise, K (eq. 33)",
            three(&ss.measured_final_rise_k),
        );
        t.row(
            "predicted temperature, °C (eq. 34)",
            three(&ss.temperature_c),
        );
        t.row(
            "measured final temperature, °C (eq. 35)",
            three(&ss.measured_final_temperature_c),
        );
        let still: Vec<f64> = ss
            .rise_k
            .iter()
            .zip(&ss.measured_final_rise_k)
            .map(|(p, m)| p - m)
            .collect();
        t.row("still to rise, K", three(&still));
        out.table(&t);
        equilibrium(out, r);
        Ok(())
    }
}

fn equilibrium(out: &mut Markup, r: &Report) {
    // A report a replay built always has one (a report read back has none).
    let Some(e) = &r.equilibrium else {
        return;
    };
    let rates: Vec<String> = e
        .rate_of_rise
        .iter()
        .map(|x| x.map_or("?".into(), |x| format!("{:+.2}", x.k_per_h)))
        .collect();
    let text = format!(
        "Rise over the last hour: [{}] K/h; IEC 60034-1 asks for less than {} K/h: {}. The final load \
         was held {:.1} × the slowest time constant ({:.1} % of its rise reached){}.",
        rates.join(", "),
        e.iec_limit_k_per_h,
        if e.iec_equilibrium { "reached" } else { "not reached" },
        e.held_over_slowest,
        100.0 * e.fraction_of_final_rise_reached,
        if e.steady_state_is_extrapolation {
            "; the steady state is an extrapolation"
        } else {
            ""
        }
    );
    out.note(if e.iec_equilibrium { "ok" } else { "warning" }, &text);
}

/// The residuals' autocorrelation with its 99 % band and their correlation with the inputs.
pub struct ResidualsSection<'a> {
    /// The report.
    pub report: &'a Report,
}

impl Section for ResidualsSection<'_> {
    fn id(&self) -> &str {
        "residuals"
    }

    fn title(&self) -> String {
        "Residual analysis".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let r = self.report;
        let res = &r.residuals;
        let ts = r.sample_time_s;
        let lines = autocorrelation_lines(r, &res.autocorrelation);
        let mut panel = Panel::new("autocorrelation of y − ŷ", lines);
        panel.band = Some((-res.band99, res.band99));
        let mut panels = vec![panel];
        // A predictor's innovations y(k) − ŷ(k|k−1) are what its likelihood assumes
        // white: where the estimate has one (pem), they are drawn below the simulation's.
        if let Some(inn) = &r.innovations {
            let lines = autocorrelation_lines(r, &inn.autocorrelation);
            let mut panel = Panel::new("autocorrelation of the innovations y − ŷ(k|k−1)", lines);
            panel.band = Some((-inn.band99, inn.band99));
            panels.push(panel);
        }
        let lag_unit = if ts == 1.0 {
            "lag, s (samples)".to_owned()
        } else {
            format!("lag, s (Ts = {ts} s)")
        };
        let chart = Chart::new(lag_unit, panels);
        out.paragraph(&format!(
            "A model that has captured the dynamics leaves residuals that are white and uncorrelated \
             with the inputs. Figure {} shows the autocorrelation of the residuals{}; the shaded band \
             is ±{} , the 99 % band of a white sequence.",
            out.next_figure(),
            of_the_measured_state_model(r),
            sig(res.band99, 3)
        ));
        out.figure(
            &chart.to_svg()?,
            &format!(
                "Autocorrelation of the simulation residuals{} (the simulation from the \
                 initial state that best fits the data: the traces' own start, the first \
                 sample's noise, would correlate every lag){}, lags 0–{}.",
                of_the_measured_state_model(r),
                if r.innovations.is_some() {
                    " (above) and of the one-step predictor's innovations (below)"
                } else {
                    ""
                },
                res.max_lag
            ),
        );
        let mut columns = vec!["".to_owned()];
        columns.extend(state_labels(r));
        let mut t = Table::new(
            format!(
                "Whiteness and input correlation of the residuals{}.",
                of_the_measured_state_model(r)
            ),
            columns,
        );
        t.row(
            format!("lags 1–{} outside the band, %", res.max_lag),
            res.autocorrelation_outside_band
                .iter()
                .map(|v| fixed(v * 100.0, 1))
                .collect(),
        );
        if let Some(inn) = &r.innovations {
            t.row(
                format!("innovations: lags 1–{} outside the band, %", inn.max_lag),
                inn.autocorrelation_outside_band
                    .iter()
                    .map(|v| fixed(v * 100.0, 1))
                    .collect(),
            );
        }
        for (j, input) in r.inputs.iter().enumerate() {
            t.row(
                format!(
                    "largest |cross-correlation| with {}",
                    input.replace('_', " ")
                ),
                res.max_abs_cross_correlation
                    .iter()
                    .map(|row| fixed(row[j], 3))
                    .collect(),
            );
        }
        out.table(&t);
        Ok(())
    }
}

/// One line per state of an autocorrelation `[state][lag]` against the lag in seconds.
fn autocorrelation_lines(r: &Report, autocorrelation: &[Vec<f64>]) -> Vec<Line> {
    let ts = r.sample_time_s;
    state_labels(r)
        .into_iter()
        .zip(autocorrelation)
        .enumerate()
        .map(|(k, (name, ac))| {
            let points = ac
                .iter()
                .enumerate()
                .map(|(lag, v)| (lag as f64 * ts, *v))
                .collect();
            Line::new(name, colour::part(k), vec![points])
        })
        .collect()
}

/// The recursive estimate's convergence: its time constants along the recording.
pub struct RecursiveSection<'a> {
    /// The replay (its estimate carries the trajectory).
    pub replay: &'a Replay,
}

impl Section for RecursiveSection<'_> {
    fn id(&self) -> &str {
        "recursive"
    }

    fn title(&self) -> String {
        "Recursive estimate".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let r = self.replay;
        let Some(traj) = &r.estimate.trajectory else {
            return Ok(());
        };
        let model = &r.estimate.model;
        let axis = TimeAxis::of_ns(&r.signals.time_ns);
        let finals = &r.analysis.spectrum.time_constants_s;
        let mut runs: Vec<Vec<Vec<(f64, f64)>>> = vec![vec![Vec::new()]; finals.len()];
        for pt in traj {
            let x = axis.x_ns(r.signals.time_ns[pt.instant]);
            let spectrum = crate::model::Spectrum::of(&model.with_theta(&pt.theta)).ok();
            for (i, run) in runs.iter_mut().enumerate() {
                match spectrum.as_ref().and_then(|s| s.time_constants_s.get(i)) {
                    Some(t) => run.last_mut().map(|s| s.push((x, *t))).unwrap_or(()),
                    None if run.last().is_some_and(|s| !s.is_empty()) => run.push(Vec::new()),
                    None => {}
                }
            }
        }
        let panels = runs
            .into_iter()
            .zip(finals)
            .enumerate()
            .map(|(i, (segments, t))| {
                let mut p = Panel::new(
                    format!("T{}, s", i + 1),
                    vec![Line::new(
                        format!("T{} (final {} s)", i + 1, sig(*t, 4)),
                        colour::part(i),
                        segments,
                    )],
                );
                p.y_range = Some(0.0..2.0 * t);
                p
            })
            .collect();
        out.paragraph(&format!(
            "Figure {} shows the time constants of the recursive estimate along the recording (where \
             the running estimate is a stable thermal system), each on a scale from 0 to twice its \
             final value; λ = the forgetting factor of the estimator settings.",
            out.next_figure()
        ));
        out.figure(
            &Chart::new(&axis.label, panels).to_svg()?,
            "Convergence of the recursive least-squares estimate: its time constants over time.",
        );
        Ok(())
    }
}

/// The passive thermal network of the model (the paper's Fig. 9).
pub struct NetworkSection<'a> {
    /// The report.
    pub report: &'a Report,
}

impl Section for NetworkSection<'_> {
    fn id(&self) -> &str {
        "network"
    }

    fn title(&self) -> String {
        "Thermal network".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let n = match &self.report.network {
            // A report a replay built always has one (a report read back has none).
            None => return Ok(()),
            Some(NetworkEntry::NotDefined { not_defined }) => {
                out.note(
                    "note",
                    &format!("The model has no thermal network: {not_defined}."),
                );
                return Ok(());
            }
            Some(NetworkEntry::Defined(n)) => n,
        };
        let scale = match n.scale_from {
            crate::network::ScaleSource::Calorimetric => {
                "the calorimetric balance (the outlet water's conductance to the coolant is c·ρ·Q)"
            }
            crate::network::ScaleSource::EnergyConservation => {
                "energy conservation (every loss enters the modelled parts: Σ_i k_ij = 1)"
            }
        };
        // A network fitted to the identified model (rather than its exact algebra) says so,
        // with how far it had to move: the passivity figures below describe the free model.
        let fitted = match (&n.fitted_from, &n.minimum_distance) {
            (Some(from), Some(d)) => format!(
                " It was fitted by {from}: it is the passive network whose discretisation lies \
                 nearest the identified Φ and Γ in their covariance-weighted distance (d = {}, {} \
                 degrees of freedom{}; weighted by {}{}).",
                sig(d.distance, 3),
                d.degrees_of_freedom,
                d.p_value
                    .map(|p| format!(", p = {}", sig(p, 2)))
                    .unwrap_or_default(),
                d.weighting,
                d.unconverged()
                    .into_iter()
                    .chain(n.collapsed_parts())
                    .map(|c| format!("; {c}"))
                    .collect::<String>()
            ),
            (Some(from), None) => format!(" Which network this is: {from}."),
            _ => String::new(),
        };
        out.paragraph(&format!(
            "The identified A_c and B_c{} as a lumped network of thermal capacitances and resistances \
             (the paper's Fig. 9): C·dθ/dt = −L·θ + K·P, with the scale of C from {scale}.{fitted} \
             Figure {} draws it.",
            of_the_measured_state_model(self.report),
            out.next_figure()
        ));
        out.figure(
            &diagram(n),
            "The thermal network: capacitances C_i and resistances R = 1/G between the parts and to the coolant.",
        );
        network_tables(out, n);
        if let Some(note) = &n.scale_note {
            out.note("note", note);
        }
        if let Some(alt) = &n.alternative_scale {
            out.note(
                "note",
                &format!(
                    "The other scale gives {} times these capacitances, conductances and shares.",
                    sig(alt.ratio_to_chosen, 4)
                ),
            );
        }
        let class = if n.passivity.is_passive {
            "ok"
        } else {
            "warning"
        };
        out.note(class, &n.passivity.verdict);
        Ok(())
    }
}

fn network_tables(out: &mut Markup, n: &crate::network::Network) {
    let labels: Vec<String> = n.states.iter().map(|s| short_name(s).to_owned()).collect();
    let mut parts = Table::new(
        "Parts: capacitance, and conductance and resistance to the coolant.",
        ["part", "C", "G_i0", "R_i0"].map(String::from).to_vec(),
    );
    for (i, label) in labels.iter().enumerate() {
        parts.row(
            label.clone(),
            vec![
                si(n.capacitance_j_per_k[i], "J/K"),
                si(n.conductance_w_per_k[i][i], "W/K"),
                n.resistance_k_per_w[i][i].map_or("–".into(), |r| si(r, "K/W")),
            ],
        );
    }
    out.table(&parts);
    let mut links = Table::new(
        "Conductances and resistances between parts.",
        ["between", "G_ij", "R_ij"].map(String::from).to_vec(),
    );
    for i in 0..labels.len() {
        for j in i + 1..labels.len() {
            links.row(
                format!("{} – {}", labels[i], labels[j]),
                vec![
                    si(n.conductance_w_per_k[i][j], "W/K"),
                    n.resistance_k_per_w[i][j].map_or("–".into(), |r| si(r, "K/W")),
                ],
            );
        }
    }
    if !links.rows.is_empty() {
        out.table(&links);
    }
    let inputs: Vec<String> = n.inputs.clone();
    let mut k = Table::matrix(
        "Loss distribution K: the share k_ij of each loss (column) that enters each part (row).",
        "part",
        &labels,
        &inputs,
        &n.loss_distribution,
        |v| fixed(v, 3),
    );
    k.row(
        "Σ_i k_ij",
        n.loss_distribution_column_sums
            .iter()
            .map(|v| fixed(*v, 3))
            .collect(),
    );
    out.table(&k);
}

/// The heat the cooling water carries away against the losses (eqs. 17–18).
pub struct CalorimetrySection<'a> {
    /// The replay (the heat on the grid).
    pub replay: &'a Replay,
    /// Its report.
    pub report: &'a Report,
}

impl Section for CalorimetrySection<'_> {
    fn id(&self) -> &str {
        "calorimetry"
    }

    fn title(&self) -> String {
        "Calorimetric balance".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let (Some(c), Some(heat)) = (&self.report.calorimetry, &self.replay.network.calorimetry)
        else {
            return Ok(());
        };
        let r = self.replay;
        let axis = TimeAxis::of_ns(&r.signals.time_ns);
        let water = grid_series(
            r,
            &axis,
            heat.heat.watts.iter().map(|v| v.map(|w| w * 1e-3)),
        );
        let (_, scale) = input_unit(r);
        let losses = grid_series(
            r,
            &axis,
            (0..r.signals.len()).map(|k| {
                r.signals
                    .inputs
                    .iter()
                    .map(|i| i.values.get(k))
                    .sum::<Option<f64>>()
                    .map(|v| v * scale)
            }),
        );
        let chart = Chart::new(
            &axis.label,
            vec![Panel::new(
                "power, kW",
                vec![
                    Line::new(
                        "heat carried by the cooling water, c·ρ·Q·Δθ",
                        colour::input(0),
                        water,
                    ),
                    Line::new("sum of the losses", colour::input(1), losses).dashed(),
                ],
            )],
        );
        out.paragraph(&format!(
            "Figure {} compares the heat the cooling water carries away (eq. 17) with the sum of the \
             computed losses; the water lags the losses by the machine's heat storage.",
            out.next_figure()
        ));
        out.figure(
            &chart.to_svg()?,
            "Calorimetric balance over the recording, kW.",
        );
        let mut t = Table::new("Calorimetric balance.", vec!["".into(), "value".into()]);
        t.row("inlet temperature", vec![c.inlet.replace('_', " ")]);
        t.row("mean flow, l/s", vec![sig(c.mean_flow_l_per_s, 4)]);
        t.row(
            "c·ρ of the water, kJ/(l·K)",
            vec![sig(c.heat_per_litre_j_per_k * 1e-3, 4)],
        );
        if let Some(e) = c.end_of_run {
            t.row("water, end of run, kW", vec![sig(e.watts * 1e-3, 4)]);
            t.row("water, end of run, pu (eq. 18)", vec![sig(e.pu, 4)]);
        }
        if let Some(l) = c.losses_end_of_run_pu {
            t.row("losses, end of run, pu", vec![sig(l, 4)]);
        }
        if let Some(s) = c.water_share_of_losses {
            t.row(
                "share of the losses the water carries, %",
                vec![fixed(100.0 * s, 1)],
            );
        }
        out.table(&t);
        Ok(())
    }
}

/// The fit on data the model was not estimated from.
pub struct ValidationSection<'a> {
    /// The report.
    pub report: &'a Report,
}

impl Section for ValidationSection<'_> {
    fn id(&self) -> &str {
        "validation"
    }

    fn title(&self) -> String {
        "Validation".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let Some(v) = &self.report.validation else {
            return Ok(());
        };
        let start = if hidden_is_the_model(self.report) {
            "the hidden-state model's outputs, each segment from the initial state fitted to its \
             outputs (no sensor gives the hidden states)"
        } else {
            "from the measured state at its start"
        };
        out.paragraph(&format!(
            "The model simulated on {} ({} instants), {start}.",
            v.source, v.fit.samples
        ));
        out.table(&fit_table(
            "Fit on the validation data.",
            self.report,
            &v.fit,
        ));
        Ok(())
    }
}

/// The estimator, its settings and heatrun's version.
pub struct EstimatorSection<'a> {
    /// The replay (the estimate's details).
    pub replay: &'a Replay,
    /// Its report.
    pub report: &'a Report,
    /// The options the replay ran with.
    pub options: &'a ReplayOptions,
}

impl EstimatorSection<'_> {
    fn settings(&self) -> Table {
        let (r, o, e) = (self.report, self.options, &self.replay.estimate);
        let est = &r.estimation;
        let mut t = Table::new(
            "Estimator and settings.",
            vec!["setting".into(), "value".into()],
        );
        t.row(
            "method",
            vec![format!("{} ({})", e.method, e.method.description())],
        );
        t.row("model", vec![r.model.name.clone()]);
        t.row("sample time Ts, s", vec![sig(r.sample_time_s, 6)]);
        let weights = match (&o.weights, e.method) {
            (Some(w), _) => w.iter().map(|v| sig(*v, 4)).collect::<Vec<_>>().join(", "),
            (None, Method::Oe) => "1/σ_i², estimated".into(),
            (None, Method::Wls) => "equal".into(),
            (None, _) => "–".into(),
        };
        t.row("weights", vec![weights]);
        if e.method == Method::Rls {
            t.row("forgetting factor λ", vec![sig(o.forgetting, 6)]);
        }
        let validation = match &o.validation {
            None => "none".to_owned(),
            Some(ValidationSource::HoldOut(f)) => {
                format!("hold-out of the last {:.0} %", f * 100.0)
            }
            Some(ValidationSource::SplitAt(t)) => format!("split at {t} s"),
            Some(ValidationSource::Recording(p)) => format!("recording {}", p.display()),
        };
        t.row("validation", vec![validation]);
        if let Some(m) = &o.machine {
            t.row("machine file", vec![m.display().to_string()]);
        }
        t.row(
            "instants, equations used, segments",
            vec![format!(
                "{}, {}, {}",
                est.instants, est.equations_used, est.segments
            )],
        );
        t.row("condition number", vec![sig(est.condition_number, 4)]);
        t.row("iterations", vec![e.iterations.to_string()]);
        t.row(
            "noise variance per state",
            vec![e
                .noise_variance
                .iter()
                .map(|v| sig(*v, 3))
                .collect::<Vec<_>>()
                .join(", ")],
        );
        if let Some(c) = &e.output_offset {
            t.row(
                "output offset per state",
                vec![c.iter().map(|v| sig(*v, 3)).collect::<Vec<_>>().join(", ")],
            );
        }
        let initial: Vec<String> = est
            .initial_temperature_c
            .iter()
            .map(|v| fixed(*v, 2))
            .collect();
        t.row(
            "initial temperatures θ_0, °C",
            vec![format!("{} at {}", initial.join(", "), est.initial_time)],
        );
        if let Some(f) = &est.field_temperature {
            t.row("field winding temperature", vec![field_source(f)]);
        }
        t.row("temperature base, K", vec![sig(est.temperature_base_k, 4)]);
        if let Some(p) = est.power_base_mva {
            t.row("power base, MVA", vec![sig(p, 4)]);
        }
        t.row("report profile", vec![r.profile.clone()]);
        t.row("heatrun version", vec![r.heatrun_version.clone()]);
        t
    }
}

fn field_source(f: &crate::losses::FieldTemperatureSource) -> String {
    use crate::losses::FieldTemperatureSource as F;
    match f {
        F::Measured => "measured".into(),
        F::ResistanceMethod => "resistance method, U_f / I_f".into(),
        F::ScaledArmatureRise {
            scale,
            final_temp_c,
        } => {
            format!("armature rise × {scale:.4} (final {final_temp_c} °C)")
        }
    }
}

impl Section for EstimatorSection<'_> {
    fn id(&self) -> &str {
        "estimator"
    }

    fn title(&self) -> String {
        "Estimator and settings".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        out.table(&self.settings());
        let mut s = String::new();
        let _ = write!(
            s,
            "Made by heatrun {} from {}; the JSON report (profile {}) holds every number of this page.",
            self.report.heatrun_version, self.report.recording.path, self.report.profile
        );
        out.note("note", &s);
        Ok(())
    }
}
