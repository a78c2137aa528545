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

/// The flow varies when one of its means over [`INITIAL_LEVEL_S`] leaves the first by
/// more than this share of their median: 5 % of c·ρ·Q moves a 70 s cooler constant by
/// about 3 %, the accuracy asked of the estimate.
pub const FLOW_VARIES: f64 = 0.05;

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
    /// What the cooling-water flow does (`None`: no flow channel).
    pub flow: Option<FlowBehaviour>,
}

/// What the recording's cooling-water flow does, from its means over
/// [`INITIAL_LEVEL_S`] on the grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlowBehaviour {
    /// The first mean, l/s.
    pub initial_l_per_s: f64,
    /// The first mean beyond [`FLOW_VARIES`] of the median from the first, with the
    /// instant its window starts (`None`: the flow is constant).
    pub first_change: Option<(usize, f64)>,
    /// The smallest and largest mean, l/s.
    pub range_l_per_s: (f64, f64),
}

impl FlowBehaviour {
    /// Whether the flow changes during the run (a pump switched).
    pub fn varies(&self) -> bool {
        self.first_change.is_some()
    }
}

/// The means of the known values over consecutive windows of [`INITIAL_LEVEL_S`] from
/// instant `first`, each with the instant its window starts (windows at least half known).
fn window_means(series: &Series, first: usize, ts_s: f64) -> Vec<(usize, f64)> {
    let window = (INITIAL_LEVEL_S / ts_s).round().max(1.0) as usize;
    (first..series.len())
        .step_by(window)
        .filter_map(|k| {
            // Indexed, not `iter().skip(k)`: skipping walks from the start every window,
            // O(n²) over a week's grid.
            let block: Vec<f64> = (k..(k + window).min(series.len()))
                .filter_map(|i| series.get(i))
                .collect();
            (block.len() * 2 >= window).then(|| (k, block.iter().sum::<f64>() / block.len() as f64))
        })
        .collect()
}

/// The flow's behaviour in a decimated recording, `None` where it has no flow channel or
/// too few values in it.
pub fn flow_behaviour(decimated: &DecimatedRecording) -> Option<FlowBehaviour> {
    let flow = &decimated.get(Quantity::CoolingWaterFlow)?.values;
    let means = window_means(flow, 0, decimated.ts_s());
    let mut sorted: Vec<f64> = means.iter().map(|m| m.1).collect();
    sorted.sort_by(f64::total_cmp);
    let median = *sorted.get(sorted.len() / 2)?;
    let first = means.first()?.1;
    Some(FlowBehaviour {
        initial_l_per_s: first,
        first_change: means
            .iter()
            .copied()
            .find(|m| (m.1 - first).abs() > FLOW_VARIES * median.abs()),
        range_l_per_s: (sorted[0], sorted[sorted.len() - 1]),
    })
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
    let means: Vec<f64> = window_means(inlet, first, ts_s)
        .into_iter()
        .map(|m| m.1)
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
        flow: flow_behaviour(decimated),
    })
}

