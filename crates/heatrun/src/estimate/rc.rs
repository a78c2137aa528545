//! Grey-box output error in the thermal network's own parameters (`--method rc`).
//!
//! The model is the passive network of the paper's Fig. 9 (see [`crate::network`]),
//!
//! ```text
//! C·dθ/dt = −L·θ + K·P,   A_c = −C⁻¹·L,   B_c = C⁻¹·K·P_base/θ_base,
//! L_ij = −G_ij (i ≠ j),   L_ii = G_i0 + Σ_{j≠i} G_ij,
//! ```
//!
//! parametrised so that every estimate is a physical network: p = [ln C_i; ln G_i0;
//! ln G_ij (i < j); η], each loss column of K on the simplex by the additive log-ratio
//! k_ij = e^{η_ij} / (1 + Σ_{l≠r_j} e^{η_lj}) with k_{r_j j} = 1 / (1 + Σ_l e^{η_lj})
//! (r_j the part that takes the largest share of loss j at the start). The columns of K
//! summing to 1 (energy conservation: every watt of loss enters a modelled part) is what
//! fixes the absolute scale of C and G, which temperatures and losses alone leave open.
//!
//! Φ = e^{A_c·Ts} and Γ (zero-order hold) follow from p; the fit minimises the same
//! simulation error as [`super::oe`], whose data pass gives the normal equations in
//! Θ = [Φ Γ]. With D = ∂Θ/∂p (exact: the Fréchet derivative of the exponential of the
//! block matrix [[A_c, B_c], [0, 0]]·Ts, from one exponential of a matrix twice its
//! size) the Jacobian in p is J_Θ·D, so JᵀJ and Jᵀr in p are Dᵀ(J_ΘᵀJ_Θ)D and Dᵀ J_Θᵀr:
//! one pass over the data per evaluation, as for OE. The start is the OE estimate's own
//! network, projected onto the passive set; that OE estimate is kept for comparison.
//!
//! Levenberg–Marquardt steps a capacitance in its logarithm. A conductance or share ratio
//! it steps in its logarithm too ([`StepCoordinates::Logarithms`], `--method rc` and far
//! starts), or, from a start near the minimum (the default's fits from the converged nearest
//! passive network), as itself relative to its start, y = e^{p − s}, held at zero (the floor
//! e^−LOG_RANGE) while its gradient points down ([`StepCoordinates::Themselves`],
//! `thermal::rc::Parametrisation::step_coordinate`). In the logarithms an entry that is zero
//! in truth is thrown e^20 below its start, where its Jacobian column ∝ e^p vanishes, and the
//! fit walks back or on a hair per step: on the four-node machine, seed 3, the free fit from
//! the projected start took 320 full-rate evaluations and the held one 1,041 coarse; stepped
//! as themselves, 69 and 133. But from that far start alone, on seed 1, the fit stepped as
//! themselves ended 16.6 K RMS off on the field winding, so far starts keep the logarithms.
//!
//! Beside p, the fit estimates a constant offset d per output, ŷ = x + d
//! ([`Estimate::output_offset`]): each rise is measured from one noisy first sample, whose
//! error stays in every later value; left out, the slowly moving losses' columns of K and
//! the conductances to the coolant take it up (benches/network.rs: 4 and 6 of 10 seeds met
//! the acceptance bar without it, 10 and 10 with it).
//!
//! The covariance of p is σ²(JᵀJ)⁻¹ at the minimum; C and G get log-normal 95 %
//! intervals (exp(ln C ± 1.96 σ)), k_ij the delta-method interval ± 1.96 σ clipped to
//! [0, 1], and Θ the covariance D·cov(p)·Dᵀ that the model analysis propagates.
//! A record stored by exception is fitted as its kept values (without OE's censoring).

use crate::estimate::Method;
use std::cell::{Cell, RefCell};

mod race;
mod score;
use race::Standing;
pub use race::StartRace;
pub use score::HeldScore;

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt, TerminationReason};
use nalgebra::{DMatrix, DVector, Dyn, Owned};

use super::oe::{self, Evaluation, OutputError, Problem};
use super::{
    check_enough_rows, DiscreteModel, Estimate, EstimationError, Estimator, IdentificationData,
    Result,
};
use crate::thermal::network::{Labels, Network, NetworkIntervals, Parts, Scaling};
use crate::thermal::rc::{projected, Parametrisation, LOG_RANGE};
use crate::thermal::ContinuousModel;

/// The grey-box network estimator.
#[derive(Debug, Clone)]
pub struct ResistanceCapacitance {
    /// Per-output weights, as for [`OutputError::weights`].
    pub weights: Option<Vec<f64>>,
    /// The model's scaling (θ_base, P_base), which turns B_c·C into K.
    pub scaling: Scaling,
    /// Told each evaluation of the objective: OE's start fit's (`oe`), then the
    /// network's (`rc`).
    pub progress: crate::progress::Observer,
    /// The coordinates Levenberg–Marquardt steps a conductance or share ratio in.
    pub coordinates: StepCoordinates,
}

/// The coordinates rc's Levenberg–Marquardt steps a conductance or share ratio in (a
/// capacitance always in its logarithm).
///
/// Measured on the four-node machine (docs/src/methods/thermal-network.md): from a start
/// near the minimum (the converged nearest passive network) [`StepCoordinates::Themselves`]
/// reaches the same network in a fraction of the evaluations; from a start far from it
/// (the identified model's network projected onto the passive set, `--method rc`'s) the
/// logarithms' bounded steps keep the fit on the way that [`StepCoordinates::Themselves`]
/// left (seed 1 ended 16.6 K RMS off on the field winding).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StepCoordinates {
    /// p = ln G (or ln of the share ratio): a step multiplies the entry.
    Logarithms,
    /// y = e^{p − s} = G/G_start, held at zero while its gradient points down
    /// (`Parametrisation::step_coordinate` in `thermal::rc`): a step adds to it.
    Themselves,
}

/// What the grey-box fit found besides Φ and Γ: the network itself.
#[derive(Debug, Clone)]
pub struct NetworkEstimate {
    /// C (J/K), G (W/K, G_i0 on the diagonal) and K at the minimum.
    pub parts: Parts,
    /// The scaling the network is in.
    pub scaling: Scaling,
    /// 95 % intervals of every C, G and k_ij.
    pub intervals: NetworkIntervals,
    /// Covariance of p = [ln C; ln G_i0; ln G_ij (i < j); η].
    pub covariance: DMatrix<f64>,
    /// The output-error estimate the fit started from (for comparison).
    pub output_error: Box<Estimate>,
}

impl Estimator for ResistanceCapacitance {
    fn method(&self) -> Method {
        Method::Rc
    }

    fn estimate(&self, data: &IdentificationData) -> Result<Estimate> {
        self.scaling_is_valid()?;
        let oe = OutputError {
            weights: self.weights.clone(),
            progress: self.progress.clone(),
        }
        .estimate(data)?;
        let start = start_parts(&oe.model, self.scaling);
        self.estimate_from_passive(data, start, oe, None)
    }
}

impl ResistanceCapacitance {
    /// The network fitted to `data` from `start` (projected onto the passive set:
    /// conductances and shares floored, each column of K summing to 1), with
    /// `output_error` (an output-error estimate on the same data) kept beside it for
    /// comparison. Where the fastest time constant of `output_error`'s model spans ten
    /// samples of a coarser grid, the fit runs there first (`coarse`, a k-th of the
    /// evaluations' cost) and the full-rate fit starts from its network. A replay
    /// starts from the passive network nearest `oe`'s model ([`crate::network`]): near
    /// the minimum, so the fit takes few evaluations.
    pub fn estimate_from(
        &self,
        data: &IdentificationData,
        start: &Parts,
        output_error: Estimate,
    ) -> Result<Estimate> {
        self.estimate_from_passive(data, projected(start.clone()), output_error, None)
    }

