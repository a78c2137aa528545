//! The replay's time series on the recording's clock: measured and model temperature per
//! part, residuals, inputs and the decimated quantities. Each series goes out as columns
//! in slices, paced ([`PacedStream`]: rerun's queue holds a bounded backlog of them).

use crate::curve::{self, CURVE_TOLERANCE};
use crate::paced::PacedStream;
use crate::sdk::{Scalars, TimeColumn};

use crate::Result;
use heatrun::decimate::DecimatedRecording;
use heatrun::estimate::IdentificationData;
use heatrun::model::ModelAnalysis;
use heatrun::pipeline::{Prepared, Replay};
use heatrun::signals::ModelSignals;
use heatrun::spec::{InputKind, ModelDescription, Scaling};

/// The stages' outputs the series are drawn from: a whole replay's, or the prepared
/// stages' as they end ([`heatrun::pipeline::StageObserver`]).
#[derive(Clone, Copy)]
pub(super) struct Stages<'a> {
    /// The model description (names, units, scaling).
    pub model: &'a ModelDescription,
    /// The states and inputs on the grid.
    pub signals: &'a ModelSignals,
    /// The decimated quantities.
    pub decimated: &'a DecimatedRecording,
    /// The estimator's data: which entries were compared (a glitch left out was not).
    pub data: &'a IdentificationData,
}

impl<'a> From<&'a Replay> for Stages<'a> {
    fn from(r: &'a Replay) -> Stages<'a> {
        Stages {
            model: &r.model,
            signals: &r.signals,
            decimated: &r.decimated,
            data: &r.data,
        }
    }
}

impl<'a> From<&'a Prepared> for Stages<'a> {
    fn from(p: &'a Prepared) -> Stages<'a> {
        Stages {
            model: &p.model,
            signals: &p.signals,
            decimated: &p.decimated,
            data: &p.data,
        }
    }
}

use super::{publish_err, style, LAG_TIMELINE, TIMELINE};

/// Rows per column chunk of a series.
pub(super) const SERIES_SLICE: usize = 1 << 13;

/// Entity path of a state's temperature plot.
pub fn temperature_entity(state: &str) -> String {
    format!("temperature/{state}")
}

/// Sends one series as columns, `(time ns, value)` pairs in time order, skipping
/// non-finite values ([`send_slices`] on the recording's clock).
pub(super) fn send_series(
    rec: &PacedStream,
    entity: &str,
    points: impl Iterator<Item = (i64, f64)>,
) -> Result<usize> {
    send_slices(rec, entity, points, |times| {
        TimeColumn::new_timestamp_nanos_since_epoch(TIMELINE, times)
    })
}

/// Sends a smooth curve, `(time ns, value)` pairs in time order, as the polyline a plot
/// draws of it: the points within [`CURVE_TOLERANCE`] of its range of the line through
/// their neighbours are left out ([`curve::thinned`]); returns the rows sent.
pub(super) fn send_curve(
    rec: &PacedStream,
    entity: &str,
    points: impl Iterator<Item = (i64, f64)>,
) -> Result<usize> {
    send_series(rec, entity, curve::thinned(points, CURVE_TOLERANCE))
}

/// Sends `(time, value)` pairs in time order as columns, skipping non-finite values, on
/// the timeline `time_column` makes of a slice's times. It goes out in slices of
/// [`SERIES_SLICE`] rows, paced ([`PacedStream::sent`]), so a week-long series never sits
/// in memory twice; returns the rows sent.
pub(super) fn send_slices<T>(
    rec: &PacedStream,
    entity: &str,
    points: impl Iterator<Item = (T, f64)>,
    time_column: impl Fn(Vec<T>) -> TimeColumn,
) -> Result<usize> {
    let mut points = points.filter(|(_, v)| v.is_finite()).peekable();
    let mut sent = 0;
    while points.peek().is_some() {
        // Sized for a whole slice: unzipped into empty vectors, they grew by copies.
        let (mut times, mut values) = (
            Vec::with_capacity(SERIES_SLICE),
            Vec::with_capacity(SERIES_SLICE),
        );
        for (t, v) in points.by_ref().take(SERIES_SLICE) {
            times.push(t);
            values.push(v);
        }
        let rows = times.len();
        sent += rows;
        rec.send_columns(
            entity,
            [time_column(times)],
            Scalars::new(values)
                .columns_of_unit_batches()
                .map_err(publish_err)?,
        )
        .map_err(publish_err)?;
        rec.sent(rows)?;
    }
    Ok(sent)
}