/// The description a recording is identified with under `policy`: with the coolant inlet
/// as reference, every state measured from its initial value is measured from the inlet's
/// initial level instead, the inlet's rise above that level is one more input where it
/// varies, and a flow that changes during the run enters as [`InputSource::CoolantFlow`]
/// where the coolant outlet is a state ([`flow_input`]). A description that reads the
/// inlet already, or whose states are not measured from their initial values, is left as
/// written. `Err` names the channel `Inlet` needs.
pub fn resolve(
    description: &ModelDescription,
    policy: ReferencePolicy,
    inlet: Option<&InletBehaviour>,
) -> Result<ModelDescription, &'static str> {
    let channel = Signal::Profile(Quantity::CoolingWaterInletTemp);
    // The flow enters only where the outlet is a state (its heat needs θ_out − θ_in).
    let flow_varies =
        inlet.and_then(|b| b.flow).is_some_and(|f| f.varies()) && flow_input(description).is_some();
    let use_inlet = match (policy, inlet) {
        (ReferencePolicy::Initial, _) => false,
        (ReferencePolicy::Inlet, None) => return Err(Quantity::CoolingWaterInletTemp.name()),
        (ReferencePolicy::Inlet, Some(_)) => true,
        (ReferencePolicy::Auto, None) => false,
        (ReferencePolicy::Auto, Some(b)) => b.varies() || b.warm_start() || flow_varies,
    };
    let reads_inlet = description.inputs.iter().any(|i| match &i.source {
        InputSource::Channel(c) | InputSource::BoundaryRise(c) => c == &channel,
        InputSource::Expression(e) => e.channels().contains(&channel),
        InputSource::CoolantFlow { .. } => true,
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
    if flow_varies {
        out.inputs.extend(flow_input(description));
    }
    Ok(out)
}

/// The state of the cooling-water outlet, where the model has one: the part whose
/// conductance to the coolant is the water's flow, c·ρ·Q.
pub fn outlet_state(description: &ModelDescription) -> Option<usize> {
    let outlet = Signal::Profile(Quantity::CoolingWaterOutletTemp);
    description.states.iter().position(|s| s.channel == outlet)
}

/// The cooling-water flow as a known input, for a description whose states include the
/// coolant outlet: [`InputSource::CoolantFlow`], u_Q(k) = −c·ρ·(Q(k) − Q₀)·(θ_out(k) −
/// θ_in(k)), of kind [`InputKind::Boundary`] (no loss, no load: it is the change of the
/// outlet's coupling to the reference node).
///
/// Why this form. The network's outlet node exchanges c·ρ·Q·(θ_out − θ_in) with the
/// coolant; with Q(t) = Q₀ + ΔQ(t) that is the conductance c·ρ·Q₀ of a constant-flow
/// network (inside A_c, identified as before) plus the heat −c·ρ·ΔQ·(θ_out − θ_in) into
/// the outlet node, which is zero wherever the flow stays at Q₀. Entered as an input with
/// its own column of Γ, the model stays linear in Φ and Γ and every estimator and
/// analysis takes it unchanged; the exact bilinear model would instead make Φ depend on
/// Q(k) (an LPV model), which no estimator here fits. The column is estimated freely (its
/// truth is the outlet node's heat column, C⁻¹e_out per watt), as the inlet's column is.
/// The outlet's rise above the inlet in the input is the measured one, not the model's:
/// PT100 noise of 0.05 K against a rise of several kelvin, times ΔQ/Q₀, is an error of
/// well under 1 % of the input, whose bias on its column (errors in variables) is of the
/// order of the squared ratio, 10⁻⁴; the simulated rise would remove it at the price of
/// a bilinear simulation inside the fit. A_c, its time constants and the network are
/// those at Q₀ (the initial flow); at another flow Q, A_c + b_Q·κ·e_outᵀ with
/// κ = −c·ρ·(Q − Q₀)·θ_base/P_base ([`a_c_at_flow`]).
pub fn flow_input(description: &ModelDescription) -> Option<InputDescription> {
    let outlet = Signal::Profile(Quantity::CoolingWaterOutletTemp);
    description.states.iter().find(|s| s.channel == outlet)?;
    Some(InputDescription {
        name: "cooling_water_flow_heat".into(),
        source: InputSource::CoolantFlow {
            flow: Signal::Profile(Quantity::CoolingWaterFlow),
            outlet,
            inlet: Signal::Profile(Quantity::CoolingWaterInletTemp),
        },
        unit: match description.scaling {
            Scaling::NameplatePerUnit => "pu",
            Scaling::AsRecorded => "W",
        }
        .into(),
        kind: InputKind::Boundary,
        delay_s: 0.0,
        from_initial: false,
    })
}

/// A_c at another flow: the identified A_c (at Q₀) with the flow input's column `b_flow`
/// of B_c fed back from the outlet state `outlet`, A_c + b_Q·κ·e_outᵀ, where
/// κ = ∂u_Q/∂x_out = −c·ρ·(Q − Q₀)·θ_base/P_base (`kappa`: the input's change per unit of
/// the outlet's rise above the inlet, in the model's scaling).
pub fn a_c_at_flow(
    a_c: &nalgebra::DMatrix<f64>,
    b_flow: &[f64],
    outlet: usize,
    kappa: f64,
) -> nalgebra::DMatrix<f64> {
    let mut a = a_c.clone();
    for (i, b) in b_flow.iter().enumerate() {
        a[(i, outlet)] += b * kappa;
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recording::Alignment;

    fn behaviour(variation_k: f64, outlet_above: f64) -> InletBehaviour {
        InletBehaviour {
            variation_k,
            initial_c: 10.0,
            outlet_start_above_k: Some(outlet_above),
            flow: None,
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
    fn a_changing_flow_is_an_input_where_the_outlet_is_a_state() {
        let g = ModelDescription::generator();
        let pump = |first_change| InletBehaviour {
            flow: Some(FlowBehaviour {
                initial_l_per_s: 48.2,
                first_change,
                range_l_per_s: (30.0, 48.2),
            }),
            ..behaviour(0.05, 0.2)
        };
        // A constant inlet, a cold start, a pump switched: the inlet is the reference
        // (the flow's heat needs θ_out − θ_in), the flow one input, no inlet rise.
        let d = resolve(&g, ReferencePolicy::Auto, Some(&pump(Some((7200, 30.0))))).unwrap();
        let names: Vec<_> = d.inputs.iter().map(|i| i.name.as_str()).collect();
        assert_eq!(names[3..], ["cooling_water_flow_heat"]);
        assert!(matches!(
            d.inputs[3].source,
            InputSource::CoolantFlow { .. }
        ));
        assert_eq!(d.inputs[3].kind, InputKind::Boundary);
        assert!(d.states.iter().all(|s| s.reference != Reference::Initial));
        let a = d.alignments();
        assert_eq!(
            a[&Signal::Profile(Quantity::CoolingWaterFlow)],
            Alignment::Interval
        );
        assert_eq!(
            a[&Signal::Profile(Quantity::CoolingWaterInletTemp)],
            Alignment::Instant
        );
        // A constant flow changes nothing; `initial` leaves the flow out (the paper).
        assert_eq!(
            resolve(&g, ReferencePolicy::Auto, Some(&pump(None)))
                .unwrap()
                .inputs
                .len(),
            3
        );
        let d = resolve(
            &g,
            ReferencePolicy::Initial,
            Some(&pump(Some((7200, 30.0)))),
        )
        .unwrap();
        assert_eq!(d.inputs.len(), 3);
        // A description without the outlet state gets no flow input.
        let mut no_outlet = g.clone();
        no_outlet.states.pop();
        let d = resolve(
            &no_outlet,
            ReferencePolicy::Auto,
            Some(&pump(Some((7200, 30.0)))),
        );
        let d = d.unwrap();
        assert_eq!(d.inputs.len(), 3);
        assert!(d.states.iter().all(|s| s.reference == Reference::Initial));
    }

    #[test]
    fn a_c_at_another_flow_feeds_the_flow_column_back_from_the_outlet() {
        // One node of capacitance C to the coolant by G = c·ρ·Q₀: A_c = −G/C; the flow's
        // heat −c·ρ·ΔQ·x enters with column 1/C, so at Q the pole is −c·ρ·Q/C.
        let (c, c_rho, q0, q) = (2.0e6, 4.19e3, 48.0, 30.0);
        let a = nalgebra::DMatrix::from_element(1, 1, -c_rho * q0 / c);
        let at = a_c_at_flow(&a, &[1.0 / c], 0, -c_rho * (q - q0));
        assert!((at[(0, 0)] / (-c_rho * q / c) - 1.0).abs() < 1e-12);
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
