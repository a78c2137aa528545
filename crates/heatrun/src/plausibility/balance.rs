//! The calorimetric balance over the run: the cooling water cannot carry away more heat
//! than the machine dissipated, and with the flow measured it carries most of it.
//!
//! From a start near the coolant's temperature, the energy the water carries away over
//! the run, E_cw = Σ c·ρ·(θ_out − θ_in)·Q·Ts (eq. 17 summed; c·ρ of eq. 18), is the
//! energy dissipated, E_loss = Σ Σ_i P_i·Ts, less the heat the parts still store at the
//! end (and whatever leaves through the air). The share E_cw / E_loss therefore lies below
//! 1 and, on any heat run long enough to identify a model, well above 0:
//! [`SHARE_RANGE`]. A share outside it is no machine: a water temperature in °F, a flow in
//! another unit than declared, losses computed from a wrong nameplate.
//!
//! Where one water channel read in another unit brings the share within
//! [`SHARE_EXPLAINED`], the replay is refused naming that channel and unit; otherwise the
//! balance is said, as a warning, and the replay goes on.

use super::{Action, Check, Finding, PlausibilityError};
use crate::decimate::DecimatedRecording;
use crate::recording::Quantity;
use crate::signals::ModelSignals;
use crate::spec::{InputKind, ModelDescription, Scaling};

/// The share of the losses the water may carry over a run: outside it, the data describe
/// no machine.
pub const SHARE_RANGE: (f64, f64) = (0.2, 1.5);
/// Where another unit of one water channel brings the share within this range, that unit
/// is the likely cause.
pub const SHARE_EXPLAINED: (f64, f64) = (0.3, 1.2);
/// The paper's c·ρ (eq. 18), J/(l·K): the check is coarse, the water's c and ρ vary by
/// less than 1 % over its range.
const HEAT_PER_LITRE_J_PER_K: f64 = 4183.0;

/// The water's heat and the losses summed over the run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunBalance {
    /// E_cw / E_loss.
    pub share: f64,
    /// Mean P_cw over the instants summed, W.
    pub water_w: f64,
    /// Mean Σ P_i over the same instants, W.
    pub losses_w: f64,
}

/// E_cw / E_loss over the instants where the outlet, inlet, flow and every heat input are
/// known, with the outlet and inlet mapped by `outlet`, `inlet` (°C → °C) and the flow
/// scaled by `flow_factor`; `None` without water channels or losses.
fn share(
    decimated: &DecimatedRecording,
    signals: &ModelSignals,
    outlet_map: impl Fn(f64) -> f64,
    inlet_map: impl Fn(f64) -> f64,
    flow_factor: f64,
) -> Option<RunBalance> {
    let outlet = decimated.get(Quantity::CoolingWaterOutletTemp)?;
    let flow = decimated.get(Quantity::CoolingWaterFlow)?;
    let inlet = decimated.get(Quantity::CoolingWaterInletTemp);
    let first_outlet = outlet.values.iter().flatten().next()?;
    let heat: Vec<_> = signals
        .inputs
        .iter()
        .filter(|i| i.kind == InputKind::Heat)
        .collect();
    if heat.is_empty() || signals.len() != decimated.len {
        return None;
    }
    let (mut water, mut losses, mut n) = (0.0, 0.0, 0usize);
    for k in 0..decimated.len {
        let (Some(out), Some(q)) = (outlet.values.get(k), flow.values.get(k)) else {
            continue;
        };
        // Without an inlet channel the outlet's first value stands for it (as in the
        // network stage's balance).
        let inl = match inlet {
            Some(i) => match i.values.get(k) {
                Some(v) => inlet_map(v),
                None => continue,
            },
            None => outlet_map(first_outlet),
        };
        let Some(p) = heat.iter().map(|i| i.values.get(k)).sum::<Option<f64>>() else {
            continue;
        };
        water += HEAT_PER_LITRE_J_PER_K * (outlet_map(out) - inl) * q * flow_factor;
        losses += p * signals.power_base;
        n += 1;
    }
    (n > 0 && losses > 0.0).then(|| RunBalance {
        share: water / losses,
        water_w: water / n as f64,
        losses_w: losses / n as f64,
    })
}

/// The balance of the run as recorded, for the generator's loss model with the flow
/// recorded; `None` otherwise.
pub fn of_run(
    model: &ModelDescription,
    decimated: &DecimatedRecording,
    signals: &ModelSignals,
) -> Option<RunBalance> {
    if model.scaling != Scaling::NameplatePerUnit {
        return None;
    }
    share(decimated, signals, |x| x, |x| x, 1.0)
}

