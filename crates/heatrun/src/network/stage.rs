//! The network stage of a replay: the identified continuous model → its passive thermal
//! network (Fig. 9), the calorimetric balance (eqs. 17-18) where the flow is recorded, and
//! whether the recording reached thermal equilibrium.
//!
//! Input: the [`ModelDescription`], the network estimated directly where the method did
//! (`rc`), the [`ContinuousModel`] with its time constants, the [`ModelSignals`] and the
//! [`DecimatedRecording`]. Output: [`NetworkAnalysis`].

use serde::Serialize;

use super::calorimetry::{self, CoolantHeat, EndOfRun, Water, WaterModel};
use super::equilibrium::{self, Equilibrium};
use super::{fit, AlternativeScale, CoolantLink, Labels, Network, Parts, ScaleSource, Scaling};
use crate::decimate::DecimatedRecording;
use crate::estimate::{Estimate, NetworkEstimate};
use crate::model::ContinuousModel;
use crate::recording::{Quantity, Signal};
use crate::signals::ModelSignals;
use crate::spec::{ModelDescription, Scaling as ModelScaling};

/// The end of the run the calorimetric balance is averaged over, s.
const END_OF_RUN_S: f64 = 600.0;

/// The heat the cooling water carries away, against the losses.
#[derive(Debug, Clone, Serialize)]
pub struct Calorimetry {
    /// Where the inlet temperature came from: `measured` or `outlet_initial`.
    pub inlet: &'static str,
    /// Mean flow over the run, l/s.
    pub mean_flow_l_per_s: f64,
    /// The water's c·ρ at the mean water temperatures, J/(l·K).
    pub heat_per_litre_j_per_k: f64,
    /// P_cw at the end of the run (eq. 17, W; eq. 18, pu).
    pub end_of_run: Option<EndOfRun>,
    /// The sum of the computed losses at the end of the run, pu of S_n.
    pub losses_end_of_run_pu: Option<f64>,
    /// P_cw / Σ losses at the end of the run: the share of the heat the water carries.
    pub water_share_of_losses: Option<f64>,
    /// P_cw on the grid, W (for rerun).
    #[serde(skip)]
    pub heat: CoolantHeat,
}

/// What the network stage found.
#[derive(Debug, Clone)]
pub struct NetworkAnalysis {
    /// The network, or why the model has none.
    pub network: Result<Network, String>,
    /// The calorimetric balance, where the flow is recorded.
    pub calorimetry: Option<Calorimetry>,
    /// The equilibrium checks.
    pub equilibrium: Equilibrium,
}

/// What the network stage finds without the network: the calorimetric balance and the
/// equilibrium checks. A replay makes them while `oe`'s re-estimation for the network
/// runs ([`crate::pipeline`]), then adds the network ([`Balance::with_network`]).
#[derive(Debug, Clone)]
pub struct Balance {
    /// The calorimetric balance, where the flow is recorded.
    pub calorimetry: Option<Calorimetry>,
    /// The equilibrium checks.
    pub equilibrium: Equilibrium,
}

impl Balance {
    /// The balance of eqs. 17-18 and the equilibrium checks against the model's time
    /// constants (ascending, s).
    pub fn of(
        model: &ModelDescription,
        signals: &ModelSignals,
        decimated: &DecimatedRecording,
        time_constants_s: &[f64],
    ) -> Balance {
        Balance {
            calorimetry: calorimetry(model, signals, decimated),
            equilibrium: equilibrium_checks(model, signals, time_constants_s),
        }
    }

