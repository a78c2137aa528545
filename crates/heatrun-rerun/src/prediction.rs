//! `heatrun predict --rrd`: the load schedule, the losses it causes and the predicted
//! temperatures with each part's limit, on a timeline of the schedule's own seconds.

use crate::paced::PacedStream;
use crate::sdk::TimeColumn;

use super::layout::{Layout, Node, View};
use super::traces::send_slices;
use super::{publish_err, style, Publisher, RerunSink};
use crate::Result;
use heatrun::model_file::ThermalModel;
use heatrun::predict::{LoadSchedule, Prediction};
use heatrun::spec::InputKind;

/// The timeline: seconds from the schedule's start.
pub const SCHEDULE_TIMELINE: &str = "schedule time";

/// A part's limit to draw beside its predicted temperature: (state name, °C).
pub type Limit = (String, f64);

/// Sends a prediction to `sink` (an .rrd is complete when this returns, or absent).
pub fn publish(
    prediction: &Prediction,
    schedule: &LoadSchedule,
    model: &ThermalModel,
    limits: &[Limit],
    sink: &RerunSink,
) -> Result<()> {
    let name = schedule
        .path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let publisher = Publisher::open(sink, &name)?;
    let rec = &publisher.rec;
    log_temperatures(rec, prediction, limits)?;
    log_losses(rec, prediction, model)?;
    log_schedule(rec, prediction, schedule)?;
    layout().send(rec).map_err(publish_err)?;
    rec.flush_blocking().map_err(publish_err)?;
    let Publisher { rec, pending, .. } = publisher;
    drop(rec);
    match pending {
        Some(pending) => Ok(pending.commit()?),
        None => Ok(()),
    }
}

/// Sends `(s, value)` pairs on the schedule's timeline ([`send_slices`]).
fn send(rec: &PacedStream, entity: &str, points: impl Iterator<Item = (f64, f64)>) -> Result<()> {
    send_slices(rec, entity, points, |times| {
        TimeColumn::new_duration_secs(SCHEDULE_TIMELINE, times)
    })?;
    Ok(())
}

fn log_temperatures(rec: &PacedStream, p: &Prediction, limits: &[Limit]) -> Result<()> {
    let t = &p.time_s;
    let span = [t[0], t[t.len() - 1]];
    for (j, name) in p.states.iter().enumerate() {
        let values = t.iter().zip(&p.temperatures_c).map(|(&s, th)| (s, th[j]));
        log_temperature(rec, name, j, values, limits, span)?;
    }
    if p.field_derived {
        let values = t
            .iter()
            .zip(&p.field_temperature_c)
            .filter_map(|(&s, th)| Some((s, (*th)?)));
        let j = p.states.len();
        log_temperature(rec, "field_winding_temp", j, values, limits, span)?;
    }
    log_bands(rec, p)
}

/// Each part's 95 % band, where the prediction has one: `<part>_lo95` and `<part>_hi95`
/// in the part's colour, lightened, beside its temperature.
fn log_bands(rec: &PacedStream, p: &Prediction) -> Result<()> {
    let Some(bands) = &p.band_c else {
        return Ok(());
    };
    let mut names: Vec<&str> = p.states.iter().map(String::as_str).collect();
    if p.field_derived {
        names.push("field_winding_temp");
    }
    for (j, name) in names.into_iter().enumerate() {
        let light = style::lightened(style::part(j), 0.6);
        for (edge, sign) in [("lo95", -1.0), ("hi95", 1.0)] {
            let entity = format!("prediction/temperature/{name}_{edge}");
            let label = format!("{name} 95 % band ({edge}), °C");
            style::series(rec, &entity, &label, light, style::LINE_WIDTH)?;
            let values = p.time_s.iter().enumerate().filter_map(|(k, &s)| {
                let value = match p.temperatures_c[k].get(j) {
                    Some(v) => *v,
                    None => p.field_temperature_c[k]?,
                };
                Some((s, value + sign * bands.half_width_k[k].get(j)?))
            });
            send(rec, &entity, values)?;
        }
    }
    Ok(())
}