    /// [`ResistanceCapacitance::estimate_from`] as one of several starts fitted beside
    /// each other: the full-rate fit is given up
    /// ([`EstimationError::StartDropped`]) where its deviance falls further behind
    /// another's in `race` than it can still gain ([`StartRace`]).
    pub fn estimate_from_in_race(
        &self,
        data: &IdentificationData,
        start: &Parts,
        output_error: Estimate,
        race: &StartRace,
    ) -> Result<Estimate> {
        self.estimate_from_passive(data, projected(start.clone()), output_error, Some(race))
    }

    /// [`ResistanceCapacitance::estimate_from`] from a `start` near the minimum (the
    /// converged nearest passive network), coarse first (`coarse_first`) as the
    /// held fits are. From a near start the coarse fit buys little where the full-rate fit
    /// is short, and much where it walks a curved valley: on forty seeds of the four-node
    /// machine (2026-11-29, best of two in turns) the typical replay 4.5 % longer, seeds 13
    /// and 35 1.31 → 0.73 s and 1.13 → 0.72 s, every printed network the same to its last
    /// digit. (Measured before the first pass's creep ended it, on seeds 1–5, it bought no
    /// time: 3.6–7.9 s at the full rate only against 3.2–8.9 s.)
    ///
    /// `race` only calls the full-rate fit off ([`StartRace::call_off`]): a fit alone in
    /// its race is never behind.
    pub fn estimate_from_near(
        &self,
        data: &IdentificationData,
        start: &Parts,
        output_error: Estimate,
        race: Option<&StartRace>,
    ) -> Result<Estimate> {
        self.scaling_is_valid()?;
        let fit = self.coarse_first(
            data,
            projected(start.clone()),
            &[],
            &output_error.model,
            race,
        )?;
        Ok(with_output_error(fit, output_error))
    }

    /// [`ResistanceCapacitance::estimate_from`] from a `start` already projected.
    fn estimate_from_passive(
        &self,
        data: &IdentificationData,
        start: Parts,
        output_error: Estimate,
        race: Option<&StartRace>,
    ) -> Result<Estimate> {
        let fit = self.coarse_first(data, start, &[], &output_error.model, race)?;
        Ok(with_output_error(fit, output_error))
    }

    /// The full-rate fit to `data` from `parts` (projected), the parameters `pinned` held.
    fn full_rate_from(
        &self,
        data: &IdentificationData,
        parts: &Parts,
        pinned: &[usize],
        race: Option<&StartRace>,
    ) -> Result<Estimate> {
        let map = Parametrisation::of_shape(data.ts_s, self.scaling, parts);
        let start = map.start.clone();
        self.fit_from(data, map, &start, pinned, (NEGLIGIBLE_CHI2, false), race)
    }

    /// The fit to `data` from `start` (projected, the parameters `pinned` held), run
    /// first on a coarser grid where the fastest time constant of `fastest_from` spans
    /// ten samples of it ([`coarse`]): the full-rate fit then starts from the coarse
    /// network, near its own minimum. The coarse fit's evaluations cost a k-th of the
    /// full rate's, and a start far from the minimum takes hundreds of them (the
    /// four-node machine's held fit from the nearest network: 1,206 full-rate
    /// evaluations, 50 s, before it went coarse first).
    fn coarse_first(
        &self,
        data: &IdentificationData,
        start: Parts,
        pinned: &[usize],
        fastest_from: &DiscreteModel,
        race: Option<&StartRace>,
    ) -> Result<Estimate> {
        self.scaling_is_valid()?;
        // The coarse fit is a start. (Weighting the full-rate
        // fit by `output_error`'s simulation error rather than its start's, tried, made it
        // stiff: 2,800 evaluations on the four-node machine against 335.)
        let coarse_fit = coarse(data, fastest_from).and_then(|coarse| {
            let map = Parametrisation::of_shape(coarse.ts_s, self.scaling, &start);
            let at = map.start.clone();
            let fit = self.fit_from(
                &coarse,
                map,
                &at,
                pinned,
                (COARSE_NEGLIGIBLE_CHI2, false),
                None,
            );
            // A failed coarse fit only loses its head start. A held conductance comes
            // back as 0: its logarithm starts finite again.
            fit.ok()?
                .network
                .map(|n| pinned_at_zero(&projected(n.parts), pinned))
        });
        // The coarse network starts the fit only where it simulates the full-rate data
        // better than the start it came from: on a grid twice as coarse as the paper's
        // fastest mode (23.9 s) it put a part with a capacitance near zero (a mode far
        // below Ts), which the full-rate fit kept (an eigenvalue of Φ at 0).
        let coarse_fit = coarse_fit.filter(|coarse| {
            let score = |parts: &Parts| {
                let map = Parametrisation::of_shape(data.ts_s, self.scaling, parts);
                simulation_score(data, &map.model(&map.start))
            };
            score(coarse) < score(&start)
        });
        let start = coarse_fit.unwrap_or(start);
        let map = Parametrisation::of_shape(data.ts_s, self.scaling, &start);
        let start = map.start.clone();
        self.fit_from(data, map, &start, pinned, (NEGLIGIBLE_CHI2, false), race)
    }

    /// The fit to `data` from `parts` with every part's conductance to the coolant but
    /// `coolant_state`'s held at zero (pinned at 10⁻⁹ of the largest conductance, where
    /// its logarithm stays finite): the network in which heat leaves the machine only
    /// through the cooling water, as the calorimetric balance measures it.
    pub fn fit_through_coolant(
        &self,
        data: &IdentificationData,
        parts: &Parts,
        coolant_state: usize,
    ) -> Result<Estimate> {
        self.fit_through_coolant_in(data, parts, coolant_state, None)
    }

    /// [`ResistanceCapacitance::fit_through_coolant_in`] from a start that may be far
    /// from the held network's minimum (a replay's starts, with their conductances to
    /// the coolant cut): run first on a coarser grid (`coarse_first`, the grid
    /// set by the fastest time constant of `fastest_from`, `oe`'s model).
    pub fn fit_through_coolant_from_start(
        &self,
        data: &IdentificationData,
        start: &Parts,
        coolant_state: usize,
        fastest_from: &DiscreteModel,
        race: Option<&StartRace>,
    ) -> Result<Estimate> {
        let n = start.capacitance_j_per_k.len();
        let pinned = held_to_coolant(n, coolant_state);
        let parts = pinned_at_zero(start, &pinned);
        self.coarse_first(data, parts, &pinned, fastest_from, race)
    }

    /// Rao's score statistic of `held` ([`Self::fit_through_coolant`]'s network, every
    /// part's conductance to the coolant but `coolant_state`'s held at zero) against the
    /// free network that contains it, taken at the held fit alone (`estimate::rc::score`):
    /// S = what freeing those conductances, each only upwards from zero, would lower
    /// J = Σ_i ‖r_i‖²/max(σ̂²_i, floor) by, beyond what the held fit's own parameters
    /// still would, by the Gauss–Newton model at the held network (σ̂²_i each output's
    /// residual variance there, `floor` the least taken as real, as the deviance's). To
    /// first order S is the likelihood-ratio statistic of the free fit against it, χ² on
    /// the conductances held, without the free fit. `None` where the held fit has no
    /// network or its normal equations cannot be factorised.
    pub fn held_score(
        &self,
        data: &IdentificationData,
        held: &Estimate,
        coolant_state: usize,
        floor: f64,
    ) -> Option<HeldScore> {
        let network = held.network.as_ref()?;
        let n = network.parts.capacitance_j_per_k.len();
        let pinned = held_to_coolant(n, coolant_state);
        let parts = pinned_at_zero(&network.parts, &pinned);
        let map = Parametrisation::of_shape(data.ts_s, self.scaling, &parts);
        let start = map.start.clone();
        let weights: Vec<f64> = held
            .noise_variance
            .iter()
            .map(|v| 1.0 / v.max(floor).max(1e-300))
            .collect();
        let segments = data.segments();
        let inner = Problem::new(data, segments, &map.model(&start), &weights).with_output_offset();
        let mut problem = RcProblem::new(inner, map, &start, &[]);
        let evaluation = problem.fit_linear_parameters()?;
        let freed: Vec<usize> = problem
            .free
            .iter()
            .enumerate()
            .filter(|(_, q)| pinned.contains(q))
            .map(|(k, _)| k)
            .collect();
        let base: Vec<usize> = (0..evaluation.grad.len())
            .filter(|k| !freed.contains(k))
            .collect();
        let (statistic, short_of_minimum) =
            score::constrained_gain(&evaluation.gram, &evaluation.grad, &base, &freed)?;
        Some(HeldScore {
            statistic,
            short_of_minimum,
        })
    }