/// Sends a series against a lag (the correlation plots).
pub(super) fn send_by_lag(
    rec: &PacedStream,
    entity: &str,
    lags: Vec<i64>,
    values: Vec<f64>,
) -> Result<()> {
    rec.send_columns(
        entity,
        [TimeColumn::new_sequence(LAG_TIMELINE, lags)],
        Scalars::new(values)
            .columns_of_unit_batches()
            .map_err(publish_err)?,
    )
    .map_err(publish_err)
}

/// Entity root of the calorimetric balance's traces.
pub const CALORIMETRY: &str = "calorimetry";

/// The calorimetric balance over time (paper eqs. 17-18), where the flow is recorded:
/// the heat the cooling water carries away, c·ρ·(θ_out − θ_in)·Q, beside the sum of the
/// computed losses, both in kW, so a wrong loss model or flow meter shows as a gap.
pub(super) fn log_calorimetry(rec: &PacedStream, replay: &Replay) -> Result<()> {
    let Some(c) = &replay.network.calorimetry else {
        return Ok(());
    };
    let s = &replay.signals;
    let water = format!("{CALORIMETRY}/heat_carried_away");
    style::series(
        rec,
        &water,
        "heat carried away by the water, kW",
        style::input(0),
        style::LINE_WIDTH,
    )?;
    send_series(
        rec,
        &water,
        on_grid(&s.time_ns, c.heat.watts.iter().map(|w| w.map(|w| w / 1e3))),
    )?;
    let losses = format!("{CALORIMETRY}/losses");
    style::series(
        rec,
        &losses,
        "sum of the losses, kW",
        style::input(1),
        style::LINE_WIDTH,
    )?;
    let scale = input_plot_scale(&replay.model, s);
    let sum = (0..s.len()).map(|k| {
        s.inputs
            .iter()
            .filter(|i| i.kind == InputKind::Heat)
            .map(|i| i.values.get(k))
            .sum::<Option<f64>>()
            .map(|v| v * scale)
    });
    send_series(rec, &losses, on_grid(&s.time_ns, sum))?;
    Ok(())
}

/// Pairs a grid series with the grid's times, keeping the instants where it is known.
pub(super) fn on_grid<'a>(
    time_ns: &'a [i64],
    values: impl Iterator<Item = Option<f64>> + 'a,
) -> impl Iterator<Item = (i64, f64)> + 'a {
    time_ns
        .iter()
        .zip(values)
        .filter_map(|(t, v)| v.map(|v| (*t, v)))
}

/// The unit of state `j`'s values as the plots show them (°C for the generator).
pub(super) fn state_unit(model: &ModelDescription, j: usize) -> String {
    match model.states.get(j).map(|s| s.unit.as_str()) {
        Some("degC") | Some("°C") | None => "°C".into(),
        Some(u) => u.into(),
    }
}

/// The unit of a rise or residual of state `j` (K for temperatures).
pub(super) fn rise_unit(model: &ModelDescription, j: usize) -> String {
    match state_unit(model, j).as_str() {
        "°C" | "K" => "K".into(),
        u => u.into(),
    }
}

/// The unit of a relative sensitivity T ∂y/∂T: the states' (pu of the temperature base
/// for the generator, K for a spec's temperatures as recorded).
pub(super) fn sensitivity_unit(model: &ModelDescription) -> &'static str {
    match model.scaling {
        Scaling::NameplatePerUnit => "pu",
        Scaling::AsRecorded => "K",
    }
}