    /// The stage's whole finding: `grey_box`'s network (`rc`'s estimate, fitted to the
    /// data), or else the passive network nearest the `identified` model, scaled by this
    /// balance's c·ρ·Q where it has one. `source` says which it is and why
    /// ([`Network::fitted_from`]); `nearest` is that nearest network where it was fitted
    /// already (in the energy-conservation scale, to the same `identified` model), which is
    /// then not fitted again.
    pub(crate) fn with_network(
        self,
        model: &ModelDescription,
        grey_box: Option<&NetworkEstimate>,
        identified: &Estimate,
        continuous: &ContinuousModel,
        signals: &ModelSignals,
        (source, nearest): (Option<&str>, Option<&fit::Fitted>),
    ) -> NetworkAnalysis {
        let mut network = match grey_box {
            Some(estimate) => estimated_network(model, estimate, self.calorimetry.as_ref()),
            None => network(
                model,
                (identified, nearest),
                continuous,
                signals,
                self.calorimetry.as_ref(),
            ),
        };
        let beside_another_model = grey_box.is_some() && identified.network.is_none();
        if let (Ok(network), true) = (network.as_mut(), beside_another_model) {
            // rc's network beside another estimator's model: the passivity figures still
            // describe the model the replay reports (how far it is from a network).
            if let Some(passivity) = algebraic_passivity(model, continuous, signals) {
                network.passivity = passivity;
            }
        }
        if let (Ok(network), Some(source)) = (network.as_mut(), source) {
            network.fitted_from = Some(match network.fitted_from.take() {
                Some(from) => format!("{from}; {source}"),
                None => source.to_owned(),
            });
        }
        NetworkAnalysis {
            network,
            calorimetry: self.calorimetry,
            equilibrium: self.equilibrium,
        }
    }
}

pub(crate) fn labels(model: &ModelDescription) -> Labels {
    Labels {
        states: model.states.iter().map(|s| s.part.clone()).collect(),
        inputs: model
            .inputs
            .iter()
            .map(|i| i.name.replace('_', " "))
            .collect(),
    }
}

/// The network, with the calorimetric scale where the outlet water is a state and the
/// flow is recorded: the passive network nearest the identified model, with the
/// algebraic network's passivity figures (how far the model itself is from a network).
fn network(
    model: &ModelDescription,
    (identified, nearest): (&Estimate, Option<&fit::Fitted>),
    continuous: &ContinuousModel,
    signals: &ModelSignals,
    calorimetry: Option<&Calorimetry>,
) -> Result<Network, String> {
    use crate::spec::InputKind;
    if let Some(i) = model.inputs.iter().find(|i| i.kind == InputKind::Exogenous) {
        return Err(format!(
            "the input `{}` is not heat, so the model is no thermal network",
            i.name
        ));
    }
    // A changing flow carried as an input: A_c is the machine at its initial flow.
    let carried_flow = signals
        .inputs
        .iter()
        .find_map(|i| i.outlet_feedback.as_ref())
        .map(|f| f.reference_flow_l_per_s);
    let coolant = coolant_link(model, calorimetry, carried_flow);
    let scaling = Scaling {
        theta_base_k: signals.temperature_base_k,
        p_base_w: signals.power_base,
    };
    // The reference node's column (the coolant inlet, C⁻¹g₀) is no heat source: the
    // network is drawn from the heat inputs' columns.
    let heat: Vec<usize> = (0..model.inputs.len())
        .filter(|&j| model.inputs[j].kind == InputKind::Heat)
        .collect();
    let b_heat = continuous.b_c.select_columns(&heat);
    let mut labels = labels(model);
    labels.inputs = heat.iter().map(|&j| labels.inputs[j].clone()).collect();
    let algebraic = Network::from_continuous(&continuous.a_c, &b_heat, scaling, coolant, &labels)
        .map_err(|e| e.to_string())?;
    Ok(nearest_network(
        algebraic,
        (identified, nearest),
        &heat,
        scaling,
        coolant,
        &labels,
    ))
}