    /// [`ResistanceCapacitance::fit_through_coolant`], given up where `race` has another
    /// held fit far ahead ([`StartRace`]).
    pub fn fit_through_coolant_in(
        &self,
        data: &IdentificationData,
        parts: &Parts,
        coolant_state: usize,
        race: Option<&StartRace>,
    ) -> Result<Estimate> {
        let n = parts.capacitance_j_per_k.len();
        let pinned = held_to_coolant(n, coolant_state);
        let parts = pinned_at_zero(parts, &pinned);
        self.full_rate_from(data, &parts, &pinned, race)
    }

    /// `estimate`'s network refitted from itself with the weights' cap raised pass by
    /// pass (`MOST_PASSES`), where an output's own weight 1/σ̂² is above the cap (an
    /// output read almost without noise); `estimate` itself otherwise, at no cost. Where
    /// `coolant_state` is given the network is [`Self::fit_through_coolant`]'s and stays
    /// held. The intervals stay at the capped weights.
    ///
    /// Why a step of its own, after the choice of network: the fits that start far from
    /// the minimum stall at the raised weights (the cap's reason), and the
    /// likelihood-ratio test between the free and the held network, whose deviance takes
    /// each output at its own σ̂, is run on the capped fits: at the raised weights an
    /// output read without noise leaves residuals of 10⁻⁶ K that are no white noise (the
    /// four-node machine, seed 2: the held network rejected at Λ = 150.8, the free one
    /// 11.4 % off in G). Refitted from the network chosen, the fit starts at its own
    /// minimum at the capped weights and moves only as the heavier weight asks
    /// (docs/src/methods/thermal-network.md).
    pub fn heavier(
        &self,
        data: &IdentificationData,
        estimate: &Estimate,
        coolant_state: Option<usize>,
    ) -> Result<Estimate> {
        let Some(network) = estimate.network.as_ref() else {
            return Ok(estimate.clone());
        };
        let own: Vec<f64> = estimate
            .noise_variance
            .iter()
            .map(|v| 1.0 / v.max(f64::MIN_POSITIVE))
            .collect();
        if self.weights.is_some() || own.is_empty() || !cap_binds(&own, WEIGHT_OVER_MEDIAN) {
            return Ok(estimate.clone());
        }
        let n = network.parts.capacitance_j_per_k.len();
        let pinned = coolant_state
            .map(|w| held_to_coolant(n, w))
            .unwrap_or_default();
        // The network reports a held conductance as 0; its logarithm starts finite again.
        let parts = pinned_at_zero(&network.parts, &pinned);
        let map = Parametrisation::of_shape(data.ts_s, self.scaling, &parts);
        let start = map.start.clone();
        let mut heavier =
            self.fit_from(data, map, &start, &pinned, (NEGLIGIBLE_CHI2, true), None)?;
        if let Some(h) = heavier.network.as_mut() {
            h.output_error = network.output_error.clone();
        }
        Ok(heavier)
    }

    fn scaling_is_valid(&self) -> Result<()> {
        let s = self.scaling;
        let ok = |v: f64| v.is_finite() && v > 0.0;
        if ok(s.theta_base_k) && ok(s.p_base_w) {
            Ok(())
        } else {
            Err(EstimationError::NoNetworkStart {
                reason: format!(
                    "the scaling θ_base = {} K, P_base = {} W must be positive",
                    s.theta_base_k, s.p_base_w
                ),
            })
        }
    }

    /// Minimises the simulation error over the network parameters from `start` (laid out
    /// as p); the estimate's `network` holds the parameters and their intervals, with the
    /// start model as its `output_error` until [`Estimator::estimate`] puts OE's there.
    fn fit_from(
        &self,
        data: &IdentificationData,
        map: Parametrisation,
        start: &[f64],
        pinned: &[usize],
        (negligible_chi2, raise_cap): (f64, bool),
        race: Option<&StartRace>,
    ) -> Result<Estimate> {
        let segments = data.segments();
        let rows_used = oe::compared_instants(data, &segments);
        check_enough_rows(data, rows_used)?;
        let start_model = map.model(start);
        let weights = match &self.weights {
            Some(w) => w.clone(),
            None => capped(oe::normalised_inverse(
                &oe::simulation_error_variance(data, &segments, &start_model)
                    .iter()
                    .map(|v| v.max(1e-24))
                    .collect::<Vec<_>>(),
            )),
        };
        // The rises are measured from one noisy first sample each: a constant offset per
        // output, estimated beside the network (without it the slow columns of K and the
        // conductances to the coolant absorb it; docs/src/methods/thermal-network.md).
        let mut inner = Problem::new(data, segments, &start_model, &weights).with_output_offset();
        inner.progress = Some(oe::Reporting::new(&self.progress, self.method().name()));
        let mut problem = RcProblem::new(inner, map, start, pinned);
        problem.race = race;
        problem.coordinates = self.coordinates;
        let mut evaluations = 0;
        // Fewer evaluations than OE's 200·(p+1): a fit that no longer gains what the data
        // can tell ends there ([`Stall`]).
        let lm = LevenbergMarquardt::new()
            .with_patience(50)
            .with_ftol(1e-10)
            .with_xtol(1e-10)
            .with_gtol(1e-10);
        // The weights' cap, raised pass by pass towards each output's own 1/σ̂²
        // ([`Continuation`]).
        let mut cap = WEIGHT_OVER_MEDIAN;
        let mut previous: Option<DVector<f64>> = None;
        // The weights of the second pass (capped), where the cap was raised after it: the
        // covariance is taken at them ([`RcProblem::settled_since`]).
        let mut reported: Option<Vec<f64>> = None;
        for pass in 0..MOST_PASSES {
            problem.pass = pass;
            let before = problem.params.clone();
            problem.stall = Stall {
                negligible_chi2,
                ..Stall::default()
            };
            // Only the first pass of several: the last must reach its minimum.
            problem.ends_on_creep = pass == 0 && self.weights.is_none();
            problem.creep = Creep::default();
            let (solved, report) = lm.minimize(problem);
            problem = solved;
            evaluations += report.number_of_evaluations;
            if let Some(gap) = problem.dropped.get() {
                return Err(EstimationError::StartDropped { gap });
            }
            if race.is_some_and(StartRace::is_called_off) {
                return Err(EstimationError::CalledOff);
            }
            let stalled = problem.stall.window.stalled.get();
            if stalled {
                // Stopped by [`Stall`]: the best point is the fit of this pass.
                let best = problem.best.borrow().clone().map(|(_, p)| p);
                if let Some(p) = best {
                    problem.set_p(&p);
                }
            }
            // A step into parameters where the model cannot be evaluated (an exponential
            // out of range) ends the minimiser there; the fit is the last good point.
            let stopped_on_bad_point = !stalled
                && (matches!(report.termination, TerminationReason::User(_))
                    || problem.residuals_here().is_none());
            if stopped_on_bad_point {
                let best = problem.best.borrow().clone().map(|(_, p)| p);
                match best {
                    Some(p) => problem.set_p(&p),
                    None if pass >= 1 => problem.set_p(&before),
                    None => {
                        return Err(EstimationError::MinimisationFailed {
                            termination: report.termination,
                        })
                    }
                }
                break;
            }
            if !report.objective_function.is_finite() {
                return Err(EstimationError::MinimisationFailed {
                    termination: report.termination,
                });
            }
            if self.weights.is_some() || pass + 1 == MOST_PASSES {
                break;
            }
            // The sensor noise: 1/σ_i² of this pass's residuals, uncapped.
            let own: Vec<f64> = problem
                .inner
                .residual_weights()
                .iter()
                .map(|s| s * s)
                .collect();
            let binds = raise_cap && cap_binds(&own, cap);
            if pass >= 1 {
                // Without a binding cap the fit ends after its second pass, as it always
                // has; with one it is raised until the network no longer moves.
                let reported = reported.get_or_insert_with(|| problem.inner.sqrt_w.clone());
                if !binds
                    || previous
                        .as_ref()
                        .is_some_and(|p| problem.settled_since(p, reported))
                {
                    break;
                }
                previous = Some(problem.params.clone());
                cap *= WEIGHT_OVER_MEDIAN;
            }
            // The next pass on those weights, capped.
            let next: Vec<f64> = capped_at(own, cap).iter().map(|w| w.sqrt()).collect();
            let change = oe::largest_relative_change(&next, &problem.inner.sqrt_w);
            problem.inner.sqrt_w = next;
            problem.forget_evaluations();
            // Objectives under the old weights are not comparable with the new ones.
            *problem.best.borrow_mut() = None;
            // A first pass ended where it crept is not the minimum: the next goes on.
            if change < 0.05 && !binds && !problem.creep.ended.get() {
                break;
            }
        }
        if let Some(sqrt_w) = reported.filter(|w| *w != problem.inner.sqrt_w) {
            problem.inner.sqrt_w = sqrt_w;
            problem.forget_evaluations();
        }
        if !problem.inner.params.iter().all(|v| v.is_finite()) {
            return Err(EstimationError::MinimisationFailed {
                termination: TerminationReason::Numerical("a network the model cannot hold"),
            });
        }
        Ok(problem.conclude(self.method(), rows_used, evaluations, start_model))
    }
}

