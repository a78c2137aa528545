//! The coolant inlet as the model's reference: which formulation a recording gets.
//!
//! The paper's formulation measures every state from its own initial value and takes the
//! losses as the only inputs, so its equilibrium at zero loss is the initial state. A
//! machine cooled by water whose inlet drifts, or that starts warm, does not follow it.
//! Its thermal network C·dθ/dt = −L·θ + g₀·θ_in + K·P has the coolant inlet as reference
//! node: measured from the inlet's initial level θ_in,0, the rises x = θ − θ_in,0 follow
//! dx/dt = A_c x + B_c P + (−A_c·1)(θ_in − θ_in,0), with x(0) = θ(0) − θ_in,0 the
//! estimated initial state (a warm start is the free response from it). [`resolve`]
//! rewrites a description that way ([`Reference::InitialOf`] states, one
//! [`InputSource::BoundaryRise`] input where the inlet varies) when the recording calls
//! for it; elsewhere the description is left as it is.

use super::{InputDescription, InputKind, InputSource, ModelDescription, Reference, Scaling};
use crate::decimate::DecimatedRecording;
use crate::recording::{Quantity, Signal};
use crate::series::Series;

/// The span whose mean is a reference channel's initial level, s.
pub const INITIAL_LEVEL_S: f64 = 600.0;
/// The inlet varies when its means over [`INITIAL_LEVEL_S`] span more than this, K:
/// 0.2 K is beyond a PT100's noise averaged over ten minutes (0.05 K/√600 ≈ 0.002 K)
/// and about 1 % of a heat run's rise.
pub const INLET_VARIES_K: f64 = 0.2;
/// A machine starts warm when its coolant outlet starts this far above the inlet, K:
/// heat is then leaving it with nothing heating it yet, so its initial state is not the
/// rest state the paper's formulation assumes.
pub const WARM_START_K: f64 = 1.0;

/// What the states are measured from (`--reference`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ReferencePolicy {
    /// The coolant inlet where the recording has it and it varies or the machine starts
    /// warm (its outlet above the inlet); the description as written elsewhere.
    #[default]
    Auto,
    /// The description as written (the paper's rises above the initial values).
    Initial,
    /// The coolant inlet wherever the recording has it.
    Inlet,
}

/// What the recording's coolant inlet does, on the grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InletBehaviour {
    /// Range of its means over [`INITIAL_LEVEL_S`], K.
    pub variation_k: f64,
    /// Its initial level (the mean over the first [`INITIAL_LEVEL_S`]), °C.
    pub initial_c: f64,
    /// How far the coolant outlet starts above it, K (`None`: no outlet channel).
    pub outlet_start_above_k: Option<f64>,
}

impl InletBehaviour {
    /// Whether it varies beyond noise ([`INLET_VARIES_K`]).
    pub fn varies(&self) -> bool {
        self.variation_k > INLET_VARIES_K
    }

    /// Whether the machine starts warm ([`WARM_START_K`]).
    pub fn warm_start(&self) -> bool {
        self.outlet_start_above_k.is_some_and(|d| d > WARM_START_K)
    }
}

/// The mean of the first [`INITIAL_LEVEL_S`] of known values of a series from instant
/// `from`: a channel's initial level, free of its sensor noise.
pub fn initial_level(series: &Series, from: usize, ts_s: f64) -> Option<f64> {
    let window = (INITIAL_LEVEL_S / ts_s).round().max(1.0) as usize;
    let (sum, count) = series
        .iter()
        .skip(from)
        .flatten()
        .take(window)
        .fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    (count > 0).then(|| sum / count as f64)
}

/// The inlet's behaviour in a decimated recording, `None` where it has no inlet channel
/// or no value in it.
pub fn inlet_behaviour(decimated: &DecimatedRecording) -> Option<InletBehaviour> {
    let inlet = &decimated.get(Quantity::CoolingWaterInletTemp)?.values;
    let ts_s = decimated.ts_s();
    let first = inlet.iter().position(|v| v.is_some())?;
    let initial_c = initial_level(inlet, first, ts_s)?;
    let window = (INITIAL_LEVEL_S / ts_s).round().max(1.0) as usize;
    let means: Vec<f64> = (first..inlet.len())
        .step_by(window)
        .filter_map(|k| {
            let block: Vec<f64> = inlet.iter().skip(k).take(window).flatten().collect();
            (block.len() * 2 >= window).then(|| block.iter().sum::<f64>() / block.len() as f64)
        })
        .collect();
    let (lo, hi) = means
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let outlet_start_above_k = decimated
        .get(Quantity::CoolingWaterOutletTemp)
        .and_then(|o| o.values.iter().skip(first).flatten().next())
        .map(|o| o - inlet.get(first).unwrap_or(initial_c));
    Some(InletBehaviour {
        variation_k: if means.is_empty() { 0.0 } else { hi - lo },
        initial_c,
        outlet_start_above_k,
    })
}