/// The passivity figures of the identified model's algebraic network (its heat inputs'
/// columns), `None` where it has none.
fn algebraic_passivity(
    model: &ModelDescription,
    continuous: &ContinuousModel,
    signals: &ModelSignals,
) -> Option<super::Passivity> {
    use crate::spec::InputKind;
    let heat: Vec<usize> = (0..model.inputs.len())
        .filter(|&j| model.inputs[j].kind == InputKind::Heat)
        .collect();
    let scaling = Scaling {
        theta_base_k: signals.temperature_base_k,
        p_base_w: signals.power_base,
    };
    let mut labels = labels(model);
    labels.inputs = heat.iter().map(|&j| labels.inputs[j].clone()).collect();
    let b_heat = continuous.b_c.select_columns(&heat);
    Network::from_continuous(&continuous.a_c, &b_heat, scaling, None, &labels)
        .ok()
        .map(|n| n.passivity)
}

/// The passive network nearest the `identified` model in the energy-conservation scale
/// (every column of K summing to 1), the start of `rc`'s fit to the data in a replay:
/// [`fit::minimum_distance`] from the algebraic network of `continuous` (the identified
/// model's A_c, B_c). Errs (saying why) where the model has no network: an input that is
/// not heat, or an algebraic network that cannot be formed. With the distance and the
/// capacitances' standard error ([`fit::Fitted`]).
pub(crate) fn nearest_parts(
    model: &ModelDescription,
    identified: &Estimate,
    continuous: &ContinuousModel,
    scaling: Scaling,
) -> Result<fit::Fitted, String> {
    use crate::spec::InputKind;
    if let Some(i) = model.inputs.iter().find(|i| i.kind != InputKind::Heat) {
        return Err(format!("the input `{}` is not heat", i.name));
    }
    let heat: Vec<usize> = (0..model.inputs.len()).collect();
    let algebraic = Network::from_continuous(
        &continuous.a_c,
        &continuous.b_c,
        scaling,
        None,
        &labels(model),
    )
    .map_err(|e| e.to_string())?;
    let start = energy_scale_start(&algebraic);
    fit::minimum_distance(
        &identified.model,
        identified.covariance.as_ref(),
        &heat,
        scaling,
        start,
    )
    .ok_or_else(|| "no passive network near the identified model was found".into())
}

/// `algebraic`'s C, G and K in the energy-conservation scale (each column of K summing to
/// 1), the minimum distance's start: a calorimetric network times its ratio to that scale.
fn energy_scale_start(algebraic: &Network) -> Parts {
    let to_energy = match (&algebraic.scale_from, &algebraic.alternative_scale) {
        (ScaleSource::Calorimetric, Some(alt)) => alt.ratio_to_chosen,
        _ => 1.0,
    };
    let n = algebraic.capacitance_j_per_k.len();
    let m = algebraic.inputs.len();
    Parts {
        capacitance_j_per_k: algebraic
            .capacitance_j_per_k
            .iter()
            .map(|c| c * to_energy)
            .collect(),
        conductance_w_per_k: nalgebra::DMatrix::from_fn(n, n, |i, j| {
            algebraic.conductance_w_per_k[i][j] * to_energy
        }),
        loss_distribution: nalgebra::DMatrix::from_fn(n, m, |i, j| {
            algebraic.loss_distribution[i][j] * to_energy
        }),
    }
}