/// `fit` with `output_error` (an output-error estimate on the same data) kept beside its
/// network for comparison.
fn with_output_error(mut fit: Estimate, output_error: Estimate) -> Estimate {
    if let Some(network) = fit.network.as_mut() {
        *network.output_error = output_error;
    }
    fit
}

/// Σ_i ln MSE_i of `model`'s simulation on `data` (outputs in their own units: the sum of
/// logarithms weighs each output by its own scale); +∞ where it cannot be simulated.
fn simulation_score(data: &IdentificationData, model: &DiscreteModel) -> f64 {
    if !model.is_stable() {
        return f64::INFINITY;
    }
    let score: f64 = oe::simulation_error_variance(data, &data.segments(), model)
        .iter()
        .map(|v| v.max(1e-300).ln())
        .sum();
    if score.is_nan() {
        f64::INFINITY
    } else {
        score
    }
}

/// The deviance of `estimate`'s fit to `data`, Σ_i N_i·ln max(σ̂²_i, floor) over the
/// outputs i (N_i observed instants, σ̂²_i the output's residual variance): −2 ln L up to
/// a constant for Gaussian white noise of unknown variance per output. `floor` (in the
/// outputs' units squared) is the least variance taken as real: an output nearly without
/// noise (a field winding from U_f/I_f whose electrical channels carry none: 10⁻⁶ K)
/// would otherwise weigh its last numerical digits against the other outputs' data.
pub fn deviance(data: &IdentificationData, estimate: &Estimate, floor: f64) -> f64 {
    data.observed_counts(&data.segments())
        .iter()
        .zip(&estimate.noise_variance)
        .map(|(&n, v)| n as f64 * v.max(floor).max(1e-300).ln())
        .sum()
}

/// The likelihood-ratio statistic of `restricted` (a network with entries held, e.g.
/// [`ResistanceCapacitance::fit_through_coolant`]) against `full`, both fitted to `data`:
/// Λ = [`deviance`] of the restricted fit − [`deviance`] of the full one, χ²-distributed
/// on as many degrees of freedom as entries held where those entries are zero in truth.
pub fn likelihood_ratio(
    data: &IdentificationData,
    full: &Estimate,
    restricted: &Estimate,
    floor: f64,
) -> f64 {
    deviance(data, restricted, floor) - deviance(data, full, floor)
}

/// The largest weight of an output over the median output's in the fit's first two
/// passes: no output is taken as more than ten times as precise (in σ) as the median one
/// until the fit is near its minimum ([`MOST_PASSES`]).
const WEIGHT_OVER_MEDIAN: f64 = 100.0;

/// Passes of the fit at most: two at weights capped at [`WEIGHT_OVER_MEDIAN`], then, where
/// the cap binds, one per cap raised [`WEIGHT_OVER_MEDIAN`] times, up to 10⁶ times the
/// median weight (an output a thousand times as precise as the median one: 5·10⁻⁵ K
/// beside PT100s at 0.05 K).
///
/// Why the cap is raised: the fit is maximum likelihood (each output weighted by its own
/// 1/σ̂²) only where no weight is capped, and an output read almost without noise (a
/// field winding from U_f/I_f whose electrical channels carry none: 10⁻⁶ K) held at 100
/// times the median weight is treated as 0.005 K of noise, which throws its information
/// away and biases the network (the four-node machine, seed 2: the cooling water's C
/// +13.5 %, its 70 s time constant 79.5 s; `oe` at the same capped weights 79.0 s, at the
/// field's own 70.2 s; docs/src/methods/thermal-network.md). Given that weight at once
/// from a distant start, the fit stalls (the cap's reason); raised a hundredfold a pass
/// from the previous pass's minimum, each pass starts near its own. Why it stops at 10⁶:
/// `oe` with the field's weight capped there finds the 70 s constant at 70.0 and 70.1 s
/// (seeds 2 and 1), as at the field's own weight; a hundred times heavier it moved by
/// 0.1 s at 40 times the evaluations (seed 2: 505 against 12), and rc's free network,
/// raised to 10¹⁴, took 3,950 evaluations (200 s) and fitted the data worse.
const MOST_PASSES: usize = 4;

/// A pass whose network parameters all moved less than this many of their standard
/// errors since the previous one ends the raising of the cap: a heavier weight would move
/// the network by nothing the data can tell.
const SETTLED_STANDARD_ERRORS: f64 = 0.1;

/// `weights` (1/σ_i², any scale) with none above [`WEIGHT_OVER_MEDIAN`] times their
/// median. An output nearly without noise (a field winding read from U_f/I_f whose
/// electrical channels carry none) would otherwise take a weight 10⁴ times the others'
/// from the first pass, on which the fit stalls far from the minimum (the four-node
/// machine: C 33 % off).
fn capped(weights: Vec<f64>) -> Vec<f64> {
    capped_at(weights, WEIGHT_OVER_MEDIAN)
}

/// `weights` with none above `cap` times their median.
fn capped_at(weights: Vec<f64>, cap: f64) -> Vec<f64> {
    let limit = cap * median(&weights);
    weights.into_iter().map(|w| w.min(limit)).collect()
}

/// Whether any of `weights` is above `cap` times their median.
fn cap_binds(weights: &[f64], cap: f64) -> bool {
    let limit = cap * median(weights);
    weights.iter().any(|w| *w > limit)
}