/// Title of the inputs' plot: the generator's heat sources in kW, or a spec's inputs.
pub(super) fn input_title(replay: &Replay) -> String {
    match replay.model.scaling {
        Scaling::NameplatePerUnit => "heat sources (losses), kW".into(),
        Scaling::AsRecorded => {
            let mut units: Vec<&str> = replay
                .signals
                .inputs
                .iter()
                .map(|i| i.unit.as_str())
                .collect();
            units.dedup();
            format!("inputs, {}", units.join(", "))
        }
    }
}

/// Factor from an input in the model's scaling to the plotted unit (kW for pu of S_n).
fn input_plot_scale(model: &ModelDescription, signals: &ModelSignals) -> f64 {
    match model.scaling {
        Scaling::NameplatePerUnit => signals.power_base / 1e3,
        Scaling::AsRecorded => signals.power_base,
    }
}

/// The series of a temperature plot's entities: measured (wide and light) and model (thin
/// on top), each in its part's colour.
fn temperature_entities(state: &str) -> (String, String) {
    let root = temperature_entity(state);
    (format!("{root}/measured"), format!("{root}/model"))
}

/// What the recording alone gives, sent as soon as it is prepared: the measured
/// temperature per part, the inputs (the generator's losses in kW) and the decimated
/// quantities with units.
pub(super) fn log_measured(rec: &PacedStream, stages: Stages<'_>) -> Result<()> {
    let s = stages.signals;
    let t = &s.time_ns;
    for (j, state) in s.states.iter().enumerate() {
        let (measured, _) = temperature_entities(&state.name);
        let unit = state_unit(stages.model, j);
        style::series(
            rec,
            &measured,
            &format!("measured, {unit}"),
            style::measured(j),
            style::MEASURED_WIDTH,
        )?;
        send_series(rec, &measured, on_grid(t, state.measured.iter()))?;
    }
    let scale = input_plot_scale(stages.model, s);
    let per_unit = stages.model.scaling == Scaling::NameplatePerUnit;
    // The losses, and a spec's inputs that are not heat (a lamp's voltage to a power, a
    // fan's speed: the plot's title names their units); a coolant inlet's rise is a
    // temperature, published with the decimated quantities (its channel), not here.
    let plotted = s.inputs.iter().filter(|i| i.kind != InputKind::Boundary);
    for (j, input) in plotted.enumerate() {
        let entity = format!("loss/{}", input.name);
        let unit = if per_unit { "kW" } else { input.unit.as_str() };
        let name = format!("{}, {unit}", input.name.replace('_', " "));
        style::series(rec, &entity, &name, style::input(j), style::LINE_WIDTH)?;
        send_series(
            rec,
            &entity,
            on_grid(t, input.values.iter().map(|v| v.map(|v| v * scale))),
        )?;
    }
    for (i, series) in stages.decimated.series.values().enumerate() {
        let entity = format!("decimated/{}", series.signal.name());
        let name = format!("{}, {}", series.signal.name(), series.unit);
        style::series(rec, &entity, &name, style::input(i), style::LINE_WIDTH)?;
        send_series(rec, &entity, on_grid(t, series.values.iter()))?;
    }
    Ok(())
}

/// Which model a simulated trace is, and so where and how it is drawn.
#[derive(Clone, Copy, PartialEq)]
enum Simulated {
    /// The replay's model (the measured-state one, or the hidden-state one the spec
    /// declares): `temperature/<state>/model` in the part's colour, and its residuals.
    ReplayModel {
        /// The legend's name before the unit.
        label: &'static str,
    },
    /// The measured-state model beside a hidden-state replay model:
    /// `temperature/<state>/measured_state_model`, thin and grey, no residuals (the
    /// residual plot is the replay's model's).
    MeasuredStateBeside,
}

/// The legend of the replay's model where the spec declares hidden states.
pub(super) const HIDDEN_MODEL_LABEL: &str = "hidden-state model ŷ = Cx + Du";

