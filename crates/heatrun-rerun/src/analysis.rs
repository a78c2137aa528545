//! The analyses behind the result: the sensitivity responses that assign each time
//! constant to a part (eqs. 27-29), the residuals' correlations, and the recursive
//! estimate's trajectory.

use crate::curve::{Polyline, CURVE_TOLERANCE};
use crate::paced::PacedStream;

use crate::Result;
use heatrun::hidden::traces::OutputSensitivities;
use heatrun::model::ModelAnalysis;
use heatrun::pipeline::Replay;
use heatrun::signals::ModelSignals;

use super::style;
use super::traces::{
    on_grid, send_by_lag, send_series, sensitivity_unit, short_part, Stages, SERIES_SLICE,
};

/// The sensitivity responses T_i ∂ŷ/∂T_i behind the assignment, from the analysis's
/// recursion over the instants the model was estimated on, one state at a time, each in its
/// part's colour.
pub(super) fn log_sensitivities(
    rec: &PacedStream,
    stages: Stages<'_>,
    analysis: &ModelAnalysis,
) -> Result<()> {
    let (model, signals) = (stages.model, stages.signals);
    let responses = &analysis.sensitivities.responses;
    let t = &signals.time_ns;
    let unit = sensitivity_unit(model);
    for i in 0..analysis.spectrum.time_constants_s.len() {
        let entities = sensitivity_entities(rec, i, signals, unit)?;
        send_responses(rec, &entities, t, |visit| {
            responses.for_each(i, stages.data, |instant, rel| visit(instant, rel));
        })?;
    }
    Ok(())
}

/// The entities of the responses to time constant `i`, one per state, styled in the
/// parts' colours.
fn sensitivity_entities(
    rec: &PacedStream,
    i: usize,
    signals: &heatrun::ModelSignals,
    unit: &str,
) -> Result<Vec<String>> {
    let mut entities = Vec::with_capacity(signals.states.len());
    for (k, state) in signals.states.iter().enumerate() {
        let entity = format!("sensitivity/T{}/{}", i + 1, state.name);
        let name = format!("{}, {unit}", short_part(&state.part));
        style::series(rec, &entity, &name, style::part(k), style::CURVE_WIDTH)?;
        entities.push(entity);
    }
    Ok(entities)
}

/// Sends the responses to one time constant, each state's to its entity as the polyline
/// a plot draws of it ([`Polyline`]: smooth curves), from one run of the recursion `run`
/// (it calls back with an instant and every state's value there): the recursion gives
/// all states at once, and was run once per state before (nine runs for three constants
/// and three states where three give the same points).
fn send_responses(
    rec: &PacedStream,
    entities: &[String],
    time_ns: &[i64],
    run: impl FnOnce(&mut dyn FnMut(usize, &[f64])),
) -> Result<()> {
    let mut curves: Vec<(Polyline, Vec<(i64, f64)>)> = entities
        .iter()
        .map(|_| (Polyline::new(CURVE_TOLERANCE), Vec::new()))
        .collect();
    let mut failed = None;
    run(&mut |instant, values| {
        for ((entity, (line, points)), v) in entities.iter().zip(&mut curves).zip(values) {
            points.extend(line.push((time_ns[instant], *v)));
            if points.len() == SERIES_SLICE && failed.is_none() {
                failed = send_series(rec, entity, points.drain(..)).err();
            }
        }
    });
    if let Some(e) = failed {
        return Err(e);
    }
    for (entity, (mut line, mut points)) in entities.iter().zip(curves) {
        points.extend(line.finish());
        send_series(rec, entity, points.into_iter())?;
    }
    Ok(())
}

/// The hidden-state model's output sensitivity responses T_i ∂ŷ/∂T_i = T_i C ∂x/∂T_i
/// behind its assignment (the report's, where the spec declares `[hidden]`), over the
/// estimation instants, one measured output at a time in its part's colour, under the
/// entities the measured-state model's would take. Nothing where the model has no
/// analysis (Φ without a real logarithm: the report then has no assignment either).
pub(super) fn log_hidden_sensitivities(rec: &PacedStream, replay: &Replay) -> Result<()> {
    let Some(h) = replay.hidden.as_ref().filter(|h| h.analysis.is_some()) else {
        return Ok(());
    };
    let Ok(responses) = OutputSensitivities::new(&h.estimate.model) else {
        return Ok(());
    };
    let t = &replay.signals.time_ns;
    let range = replay.estimation_range.clone();
    let unit = sensitivity_unit(&replay.model);
    for i in 0..responses.time_constants_s().len() {
        let entities = sensitivity_entities(rec, i, &replay.signals, unit)?;
        send_responses(rec, &entities, t, |visit| {
            responses.for_each(i, &replay.data, range.clone(), |instant, y| {
                visit(instant, y)
            });
        })?;
    }
    Ok(())
}