/// The parameters pinned in a network of `n` parts where heat leaves only through
/// `coolant_state`: every other part's conductance to the coolant (the p layout's
/// n + i).
fn held_to_coolant(n: usize, coolant_state: usize) -> Vec<usize> {
    (0..n)
        .filter(|&i| i != coolant_state)
        .map(|i| n + i)
        .collect()
}

/// `parts` with the conductances to the coolant that `pinned` holds (p indices n + i, as
/// [`held_to_coolant`] gives them) at [`PINNED_ZERO`] of the largest conductance: zero
/// for the network, a finite logarithm for the fit.
fn pinned_at_zero(parts: &Parts, pinned: &[usize]) -> Parts {
    let n = parts.capacitance_j_per_k.len();
    let mut parts = parts.clone();
    let g_max = parts.conductance_w_per_k.amax();
    for i in pinned
        .iter()
        .filter(|&&q| (n..2 * n).contains(&q))
        .map(|q| q - n)
    {
        parts.conductance_w_per_k[(i, i)] = PINNED_ZERO * g_max;
    }
    parts
}

/// The median (the upper one of an even count).
fn median(values: &[f64]) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    sorted[sorted.len() / 2]
}

/// A conductance held at zero, relative to the largest: far below any the data could
/// tell apart from none, its logarithm finite.
const PINNED_ZERO: f64 = 1e-9;

/// Samples of the coarse grid per fastest time constant: the coarse fit resolves every
/// mode of the model.
const COARSE_SAMPLES_PER_FASTEST: f64 = 10.0;

/// The data on a grid k·Ts coarser, k = ⌊T_min / (10·Ts)⌋ (T_min the fastest time
/// constant of `model`): the outputs at every k-th instant, the inputs averaged over the
/// k instants they are held across (the zero-order hold of the coarse grid), an instant
/// known where its output row and its block's inputs are. `None` where k < 2, the outputs
/// are masked (stored by exception: no block average is the record) or the model has no
/// real time constants. Only a start: the full-rate fit follows.
fn coarse(data: &IdentificationData, model: &DiscreteModel) -> Option<IdentificationData> {
    if data.output_observed.is_some() {
        return None;
    }
    let fastest = crate::thermal::Spectrum::of(model)
        .ok()?
        .time_constants_s
        .first()
        .copied()
        .filter(|t| t.is_finite() && *t > 0.0)?;
    let k = (fastest / (COARSE_SAMPLES_PER_FASTEST * data.ts_s)).floor() as usize;
    if k < 2 {
        return None;
    }
    let rows = data.len() / k;
    let (n, m) = (data.states(), data.input_count());
    let outputs = DMatrix::from_fn(rows, n, |r, c| data.outputs[(r * k, c)]);
    let inputs = DMatrix::from_fn(rows, m, |r, c| {
        (r * k..r * k + k).map(|i| data.inputs[(i, c)]).sum::<f64>() / k as f64
    });
    let outputs_known = (0..rows).map(|r| data.outputs_known[r * k]).collect();
    let inputs_known = (0..rows)
        .map(|r| (r * k..r * k + k).all(|i| data.inputs_known[i]))
        .collect();
    Some(IdentificationData::new(
        data.ts_s * k as f64,
        outputs,
        inputs,
        outputs_known,
        inputs_known,
    ))
}

/// The start: the network of `model` (OE's), projected onto the passive set —
/// conductances and shares floored at `thermal::rc::START_FLOOR` (of the largest
/// conductance; of 1), each column of K renormalised to 1. Where the model has no
/// network, a rough one from its diagonal.
pub(crate) fn start_parts(model: &DiscreteModel, scaling: Scaling) -> Parts {
    let (n, m) = (model.phi.nrows(), model.gamma.ncols());
    let continuous = ContinuousModel::from_discrete(model).ok();
    let network = continuous.as_ref().and_then(|c| {
        Network::from_continuous(&c.a_c, &c.b_c, scaling, None, &Labels::numbered(n, m)).ok()
    });
    let parts = match network {
        Some(net) => Parts {
            capacitance_j_per_k: net.capacitance_j_per_k.clone(),
            conductance_w_per_k: DMatrix::from_fn(n, n, |i, j| net.conductance_w_per_k[i][j]),
            loss_distribution: DMatrix::from_fn(n, m, |i, j| net.loss_distribution[i][j]),
        },
        None => rough_parts(continuous.as_ref(), model, scaling),
    };
    projected(parts)
}

/// A rough network where the identified model has none: rates from A_c's diagonal (or
/// the sample time's 1000th part), shares from B_c's positive entries, equal capacitances
/// scaled so that B_c's positive part is matched on average.
fn rough_parts(
    continuous: Option<&ContinuousModel>,
    model: &DiscreteModel,
    scaling: Scaling,
) -> Parts {
    let (n, m) = (model.phi.nrows(), model.gamma.ncols());
    let w = scaling.p_base_w / scaling.theta_base_k;
    let fallback_rate = 1e-3 / model.ts_s;
    let (rates, b_plus): (Vec<f64>, DMatrix<f64>) = match continuous {
        Some(c) => (
            (0..n)
                .map(|i| (-c.a_c[(i, i)]).max(fallback_rate))
                .collect(),
            c.b_c.map(|b| b.max(0.0)),
        ),
        None => (vec![fallback_rate; n], DMatrix::from_element(n, m, 1.0)),
    };
    let total_b = b_plus.sum().max(1e-300);
    let c = w * m as f64 / total_b;
    let loss_distribution = DMatrix::from_fn(n, m, |i, j| {
        let col = b_plus.column(j).sum();
        if col > 0.0 {
            b_plus[(i, j)] / col
        } else {
            1.0 / n as f64
        }
    });
    let conductance = DMatrix::from_fn(n, n, |i, j| {
        if i == j {
            0.5 * c * rates[i]
        } else {
            0.25 * c * rates[i].min(rates[j])
        }
    });
    Parts {
        capacitance_j_per_k: vec![c; n],
        conductance_w_per_k: conductance,
        loss_distribution,
    }
}

/// The least-squares problem LM sees: parameters [p; x0 of each segment], evaluated
/// through OE's problem in [Θ; x0].
struct RcProblem<'a> {
    inner: Problem<'a>,
    map: Parametrisation,
    /// The entries of p the fit moves, increasing; the others stay pinned at their start
    /// (a conductance held at zero: [`pinned_to_coolant`]).
    free: Vec<usize>,
    /// The whole of p, pinned entries included.
    p_full: Vec<f64>,
    /// [p's free entries; x0 of each segment] (x0 only where OE estimates them).
    params: DVector<f64>,
    /// D = ∂Θ/∂p at `params`, the free entries' columns.
    d: DMatrix<f64>,
    cache: RefCell<Option<(DVector<f64>, Evaluation)>>,
    /// J at the parameters it was simulated at, without the normal equations.
    objective: RefCell<Option<(DVector<f64>, f64)>>,
    /// The lowest objective evaluated so far and its parameters: where the minimiser
    /// stops on a point the model cannot be evaluated at, the fit returns here.
    best: RefCell<Option<(f64, DVector<f64>)>>,
    /// Whether the fit still gains: it ends where it no longer does.
    stall: Stall,
    /// The other starts' fits this one runs beside, if any.
    race: Option<&'a StartRace>,
    /// How far behind the race's lowest deviance the fit was dropped, where it was.
    dropped: Cell<Option<f64>>,
    /// The pass of the fit ([`MOST_PASSES`]), from 0.
    pass: usize,
    /// Whether this pass ends where it creeps ([`Creep`]): a first pass that another,
    /// on the weights it leads to, follows.
    ends_on_creep: bool,
    /// The Gauss–Newton model's guidance over the pass's accepted points.
    creep: Creep,
    /// The coordinates the conductances and share ratios are stepped in.
    coordinates: StepCoordinates,
}