/// The measured-state model's temperature per part beside the measured one, and its
/// residual y − ŷ in the part's colour; where the spec declares hidden states (the
/// replay's model is then the hidden one, [`log_hidden_temperatures`]), the same trace
/// drawn thin and grey as the measured-state model's, without residuals.
pub(super) fn log_model_temperatures(
    rec: &PacedStream,
    stages: Stages<'_>,
    analysis: &ModelAnalysis,
) -> Result<()> {
    let which = match stages.model.hidden {
        Some(_) => Simulated::MeasuredStateBeside,
        None => Simulated::ReplayModel { label: "model" },
    };
    let sim = &analysis.simulated;
    log_simulated(rec, stages, |k, j| sim[(k, j)], which)
}

/// The hidden-state model's measured outputs ŷ = C x + D u per part, each segment from
/// the initial state the replay fitted to it (estimation and validation apart), and its
/// residuals y − ŷ: the replay's model where the spec declares `[hidden]`.
pub(super) fn log_hidden_temperatures(rec: &PacedStream, replay: &Replay) -> Result<()> {
    let Some(h) = &replay.hidden else {
        return Ok(());
    };
    let sim = heatrun::hidden::traces::simulated_outputs(
        &h.estimate.model,
        &replay.data,
        replay.estimation_range.clone(),
    );
    let label = HIDDEN_MODEL_LABEL;
    log_simulated(
        rec,
        replay.into(),
        |k, j| sim[(k, j)],
        Simulated::ReplayModel { label },
    )
}

/// Sends the simulated rises `sim(k, state)` (pu; NaN where not simulated) as
/// temperatures over each state's reference, and for the replay's model the residuals
/// where the estimator compared.
fn log_simulated(
    rec: &PacedStream,
    stages: Stages<'_>,
    sim: impl Fn(usize, usize) -> f64,
    which: Simulated,
) -> Result<()> {
    let s = stages.signals;
    let t = &s.time_ns;
    let base = s.temperature_base_k;
    for (j, state) in s.states.iter().enumerate() {
        let unit = state_unit(stages.model, j);
        let (entity, name, colour) = match which {
            Simulated::ReplayModel { label } => (
                temperature_entities(&state.name).1,
                format!("{label}, {unit}"),
                style::part(j),
            ),
            Simulated::MeasuredStateBeside => (
                format!("{}/measured_state_model", temperature_entity(&state.name)),
                format!("measured-state model, {unit}"),
                style::REFERENCE,
            ),
        };
        style::series(rec, &entity, &name, colour, style::CURVE_WIDTH)?;
        send_curve(
            rec,
            &entity,
            on_grid(
                t,
                (0..s.len()).map(|k| Some(state.reference_at(k)? + base * sim(k, j))),
            ),
        )?;
        if which == Simulated::MeasuredStateBeside {
            continue;
        }
        let residual = format!("residual/{}", state.name);
        let label = format!(
            "{}, {}",
            short_part(&state.part),
            rise_unit(stages.model, j)
        );
        style::series(rec, &residual, &label, colour, style::LINE_WIDTH)?;
        send_series(
            rec,
            &residual,
            on_grid(
                t,
                // Where the estimator compared: an entry left out as a glitch or frozen
                // is in the measured trace, not among the residuals.
                (0..s.len()).map(|k| {
                    let y = s.rise_pu(j, k).filter(|_| stages.data.observed(k, j))?;
                    Some(base * (y - sim(k, j)))
                }),
            ),
        )?;
    }
    Ok(())
}

/// A part's name up to its parenthesis ("stator winding (copper)" → "stator winding").
pub(super) fn short_part(part: &str) -> &str {
    part.split(" (").next().unwrap_or(part)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_part_is_named_up_to_its_parenthesis() {
        assert_eq!(short_part("stator winding (copper)"), "stator winding");
        assert_eq!(short_part("iron core"), "iron core");
    }
}