/// Entity root of the residuals' autocorrelation as bars over the lag, one per state.
pub const AUTOCORRELATION_BY_LAG: &str = "residual_autocorrelation";

/// Per state: the residual's autocorrelation with its 99 % band, and its
/// cross-correlation with each input, against the lag.
pub(super) fn log_residual_correlation(
    rec: &PacedStream,
    signals: &ModelSignals,
    analysis: &ModelAnalysis,
) -> Result<()> {
    let res = &analysis.residuals;
    let lag = res.max_lag as i64;
    for (i, state) in signals.states.iter().enumerate() {
        // The correlogram as bars over the lag, static: it shows on whatever timeline the
        // viewer is on, where the series below need the `lag` timeline picked.
        rec.log_static(
            format!("{AUTOCORRELATION_BY_LAG}/{}", state.name),
            &crate::sdk::BarChart::new(res.autocorrelation[i].as_slice())
                .with_abscissa((0..=lag).collect::<Vec<i64>>().as_slice())
                .with_color(style::part(i)),
        )
        .map_err(super::publish_err)?;
        let root = format!("residual_correlation/{}", state.name);
        let auto = format!("{root}/autocorrelation");
        style::series(
            rec,
            &auto,
            "autocorrelation",
            style::part(i),
            style::MEASURED_WIDTH / 2.0,
        )?;
        send_by_lag(
            rec,
            &auto,
            (0..=lag).collect(),
            res.autocorrelation[i].clone(),
        )?;
        for (bound, sign) in [("band99_upper", 1.0), ("band99_lower", -1.0)] {
            let entity = format!("{root}/{bound}");
            style::series(rec, &entity, "99 % band", style::REFERENCE, 1.0)?;
            send_by_lag(rec, &entity, vec![-lag, lag], vec![sign * res.band99; 2])?;
        }
        for (j, input) in signals.inputs.iter().enumerate() {
            let entity = format!("{root}/cross_{}", input.name);
            let name = format!("× {}", input.name.replace('_', " "));
            style::series(rec, &entity, &name, style::input(j), style::LINE_WIDTH)?;
            send_by_lag(
                rec,
                &entity,
                (-lag..=lag).collect(),
                res.cross_correlation[i][j].clone(),
            )?;
        }
    }
    Ok(())
}

/// The recursive estimate's Φ, Γ and time constants as they evolve (`--method rls`).
pub(super) fn log_trajectory(rec: &PacedStream, replay: &Replay) -> Result<()> {
    let Some(traj) = &replay.estimate.trajectory else {
        return Ok(());
    };
    let model = &replay.estimate.model;
    let (n, m) = (model.phi.nrows(), model.gamma.ncols());
    let p = n + m;
    let t: Vec<i64> = traj
        .iter()
        .map(|pt| replay.signals.time_ns[pt.instant])
        .collect();
    for i in 0..n {
        for j in 0..p {
            let (entity, name, colour) = if j < n {
                (
                    format!("rls/phi/{}{}", i + 1, j + 1),
                    format!("Φ({},{})", i + 1, j + 1),
                    style::part(j),
                )
            } else {
                (
                    format!("rls/gamma/{}{}", i + 1, j - n + 1),
                    format!("Γ({},{})", i + 1, j - n + 1),
                    style::input(j - n),
                )
            };
            style::series(rec, &entity, &name, colour, style::LINE_WIDTH)?;
            send_series(
                rec,
                &entity,
                on_grid(&t, traj.iter().map(|pt| Some(pt.theta[i * p + j]))),
            )?;
        }
    }
    // Time constants where the running estimate is a stable thermal system.
    let constants: Vec<Option<Vec<f64>>> = traj
        .iter()
        .map(|pt| {
            heatrun::model::Spectrum::of(&model.with_theta(&pt.theta))
                .ok()
                .map(|s| s.time_constants_s)
        })
        .collect();
    for i in 0..n {
        let entity = format!("rls/time_constant/T{}", i + 1);
        let name = format!("T{}, s", i + 1);
        style::series(rec, &entity, &name, style::part(i), style::LINE_WIDTH)?;
        send_series(
            rec,
            &entity,
            on_grid(&t, constants.iter().map(|c| c.as_ref().map(|c| c[i]))),
        )?;
    }
    Ok(())
}