/// A change of the weighted squared error J smaller than this many noise variances σ²
/// (χ² units, σ² ≈ J/N at the minimum) over [`RC_STALL_WINDOW`] evaluations is no progress
/// the data can tell apart: a gain under 0.05 noise variances an evaluation is a walk along
/// a direction the data hardly see (a conductance or share towards zero), not a descent.
/// (The window was fifty before issue 33: a pass ran on for fifty evaluations past its
/// minimum, and the four-node machine's fits spent most of their time there.)
const NEGLIGIBLE_CHI2: f64 = 0.5;

/// rc's window of evaluations for [`NEGLIGIBLE_CHI2`]: half `oe`'s [`oe::STALL_WINDOW`], at
/// the same gain an evaluation. Every pass that does not meet the Gauss–Newton stop
/// ([`RcProblem::within_noise_of_minimum`]) ends by a window that gains nothing, so that
/// window is spent whatever the start: started from the converged nearest network, the
/// four-node machine's free fits spent 40 of each pass's 40 to 80 evaluations there (seed 5:
/// 2.6 s of the fit's 2.6 s against 0.9 s with this window, the same network to the
/// printed digit on seeds 1–5).
const RC_STALL_WINDOW: usize = 10;

/// [`NEGLIGIBLE_CHI2`] of the coarse fit that starts the full-rate one ([`coarse`]): the
/// same gain of the coarse grid's noise variances per [`RC_STALL_WINDOW`] evaluations. The coarse
/// fit is a start, kept only where it simulates the full-rate data better than its own
/// start, and the full-rate fit goes on from it; run to its minimum instead, the
/// four-node machine's coarse fits spent 1,100 of their 1,643 evaluations gaining a
/// thousandth of one noise variance each. (At 10 noise variances, the paper's model,
/// noise-free over 6,000 s, once gave a start from which the full-rate fit ended on a Φ
/// with an eigenvalue at 0.)
const COARSE_NEGLIGIBLE_CHI2: f64 = NEGLIGIBLE_CHI2;

/// The end of a walk towards a zero conductance or share: its logarithm goes towards −∞
/// with ever smaller gains, each step within LM's tolerances (which must stay tight: a
/// shrunk trust region's step would meet a looser one at a bad start). On the four-node
/// machine that walk took 1,300 of 1,900 evaluations for 7 χ² units in all; the fit
/// stops where a window of [`RC_STALL_WINDOW`] evaluations lowers the best J by less than
/// [`NEGLIGIBLE_CHI2`]·J/N.
#[derive(Debug, Clone, Default)]
struct Stall {
    /// The pass's evaluations, counted in windows.
    window: oe::StallWindow,
    /// The gain over a window, in noise variances, below which the pass ends.
    negligible_chi2: f64,
}

/// Accepted points per window over which [`Creep`] compares the gain made with the gain
/// the Gauss–Newton model predicted at the window's start.
const CREEP_WINDOW: usize = 10;

/// The share of the Gauss–Newton model's predicted gain below which a window's gain is a
/// creep ([`Creep`]).
const CREEP_SHARE: f64 = 0.05;

/// A first pass creeping along a valley: over a window of [`CREEP_WINDOW`] accepted points
/// Levenberg–Marquardt gained less than [`CREEP_SHARE`] of what the Gauss–Newton step
/// predicted at the window's start (ΔJ/σ² < 0.05·‖z‖²/σ²), so the quadratic model is no
/// guide there and each step is a sliver of the trust region. The first pass's weights are
/// its start's (the nearest network's simulation error); the second pass's, from the
/// first's residuals, change the valley: on the four-node machine, seed 13, rc's free fit
/// crept 300 evaluations in its first pass (D down by 230 with 650 predicted) and its
/// second fell by 5,000 in ten; seed 22's held fit on the coarse grid crept 605.
/// Ended there, the first pass hands its point to the second, which always follows.
#[derive(Debug, Default)]
struct Creep {
    /// Accepted points so far in the pass.
    accepted: Cell<usize>,
    /// J and the predicted gain ‖z‖²/σ² at the current window's start.
    window_start: Cell<(f64, f64)>,
    /// Whether the pass was ended by a creep.
    ended: Cell<bool>,
}

impl Creep {
    /// Counts an accepted point (`reduced` = [z; ρ], J = ‖reduced‖², of a fit over
    /// `entries` entries); true where the window that ends here crept.
    fn crept(&self, reduced: &DVector<f64>, entries: usize) -> bool {
        let objective = reduced.norm_squared();
        let (decrease, sigma2) = gauss_newton_decrease(reduced, entries);
        let sigma2 = sigma2.max(f64::MIN_POSITIVE);
        let predicted = decrease / sigma2;
        let k = self.accepted.get();
        self.accepted.set(k + 1);
        let (start_objective, start_predicted) = self.window_start.get();
        if !k.is_multiple_of(CREEP_WINDOW) {
            return false;
        }
        self.window_start.set((objective, predicted));
        let crept = k > 0 && (start_objective - objective) / sigma2 < CREEP_SHARE * start_predicted;
        self.ended.set(crept);
        crept
    }
}

/// The decrease ‖z‖² of J its Gauss–Newton step predicts at a point (`reduced` = [z; ρ],
/// the residuals' QR-reduced form, J = ‖reduced‖²) and the noise variance σ² = J/N of a
/// fit over `entries` entries.
fn gauss_newton_decrease(reduced: &DVector<f64>, entries: usize) -> (f64, f64) {
    let p = reduced.len().saturating_sub(1);
    let decrease = reduced.rows(0, p).norm_squared();
    (decrease, reduced.norm_squared() / entries.max(1) as f64)
}

