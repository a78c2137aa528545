//! The order of a hidden-state model, chosen on the estimation data alone, and the
//! identification as a whole: subspace start, output-error refinement.
//!
//! Each candidate order n is identified on the first part of the estimation data and
//! simulated over its held-back tail (each segment from the initial state fitted to its
//! own observed outputs, as [`HiddenStateModel::simulate_segments`] does everywhere); the
//! order with the best mean NRMSE fit there is chosen, and the model re-identified at
//! that order on all the estimation data. The candidates' Akaike criterion on the first
//! part, AIC = N_y ln(2J/N_y) + 2 P, is given beside it, for the record.

use serde::Serialize;

use super::refine::{refine, Refined};
use super::subspace::{decompose, horizon_for};
use super::{HiddenError, HiddenStateModel, OutputMatrix};
use crate::estimate::IdentificationData;
use crate::model::fit::fit;
use crate::model::Fit;

/// The model order: given, or chosen on the data among 1 ..= `largest`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum OrderChoice {
    /// This many states.
    Given(usize),
    /// The best of 1 ..= `largest` states (at least the outputs' number where C = [I 0]).
    Chosen {
        /// The largest order tried.
        largest: usize,
    },
}

/// How to identify a hidden-state model.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct HiddenOptions {
    /// The order, or how to choose it.
    pub order: OrderChoice,
    /// Whether C is estimated or fixed to [I 0].
    pub output_matrix: OutputMatrix,
    /// Whether D is estimated (an input acting within the sample) or zero.
    pub feedthrough: bool,
    /// Fraction (0, 1) of the estimation data held back to choose the order on.
    pub hold_back: f64,
}

impl Default for HiddenOptions {
    fn default() -> Self {
        HiddenOptions {
            order: OrderChoice::Chosen { largest: 8 },
            output_matrix: OutputMatrix::Measured,
            feedthrough: false,
            hold_back: 0.2,
        }
    }
}

/// One order tried.
#[derive(Debug, Clone, Serialize)]
pub struct OrderCandidate {
    /// The order n.
    pub order: usize,
    /// Mean NRMSE fit (%) on the held-back tail of the estimation data, where identified.
    pub hold_back_fit_percent: Option<f64>,
    /// AIC on the first part of the estimation data.
    pub aic: Option<f64>,
    /// Why the order gave no model, where it did not.
    pub refused: Option<String>,
}

/// A hidden-state model identified from data, with how its order was chosen.
#[derive(Debug, Clone, Serialize)]
pub struct HiddenEstimate {
    /// The model.
    pub model: HiddenStateModel,
    /// Singular values of the subspace step on all the estimation data, descending.
    pub singular_values: Vec<f64>,
    /// The orders tried (empty where the order was given).
    pub candidates: Vec<OrderCandidate>,
    /// The options it was identified with.
    pub options: HiddenOptions,
    /// LM's cost evaluations in the final refinement.
    pub evaluations: usize,
}

/// Subspace start and output-error refinement at one order.
fn at_order(
    data: &IdentificationData,
    order: usize,
    options: &HiddenOptions,
    largest: usize,
) -> Result<(Refined, Vec<f64>), HiddenError> {
    let sub = decompose(data, horizon_for(largest, data.states()))?;
    let start = sub.model(data, order, options.feedthrough, options.output_matrix)?;
    let refined = refine(data, &start, options.output_matrix, options.feedthrough)?;
    Ok((refined, sub.singular_values))
}

/// The fit of `model` over `data`, each segment from its fitted x0
/// ([`HiddenStateModel::simulate_segments`]); errors in the data's units.
pub fn fit_of(model: &HiddenStateModel, data: &IdentificationData) -> Fit {
    compare(data, &model.simulate_segments(data))
}

/// The fit of a simulation (N × p, NaN where absent) to `data`'s observed outputs.
pub fn compare(data: &IdentificationData, simulated: &nalgebra::DMatrix<f64>) -> Fit {
    fit(data, simulated, 1.0)
}

/// Mean over the outputs of the NRMSE fit (%) of `model` over `data`.
pub fn mean_fit_percent(model: &HiddenStateModel, data: &IdentificationData) -> f64 {
    let f = fit_of(model, data);
    f.nrmse_fit_percent.iter().sum::<f64>() / f.nrmse_fit_percent.len().max(1) as f64
}

/// Identifies a hidden-state model from `data` (its estimation part only).
pub fn identify(
    data: &IdentificationData,
    options: &HiddenOptions,
) -> Result<HiddenEstimate, HiddenError> {
    let p = data.states();
    let smallest = match options.output_matrix {
        OutputMatrix::Measured => p,
        OutputMatrix::Free => 1,
    };
    let (order, largest, candidates) = match options.order {
        OrderChoice::Given(n) => (n, n, Vec::new()),
        OrderChoice::Chosen { largest } => {
            let split = ((1.0 - options.hold_back) * data.len() as f64).round() as usize;
            let (first, tail) = (data.slice(0..split), data.slice(split..data.len()));
            let candidates: Vec<OrderCandidate> = (smallest..=largest)
                .map(|n| candidate(&first, &tail, n, options, largest))
                .collect();
            let best = candidates
                .iter()
                .filter_map(|c| c.hold_back_fit_percent.map(|f| (c.order, f)))
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(n, _)| n);
            match best {
                Some(n) => (n, largest, candidates),
                None => {
                    return Err(HiddenError::NoOrder {
                        reason: candidates
                            .first()
                            .and_then(|c| c.refused.clone())
                            .unwrap_or_default(),
                    })
                }
            }
        }
    };
    let (refined, singular_values) = at_order(data, order, options, largest)?;
    Ok(HiddenEstimate {
        model: refined.model,
        singular_values,
        candidates,
        options: *options,
        evaluations: refined.evaluations,
    })
}

/// One candidate order's figures.
fn candidate(
    first: &IdentificationData,
    tail: &IdentificationData,
    order: usize,
    options: &HiddenOptions,
    largest: usize,
) -> OrderCandidate {
    match at_order(first, order, options, largest) {
        Ok((refined, _)) => {
            let n_y = refined.compared as f64;
            OrderCandidate {
                order,
                hold_back_fit_percent: Some(mean_fit_percent(&refined.model, tail)),
                aic: Some(n_y * (refined.weighted_sse / n_y).ln() + 2.0 * refined.parameters as f64),
                refused: None,
            }
        }
        Err(e) => OrderCandidate {
            order,
            hold_back_fit_percent: None,
            aic: None,
            refused: Some(e.to_string()),
        },
    }
}