/// The passive network nearest the identified model ([`fit::minimum_distance`], from the
/// algebraic network in the energy-conservation scale; or `nearest`, that fit made
/// already by the network's decision), rescaled to c·ρ·Q where the
/// coolant link is given (energy conservation beside it), carrying the algebraic
/// network's passivity figures; the algebraic network itself where the fit fails.
fn nearest_network(
    algebraic: Network,
    (identified, nearest): (&Estimate, Option<&fit::Fitted>),
    heat: &[usize],
    scaling: Scaling,
    coolant: Option<CoolantLink>,
    labels: &Labels,
) -> Network {
    // The nearest network fitted already is the same fit only where every input is heat
    // (it was fitted to all of Γ's columns, as [`nearest_parts`] does).
    let given = nearest.filter(|_| heat.len() == identified.model.gamma.ncols());
    let Some(fitted) = given.cloned().or_else(|| {
        fit::minimum_distance(
            &identified.model,
            identified.covariance.as_ref(),
            heat,
            scaling,
            energy_scale_start(&algebraic),
        )
    }) else {
        return algebraic;
    };
    // Calorimetric: every C, G and k_ij times c·ρ·Q / G_out,0 (A_c and B_c unchanged).
    let ratio = coolant.map(|link| {
        link.conductance_w_per_k / fitted.parts.conductance_w_per_k[(link.state, link.state)]
    });
    let (parts, scale_from) = match ratio {
        Some(r) => (fitted.parts.scaled(r), ScaleSource::Calorimetric),
        None => (fitted.parts.clone(), ScaleSource::EnergyConservation),
    };
    let Ok(mut network) = Network::from_parts(&parts, scaling, scale_from, labels) else {
        return algebraic;
    };
    network.alternative_scale = ratio.map(|r| AlternativeScale {
        scale_from: ScaleSource::EnergyConservation,
        capacitance_j_per_k: fitted.parts.capacitance_j_per_k.clone(),
        ratio_to_chosen: 1.0 / r,
    });
    network.scale_note = if ratio.is_some() {
        None
    } else {
        algebraic.scale_note.clone()
    };
    network.passivity = algebraic.passivity;
    network.fitted_from = Some(if identified.output_offset.is_some() {
        "minimum distance to the identified model, re-estimated with the first sample's offset"
            .into()
    } else {
        "minimum distance to the identified model".into()
    });
    network.minimum_distance = Some(fitted.distance);
    network.first_sample_offset_k = identified
        .output_offset
        .as_ref()
        .map(|d| d.iter().map(|v| v * scaling.theta_base_k).collect());
    network
}

/// The outlet's conductance to the coolant, c·ρ·Q, where the outlet water is a state and
/// the flow is recorded: at the mean flow, or at `flow` (l/s) where the model carries a
/// changing flow as an input (its A_c is the machine at the initial flow).
fn coolant_link(
    model: &ModelDescription,
    calorimetry: Option<&Calorimetry>,
    flow: Option<f64>,
) -> Option<CoolantLink> {
    let outlet = Signal::Profile(Quantity::CoolingWaterOutletTemp);
    calorimetry.and_then(|c| {
        let state = model.states.iter().position(|s| s.channel == outlet)?;
        Some(CoolantLink {
            state,
            conductance_w_per_k: c.heat_per_litre_j_per_k * flow.unwrap_or(c.mean_flow_l_per_s),
        })
    })
}

/// The network `rc` estimated, scaled by energy conservation (its K's columns sum to 1
/// by construction), with the calorimetric scale beside it where the flow is recorded:
/// c·ρ·Q over the estimated G_out,0.
fn estimated_network(
    model: &ModelDescription,
    estimate: &NetworkEstimate,
    calorimetry: Option<&Calorimetry>,
) -> Result<Network, String> {
    let mut network = Network::from_parts(
        &estimate.parts,
        estimate.scaling,
        ScaleSource::EnergyConservation,
        &labels(model),
    )
    .map_err(|e| e.to_string())?;
    network.scale_note =
        Some("estimated in C, G and K by rc with each column of K summing to 1".into());
    if let Some(link) = coolant_link(model, calorimetry, None) {
        let ratio = link.conductance_w_per_k / network.conductance_w_per_k[link.state][link.state];
        network.alternative_scale = Some(AlternativeScale {
            scale_from: ScaleSource::Calorimetric,
            capacitance_j_per_k: network
                .capacitance_j_per_k
                .iter()
                .map(|c| c * ratio)
                .collect(),
            ratio_to_chosen: ratio,
        });
    }
    network.intervals_95 = Some(estimate.intervals.clone());
    Ok(network)
}