impl<'a> RcProblem<'a> {
    fn new(
        inner: Problem<'a>,
        map: Parametrisation,
        start: &[f64],
        pinned: &[usize],
    ) -> RcProblem<'a> {
        let p_theta = inner.p_theta();
        let free: Vec<usize> = (0..start.len()).filter(|q| !pinned.contains(q)).collect();
        let mut params: Vec<f64> = free.iter().map(|&q| start[q]).collect();
        params.extend(inner.params.iter().skip(p_theta).copied());
        let mut problem = RcProblem {
            d: DMatrix::zeros(0, 0),
            inner,
            map,
            free,
            p_full: start.to_vec(),
            params: DVector::from_vec(params),
            cache: RefCell::new(None),
            objective: RefCell::new(None),
            best: RefCell::new(None),
            stall: Stall::default(),
            race: None,
            dropped: Cell::new(None),
            coordinates: StepCoordinates::Logarithms,
            pass: 0,
            ends_on_creep: false,
            creep: Creep::default(),
        };
        let params = problem.params.clone();
        problem.set_p(&params);
        problem
    }

    fn p(&self) -> &[f64] {
        &self.p_full
    }

    /// The parts whose conductance to the coolant the fit holds ([`pinned_at_zero`]).
    fn held_parts(&self, n: usize) -> impl Iterator<Item = usize> + '_ {
        (0..n).filter(move |i| !self.free.contains(&(n + i)))
    }

    /// The network at p, a conductance to the coolant the fit holds at 0: what the data
    /// say of it is that heat does not leave there.
    fn reported_parts(&self, p: &[f64]) -> Parts {
        let mut parts = self.map.parts(p);
        let n = parts.capacitance_j_per_k.len();
        for i in self.held_parts(n) {
            parts.conductance_w_per_k[(i, i)] = 0.0;
        }
        parts
    }

    /// The 95 % intervals at p, none for a held conductance (it is not estimated).
    fn reported_intervals(&self, p: &[f64], cov_p: &DMatrix<f64>) -> NetworkIntervals {
        let mut intervals = self.map.intervals(p, cov_p);
        let n = intervals.capacitance_j_per_k.len();
        for i in self.held_parts(n) {
            intervals.conductance_w_per_k[i][i] = None;
        }
        intervals
    }

    /// OE's evaluation in [Θ; x0] carried to [p; x0] by T = diag(D, I).
    fn evaluate(&self) -> Evaluation {
        let e = self.inner.normal_equations();
        let (pt, pp) = (self.inner.p_theta(), self.free.len());
        let rest = e.gram.nrows() - pt;
        let d = &self.d;
        let cols = pp + rest;
        let mut gram = DMatrix::zeros(cols, cols);
        let g_tt = e.gram.view((0, 0), (pt, pt));
        gram.view_mut((0, 0), (pp, pp))
            .copy_from(&(d.transpose() * g_tt * d));
        if rest > 0 {
            let g_tx = d.transpose() * e.gram.view((0, pt), (pt, rest));
            gram.view_mut((0, pp), (pp, rest)).copy_from(&g_tx);
            gram.view_mut((pp, 0), (rest, pp))
                .copy_from(&g_tx.transpose());
            gram.view_mut((pp, pp), (rest, rest))
                .copy_from(&e.gram.view((pt, pt), (rest, rest)));
        }
        let mut grad = DVector::zeros(cols);
        grad.rows_mut(0, pp)
            .copy_from(&(d.transpose() * e.grad.rows(0, pt)));
        grad.rows_mut(pp, rest).copy_from(&e.grad.rows(pt, rest));
        Evaluation {
            sse: e.sse,
            gram,
            grad,
        }
    }

    /// Sets [p's free entries; x0] from `x` (p as laid out, logarithms), within
    /// e^±LOG_RANGE of the start, and D = ∂Θ/∂p there.
    fn set_p(&mut self, x: &DVector<f64>) {
        self.params.copy_from(x);
        let pp = self.free.len();
        // Logarithms within e^±LOG_RANGE of the start: the exponentials stay finite.
        for (k, &q) in self.free.iter().enumerate() {
            let s = self.map.start[q];
            self.params[k] = self.params[k].clamp(s - LOG_RANGE, s + LOG_RANGE);
            self.p_full[q] = self.params[k];
        }
        let x = &self.params.clone();
        let theta = self.map.model(&self.p_full).theta();
        let pt = self.inner.p_theta();
        for (q, t) in theta.iter().enumerate() {
            self.inner.params[q] = *t;
        }
        for q in pp..x.len() {
            self.inner.params[pt + q - pp] = x[q];
        }
        self.d = self
            .map
            .theta_jacobian(&self.p_full)
            .select_columns(&self.free);
    }

    fn evaluated(&self) -> std::cell::Ref<'_, Evaluation> {
        oe::cached(&self.cache, &self.params, || self.evaluate())
    }

    /// Drops the evaluations kept: the weights they were made at have changed.
    fn forget_evaluations(&self) {
        *self.cache.borrow_mut() = None;
        *self.objective.borrow_mut() = None;
    }

    /// The residuals at the current parameters in the form [0; …; 0; √J]
    /// ([`Evaluation::residual_last_form`]), from a simulation without sensitivities;
    /// `None` where the model cannot be evaluated there (an exponential out of range).
    fn residuals_here(&self) -> Option<DVector<f64>> {
        if !self.params.iter().all(|v| v.is_finite()) {
            return None;
        }
        let objective = oe::cached(&self.objective, &self.params, || {
            self.inner.evaluate_objective().iter().sum::<f64>()
        });
        let objective = *objective;
        if !(objective.is_finite() && objective >= 0.0) {
            return None;
        }
        let mut r = DVector::zeros(self.params.len() + 1);
        r[self.params.len()] = objective.sqrt();
        Some(r)
    }

    /// Residuals far above the best so far, for a trial point the model cannot be
    /// evaluated at: LM rejects the step and shrinks its trust region, where `None`
    /// would end the fit there (seeds 1, 3 and 5 of the four-node machine ended on their
    /// third evaluation, 86 % off in a time constant). `None` before any good point.
    fn rejected(&self) -> Option<DVector<f64>> {
        let best = self.best.borrow().as_ref().map(|(b, _)| *b)?;
        let rows = self.params.len() + 1;
        Some(DVector::from_element(
            rows,
            (1e6 * best / rows as f64).sqrt(),
        ))
    }

    /// Counts one evaluation with the best J so far, `lowest`; true where the window
    /// that ends here lowered it by less than [`NEGLIGIBLE_CHI2`]·J/N ([`Stall`]).
    fn stalled_at(&self, lowest: f64) -> bool {
        let entries: usize = self.inner.counts.iter().sum();
        self.stall.window.counted_in(
            lowest,
            entries,
            (self.stall.negligible_chi2, RC_STALL_WINDOW),
        )
    }

    /// Whether the Gauss–Newton step from here would lower J by less than
    /// [`SETTLED_STANDARD_ERRORS`]² noise variances: with `reduced` = [z; ρ] the residuals
    /// in square-root form ([`Evaluation::square_root_form`]), that decrease is
    /// ‖z‖² = rᵀJ(JᵀJ)⁻¹Jᵀr = δᵀ(JᵀJ)δ for the step δ to the local minimum, and
    /// ‖z‖²/σ² (σ² = J/N, the weighted noise variance) is δ's squared length in the
    /// parameters' standard errors. Below 0.1², the minimum is nearer than a tenth of a
    /// standard error in every direction: a step the data cannot tell from none. This
    /// rule, not LM's relative tolerances (10⁻¹⁰ of J, a 10⁻⁵th of one noise variance on
    /// a 6 h run), ends a pass at its minimum: a pass ran on for [`RC_STALL_WINDOW`]
    /// evaluations there before.
    fn within_noise_of_minimum(&self, reduced: &DVector<f64>) -> bool {
        let (decrease, sigma2) = gauss_newton_decrease(reduced, self.entries());
        decrease < SETTLED_STANDARD_ERRORS.powi(2) * sigma2
    }

    /// Fits the start states and output offsets, which the outputs are linear in, to the
    /// network as it stands, by one Gauss–Newton step in them alone (their least-squares
    /// fit: a fit's own are not kept beside its network); the evaluation there. `None`
    /// where their normal equations cannot be factorised.
    fn fit_linear_parameters(&mut self) -> Option<Evaluation> {
        let evaluation = self.evaluate();
        let linear: Vec<usize> = (self.free.len()..evaluation.grad.len()).collect();
        if linear.is_empty() {
            return Some(evaluation);
        }
        let (_, step) = score::gain_and_step(&evaluation.gram, &evaluation.grad, &linear)?;
        let mut params = self.params.clone();
        for (k, d) in linear.iter().zip(step.iter()) {
            params[*k] += d;
        }
        self.set_p(&params);
        Some(self.evaluate())
    }

    /// The entries the fit compares.
    fn entries(&self) -> usize {
        self.inner.counts.iter().sum()
    }

    /// Tells the race, if any, this accepted point's deviance and what its Gauss–Newton
    /// step predicts it can still gain (‖z‖²/σ², `reduced` = [z; ρ]); the gap to the
    /// lowest deviance where the fit is too far behind to go on ([`StartRace`]).
    fn behind_in_race(&self, evaluation: &Evaluation, reduced: &DVector<f64>) -> Option<f64> {
        let race = self.race?;
        let (decrease, sigma2) = gauss_newton_decrease(reduced, self.entries());
        let standing = Standing {
            deviance: race::deviance(
                &evaluation.sse,
                &self.inner.counts,
                &self.inner.sqrt_w,
                race.floor(),
            ),
            predicted_gain: decrease / sigma2.max(f64::MIN_POSITIVE),
            parameters: self.free.len(),
        };
        // Published from the first point on, but a fit is dropped only from its second
        // pass, at the minimum of its first: far from a minimum the Gauss–Newton step
        // predicts less than the fit goes on to gain (dropped in its first pass, the
        // start that ends lowest was given up on the four-node machine, seed 3).
        let gap = race.behind(&standing)?;
        (self.pass >= 1).then_some(gap)
    }

    /// Whether every network parameter moved less than [`SETTLED_STANDARD_ERRORS`] of its
    /// standard error from `previous`, the standard error the fit reports: σ²(JᵀWJ)⁻¹ at
    /// the current parameters with the second pass's capped weights `reported_sqrt_w`.
    ///
    /// Why not at the raised weights: an output read almost without noise leaves residuals
    /// of 10⁻⁶ K that are no white noise (the stator winding's noisy temperature enters
    /// the armature copper loss it is driven by; the truth itself reproduces the four-node
    /// machine's field winding only within 7·10⁻⁶ K RMS): weighted by their own 1/σ̂² they
    /// would give intervals of ±0.5 % that miss the truth by 2.6 % (seed 2's cooling
    /// water). The capped weights take that output as a tenth of the median output's
    /// noise, as the fit's intervals always have.
    fn settled_since(&mut self, previous: &DVector<f64>, reported_sqrt_w: &[f64]) -> bool {
        let kept = std::mem::replace(&mut self.inner.sqrt_w, reported_sqrt_w.to_vec());
        self.forget_evaluations();
        let (cov, _) = self.covariance(&self.evaluate());
        self.inner.sqrt_w = kept;
        self.forget_evaluations();
        (0..self.free.len()).all(|q| {
            let moved = (self.params[q] - previous[q]).abs();
            moved <= SETTLED_STANDARD_ERRORS * cov[(q, q)].max(0.0).sqrt()
        })
    }

    /// σ²(JᵀWJ)⁻¹ of [free p; x0] at `evaluation` (σ² the weighted residuals' sum of
    /// squares over the degrees of freedom), and the condition number of the scaled J.
    fn covariance(&self, evaluation: &Evaluation) -> (DMatrix<f64>, f64) {
        let entries: usize = self.inner.counts.iter().sum();
        let dof = entries.saturating_sub(self.params.len()).max(1) as f64;
        let sigma2 = evaluation.sse.iter().sum::<f64>() / dof;
        oe::covariance_from_gram(&evaluation.gram, sigma2)
    }

    /// The estimate at the minimum, with the network and its intervals.
    fn conclude(
        &self,
        method: Method,
        rows_used: usize,
        evaluations: usize,
        start_model: DiscreteModel,
    ) -> Estimate {
        let n = self.inner.n;
        let evaluation = self.evaluate();
        let (full, condition_number) = self.covariance(&evaluation);
        let pp = self.free.len();
        let cov_free = full.view((0, 0), (pp, pp)).into_owned();
        let theta_cov = &self.d * &cov_free * self.d.transpose();
        // A pinned entry is no estimate: no variance, no covariance.
        let mut cov_p = DMatrix::zeros(self.map.len(), self.map.len());
        for (a, &qa) in self.free.iter().enumerate() {
            for (b, &qb) in self.free.iter().enumerate() {
                cov_p[(qa, qb)] = cov_free[(a, b)];
            }
        }
        let noise_variance: Vec<f64> = (0..n)
            .map(|c| {
                let w = self.inner.sqrt_w[c].powi(2).max(1e-300);
                evaluation.sse[c] / self.inner.counts[c].max(1) as f64 / w
            })
            .collect();
        let p = self.p();
        let start_estimate = Estimate {
            model: start_model,
            // OE's, once [`Estimator::estimate`] puts its estimate here.
            method: Method::Oe,
            rows_used,
            condition_number: f64::NAN,
            covariance: None,
            robust_covariance: None,
            noise_variance: Vec::new(),
            iterations: 0,
            output_offset: None,
            trajectory: None,
            network: None,
            predictor: None,
        };
        Estimate {
            model: self.map.model(p),
            method,
            rows_used,
            condition_number,
            covariance: Some(theta_cov),
            robust_covariance: None,
            noise_variance,
            iterations: evaluations,
            output_offset: self.inner.output_offset(),
            trajectory: None,
            network: Some(Box::new(NetworkEstimate {
                parts: self.reported_parts(p),
                scaling: self.map.scaling,
                intervals: self.reported_intervals(p, &cov_p),
                covariance: cov_p,
                output_error: Box::new(start_estimate),
            })),
            predictor: None,
        }
    }
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for RcProblem<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    /// Sets [p's free entries; x0] from `x` in the fit's step coordinates
    /// ([`Parametrisation::step_coordinate`] where they are [`StepCoordinates::Themselves`]).
    fn set_params(&mut self, x: &DVector<f64>) {
        if self.coordinates == StepCoordinates::Logarithms {
            return self.set_p(x);
        }
        let mut p = x.clone();
        for (k, &q) in self.free.iter().enumerate() {
            p[k] = self.map.param_of_step_coordinate(q, x[k]);
        }
        self.set_p(&p);
    }

    /// [p's free entries; x0] in the fit's step coordinates.
    fn params(&self) -> DVector<f64> {
        let mut y = self.params.clone();
        if self.coordinates == StepCoordinates::Logarithms {
            return y;
        }
        for (k, &q) in self.free.iter().enumerate() {
            y[k] = self.map.step_coordinate(q, self.params[k]);
        }
        y
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        if self.race.is_some_and(StartRace::is_called_off) {
            // No residuals: LM stops here, and the fit reports itself called off.
            return None;
        }
        let Some(r) = self.residuals_here() else {
            return self.rejected();
        };
        let objective = r.norm_squared();
        let mut best = self.best.borrow_mut();
        if best.as_ref().is_none_or(|(b, _)| objective < *b) {
            *best = Some((objective, self.params.clone()));
        }
        let lowest = best.as_ref().map_or(objective, |(b, _)| *b);
        drop(best);
        if self.stalled_at(lowest) {
            // No residuals: LM stops here ([`Stall`]); the fit takes the best point.
            return None;
        }
        Some(r)
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        if self.race.is_some_and(StartRace::is_called_off) {
            return None;
        }
        let evaluation = self.evaluated();
        let mut j = evaluation.residual_last_form()?;
        if !j.iter().all(|v| v.is_finite()) {
            return None;
        }
        // In the step coordinates ([`Parametrisation::step_coordinate`]); an entry at zero
        // whose gradient still points down is held there (its column zero): the step
        // does not spend its length on a move the floor undoes.
        let themselves = self.coordinates == StepCoordinates::Themselves;
        for (k, &q) in self.free.iter().enumerate().filter(|_| themselves) {
            let p_q = self.params[k];
            let held = self.map.at_floor(q, p_q) && evaluation.grad[k] > 0.0;
            let scale = if held {
                0.0
            } else {
                self.map.step_coordinate_scale(q, p_q)
            };
            j.column_mut(k).scale_mut(scale);
        }
        // The Gauss–Newton step's predicted decrease, where JᵀJ is definite.
        if let Some((r, _)) = evaluation.square_root_form() {
            if self.within_noise_of_minimum(&r) {
                // No Jacobian: LM stops here, at the point it just accepted ([`Stall`]).
                self.stall.window.stalled.set(true);
                return None;
            }
            if self.ends_on_creep && self.creep.crept(&r, self.entries()) {
                // No Jacobian: LM stops here; the next pass goes on from this point.
                self.stall.window.stalled.set(true);
                return None;
            }
            if let Some(gap) = self.behind_in_race(&evaluation, &r) {
                // No Jacobian: LM stops, and the fit reports the start dropped.
                self.dropped.set(Some(gap));
                return None;
            }
        }
        Some(j)
    }
}

#[cfg(test)]
mod tests;