/// The description a recording is identified with under `policy`: with the coolant inlet
/// as reference, every state measured from its initial value is measured from the inlet's
/// initial level instead, and the inlet's rise above that level is one more input where it
/// varies. A description that reads the inlet already, or whose states are not measured
/// from their initial values, is left as written. `Err` names the channel `Inlet` needs.
pub fn resolve(
    description: &ModelDescription,
    policy: ReferencePolicy,
    inlet: Option<&InletBehaviour>,
) -> Result<ModelDescription, &'static str> {
    let channel = Signal::Profile(Quantity::CoolingWaterInletTemp);
    let use_inlet = match (policy, inlet) {
        (ReferencePolicy::Initial, _) => false,
        (ReferencePolicy::Inlet, None) => return Err(Quantity::CoolingWaterInletTemp.name()),
        (ReferencePolicy::Inlet, Some(_)) => true,
        (ReferencePolicy::Auto, None) => false,
        (ReferencePolicy::Auto, Some(b)) => b.varies() || b.warm_start(),
    };
    let reads_inlet = description.inputs.iter().any(|i| match &i.source {
        InputSource::Channel(c) | InputSource::BoundaryRise(c) => c == &channel,
        InputSource::Expression(e) => e.channels().contains(&channel),
        InputSource::Loss(_) => false,
    });
    let adaptable = !reads_inlet
        && description
            .states
            .iter()
            .all(|s| s.reference == Reference::Initial && s.channel != channel);
    if !use_inlet || !adaptable {
        return Ok(description.clone());
    }
    let mut out = description.clone();
    for s in &mut out.states {
        s.reference = Reference::InitialOf(channel.clone());
    }
    if inlet.is_some_and(|b| b.varies()) {
        out.inputs.push(InputDescription {
            name: "cooling_water_inlet_rise".into(),
            source: InputSource::BoundaryRise(channel),
            unit: match description.scaling {
                Scaling::NameplatePerUnit => "pu",
                Scaling::AsRecorded => "K",
            }
            .into(),
            kind: InputKind::Boundary,
            from_initial: false,
            delay_s: 0.0,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn behaviour(variation_k: f64, outlet_above: f64) -> InletBehaviour {
        InletBehaviour {
            variation_k,
            initial_c: 10.0,
            outlet_start_above_k: Some(outlet_above),
        }
    }

    #[test]
    fn the_inlet_becomes_the_reference_where_it_varies_or_the_machine_starts_warm() {
        let g = ModelDescription::generator();
        let auto =
            |b: Option<InletBehaviour>| resolve(&g, ReferencePolicy::Auto, b.as_ref()).unwrap();
        // No inlet, a constant one with a cold start: the paper's formulation.
        for b in [None, Some(behaviour(0.05, 0.2))] {
            let d = auto(b);
            assert_eq!(d.inputs.len(), 3);
            assert!(d.states.iter().all(|s| s.reference == Reference::Initial));
        }
        // A drifting inlet: the states from its initial level, its rise an input.
        let d = auto(Some(behaviour(3.0, 0.2)));
        assert_eq!(d.inputs.len(), 4);
        assert_eq!(d.inputs[3].kind, InputKind::Boundary);
        assert!(d.inputs_are_heat());
        let inlet = Signal::Profile(Quantity::CoolingWaterInletTemp);
        assert!(d
            .states
            .iter()
            .all(|s| s.reference == Reference::InitialOf(inlet.clone())));
        // A warm start with a constant inlet: from its level, no input.
        let d = auto(Some(behaviour(0.05, 25.0)));
        assert_eq!(d.inputs.len(), 3);
        assert!(d.states.iter().all(|s| s.reference != Reference::Initial));
        // `initial` keeps the paper's; `inlet` needs the channel.
        let d = resolve(&g, ReferencePolicy::Initial, Some(&behaviour(3.0, 25.0))).unwrap();
        assert_eq!(d.inputs.len(), 3);
        assert_eq!(
            resolve(&g, ReferencePolicy::Inlet, None).unwrap_err(),
            "cooling_water_inlet_temp"
        );
    }

    #[test]
    fn the_initial_level_is_the_mean_of_the_first_window() {
        let mut s = Series::unknown(2000);
        for k in 3..2000 {
            s.set(k, Some(if k < 603 { 10.0 + (k % 2) as f64 } else { 50.0 }));
        }
        assert_eq!(initial_level(&s, 0, 1.0), Some(10.5));
        assert_eq!(initial_level(&Series::unknown(5), 0, 1.0), None);
    }
}