/// One part's predicted temperature, in colour `j`, and its limit where it has one.
fn log_temperature(
    rec: &PacedStream,
    name: &str,
    j: usize,
    values: impl Iterator<Item = (f64, f64)>,
    limits: &[Limit],
    span: [f64; 2],
) -> Result<()> {
    let entity = format!("prediction/temperature/{name}");
    let colour = style::part(j);
    style::series(
        rec,
        &entity,
        &format!("{name}, °C"),
        colour,
        style::LINE_WIDTH,
    )?;
    send(rec, &entity, values)?;
    if let Some((_, limit)) = limits.iter().rev().find(|(n, _)| n == name) {
        let entity = format!("prediction/temperature/{name}_limit");
        let label = format!("{name} limit {limit:.0} °C");
        let light = style::lightened(colour, 0.5);
        style::series(rec, &entity, &label, light, style::LINE_WIDTH)?;
        send(rec, &entity, span.into_iter().map(|s| (s, *limit)))?;
    }
    Ok(())
}

/// The heat inputs in kW (W per unit: the model's power base), other inputs as they are.
fn log_losses(rec: &PacedStream, p: &Prediction, model: &ThermalModel) -> Result<()> {
    for (i, input) in model.inputs.iter().enumerate() {
        if input.kind != InputKind::Heat {
            continue;
        }
        let entity = format!("prediction/losses/{}", input.name);
        let unit = if model.per_unit { "kW" } else { "as recorded" };
        style::series(
            rec,
            &entity,
            &format!("{}, {unit}", input.name),
            style::input(i),
            style::LINE_WIDTH,
        )?;
        let scale = if model.per_unit {
            model.power_base_w / 1e3
        } else {
            1.0
        };
        let values = p
            .time_s
            .iter()
            .zip(&p.inputs_model)
            .map(|(&s, u)| (s, u[i] * scale));
        send(rec, &entity, values)?;
    }
    Ok(())
}

/// The operating point in force at each instant.
fn log_schedule(rec: &PacedStream, p: &Prediction, schedule: &LoadSchedule) -> Result<()> {
    type Quantity = (
        &'static str,
        &'static str,
        fn(&heatrun::predict::OperatingPoint) -> f64,
    );
    let quantities: [Quantity; 3] = [
        ("currents", "armature current, A", |o| o.armature_current_a),
        ("currents", "field current, A", |o| o.field_current_a),
        ("voltage", "line voltage, kV", |o| o.line_voltage_v / 1e3),
    ];
    for (i, (group, label, value)) in quantities.into_iter().enumerate() {
        let entity = format!(
            "prediction/schedule/{group}/{}",
            label.split(',').next().unwrap_or(label).replace(' ', "_")
        );
        style::series(rec, &entity, label, style::input(i), style::LINE_WIDTH)?;
        send(
            rec,
            &entity,
            p.time_s.iter().map(|&s| (s, value(schedule.point_at(s)))),
        )?;
    }
    Ok(())
}

fn layout() -> Layout {
    let view = |name: &str, origin: &str| -> Node {
        View::time_series(name.to_owned(), origin.to_owned()).into()
    };
    Layout {
        root: Node::vertical(
            "heatrun predict",
            vec![
                view(
                    "predicted temperatures, their 95 % bands and limits, °C",
                    "prediction/temperature",
                ),
                view("losses", "prediction/losses"),
                Node::horizontal(
                    "schedule",
                    vec![
                        view("schedule: currents, A", "prediction/schedule/currents"),
                        view("schedule: line voltage, kV", "prediction/schedule/voltage"),
                    ],
                ),
            ],
        )
        .with_shares([2.0, 1.0, 1.0]),
    }
}
