//! Model analysis stage: an estimated discrete model → its continuous form,
//! spectrum and time constants, simulated response and fit, output sensitivities
//! and time-constant assignment, and steady state.
//!
//! Input: an [`Estimate`] and the [`IdentificationData`] it came from. Output: a
//! [`ModelAnalysis`].

pub(crate) mod fit;
pub mod residuals;
pub mod sensitivity;
mod uncertainty;

use std::borrow::Cow;
use std::ops::Range;

use nalgebra::DMatrix;
use serde::Serialize;

pub use crate::thermal::matrix;
pub use crate::thermal::{ContinuousModel, ModelError, Spectrum};
pub use fit::Fit;
pub use residuals::ResidualAnalysis;
pub use sensitivity::{Assignment, Sensitivities, SensitivityResponses};
pub use uncertainty::{propagate, Uncertainty};

use crate::estimate::{DiscreteModel, Estimate, IdentificationData};

/// Everything the analysis derives from one estimate.
#[derive(Debug, Clone, Serialize)]
pub struct ModelAnalysis {
    /// A_c and B_c.
    pub continuous: ContinuousModel,
    /// Eigenvalues and time constants.
    pub spectrum: Spectrum,
    /// Simulated outputs ŷ (eq. 8) over the data analysed, N × n, NaN outside the
    /// simulated segments.
    #[serde(skip)]
    pub simulated: DMatrix<f64>,
    /// Fit of ŷ to y.
    pub fit: Fit,
    /// Sensitivities of ŷ to the time constants: their norms, and the responses over
    /// the estimation range (instants of `data`) that the plots draw.
    pub sensitivities: Sensitivities,
    /// Each time constant's state.
    pub assignment: Vec<Assignment>,
    /// The constant input the steady state is computed for (pu).
    pub steady_state_input: Vec<f64>,
    /// Steady-state outputs −A_c⁻¹ B_c u (pu).
    pub steady_state: Vec<f64>,
    /// 95 % intervals of the time constants and the steady state, where the method
    /// gives a covariance.
    pub uncertainty: Option<Uncertainty>,
    /// Whiteness of the residuals and their correlation with the inputs.
    pub residuals: ResidualAnalysis,
    /// The same analysis of the innovations y(k) − ŷ(k|k−1) of the one-step predictor,
    /// where the method estimated one (`pem`): what it leaves unexplained, which is white
    /// where the predictor is right even when the simulation's residuals are not.
    pub innovations: Option<ResidualAnalysis>,
}

/// Largest lag of the residual correlations.
pub const RESIDUAL_MAX_LAG: usize = 60;

/// Analyses an estimate against its data; `estimation_range` is the part of `data` the
/// estimate came from (the fit, sensitivities and residuals describe it), while the
/// simulated output covers all of `data`, held-out instants included. `steady_state_input`
/// is the input (normally the last measured one, eq. 30) whose steady state is wanted.
/// `continuous` is the model's continuous form where the caller has already made it
/// (for that input): it is made here otherwise.
pub fn analyse(
    estimate: &Estimate,
    continuous: Option<ContinuousModel>,
    data: &IdentificationData,
    estimation_range: Range<usize>,
    temperature_base_k: f64,
    steady_state_input: &[f64],
) -> Result<ModelAnalysis, ModelError> {
    let model = &estimate.model;
    let spectrum = Spectrum::of(model)?;
    let continuous = match continuous {
        Some(c) => c,
        None => ContinuousModel::from_discrete(model)?,
    };
    let mut simulated = fit::simulate(model, data, &data.segments());
    // ŷ = x + d where the method estimated an output offset d (rc: the error of the
    // first samples the rises are measured from); NaN rows stay NaN.
    if let Some(offset) = &estimate.output_offset {
        crate::estimate::add_output_offset(&mut simulated, offset);
    }
    let whole = estimation_range == (0..data.len());
    // Simulation is causal: the rows of the estimation range are the simulation of that
    // range alone. A week's data are not copied unless a part is held out.
    let (estimation, estimation_sim) = if whole {
        (Cow::Borrowed(data), Cow::Borrowed(&simulated))
    } else {
        (
            Cow::Owned(data.slice(estimation_range.clone())),
            Cow::Owned(
                simulated
                    .rows(estimation_range.start, estimation_range.len())
                    .into_owned(),
            ),
        )
    };
    let fit = fit::fit(&estimation, &estimation_sim, temperature_base_k);
    let mut sensitivities = sensitivity::sensitivities(
        &continuous,
        &spectrum.time_constants_s,
        model.ts_s,
        &estimation,
        &estimation.segments(),
    )?;
    sensitivities.responses.shift(estimation_range.start);
    let assignment = sensitivity::assign(&sensitivities);
    let steady_state = continuous.steady_state(steady_state_input)?;
    let uncertainty = uncertainty::propagate(estimate, steady_state_input);
    // Where the method estimated an output offset (y = x + d), the reported simulation
    // carries it from the first instant and is the model's own error already.
    let residuals = match &estimate.output_offset {
        None => own_residuals(model, &estimation, &estimation_sim),
        Some(_) => residuals::analyse(&estimation, &estimation_sim, RESIDUAL_MAX_LAG),
    };
    let innovations = estimate.predictor.as_ref().map(|p| {
        let predicted = p.predict(model, &estimation);
        residuals::analyse(&estimation, &predicted, RESIDUAL_MAX_LAG)
    });
    drop((estimation, estimation_sim));
    Ok(ModelAnalysis {
        continuous,
        spectrum,
        simulated,
        fit,
        sensitivities,
        assignment,
        steady_state_input: steady_state_input.to_vec(),
        steady_state,
        uncertainty,
        residuals,
        innovations,
    })
}

/// The residual analysis of the model's own error: the simulation from each segment's
/// initial state that best fits it ([`DiscreteModel::best_initial_state`], as `oe` fits
/// its own). The reported simulation starts from the measured temperatures, as the
/// paper's fit does; their first sample's noise decays through the slow modes, so its
/// residuals correlate at every lag on any noisy run (the paper's noisy run: every lag of
/// the winding's and the core's outside the band, where the model's own error has none).
fn own_residuals(
    model: &DiscreteModel,
    estimation: &IdentificationData,
    simulated: &DMatrix<f64>,
) -> residuals::ResidualAnalysis {
    let correction = model.start_correction(estimation, &estimation.segments());
    residuals::analyse_from_best_start(estimation, simulated, &correction, RESIDUAL_MAX_LAG)
}