/// Checks the balance: `None` within [`SHARE_RANGE`]; a refusal where one water channel
/// in another unit explains it; else a finding to say.
pub fn check(
    model: &ModelDescription,
    decimated: &DecimatedRecording,
    signals: &ModelSignals,
) -> Result<Option<Finding>, PlausibilityError> {
    let Some(run) = of_run(model, decimated, signals) else {
        return Ok(None);
    };
    if (SHARE_RANGE.0..=SHARE_RANGE.1).contains(&run.share) {
        return Ok(None);
    }
    let fahrenheit = |x: f64| (x - 32.0) / 1.8;
    let kelvin = |x: f64| x - 273.15;
    let has_inlet = decimated.get(Quantity::CoolingWaterInletTemp).is_some();
    let id = |x: f64| x;
    // (channel, likely unit, its share)
    let mut explained: Vec<(Quantity, &str, f64)> = Vec::new();
    let mut try_one = |q: Quantity, unit: &'static str, s: Option<RunBalance>| {
        if let Some(s) = s.filter(|s| (SHARE_EXPLAINED.0..=SHARE_EXPLAINED.1).contains(&s.share)) {
            explained.push((q, unit, s.share));
        }
    };
    let out = Quantity::CoolingWaterOutletTemp;
    try_one(out, "°F", share(decimated, signals, fahrenheit, id, 1.0));
    try_one(out, "K", share(decimated, signals, kelvin, id, 1.0));
    if has_inlet {
        let inl = Quantity::CoolingWaterInletTemp;
        try_one(inl, "°F", share(decimated, signals, id, fahrenheit, 1.0));
        try_one(inl, "K", share(decimated, signals, id, kelvin, 1.0));
    }
    // The flow in each of the profile's other units than the one declared.
    let declared = decimated
        .channels
        .iter()
        .filter(|c| c.signal.quantity() == Some(Quantity::CoolingWaterFlow))
        .count();
    if declared > 0 {
        for unit in Quantity::CoolingWaterFlow.accepted_units() {
            let scale = Quantity::CoolingWaterFlow.unit_scale(unit).unwrap_or(1.0);
            // Values written as l/s that are `unit`: the true flow is scale × them.
            if (scale - 1.0).abs() > 1e-12 {
                try_one(
                    Quantity::CoolingWaterFlow,
                    unit,
                    share(decimated, signals, id, id, scale),
                );
            }
        }
    }
    let more = run.share > SHARE_RANGE.1;
    let what = if more {
        format!(
            "the cooling water carries away {:.1} % of the losses over the run ({:.1} kW \
             against {:.1} kW on average), more than the machine dissipates",
            100.0 * run.share,
            run.water_w / 1e3,
            run.losses_w / 1e3
        )
    } else {
        format!(
            "the cooling water carries away only {:.1} % of the losses over the run ({:.1} kW \
             against {:.1} kW on average) though its flow is measured",
            100.0 * run.share,
            run.water_w / 1e3,
            run.losses_w / 1e3
        )
    };
    // One explanation alone is the likely cause; several leave it open.
    if let [(q, unit, s)] = explained[..] {
        let fix = if q == Quantity::CoolingWaterFlow {
            format!(
                "the flow is likely recorded in {unit} where it was read as l/s (read as \
                 {unit} the water carries {:.1} %); fix `unit` of {q} in the import map or \
                 the recording's channel metadata",
                100.0 * s
            )
        } else {
            format!(
                "{q} is likely recorded in {unit} while its unit says degC (read as {unit} the \
                 water carries {:.1} %); convert it to °C in the historian, the table or the \
                 recording (the profile takes temperatures in degC only)",
                100.0 * s
            )
        };
        return Err(PlausibilityError(Box::new(Finding {
            check: Check::CalorimetricBalance,
            channels: vec![q.name().to_owned()],
            time: None,
            cause: format!("{q} recorded in {unit}"),
            action: Action::Refused,
            message: format!("{q}: {what}: {fix}; the replay is refused"),
        })));
    }
    Ok(Some(Finding {
        check: Check::CalorimetricBalance,
        channels: vec![
            Quantity::CoolingWaterOutletTemp.name().to_owned(),
            Quantity::CoolingWaterFlow.name().to_owned(),
        ],
        time: None,
        cause: "a water channel's unit or the nameplate's losses".into(),
        action: Action::Said,
        message: format!(
            "cooling_water_outlet_temp, cooling_water_flow: {what}, which no machine does: \
             check the water channels' units and the nameplate's losses; the model is \
             identified as recorded"
        ),
    }))
}