/// The balance of eqs. 17-18 where `cooling_water_flow` is recorded (the generator's
/// loss model only: its inputs are the losses in pu of S_n).
fn calorimetry(
    model: &ModelDescription,
    signals: &ModelSignals,
    decimated: &DecimatedRecording,
) -> Option<Calorimetry> {
    if model.scaling != ModelScaling::NameplatePerUnit {
        return None;
    }
    let flow = decimated.get(Quantity::CoolingWaterFlow)?;
    let outlet = decimated.get(Quantity::CoolingWaterOutletTemp)?;
    let (inlet, source) = match decimated.get(Quantity::CoolingWaterInletTemp) {
        Some(i) => (i.values.clone(), "measured"),
        None => {
            let first = outlet.values.get(signals.initial_index)?;
            let n = decimated.len;
            ((0..n).map(|_| Some(first)).collect(), "outlet_initial")
        }
    };
    let heat = calorimetry::heat_carried_away(
        outlet.values.iter(),
        inlet.iter(),
        flow.values.iter(),
        WaterModel::MEASURED,
        signals.power_base,
    )
    .ok()?;
    let mean = |s: &crate::series::Series| {
        let (sum, n) = s
            .iter()
            .flatten()
            .fold((0.0, 0usize), |(a, n), v| (a + v, n + 1));
        (n > 0).then(|| sum / n as f64)
    };
    let (mean_out, mean_in, mean_flow) =
        (mean(&outlet.values)?, mean(&inlet)?, mean(&flow.values)?);
    let water_in = Water::at(mean_in).ok()?;
    let c_rho = Water::at(0.5 * (mean_out + mean_in))
        .ok()?
        .specific_heat_j_per_kg_k
        * water_in.density_kg_per_l();
    let end_of_run = heat.end_of_run(signals.ts_s, END_OF_RUN_S);
    let losses_end_of_run_pu = losses_at_end(signals);
    Some(Calorimetry {
        inlet: source,
        mean_flow_l_per_s: mean_flow,
        heat_per_litre_j_per_k: c_rho,
        water_share_of_losses: end_of_run.zip(losses_end_of_run_pu).map(|(e, l)| e.pu / l),
        end_of_run,
        losses_end_of_run_pu,
        heat,
    })
}

/// Σ u_i averaged over the end of the run, in the inputs' scaling.
fn losses_at_end(signals: &ModelSignals) -> Option<f64> {
    let take = (END_OF_RUN_S / signals.ts_s) as usize + 1;
    let (sum, n) = (0..signals.len())
        .rev()
        .take(take)
        .filter_map(|k| {
            // The losses: the heat inputs (a coolant inlet's rise is no loss).
            signals
                .inputs
                .iter()
                .filter(|i| i.kind == crate::spec::InputKind::Heat)
                .map(|i| i.values.get(k))
                .sum::<Option<f64>>()
        })
        .fold((0.0, 0usize), |(a, n), v| (a + v, n + 1));
    (n > 0).then(|| sum / n as f64)
}

/// IEC 60034-1's rate of rise over the last hour and the paper's held-load criterion.
fn equilibrium_checks(
    model: &ModelDescription,
    signals: &ModelSignals,
    time_constants_s: &[f64],
) -> Equilibrium {
    let names: Vec<String> = signals.states.iter().map(|s| s.part.clone()).collect();
    let rates = equilibrium::rates_of_rise(model, signals);
    let slowest = time_constants_s.iter().copied().fold(f64::NAN, f64::max);
    Equilibrium::assess(&names, rates, held_s(signals), slowest)
}

/// How long the final load was held ([`equilibrium::held_s`]): the coolant inlet's drift
/// is not load, it is left out.
fn held_s(signals: &ModelSignals) -> f64 {
    let load = signals
        .inputs
        .iter()
        .filter(|i| i.kind != crate::spec::InputKind::Boundary)
        .map(|i| &i.values);
    equilibrium::held_s(load, signals.len(), signals.ts_s)
}
